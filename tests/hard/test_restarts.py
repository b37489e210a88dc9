"""Restarts of IDAS on a fast machine: every integrator call starts with IDAS's search for consistent
initial values, and its line search failed (IDA_LINESEARCH_FAIL) on points already consistent to Newton
accuracy when CasADi gave it the call's *last* output time as its time scale (`solvers.FIRST_TIME_SHARE`).

Scene: the slider-crank of `tests/models.py` (r = 0.1 m, l = 0.35 m) driven by a Speed source at 3000 rpm,
20 s (1000 turns), rtol = atol = 1e-6, 2001 output points: the calls restart every ~0.8 s (the whole-turn
limit). Before, the run stopped at t = 15.6 s (14 restarts failed, the last one for good). Pass criterion:
the run completes and the piston stays within 10·(rtol·(r + l) + atol) of x = r cos θ + √(l² − r² sin² θ)
at the simulated crank angle, scale r + l.
"""
from __future__ import annotations

import numpy as np

from mechnet.components import rotational as rot
from mechnet.components.signals import Constant
from models import slider_crank, slider_crank_x

R, L = 0.1, 0.35
W = 3000 * 2 * np.pi / 60


def test_a_thousand_turns_restart_without_losing_the_run():
    rtol = atol = 1e-6
    cm = slider_crank(R, L, theta0=0.0, crank_drive=rot.Speed(name="motor", w_ref=Constant(W), phi_start=0.0)).compile()
    res = cm.simulate(20.0, rtol=rtol, atol=atol, n_out=2001, progress=False)
    assert res.success, res.failure
    theta = res["joint_a.phi"]
    gap = np.max(np.abs(res["slider.s"] - slider_crank_x(R, L, theta)))
    assert gap <= 10 * (rtol * (R + L) + atol), gap
