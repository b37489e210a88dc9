"""Discrete modes (`mn.Mode`): compiled into the DAE's d, reset by state events, observed per row.

The scene (`models.relay_inertia`): an inertia J at phi = 0 turning at w0; a relay closes when phi rises
through phi_on and drives it with tau_on < 0 (braking), and opens when phi falls back through phi_off.
Piecewise in closed form, with a = tau_on / J:
    t1 = phi_on / w0;  phi = phi_on + w0 (t - t1) + a (t - t1)^2 / 2 while closed;
    phi falls through phi_off at t2 = t1 + (w0 + sqrt(w0^2 + 2 a (phi_off - phi_on))) / (-a), then coasts
    at the speed w2 = w0 + a (t2 - t1).
Tolerances: the solver runs at rtol 1e-10, atol 1e-12; event times and phi at t_end are asserted to
rtol 1e-8 (the events are located to 1e-12 relative in time; the rest is integration error).
"""
import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from models import oscillator, relay_inertia, Relay

J, W0, TAU_ON, PHI_ON, PHI_OFF = 0.5, 2.0, -1.0, 1.0, 0.5
T_END = 3.5


def closed_form():
    a = TAU_ON / J
    t1 = PHI_ON / W0
    t2 = t1 + (W0 + np.sqrt(W0 ** 2 + 2 * a * (PHI_OFF - PHI_ON))) / -a
    w2 = W0 + a * (t2 - t1)
    return t1, t2, PHI_OFF + w2 * (T_END - t2)


@pytest.fixture(scope="module")
def cm():
    return relay_inertia(J=J, w0=W0, tau_on=TAU_ON, phi_on=PHI_ON, phi_off=PHI_OFF).compile()


def test_the_mode_is_the_dae_discrete_variable(cm):
    dae = cm.dae
    assert dae.d_names == ("relay.on",)
    assert dae.d_value == (0.0,)
    assert "relay.on" not in dae.x_names + dae.z_names
    assert dae.units["relay.on"] == "1"
    # the closing event's transition sets the mode to 1 and leaves the states as they were
    x_plus, d_plus = dae.transition[0](0.5, [1.0, 2.0], [], [], [], [0.0])
    assert float(d_plus) == 1.0
    np.testing.assert_array_equal(np.asarray(x_plus).ravel(), [1.0, 2.0])
    # the mode enters the equations like a parameter: the inertia's acceleration is on * tau_on / J
    xdot = np.asarray(dae.ode(0.0, [1.0, 2.0], [], [], [], [1.0])).ravel()
    assert xdot[1] == pytest.approx(TAU_ON / J, rel=1e-15)


def test_relay_switches_where_the_closed_form_says(cm):
    t1, t2, phi_end = closed_form()
    res = cm.simulate(T_END, rtol=1e-10, atol=1e-12, n_out=36)
    state = [e for e in res.events if e.kind == "state"]
    assert [e.cause for e in state] == ["relay (Relay), event 1 — close", "relay (Relay), event 2 — open"]
    assert state[0].t == pytest.approx(t1, rel=1e-8)
    assert state[1].t == pytest.approx(t2, rel=1e-8)
    assert res["j1.phi"][-1] == pytest.approx(phi_end, rel=1e-8)
    # each row is observed with the mode that held there: the left limit of an event open, the right closed
    on = res["relay.on"]
    for event, before, after in ((state[0], 0.0, 1.0), (state[1], 1.0, 0.0)):
        rows = np.flatnonzero(res.t == event.t)
        assert on[rows[-2]] == before and on[rows[-1]] == after
    t_close, t_open = state[0].t, state[1].t
    assert np.all(on[res.t < t_close] == 0.0) and np.all(on[(res.t > t_close) & (res.t < t_open)] == 1.0)
    assert np.all(on[res.t > t_open] == 0.0)
    np.testing.assert_allclose(res["relay.tau"], TAU_ON * on, rtol=0, atol=0)


def test_a_start_value_sets_the_mode(cm):
    res = cm.simulate(0.2, start={"relay.on": 1.0}, rtol=1e-10, atol=1e-12, n_out=3)
    assert np.all(res["relay.on"] == 1.0)
    assert res["j1.w"][-1] == pytest.approx(W0 + TAU_ON / J * 0.2, rel=1e-9)


def test_the_relay_switches_on_every_swing_of_a_spring():
    res = relay_inertia(c=4.0, tau_on=-1.0, phi_on=0.5, phi_off=-0.5, w0=2.0).compile().simulate(10.0, n_out=101)
    causes = [e.cause.rsplit(" ", 1)[-1] for e in res.events if e.kind == "state"]
    assert len(causes) >= 6 and causes == ["close", "open"] * (len(causes) // 2)


def test_a_model_without_modes_has_an_empty_d():
    dae = oscillator().compile().dae
    assert dae.d.numel() == 0 and dae.d_names == () and dae.d_value == ()


class BadRelay(Relay):
    """A relay whose reset gives the mode two values."""

    def events(self):
        return [mn.When(self.flange.phi - self.phi_on, reset={self.on: ca.vertcat(1.0, 2.0)})]


def test_a_non_scalar_mode_reset_is_refused_naming_the_component():
    m = mn.Model("bad")
    j1 = m.add(rot.Inertia(name="j1", J=1.0, phi_start=0.0, w_start=1.0))
    relay = m.add(BadRelay(name="relay"))
    m.connect(relay.flange, j1.flange_a)
    with pytest.raises(mn.StructureError, match=r"relay \(BadRelay\), event 1: the new value of relay.on must be a scalar"):
        m.compile()


def test_a_reset_that_makes_another_condition_cross_fires_it_at_the_same_instant():
    """tests/models.py Cascade: x reaches 1 at t = 0.7 s (x0 = 0.3, speed 1); mode a is set there, and its
    jump makes the second condition cross, which sets b at the same instant. Exactly those two events,
    and the run goes on to 2 s (default tolerances; event time within 1e-9 s of the closed form)."""
    from models import cascade
    res = cascade().compile().simulate(2.0)
    assert res.failure is None and res.t[-1] == 2.0
    assert [e.cause.split("— ")[-1] for e in res.events] == ["first", "second"]
    assert all(abs(e.t - 0.7) < 1e-9 for e in res.events)
    assert res["c.a"][-1] == 1.0 and res["c.b"][-1] == 1.0
