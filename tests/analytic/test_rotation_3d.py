"""Rotation in 3D (Spherical and FreeMotion joints, quaternion orientation) against closed forms.

1. a torque-free body spun near its intermediate axis: the Jacobi elliptic solution's half period,
   conservation of T and |H|, and the error at the default tolerances against SciPy's RK45 on Euler's
   equations at the same settings;
2. a free body tumbling under gravity: its mass centre on the exact parabola, |Q| − 1 reported;
3. a conical pendulum on a spherical joint: the cone angle kept, precession at √(g/(L cos α));
4. a heavy symmetric top in steady precession: nutation angle kept, precession at the slow root;
5. bad input: a start orientation that is not a rotation, a zero quaternion, a zero axis.

Conventions: FreeMotion's w_rel is the body's angular velocity in body axes when frame_a is the world;
frame orientations are observed as `<frame>.R[k]`, row-major, columns = the frame's axes in world.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipk

import mechnet as mn
from mechnet import inertia
from mechnet.components import multibody as mb

G = 9.81
I_BODY = np.array([0.3, 0.35, 0.4])


def _connect(m, pairs):
    for a, b in pairs:
        m.connect(a, b)


def _free_body(w0, g=(0.0, 0.0, 0.0), I=I_BODY, mass=2.0, r0=(0.0, 0.0, 0.0), v0=(0.0, 0.0, 0.0), Q0=None):
    m = mn.Model("free_body")
    world = m.add(mb.World(name="world", g=list(g)))
    free = m.add(mb.FreeMotion(name="free", Q_start=Q0 if Q0 is not None else [1.0, 0, 0, 0], w_rel_start=list(w0),
                               r_rel_start=list(r0), v_rel_start=list(v0)))
    body = m.add(mb.Body(name="body", m=mass, I=np.diag(I)))
    _connect(m, [(world.frame_b, free.frame_a), (free.frame_b, body.frame_a)])
    return m


def _euler(t, w, I=I_BODY):
    """Euler's equations of a torque-free body, body axes."""
    I1, I2, I3 = I
    return [(I2 - I3) / I1 * w[1] * w[2], (I3 - I1) / I2 * w[2] * w[0], (I1 - I2) / I3 * w[0] * w[1]]


def _half_period(w0, I=I_BODY):
    """Time between sign changes of ω₂ (the intermediate axis) in the torque-free motion: 2K(k)/λ.

    Landau & Lifshitz, *Mechanics*, §37 (I1 < I2 < I3, 2E = Σ I ω², M² = Σ I² ω²): for M² > 2E·I2,
    λ² = (I3 − I2)(M² − 2E·I1)/(I1·I2·I3) and k² = (I2 − I1)(2E·I3 − M²)/((I3 − I2)(M² − 2E·I1));
    for M² < 2E·I2 the same with I1 and I3 exchanged. ω₂ ∝ sn(λt, k) changes sign every 2K(k)/λ."""
    I1, I2, I3 = I
    w0 = np.asarray(w0)
    E2, M2 = np.sum(I * w0 ** 2), np.sum((I * w0) ** 2)
    if M2 > E2 * I2:
        lam2 = (I3 - I2) * (M2 - E2 * I1) / (I1 * I2 * I3)
        k2 = (I2 - I1) * (E2 * I3 - M2) / ((I3 - I2) * (M2 - E2 * I1))
    else:
        lam2 = (I2 - I1) * (E2 * I3 - M2) / (I1 * I2 * I3)
        k2 = (I3 - I2) * (M2 - E2 * I1) / ((I2 - I1) * (E2 * I3 - M2))
    return 2 * ellipk(k2) / np.sqrt(lam2)


W0_INTERMEDIATE = (0.5, 6.0, 1.0)      # rad/s: spun about the intermediate axis, off it enough to flip 3 times in 20 s


def test_intermediate_axis_flips_with_the_elliptic_half_period():
    """ω₂'s sign changes 2K(k)/λ apart within 1e-6 relative (rtol 1e-12, atol 1e-12 rad/s, 20 s; the
    crossing times interpolated linearly between output points 1e-4 s apart: error ~1e-9 s)."""
    cm = _free_body(W0_INTERMEDIATE).compile()
    res = cm.simulate(20.0, rtol=1e-12, atol=1e-12, n_out=200001)
    w2 = res["free.w_rel[1]"]
    k = np.flatnonzero(np.sign(w2[1:]) != np.sign(w2[:-1]))
    crossings = res.t[k] - w2[k] * (res.t[k + 1] - res.t[k]) / (w2[k + 1] - w2[k])
    assert len(crossings) >= 3
    expected = _half_period(W0_INTERMEDIATE)
    assert np.max(np.abs(np.diff(crossings) - expected)) <= 1e-6 * expected


def test_torque_free_energy_and_momentum_are_conserved():
    """T and |H| (body axes: |I·ω|) conserved to 1e-9 relative over 20 s at rtol 1e-12, atol 1e-12;
    |Q| − 1 is reported as an invariant and stays below 1e-9 (renormalised at restarts)."""
    cm = _free_body(W0_INTERMEDIATE).compile()
    res = cm.simulate(20.0, rtol=1e-12, atol=1e-12, n_out=2001)
    w = np.column_stack([res[f"free.w_rel[{i}]"] for i in range(3)])
    T = 0.5 * np.sum(I_BODY * w ** 2, axis=1)
    H = np.linalg.norm(I_BODY * w, axis=1)
    assert np.max(np.abs(T / T[0] - 1)) <= 1e-9
    assert np.max(np.abs(H / H[0] - 1)) <= 1e-9
    names = list(cm.dae.invariant_names)
    assert any("|Q| − 1" in n and n.startswith("free") for n in names)
    Q = np.column_stack([res[f"free.Q[{i}]"] for i in range(4)])
    assert np.max(np.abs(np.linalg.norm(Q, axis=1) - 1)) <= 1e-9


def test_default_tolerances_are_as_accurate_as_rk45_on_eulers_equations():
    """At the default settings (rtol 1e-6, atol 1e-8) ω at t = 20 s is within 10× the error of SciPy's
    RK45 on Euler's equations at the same rtol and atol; both against RK45 at rtol 1e-12 (DOP853)."""
    cm = _free_body(W0_INTERMEDIATE).compile()
    res = cm.simulate(20.0)
    mine = np.array([res[f"free.w_rel[{i}]"][-1] for i in range(3)])
    exact = solve_ivp(_euler, (0, 20), W0_INTERMEDIATE, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    rk45 = solve_ivp(_euler, (0, 20), W0_INTERMEDIATE, method="RK45", rtol=1e-6, atol=1e-8).y[:, -1]
    assert np.max(np.abs(mine - exact)) <= 10 * np.max(np.abs(rk45 - exact))


def test_a_tumbling_body_falls_on_the_parabola():
    """A body spun about a general axis, thrown under gravity (0, 0, −9.81): its mass centre (frame
    origin) on r0 + v0·t + ½·g·t² within 1e-10 of the distance fallen over the run (100 s, 4.7e4 m;
    rtol 1e-10, atol 1e-10), and in the first second within 10·(rtol·|r| + atol); no failure;
    |Q| − 1 within what one integrator call can accumulate, 10·rtol per step (renormalised at the start
    of every call: without that the drift would add up over the whole run)."""
    g, r0, v0 = np.array([0, 0, -G]), np.array([0.1, -0.2, 3.0]), np.array([1.0, 0.5, 20.0])
    cm = _free_body((1.0, 2.0, -3.0), g=g, r0=r0, v0=v0).compile()
    res = cm.simulate(100.0, rtol=1e-10, atol=1e-10, n_out=1001)
    assert res.failure is None
    t = res.t
    r = np.column_stack([res[f"body.frame_a.r_0[{i}]"] for i in range(3)])
    exact = r0 + np.outer(t, v0) + 0.5 * np.outer(t ** 2, g)
    error = np.linalg.norm(r - exact, axis=1)
    assert np.max(error) <= 1e-10 * np.linalg.norm(exact[-1] - r0)
    early = t <= 1.0
    assert np.all(error[early] <= 10 * (1e-10 * np.linalg.norm(exact[early], axis=1) + 1e-10))
    Q = np.column_stack([res[f"free.Q[{i}]"] for i in range(4)])
    steps_per_call = res.stats["nsteps"] / res.stats["segments"]
    assert np.max(np.abs(np.linalg.norm(Q, axis=1) - 1)) <= 10 * 1e-10 * steps_per_call


def _conical_pendulum(alpha, L=1.0, radius=0.05):
    """A small solid sphere (1 kg, radius 5 cm: a particle would have no inertia about the rod, which
    leaves the spin about it undetermined) on a rod of length L from a spherical joint at the world
    origin, gravity −z, tilted by alpha about x and circling the vertical at the conical rate
    √(g/(L cos α)): the same as a particle's, since an isotropic inertia adds no gyroscopic moment (the
    heavy top's relation A·Ω²·cos θ − C·ω3·Ω + m·g·l = 0 with A − C = m·L², ω3 = Ω·cos θ, θ = π − α)."""
    rate = np.sqrt(G / (L * np.cos(alpha)))
    m = mn.Model("conical")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    ball = m.add(mb.Spherical(name="ball", axis_start=[1, 0, 0], angle_start=alpha, w_rel_a_start=[0, 0, rate]))
    rod = m.add(mb.FixedTranslation(name="rod", r=[0.0, 0.0, -L]))
    bob = m.add(mb.Body(name="bob", m=1.0, I=inertia.sphere(1.0, radius)))
    _connect(m, [(world.frame_b, ball.frame_a), (ball.frame_b, rod.frame_a), (rod.frame_b, bob.frame_a)])
    return m, rate


def test_a_particle_on_a_spherical_joint_is_refused_with_the_reason():
    """A particle on a rod has no inertia about the rod: the spin about it is undetermined."""
    m = mn.Model("particle_on_ball")
    world = m.add(mb.World(name="world"))
    ball = m.add(mb.Spherical(name="ball", Q_start=[1.0, 0, 0, 0], w_rel_start=[0.0, 0.0, 0.0]))
    rod = m.add(mb.FixedTranslation(name="rod", r=[0.0, -1.0, 0.0]))
    bob = m.add(mb.Particle(name="bob", m=1.0))
    _connect(m, [(world.frame_b, ball.frame_a), (ball.frame_b, rod.frame_a), (rod.frame_b, bob.frame_a)])
    with pytest.raises(mn.MechnetError, match="ball \\(Spherical\\) moves no mass in some direction.*rotational inertia"):
        m.compile()


def test_a_conical_pendulum_keeps_its_cone_and_rate():
    """Cone angle kept within 1e-8 rad over 10 s and the bob's azimuth advancing at √(g/(L cos α))
    within 1e-8 relative (rtol 1e-12, atol 1e-12; α = 0.6 rad, L = 1 m)."""
    alpha = 0.6
    cm, rate = _conical_pendulum(alpha)[0].compile(), _conical_pendulum(alpha)[1]
    res = cm.simulate(10.0, rtol=1e-12, atol=1e-12, n_out=1001)
    r = np.column_stack([res[f"bob.frame_a.r_0[{i}]"] for i in range(3)])
    cone = np.arccos(-r[:, 2] / np.linalg.norm(r, axis=1))
    assert np.max(np.abs(cone - alpha)) <= 1e-8
    azimuth = np.unwrap(np.arctan2(r[:, 1], r[:, 0]))
    measured = (azimuth[-1] - azimuth[0]) / (res.t[-1] - res.t[0])
    assert abs(measured / rate - 1) <= 1e-8


def _top(theta0, spin, l=0.1, mass=1.0, A_cm=0.002, C=0.004):
    """A symmetric top on a spherical pivot at its tip (world origin), symmetry axis = body z, mass
    centre at l along it; tilted by theta0 about world x; gravity −z. Returns the model, Ω (the slow
    root of A·Ω²·cos θ0 − C·ω3·Ω + m·g·l = 0, A about the pivot) and ω3."""
    A = A_cm + mass * l ** 2
    omega3 = spin
    disc = (C * omega3) ** 2 - 4 * A * np.cos(theta0) * mass * G * l
    Omega = (C * omega3 - np.sqrt(disc)) / (2 * A * np.cos(theta0))
    s = omega3 - Omega * np.cos(theta0)           # spin rate relative to the precessing plane
    R0 = mb.frames.matrix_of_quaternion(mb.frames.quaternion_of_axis_angle([1, 0, 0], theta0))
    w_body = R0.T @ np.array([0, 0, Omega]) + np.array([0, 0, s])
    m = mn.Model("top")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    pivot = m.add(mb.Spherical(name="pivot", R_rel_start=R0, w_rel_start=list(w_body)))
    body = m.add(mb.Body(name="top", m=mass, r_cm=[0.0, 0.0, l], I=np.diag([A_cm, A_cm, C])))
    _connect(m, [(world.frame_b, pivot.frame_a), (pivot.frame_b, body.frame_a)])
    return m, Omega


def test_a_heavy_top_in_steady_precession():
    """θ stays within 1e-7 rad of θ0 = 0.5 over 10 s and the symmetry axis precesses at Ω within 1e-7
    relative (rtol 1e-12, atol 1e-12; spin ω3 = 100 rad/s)."""
    theta0 = 0.5
    m, Omega = _top(theta0, 100.0)
    res = m.compile().simulate(10.0, rtol=1e-12, atol=1e-12, n_out=2001)
    axis = np.column_stack([res[f"top.frame_a.R[{k}]"] for k in (2, 5, 8)])     # body z in world
    theta = np.arccos(np.clip(axis[:, 2], -1, 1))
    assert np.max(np.abs(theta - theta0)) <= 1e-7
    azimuth = np.unwrap(np.arctan2(axis[:, 1], axis[:, 0]))
    rate = (azimuth[-1] - azimuth[0]) / (res.t[-1] - res.t[0])
    assert abs(rate / Omega - 1) <= 1e-7


@pytest.mark.parametrize("kwargs,match", [
    (dict(R_rel_start=np.diag([1.0, 1.0, -1.0])), "R_rel_start .* is not a rotation"),
    (dict(R_rel_start=[[1.0, 0.1, 0], [0, 1, 0], [0, 0, 1]]), "R_rel_start .* is not a rotation"),
    (dict(Q_start=[0.0, 0.0, 0.0, 0.0]), "zero quaternion"),
    (dict(axis_start=[0.0, 0.0, 0.0], angle_start=0.5), "axis_start .* zero vector"),
    (dict(axis_start=[0.0, 0.0, 1.0]), "axis_start and angle_start go together"),
    (dict(Q_start=[1.0, 0, 0, 0], R_rel_start=np.eye(3)), "once"),
])
def test_bad_start_orientations_are_refused_by_name(kwargs, match):
    with pytest.raises(mn.MechnetError, match=match) as err:
        mb.Spherical(name="ball", **kwargs)
    assert "ball (Spherical)" in str(err.value)


def test_kinematics_takes_a_quaternion_for_a_spherical_joint():
    """mn.kinematics with the pivot's quaternion: the top's frame is R(Q/|Q|) (unnormalised Q given, 1e-15),
    its mass centre at R·(0, 0, l); a wrong length is refused by name."""
    model, _ = _top(0.5, 100.0)
    cm = model.compile()
    Q = np.array([2.0, 0.4, -0.6, 1.0])
    R = mb.frames.matrix_of_quaternion(Q)
    k = mn.kinematics(cm, q={"pivot": Q})["top.frame_a"]
    assert np.max(np.abs(k["R"] - R)) <= 1e-15
    with pytest.raises(mn.MechnetError, match="q\\['pivot'\\] needs 4 number"):
        mn.kinematics(cm, q={"pivot": [1.0, 0.0]})


def test_a_free_body_held_off_its_mass_centre_has_eulers_accelerations():
    """A heavy body (1000 kg, I = diag(0.01, 0.02, 0.028) kg·m²) on a FreeMotion whose frame_b sits
    0.62 m from the mass centre: der(w_rel) from the compiled ODE equals Euler's equations within 1e-9
    relative at 50 random orientations (m·|c|²/I ≈ 4e4 amplifies round-off once, not squared)."""
    I, w0, rc, mass = np.array([0.01, 0.02, 0.028]), np.array([0.4, 5.0, 1.0]), np.array([0.3, -0.2, 0.5]), 1000.0
    m = mn.Model("offset")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    free = m.add(mb.FreeMotion(name="free", Q_start=[1.0, 0, 0, 0], w_rel_start=list(w0), r_rel_start=[0, 0, 0],
                               v_rel_start=list(np.cross(w0, -rc))))
    body = m.add(mb.Body(name="body", m=mass, r_cm=list(rc), I=np.diag(I)))
    _connect(m, [(world.frame_b, free.frame_a), (free.frame_b, body.frame_a)])
    dae = m.compile().dae
    names = list(dae.x_names)
    euler = np.array(_euler(0.0, w0, I))
    rng = np.random.default_rng(0)
    for _ in range(50):
        Q = rng.normal(size=4)
        Q /= np.linalg.norm(Q)
        v = mb.frames.matrix_of_quaternion(Q) @ np.cross(w0, -rc)     # the mass centre at rest
        values = {**{f"free.Q[{i}]": Q[i] for i in range(4)}, **{f"free.w_rel[{i}]": w0[i] for i in range(3)},
                  **{f"free.v_rel[{i}]": v[i] for i in range(3)}}
        x = np.array([values.get(n, 0.0) for n in names])
        xdot = np.asarray(dae.ode(0.0, x, np.zeros(0), np.zeros(0), dae.p_value, dae.d_value)).ravel()
        wdot = np.array([xdot[names.index(f"free.w_rel[{i}]")] for i in range(3)])
        assert np.max(np.abs(wdot - euler)) <= 1e-9 * np.max(np.abs(euler))


@pytest.mark.parametrize("order", ["revolute first", "spherical first"])
def test_a_redundant_freedom_at_one_point_is_refused_at_compile_time(order):
    """A revolute and a spherical joint at the same point give the rotation about the revolute's axis
    twice: its acceleration is undetermined. Refused when compiling, naming the first joint (before:
    the revolute-first order compiled and failed 0.1 s into the run)."""
    m = mn.Model("redundant")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
    ball = m.add(mb.Spherical(name="ball", axis_start=[1, 0, 0], angle_start=0.3, w_rel_start=[0, 0, 0]))
    rod = m.add(mb.FixedTranslation(name="rod", r=[0, 0, -1.0]))
    bob = m.add(mb.Body(name="bob", m=1.0, I=np.eye(3) * 0.01))
    first, second = (rev, ball) if order == "revolute first" else (ball, rev)
    _connect(m, [(world.frame_b, first.frame_a), (first.frame_b, second.frame_a), (second.frame_b, rod.frame_a),
                 (rod.frame_b, bob.frame_a)])
    with pytest.raises(mn.MechnetError, match=f"{first.name} .* a joint beyond it at the same point already gives"):
        m.compile()


def test_an_exported_free_body_keeps_its_quaternion_handling(tmp_path):
    """kind="casadi" and load: the quaternion's state indices travel in model.json, so the loaded model
    renormalises as the original does; 5 s at default settings give identical numbers."""
    from mechnet.export import load
    cm = _free_body((1.0, 2.0, -3.0), g=(0.0, 0.0, -G)).compile()
    loaded = load(cm.export(tmp_path / "free_body", kind="casadi"))
    assert loaded.dae.info["quaternions"] == cm.dae.info["quaternions"] == ((0, 1, 2, 3),)
    a, b = loaded.simulate(5.0), cm.simulate(5.0)
    assert all(np.array_equal(a[f"free.Q[{i}]"], b[f"free.Q[{i}]"]) for i in range(4))


def test_the_conical_pendulums_rod_force_is_a_force_system_through_the_pivot():
    """ForceSystem.from_frame on the bob's frame: the rod's wrench on the bob is m·(a − g) (a the conical
    motion's centripetal acceleration), with no moment about the bob's centre (its spin is steady), and
    its central axis runs along the rod: through the bob and the pivot at the world origin (pitch 0).
    rtol 1e-12, atol 1e-12, at t = 2 s; tolerances 1e-8 of the weight (N, N·m, m)."""
    from mechnet.vectors import ForceSystem
    alpha, L = 0.6, 1.0
    model, rate = _conical_pendulum(alpha, L)
    res = model.compile().simulate(2.0, rtol=1e-12, atol=1e-12)
    wrench = ForceSystem.from_frame(res, "bob.frame_a")
    r = np.array([res[f"bob.frame_a.r_0[{i}]"][-1] for i in range(3)])
    a = -rate ** 2 * np.array([r[0], r[1], 0.0])
    expected = 1.0 * (a - np.array([0.0, 0.0, -G]))
    assert np.max(np.abs(wrench.resultant - expected)) <= 1e-8 * G
    assert np.max(np.abs(wrench.moment_about(r))) <= 1e-8 * G
    axis = wrench.central_axis()
    for point in (r, np.zeros(3)):                       # the bob and the pivot lie on the axis
        off = (point - axis.point) - ((point - axis.point) @ axis.direction) * axis.direction
        assert np.linalg.norm(off) <= 1e-8
    assert abs(axis.pitch) <= 1e-8
    with pytest.raises(mn.MechnetError, match="'bob.nowhere' is not a frame"):
        ForceSystem.from_frame(res, "bob.nowhere")


def test_a_spherical_joint_on_a_loop_is_refused_by_name():
    """Until spatial loops through quaternion joints land: a loop World – revolute – link – spherical –
    link – revolute – World is refused naming the spherical joint and the loop's cut joint."""
    m = mn.Model("loop")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    r1 = m.add(mb.Revolute(name="r1", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
    a = m.add(mb.BodyShape(name="a", r=[1.0, 0, 0], r_cm=[0.5, 0, 0], m=1.0, I=inertia.rod(1.0, 1.0)))
    ball = m.add(mb.Spherical(name="ball", Q_start=[1.0, 0, 0, 0], w_rel_start=[0.0, 0.0, 0.0]))
    b = m.add(mb.BodyShape(name="b", r=[0, 1.0, 0], r_cm=[0, 0.5, 0], m=1.0, I=inertia.rod(1.0, 1.0, axis=1)))
    ground = m.add(mb.FixedTranslation(name="ground", r=[1.0, 1.0, 0]))
    r2 = m.add(mb.Revolute(name="r2", n=[0, 0, 1]))
    _connect(m, [(world.frame_b, r1.frame_a), (r1.frame_b, a.frame_a), (a.frame_b, ball.frame_a),
                 (ball.frame_b, b.frame_a), (world.frame_b, ground.frame_a), (ground.frame_b, r2.frame_a),
                 (r2.frame_b, b.frame_b)])
    with pytest.raises(mn.MechnetError, match="ball \\(Spherical\\) lies on the kinematic loop closed at .*not "
                                              "supported yet"):
        m.compile()


def test_kinematics_takes_the_identity_for_a_quaternion_without_start_and_refuses_a_zero_one():
    m = mn.Model("no_start")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    ball = m.add(mb.Spherical(name="ball"))
    rod = m.add(mb.FixedTranslation(name="rod", r=[0.0, 0.0, -1.0]))
    bob = m.add(mb.Body(name="bob", m=1.0, I=inertia.sphere(1.0, 0.05)))
    _connect(m, [(world.frame_b, ball.frame_a), (ball.frame_b, rod.frame_a), (rod.frame_b, bob.frame_a)])
    cm = m.compile()
    frames = mn.kinematics(cm)
    assert np.array_equal(frames["bob.frame_a"]["R"], np.eye(3))
    assert np.allclose(frames["bob.frame_a"]["r_0"], [0.0, 0.0, -1.0], atol=1e-15)
    with pytest.raises(mn.MechnetError, match="quaternion in q\\['ball'\\] is zero"):
        mn.kinematics(cm, q={"ball": [0.0, 0.0, 0.0, 0.0]})


def test_the_quaternion_norm_stays_bounded_over_a_long_event_free_run():
    """500 s of the tumbling body at the default tolerances in one integrator call: the pull term
    λ(1 − |Q|²)Q of der(Q) keeps ||Q| − 1| below 1e-5 (without it the drift grew linearly: 2.4e-4 by
    200 s, 2.2e-3 by 2000 s), and T stays within 1e-5 relative (R uses Q/|Q|: the pull changes nothing
    physical)."""
    cm = _free_body(W0_INTERMEDIATE).compile()
    res = cm.simulate(500.0, n_out=401)
    Q = np.column_stack([res[f"free.Q[{i}]"] for i in range(4)])
    assert np.max(np.abs(np.linalg.norm(Q, axis=1) - 1)) <= 1e-5
    w = np.column_stack([res[f"free.w_rel[{i}]"] for i in range(3)])
    T = 0.5 * np.sum(I_BODY * w ** 2, axis=1)
    assert np.max(np.abs(T / T[0] - 1)) <= 1e-5


def test_a_twenty_link_spherical_chain_keeps_its_energy():
    """20 thin steel rods (BodyCylinder, 0.5 m, 4 cm) on spherical joints, released bent, gravity −z:
    SystemEnergy constant to 1e-8 of the largest kinetic energy over 0.3 s (rtol 1e-10, atol 1e-10).
    Before the ball joints' reduced inertia was written with its exact zero blocks and A⁻¹ through
    Cholesky, round-off grew ~7x per link: der(w_rel) was off by 68 rad/s² of 176 at 20 links (against
    MuJoCo, benchmarks/rotation.py) and the run failed in its first hundredth of a second."""
    m = mn.Model("chain20")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    frame = world.frame_b
    for k in range(20):
        ball = m.add(mb.Spherical(name=f"ball{k}", axis_start=[1, 0.3 * (k % 3), 0], angle_start=0.3,
                                  w_rel_start=[0.0, 0.0, 0.0]))
        rod = m.add(mb.BodyCylinder(name=f"rod{k}", r=[0.0, 0.0, -0.5], diameter=0.04))
        m.connect(frame, ball.frame_a)
        m.connect(ball.frame_b, rod.frame_a)
        frame = rod.frame_b
    m.add(mb.SystemEnergy(name="energy"))
    res = m.compile().simulate(0.3, rtol=1e-10, atol=1e-10, n_out=31)
    assert res.failure is None
    drift = np.max(np.abs(res["energy.total"] - res["energy.total"][0]))
    assert drift <= 1e-8 * np.max(res["energy.kinetic"])
