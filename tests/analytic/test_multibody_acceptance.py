"""Acceptance tests of the 3D multibody components (the issue's list), each against an independent reference.

1. simple pendulum (World + Revolute + FixedTranslation + Particle): period against 2π√(L/g) and
   the exact elliptic-integral period;
2. planar double pendulum from 3D components: explicit ODE with 4 states, energy drift against a
   hand-written CasADi model integrated with the same CVODES settings;
3. a joint driven through its flange by a geared motor: reflected inertia J·ratio²;
4. a particle on three prismatic joints orbiting a fixed mass (Gravitation): circular orbit,
   Kepler's third law, energy and angular momentum;
5. `mn.kinematics` of a spatial 3-link arm against forward kinematics written out in numpy;
6. the compiled N-link chain grows linearly in N.

Conventions used below: World's default gravity is g = (0, −9.81, 0); a revolute about z measures
its angle from the +x axis, so a pendulum hangs at phi = −π/2.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.special import ellipk

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot

G = 9.81


def _connect(m, pairs):
    for a, b in pairs:
        m.connect(a, b)


# ---- 1. simple pendulum ---------------------------------------------------------------------------

def _simple_pendulum(theta0, L=1.0, mass=1.0):
    """Released from rest at theta0 from the hanging position (phi = −π/2 + theta0)."""
    m = mn.Model("pendulum")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=-np.pi / 2 + theta0, w_start=0.0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[L, 0, 0]))
    pt = m.add(mb.Particle(name="pt", m=mass))
    _connect(m, [(world.frame_b, rev.frame_a), (rev.frame_b, rod.frame_a), (rod.frame_b, pt.frame_a)])
    return m.compile()


def _elliptic_period(theta0, L=1.0, g=G):
    """Exact period of a point-mass pendulum: 4√(L/g)·K(k), k = sin(theta0/2); SciPy's ellipk takes m = k²."""
    return 4 * np.sqrt(L / g) * ellipk(np.sin(theta0 / 2) ** 2)


def _turning_times(res, speed="rev.w"):
    """Times where the angular speed is exactly zero, refined from each output point by one Newton step.

    The outputs are placed at the predicted turning points, so w is tiny there; w(t) has a simple zero at
    the true turning time t* with dw/dt = der(w) read from the result (the right-hand side at the
    integrated state, no finite differences). At a turning point d²w/dt² = (g/L)·sin(phi)·w = 0, so
    t* = t − w/der(w) has error ~ |w'''|·δ³/(6|der(w)|) with δ = |t − t*| ≲ 1e-8 s: ~1e-24 s, far below
    any tolerance here. The remaining error is the integrator's.
    """
    return res.t - res[speed] / res[f"der({speed})"]


@pytest.mark.parametrize("amplitude_deg", [0.2, 170.0])
def test_simple_pendulum_period(amplitude_deg):
    theta0 = np.radians(amplitude_deg)
    cm = _simple_pendulum(theta0)
    assert cm.state_names == ("rev.phi", "rev.w") and cm.dae.z.numel() == 0
    T = _elliptic_period(theta0)
    # outputs at the predicted half and full period, and after 3 periods
    res = cm.simulate(3 * T, t_out=[0.0, T / 2, T, 2 * T, 3 * T], rtol=1e-12, atol=1e-12)
    assert res.success
    t_star = _turning_times(res)[1:]
    periods = t_star / np.array([0.5, 1.0, 2.0, 3.0])
    # at the half period the pendulum is at the other extreme: phi = −π/2 − theta0 (atol 1e-9 rad at
    # rtol = atol = 1e-12; the residual |w| there is ~1e-9 rad/s, so phi is off by O(w²) only)
    assert res["rev.phi"][1] == pytest.approx(-np.pi / 2 - theta0, abs=1e-9)
    # exact period (elliptic integral): 1e-8 relative at rtol = atol = 1e-12 over 3 periods (up to 14.7 s),
    # scale T = 2.0 s (0.2°) and 4.9 s (170°). Measured 2.7e-10 and 6.7e-10.
    assert np.max(np.abs(periods - T)) <= 1e-8 * T
    if amplitude_deg < 1:
        # small-amplitude period 2π√(L/g): 1e-6 relative. The finite-amplitude correction itself is
        # theta0²/16 = 7.6e-7 at 0.2°, so this bound is the physics' own margin, not the solver's.
        T0 = 2 * np.pi * np.sqrt(1.0 / G)
        assert np.max(np.abs(periods - T0)) <= 1e-6 * T0
    else:
        # the 170° period is far from the linear one (factor 2.44): the elliptic test is not vacuous
        assert T > 2.4 * 2 * np.pi * np.sqrt(1.0 / G)


# ---- 2. double pendulum ---------------------------------------------------------------------------

M1, M2, L1, L2 = 1.0, 1.0, 1.0, 1.0
PHI1, PHI2 = 0.5, 0.0             # arm 1 0.5 rad above horizontal, arm 2 straight on (relative angle 0)
DP_TOL = dict(rtol=1e-10, atol=1e-10)
DP_GRID = np.linspace(0.0, 100.0, 2001)


def _double_pendulum():
    m = mn.Model("double_pendulum")
    world = m.add(mb.World(name="world"))
    m.add(mb.SystemEnergy(name="energy"))
    r1 = m.add(mb.Revolute(name="rev1", n=[0, 0, 1], phi_start=PHI1, w_start=0.0))
    t1 = m.add(mb.FixedTranslation(name="rod1", r=[L1, 0, 0]))
    p1 = m.add(mb.Particle(name="p1", m=M1))
    r2 = m.add(mb.Revolute(name="rev2", n=[0, 0, 1], phi_start=PHI2, w_start=0.0))
    t2 = m.add(mb.FixedTranslation(name="rod2", r=[L2, 0, 0]))
    p2 = m.add(mb.Particle(name="p2", m=M2))
    _connect(m, [(world.frame_b, r1.frame_a), (r1.frame_b, t1.frame_a), (t1.frame_b, p1.frame_a),
                 (t1.frame_b, r2.frame_a), (r2.frame_b, t2.frame_a), (t2.frame_b, p2.frame_a)])
    return m.compile()


def _energy_absolute(th1, th2, w1, w2):
    """Energy of the double pendulum in absolute angles from +x (y up, g along −y)."""
    T = 0.5 * M1 * L1 ** 2 * w1 ** 2 + 0.5 * M2 * (L1 ** 2 * w1 ** 2 + L2 ** 2 * w2 ** 2
                                                  + 2 * L1 * L2 * w1 * w2 * np.cos(th1 - th2))
    V = M1 * G * L1 * np.sin(th1) + M2 * G * (L1 * np.sin(th1) + L2 * np.sin(th2))
    return T, V


def _hand_written_double_pendulum(grid):
    """The textbook double pendulum in absolute angles, Lagrange's equations written out, CVODES BDF
    with Newton iteration (mechnet's 'cvodes-bdf' settings) at the same tolerances and output grid."""
    q, qd = ca.SX.sym("q", 2), ca.SX.sym("qd", 2)
    c, s = ca.cos(q[0] - q[1]), ca.sin(q[0] - q[1])
    M = ca.vertcat(ca.horzcat((M1 + M2) * L1 ** 2, M2 * L1 * L2 * c), ca.horzcat(M2 * L1 * L2 * c, M2 * L2 ** 2))
    rhs = ca.vertcat(-M2 * L1 * L2 * s * qd[1] ** 2 - (M1 + M2) * G * L1 * ca.cos(q[0]),
                     M2 * L1 * L2 * s * qd[0] ** 2 - M2 * G * L2 * ca.cos(q[1]))
    x = ca.vertcat(q, qd)
    opts = dict(linear_multistep_method="bdf", nonlinear_solver_iteration="newton", reltol=DP_TOL["rtol"],
                abstol=DP_TOL["atol"], max_num_steps=20_000)
    F = ca.integrator("hand", "cvodes", {"x": x, "ode": ca.vertcat(qd, ca.solve(M, rhs))}, 0.0, list(grid[1:]), opts)
    x0 = [PHI1, PHI1 + PHI2, 0.0, 0.0]
    X = np.hstack([np.array(x0)[:, None], F(x0=x0)["xf"].full()])
    return X


def test_double_pendulum_explicit_ode_and_energy_drift():
    cm = _double_pendulum()
    assert cm.n_states == 4 and sorted(cm.state_names) == ["rev1.phi", "rev1.w", "rev2.phi", "rev2.w"]
    assert cm.dae.z.numel() == 0, "a planar tree is an explicit ODE"
    res = cm.simulate(DP_GRID[-1], t_out=DP_GRID, **DP_TOL)
    assert res.success
    # SystemEnergy against the closed form at mechnet's own states, every output point: algebraic,
    # round-off only (atol 1e-11 J at scale m g L = 9.81 J; total energy 14.1 J)
    th1, th2 = res["rev1.phi"], res["rev1.phi"] + res["rev2.phi"]
    w1, w2 = res["rev1.w"], res["rev1.w"] + res["rev2.w"]
    T, V = _energy_absolute(th1, th2, w1, w2)
    assert np.max(np.abs(res["energy.kinetic"] - T)) < 1e-11
    assert np.max(np.abs(res["energy.potential"] - V)) < 1e-11
    assert res["energy.total"][0] == pytest.approx(sum(_energy_absolute(PHI1, PHI1 + PHI2, 0.0, 0.0)), abs=1e-12)
    # the start is chaotic, not a small oscillation: the second arm folds over
    assert np.max(np.abs(res["rev2.phi"])) > np.pi / 2
    # Energy drift over 100 s, relative to m g L = 9.81 J, max over the 2001-point grid, rtol = atol = 1e-10:
    # at most 3× the hand-written model's drift at the same settings and grid, and at most 1e-6.
    # Measured: mechnet 4.7e-7, hand-written 6.6e-7. The 1e-6 bound has little margin: the hand model
    # itself reaches 0.8e-6 to 1.05e-6 with other output grids (the drift is the integrator's).
    E = res["energy.total"]
    drift = np.max(np.abs(E - E[0])) / (M1 * G * L1)
    X = _hand_written_double_pendulum(DP_GRID)
    Eh = sum(_energy_absolute(*X))
    drift_hand = np.max(np.abs(Eh - Eh[0])) / (M1 * G * L1)
    assert drift <= 3 * drift_hand
    assert drift <= 1e-6


# ---- 3. geared motor driving a joint through its flange ---------------------------------------------

RATIO, J_MOTOR, TAU_MOTOR = 5.0, 0.05, 0.3
LINK_M, LINK_D = 2.0, 0.7
LINK_I = np.array([[0.05, 0.0, 0.01], [0.0, 0.08, 0.0], [0.01, 0.0, 0.04]])    # about the cm, with a product xz


def _geared_link(g, phi0=0.3, w0=0.5):
    """World → Revolute(z, use_flange) → Body (cm at d along x); motor inertia → gear → joint axis."""
    m = mn.Model("geared")
    world = m.add(mb.World(name="world", g=g))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], use_flange=True, phi_start=phi0, w_start=w0))
    body = m.add(mb.Body(name="link", m=LINK_M, r_cm=[LINK_D, 0, 0.2], I=LINK_I))
    fixed = m.add(rot.Fixed(name="fixed"))
    gear = m.add(rot.IdealGear(name="gear", ratio=RATIO))          # motor side flange_a: phi_a = ratio·phi_joint
    motor = m.add(rot.Inertia(name="motor", J=J_MOTOR))
    torque = m.add(rot.ConstantTorque(name="torque", tau_constant=TAU_MOTOR))
    _connect(m, [(world.frame_b, rev.frame_a), (rev.frame_b, body.frame_a), (rev.support, fixed.flange),
                 (rev.axis, gear.flange_b), (gear.flange_a, motor.flange_b), (motor.flange_a, torque.flange)])
    return m.compile()


def _joint_inertia():
    """About the joint axis z through the origin: I_zz of the cm tensor plus m·(x² + y²) of the cm
    (the z offset and the product I_xz give reaction torques only)."""
    return LINK_I[2, 2] + LINK_M * LINK_D ** 2


def test_geared_motor_reflected_inertia_without_gravity():
    cm = _geared_link(g=[0.0, 0.0, 0.0])
    assert sorted(cm.state_names) == ["rev.phi", "rev.w"]     # the motor angle is dependent on the joint's
    res = cm.simulate(2.0, **DP_TOL)
    assert res.success
    a = RATIO * TAU_MOTOR / (_joint_inertia() + J_MOTOR * RATIO ** 2)
    # joint acceleration: an expression of constants, 1e-9 relative (rtol 1e-9, atol 0; scale a = 0.66 rad/s²;
    # integrator tolerance and horizon play no part)
    assert np.max(np.abs(res["der(rev.w)"] - a)) <= 1e-9 * a
    # motion: phi0 + w0 t + a t²/2; rtol = atol = 1e-10, horizon 2 s, scale 2.6 rad: atol 1e-8
    t = res.t
    assert np.max(np.abs(res["rev.phi"] - (0.3 + 0.5 * t + a * t ** 2 / 2))) < 1e-8
    # the motor turns ratio times as far
    assert np.max(np.abs(res["motor.phi"] - RATIO * res["rev.phi"])) < 1e-9
    # without the reflected inertia (1.25 of 2.27 kg·m²) the acceleration would be 2.2× larger: not vacuous
    assert RATIO * TAU_MOTOR / _joint_inertia() > 2 * a


@pytest.mark.parametrize("gravity", [[0.0, 0.0, -9.81], [0.0, -9.81, 0.0]], ids=["g_along_axis", "g_in_plane"])
def test_geared_motor_reflected_inertia_with_gravity(gravity):
    phi0 = 0.3
    cm = _geared_link(g=gravity, phi0=phi0)
    res = cm.simulate(1.0, **DP_TOL)
    assert res.success
    # gravity torque about z on the cm at (d cos phi, d sin phi): −m g_y d cos phi (zero if g is along z)
    g_y = gravity[1]

    def acc(phi):
        return (RATIO * TAU_MOTOR + LINK_M * g_y * LINK_D * np.cos(phi)) / (_joint_inertia() + J_MOTOR * RATIO ** 2)

    # initial acceleration: 1e-9 relative (rtol 1e-9, atol 0; scale 0.66 / 5.1 rad/s²; no integration involved)
    assert res["der(rev.w)"][0] == pytest.approx(acc(phi0), rel=1e-9, abs=0)
    # and along the trajectory, from the integrated angle (algebraic relation, round-off only): 1e-9 relative
    # to the largest |acceleration| (rtol = atol = 1e-10 do not enter; horizon 1 s)
    want = acc(res["rev.phi"])
    assert np.max(np.abs(res["der(rev.w)"] - want)) <= 1e-9 * np.max(np.abs(want))


# ---- 4. Kepler orbit on three prismatic joints ------------------------------------------------------

def _orbit_plane():
    """Orthonormal e1, e2 (in the orbit plane) and e3 = e1 × e2, inclined to every coordinate plane."""
    c, s = np.cos, np.sin
    Rz = np.array([[c(0.4), -s(0.4), 0], [s(0.4), c(0.4), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, c(0.5), -s(0.5)], [0, s(0.5), c(0.5)]])
    R = Rz @ Rx
    return R[:, 0], R[:, 1], R[:, 2]


def _orbit(r0, GM=1.0, m_sat=1e-3):
    """A small particle on x, y, z prismatic joints from the World, attracted by Gravitation to a heavy
    particle fixed at the origin (on the world frame: it cannot move, so no reduced mass: use G·M)."""
    e1, e2, _ = _orbit_plane()
    x0, v0 = r0 * e1, np.sqrt(GM / r0) * e2                 # circular speed √(G M / r)
    m = mn.Model("orbit")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    m.add(mb.SystemEnergy(name="energy"))
    m.add(mb.SystemMomentum(name="mom", point=[0.0, 0.0, 0.0]))
    joints = [m.add(mb.Prismatic(name=f"p{c}", n=n, s_start=x0[k], v_start=v0[k]))
              for k, (c, n) in enumerate(zip("xyz", np.eye(3).tolist()))]
    sat = m.add(mb.Particle(name="sat", m=m_sat))
    sun = m.add(mb.Particle(name="sun", m=1.0))
    grav = m.add(mb.Gravitation(name="grav", m_a=1.0, m_b=m_sat, G=GM))
    _connect(m, [(world.frame_b, joints[0].frame_a), (joints[0].frame_b, joints[1].frame_a),
                 (joints[1].frame_b, joints[2].frame_a), (joints[2].frame_b, sat.frame_a),
                 (world.frame_b, sun.frame_a), (world.frame_b, grav.frame_a), (sat.frame_a, grav.frame_b)])
    return m.compile()


def test_circular_orbit_kepler():
    r0, GM, m_sat = 1.0, 1.0, 1e-3
    cm = _orbit(r0, GM, m_sat)
    assert cm.n_states == 6 and cm.dae.z.numel() == 0
    T = 2 * np.pi * np.sqrt(r0 ** 3 / GM)                   # Kepler III with the central mass fixed
    res = cm.simulate(10 * T, n_out=2001, rtol=1e-12, atol=1e-14)
    assert res.success
    pos = np.vstack([res["px.s"], res["py.s"], res["pz.s"]])
    vel = np.vstack([res["px.v"], res["py.v"], res["pz.v"]])
    e1, e2, e3 = _orbit_plane()
    # rtol 1e-12, atol 1e-14 (scale: positions and speeds ~1), 10 orbits (62.8 s). Measured radius
    # error 1.8e-9, period 1.3e-9, energy 1.8e-9, angular momentum 7.9e-10 (all relative).
    # circular: radius within 1e-8 relative
    radius = np.linalg.norm(pos, axis=0)
    assert np.max(np.abs(radius - r0)) <= 1e-8 * r0
    # stays in the inclined plane: atol 1e-10 at scale r0 = 1 m
    assert np.max(np.abs(e3 @ pos)) < 1e-10
    # period: the unwrapped angle in the plane after 10 orbits gives the mean angular rate; 1e-8 relative
    angle = np.unwrap(np.arctan2(e2 @ pos, e1 @ pos))
    T_measured = 2 * np.pi * res.t[-1] / (angle[-1] - angle[0])
    assert T_measured == pytest.approx(T, rel=1e-8)
    assert angle[-1] - angle[0] == pytest.approx(20 * np.pi, rel=1e-6)     # ten whole turns, prograde
    # energy: ½ m v² − G M m / r, SystemEnergy against the closed form (round-off, atol 1e-15 J at
    # scale 5e-4 J), then conserved to 1e-8 relative
    E = res["energy.total"]
    E_formula = 0.5 * m_sat * np.sum(vel ** 2, axis=0) - GM * m_sat / radius
    assert np.max(np.abs(E - E_formula)) < 1e-15
    assert E[0] == pytest.approx(-0.5 * GM * m_sat / r0, rel=1e-12)
    assert np.max(np.abs(E - E[0])) <= 1e-8 * abs(E[0])
    # angular momentum about the origin: m r × v, perpendicular to the plane, |L| = m √(G M r); conserved
    # to 1e-8 relative (SystemMomentum)
    Lv = np.vstack([res[f"mom.L[{i}]"] for i in range(3)])
    L0 = m_sat * np.sqrt(GM * r0) * e3
    assert np.max(np.abs(Lv[:, 0] - L0)) < 1e-15
    assert np.max(np.abs(Lv - L0[:, None])) <= 1e-8 * np.linalg.norm(L0)


# ---- 5. kinematics of a spatial arm ----------------------------------------------------------------

ARM = (0.5, 0.4, 0.3)


def _Rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _Ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _arm():
    """Base revolute about z, a column of 0.5 up z, shoulder and elbow about y, links 0.4 and 0.3 along x."""
    m = mn.Model("arm")
    world = m.add(mb.World(name="world"))
    j1 = m.add(mb.Revolute(name="j1", n=[0, 0, 1]))
    c1 = m.add(mb.FixedTranslation(name="column", r=[0, 0, ARM[0]]))
    j2 = m.add(mb.Revolute(name="j2", n=[0, 1, 0]))
    c2 = m.add(mb.FixedTranslation(name="upper", r=[ARM[1], 0, 0]))
    j3 = m.add(mb.Revolute(name="j3", n=[0, 1, 0]))
    c3 = m.add(mb.FixedTranslation(name="fore", r=[ARM[2], 0, 0]))
    b1 = m.add(mb.Body(name="b1", m=1.0, r_cm=[0.1, 0, 0.25], I=np.diag([0.02, 0.02, 0.01])))
    b2 = m.add(mb.Particle(name="b2", m=1.0))
    b3 = m.add(mb.Particle(name="tip", m=0.5))
    _connect(m, [(world.frame_b, j1.frame_a), (j1.frame_b, c1.frame_a), (j1.frame_b, b1.frame_a),
                 (c1.frame_b, j2.frame_a), (j2.frame_b, c2.frame_a), (c2.frame_b, j3.frame_a),
                 (c2.frame_b, b2.frame_a), (j3.frame_b, c3.frame_a), (c3.frame_b, b3.frame_a)])
    return m.compile()


def _arm_reference(q, qd):
    """Frames (origin, orientation) of the arm, and velocities from the hand-derived Jacobian."""
    R1 = _Rz(q[0])
    o1 = np.zeros(3)                                  # j1 frames
    o2 = R1 @ np.array([0, 0, ARM[0]])                # column.frame_b = j2.frame_a
    R2 = R1 @ _Ry(q[1])
    o3 = o2 + R2 @ np.array([ARM[1], 0, 0])           # upper.frame_b = j3.frame_a
    R3 = R2 @ _Ry(q[2])
    o4 = o3 + R3 @ np.array([ARM[2], 0, 0])           # fore.frame_b (the tip)
    # joint axes in world and the joints' positions on them
    a1, a2, a3 = np.array([0, 0, 1.0]), R1 @ np.array([0, 1.0, 0]), R2 @ np.array([0, 1.0, 0])
    w1, w2, w3 = a1 * qd[0], a1 * qd[0] + a2 * qd[1], a1 * qd[0] + a2 * qd[1] + a3 * qd[2]

    def v(p, upto):
        out = np.cross(a1 * qd[0], p - o1)
        if upto >= 2:
            out = out + np.cross(a2 * qd[1], p - o2)
        if upto >= 3:
            out = out + np.cross(a3 * qd[2], p - o3)
        return out

    return {"j1.frame_a": (o1, np.eye(3), np.zeros(3), np.zeros(3)),
            "j1.frame_b": (o1, R1, v(o1, 1), w1),
            "j2.frame_a": (o2, R1, v(o2, 1), w1),
            "j2.frame_b": (o2, R2, v(o2, 2), w2),
            "j3.frame_a": (o3, R2, v(o3, 2), w2),
            "j3.frame_b": (o3, R3, v(o3, 3), w3),
            "fore.frame_b": (o4, R3, v(o4, 3), w3),
            "tip.frame_a": (o4, R3, v(o4, 3), w3)}


def test_kinematics_of_spatial_arm():
    cm = _arm()
    rng = np.random.default_rng(3)
    configs = [np.zeros(3), np.array([np.pi / 2, -np.pi / 2, np.pi]), rng.uniform(-np.pi, np.pi, 3),
               rng.uniform(-np.pi, np.pi, 3)]
    for q in configs:
        qd = rng.uniform(-2, 2, 3)
        kin = mn.kinematics(cm, q=dict(zip(["j1", "j2", "j3"], q)), qd=dict(zip(["j1", "j2", "j3"], qd)))
        ref = _arm_reference(q, qd)
        for label, (r, R, v, w) in ref.items():
            got = kin[label]
            # positions (scale 1.2 m), orientations (scale 1) and velocities (scale ~5 m/s, rad/s):
            # the same products evaluated in another order, round-off only: atol 1e-12
            assert np.max(np.abs(got["r_0"] - r)) < 1e-12, label
            assert np.max(np.abs(got["R"] - R)) < 1e-12, label
            assert np.max(np.abs(got["v_0"] - v)) < 1e-12, label
            assert np.max(np.abs(got["w_0"] - w)) < 1e-12, label
        # velocities against central finite differences of mechnet's own positions and orientations along
        # q + h·qd (h = 1e-5: truncation ~h²·|d³r/dh³| ~ 1e-9, round-off ~1e-16/h = 1e-11): atol 1e-8
        h = 1e-5
        plus = mn.kinematics(cm, q=dict(zip(["j1", "j2", "j3"], q + h * qd)))
        minus = mn.kinematics(cm, q=dict(zip(["j1", "j2", "j3"], q - h * qd)))
        for label in ref:
            v_fd = (plus[label]["r_0"] - minus[label]["r_0"]) / (2 * h)
            Rdot = (plus[label]["R"] - minus[label]["R"]) / (2 * h)
            W = Rdot @ kin[label]["R"].T                   # [ω]× = Ṙ Rᵀ
            w_fd = np.array([W[2, 1], W[0, 2], W[1, 0]])
            assert np.max(np.abs(kin[label]["v_0"] - v_fd)) < 1e-8, label
            assert np.max(np.abs(kin[label]["w_0"] - w_fd)) < 1e-8, label


# ---- 6. linear growth of the compiled chain --------------------------------------------------------

def _chain(n):
    m = mn.Model(f"chain{n}")
    world = m.add(mb.World(name="world"))
    previous = world.frame_b
    for k in range(n):
        rev = m.add(mb.Revolute(name=f"rev{k}", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[1.0, 0, 0]))
        mass = m.add(mb.Particle(name=f"mass{k}", m=1.0))
        _connect(m, [(previous, rev.frame_a), (rev.frame_b, rod.frame_a), (rod.frame_b, mass.frame_a)])
        previous = rod.frame_b
    return m.compile()


def _growth_exponents(sizes):
    counts = []
    for n in sizes:
        cm = _chain(n)
        assert cm.n_states == 2 * n and cm.dae.z.numel() == 0, f"N = {n}: an explicit ODE with 2N states"
        counts.append(cm.dae.ode.n_instructions())
    logs_n, logs_c = np.log(sizes), np.log(counts)
    fit = np.polyfit(logs_n, logs_c, 1)[0]
    last = (logs_c[-1] - logs_c[-2]) / (logs_n[-1] - logs_n[-2])
    return fit, last, counts


def test_chain_operation_count_grows_linearly():
    # log-log slope of ode instructions vs N over N = 10 … 160: ≤ 1.1 (exact count, no tolerance; measured
    # 1.05 — 1186 … 21736 instructions, ~136 per link — and 1.01 between 80 and 160). Takes ~10 s.
    fit, last, counts = _growth_exponents([10, 20, 40, 80, 160])
    assert fit <= 1.1 and last <= 1.1, (fit, last, counts)


def test_chain_operation_count_grows_linearly_fast():
    # the same on N = 10, 20, 40 (~2 s); measured slope 1.08
    fit, last, counts = _growth_exponents([10, 20, 40])
    assert fit <= 1.1 and last <= 1.1, (fit, last, counts)
