"""Table modes (Modelica's): linear, hold, jumps at a time given twice; bad tables name the culprit; the
input plan hands the integrator each knot's value on the side a call starts from."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.signals import Table
from mechnet.simulate.inputs import plan_inputs

TIMES, U = [0.0, 0.3, 0.7, 1.2], [2.0, -1.0, 3.0, 0.5]


def test_hold_keeps_each_value_until_the_next_time_and_is_right_continuous():
    hold = Table(TIMES, U, mode="hold")
    t = np.array([-1.0, 0.0, 0.29, 0.3, 0.69, 0.7, 1.1999, 1.2, 5.0])
    expected = [2.0, 2.0, 2.0, -1.0, -1.0, 3.0, 3.0, 0.5, 0.5]
    assert np.array_equal(hold(t), expected)
    assert hold.events() == tuple(TIMES) and hold.smoothness == 0


def test_a_time_given_twice_is_a_jump_between_linear_pieces():
    # 0 -> 2 on [0, 1), jump to -1 at 1, -1 -> 1 on [1, 2); value right after the knot, right-hand slope
    jump = Table([0.0, 1.0, 1.0, 2.0], [0.0, 2.0, -1.0, 1.0])
    t = np.array([-0.5, 0.5, 1.0 - 1e-9, 1.0, 1.5, 2.0, 3.0])
    expected = [0.0, 1.0, 2.0 - 2e-9, -1.0, 0.0, 1.0, 1.0]
    assert np.max(np.abs(jump(t) - expected)) < 1e-15
    s = ca.SX.sym("t")
    slope = ca.Function("d", [s], [ca.jacobian(jump.expr(s), s)])
    assert float(slope(1.0)) == 2.0 and float(slope(2.0)) == 0.0
    assert jump.events() == (0.0, 1.0, 2.0) and jump.smoothness == 0
    assert Table([0.0, 1.0, 2.0], [0.0, 2.0, 1.0]).smoothness == 1      # kinks only: differentiable once


@pytest.mark.parametrize("times, mode, text", [
    ([0.0, 1.0, 1.0, 1.0], "linear", r"Table: time\[1\] = time\[2\] = time\[3\] = 1: a jump takes exactly two"),
    ([0.0, 2.0, 1.0, 3.0], "linear", r"Table: times must be strictly increasing except at a jump.*"
                                     r"time\[1\] = 2 and time\[2\] = 1"),
    ([0.0, 1.0, 1.0, 2.0], "hold", r"Table: times must be strictly increasing, but time\[1\] = 1 and time\[2\]"),
    ([0.0, 1.0, 2.0, 3.0], "cubic", r"Table: mode = 'cubic' is not one of 'linear', 'hold'"),
])
def test_bad_tables_name_the_culprit(times, mode, text):
    with pytest.raises(mn.ParameterError, match=text):
        Table(times, [0.0, 1.0, 2.0, 3.0], mode=mode)


@pytest.fixture(scope="module")
def dae():
    m = mn.Model("driven")
    j = m.add(rot.Inertia(name="j", J=1.0, phi_start=0.0, w_start=0.0))
    tq = m.add(rot.Torque(name="tq"))
    m.connect(tq.flange, j.flange_a)
    return m.compile().dae


def test_the_plan_hands_each_call_the_side_of_the_jump_it_starts_on(dae):
    # jumps at 1 (2 -> -1) and at 2 (1 -> 5); a knot at t_end = 3 holds 5 after the table. A call from t0
    # sees the knots up to t0 after their jump, the later ones before it: linear within [t_a, t_a+1)
    plan = plan_inputs(dae, {"tq.tau": ([0.0, 1.0, 1.0, 2.0, 2.0], [0.0, 2.0, -1.0, 1.0, 5.0])}, 0.0, 3.0, 11)
    assert np.array_equal(plan.table_data(0.0), [0.0, 2.0, 1.0, 5.0])        # [0, 1): 0 -> 2
    assert np.array_equal(plan.table_data(1.0), [0.0, -1.0, 1.0, 5.0])       # [1, 2): -1 -> 1
    assert np.array_equal(plan.table_data(2.5), [0.0, -1.0, 5.0, 5.0])       # [2, 3]: 5
    assert np.array_equal(plan.at([0.5, 1.0, 1.5, 2.0, 3.0])[0], [1.0, -1.0, 0.0, 5.0, 5.0])
    assert [t for t, _ in plan.time_events] == [1.0, 2.0]
    assert plan.time_events[0][1] == "input tq.tau knot"


def test_only_a_tables_times_key_the_integrator(dae):
    # the values are parameters: the same times with other values (a sweep, an optimiser) share one integrator
    a = plan_inputs(dae, {"tq.tau": Table(TIMES, U, mode="hold")}, 0.0, 1.5, 11)
    b = plan_inputs(dae, {"tq.tau": Table(TIMES, np.negative(U), mode="hold")}, 0.0, 1.5, 11)
    assert a.key() == b.key() and a.table_data().size == b.table_data().size == len(TIMES) + 1
    assert [t for t, _ in a.time_events] == TIMES        # every knot of a Table (the run keeps 0 < t < 1.5)


@pytest.mark.parametrize("given, text", [
    (([0.0, 1.0, 1.0, 1.0], [0.0, 1.0, 2.0, 3.0]), r"input 'tq\.tau': time\[1\] = time\[2\] = time\[3\] = 1"),
    (([0.0, 1.0, 0.5], [0.0, 1.0, 2.0]), r"input 'tq\.tau': times must be strictly increasing except at a jump"),
])
def test_bad_input_tables_name_the_input_and_index(dae, given, text):
    with pytest.raises(mn.InputError, match=text):
        plan_inputs(dae, {"tq.tau": given}, 0.0, 1.0, 11)
