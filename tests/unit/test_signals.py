"""Signals: values against their definitions, events where they jump or kink, bad tables."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.components.signals import Constant, Ramp, Sine, Step, Table

T = np.linspace(-1.0, 4.0, 501)


def test_constant_and_step():
    assert np.all(Constant(2.5)(T) == 2.5)
    s = Step(2.0, offset=-1.0, start_time=1.0)
    assert np.array_equal(s(T), np.where(T >= 1.0, 1.0, -1.0))
    assert s.events() == (1.0,)


def test_ramp():
    r = Ramp(3.0, 2.0, offset=1.0, start_time=0.5)
    expected = 1.0 + 3.0 * np.clip(T - 0.5, 0.0, 2.0) / 2.0
    assert np.max(np.abs(r(T) - expected)) < 1e-15
    assert r.events() == (0.5, 2.5)


def test_sine():
    s = Sine(2.0, 1.5, phase=0.3, offset=0.1, start_time=1.0)
    expected = 0.1 + np.where(T >= 1.0, 2.0 * np.sin(2 * np.pi * 1.5 * (T - 1.0) + 0.3), 0.0)
    assert np.max(np.abs(s(T) - expected)) < 1e-14
    assert Sine(1.0, 1.0).events() == ()


def test_table_interpolates_linearly_and_holds_outside():
    times, values = [0.0, 1.0, 1.5, 3.0], [0.0, 2.0, -1.0, -1.0]
    tab = Table(times, values)
    assert np.max(np.abs(tab(T) - np.interp(T, times, values))) < 1e-14
    assert tab.events() == tuple(times)


def test_signals_are_differentiable_in_time():
    t = ca.SX.sym("t")
    for signal, slope in ((Ramp(3.0, 2.0), 1.5), (Table([0.0, 2.0], [0.0, 4.0]), 2.0)):
        d = ca.Function("d", [t], [ca.jacobian(signal.expr(t), t)])
        assert float(d(1.0)) == pytest.approx(slope, abs=1e-14)


def test_ramp_takes_the_right_hand_slope_at_its_corners():
    # A time event restarts the integrator exactly at a corner (events() gives start_time + duration);
    # from there the slope after the corner must hold, although 0.7 - 0.2 < 0.5 in floating point.
    t = ca.SX.sym("t")
    ramp = Ramp(5.0, 0.5, offset=1.0, start_time=0.2)
    start, end = ramp.events()
    d = ca.Function("d", [t], [ca.jacobian(ramp.expr(t), t)])
    y = ca.Function("y", [t], [ramp.expr(t)])
    assert float(d(start)) == 10.0 and float(d(end)) == 0.0 and float(d(0.5 * (start + end))) == 10.0
    assert float(y(end)) == 6.0 and float(y(start)) == 1.0


@pytest.mark.parametrize("times", [[0.0, 1.0, 0.5], [0.0, 2.0, 1.0]])
def test_table_with_decreasing_times_is_rejected(times):
    # two equal times are a jump (tests/unit/test_table_modes.py); a time going back is refused
    with pytest.raises(mn.ParameterError, match=r"strictly increasing.*time\[1\]"):
        Table(times, [0.0, 1.0, 2.0])


def test_table_shape_and_values_are_checked():
    with pytest.raises(mn.ParameterError, match="two knots"):
        Table([0.0], [1.0])
    with pytest.raises(mn.ParameterError, match="finite"):
        Table([0.0, 1.0], [0.0, np.nan])
    with pytest.raises(mn.ParameterError, match="duration"):
        Ramp(1.0, 0.0)
    with pytest.raises(mn.ParameterError, match="height"):
        Step(float("nan"))
