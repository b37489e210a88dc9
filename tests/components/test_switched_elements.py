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


def pushed_block():
    """A 1 kg block pushed by the input `push.f` on a surface with friction (μk = 0.2, μs = 0.3, fn = 9.81 N)."""
    m = mn.Model("block_push")
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    push = m.add(tr.Force(name="push"))
    ground = m.add(tr.Fixed(name="ground"))
    fr = m.add(tr.Friction(name="fr", fn=9.81, mu_k=0.2, mu_s=0.3))
    m.connect(push.flange, mass.flange_a)
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, mass.flange_b)
    return m


# ---- bad input ---------------------------------------------------------------------------------

@pytest.mark.parametrize("make, match", [
    (lambda: tr.Friction(name="fr", fn=1.0, mu_k=-0.1), "fr.*mu_k"),
    (lambda: tr.SupportFriction(name="fr", F_Coulomb=-1.0), "fr.*F_Coulomb"),
    (lambda: rot.BearingFriction(name="bf", tau_Coulomb=1.0, tau_prop=-2.0), "bf.*tau_prop"),
    (lambda: tr.Friction(name="fr", fn=1.0, mu_k=0.4, mu_s=0.3), "fr.*mu_s = 0.3 is below mu_k = 0.4; mu_s must be >= mu_k"),
    (lambda: rot.Clutch(name="cl", fn_max=1.0, mu_k=0.4, mu_s=0.3), "cl.*mu_s"),
    (lambda: tr.Contact(name="c", e=1.5), r"c \(Contact\).*e = 1.5 must lie in \[0, 1\]"),
    (lambda: rot.HardStop(name="st", phi_min=0.0, phi_max=1.0, e=-0.1), "st.*e = -0.1 must lie in"),
    (lambda: tr.HardStop(name="st", s_min=1.0, s_max=0.5), r"st \(HardStop\): s_max = 0.5 is not above s_min = 1; s_max must be > s_min \(limits reversed or equal\)"),
    (lambda: rot.HardStop(name="st", phi_min=0.2, phi_max=0.2), "st.*limits reversed or equal"),
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
    prob = ocp.Problem(pushed_block().compile(), t_final=2.0)
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

def _drive(brake_input=None):
    m = mn.Model("drive")
    motor = m.add(rot.Inertia(name="motor", J=0.1, phi_start=0.0, w_start=10.0))
    load = m.add(rot.Inertia(name="load", J=0.3, phi_start=0.0, w_start=0.0))
    clutch = m.add(rot.Clutch(name="clutch", fn_max=100.0, mu_k=0.3, mu_s=0.4, cgeo=0.1,
                              **({} if brake_input is not None else {"f_normalized": Step(1.0, start_time=0.5)})))
    brake = m.add(rot.Brake(name="brake", fn_max=100.0, mu_k=0.5, mu_s=0.5, cgeo=0.1,
                            f_normalized=Step(1.0, start_time=2.0) if brake_input is None else brake_input))
    housing = m.add(rot.Fixed(name="housing"))
    m.connect(motor.flange_b, clutch.flange_a)
    m.connect(clutch.flange_b, load.flange_a)
    m.connect(housing.flange, brake.flange_a)
    m.connect(brake.flange_b, load.flange_b)
    return mn.compile(m)


def _state_times(res):
    return {e.cause.split(" — ")[1]: e.t for e in res.events if e.kind == "state"}


def test_a_brake_without_normal_force_holds_nothing_until_it_is_pressed():
    """Motor (J = 0.1, 10 rad/s) and load (J = 0.3) joined by a clutch pressed at 0.5 s (slip torque
    0.3·0.1·100 = 3 N·m); the load's brake has no normal force until 2 s: it is open (no static limit,
    nothing to hold), so it makes no event and carries exactly 0 N·m on every row before 2 s — the row
    at 0.5 s too, where it used to read the 3 N·m it "held" before a breakaway at that instant. The
    clutch, open until 0.5 s, starts sliding when pressed; speeds equal at 0.75 s (2.5 rad/s); the
    brake (5 N·m from 2 s) starts sliding at 2 s, stops both at 2.2 s and holds them. Times within
    1e-9 s at rtol 1e-10."""
    res = _drive().simulate(4.0, n_out=41, rtol=1e-10, atol=1e-12)
    assert res.failure is None
    before = res.t < 2.0
    assert np.all(res["brake.tau"][before] == 0.0)
    assert not [e for e in res.events if e.t < 2.0 and e.cause.startswith("brake")]
    state = _state_times(res)
    assert state["clutch starts sliding"] == 0.5
    assert state["clutch sticks"] == pytest.approx(0.75, abs=1e-9)
    assert state["brake starts sliding"] == 2.0
    assert state["brake sticks"] == pytest.approx(2.2, abs=1e-9)
    # one row at 0.5 s: the right limit (the left limit's inputs cannot be shown at that time)
    at = np.flatnonzero(res.t == 0.5)
    assert at.size == 1 and res["clutch.tau"][at[0]] == pytest.approx(-3.0, rel=1e-12)
    after = res.t > 2.2 + 1e-9
    assert np.max(np.abs(res["load.w"][after])) <= 1e-12 and np.max(np.abs(res["motor.w"][after])) <= 1e-12


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_brake_pressed_on_a_moving_disc_starts_sliding_without_breaking_away(sign):
    """A disc (J = 1 kg·m², ±5 rad/s) driven by ∓8 N·m; its brake (kinetic 0.5·0.1·100 = 5 N·m, static 6)
    is pressed at 0.1 s while the disc turns: the one state event is "starts sliding" (no breakaway, which
    is for a still element), and the disc then decelerates at ∓13 rad/s² (within 1e-9 at rtol 1e-10)."""
    m = mn.Model("pressed")
    disc = m.add(rot.Inertia(name="disc", J=1.0, phi_start=0.0, w_start=5.0 * sign))
    drive = m.add(rot.ConstantTorque(name="drive", tau_constant=-8.0 * sign))
    brake = m.add(rot.Brake(name="brake", fn_max=100.0, cgeo=0.1, mu_k=0.5, mu_s=0.6,
                            f_normalized=Step(1.0, start_time=0.1)))
    housing = m.add(rot.Fixed(name="housing"))
    m.connect(drive.flange, disc.flange_a)
    m.connect(housing.flange, brake.flange_a)
    m.connect(brake.flange_b, disc.flange_b)
    res = m.compile().simulate(0.3, t_out=[0.0, 0.1, 0.2, 0.25, 0.3], rtol=1e-10, atol=1e-12)
    assert [(e.t, e.cause.split(" — ")[-1]) for e in res.events if e.kind == "state"] == \
        [(0.1, "brake starts sliding")]
    w = res["disc.w"]
    assert (w[3] - w[2]) / 0.05 == pytest.approx(-13.0 * sign, abs=1e-9)


def test_the_clutch_brake_example_shows_no_brake_torque_before_the_brake_is_pressed():
    """examples/clutch_brake.py at its own settings (301 rows, rtol 1e-10): brake.tau is 0 on every row
    before 2 s and no brake event is listed before 2 s (issue 31, item 2)."""
    import importlib.util
    from pathlib import Path
    path = Path(__file__).resolve().parents[2] / "examples" / "clutch_brake.py"
    spec = importlib.util.spec_from_file_location("clutch_brake_example", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    res = example.build().compile().simulate(example.t_end, n_out=301, rtol=1e-10, atol=1e-12)
    assert res.failure is None
    assert np.all(res["brake.tau"][res.t < 2.0] == 0.0)
    assert not [e for e in res.events if e.t < 2.0 and e.cause.startswith("brake")]


# ---- stops, contacts and joints ----------------------------------------------------------------

def test_a_mass_rests_against_a_stop_while_pushed_and_leaves_when_pulled():
    """1 kg at 0, pushed by 2 N toward a stop at s_max = 0.1 m (e = 0.5): impacts at √(2·0.1/2) = 0.316 s,
    then ever shorter bounces (each flight e times the last) accumulating at 0.316·(1 + 2e/(1 − e))
    = 0.949 s, where it rests, the stop holding the 2 N; at 3 s the push turns to −2 N and it lets go
    at that instant (a condition thrown across by a time event). rtol 1e-10, atol 1e-12."""
    m = mn.Model("pushed")
    wall = m.add(tr.Fixed(name="wall"))
    stop = m.add(tr.HardStop(name="stop", s_min=-1.0, s_max=0.1, e=0.5))
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    push = m.add(tr.Force(name="push", f=Step(-4.0, offset=2.0, start_time=3.0)))
    m.connect(wall.flange, stop.flange_a)
    m.connect(stop.flange_b, mass.flange_a)
    m.connect(push.flange, mass.flange_b)
    res = mn.compile(m).simulate(3.5, n_out=36, rtol=1e-10, atol=1e-12)
    assert res.failure is None
    impacts = [e.t for e in res.events if e.kind == "state" and "hits s_max" in e.cause]
    assert impacts[0] == pytest.approx(np.sqrt(0.1), abs=1e-9)
    assert impacts[1] - impacts[0] == pytest.approx(2 * 0.5 * np.sqrt(0.1), abs=1e-9)   # flight: 2·e·v/a
    rest = next(e.t for e in res.events if e.kind == "rest")
    assert rest == pytest.approx(np.sqrt(0.1) * (1 + 2 * 0.5 / 0.5), abs=1e-3)
    held = (res.t > rest + 1e-9) & (res.t < 3.0)
    assert np.all(res["stop.mode"][held] == 1.0)
    assert np.allclose(res["stop.f"][held], 2.0, rtol=1e-12)                # the push, carried by the stop
    assert np.max(np.abs(res["mass.s"][held] - 0.1)) <= 10 * (1e-10 * 0.1 + 1e-12)
    lets_go = [e.t for e in res.events if "lets go" in e.cause]
    assert lets_go == [3.0]
    after = res.t > 3.0
    np.testing.assert_allclose(res["mass.s"][after], 0.1 - 0.5 * 2.0 * (res.t[after] - 3.0) ** 2, rtol=1e-8, atol=1e-12)


def test_an_elastic_gap_settles_at_its_static_compression():
    """A 0.1 kg ball dropped 0.2 m on an ElastoGap (c = 1e4 N/m, d = 20 N·s/m) bounces, is damped and
    settles at the static compression −m·g/c = −9.81e-5 m (within 1e-9 m after 3 s, rtol 1e-8)."""
    m = mn.Model("gap_ball")
    floor = m.add(tr.Fixed(name="floor"))
    gap = m.add(tr.ElastoGap(name="gap", c=1e4, d=20.0))
    ball = m.add(tr.Mass(name="ball", m=0.1, s_start=0.2, v_start=0.0))
    gravity = m.add(tr.ConstantForce(name="gravity", f_constant=-0.981))
    m.connect(floor.flange, gap.flange_a)
    m.connect(gap.flange_b, ball.flange_a)
    m.connect(gravity.flange, ball.flange_b)
    res = mn.compile(m).simulate(3.0, n_out=31, rtol=1e-8, atol=1e-10)
    assert res.failure is None and len([e for e in res.events if e.kind == "state"]) >= 2
    assert res["ball.s"][-1] == pytest.approx(-0.981 / 1e4, abs=1e-9)
    assert np.all(res["gap.f"] <= 0.0)                      # it only ever pushes


def test_newtons_cradle_on_prismatic_joints():
    """Five 0.2 kg balls (d = 5 cm) on prismatic joints along x, 1 mm apart, contacts between the
    joints' axis flanges (e = 1), the first at 1 m/s: four impacts at 1, 2, 3, 4 ms (to 1e-9 s), the
    last leaves at 1 m/s (1e-9 relative), the others at rest (1e-9 m/s). rtol 1e-10, atol 1e-12."""
    from mechnet.components import multibody as mb
    n, d, gap, mass = 5, 0.05, 1e-3, 0.2
    m = mn.Model("cradle_mb")
    world = m.add(mb.World(name="world", g=[0.0, -9.81, 0.0]))
    rail = m.add(tr.Fixed(name="rail"))
    joints = []
    for i in range(n):
        joint = m.add(mb.Prismatic(name=f"slide{i}", n=[1, 0, 0], use_flange=True, s_start=i * (d + gap),
                                   v_start=1.0 if i == 0 else 0.0))
        body = m.add(mb.Body(name=f"ball{i}", m=mass, r_cm=[0, 0, 0], I=np.eye(3) * 0.4 * mass * (d / 2) ** 2))
        m.connect(world.frame_b, joint.frame_a)
        m.connect(joint.frame_b, body.frame_a)
        m.connect(rail.flange, joint.support)
        joints.append(joint)
    for i in range(n - 1):
        contact = m.add(tr.Contact(name=f"c{i}", e=1.0, s_contact=d))
        m.connect(joints[i].axis, contact.flange_a)
        m.connect(contact.flange_b, joints[i + 1].axis)
    res = mn.compile(m).simulate(0.01, n_out=11, rtol=1e-10, atol=1e-12)
    impacts = [e.t for e in res.events if e.kind == "state"]
    np.testing.assert_allclose(impacts, [1e-3, 2e-3, 3e-3, 4e-3], atol=1e-9)
    v = np.array([res[f"slide{i}.v"][-1] for i in range(n)])
    assert v[-1] == pytest.approx(1.0, rel=1e-9)
    assert np.max(np.abs(v[:-1])) <= 1e-9


def test_a_pendulum_with_coulomb_bearing_friction_swings_down_to_rest():
    """A point mass (1 kg, 0.5 m) on a revolute joint with BearingFriction (τ_C = 0.6 N·m) on its
    flanges, released at θ = 1 rad from the downward vertical. Between turning points energy falls by
    τ_C·|Δθ|: V(a) − V(b) = τ_C·|a − b|, V = −m·g·l·cos θ; it sticks at each turning point and breaks away
    while m·g·l·|sin θ| > τ_C. Turning angles from that energy balance (brentq to 1e-15) within 1e-7 rad
    at rtol 1e-10, atol 1e-12; the last one holds for good (w = 0 exactly)."""
    from scipy.optimize import brentq
    from mechnet.components import multibody as mb
    M, L, G, TC = 1.0, 0.5, 9.81, 0.6
    m = mn.Model("pendulum_friction")
    world = m.add(mb.World(name="world", g=[0, -G, 0]))
    joint = m.add(mb.Revolute(name="joint", n=[0, 0, 1], use_flange=True, phi_start=1.0 - np.pi / 2, w_start=0.0))
    bob = m.add(mb.Body(name="bob", m=M, r_cm=[L, 0, 0], I=np.zeros((3, 3))))
    bearing = m.add(rot.BearingFriction(name="bearing", tau_Coulomb=TC))
    fixed = m.add(rot.Fixed(name="fixed"))
    m.connect(world.frame_b, joint.frame_a)
    m.connect(joint.frame_b, bob.frame_a)
    m.connect(joint.support, fixed.flange)
    m.connect(fixed.flange, bearing.flange_a)
    m.connect(bearing.flange_b, joint.axis)
    res = mn.compile(m).simulate(6.0, n_out=61, rtol=1e-10, atol=1e-12)
    assert res.failure is None

    def potential(theta):
        return -M * G * L * np.cos(theta)
    turning = [1.0]
    while M * G * L * abs(np.sin(turning[-1])) > TC:
        a, toward = turning[-1], -np.sign(turning[-1])

        def h(step):
            return potential(a) - potential(a + toward * step) - TC * step
        grid = np.linspace(1e-9, 2 * abs(a) + 1e-9, 20001)
        k = int(np.argmax(h(grid) < 0))
        turning.append(a + toward * brentq(h, grid[k - 1], grid[k], xtol=1e-15))
    sticks = [e.t for e in res.events if "sticks" in e.cause]
    assert len(sticks) == len(turning) - 1 == 4
    angles = [res["joint.phi"][np.flatnonzero(res.t == t)[-1]] + np.pi / 2 for t in sticks]
    np.testing.assert_allclose(angles, turning[1:], atol=1e-7)
    after = res.t > sticks[-1]
    assert np.all(res["joint.w"][after] == 0.0)
    assert np.ptp(res["joint.phi"][after]) == 0.0


def test_a_sliding_block_rebounds_off_a_stop_and_friction_stops_it():
    """A 1 kg block sliding at −2 m/s on a surface (μk = 0.2, μs = 0.3: deceleration μk·g = 1.962 m/s²)
    hits a stop at s_min = −0.1 m (e = 0.5). The impact throws the relative velocity across 0: friction
    must slide the other way (not stick), so the block rebounds at −e·v₁, slides back and sticks when
    friction has taken its speed, at t₁ − e·v₁/(μk·g), then stays. Times within 1e-9 s, positions 1e-9 m
    (rtol 1e-10, atol 1e-12)."""
    g, mu_k, e = 9.81, 0.2, 0.5
    m = mn.Model("block_stop")
    ground = m.add(tr.Fixed(name="ground"))
    block = m.add(tr.Mass(name="block", m=1.0, s_start=0.0, v_start=-2.0))
    fr = m.add(tr.Friction(name="fr", fn=g, mu_k=mu_k, mu_s=0.3))
    stop = m.add(tr.HardStop(name="stop", s_min=-0.1, s_max=1.0, e=e))
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, block.flange_a)
    m.connect(ground.flange, stop.flange_a)
    m.connect(stop.flange_b, block.flange_b)
    res = mn.compile(m).simulate(2.0, n_out=21, rtol=1e-10, atol=1e-12)
    a = mu_k * g
    t1 = (2.0 - np.sqrt(4.0 - 2 * a * 0.1)) / a              # −0.1 = −2t + a t²/2
    v1 = -2.0 + a * t1
    t2 = t1 + (-e * v1) / a
    s2 = -0.1 + (e * v1) ** 2 / (2 * a)
    hit = next(ev.t for ev in res.events if "hits s_min" in ev.cause)
    assert hit == pytest.approx(t1, abs=1e-9)
    after_hit = np.flatnonzero(res.t == hit)[-1]
    assert res["block.v"][after_hit] == pytest.approx(-e * v1, rel=1e-9)
    stick = [ev.t for ev in res.events if "sticks" in ev.cause and ev.t > hit]
    assert stick[-1] == pytest.approx(t2, abs=1e-9)
    rest = res.t > t2 + 1e-9
    assert np.max(np.abs(res["block.s"][rest] - s2)) <= 1e-9 and np.all(res["block.v"][rest] == 0.0)


def test_an_exported_and_loaded_ball_still_comes_to_rest(tmp_path):
    """kind="casadi" carries the rest transitions: the loaded ball (e = 0.8 from 1 m, rtol 1e-10) rests
    at the accumulation point T∞ = √(2h/g)·(1 + e)/(1 − e) = 4.0637 s (within 1e-3 s) as the native one."""
    from mechnet.export import load
    m = mn.Model("ball")
    floor = m.add(tr.Fixed(name="floor"))
    contact = m.add(tr.Contact(name="contact", e=0.8))
    ball = m.add(tr.Mass(name="ball", m=0.1, s_start=1.0, v_start=0.0))
    gravity = m.add(tr.ConstantForce(name="gravity", f_constant=-0.981))
    m.connect(floor.flange, contact.flange_a)
    m.connect(contact.flange_b, ball.flange_a)
    m.connect(gravity.flange, ball.flange_b)
    loaded = load(mn.compile(m).export(tmp_path / "ball", kind="casadi"))
    res = loaded.simulate(6.0, n_out=61, rtol=1e-10, atol=1e-12)
    assert res.failure is None
    rest = [e.t for e in res.events if e.kind == "rest"]
    t_inf = np.sqrt(2 * 1.0 / 9.81) * 1.8 / 0.2
    assert len(rest) == 1 and rest[0] == pytest.approx(t_inf, abs=1e-3)
    assert np.all(res["contact.mode"][res.t > rest[0]] == -1.0)


def test_an_ocp_refuses_what_it_cannot_smooth_by_name():
    """A stop (rigid impacts) cannot be posed smooth: the problem is refused naming it; so is friction in
    a compiled model that crossed a process boundary (no scene left to compile smooth again)."""
    import pickle

    from mechnet import ocp
    m = mn.Model("pushed_to_stop")
    wall = m.add(tr.Fixed(name="wall"))
    stop = m.add(tr.HardStop(name="stop", s_min=-1.0, s_max=1.0, e=0.5))
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    push = m.add(tr.Force(name="push"))
    m.connect(wall.flange, stop.flange_a)
    m.connect(stop.flange_b, mass.flange_a)
    m.connect(push.flange, mass.flange_b)
    with pytest.raises(mn.OcpError, match=r"stop \(HardStop\) switch modes.*tr.ElastoGap"):
        ocp.Problem(m.compile(), t_final=1.0)
    crossed = pickle.loads(pickle.dumps(pushed_block().compile()))
    with pytest.raises(mn.OcpError, match=r"fr \(Friction\) switch modes"):
        ocp.Problem(crossed, t_final=1.0)


def test_a_block_held_by_stiction_leaves_when_struck():
    """Striker (1 kg, 1 m/s, frictionless) hits an equal block held by stiction (μs = 0.3, μk = 0.2,
    fn = 9.81 N) through a contact with e = 1, 0.4 m apart. Friction carries a bounded force, so no
    impulse: the striker stops and the block leaves at 1 m/s (1e-9), then slides to rest after
    1/(μk·g) s, 1/(2μk·g) m further (1e-9; rtol 1e-10, atol 1e-12)."""
    m = mn.Model("strike")
    ground = m.add(tr.Fixed(name="ground"))
    striker = m.add(tr.Mass(name="striker", m=1.0, s_start=0.0, v_start=1.0))
    target = m.add(tr.Mass(name="target", m=1.0, s_start=0.5, v_start=0.0))
    fr = m.add(tr.Friction(name="fr", fn=9.81, mu_k=0.2, mu_s=0.3))
    contact = m.add(tr.Contact(name="c", e=1.0, s_contact=0.1))
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, target.flange_a)
    m.connect(striker.flange_b, contact.flange_a)
    m.connect(contact.flange_b, target.flange_b)
    res = mn.compile(m).simulate(1.5, n_out=16, rtol=1e-10, atol=1e-12)
    hit = next(e.t for e in res.events if "c hits" in e.cause)
    after = np.flatnonzero(res.t == hit)[-1]
    assert hit == pytest.approx(0.4, abs=1e-9)
    assert res["striker.v"][after] == pytest.approx(0.0, abs=1e-9)
    assert res["target.v"][after] == pytest.approx(1.0, rel=1e-9)
    a = 0.2 * 9.81
    stick = [e.t for e in res.events if "fr sticks" in e.cause][-1]
    assert stick == pytest.approx(hit + 1.0 / a, abs=1e-9)
    assert res["target.s"][-1] == pytest.approx(0.5 + 1.0 / (2 * a), abs=1e-9)


def test_a_body_resting_on_its_stop_is_knocked_off_it():
    """m1 (1 kg) rests on its upper stop at 0.1 m, pressed up by 2 N; m2 (1 kg) comes down at 1 m/s onto
    it (contact e = 1). A stop only pushes: m1 leaves downward at 1 m/s and m2 stops (1e-9), the stop
    free (mode 0) — not a bilateral bond pulling m1 back."""
    m = mn.Model("knock")
    wall = m.add(tr.Fixed(name="wall"))
    stop = m.add(tr.HardStop(name="stop", s_min=-10.0, s_max=0.1, e=1.0))
    m1 = m.add(tr.Mass(name="m1", m=1.0, s_start=0.1, v_start=0.0))
    m2 = m.add(tr.Mass(name="m2", m=1.0, s_start=0.5, v_start=-1.0))
    push = m.add(tr.ConstantForce(name="push", f_constant=2.0))
    contact = m.add(tr.Contact(name="c", e=1.0, s_contact=0.1))
    m.connect(wall.flange, stop.flange_a)
    m.connect(stop.flange_b, m1.flange_a)
    m.connect(push.flange, m1.flange_a)
    m.connect(m1.flange_b, contact.flange_a)
    m.connect(contact.flange_b, m2.flange_b)
    res = mn.compile(m).simulate(0.35, n_out=8, rtol=1e-10, atol=1e-12)
    start = np.flatnonzero(res.t == 0.0)[-1]            # after the event at t = 0: v = 0 on its limit
    assert res["stop.mode"][start] == 1.0                  # resting
    hit = next(e.t for e in res.events if "c hits" in e.cause)
    after = np.flatnonzero(res.t == hit)[-1]
    assert hit == pytest.approx(0.3, abs=1e-9)
    assert res["m1.v"][after] == pytest.approx(-1.0, rel=1e-9) and res["m2.v"][after] == pytest.approx(0.0, abs=1e-9)
    assert res["stop.mode"][after] == 0.0


def test_a_torque_stepping_past_the_static_limit_shows_no_held_torque_above_it():
    """A shaft (J = 0.5) in a bearing holding up to 2 N·m (sliding 1.5 N·m), driven by a torque that
    steps from 0 to 5 N·m at 1 s: it breaks away at that instant (a condition thrown across by a time
    event). The row at 1 s is the right limit, sliding: friction −1.5 N·m, not the 5 N·m the stuck mode
    would need (a state on neither side of the instant). Every row's friction torque stays within the
    static limit; rtol 1e-10."""
    m = mn.Model("bearing")
    shaft = m.add(rot.Inertia(name="shaft", J=0.5, phi_start=0.0, w_start=0.0))
    housing = m.add(rot.Fixed(name="housing"))
    bearing = m.add(rot.BearingFriction(name="bearing", tau_Coulomb=1.5, tau_Stribeck=0.5))
    drive = m.add(rot.Torque(name="drive", tau=Step(5.0, start_time=1.0)))
    m.connect(housing.flange, bearing.flange_a)
    m.connect(bearing.flange_b, shaft.flange_a)
    m.connect(drive.flange, shaft.flange_b)
    res = mn.compile(m).simulate(2.0, n_out=21, rtol=1e-10, atol=1e-12)
    assert res.failure is None
    assert _state_times(res)["bearing breaks away"] == 1.0
    assert np.max(np.abs(res["bearing.tau"])) <= 2.0
    at = np.flatnonzero(res.t == 1.0)
    assert at.size == 1 and abs(res["bearing.tau"][at[0]]) == pytest.approx(1.5, rel=1e-12)


def test_a_table_input_stepping_at_a_time_event_is_judged_at_its_left_limit():
    """The clutch-and-brake scene with the clutch pressed by an input table that jumps at 0.5 s (not a
    Step signal), the brake never pressed: the clutch starts sliding at 0.5 s exactly, as with the
    signal, and the open brake makes no event and carries no torque."""
    cm = _drive(brake_input=0.0)
    res = cm.simulate(1.0, n_out=11, rtol=1e-10, atol=1e-12,
                      inputs={"clutch.f_normalized": ([0.0, 0.5, 0.5, 1.0], [0.0, 0.0, 1.0, 1.0])})
    assert res.failure is None
    state = _state_times(res)
    assert state["clutch starts sliding"] == 0.5
    assert state["clutch sticks"] == pytest.approx(0.75, abs=1e-9)
    assert not [e for e in res.events if e.cause.startswith("brake")]
    assert np.all(res["brake.tau"] == 0.0)


def test_a_tunable_stribeck_speed_of_zero_is_the_step_to_kinetic():
    """v_Stribeck = mn.tunable(0.0) means what the folded 0 means (no NaN from exp(−0/0)): the block on the
    incline slides with a = g(sin θ − μk cos θ) either way (1e-9 relative)."""
    g, theta = 9.81, 0.3
    runs = []
    for v_stribeck in (0.0, mn.tunable(0.0)):
        m = mn.Model("incline")
        block = m.add(tr.Mass(name="block", m=1.0, s_start=0.0, v_start=0.0))
        surface = m.add(tr.Fixed(name="surface"))
        fr = m.add(tr.Friction(name="fr", fn=g * np.cos(theta), mu_k=0.2, mu_s=0.25, v_Stribeck=v_stribeck))
        slope = m.add(tr.ConstantForce(name="slope", f_constant=g * np.sin(theta)))
        m.connect(surface.flange, fr.flange_a)
        m.connect(fr.flange_b, block.flange_a)
        m.connect(slope.flange, block.flange_b)
        runs.append(mn.compile(m).simulate(1.0, n_out=11, rtol=1e-10, atol=1e-12))
    a = g * (np.sin(theta) - 0.2 * np.cos(theta))
    for res in runs:
        assert res.failure is None and res["block.a"][-1] == pytest.approx(a, rel=1e-9)


def test_a_held_element_that_an_impact_leaves_still_keeps_no_speed():
    """A striker at 5e-7 m/s (below v_small = 1e-6) hits a block held by stiction (contact e = 1): the
    freed jump would move the block slower than v_small, so it stays stuck — held rigidly in the impact,
    its speed exactly 0 (no creep over 1000 s, not 5e-4 m)."""
    m = mn.Model("soft_strike")
    ground = m.add(tr.Fixed(name="ground"))
    striker = m.add(tr.Mass(name="striker", m=1.0, s_start=0.0, v_start=5e-7))
    target = m.add(tr.Mass(name="target", m=1.0, s_start=0.5, v_start=0.0))
    fr = m.add(tr.Friction(name="fr", fn=9.81, mu_k=0.2, mu_s=0.3))
    contact = m.add(tr.Contact(name="c", e=1.0, s_contact=0.1))
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, target.flange_a)
    m.connect(striker.flange_b, contact.flange_a)
    m.connect(contact.flange_b, target.flange_b)
    res = mn.compile(m).simulate(0.4 / 5e-7 + 1000.0, n_out=11, rtol=1e-10, atol=1e-12)
    assert any("c hits" in e.cause for e in res.events)
    assert res["fr.mode"][-1] == 0.0 and res["target.v"][-1] == 0.0 and res["target.s"][-1] == 0.5
    assert res["striker.v"][-1] == pytest.approx(-5e-7, rel=1e-9)        # bounced off the held block


def test_a_slow_knock_into_a_resting_stop_keeps_it_resting():
    """m1 rests on its upper stop (v_rest = 0.5 m/s); m2 below pushes it up into the stop at 0.3 m/s:
    slower than v_rest, the stop keeps holding (plastically: m1's speed exactly 0, never past s_max)."""
    m = mn.Model("slow_knock")
    wall = m.add(tr.Fixed(name="wall"))
    stop = m.add(tr.HardStop(name="stop", s_min=-10.0, s_max=0.1, e=1.0, v_rest=0.5))
    m1 = m.add(tr.Mass(name="m1", m=1.0, s_start=0.1, v_start=0.0))
    m2 = m.add(tr.Mass(name="m2", m=1.0, s_start=-0.3, v_start=0.3))
    push = m.add(tr.ConstantForce(name="push", f_constant=2.0))
    contact = m.add(tr.Contact(name="c", e=1.0, s_contact=0.1))
    m.connect(wall.flange, stop.flange_a)
    m.connect(stop.flange_b, m1.flange_a)
    m.connect(push.flange, m1.flange_a)
    m.connect(m2.flange_b, contact.flange_a)
    m.connect(contact.flange_b, m1.flange_b)
    res = mn.compile(m).simulate(3.0, n_out=7, rtol=1e-10, atol=1e-12)
    assert any("c hits" in e.cause for e in res.events)
    assert np.max(res["m1.s"]) <= 0.1 + 1e-12 and res["m1.v"][-1] == 0.0 and res["stop.mode"][-1] == 1.0


@pytest.mark.parametrize("s0, match", [(1.5, r"stop \(HardStop\): the relative position must start at or below s_max "
                                                r"\(it starts 0.5 beyond it\)"),
                                       (-0.25, r"at or above s_min \(it starts 0.25 beyond it\)")])
def test_a_start_outside_the_stops_is_refused_by_name(s0, match):
    """A body started beyond a stop would never meet its impact condition (it starts on the wrong side):
    the start is refused, naming the stop, the limit and by how much."""
    m = mn.Model("outside")
    wall = m.add(tr.Fixed(name="wall"))
    stop = m.add(tr.HardStop(name="stop", s_min=0.0, s_max=1.0, e=0.5))
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=s0, v_start=0.0))
    m.connect(wall.flange, stop.flange_a)
    m.connect(stop.flange_b, mass.flange_a)
    cm = m.compile()
    with pytest.raises(mn.InitializationError, match=match):
        cm.simulate(1.0)
    assert cm.simulate(1.0, start={"mass.s": 0.5}).failure is None          # inside: fine


class _BadJump(tr.PartialOneFlange):
    """A component whose When jumps along a plain Mode (not an Impulse), or rests a state."""

    on = mn.Mode(0.0)
    v = mn.Var(unit="m/s")
    misuse = "jump"

    def equations(self):
        return [mn.Eq(self.v, mn.der(self.flange.s)), mn.Eq(self.flange.f, 0.0)]

    def events(self):
        if self.misuse == "jump":
            return [mn.When(self.flange.s, jump={self.on: (self.v, 0.0)}, direction="falling")]
        return [mn.When(self.flange.s, rest={self.v: 0.0}, direction="falling")]


@pytest.mark.parametrize("misuse, match", [("jump", r"bad \(_BadJump\), event 1: a jump's key must be an Impulse"),
                                           ("rest", r"bad \(_BadJump\), event 1: a rest target must be a Mode")])
def test_a_jump_or_rest_on_the_wrong_kind_of_variable_is_refused_by_name(misuse, match):
    m = mn.Model("bad_jump")
    bad = m.add(_BadJump(name="bad"))
    bad.misuse = misuse
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=1.0, v_start=0.0))
    m.connect(bad.flange, mass.flange_a)
    with pytest.raises(mn.StructureError, match=match):
        m.compile()
