"""Kinematic loops (Multibody II acceptance): planar four-bars and slider-cranks closed automatically.

The scenes are built as a user wires them (tests/models.py): every pin is a plain
`Revolute` about z, so each loop has three redundant out-of-plane constraints
that the compiler drops. References are closed forms: Freudenstein's equation
for the four-bar, x = r cos θ + √(l² − r² sin² θ) for the slider-crank.
"""
from __future__ import annotations

import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components.signals import Constant

from models import four_bar, four_bar_angles, slider_crank, slider_crank_x

A, B, C, D = 0.2, 0.6, 0.5, 0.6          # crank, coupler, rocker, ground (m): Grashof crank-rocker
PINS = ("joint_a", "joint_b", "joint_c", "joint_d")


def _wrap(x):
    return np.angle(np.exp(1j * x))


def _closure_gap(res, pins):
    """Largest distance between the two frames of any pin (the cut one included) over the run."""
    return max(np.max(np.abs(res[f"{p}.frame_a.r_0[{i}]"] - res[f"{p}.frame_b.r_0[{i}]"]))
               for p in pins for i in range(3))


def test_summary_reports_the_loop_and_the_dropped_planar_constraints():
    cm = four_bar().compile()
    text = cm.summary()
    assert "1 kinematic loop" in text
    assert "3 redundant constraint(s) dropped" in text and "planar" in text
    assert cm.n_states == 2                       # one degree of freedom: one angle and its speed


def test_kinematic_four_bar_follows_freudenstein():
    # Crank turned at 2 rad/s by a Speed source (no degree of freedom left): the rocker angle against
    # Freudenstein's closed form at 1000 times over 10 s (3.2 revolutions). rtol 1e-10, atol 1e-11,
    # scale 1 rad: |Δθ4| < 1e-8 rad (measured 8.8e-11). Closure: every pin's frames coincide within
    # 10·(rtol·L + atol), L = 0.6 m the longest link.
    w, th0, rtol, atol = 2.0, 0.3, 1e-10, 1e-11
    cm = four_bar(drive=rot.Speed(name="motor", w_ref=Constant(w), phi_start=th0)).compile()
    t = np.linspace(0.0, 10.0, 1000)
    res = cm.simulate(10.0, rtol=rtol, atol=atol, t_out=t)
    assert res.success
    th2 = th0 + w * t
    assert np.max(np.abs(res["joint_a.phi"] - th2)) < 1e-9
    th3, th4 = four_bar_angles(A, B, C, D, th2)
    assert np.max(np.abs(_wrap(res["joint_d.phi"] - th4))) < 1e-8
    assert np.max(np.abs(_wrap(res["joint_b.phi"] - (th3 - th2)))) < 1e-8
    assert _closure_gap(res, PINS) <= 10 * (rtol * B + atol)


def test_four_bar_with_motor_torque_balances_energy():
    # One degree of freedom, a constant crank torque τ against gravity: motor work τ·Δθ2 = ΔE (kinetic +
    # potential of the three links, SystemEnergy). rtol 1e-10, atol 1e-10, horizon 3 s, scale the
    # largest |motor work| (≈ 2 J): |ΔE − W| < 1e-6 · max|W| (measured 6.8e-9).
    tau = 2.0
    m = four_bar(drive=rot.ConstantTorque(name="motor", tau_constant=tau))
    m.add(mb.SystemEnergy(name="energy"))
    cm = m.compile()
    assert cm.n_states == 2
    res = cm.simulate(3.0, rtol=1e-10, atol=1e-10, n_out=301)
    assert res.success
    E, th2 = res["energy.total"], res["joint_a.phi"]
    work = tau * (th2 - th2[0])
    assert np.max(np.abs(work)) > 0.5                       # the crank really moves
    assert np.max(np.abs(E - E[0] - work)) < 1e-6 * np.max(np.abs(work))
    assert _closure_gap(res, PINS) <= 10 * (1e-10 * B + 1e-10)


def test_kinematic_slider_crank_piston_follows_the_closed_form():
    # Crank at 3 rad/s (Speed source), r = 0.1 m, l = 0.35 m, 10 s (4.8 revolutions, both dead centres
    # passed nearly 10 times each). rtol 1e-10, atol 1e-11, scale l: |Δx| < 1e-9 m.
    r, l, w, th0 = 0.1, 0.35, 3.0, 0.4
    cm = slider_crank(r, l, crank_drive=rot.Speed(name="motor", w_ref=Constant(w), phi_start=th0)).compile()
    res = cm.simulate(10.0, rtol=1e-10, atol=1e-11, n_out=1001)
    assert res.success
    assert np.max(np.abs(res["slider.s"] - slider_crank_x(r, l, th0 + w * res.t))) < 1e-9
    assert _closure_gap(res, ("joint_a", "joint_b", "joint_c")) <= 10 * (1e-10 * l + 1e-11)


def test_slider_crank_under_constant_torque_passes_dead_centres():
    # Constant crank torque 1 N·m against a bearing damper 0.05 N·m·s (steady speed ≈ 20 rad/s), 20 s:
    # the crank passes the dead centres (θ = kπ) more than 100 times. Pass criterion for "no step-size
    # collapse": the run succeeds, with fewer than 500 steps per revolution on average at rtol 1e-6
    # and failed error tests under 5 % of the steps. The piston stays on its closed form within
    # 10·(rtol·l + atol) with rtol 1e-6, atol 1e-8 (measured 1.7e-7 < 3.6e-6).
    r, l = 0.1, 0.35
    m = slider_crank(r, l, crank_drive=rot.ConstantTorque(name="motor", tau_constant=1.0))
    loss = m.add(rot.Damper(name="loss", d=0.05))
    m.connect(loss.flange_a, m.fixed.flange)
    m.connect(loss.flange_b, m.joint_a.axis)
    cm = m.compile()
    res = cm.simulate(20.0, rtol=1e-6, atol=1e-8, n_out=2001)
    assert res.success, res.failure
    th = res["joint_a.phi"]
    passes = int(np.floor(th[-1] / np.pi) - np.floor(th[0] / np.pi))
    assert passes > 100
    revolutions = (th[-1] - th[0]) / (2 * np.pi)
    assert res.stats["nsteps"] / revolutions < 500
    assert res.stats["netfails"] < 0.05 * res.stats["nsteps"]
    assert np.max(np.abs(res["slider.s"] - slider_crank_x(r, l, th))) < 10 * (1e-6 * l + 1e-8)


def test_a_planar_loop_carries_no_out_of_plane_wrench():
    """All forces of a planar slider-crank lie in its plane, so the cut joint's out-of-plane force and
    in-plane-axis torques vanish on both of its frames. They are structural zeros of the compiled model
    (exactly 0.0 in a run, not round-off), and none is left to the integrator as an unknown."""
    m = slider_crank(crank_drive=rot.ConstantTorque(name="motor", tau_constant=1.0))
    cm = m.compile()
    assert not any(".frame_" in n for n in cm.dae.z_names), cm.dae.z_names
    res = cm.simulate(0.5, rtol=1e-8, atol=1e-10, n_out=51)
    assert res.success
    for side in ("frame_a", "frame_b"):
        for name in (f"joint_c.{side}.f[2]", f"joint_c.{side}.t[0]", f"joint_c.{side}.t[1]"):
            assert np.all(res[name] == 0.0), name
    # the in-plane reaction is not zero: the rod pushes the piston (scale: the crank torque over r, 10 N)
    assert np.max(np.abs(res["joint_c.frame_a.f[0]"])) > 0.1


def _massless_parallelogram(theta0):
    """Ground pin1 at the origin and pin4 at (1, 0); crank and rocker bare 0.5 m FixedTranslations (no
    mass), coupler 1 m with a 1 kg particle at its end. Crank up at pin1.phi = 0; on the parallelogram
    branch the coupler translates, so the particle swings on a 0.5 m circle about pin4."""
    m = mn.Model("massless_parallelogram")
    world = m.add(mb.World(name="world"))
    anchor = m.add(mb.FixedTranslation(name="anchor", r=[1.0, 0.0, 0.0]))
    guesses = {1: {"phi_start": theta0, "w_start": 0.0}, 2: {"phi_guess": -theta0},
               3: {"phi_guess": theta0}, 4: {"phi_guess": theta0}}
    pins = [m.add(mb.Revolute(name=f"pin{k}", **guesses[k])) for k in range(1, 5)]
    crank = m.add(mb.FixedTranslation(name="crank", r=[0.0, 0.5, 0.0]))
    coupler = m.add(mb.FixedTranslation(name="coupler", r=[1.0, 0.0, 0.0]))
    rocker = m.add(mb.FixedTranslation(name="rocker", r=[0.0, -0.5, 0.0]))
    mass = m.add(mb.Particle(name="mass", m=1.0))
    m.add(mb.SystemEnergy(name="energy"))
    for a, b in [(world.frame_b, pins[0].frame_a), (pins[0].frame_b, crank.frame_a),
                 (crank.frame_b, pins[1].frame_a), (pins[1].frame_b, coupler.frame_a),
                 (coupler.frame_b, pins[2].frame_a), (pins[2].frame_b, rocker.frame_a),
                 (rocker.frame_b, pins[3].frame_b), (world.frame_b, anchor.frame_a),
                 (anchor.frame_b, pins[3].frame_a), (coupler.frame_b, mass.frame_a)]:
        m.connect(a, b)
    return m


def test_massless_crank_and_rocker_swing_the_coupler_as_a_simple_pendulum():
    # A parallelogram whose crank and rocker have no mass (bare links inside the loop) and whose
    # coupler carries a 1 kg point: the point moves on a 0.5 m circle, so the crank angle from the
    # bottom, θ = pin1.phi − π, obeys θ'' = −(g/L) sin θ with L = 0.5 m. Released at θ = −0.5 rad, 3 s
    # (about 2 periods). Reference: that ODE with CVODES at rtol = atol = 1e-12. Pass criteria at
    # rtol 1e-6, 1e-8, 1e-10 (atol = rtol/100): success; the error against the reference falls at least
    # tenfold per step and is below 1e-7 rad at rtol 1e-10 (measured 9.0e-6, 1.6e-7, 2.3e-9 rad);
    # energy is conserved within 1e-6·m g L at rtol 1e-10 (measured 7.9e-9 J; scale 4.9 J).
    import casadi as ca

    g, L = 9.81, 0.5
    grid = np.linspace(0.0, 3.0, 301)
    th, w = ca.SX.sym("th"), ca.SX.sym("w")
    F = ca.integrator("F", "cvodes", {"x": ca.vertcat(th, w), "ode": ca.vertcat(w, -g / L * ca.sin(th))},
                      0.0, list(grid[1:]), {"reltol": 1e-12, "abstol": 1e-12})
    reference = np.concatenate([[-0.5], np.array(F(x0=[-0.5, 0.0])["xf"])[0]])
    cm = _massless_parallelogram(np.pi - 0.5).compile()
    assert cm.n_states == 2
    errors = []
    for rtol in (1e-6, 1e-8, 1e-10):
        res = cm.simulate(3.0, rtol=rtol, atol=rtol / 100, n_out=grid.size)
        assert res.success, res.failure
        errors.append(np.max(np.abs(res["pin1.phi"] - np.pi - reference)))
    assert errors[1] < errors[0] / 10 and errors[2] < errors[1] / 10 and errors[2] < 1e-7, errors
    E = res["energy.total"]
    assert np.max(np.abs(E - E[0])) < 1e-6 * 1.0 * g * L


def test_kinematic_four_bar_through_the_corners_of_a_speed_ramp():
    # The crank's speed ramps from 1 to 6 rad/s over 0.2..0.7 s (Ramp(5, 0.5)): its acceleration jumps at
    # both corners, where the run restarts. Before the ramp took its right-hand slope at the upper corner
    # (0.7 - 0.2 < 0.5 in floating point) IDAS failed there. Crank angle against the closed-form
    # integral of the ramp, rocker against Freudenstein, over 1 s at rtol 1e-10, atol 1e-11: within 1e-8 rad.
    from mechnet.components.signals import Ramp
    cm = four_bar(drive=rot.Speed(name="motor", w_ref=Ramp(5.0, 0.5, offset=1.0, start_time=0.2),
                                  phi_start=0.3)).compile()
    t = np.linspace(0.0, 1.0, 201)
    res = cm.simulate(1.0, rtol=1e-10, atol=1e-11, t_out=t)
    assert res.success, res.failure
    tau = np.clip(t - 0.2, 0.0, 0.5)
    th2 = 0.3 + t + 10.0 * tau ** 2 / 2 + 5.0 * np.maximum(t - 0.7, 0.0)
    assert np.max(np.abs(res["joint_a.phi"] - th2)) < 1e-8
    _, th4 = four_bar_angles(A, B, C, D, th2)
    assert np.max(np.abs(_wrap(res["joint_d.phi"] - th4))) < 1e-8


def _four_bar_on_a_turntable():
    """The crank-rocker four-bar (pins about z) on a platform that turns freely about world x: the
    loop's plane turns with the platform, so its normal is constant only in the platform's axes."""
    th3, th4 = four_bar_angles(A, B, C, D, 0.3)
    m = mn.Model("turntable_four_bar")
    world = m.add(mb.World(name="world", g=[0.0, -9.81, 0.0]))
    base = m.add(mb.Revolute(name="base", n=[1, 0, 0], phi_start=0.2, w_start=1.0))
    platform = m.add(mb.Body(name="platform", m=3.0, I=np.diag([0.2, 0.3, 0.4])))
    ground = m.add(mb.FixedTranslation(name="ground", r=[D, 0, 0]))
    pins = {k: m.add(mb.Revolute(name=f"joint_{k}", n=[0, 0, 1], **kw))
            for k, kw in (("a", dict(phi_start=0.3, w_start=0.0)), ("b", dict(phi_guess=th3 - 0.3)),
                          ("c", dict(phi_guess=th4 - th3)), ("d", dict(phi_guess=th4)))}
    links = {}
    for name, L, mass in (("crank", A, 1.0), ("coupler", B, 2.0), ("rocker", C, 1.5)):
        links[name] = m.add(mb.FixedTranslation(name=name, r=[L, 0, 0]))
        body = m.add(mb.Body(name=f"{name}_body", m=mass, r_cm=[L / 2, 0, 0],
                             I=np.diag([1e-4, mass * L**2 / 12 + 1e-4, mass * L**2 / 12 + 1e-4])))
        m.connect(links[name].frame_a, body.frame_a)
    for a, b in [(world.frame_b, base.frame_a), (base.frame_b, platform.frame_a), (base.frame_b, ground.frame_a),
                 (base.frame_b, pins["a"].frame_a), (pins["a"].frame_b, links["crank"].frame_a),
                 (links["crank"].frame_b, pins["b"].frame_a), (pins["b"].frame_b, links["coupler"].frame_a),
                 (ground.frame_b, pins["d"].frame_a), (pins["d"].frame_b, links["rocker"].frame_a),
                 (links["coupler"].frame_b, pins["c"].frame_a), (pins["c"].frame_b, links["rocker"].frame_b)]:
        m.connect(a, b)
    m.add(mb.SystemEnergy(name="energy"))
    return m


def test_a_planar_loop_on_a_turning_platform_closes_and_keeps_its_energy():
    """The loop's position residual is resolved in the axes of the loop's root (here the platform), where
    the plane's normal is a constant direction: the three out-of-plane constraints are dropped as on the
    ground, and the mechanism has two degrees of freedom. 1 s at rtol 1e-10, atol 1e-12, no damping:
    energy constant within 1e-7 of the total (measured 1.1e-8 relative; no hand-written model of this
    scene: a regression bound), pins closed within
    10·(rtol·(a+b+c+d) + atol)."""
    cm = _four_bar_on_a_turntable().compile()
    assert "3 redundant constraint(s) dropped (position z (axes of" in cm.summary()
    assert cm.n_states == 4
    res = cm.simulate(1.0, rtol=1e-10, atol=1e-12, n_out=101)
    assert res.success, res.failure
    E = res["energy.total"]
    assert np.max(np.abs(E - E[0])) < 1e-7 * np.max(np.abs(E))
    assert np.ptp(res["base.phi"]) > 0.5                     # the platform did turn
    assert _closure_gap(res, PINS) <= 10 * (1e-10 * (A + B + C + D) + 1e-12)


def _four_bar_about(pin_axis, along, mount=None):
    """The crank-rocker four-bar (A … D above) with its pins about `pin_axis` and its links along `along`
    (perpendicular to it), on the ground or on a fixed `mount` rotation (a rotation vector); isotropic
    link inertias, so the same motion in any orientation has the same joint angles."""
    th3, th4 = four_bar_angles(A, B, C, D, 0.3)
    m = mn.Model("four_bar_about")
    world = m.add(mb.World(name="world", g=[0.0, -9.81, 0.0]))
    base = world.frame_b
    if mount is not None:
        tilt = m.add(mb.FixedRotation(name="tilt", n=list(mount), angle=float(np.linalg.norm(mount))))
        m.connect(base, tilt.frame_a)
        base = tilt.frame_b
    along = np.asarray(along, dtype=float)
    ground = m.add(mb.FixedTranslation(name="ground", r=list(D * along)))
    pins = {k: m.add(mb.Revolute(name=f"joint_{k}", n=list(pin_axis), **kw))
            for k, kw in (("a", dict(phi_start=0.3, w_start=2.0)), ("b", dict(phi_guess=th3 - 0.3)),
                          ("c", dict(phi_guess=th4 - th3)), ("d", dict(phi_guess=th4)))}
    links = {}
    for name, L, mass in (("crank", A, 1.0), ("coupler", B, 2.0), ("rocker", C, 1.5)):
        links[name] = m.add(mb.FixedTranslation(name=name, r=list(L * along)))
        body = m.add(mb.Body(name=f"{name}_body", m=mass, r_cm=list(L / 2 * along), I=0.01 * np.eye(3)))
        m.connect(links[name].frame_a, body.frame_a)
    for a, b in [(base, ground.frame_a), (base, pins["a"].frame_a), (pins["a"].frame_b, links["crank"].frame_a),
                 (links["crank"].frame_b, pins["b"].frame_a), (pins["b"].frame_b, links["coupler"].frame_a),
                 (ground.frame_b, pins["d"].frame_a), (pins["d"].frame_b, links["rocker"].frame_a),
                 (links["coupler"].frame_b, pins["c"].frame_a), (pins["c"].frame_b, links["rocker"].frame_b)]:
        m.connect(a, b)
    return m


def test_a_planar_loop_with_pins_about_an_oblique_axis_moves_like_the_same_loop_on_a_tilted_mount():
    """Pins about n = (1, 2, 2)/3 on the ground, against pins about z on a fixed mount that turns z onto n
    and x onto the links' direction: the same mechanism, the same gravity. Two defects, each caught here:
    the first was refused as over-constrained (the closure's angles about frame_a's axes do not keep the
    out-of-plane directions constant for an oblique axis); the second got a wrong acceleration (a 1e-17
    round-off coefficient of the mount's Rᵀ·R, in a dropped direction's equation, was divided by).
    1 s at rtol 1e-10, atol 1e-12: joint angles agree within 1e-7 rad (each run's error is of order
    1e-9 rad per turn)."""
    from scipy.spatial.transform import Rotation
    n, u = np.array([1.0, 2.0, 2.0]) / 3.0, np.array([2.0, -1.0, 0.0]) / np.sqrt(5.0)
    mount = Rotation.align_vectors([n, u], [[0, 0, 1], [1, 0, 0]])[0]
    oblique = _four_bar_about(n, u).compile()
    assert "3 redundant constraint(s) dropped" in oblique.summary()
    tilted = _four_bar_about([0, 0, 1], [1, 0, 0], mount=mount.as_rotvec()).compile()
    settings = dict(rtol=1e-10, atol=1e-12, n_out=101)
    a, b = oblique.simulate(1.0, **settings), tilted.simulate(1.0, **settings)
    assert a.success and b.success
    for pin in PINS:
        assert np.max(np.abs(a[f"{pin}.phi"] - b[f"{pin}.phi"])) < 1e-7, pin
