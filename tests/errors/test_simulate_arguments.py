"""simulate() arguments: every wrong value is a MechnetError naming it."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from models import BouncingBall, oscillator


@pytest.fixture(scope="module")
def cm():
    return oscillator().compile()


@pytest.mark.parametrize("kwargs, error, text", [
    (dict(n_out=1), mn.MechnetError, "n_out"),
    (dict(n_out=-5), mn.MechnetError, "n_out"),
    (dict(n_out=2.5), mn.MechnetError, "n_out"),
    (dict(rtol=-1.0), mn.MechnetError, "rtol"),
    (dict(atol=0.0), mn.MechnetError, "atol"),
    (dict(rtol="tight"), mn.MechnetError, "rtol"),
    (dict(rtol=10.0), mn.MechnetError, r"rtol = 10\.0 must lie in \[1e-14, 1\)"),   # off by the amplitude
    (dict(rtol=1.0), mn.MechnetError, "rtol"),
    (dict(rtol=1e-16), mn.MechnetError, "rtol"),
    (dict(start={"j1.phi": "a"}), mn.InitializationError, r"start value j1\.phi"),
    (dict(guess={"j1.w": float("inf")}), mn.InitializationError, r"guess j1\.w"),
    (dict(t_out=[0.0, 0.5, 1.0], n_out=3), mn.MechnetError, "n_out or t_out"),
    (dict(continue_from={"j1.phi": 0.1}), mn.MechnetError, "continue_from"),
])
def test_bad_simulate_arguments(cm, kwargs, error, text):
    with pytest.raises(error, match=text):
        cm.simulate(1.0, **kwargs)


def test_t_end_must_be_a_number(cm):
    with pytest.raises(mn.MechnetError, match="t_end"):
        cm.simulate("1")


def test_t_end_must_match_t_out(cm):
    with pytest.raises(mn.MechnetError, match=r"t_end = 2 but t_out ends at 1"):
        cm.simulate(2.0, t_out=[0.0, 0.5, 1.0])


def test_events_must_return_a_list():
    class Bad(BouncingBall):
        def events(self):
            return mn.When(self.h, reset={self.v: -self.v})

    m = mn.Model("bad")
    m.add(Bad(name="b", h_start=1.0, v_start=0.0))
    with pytest.raises(mn.StructureError, match=r"b \(Bad\): events\(\) must return a list"):
        m.compile()


def test_reset_value_with_a_stray_symbol():
    import casadi as ca

    class Bad(BouncingBall):
        def events(self):
            return [mn.When(self.h, reset={self.v: ca.SX.sym("k") * self.v})]

    m = mn.Model("bad")
    m.add(Bad(name="b", h_start=1.0, v_start=0.0))
    with pytest.raises(mn.StructureError, match=r"new value of .* uses 'k'"):
        m.compile()


def test_expose_refuses_a_taken_name():
    from mechnet.components import rotational as rot

    sub = mn.Model("drive")
    j = sub.add(rot.Inertia(name="j", J=1.0))
    sub.expose("flange", j.flange_a)
    with pytest.raises(mn.NameConflictError, match="'flange'"):
        sub.expose("flange", j.flange_b)
    with pytest.raises(mn.NameConflictError, match="'compile'"):
        sub.expose("compile", j.flange_b)


# ---- the shared argument checks (core/arguments.py): each names the argument --------------------------

@pytest.mark.parametrize("kwargs, text", [
    (dict(params=["spring.c", 1.0]), r"simulate\(params=\.\.\.\) takes a mapping"),
    (dict(inputs="tq.tau"), r"simulate\(inputs=\.\.\.\) takes a mapping"),
    (dict(start=0.5), r"simulate\(start=\.\.\.\) takes a mapping"),
    (dict(guess=[("j1.w", 0.0)]), r"simulate\(guess=\.\.\.\) takes a mapping"),
    (dict(start={1: 0.5}), r"names must be dotted strings"),
    (dict(max_steps=0), r"max_steps = 0 must be a whole number of at least 1"),
    (dict(max_steps=-1), r"max_steps"),
    (dict(max_steps=None), r"max_steps"),
    (dict(max_steps=2.5), r"max_steps"),
    (dict(max_steps="100"), r"max_steps"),
    (dict(n_out=True), r"n_out"),
    (dict(n_out=10 ** 8), r"n_out = 100000000 would need about .* GiB"),
    (dict(progress="yes"), r"progress"),
    (dict(steady_state=1), r"steady_state"),
])
def test_simulate_arguments_are_checked_in_one_place(cm, kwargs, text):
    with pytest.raises(mn.MechnetError, match=text):
        cm.simulate(1.0, **kwargs)


def test_a_model_with_nothing_to_simulate_says_so():
    from mechnet.components import rotational as rot
    m = mn.Model("empty")
    m.add(rot.Fixed(name="fixed"))
    with pytest.raises(mn.MechnetError, match=r"model 'empty' has nothing to simulate"):
        m.compile().simulate(1.0)


def test_continue_from_a_result_of_another_model_is_refused(cm):
    from models import cartesian_pendulum
    other = cartesian_pendulum().compile().simulate(0.1)
    with pytest.raises(mn.MechnetError, match=r"continue_from holds a result of another model"):
        cm.simulate(1.0, continue_from=other)


def test_result_access_by_name(cm, tmp_path):
    res = cm.simulate(1.0, n_out=11)
    with pytest.raises(mn.UnknownNameError, match=r"dotted name, such as res\["):
        res[0]
    with pytest.raises(mn.MechnetError, match=r"to_csv\(path\) = .* is a directory"):
        res.to_csv(tmp_path)
    with pytest.raises(mn.MechnetError, match=r"does not exist"):
        res.to_csv(tmp_path / "missing" / "out.csv")
    # one name is one name, not its characters; the plotted line is the oscillator's angle
    fig = res.plot("j1.phi")
    line = fig.axes[0].lines[0]
    assert np.allclose(line.get_ydata(), res["j1.phi"])
    assert abs(res["j1.phi"][-1] - 0.5 * np.cos(np.sqrt(1000.0))) < 1e-4     # closed form, rtol 1e-6


@pytest.fixture(scope="module")
def driven():
    """An inertia driven by an input torque: w(1) = (1/J)∫tau for any good input."""
    from mechnet.components import rotational as rot
    m = mn.Model("driven")
    tq = m.add(rot.Torque(name="tq"))
    j1 = m.add(rot.Inertia(name="j1", J=0.5, phi_start=0.0, w_start=0.0))
    m.connect(tq.flange, j1.flange_a)
    return m.compile()


def _raises(t):
    raise RuntimeError("sensor offline")


@pytest.mark.parametrize("value, text", [
    ("3.0", r"input 'tq.tau' = '3.0': give a number"),
    (None, r"input 'tq.tau' = None: give a number"),
    ({"t": 1}, r"input 'tq.tau' = \{'t': 1\}: give a number"),
    (1 + 2j, r"input 'tq.tau' = \(1\+2j\): give a number"),
    (_raises, r"input 'tq.tau': the callable raised RuntimeError at t = 0 s: sensor offline"),
    (lambda: 1.0, r"input 'tq.tau': the callable raised TypeError at t = 0 s"),
    (lambda t: "x", r"input 'tq.tau': the callable returned 'x' at t = 0 s"),
    (([0.0, 1.0, 2.0], [1.0, 2.0]), r"needs at least two samples and as many values as times \(got 3 times, 2"),
    (([0.0, float("nan"), 2.0], [1.0, 2.0, 3.0]), r"time\[1\] = nan is not finite"),
    ((["0", "1"], [1.0, 2.0]), r"a table must hold numbers"),
])
def test_bad_inputs_are_named(driven, value, text):
    with pytest.raises(mn.InputError, match=text):
        driven.simulate(1.0, inputs={"tq.tau": value})


def test_good_inputs_still_drive(driven):
    # tau = 2 t: w(1) = (1/J) ∫0..1 2t dt = 1/J = 2 rad/s (linear in t: sampled exactly; rtol 1e-6)
    res = driven.simulate(1.0, inputs={"tq.tau": lambda t: 2.0 * t})
    assert abs(res["j1.w"][-1] - 2.0) < 1e-5


def test_a_failure_from_the_arguments_says_which_to_change(cm):
    # issue 16: max_steps = 1 failed naming j1.w; the oscillator's run needs thousands of steps
    with pytest.warns(mn.IntegrationWarning):
        res = cm.simulate(1.0, max_steps=1)
    assert not res.success
    assert "max_steps = 1 ran out: raise max_steps" in str(res.failure)


@pytest.mark.parametrize("times, values", [(["0", "1"], [1.0, 2.0]), ([0.0, 1.0], [None, 2.0]), ("01", "12")])
def test_a_table_must_hold_numbers(times, values):
    from mechnet.components.signals import Table
    with pytest.raises(mn.ParameterError, match=r"Table: (times|values) must be numbers"):
        Table(times, values)


def test_a_tiny_atol_is_named_when_the_run_fails(cm):
    # issue 16: atol = 1e-300 failed at t = 0 naming j1.w (its speed starts at 0, where only atol holds it)
    # (with BDF: Adams' functional iteration, auto's first choice, happens to get through this one)
    with pytest.warns(mn.IntegrationWarning):
        res = cm.simulate(1.0, atol=1e-300, method="cvodes-bdf")
    assert not res.success and "atol = 1e-300 asks for an absolute error no double resolves" in str(res.failure)
