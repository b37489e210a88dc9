"""A failed integrator call keeps the solution it reached (`solvers.call`: CasADi writes each output
time's column into the caller's buffer as the solver passes it)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from mechnet.simulate.solvers import SolverFailure, call


@pytest.mark.parametrize("plugin", ["cvodes", "idas"])
def test_a_failed_call_keeps_the_outputs_it_reached(plugin):
    # x' = x², x(0) = 1: x = 1/(1 − t) blows up at t = 1. Outputs every 0.1 s to 2 s, rtol = atol = 1e-8:
    # the solver fails just past t = 0.9 (step budget 500); the outputs before agree with 1/(1 − t) to
    # 1e-5 relative (scale x ≤ 10: 100·(rtol·x + atol) per unit of x), those after are NaN.
    x = ca.SX.sym("x")
    times = np.linspace(0.1, 2.0, 20)
    F = ca.integrator("F", plugin, {"x": x, "ode": x ** 2}, 0.0, list(times),
                      {"reltol": 1e-8, "abstol": 1e-8, "max_num_steps": 500})
    with pytest.raises(SolverFailure) as failed:
        call(F, np.array([1.0]), np.zeros(0), np.zeros(0))
    reached = failed.value.outputs["xf"][0]
    done = np.isfinite(reached)
    assert done.sum() == 9 and np.all(done[:9])
    assert np.allclose(reached[:9], 1 / (1 - times[:9]), rtol=1e-5, atol=0)
    assert 0.9 <= failed.value.stats["tcur"] < 1.0


def test_successful_call_returns_the_buffers_statistics():
    # x' = −x over 1 s at rtol 1e-10: x(1) = e^-1 to 1e-8; the statistics are the call's own (steps > 0)
    x = ca.SX.sym("x")
    F = ca.integrator("F", "cvodes", {"x": x, "ode": -x}, 0.0, [0.5, 1.0], {"reltol": 1e-10, "abstol": 1e-10})
    stats, out = call(F, np.array([1.0]), np.zeros(0), np.zeros(0))
    assert out["xf"].shape == (1, 2) and abs(out["xf"][0, -1] - np.exp(-1.0)) < 1e-8
    assert stats["nsteps"] > 0 and stats["tcur"] == pytest.approx(1.0)
