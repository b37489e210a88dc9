"""Friction, stops and contacts beyond the acceptance scenes: their bad input, their forms (switched,
smooth, absent), what the summary says they cost, the optimal-control layer smoothing them, and
the event iteration at a time event (a brake with no normal force breaking away the instant a clutch
engages)."""
import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.components.signals import Step


def block(friction, push=5.0, c=10.0, s0=0.0):
    """A 1 kg block on a spring (c to a wall), pushed by a constant force, rubbing on the ground."""
    m = mn.Model("block")
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=s0, v_start=0.0))
    wall = m.add(tr.Fixed(name="wall"))
    ground = m.add(tr.Fixed(name="ground"))
    spring = m.add(tr.Spring(name="spring", c=c))
    force = m.add(tr.ConstantForce(name="push", f_constant=push))
    m.connect(wall.flange, spring.flange_a)
    m.connect(spring.flange_b, mass.flange_a)
    m.connect(force.flange, mass.flange_b)
    if friction is not None:
        m.add(friction)
        m.connect(ground.flange, friction.flange_a)
        m.connect(friction.flange_b, mass.flange_b)
    return m


# ---- bad input ---------------------------------------------------------------------------------

@pytest.mark.parametrize("make, match", [
    (lambda: tr.Friction(name="fr", fn=1.0, mu_k=-0.1), "fr.*mu_k"),
    (lambda: tr.SupportFriction(name="fr", F_Coulomb=-1.0), "fr.*F_Coulomb"),
    (lambda: rot.BearingFriction(name="bf", tau_Coulomb=1.0, tau_prop=-2.0), "bf.*tau_prop"),
    (lambda: tr.Friction(name="fr", fn=1.0, mu_k=0.4, mu_s=0.3), "fr.*mu_s = 0.3 is below kinetic mu_k = 0.4"),
    (lambda: rot.Clutch(name="cl", fn_max=1.0, mu_k=0.4, mu_s=0.3), "cl.*mu_s"),
    (lambda: tr.Contact(name="c", e=1.5), r"c \(Contact\).*restitution e = 1.5 must lie in \[0, 1\]"),
    (lambda: rot.HardStop(name="st", phi_min=0.0, phi_max=1.0, e=-0.1), "st.*restitution"),
    (lambda: tr.HardStop(name="st", s_min=1.0, s_max=0.5), r"st \(HardStop\): limits reversed: s_min = 1.0"),
    (lambda: rot.HardStop(name="st", phi_min=0.2, phi_max=0.2), "st.*limits reversed"),
])
def test_bad_coefficients_are_refused_by_name(make, match):
    with pytest.raises(mn.ParameterError, match=match):
        make()


def test_accumulating_events_without_a_rest_mode_stop_naming_component_and_times():
    """The hand-written ball of tests/models.py has no rest mode: its bounces accumulate (e = 0.8, from
    1 m: T∞ = 4.06 s), so the run stops there with the partial result, the message naming the
    component and its last event times."""
    from models import bouncing_ball
    cm = mn.compile(bouncing_ball(h0=1.0, e=0.8))
    with pytest.warns(mn.IntegrationWarning, match="event accumulation"):
        res = cm.simulate(10.0, n_out=101)
    message = str(res.failure)
    assert "b (BouncingBall)" in message and "its last events at t = " in message
    assert 3.9 < res.t[-1] < 4.1 and res.t[-1] < 10.0       # kept up to the accumulation point


# ---- forms ------------------------------------------------------------------------------------

def test_friction_with_all_coefficients_zero_compiles_to_the_scene_without_it():
    """Nothing to switch: no modes, no zero crossings, and ode/alg the same functions (compared at
    random points to 0 and in instruction count)."""
    with_it = mn.compile(block(tr.SupportFriction(name="fr", F_Coulomb=0.0)))
    without = mn.compile(block(None))
    a, b = with_it.dae, without.dae
    assert a.x_names == b.x_names and a.z_names == b.z_names
    assert a.d_names == () and a.zero_labels == ()
    assert a.ode.n_instructions() == b.ode.n_instructions()
    rng = np.random.default_rng(0)
    for _ in range(5):
        x = rng.normal(size=len(a.x_names))
        np.testing.assert_array_equal(np.asarray(a.ode(0.0, x, [], [], [], [])),
                                      np.asarray(b.ode(0.0, x, [], [], [], [])))
    assert "fr (SupportFriction, absent): 0 modes" in with_it.summary()


def test_summary_lists_each_switched_element_with_its_cost():
    cm = mn.compile(block(tr.Friction(name="fr", fn=9.81, mu_k=0.2, mu_s=0.3)))
    text = cm.summary()
    line = next(l for l in text.splitlines() if l.strip().startswith("fr (Friction"))
    assert "switched" in line and "2 modes" in line and "3 zero-crossing functions" in line
    assert int(line.split("functions, ")[1].split()[0]) > 0        # instructions of its conditions


def test_smooth_form_creeps_at_the_documented_speed():
    """Regularised friction f = F_C·v/√(v² + v_s²) held by a force F < F_C creeps at the steady speed
    v = v_s·F/√(F_C² − F²) (switched.py). A 1 kg block pushed by F = 1 N against F_C = 2 N, v_s = 1e-3
    m/s: v = 5.774e-4 m/s; after 2 s (time constant ~1e-3 s) within 1e-8 relative at rtol 1e-10."""
    m = block(tr.SupportFriction(name="fr", F_Coulomb=2.0, smooth=True, v_smooth=1e-3), push=1.0, c=0.0)
    cm = mn.compile(m)
    assert cm.dae.d_names == () and cm.dae.zero_labels == ()
    res = cm.simulate(2.0, n_out=11, rtol=1e-10, atol=1e-12)
    expected = 1e-3 * 1.0 / np.sqrt(2.0 ** 2 - 1.0 ** 2)
    assert res["mass.v"][-1] == pytest.approx(expected, rel=1e-8)
    # the switched form holds it: no creep at all
    stuck = mn.compile(block(tr.SupportFriction(name="fr", F_Coulomb=2.0), push=1.0, c=0.0))
    assert np.max(np.abs(stuck.simulate(2.0, n_out=11)["mass.s"])) == 0.0


def test_smooth_friction_for_a_whole_model():
    m = block(tr.Friction(name="fr", fn=9.81, mu_k=0.2, mu_s=0.3))
    with mn.smooth_friction():
        cm = mn.compile(m)
    assert cm.dae.d_names == () and "fr (Friction, smooth)" in cm.summary()
    assert mn.compile(m).dae.d_names == ("fr.mode", "fr.impulse")       # outside the block: switched


def test_ocp_poses_friction_in_its_smooth_form_and_says_so():
    """A 1 kg block moved 1 m in 2 s against friction (μk = 0.2, μs = 0.3) by a bounded force: the
    problem is posed on the smooth form (the switched one has events IPOPT cannot see)."""
    from mechnet import ocp
    m = mn.Model("block_push")
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    push = m.add(tr.Force(name="push"))
    ground = m.add(tr.Fixed(name="ground"))
    fr = m.add(tr.Friction(name="fr", fn=9.81, mu_k=0.2, mu_s=0.3))
    m.connect(push.flange, mass.flange_a)
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, mass.flange_b)
    prob = ocp.Problem(m.compile(), t_final=2.0)
    assert prob.smoothed == ("fr",) and prob.dae.d_names == ()
    prob.bounds("push.f", -10.0, 10.0)
    prob.subject_to(prob.at_end(prob.var("mass.s")) == 1.0)
    prob.subject_to(prob.at_end(prob.var("mass.v")) == 0.0)
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    sol = prob.solve(ocp.Collocation(N=30))
    assert sol.success and sol.stats["smoothed"] == ("fr",)
    assert sol["mass.s"][-1] == pytest.approx(1.0, abs=1e-8)
    # moving forward the whole way, the push beats kinetic friction on average: ∫f dt ≥ μk·m·g·T
    assert np.trapezoid(sol["push.f"], sol.t) > 0.2 * 9.81 * 2.0 * 0.9


# ---- events at a time event -------------------------------------------------------------------

def test_a_brake_without_normal_force_breaks_away_the_instant_a_clutch_engages():
    """Motor (J = 0.1, 10 rad/s) and load (J = 0.3) joined by a clutch engaging at 0.5 s (slip torque
    0.3·0.1·100 = 3 N·m); the load's brake has no normal force until 2 s, so it breaks away *at* 0.5 s
    (the condition jumps with the input: no crossing before). Speeds equal at 0.75 s (2.5 rad/s); the
    brake (5 N·m from 2 s) stops both at 2.2 s and holds them. Times within 1e-9 s at rtol 1e-10."""
    m = mn.Model("drive")
    motor = m.add(rot.Inertia(name="motor", J=0.1, phi_start=0.0, w_start=10.0))
    load = m.add(rot.Inertia(name="load", J=0.3, phi_start=0.0, w_start=0.0))
    clutch = m.add(rot.Clutch(name="clutch", fn_max=100.0, mu_k=0.3, mu_s=0.4, cgeo=0.1,
                              f_normalized=Step(1.0, start_time=0.5)))
    brake = m.add(rot.Brake(name="brake", fn_max=100.0, mu_k=0.5, mu_s=0.5, cgeo=0.1, f_normalized=Step(1.0, start_time=2.0)))
    housing = m.add(rot.Fixed(name="housing"))
    m.connect(motor.flange_b, clutch.flange_a)
    m.connect(clutch.flange_b, load.flange_a)
    m.connect(housing.flange, brake.flange_a)
    m.connect(brake.flange_b, load.flange_b)
    res = mn.compile(m).simulate(4.0, n_out=41, rtol=1e-10, atol=1e-12)
    assert res.failure is None
    state = {e.cause.split(" — ")[1]: e.t for e in res.events if e.kind == "state"}
    assert state["brake breaks away"] == 0.5
    assert state["clutch sticks"] == pytest.approx(0.75, abs=1e-9)
    assert state["brake sticks"] == pytest.approx(2.2, abs=1e-9)
    after = res.t > 2.2 + 1e-9
    assert np.max(np.abs(res["load.w"][after])) <= 1e-12 and np.max(np.abs(res["motor.w"][after])) <= 1e-12
