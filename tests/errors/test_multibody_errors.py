"""Multibody scenes a user can get wrong: a MechnetError subclass naming the culprit and what is wrong.

Construction-time problems (axes, inertia tensors, vector sizes, flags, loads) raise ParameterError
naming `name (Type)` and the argument; scene problems found at compile time (no World, two Worlds, a
body with no path to the World, kinematic loops, joints that move no mass) raise StructureError
naming the components involved.
"""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import translational as tr


def culprit(component: str, cls, *words: str) -> str:
    """Regex: `component (Class)` followed (anywhere later) by each of `words` in order."""
    return rf"(?s){re.escape(component)} \({cls.__name__}\)" + "".join(rf".*{re.escape(w)}" for w in words)


def _connect(m, pairs):
    for a, b in pairs:
        m.connect(a, b)


# ---- construction: axes, inertia, sizes, flags, loads --------------------------------------------

@pytest.mark.parametrize("cls, name, extra", [
    (mb.Revolute, "hinge", {}),
    (mb.Prismatic, "slide", {}),
    (mb.FixedRotation, "tilt", {"angle": 0.3}),
], ids=["Revolute", "Prismatic", "FixedRotation"])
def test_zero_axis_is_refused(cls, name, extra):
    with pytest.raises(mn.ParameterError, match=culprit(name, cls, "n", "zero vector")):
        cls(name=name, n=[0.0, 0.0, 0.0], **extra)


@pytest.mark.parametrize("I, reason", [
    ([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "not symmetric"),
    (np.diag([1.0, 1.0, -1.0]), "not positive semi-definite"),
    (np.diag([1.0, 1.0, 3.0]), "triangle inequality"),
    (np.diag([1.0, np.nan, 1.0]), "not finite"),
], ids=["asymmetric", "indefinite", "triangle", "nan"])
def test_non_physical_inertia_is_refused(I, reason):
    with pytest.raises(mn.ParameterError, match=culprit("arm", mb.Body, "I", reason)):
        mb.Body(name="arm", m=1.0, I=I)


def test_physical_inertia_limits_are_accepted():
    # the limits themselves are physical: a point mass (zero tensor), a thin rod (0, a, a) and a flat plate
    # (a, b, a + b) meet the triangle inequality with equality
    for I in (np.zeros((3, 3)), np.diag([0.0, 1.0, 1.0]), np.diag([1.0, 2.0, 3.0])):
        mb.Body(name="ok", m=1.0, I=I)


@pytest.mark.parametrize("make, component, cls, param, expected", [
    (lambda: mb.FixedTranslation(name="rod", r=[1.0, 0.0]), "rod", mb.FixedTranslation, "r", "vector of 3"),
    (lambda: mb.Revolute(name="hinge", n=[1.0, 0.0]), "hinge", mb.Revolute, "n", "vector of 3"),
    (lambda: mb.Prismatic(name="slide", n=[1.0, 0.0, 0.0, 0.0]), "slide", mb.Prismatic, "n", "vector of 3"),
    (lambda: mb.Body(name="arm", m=1.0, r_cm=[0.1, 0.2]), "arm", mb.Body, "r_cm", "vector of 3"),
    (lambda: mb.Body(name="arm", m=1.0, I=np.eye(2)), "arm", mb.Body, "I", "3x3"),
    (lambda: mb.World(name="world", g=[0.0, -9.81]), "world", mb.World, "g", "vector of 3"),
    (lambda: mb.FixedTranslation(name="rod", r=[np.nan, 0.0, 0.0]), "rod", mb.FixedTranslation, "r", "not finite"),
], ids=["r", "n_revolute", "n_prismatic", "r_cm", "I", "g", "r_nan"])
def test_wrong_vector_size_is_refused(make, component, cls, param, expected):
    with pytest.raises(mn.ParameterError, match=culprit(component, cls, param, expected)):
        make()


@pytest.mark.parametrize("cls, name, kw", [
    (mb.Particle, "pt", {"m": 0.0}),
    (mb.Body, "arm", {"m": -1.0}),
    (mb.Spring, "spring", {"c": -1.0}),
    (mb.Gravitation, "grav", {"m_a": 1.0, "m_b": 1.0, "G": 0.0}),
    (mb.World, "world", {"point_gravity": True, "mue": -1.0}),
], ids=["Particle_m", "Body_m", "Spring_c", "Gravitation_G", "World_mue"])
def test_non_physical_scalars_are_refused(cls, name, kw):
    param = {"Particle": "m", "Body": "m", "Spring": "c", "Gravitation": "G", "World": "mue"}[cls.__name__]
    with pytest.raises(mn.ParameterError, match=culprit(name, cls, param)):
        cls(name=name, **kw)


@pytest.mark.parametrize("cls", [mb.Revolute, mb.Prismatic])
@pytest.mark.parametrize("value", [1, "yes", None])
def test_use_flange_must_be_a_bool(cls, value):
    with pytest.raises(mn.ParameterError, match=culprit("joint", cls, "use_flange", "True or False")):
        cls(name="joint", use_flange=value)


@pytest.mark.parametrize("cls, port, fixed", [
    (mb.Revolute, "axis", rot.Fixed), (mb.Revolute, "support", rot.Fixed),
    (mb.Prismatic, "axis", tr.Fixed), (mb.Prismatic, "support", tr.Fixed),
])
def test_flanges_exist_only_with_use_flange(cls, port, fixed):
    m = mn.Model("m")
    joint = m.add(cls(name="joint"))
    ground = m.add(fixed(name="ground"))
    with pytest.raises(mn.ConnectError, match=culprit("joint", cls, port, "use_flange=True")):
        m.connect(getattr(joint, port), ground.flange)


@pytest.mark.parametrize("cls, key, value", [
    (mb.WorldForce, "force", [1.0, 2.0]),
    (mb.WorldForce, "force", [1.0, 2.0, 3.0, 4.0]),
    (mb.WorldForce, "force", 3.0),
    (mb.WorldTorque, "torque", [1.0, 2.0]),
], ids=["force_2", "force_4", "force_scalar", "torque_2"])
def test_world_load_needs_three_entries(cls, key, value):
    with pytest.raises(mn.ParameterError, match=culprit("load", cls, key, "three numbers or signals")):
        cls(name="load", **{key: value})


def test_world_load_entry_and_resolve_in_are_checked():
    with pytest.raises(mn.ParameterError, match=culprit("load", mb.WorldForce, "force[1]", "not a number")):
        mb.WorldForce(name="load", force=[1.0, "a", 0.0])
    with pytest.raises(mn.ParameterError, match=culprit("load", mb.WorldTorque, "resolve_in", "'frame_a'")):
        mb.WorldTorque(name="load", torque=[0.0, 0.0, 1.0], resolve_in="frame_a")


# ---- scene structure: World, connectivity, loops ---------------------------------------------------

def _pendulum_scene(m, world):
    rev = m.add(mb.Revolute(name="rev", phi_start=0.1, w_start=0.0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[1.0, 0.0, 0.0]))
    pt = m.add(mb.Particle(name="pt", m=1.0))
    _connect(m, [(rev.frame_b, rod.frame_a), (rod.frame_b, pt.frame_a)])
    if world is not None:
        m.connect(world.frame_b, rev.frame_a)
    return rod


def test_body_without_path_to_the_world():
    # a body on a fixed translation that is connected to nothing else floats free: its position is undefined
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    _pendulum_scene(m, world)
    loose = m.add(mb.FixedTranslation(name="loose", r=[1.0, 0.0, 0.0]))
    orphan = m.add(mb.Body(name="orphan", m=1.0, r_cm=[0.1, 0.0, 0.0]))
    m.connect(loose.frame_b, orphan.frame_a)
    with pytest.raises(mn.StructureError, match=r"no path to the World \(world\).*orphan \(Body\)") as err:
        m.compile()
    assert "loose (FixedTranslation)" in str(err.value)
    assert "pt (Particle)" not in str(err.value)       # the connected pendulum is not blamed


def test_two_worlds_are_named():
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    m.add(mb.World(name="earth"))
    _pendulum_scene(m, world)
    with pytest.raises(mn.StructureError, match=r"2 Worlds") as err:
        m.compile()
    assert "world" in str(err.value) and "earth" in str(err.value) and "exactly one World" in str(err.value)


def test_no_world():
    m = mn.Model("m")
    _pendulum_scene(m, None)
    with pytest.raises(mn.StructureError, match=r"no World") as err:
        m.compile()
    assert "rev.frame_a" in str(err.value)        # names frames of the scene
    assert "World(name='world')" in str(err.value)  # and says what to add


def test_two_joints_to_one_body_close_a_kinematic_loop():
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    hinge_z = m.add(mb.Revolute(name="hinge_z", n=[0, 0, 1]))
    hinge_y = m.add(mb.Revolute(name="hinge_y", n=[0, 1, 0]))
    body = m.add(mb.Body(name="body", m=1.0, r_cm=[0.5, 0.0, 0.0]))
    _connect(m, [(world.frame_b, hinge_z.frame_a), (hinge_z.frame_b, body.frame_a),
                 (world.frame_b, hinge_y.frame_a), (hinge_y.frame_b, body.frame_a)])
    with pytest.raises(mn.StructureError, match=r"kinematic loop") as err:
        m.compile()
    assert "hinge_z" in str(err.value) and "hinge_y" in str(err.value)


# ---- a joint that moves no mass ---------------------------------------------------------------

def _massless_link(n, r):
    """World → Revolute(n) → FixedTranslation(r) → Particle: with r on the axis the particle does not move."""
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=n, phi_start=0.3, w_start=0.1))
    rod = m.add(mb.FixedTranslation(name="rod", r=r))
    pt = m.add(mb.Particle(name="pt", m=1.0))
    _connect(m, [(world.frame_b, rev.frame_a), (rev.frame_b, rod.frame_a), (rod.frame_b, pt.frame_a)])
    return m


def test_joint_moving_no_mass_is_refused_at_compile():
    # the particle at the joint's origin (on the axis): no inertia about the axis, the acceleration is 0/0
    with pytest.raises(mn.StructureError, match=culprit("rev", mb.Revolute, "moves no mass")):
        _massless_link([0, 0, 1], [0, 0, 0]).compile()
    # the same on the axis but away from the origin, and for a body with inertia only across the axis
    with pytest.raises(mn.StructureError, match=culprit("rev", mb.Revolute, "moves no mass")):
        _massless_link([0, 0, 1], [0, 0, 0.5]).compile()
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1]))
    body = m.add(mb.Body(name="needle", m=1.0, r_cm=[0, 0, 0.3], I=np.diag([1.0, 1.0, 0.0])))
    _connect(m, [(world.frame_b, rev.frame_a), (rev.frame_b, body.frame_a)])
    with pytest.raises(mn.StructureError, match=culprit("rev", mb.Revolute, "moves no mass")):
        m.compile()


def test_joint_moving_no_mass_deeper_in_the_tree_is_named():
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    rod = _pendulum_scene(m, world)
    spin = m.add(mb.Revolute(name="spin", n=[1, 0, 0]))       # along the rod, the bead at the rod's end
    bead = m.add(mb.Particle(name="bead", m=1.0))
    _connect(m, [(rod.frame_b, spin.frame_a), (spin.frame_b, bead.frame_a)])
    with pytest.raises(mn.StructureError, match=culprit("spin", mb.Revolute, "moves no mass")) as err:
        m.compile()
    assert "rev (" not in str(err.value)


def _outcome(model):
    """Compile and simulate; return the message of a MechnetError raised, or of res.failure, or None."""
    try:
        cm = model.compile()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = cm.simulate(1.0, n_out=11)
    except mn.MechnetError as e:
        return str(e)
    return None if res.failure is None else str(res.failure)


@pytest.mark.parametrize("n, r", [
    pytest.param([1, 1, 0], [1, 1, 0], id="diagonal_axis"),
    pytest.param([1, 2, 3], [0.1, 0.2, 0.3], id="skew_axis"),
    pytest.param([0, 0.6, 0.8], [0, 0.3, 0.4], id="tilted_axis"),
])
def test_joint_moving_no_mass_on_a_tilted_axis(n, r):
    # The particle lies on a non-coordinate axis: the joint's acceleration is undetermined. Acceptable
    # outcomes: a MechnetError at compile or simulate, or a result with res.failure set — naming the joint.
    message = _outcome(_massless_link(n, r))
    assert message is not None, "a joint that moves no mass must not simulate silently"
    assert "rev" in message
    assert "moves no mass" in message        # caught at compile by the numerical pivot check


def test_loop_that_moves_no_mass_is_refused_naming_its_joints():
    # A slider-crank whose only mass is a particle on the crank axis: the loop's one freedom moves no
    # mass, so the check that lets a loop give a joint its mass (issue 15, item 8) must still refuse it.
    m = mn.Model("m")
    world = m.add(mb.World(name="world"))
    crank_j = m.add(mb.Revolute(name="crank_joint", n=[0, 0, 1], phi_start=0.3))
    rod_j = m.add(mb.Revolute(name="rod_joint", n=[0, 0, 1]))
    wrist = m.add(mb.Revolute(name="wrist_pin", n=[0, 0, 1]))
    slider = m.add(mb.Prismatic(name="slider", n=[1, 0, 0], s_guess=0.25))
    crank = m.add(mb.FixedTranslation(name="crank", r=[0.05, 0, 0]))
    conrod = m.add(mb.FixedTranslation(name="conrod", r=[0.2, 0, 0]))
    hub = m.add(mb.Particle(name="hub", m=1.0))
    _connect(m, [(world.frame_b, crank_j.frame_a), (crank_j.frame_b, hub.frame_a),
                 (crank_j.frame_b, crank.frame_a), (crank.frame_b, rod_j.frame_a),
                 (rod_j.frame_b, conrod.frame_a), (conrod.frame_b, wrist.frame_a),
                 (world.frame_b, slider.frame_a), (slider.frame_b, wrist.frame_b)])
    with pytest.raises(mn.StructureError, match=culprit("crank_joint", mb.Revolute, "no mass", "loop")):
        m.compile()
