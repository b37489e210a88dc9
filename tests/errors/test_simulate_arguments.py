"""simulate() arguments: every wrong value is a MechnetError naming it."""
from __future__ import annotations

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
