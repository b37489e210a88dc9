"""A failed integrator call keeps the solution it reached (`solvers.call`), and a monitored piece whose
solver gave up past a due switch is cut at the switch from that part (`pieces._switch_in_partial`)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.special import ellipk

from mechnet.simulate import pieces
from mechnet.simulate.solvers import SolverFailure, call
from models import cartesian_pendulum


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


def test_the_cartesian_pendulum_switches_from_the_part_a_failed_piece_reached(monkeypatch):
    # theta0 = 2.5 rad, 4 periods at rtol = atol = 1e-8 (scale L = 1 m): pieces that run on past a switch
    # into the old selection's singular point run out of their step budget; the switch is taken from the
    # part they reached. Criteria: that path was taken, four switches per period (two per coordinate
    # passing ±L), the length constraint within 10·(rtol·L + atol), and x at 1 s against the angle
    # model's solution within 100·(rtol·L + atol) (before any error can grow).
    used = []
    original = pieces.MonitoredPieces._switch_in_partial

    def watched(self, pts):
        found = original(self, pts)
        used.append(found is not None)
        return found
    monkeypatch.setattr(pieces.MonitoredPieces, "_switch_in_partial", watched)
    theta0, g = 2.5, 9.81
    period = 4 * np.sqrt(1 / g) * ellipk(np.sin(theta0 / 2) ** 2)
    cm = cartesian_pendulum(theta0=theta0).compile()
    grid = np.union1d(np.linspace(0.0, 4 * period, 81), [1.0])
    res = cm.simulate(grid[-1], rtol=1e-8, atol=1e-8, t_out=grid)
    assert res.success and any(used)
    assert sum(e.kind == "reselection" for e in res.events) >= 4 * 4 - 1
    assert np.max(np.abs(np.hypot(res["p.x"], res["p.y"]) - 1.0)) <= 10 * (1e-8 + 1e-8)
    th, w = ca.SX.sym("th"), ca.SX.sym("w")
    F = ca.integrator("F", "cvodes", {"x": ca.vertcat(th, w), "ode": ca.vertcat(w, -g * ca.sin(th))}, 0.0,
                      [1.0], {"reltol": 1e-12, "abstol": 1e-12})
    x_1 = np.sin(float(F(x0=[theta0, 0.0])["xf"][0]))
    assert abs(res["p.x"][np.searchsorted(grid, 1.0)] - x_1) <= 100 * (1e-8 + 1e-8)
