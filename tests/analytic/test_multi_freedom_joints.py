"""Universal, Cylindrical and Planar joints against the same freedoms built from revolute and prismatic
joints in series (massless links between them: the tree passes the same motion through either way).

Settings: rtol 1e-10, atol 1e-12, 3 s; coordinates agree within 1e-8 (both runs' integration error,
~10·rtol·scale with angles and distances of order 1). Energy is conserved to 1e-8 relative in the
joints' own run (no damping, gravity only)."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet import inertia
from mechnet.components import multibody as mb

G = 9.81
SETTINGS = dict(rtol=1e-10, atol=1e-12, n_out=301)


def _bob(m, at, offset=(0.3, -0.2, -1.0)):
    rod = m.add(mb.FixedTranslation(name="rod", r=list(offset)))
    body = m.add(mb.Body(name="bob", m=2.0, I=inertia.box(2.0, 0.2, 0.3, 0.1)))
    energy = m.add(mb.SystemEnergy(name="energy"))
    m.connect(at, rod.frame_a)
    m.connect(rod.frame_b, body.frame_a)
    return energy


def _series(m, world, joints):
    frame = world.frame_b
    for j in joints:
        m.connect(frame, j.frame_a)
        frame = j.frame_b
    return frame


def _universal(single):
    m = mn.Model("universal")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    if single:
        joint = m.add(mb.Universal(name="u", n_a=[1, 0, 0], n_b=[0, 1, 0], phi_a_start=0.4, phi_b_start=-0.3,
                                   w_a_start=1.0, w_b_start=0.5))
        end = _series(m, world, [joint])
    else:
        a = m.add(mb.Revolute(name="ra", n=[1, 0, 0], phi_start=0.4, w_start=1.0))
        b = m.add(mb.Revolute(name="rb", n=[0, 1, 0], phi_start=-0.3, w_start=0.5))
        end = _series(m, world, [a, b])
    _bob(m, end)
    return m


def _cylindrical(single):
    m = mn.Model("cylindrical")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    tilt = m.add(mb.FixedRotation(name="tilt", n=[0, 0, 1], angle=0.5))
    m.connect(world.frame_b, tilt.frame_a)
    if single:
        joint = m.add(mb.Cylindrical(name="c", n=[1, 0, 0], s_start=0.2, phi_start=0.1, v_start=0.0, w_start=2.0))
        m.connect(tilt.frame_b, joint.frame_a)
        end = joint.frame_b
    else:
        p = m.add(mb.Prismatic(name="p", n=[1, 0, 0], s_start=0.2, v_start=0.0))
        r = m.add(mb.Revolute(name="r", n=[1, 0, 0], phi_start=0.1, w_start=2.0))
        m.connect(tilt.frame_b, p.frame_a)
        m.connect(p.frame_b, r.frame_a)
        end = r.frame_b
    _bob(m, end, offset=(0.0, 0.5, 0.0))
    return m


def _planar(single):
    m = mn.Model("planar")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    if single:
        joint = m.add(mb.Planar(name="pl", n=[0, 0, 1], s_x_start=0.0, s_y_start=0.0, phi_start=0.3,
                                v_x_start=1.0, v_y_start=5.0, w_start=4.0))
        end = _series(m, world, [joint])
    else:
        e_x, e_y = mb.joints._PlaneAxes.across([0, 0, 1])
        px = m.add(mb.Prismatic(name="px", n=list(e_x), s_start=0.0, v_start=1.0))
        py = m.add(mb.Prismatic(name="py", n=list(e_y), s_start=0.0, v_start=5.0))
        r = m.add(mb.Revolute(name="r", n=[0, 0, 1], phi_start=0.3, w_start=4.0))
        end = _series(m, world, [px, py, r])
    _bob(m, end, offset=(0.4, 0.0, 0.0))
    return m


CASES = {
    "universal": (_universal, [("u.phi_a", "ra.phi"), ("u.phi_b", "rb.phi")]),
    "cylindrical": (_cylindrical, [("c.s", "p.s"), ("c.phi", "r.phi")]),
    "planar": (_planar, [("pl.s_x", "px.s"), ("pl.s_y", "py.s"), ("pl.phi", "r.phi")]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_joint_with_several_freedoms_moves_as_its_joints_in_series(case):
    build, pairs = CASES[case]
    one = build(True).compile().simulate(3.0, **SETTINGS)
    series = build(False).compile().simulate(3.0, **SETTINGS)
    assert one.failure is None and series.failure is None
    for mine, theirs in pairs:
        assert np.max(np.abs(one[mine] - series[theirs])) <= 1e-8, (mine, theirs)
    energy = one["energy.total"]
    assert np.max(np.abs(energy - energy[0])) <= 1e-8 * max(np.max(np.abs(one["energy.kinetic"])), 1.0)


def test_a_universal_joint_with_parallel_axes_is_refused():
    with pytest.raises(mn.MechnetError, match="u \\(Universal\\): n_a .* parallel"):
        mb.Universal(name="u", n_a=[1, 0, 0], n_b=[2, 0, 0])


def test_a_cardan_shaft_has_the_textbook_speed_ratio():
    """Input shaft (x) driven at 2 rad/s by a Speed source, a cross on two pins (z, then y), an output
    shaft tilted by β = 0.4 rad in the x-y plane: a spatial loop of four revolutes whose axes meet at one
    point (its position closures are redundant and dropped). The output speed ratio is
    cos β / (1 − sin²β·cos²φ), φ the input yoke's angle from the plane of the two shafts: the yoke holds
    the first pin (z), perpendicular to that plane at input.phi = 0, so φ = input.phi + π/2. Within 1e-9
    over 3 s (rtol 1e-11, atol 1e-12). (The loop is built from revolutes: a Universal joint cannot lie
    on a loop yet.)"""
    from mechnet.components import rotational as rot
    from mechnet.components import signals as sig
    beta = 0.4
    m = mn.Model("cardan")
    world = m.add(mb.World(name="world", g=[0, 0, 0]))
    inp = m.add(mb.Revolute(name="input", n=[1, 0, 0], use_flange=True))
    motor = m.add(rot.Speed(name="motor", w_ref=sig.Constant(2.0), phi_start=0.0))
    fixed = m.add(rot.Fixed(name="fixed"))
    yoke_in = m.add(mb.Body(name="yoke_in", m=1.0, I=inertia.box(1.0, 0.1, 0.1, 0.1)))
    pin_a = m.add(mb.Revolute(name="pin_a", n=[0, 0, 1]))
    pin_b = m.add(mb.Revolute(name="pin_b", n=[0, 1, 0]))
    cross = m.add(mb.Body(name="cross", m=0.2, I=inertia.sphere(0.2, 0.02)))
    tilt = m.add(mb.FixedRotation(name="tilt", n=[0, 0, 1], angle=beta))
    out = m.add(mb.Revolute(name="output", n=[1, 0, 0]))
    yoke_out = m.add(mb.Body(name="yoke_out", m=1.0, I=inertia.box(1.0, 0.1, 0.1, 0.1)))
    for a, b in [(motor.flange, inp.axis), (fixed.flange, inp.support), (world.frame_b, inp.frame_a),
                 (inp.frame_b, yoke_in.frame_a), (inp.frame_b, pin_a.frame_a), (pin_a.frame_b, cross.frame_a),
                 (pin_a.frame_b, pin_b.frame_a), (world.frame_b, tilt.frame_a), (tilt.frame_b, out.frame_a),
                 (out.frame_b, yoke_out.frame_a), (out.frame_b, pin_b.frame_b)]:
        m.connect(a, b)
    res = m.compile().simulate(3.0, rtol=1e-11, atol=1e-12, n_out=301)
    assert res.failure is None
    phi = res["input.phi"] + np.pi / 2
    expected = np.cos(beta) / (1 - np.sin(beta) ** 2 * np.cos(phi) ** 2)
    assert np.max(np.abs(res["output.w"] / res["input.w"] - expected)) <= 1e-9
    assert np.ptp(res["output.w"] / res["input.w"]) > 0.1          # the ratio really varies (1/cos β − cos β)


def _on_a_tumbling_arm(kind, single):
    """The joint under test between moving bodies: World – Spherical (tumbling) – BodyBox arm – joint –
    rod – off-axis body, gravity −y: the parent's rotation enters the velocity-product terms."""
    m = mn.Model(kind)
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    sph = m.add(mb.Spherical(name="sph", axis_start=[1, 2, 3], angle_start=0.8, w_rel_start=[2.0, -1.0, 3.0]))
    arm = m.add(mb.BodyBox(name="arm", r=[0.6, 0.2, -0.1], width=0.08, density=3000.0))
    m.connect(world.frame_b, sph.frame_a)
    m.connect(sph.frame_b, arm.frame_a)
    if kind == "universal":
        joints = [mb.Universal(name="u", n_a=[1, 1, 0], n_b=[0, 0, 1], phi_a_start=0.4, phi_b_start=-0.3,
                               w_a_start=1.0, w_b_start=0.5)] if single else \
            [mb.Revolute(name="ra", n=[1, 1, 0], phi_start=0.4, w_start=1.0),
             mb.Revolute(name="rb", n=[0, 0, 1], phi_start=-0.3, w_start=0.5)]
        pairs = [("u.phi_a", "ra.phi"), ("u.phi_b", "rb.phi")]
    elif kind == "cylindrical":
        joints = [mb.Cylindrical(name="c", n=[0, 1, 1], s_start=0.2, phi_start=0.1, v_start=0.3, w_start=2.0)] \
            if single else [mb.Prismatic(name="p", n=[0, 1, 1], s_start=0.2, v_start=0.3),
                            mb.Revolute(name="r", n=[0, 1, 1], phi_start=0.1, w_start=2.0)]
        pairs = [("c.s", "p.s"), ("c.phi", "r.phi")]
    else:
        e_x, e_y = mb.joints._PlaneAxes.across([1, 0, 1])
        joints = [mb.Planar(name="pl", n=[1, 0, 1], s_x_start=0.1, s_y_start=-0.1, phi_start=0.3, v_x_start=1.0,
                            v_y_start=0.5, w_start=4.0)] if single else \
            [mb.Prismatic(name="px", n=list(e_x), s_start=0.1, v_start=1.0),
             mb.Prismatic(name="py", n=list(e_y), s_start=-0.1, v_start=0.5),
             mb.Revolute(name="r", n=[1, 0, 1], phi_start=0.3, w_start=4.0)]
        pairs = [("pl.s_x", "px.s"), ("pl.s_y", "py.s"), ("pl.phi", "r.phi")]
    frame = arm.frame_b
    for j in joints:
        m.add(j)
        m.connect(frame, j.frame_a)
        frame = j.frame_b
    rod = m.add(mb.FixedTranslation(name="rod", r=[0.3, -0.2, 0.4]))
    bob = m.add(mb.Body(name="bob", m=2.0, r_cm=[0.05, 0.02, -0.03], I=inertia.box(2.0, 0.2, 0.3, 0.1)))
    m.connect(frame, rod.frame_a)
    m.connect(rod.frame_b, bob.frame_a)
    return m, pairs


@pytest.mark.parametrize("kind", ["universal", "cylindrical", "planar"])
def test_the_joints_agree_with_their_series_on_a_tumbling_parent(kind):
    """Coordinates within 1e-8 of the series build over 0.5 s (rtol 1e-11, atol 1e-13; the motion is
    chaotic later, so early: both runs' error ~10·rtol·scale)."""
    settings = dict(rtol=1e-11, atol=1e-13, n_out=51)
    (one, pairs), (series, _) = _on_a_tumbling_arm(kind, True), _on_a_tumbling_arm(kind, False)
    a, b = one.compile().simulate(0.5, **settings), series.compile().simulate(0.5, **settings)
    for mine, theirs in pairs:
        assert np.max(np.abs(a[mine] - b[theirs])) <= 1e-8, (mine, theirs)
