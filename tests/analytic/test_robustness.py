"""Results that must not depend on how the run is sampled or started."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

import mechnet as mn
from mechnet.components import translational as tr
from mechnet.components.signals import Step
from models import BouncingBall, cartesian_pendulum


def test_reselection_does_not_depend_on_the_output_grid():
    # theta0 = 2.5, 3 periods, rtol = atol = 1e-8: with 21 or 3001 output points the energy per unit mass
    # stays within 1e-3 of its start (scale g·L ≈ 10 J/kg) and the rod length within 10·(rtol·L + atol).
    theta0 = 2.5
    T = 4 * math.sqrt(1 / 9.81) * ellipk(math.sin(theta0 / 2) ** 2)
    cm = cartesian_pendulum(theta0=theta0).compile()
    for n_out in (21, 3001):
        res = cm.simulate(3 * T, rtol=1e-8, atol=1e-8, n_out=n_out)
        assert res.success
        E = 0.5 * (res["p.vx"] ** 2 + res["p.vy"] ** 2) + 9.81 * res["p.y"]
        assert np.max(np.abs(E - E[0])) < 1e-3, n_out
        assert np.max(np.abs(np.hypot(res["p.x"], res["p.y"]) - 1.0)) <= 10 * (1e-8 + 1e-8)


@pytest.mark.parametrize("theta0", [0.8, 1.0, 1.5, 2.3])
def test_start_values_seed_the_initial_newton(theta0):
    # the dependent coordinate starts from the fixed values, not from a default guess of 0
    cm = cartesian_pendulum(theta0=theta0).compile()
    res = cm.simulate(0.1)
    assert res["p.x"][0] == pytest.approx(math.sin(theta0), abs=1e-12)
    assert res["p.y"][0] == pytest.approx(-math.cos(theta0), abs=1e-10)


def test_two_balls_landing_at_the_same_instant_both_bounce():
    m = mn.Model("two")
    m.add(BouncingBall(name="b1", h_start=1.0, v_start=0.0))
    m.add(BouncingBall(name="b2", h_start=1.0, v_start=0.0))
    res = m.compile().simulate(1.0, rtol=1e-10, atol=1e-10)
    first = [e for e in res.events if abs(e.t - math.sqrt(2 / 9.81)) < 1e-8]
    assert sorted(e.cause.split()[0] for e in first) == ["b1", "b2"]
    assert res["b1.h"][-1] > 0 and res["b2.h"][-1] > 0
    assert res["b1.h"][-1] == pytest.approx(res["b2.h"][-1], abs=1e-12)


def test_array_input_is_held_outside_its_table_for_the_integrator_too():
    # force ramps 0 -> 1 N over [0, 0.5] s, then holds: v(1) = 0.25 + 0.5 = 0.75 m/s on 1 kg
    # (rtol = atol = 1e-10: < 1e-8). CasADi's interpolant alone would extrapolate to 2 N.
    m = mn.Model("pushed")
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    f = m.add(tr.Force(name="f"))
    m.connect(f.flange, mass.flange_a)
    res = m.compile().simulate(1.0, inputs={"f.f": ([0.0, 0.5], [0.0, 1.0])}, rtol=1e-10, atol=1e-10)
    assert res["mass.v"][-1] == pytest.approx(0.75, abs=1e-8)
    assert res["f.f"][-1] == 1.0


def test_an_event_a_rounding_error_from_an_output_time_replaces_it():
    m = mn.Model("stepped")
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    f = m.add(tr.Force(name="f", f=Step(1.0, start_time=0.3)))
    m.connect(f.flange, mass.flange_a)
    res = m.compile().simulate(1.0, n_out=11)
    assert res.t.size == 11 and 0.3 in res.t
