"""One closed-form scenario per multibody component (mechnet.components.multibody).

Conventions: World's default gravity is g = (0, −9.81, 0); a revolute about z measures its angle from
the +x axis (a pendulum hangs at phi = −π/2); frame cut forces are resolved in the frame and positive
into the component; `der(x)` of a state is in the result, evaluated at the integrated state.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ellipk

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.components.signals import Sine

G = 9.81
TIGHT = dict(rtol=1e-10, atol=1e-10)
CLOSE = dict(rtol=1e-12, atol=1e-12)     # for closed forms followed over many periods


def _connect(m, pairs):
    for a, b in pairs:
        m.connect(a, b)


def _vec(res, name):
    return np.vstack([res[f"{name}[{i}]"] for i in range(3)])


def _Rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _Rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _Ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _turning_times(res, speed):
    """Zeros of the angular speed, one Newton step from output points placed at the predicted turning
    points: t* = t − w/der(w). At a turning point d²w/dt² ∝ w = 0, so the step's own error is
    O(δ³) with δ = |t − t*| ~ 1e-9 s: negligible; what is left is the integrator's error."""
    return res.t - res[speed] / res[f"der({speed})"]


# ---- Body: physical pendulum ----------------------------------------------------------------------

BODY_M, BODY_D = 1.5, 0.4
BODY_I = np.array([[0.03, 0.004, 0.006], [0.004, 0.05, -0.002], [0.006, -0.002, 0.04]])   # about the cm


@pytest.mark.parametrize("theta0", [0.002, 0.8])
def test_body_physical_pendulum_period(theta0):
    # cm at d along x (plus an offset along the axis z, which changes nothing), inertia with products:
    # about the axis z through the pivot I_O = I_zz + m d², and T = 4√(I_O/(m g d))·K(sin²(theta0/2)),
    # → 2π√(I_O/(m g d)) for small amplitude.
    m = mn.Model("physical")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=-np.pi / 2 + theta0, w_start=0.0))
    body = m.add(mb.Body(name="body", m=BODY_M, r_cm=[BODY_D, 0, 0.25], I=BODY_I))
    _connect(m, [(world.frame_b, rev.frame_a), (rev.frame_b, body.frame_a)])
    cm = m.compile()
    I_O = BODY_I[2, 2] + BODY_M * BODY_D ** 2
    T_small = 2 * np.pi * np.sqrt(I_O / (BODY_M * G * BODY_D))
    T = 4 * np.sqrt(I_O / (BODY_M * G * BODY_D)) * ellipk(np.sin(theta0 / 2) ** 2)
    res = cm.simulate(2 * T, t_out=[0.0, T / 2, T, 2 * T], rtol=1e-12, atol=1e-12)
    assert res.success
    periods = _turning_times(res, "rev.w")[1:] / np.array([0.5, 1.0, 2.0])
    # exact period: 1e-8 relative at rtol = atol = 1e-12, horizon 2 periods (2.9 s), scale T = 1.37 / 1.43 s;
    # measured 1.1e-9 / 7.7e-12
    assert np.max(np.abs(periods - T)) <= 1e-8 * T
    if theta0 < 0.01:
        # small-amplitude formula: 1e-6 relative (its own error theta0²/16 = 2.5e-7)
        assert np.max(np.abs(periods - T_small)) <= 1e-6 * T_small
    # the point-mass period (I_O = m d²) differs by 7 %: the body's own inertia is not ignored
    assert abs(2 * np.pi * np.sqrt(BODY_D / G) - T_small) > 0.05 * T_small


# ---- Prismatic with line springs and dampers ----------------------------------------------------

def _slider(element, s0, v0, mass=2.0):
    """A mass on a prismatic joint along x from the world origin, a line element from the origin to the
    mass (the line stays on +x). Gravity along −y is perpendicular to the joint: it does no work."""
    m = mn.Model("slider")
    world = m.add(mb.World(name="world"))
    pri = m.add(mb.Prismatic(name="pri", n=[1, 0, 0], s_start=s0, v_start=v0))
    pt = m.add(mb.Particle(name="pt", m=mass))
    el = m.add(element)
    _connect(m, [(world.frame_b, pri.frame_a), (pri.frame_b, pt.frame_a),
                 (world.frame_b, el.frame_a), (pri.frame_b, el.frame_b)])
    return m.compile()


def test_prismatic_with_spring_is_harmonic():
    c, mass, s_un, s0 = 50.0, 2.0, 0.5, 0.8
    cm = _slider(mb.Spring(name="spring", c=c, s_unstretched=s_un), s0, 0.0, mass)
    res = cm.simulate(5.0, n_out=501, **CLOSE)
    assert res.success
    w = np.sqrt(c / mass)
    # s = s_un + (s0 − s_un) cos ωt: rtol = atol = 1e-12, horizon 5 s (4 periods), scale 0.3 m: atol 5e-9
    # (measured 5.2e-10; BDF's global error grows to ~500·rtol here)
    assert np.max(np.abs(res["pri.s"] - (s_un + (s0 - s_un) * np.cos(w * res.t)))) < 5e-9
    assert np.max(np.abs(res["pri.v"] + (s0 - s_un) * w * np.sin(w * res.t))) < 3e-8      # scale 1.5 m/s (2.5e-9)
    # the spring's length and force (observed): s = |r|, f = c (s − s_un); round-off, atol 1e-12
    assert np.max(np.abs(res["spring.s"] - res["pri.s"])) < 1e-12
    assert np.max(np.abs(res["spring.f"] - c * (res["pri.s"] - s_un))) < 1e-10


def test_line_damper_exponential_decay():
    d, mass, s0, v0 = 0.8, 2.0, 1.0, 0.5
    cm = _slider(mb.Damper(name="damper", d=d), s0, v0, mass)
    res = cm.simulate(5.0, n_out=201, **CLOSE)
    assert res.success
    k = d / mass
    # v = v0 e^{−kt}, s = s0 + v0/k (1 − e^{−kt}): rtol = atol = 1e-12, horizon 5 s, scale 2 m, 0.5 m/s:
    # atol 2e-10 (measured 1e-11 and 2.4e-11)
    assert np.max(np.abs(res["pri.v"] - v0 * np.exp(-k * res.t))) < 2e-10
    assert np.max(np.abs(res["pri.s"] - (s0 + v0 / k * (1 - np.exp(-k * res.t))))) < 2e-10


def test_line_spring_damper_underdamped():
    c, d, mass, s_un, s0, v0 = 50.0, 1.2, 2.0, 0.5, 0.8, -0.4
    cm = _slider(mb.SpringDamper(name="sd", c=c, d=d, s_unstretched=s_un), s0, v0, mass)
    res = cm.simulate(4.0, n_out=401, **CLOSE)
    assert res.success
    w0, zeta = np.sqrt(c / mass), d / (2 * np.sqrt(c * mass))
    wd, t = w0 * np.sqrt(1 - zeta ** 2), res.t
    x0 = s0 - s_un
    x = np.exp(-zeta * w0 * t) * (x0 * np.cos(wd * t) + (v0 + zeta * w0 * x0) / wd * np.sin(wd * t))
    # underdamped closed form: rtol = atol = 1e-12, horizon 4 s (3 periods), scale 0.3 m: atol 3e-9 (measured 2.5e-10)
    assert np.max(np.abs(res["pri.s"] - (s_un + x))) < 3e-9
    assert zeta == pytest.approx(0.06)        # visibly damped: amplitude e^{−ζω₀·4 s} = 0.30 at the end


# ---- WorldForce and WorldTorque ------------------------------------------------------------------

@pytest.mark.parametrize("resolve_in", ["world", "frame_b"])
def test_world_force_on_rotated_prismatic(resolve_in):
    # World (no gravity) → FixedRotation (0.6 rad about z) → Prismatic along its x → mass with a force.
    # In world components the force's share along the axis (cos a, sin a, 0) drives the mass; resolved in
    # frame_b (whose x is the axis) it is the force's x entry.
    alpha, mass, F = 0.6, 2.0, np.array([2.0, 1.0, 3.0])
    m = mn.Model("push")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    fr = m.add(mb.FixedRotation(name="fr", n=[0, 0, 1], angle=alpha))
    pri = m.add(mb.Prismatic(name="pri", n=[1, 0, 0], s_start=0.0, v_start=0.0))
    pt = m.add(mb.Particle(name="pt", m=mass))
    force = m.add(mb.WorldForce(name="force", force=F.tolist(), resolve_in=resolve_in))
    _connect(m, [(world.frame_b, fr.frame_a), (fr.frame_b, pri.frame_a), (pri.frame_b, pt.frame_a),
                 (pri.frame_b, force.frame_b)])
    res = m.compile().simulate(2.0, n_out=21, **TIGHT)
    assert res.success
    along = F @ np.array([np.cos(alpha), np.sin(alpha), 0.0]) if resolve_in == "world" else F[0]
    # s = F_axis t²/(2m): rtol = atol = 1e-10, horizon 2 s, scale 2.2 m: atol 1e-9
    assert np.max(np.abs(res["pri.s"] - along * res.t ** 2 / (2 * mass))) < 1e-9
    # the particle moves along the rotated axis in world
    r = _vec(res, "pt.frame_a.r_0")
    assert np.max(np.abs(r - np.outer([np.cos(alpha), np.sin(alpha), 0.0], res["pri.s"]))) < 1e-12


def test_world_torque_on_revolute():
    # A torque (0.7, −0.3, 1.2) N·m on a body whose cm is on the joint axis z (I_zz = 0.4): only the z
    # share turns it, phi = phi0 + w0 t + τ_z t²/(2 I_zz); gravity acts at the axis (no torque).
    I = np.diag([0.2, 0.3, 0.4])
    tau = np.array([0.7, -0.3, 1.2])
    m = mn.Model("twist")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=0.1, w_start=-0.2))
    body = m.add(mb.Body(name="body", m=3.0, I=I))
    torque = m.add(mb.WorldTorque(name="torque", torque=tau.tolist()))
    _connect(m, [(world.frame_b, rev.frame_a), (rev.frame_b, body.frame_a), (rev.frame_b, torque.frame_b)])
    res = m.compile().simulate(2.0, n_out=21, **TIGHT)
    assert res.success
    t = res.t
    # rtol = atol = 1e-10, horizon 2 s, scale 6 rad: atol 1e-8
    assert np.max(np.abs(res["rev.phi"] - (0.1 - 0.2 * t + tau[2] * t ** 2 / (2 * I[2, 2])))) < 1e-8
    # the world holds the weight and the torque's x, y shares (frame_a is the world frame): observed, the
    # body spins about a principal axis so no gyroscopic torque; atol 1e-10 at scale 29 N, 0.7 N·m
    assert np.max(np.abs(_vec(res, "rev.frame_a.f") - np.array([[0.0], [3.0 * G], [0.0]]))) < 1e-10
    assert np.max(np.abs(_vec(res, "rev.frame_a.t") - np.array([[-tau[0]], [-tau[1]], [0.0]]))) < 1e-10


# ---- FixedRotation, Weld, reversed wiring: the same pendulum seen differently -------------------

def _pendulum(theta0=0.6, w0=0.0, L=0.8, mass=1.3, g=(0.0, -G, 0.0), rotation=None, weld=False,
              reversed_joint=False, cut=False):
    m = mn.Model("pendulum")
    world = m.add(mb.World(name="world", g=list(g)))
    phi0 = -np.pi / 2 + theta0
    sign = -1.0 if reversed_joint else 1.0
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=sign * phi0, w_start=sign * w0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[L, 0, 0]))
    pt = m.add(mb.Particle(name="pt", m=mass))
    base = world.frame_b
    if rotation is not None:
        fr = m.add(mb.FixedRotation(name="fr", n=rotation[0], angle=rotation[1]))
        m.connect(base, fr.frame_a)
        base = fr.frame_b
    if weld:
        w1 = m.add(mb.Weld(name="weld1"))
        m.connect(base, w1.frame_a)
        base = w1.frame_b
    if reversed_joint:           # the world side on frame_b: frame_a turns by −phi relative to it
        _connect(m, [(base, rev.frame_b), (rev.frame_a, rod.frame_a)])
    else:
        _connect(m, [(base, rev.frame_a), (rev.frame_b, rod.frame_a)])
    tip = rod.frame_b
    if weld:
        w2 = m.add(mb.Weld(name="weld2"))
        m.connect(tip, w2.frame_a)
        tip = w2.frame_b
    if cut:
        sensor = m.add(mb.CutForceTorque(name="cut"))
        m.connect(tip, sensor.frame_a)
        tip = sensor.frame_b
    m.connect(tip, pt.frame_a)
    return m.compile()


PEND_GRID = np.linspace(0.0, 3.0, 61)


def _plain_pendulum_result(**kw):
    return _pendulum(**kw).simulate(PEND_GRID[-1], t_out=PEND_GRID, **TIGHT)


def test_fixed_rotation_about_gravity_rotates_the_motion():
    # Turning the pendulum's plane about the vertical (y) by 0.7 rad changes nothing but the plane:
    # same angle history, positions rotated by Ry(0.7).
    plain = _plain_pendulum_result()
    res = _pendulum(rotation=([0, 1, 0], 0.7)).simulate(PEND_GRID[-1], t_out=PEND_GRID, **TIGHT)
    assert res.success and plain.success
    # same ODE integrated twice: rtol = atol = 1e-10, horizon 3 s, scale 1 rad: atol 1e-8
    assert np.max(np.abs(res["rev.phi"] - plain["rev.phi"])) < 1e-8
    assert np.max(np.abs(_vec(res, "pt.frame_a.r_0") - _Ry(0.7) @ _vec(plain, "pt.frame_a.r_0"))) < 1e-8
    assert np.max(np.abs(_vec(res, "pt.frame_a.r_0")[2])) > 0.1      # really out of the x-y plane


def test_fixed_rotation_tilting_the_plane_reduces_gravity():
    # Tilted by a = 0.5 rad about x, the pendulum's plane sees g·cos(a) along its −y axis: the motion is
    # the plain pendulum's under gravity g·cos(a), and energy gives w² = (2 g cos a / L)(sin phi0 − sin phi).
    a, L, theta0 = 0.5, 0.8, 0.6
    res = _pendulum(rotation=([1, 0, 0], a), L=L, theta0=theta0).simulate(PEND_GRID[-1], t_out=PEND_GRID,
                                                                          **CLOSE)
    ref = _pendulum(g=(0.0, -G * np.cos(a), 0.0), L=L, theta0=theta0).simulate(PEND_GRID[-1], t_out=PEND_GRID,
                                                                              **CLOSE)
    assert res.success and ref.success
    # rtol = atol = 1e-12, horizon 3 s (about 2 periods), scale 1 rad: atol 1e-9 (measured 4e-13)
    assert np.max(np.abs(res["rev.phi"] - ref["rev.phi"])) < 1e-9
    phi0 = -np.pi / 2 + theta0
    w2 = 2 * G * np.cos(a) / L * (np.sin(phi0) - np.sin(res["rev.phi"]))
    # the energy integral: scale w² ~ 3 rad²/s², atol 3e-8 (measured 2.4e-9); with g instead of g·cos(a)
    # the two sides would differ by up to 0.5 rad²/s²
    assert np.max(np.abs(res["rev.w"] ** 2 - w2)) < 3e-8
    assert np.max(np.abs(_vec(res, "pt.frame_a.r_0") - _Rx(a) @ _vec(ref, "pt.frame_a.r_0"))) < 1e-8


def test_weld_is_rigid_and_transparent():
    theta0, L = 0.6, 0.8
    plain = _plain_pendulum_result(theta0=theta0, L=L)
    res = _pendulum(theta0=theta0, L=L, weld=True).simulate(PEND_GRID[-1], t_out=PEND_GRID, **TIGHT)
    assert res.success
    # welds add no state and no motion (same ODE: atol 1e-10 at scale 1 rad over 3 s)
    assert _pendulum(weld=True).state_names == ("rev.phi", "rev.w")
    assert np.max(np.abs(res["rev.phi"] - plain["rev.phi"])) < 1e-10
    for w in ("weld1", "weld2"):      # both sides coincide: origin and orientation (round-off)
        assert np.max(np.abs(_vec(res, f"{w}.frame_a.r_0") - _vec(res, f"{w}.frame_b.r_0"))) < 1e-14
        for i in range(9):
            assert np.max(np.abs(res[f"{w}.frame_a.R[{i}]"] - res[f"{w}.frame_b.R[{i}]"])) < 1e-14
    # the exact elliptic period with the welds in the chain (1e-8 relative, rtol = atol = 1e-12)
    T = 4 * np.sqrt(L / G) * ellipk(np.sin(theta0 / 2) ** 2)
    r = _pendulum(theta0=theta0, L=L, weld=True).simulate(T, t_out=[0.0, T / 2, T], rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(_turning_times(r, "rev.w")[1:] / np.array([0.5, 1.0]) - T)) <= 1e-8 * T


def test_reversed_joint_mirrors_the_angle():
    # World on rev.frame_b: the link hangs from frame_a, turned by −phi. Started at −phi0, −w0 the angle is
    # the mirror image of the normally wired pendulum and the particle moves identically.
    plain = _plain_pendulum_result(theta0=0.6, w0=1.5)
    res = _pendulum(theta0=0.6, w0=1.5, reversed_joint=True).simulate(PEND_GRID[-1], t_out=PEND_GRID, **TIGHT)
    assert res.success
    # same dynamics up to the sign of the coordinate: rtol = atol = 1e-10, horizon 3 s, scale 2 rad: atol 1e-8
    assert np.max(np.abs(res["rev.phi"] + plain["rev.phi"])) < 1e-8
    assert np.max(np.abs(res["rev.w"] + plain["rev.w"])) < 1e-7
    assert np.max(np.abs(_vec(res, "pt.frame_a.r_0") - _vec(plain, "pt.frame_a.r_0"))) < 1e-8
    assert np.max(np.abs(res["rev.phi"] - plain["rev.phi"])) > 1.0       # the mirror is not the identity


# ---- CutForceTorque and joint reactions ---------------------------------------------------------

def test_cut_force_of_a_hanging_mass():
    # At rest at the bottom the rod carries the weight m g: in the sensor's frame (x along the rod, pointing
    # away from the pivot) the force from the rod onto the mass is −m g along x; the world pushes the joint
    # up with m g.
    mass, L = 1.3, 0.8
    res = _pendulum(theta0=0.0, L=L, mass=mass, cut=True).simulate(2.0, n_out=11, **TIGHT)
    assert res.success
    # stays at rest (equilibrium; atol 1e-12 rad)
    assert np.max(np.abs(res["rev.phi"] + np.pi / 2)) < 1e-12
    # observed, round-off: atol 1e-10 at scale m g = 12.8 N
    assert np.max(np.abs(_vec(res, "cut.f") - np.array([[-mass * G], [0.0], [0.0]]))) < 1e-10
    assert np.max(np.abs(_vec(res, "cut.t"))) < 1e-10
    assert np.max(np.abs(_vec(res, "rev.frame_a.f") - np.array([[0.0], [mass * G], [0.0]]))) < 1e-10


def test_cut_force_of_a_spinning_mass_is_centripetal():
    # No gravity, spinning at constant w: the rod pulls the mass inwards with m w² L.
    mass, L, w = 1.3, 0.8, 3.0
    res = _pendulum(theta0=0.0, w0=w, L=L, mass=mass, g=(0.0, 0.0, 0.0), cut=True).simulate(2.0, n_out=41, **TIGHT)
    assert res.success
    assert np.max(np.abs(res["rev.w"] - w)) < 1e-10           # no torque: constant speed
    Fc = mass * w ** 2 * L                                     # 9.36 N
    # observed, round-off: atol 1e-10 at scale 9.4 N
    assert np.max(np.abs(_vec(res, "cut.f") - np.array([[-Fc], [0.0], [0.0]]))) < 1e-10
    # the joint's reaction in world axes points from the pivot away from the mass: −Fc (cos phi, sin phi, 0)
    phi = res["rev.phi"]
    want = -Fc * np.vstack([np.cos(phi), np.sin(phi), 0 * phi])
    assert np.max(np.abs(_vec(res, "rev.frame_a.f") - want)) < 1e-9


# ---- RelativePosition, RelativeVelocity ----------------------------------------------------------

def test_relative_position_and_velocity_in_a_moving_frame():
    # Double pendulum (lengths 1.0, 0.7); sensors from the elbow frame (rod1.frame_b, turned by phi1) to the
    # tip: r_rel = L2 (cos phi2, sin phi2, 0) in elbow axes; v_rel is the world derivative of the difference,
    # resolved in elbow axes: L2 (w1 + w2)(−sin phi2, cos phi2, 0).
    L1, L2 = 1.0, 0.7
    m = mn.Model("relative")
    world = m.add(mb.World(name="world"))
    r1 = m.add(mb.Revolute(name="rev1", phi_start=0.3, w_start=1.0))
    t1 = m.add(mb.FixedTranslation(name="rod1", r=[L1, 0, 0]))
    p1 = m.add(mb.Particle(name="p1", m=1.0))
    r2 = m.add(mb.Revolute(name="rev2", phi_start=-0.8, w_start=0.5))
    t2 = m.add(mb.FixedTranslation(name="rod2", r=[L2, 0, 0]))
    p2 = m.add(mb.Particle(name="p2", m=0.6))
    pos = m.add(mb.RelativePosition(name="pos"))
    vel = m.add(mb.RelativeVelocity(name="vel"))
    _connect(m, [(world.frame_b, r1.frame_a), (r1.frame_b, t1.frame_a), (t1.frame_b, p1.frame_a),
                 (t1.frame_b, r2.frame_a), (r2.frame_b, t2.frame_a), (t2.frame_b, p2.frame_a),
                 (t1.frame_b, pos.frame_a), (t2.frame_b, pos.frame_b),
                 (t1.frame_b, vel.frame_a), (t2.frame_b, vel.frame_b)])
    cm = m.compile()
    assert cm.n_states == 4                  # the sensors add nothing to integrate
    res = cm.simulate(3.0, n_out=61, **TIGHT)
    assert res.success
    phi2, w1, w2 = res["rev2.phi"], res["rev1.w"], res["rev2.w"]
    zero = 0 * phi2
    # observed expressions of the states: round-off only, atol 1e-12 (scale 0.7 m) and 1e-11 (scale ~10 m/s)
    assert np.max(np.abs(_vec(res, "pos.r_rel") - L2 * np.vstack([np.cos(phi2), np.sin(phi2), zero]))) < 1e-12
    want_v = L2 * (w1 + w2) * np.vstack([-np.sin(phi2), np.cos(phi2), zero])
    assert np.max(np.abs(_vec(res, "vel.v_rel") - want_v)) < 1e-11
    # not the same as the velocity relative to the moving frame, L2·w2·(…): the test tells them apart
    assert np.max(np.abs(w1)) > 0.5


# ---- SystemMomentum: torque-free rotation ----------------------------------------------------------

def test_system_momentum_free_rotation():
    # A body with an asymmetric, non-principal inertia on a z-y-x gimbal of three revolutes whose axes meet
    # at its mass centre: the massless gimbal applies no torque about the centre, so the body rotates
    # torque-free — its angular momentum about the centre is constant in world (Euler's equations),
    # energy is constant, and the linear momentum is zero.
    Q = _Rz(0.05) @ _Ry(0.2) @ _Rx(0.1)
    I = Q @ np.diag([3.0, 2.0, 1.0]) @ Q.T
    m = mn.Model("gimbal")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    m.add(mb.SystemEnergy(name="energy"))
    m.add(mb.SystemMomentum(name="mom", point=[0.0, 0.0, 0.0]))
    j1 = m.add(mb.Revolute(name="j1", n=[0, 0, 1], phi_start=0.2, w_start=0.3))
    j2 = m.add(mb.Revolute(name="j2", n=[0, 1, 0], phi_start=-0.1, w_start=0.2))
    j3 = m.add(mb.Revolute(name="j3", n=[1, 0, 0], phi_start=0.0, w_start=5.0))
    body = m.add(mb.Body(name="body", m=2.0, I=I))
    _connect(m, [(world.frame_b, j1.frame_a), (j1.frame_b, j2.frame_a), (j2.frame_b, j3.frame_a),
                 (j3.frame_b, body.frame_a)])
    res = m.compile().simulate(10.0, n_out=1001, **TIGHT)
    assert res.success
    L = _vec(res, "mom.L")
    # L at t = 0 from the start values: R = Rz(0.2) Ry(−0.1), ω = 0.3 z + 0.2 Rz(0.2) y + 5 R x (round-off)
    R = _Rz(0.2) @ _Ry(-0.1)
    omega = 0.3 * np.array([0, 0, 1.0]) + 0.2 * _Rz(0.2) @ np.array([0, 1.0, 0]) + 5.0 * R @ np.array([1.0, 0, 0])
    L0 = R @ I @ R.T @ omega
    assert np.max(np.abs(L[:, 0] - L0)) < 1e-12
    # conserved: rtol = atol = 1e-10, horizon 10 s (8 turns of the spin), scale |L| = 14.7 kg·m²/s;
    # 1e-7 relative (measured 2.8e-8, energy 5.1e-8)
    assert np.max(np.abs(L - L0[:, None])) <= 1e-7 * np.linalg.norm(L0)
    E = res["energy.total"]
    assert np.max(np.abs(E - E[0])) <= 1e-7 * E[0]
    assert np.max(np.abs(_vec(res, "mom.p"))) < 1e-12
    # a real tumble: the gimbal angle j2 wobbles by ±0.3 rad and L is not along the spin axis j3
    assert np.ptp(res["j2.phi"]) > 0.4


# ---- World(point_gravity=True) ---------------------------------------------------------------------

def test_point_gravity_field_orbit():
    mue, r0 = 2.0, 1.5
    x0 = r0 * np.array([0.6, 0.0, 0.8])
    v0 = np.sqrt(mue / r0) * np.array([0.0, 1.0, 0.0])
    m = mn.Model("satellite")
    world = m.add(mb.World(name="world", point_gravity=True, mue=mue))
    m.add(mb.SystemEnergy(name="energy"))
    joints = [m.add(mb.Prismatic(name=f"p{c}", n=n, s_start=x0[k], v_start=v0[k]))
              for k, (c, n) in enumerate(zip("xyz", np.eye(3).tolist()))]
    sat = m.add(mb.Particle(name="sat", m=0.1))
    _connect(m, [(world.frame_b, joints[0].frame_a), (joints[0].frame_b, joints[1].frame_a),
                 (joints[1].frame_b, joints[2].frame_a), (joints[2].frame_b, sat.frame_a)])
    cm = m.compile()
    T = 2 * np.pi * np.sqrt(r0 ** 3 / mue)
    res = cm.simulate(T, n_out=201, rtol=1e-12, atol=1e-14)
    assert res.success
    # initial acceleration −mue r/|r|³ (observed at the start values, round-off: atol 1e-13 at scale 0.89 m/s²)
    acc = np.array([res[f"der(p{c}.v)"][0] for c in "xyz"])
    assert np.max(np.abs(acc + mue * x0 / r0 ** 3)) < 1e-13
    # circular for a whole orbit: radius 1e-8 relative at rtol 1e-12, atol 1e-14, horizon one period (8.2 s),
    # scale r0 = 1.5 m (measured 8.8e-10)
    pos = np.vstack([res["px.s"], res["py.s"], res["pz.s"]])
    assert np.max(np.abs(np.linalg.norm(pos, axis=0) - r0)) <= 1e-8 * r0
    # back at the start after one Kepler period 2π√(r0³/mue): 1e-8 relative to r0 (measured 4.0e-9)
    assert np.max(np.abs(pos[:, -1] - x0)) <= 1e-8 * r0
    # energy with the point potential −mue m/|r|: −mue m/(2 r0), conserved to 1e-8 relative (measured 8.7e-10)
    E = res["energy.total"]
    assert E[0] == pytest.approx(-mue * 0.1 / (2 * r0), rel=1e-12)
    assert np.max(np.abs(E - E[0])) <= 1e-8 * abs(E[0])


# ---- joints driven through their flanges ----------------------------------------------------------

def test_prismatic_use_flange_with_constant_force():
    # A vertical prismatic (n = y) pushed up by 30 N through its axis flange, support fixed: a = F/m − g.
    F, mass = 30.0, 2.0
    m = mn.Model("lift")
    world = m.add(mb.World(name="world"))
    pri = m.add(mb.Prismatic(name="pri", n=[0, 1, 0], use_flange=True, s_start=0.2, v_start=-1.0))
    pt = m.add(mb.Particle(name="pt", m=mass))
    fixed = m.add(tr.Fixed(name="fixed"))
    push = m.add(tr.ConstantForce(name="push", f_constant=F))
    _connect(m, [(world.frame_b, pri.frame_a), (pri.frame_b, pt.frame_a), (pri.support, fixed.flange),
                 (pri.axis, push.flange)])
    res = m.compile().simulate(2.0, n_out=21, **TIGHT)
    assert res.success
    a = F / mass - G                                     # 5.19 m/s²
    t = res.t
    # s = s0 + v0 t + a t²/2: rtol = atol = 1e-10, horizon 2 s, scale 8.6 m: atol 1e-8
    assert np.max(np.abs(res["pri.s"] - (0.2 - t + a * t ** 2 / 2))) < 1e-8
    # the drive force is F and the support takes −F (observed, round-off; scale 30 N)
    assert np.max(np.abs(res["pri.f"] - F)) < 1e-12
    assert np.max(np.abs(res["pri.support.f"] + F)) < 1e-12


def _driven_link(source, L=0.7, mass=2.0):
    m = mn.Model("driven")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], use_flange=True))
    rod = m.add(mb.FixedTranslation(name="rod", r=[L, 0, 0]))
    pt = m.add(mb.Particle(name="pt", m=mass))
    fixed = m.add(rot.Fixed(name="fixed"))
    src = m.add(source)
    _connect(m, [(world.frame_b, rev.frame_a), (rev.frame_b, rod.frame_a), (rod.frame_b, pt.frame_a),
                 (rev.support, fixed.flange), (rev.axis, src.flange)])
    return m.compile()


@pytest.mark.parametrize("kind", ["position", "speed"])
def test_prescribed_motion_needs_the_inverse_dynamics_torque(kind):
    # Prescribed motion of a point mass m at L: the joint torque is τ = m L² φ̈ + m g L cos φ (gravity −y).
    L, mass, A, f, phi_c = 0.7, 2.0, 0.5, 0.7, 0.2
    om = 2 * np.pi * f
    if kind == "position":
        src = rot.Position(name="src", phi_ref=Sine(A, f, offset=phi_c))                # φ = φc + A sin ωt
    else:
        src = rot.Speed(name="src", w_ref=Sine(A * om, f, phase=np.pi / 2), phi_start=phi_c)   # φ̇ = Aω cos ωt
    cm = _driven_link(src, L, mass)
    assert cm.n_states == (0 if kind == "position" else 1)
    res = cm.simulate(3.0, n_out=301, **CLOSE)
    assert res.success
    t = res.t
    phi = phi_c + A * np.sin(om * t)
    phi_dd = -A * om ** 2 * np.sin(om * t)
    # the prescribed angle (position: algebraic, round-off; speed: integrated, rtol = atol = 1e-12 over 3 s,
    # scale 0.7 rad: atol 3e-9, measured 3.1e-10)
    assert np.max(np.abs(res["rev.phi"] - phi)) < 3e-9
    tau = mass * L ** 2 * phi_dd + mass * G * L * np.cos(phi)
    scale = np.max(np.abs(tau))                                   # ~15 N·m
    # drive torque of the joint and the torque the source delivers (−cut torque into it): 1e-6 relative to the
    # amplitude (observed expressions; for the speed source they follow the integrated angle, error ~1e-9)
    assert np.max(np.abs(res["rev.tau"] - tau)) <= 1e-6 * scale
    assert np.max(np.abs(-res["src.flange.tau"] - tau)) <= 1e-6 * scale
    assert np.max(np.abs(res["rev.support.tau"] + tau)) <= 1e-6 * scale
