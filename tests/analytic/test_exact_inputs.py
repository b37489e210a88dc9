"""Exact piecewise inputs: an inertia driven by a zero-order hold (an optimal control's), by jumps and by
linear pieces follows the closed form, with the knots as time events.

J driven from rest by a torque linear on each piece [t_a, t_b) has w piecewise quadratic (linear under a
hold) and phi piecewise cubic (quadratic under a hold). The integrator restarts at each knot, so no step
crosses one and BDF integrates these low-degree polynomials almost exactly. Runs at rtol 1e-12, atol
1e-14; compared at rtol 1e-10, atol 1e-12 (100× the solver's tolerance: the worst seen is 1 % of it). A
knot smeared over one sampling interval misses by ~1e-3 (test_a_sampled_step_function_smears).
"""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.signals import Ramp, Step, Table

J, T_END = 0.5, 1.5
SOLVER = dict(rtol=1e-12, atol=1e-14)
CLOSE = dict(rtol=1e-10, atol=1e-12)

TIMES, U = [0.0, 0.3, 0.7, 1.2], [2.0, -1.0, 3.0, 0.5]                     # a zero-order hold
HOLD = [(0.0, 0.3, 2.0, 2.0), (0.3, 0.7, -1.0, -1.0), (0.7, 1.2, 3.0, 3.0), (1.2, T_END, 0.5, 0.5)]
HOLD_AS_JUMPS = ([0.0, 0.3, 0.3, 0.7, 0.7, 1.2, 1.2], [2.0, 2.0, -1.0, -1.0, 3.0, 3.0, 0.5])
JUMP_TIMES, JUMP_VALUES = [0.0, 0.3, 0.3, 0.7, 1.2, 1.2], [0.0, 2.0, -1.0, 1.0, 3.0, 0.5]  # jumps, a kink at 0.7
JUMPS = [(0.0, 0.3, 0.0, 2.0), (0.3, 0.7, -1.0, 1.0), (0.7, 1.2, 1.0, 3.0), (1.2, T_END, 0.5, 0.5)]


def closed_form(pieces, t):
    """tau, w, phi at the times t of J driven from rest by a torque going linearly from tau_a to tau_b on each
    piece (t_a, t_b, tau_a, tau_b); tau right-continuous at the knots."""
    tau, w, phi = (np.zeros_like(t) for _ in range(3))
    w0 = phi0 = 0.0
    for a, b, ya, yb in pieces:
        slope = (yb - ya) / (b - a)
        on = (t >= a) & (t <= b)
        s = t[on] - a
        tau[on] = ya + slope * s
        w[on] = w0 + (ya * s + slope * s**2 / 2) / J
        phi[on] = phi0 + w0 * s + (ya * s**2 / 2 + slope * s**3 / 6) / J
        d = b - a
        w0, phi0 = w0 + (ya * d + slope * d**2 / 2) / J, phi0 + w0 * d + (ya * d**2 / 2 + slope * d**3 / 6) / J
    return tau, w, phi


class Clock(mn.Component):
    """A sawtooth q in [-0.5, 0.5) wrapping at q = 0.5 (t = 0.5, 1.5, ...): state events, so the run goes
    through the monitored pieces (`pieces.py`) rather than plain segments."""

    q = mn.State(unit="s")

    def equations(self):
        return [mn.Eq(mn.der(self.q), 1.0)]

    def events(self):
        return [mn.When(self.q - 0.5, reset={self.q: self.q - 1.0}, direction="rising", doc="wrap")]


def driven(tau=None, clock=False):
    m = mn.Model("driven")
    j = m.add(rot.Inertia(name="j", J=J, phi_start=0.0, w_start=0.0))
    tq = m.add(rot.Torque(name="tq", **({} if tau is None else {"tau": tau})))
    m.connect(tq.flange, j.flange_a)
    if clock:
        m.add(Clock(name="clock", q_start=0.0))
    return m.compile()


def assert_closed_form(res, pieces):
    tau, w, phi = closed_form(pieces, res.t)
    np.testing.assert_allclose(res["j.w"], w, **CLOSE)
    np.testing.assert_allclose(res["j.phi"], phi, **CLOSE)
    np.testing.assert_allclose(res["tq.tau"], tau, rtol=0, atol=1e-12)      # after each jump at its knot


INPUTS = {                                           # given input, its closed form, its time events
    "hold Table": (Table(TIMES, U, mode="hold"), HOLD, [0.3, 0.7, 1.2]),
    "hold as a pair with jumps": (HOLD_AS_JUMPS, HOLD, [0.3, 0.7, 1.2]),
    "linear Table with jumps": (Table(JUMP_TIMES, JUMP_VALUES), JUMPS, [0.3, 0.7, 1.2]),
    "pair with jumps": ((JUMP_TIMES, JUMP_VALUES), JUMPS, [0.3, 1.2]),          # a pair's kinks are no events
    "Step": (Step(3.0, offset=-1.0, start_time=0.35), [(0.0, 0.35, -1.0, -1.0), (0.35, T_END, 2.0, 2.0)], [0.35]),
    "Ramp": (Ramp(3.0, 0.5, start_time=0.2), [(0.0, 0.2, 0.0, 0.0), (0.2, 0.7, 0.0, 3.0), (0.7, T_END, 3.0, 3.0)],
             [0.2, 0.7]),
}


@pytest.mark.parametrize("method", ["auto", "idas"])
@pytest.mark.parametrize("case", INPUTS)
def test_an_input_table_or_signal_is_replayed_exactly(case, method):
    given, pieces, knots = INPUTS[case]
    res = driven().simulate(T_END, inputs={"tq.tau": given}, method=method, **SOLVER)
    assert_closed_form(res, pieces)
    assert [e.t for e in res.events] == knots
    assert all(e.kind == "time" and e.cause.startswith("input tq.tau") for e in res.events)


@pytest.mark.parametrize("table, pieces", [(Table(TIMES, U, mode="hold"), HOLD),
                                           (Table(JUMP_TIMES, JUMP_VALUES), JUMPS)], ids=["hold", "jumps"])
def test_a_table_as_component_parameter_gives_the_same_closed_form(table, pieces):
    res = driven(tau=table).simulate(T_END, **SOLVER)
    assert_closed_form(res, pieces)
    assert [e.t for e in res.events] == [0.3, 0.7, 1.2]


def test_a_hold_input_is_exact_in_monitored_pieces_too():
    # state events at 0.5 and 1.5 (t_end: not inside) between the knots; calls start inside segments there
    res = driven(clock=True).simulate(T_END, inputs={"tq.tau": Table(TIMES, U, mode="hold")}, **SOLVER)
    assert_closed_form(res, HOLD)
    assert [e.kind for e in res.events] == ["time", "state", "time", "time"]
    assert np.allclose([e.t for e in res.events], [0.3, 0.5, 0.7, 1.2], rtol=0, atol=1e-12)   # 0.5: a root


def test_a_sampled_step_function_smears():
    # the replayed control: a step-function callable is sampled on a grid (every 0.75 ms) and
    # interpolated linearly, so each jump is smeared over one interval; the hold Table is exact
    step_function = lambda t: U[int(np.searchsorted(TIMES, t, side="right")) - 1]     # noqa: E731
    _, w, phi = closed_form(HOLD, np.array([T_END]))
    cm = driven()
    table = cm.simulate(T_END, inputs={"tq.tau": Table(TIMES, U, mode="hold")}, **SOLVER)
    sampled = cm.simulate(T_END, inputs={"tq.tau": step_function}, **SOLVER)
    assert abs(table["j.phi"][-1] - phi[0]) < 1e-10 * abs(phi[0])
    assert abs(sampled["j.phi"][-1] - phi[0]) > 1e-4 and sampled.events == []
