"""Bodies from shapes (BodyShape, BodyBox, BodyCylinder: Modelica's two-frame bodies) against the same
scene built from Body + FixedTranslation, and their mass properties against mechnet.inertia's tables."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet import inertia
from mechnet.components import multibody as mb

RHO = 7700.0


def _double_pendulum(shapes: bool, backwards: bool = False):
    """World – revolute – link (1 m box 0.1 x 0.05) – revolute – 0.5 m cylinder (diameter 5 cm), steel;
    with shapes=False the same from Body + FixedTranslation. backwards: the box hangs from its frame_b."""
    m = mn.Model("shapes" if shapes else "plain")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=-1.0, w_start=0.0))
    m.connect(world.frame_b, rev.frame_a)
    r = [-1.0, 0, 0] if backwards else [1.0, 0, 0]
    mass = RHO * 1.0 * 0.1 * 0.05
    if shapes:
        link = m.add(mb.BodyBox(name="link", r=r, width=0.1, height=0.05))
        near, far = (link.frame_b, link.frame_a) if backwards else (link.frame_a, link.frame_b)
        m.connect(rev.frame_b, near)
        body_at = None
    else:
        link = m.add(mb.FixedTranslation(name="link", r=r))
        body = m.add(mb.Body(name="body", m=mass, r_cm=[x / 2 for x in r], I=inertia.box(mass, 1.0, 0.1, 0.05)))
        near, far = (link.frame_b, link.frame_a) if backwards else (link.frame_a, link.frame_b)
        m.connect(rev.frame_b, near)
        m.connect(link.frame_a, body.frame_a)
        body_at = body
    rev2 = m.add(mb.Revolute(name="rev2", n=[0, 0, 1], phi_start=0.5, w_start=0.0))
    m.connect(far, rev2.frame_a)
    if shapes:
        tip = m.add(mb.BodyCylinder(name="tip", r=[0.5, 0, 0], diameter=0.05))
    else:
        mass2 = RHO * np.pi / 4 * 0.05 ** 2 * 0.5
        tip = m.add(mb.Body(name="tip", m=mass2, r_cm=[0.25, 0, 0], I=inertia.cylinder(mass2, 0.025, 0.5, axis=0)))
    m.connect(rev2.frame_b, tip.frame_a)
    return m, body_at


@pytest.mark.parametrize("backwards", [False, True])
def test_shapes_move_as_body_plus_fixed_translation(backwards):
    """The same motion (rtol 1e-10, atol 1e-12, 2 s: identical to 1e-12 rad, both built from the same
    numbers) and the same cut forces: a BodyBox's frame_a carries what the Body and the FixedTranslation
    carry there together, its frame_b what the FixedTranslation's does (1e-9 N relative)."""
    a = _double_pendulum(True, backwards)[0].compile().simulate(2.0, rtol=1e-10, atol=1e-12)
    b = _double_pendulum(False, backwards)[0].compile().simulate(2.0, rtol=1e-10, atol=1e-12)
    for name in ("rev.phi", "rev2.phi"):
        assert np.max(np.abs(a[name] - b[name])) <= 1e-12
    for i in range(3):
        together = b[f"link.frame_a.f[{i}]"] + b[f"body.frame_a.f[{i}]"]
        scale = np.max(np.abs(together)) + 1.0
        assert np.max(np.abs(a[f"link.frame_a.f[{i}]"] - together)) <= 1e-9 * scale
        assert np.max(np.abs(a[f"link.frame_b.f[{i}]"] - b[f"link.frame_b.f[{i}]"])) <= 1e-9 * scale


def test_a_box_along_any_axis_has_the_tables_inertia():
    """A hollow box along z, its width along x: m = ρ·L·(w·h − wi·hi); I = outer box − hollow (the box
    table, mechnet.inertia.box) in the axes (length, width, height) = (z, x, y); mass centre halfway."""
    box = mb.BodyBox(name="box", r=[0, 0, 2.0], r_shape=[0, 0, 0.5], length_direction=[0, 0, 3.0],
                     width_direction=[1.0, 0, 0.2], width=0.2, height=0.1, inner_width=0.1, inner_height=0.05)
    m, r_cm, I = box.mass_properties()
    L, outer, inner = 1.5, RHO * 1.5 * 0.2 * 0.1, RHO * 1.5 * 0.1 * 0.05
    assert abs(float(m) - (outer - inner)) <= 1e-12 * outer
    assert np.allclose(np.asarray(r_cm).ravel(), [0, 0, 0.5 + L / 2], rtol=0, atol=1e-15)
    table = inertia.box(outer, L, 0.2, 0.1) - inertia.box(inner, L, 0.1, 0.05)    # axes (length, width, height)
    E = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0]], dtype=float)                   # columns: z, x, y
    assert np.allclose(np.asarray(I), E @ table @ E.T, rtol=1e-12, atol=1e-15)


def test_a_tube_has_the_hollow_cylinders_inertia():
    """BodyCylinder with an inner diameter: m = ρ·π/4·(d² − di²)·L, I = mechnet.inertia.hollow_cylinder."""
    tube = mb.BodyCylinder(name="tube", r=[0, 0.8, 0], diameter=0.1, inner_diameter=0.08)
    m, r_cm, I = tube.mass_properties()
    mass = RHO * np.pi / 4 * (0.1 ** 2 - 0.08 ** 2) * 0.8
    assert abs(float(m) - mass) <= 1e-12 * mass
    assert np.allclose(np.asarray(r_cm).ravel(), [0, 0.4, 0], atol=1e-15)
    assert np.allclose(np.asarray(I), inertia.hollow_cylinder(mass, 0.04, 0.05, 0.8, axis=1), rtol=1e-12)


def test_body_shape_is_a_body_and_a_rigid_link():
    """BodyShape(r, r_cm, m, I) moves as Body + FixedTranslation (identical numbers, rtol 1e-10, 2 s)."""
    def build(shape):
        m = mn.Model("bs")
        world = m.add(mb.World(name="world"))
        rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=-0.3, w_start=1.0))
        m.connect(world.frame_b, rev.frame_a)
        I = inertia.rod(2.0, 1.2)
        if shape:
            link = m.add(mb.BodyShape(name="link", r=[1.2, 0, 0], r_cm=[0.6, 0, 0], m=2.0, I=I))
            m.connect(rev.frame_b, link.frame_a)
        else:
            link = m.add(mb.FixedTranslation(name="link", r=[1.2, 0, 0]))
            body = m.add(mb.Body(name="body", m=2.0, r_cm=[0.6, 0, 0], I=I))
            m.connect(rev.frame_b, link.frame_a)
            m.connect(rev.frame_b, body.frame_a)
        bob = m.add(mb.Body(name="bob", m=0.5, I=inertia.sphere(0.5, 0.05)))
        m.connect(link.frame_b, bob.frame_a)
        return m.compile().simulate(2.0, rtol=1e-10, atol=1e-12)
    a, b = build(True), build(False)
    assert np.array_equal(a["rev.phi"], b["rev.phi"])


@pytest.mark.parametrize("cls,kwargs,match", [
    (mb.BodyBox, dict(r=[1.0, 0, 0], density=-1.0), "density"),
    (mb.BodyBox, dict(r=[1.0, 0, 0], width=-0.1), "width"),
    (mb.BodyBox, dict(r=[1.0, 0, 0], width_direction=[2.0, 0, 0]), "width_direction .* parallel"),
    (mb.BodyBox, dict(r=[1.0, 0, 0], width=0.1, height=0.1, inner_width=0.2, inner_height=0.05), "hollow"),
    (mb.BodyBox, dict(r=[0.0, 0, 0]), "no axis|length"),
    (mb.BodyCylinder, dict(r=[1.0, 0, 0], diameter=0.1, inner_diameter=0.1), "inner_diameter"),
    (mb.BodyCylinder, dict(r=[0.0, 0, 0], length_direction=[1.0, 0, 0]), "length"),
    (mb.BodyShape, dict(r=[1.0, 0, 0], m=0.0), "m"),
])
def test_bad_shapes_are_refused_by_name(cls, kwargs, match):
    with pytest.raises(mn.MechnetError, match=match) as err:
        cls(name="part", **kwargs)
    assert f"part ({cls.__name__})" in str(err.value)


def test_sizes_left_at_their_default_keep_it_when_every_parameter_is_tunable():
    """Under mn.every_parameter_tunable() a BodyBox's 0 sizes (width, height, length) still mean their
    defaults: the same mass (19.25 kg of steel for a 1 m box of 5 cm x 5 cm) as without."""
    plain = mb.BodyBox(name="box", r=[1.0, 0, 0])
    with mn.every_parameter_tunable():
        tuned = mb.BodyBox(name="box", r=[1.0, 0, 0])
    assert "width" in tuned.tunable
    assert abs(float(plain.mass_properties()[0]) - 19.25) <= 1e-12
    assert abs(float(ca_value(tuned.mass_properties()[0], tuned)) - 19.25) <= 1e-12


def ca_value(expr, component):
    """A mass property with the component's tunable symbols at their values."""
    import casadi as ca
    syms = [s for s, _ in component.tunable.values()]
    values = [v for _, v in component.tunable.values()]
    return ca.evalf(ca.substitute(ca.SX(expr), ca.vertcat(*syms), ca.DM(values)))
