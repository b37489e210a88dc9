"""A badly scaled multi-loop mechanism: millimetres, grams and a stiff spring.

The Stephenson six-bar of `models.stephenson_mm` (two loops sharing one pin, links of 10–45 mm,
masses of 2–5 g, a 5 kN/m spring oscillating near 1 kHz, accelerations near 1e5 rad/s²) against
an independently written CasADi model of the same mechanism in its one free coordinate (the
crank angle θ): the dependent links follow from closed-form circle intersections and the motion
from Lagrange's equation M(θ) θ̈ + ½ M'(θ) θ̇² + V'(θ) = 0, integrated with CVODES.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from mechnet.components import multibody as mb

from models import stephenson_mm, stephenson_mm_by_hand

MM = 1e-3
N_OUT = 201


def run_hand_written(rtol, atol, grid, c):
    x, rate, energy = stephenson_mm_by_hand(c=c)
    F = ca.integrator("F", "cvodes", {"x": x, "ode": rate}, 0.0, grid[1:],
                      {"reltol": rtol, "abstol": atol, "max_num_steps": 100_000})
    out = np.array(F(x0=[1.0, 0.0])["xf"])
    th, w = np.concatenate([[1.0], out[0]]), np.concatenate([[0.0], out[1]])
    E = np.array([float(energy(a, b)) for a, b in zip(th, w)])
    return th, float(np.max(np.abs(E - E[0])))


@pytest.mark.parametrize("c, t_end, pin_force", [(5e3, 0.02, 1.0), (5e6, 0.002, 5e3)], ids=["5kN/m", "5MN/m"])
def test_millimetre_six_bar_error_falls_as_the_tolerance_tightens(c, t_end, pin_force):
    # Released at rest with the spring c stretched 2 mm, at rtol 1e-6, 1e-8, 1e-10 with
    # atol = rtol/100 (angles are O(1) rad). 5 kN/m: 20 ms, about 1.5 swings of the crank between 1.0 and
    # 0.16 rad, pin forces about 10 N. 5 MN/m: 2 ms, spring energy E0 = 10 J, pin forces up to 6.6e3 N
    # (the multipliers of a hand-written model would be as large), accelerations ~1e7 rad/s².
    # Reference: the hand-written model at rtol 1e-13, atol 1e-15. Pass criteria at each tolerance:
    # the run succeeds; some pin force exceeds `pin_force` (the scale is what it claims); every pin
    # closes within 10·(rtol·L + atol), L = 45 mm; the energy drift is within 3× the hand-written
    # model's at the same settings (5 kN/m, E0 = 13.6 mJ: measured 1.4e-6, 1.2e-8, 1.2e-10 J against
    # 5.8e-7, 1.1e-8, 3.3e-10 J; 5 MN/m: 1.1e-3, 2.3e-5, 3.4e-7 J against 2.1e-3, 2.6e-5, 8.2e-7 J).
    # Across tolerances: the crank-angle error against the reference falls at least tenfold per step
    # (measured 2.6e-5, 2.2e-7, 2.3e-9 rad and 3.5e-5, 4.9e-7, 1.1e-8 rad). Before the refined
    # symbolic solve (tearing.refined_solve) the accelerations carried 1e-6 relative noise and
    # rtol 1e-10 needed 40 000 steps over 20 ms.
    grid = np.linspace(0.0, t_end, N_OUT)
    reference, _ = run_hand_written(1e-13, 1e-15, grid, c)
    model = stephenson_mm(c=c)
    model.add(mb.SystemEnergy(name="energy"))
    cm = model.compile()
    pins = [c.path for c in model.components() if isinstance(c, mb.Revolute)]
    errors = []
    for rtol in (1e-6, 1e-8, 1e-10):
        atol = rtol / 100
        res = cm.simulate(t_end, rtol=rtol, atol=atol, n_out=N_OUT)
        assert res.success, res.failure
        gap = max(np.max(np.abs(res[f"{p}.frame_a.r_0[{i}]"] - res[f"{p}.frame_b.r_0[{i}]"]))
                  for p in pins for i in range(3))
        assert gap <= 10 * (rtol * 45 * MM + atol), (rtol, gap)
        E = res["energy.total"]
        _, drift_hand = run_hand_written(rtol, atol, grid, c)
        assert max(np.max(np.abs(res[f"{p}.frame_a.f[{i}]"])) for p in pins for i in range(2)) > pin_force
        assert np.max(np.abs(E - E[0])) <= 3 * drift_hand, (rtol, np.max(np.abs(E - E[0])), drift_hand)
        errors.append(np.max(np.abs(res["pin_O0.phi"] - reference)))
    assert errors[1] < errors[0] / 10 and errors[2] < errors[1] / 10, errors
