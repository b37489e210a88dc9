"""Numbers that would give silent non-physical results are refused, naming the argument (issue 15, item 9).

A NaN or infinite joint coordinate for `kinematics`, operating point for `linearize`/`trim`, or load
component used to come back as NaN results without an error; an axis such as [0, 0, 1e200] overflowed
while being normalised and was then blamed as "moves no mass". The checks are the shared ones of
core/declarations.py (`finite_number`, `direction`, `unit_vector`).
"""
from __future__ import annotations

import re

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb

G, L = 9.81, 0.5            # m/s², m: gravity along −y, pendulum length


def _pendulum(n=(0.0, 0.0, 1.0)):
    """A point mass on a massless rod L along x of a Revolute about n: it hangs at φ = −π/2 for n = +z."""
    m = mn.Model("pendulum")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    rev = m.add(mb.Revolute(name="rev", n=list(n), phi_start=0.1, w_start=0.0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[L, 0.0, 0.0]))
    bob = m.add(mb.Particle(name="bob", m=1.0))
    for a, b in ((world.frame_b, rev.frame_a), (rev.frame_b, rod.frame_a), (rod.frame_b, bob.frame_a)):
        m.connect(a, b)
    return m


@pytest.fixture(scope="module")
def pendulum():
    return _pendulum().compile()


@pytest.mark.parametrize("q, qd, what", [
    ({"rev": np.nan}, None, "q['rev']"),
    ({"rev": np.inf}, None, "q['rev']"),
    (None, {"rev": -np.inf}, "qd['rev']"),
    ({"rev": "a"}, None, "q['rev']"),
])
def test_kinematics_refuses_a_non_finite_coordinate(pendulum, q, qd, what):
    with pytest.raises(mn.InputError, match=re.escape(what)):
        mn.kinematics(pendulum, q=q, qd=qd)


def test_kinematics_refuses_an_unknown_parameter(pendulum):
    with pytest.raises(mn.UnknownNameError, match="rev.mass"):
        mn.kinematics(pendulum, q={"rev": 0.0}, params={"rev.mass": 1.0})


@pytest.mark.parametrize("kwargs, what", [
    ({"x_op": {"rev.phi": np.nan}}, "'rev.phi'"),
    ({"x_op": {"rev.w": np.inf}}, "'rev.w'"),
    ({"x_op": {"rev.phi": 0.0}, "t": np.nan}, "linearize(t=...)"),
])
def test_linearize_refuses_a_non_finite_operating_point(pendulum, kwargs, what):
    with pytest.raises(mn.InputError, match=re.escape(what)):
        pendulum.linearize(**kwargs)


def test_trim_refuses_a_non_finite_guess_or_fixed_value(pendulum):
    with pytest.raises(mn.InputError, match=re.escape("'rev.phi'")):
        pendulum.trim(guess={"rev.phi": np.nan})
    with pytest.raises(mn.InputError, match=re.escape("trim(t=...)")):
        pendulum.trim(t=np.inf)


@pytest.mark.parametrize("cls, key", [(mb.WorldForce, "force"), (mb.WorldTorque, "torque")])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_world_load_refuses_a_non_finite_component(cls, key, bad):
    with pytest.raises(mn.ParameterError, match=re.escape(f"load ({cls.__name__}): {key}[1]") + ".*not finite"):
        cls("load", [1.0, bad, 0.0])


@pytest.mark.parametrize("cls", [mb.Revolute, mb.Prismatic, mb.FixedRotation])
def test_non_finite_axis_is_refused(cls):
    with pytest.raises(mn.ParameterError, match=re.escape(f"axis ({cls.__name__}): parameter n") + ".*not finite"):
        cls(name="axis", n=[0.0, np.nan, 1.0])


@pytest.mark.parametrize("scale", [1e200, 1e-200, 1.0])
def test_axis_of_any_finite_length_gives_the_pendulum_frequency(scale):
    # n = scale·z is the z axis whatever its length: |n| used to overflow (1e200) or underflow (1e-200)
    # and the joint was refused as "moves no mass". Linearised about the hanging position φ = −π/2 the
    # pendulum's poles are ±i·√(g/L), to rtol 1e-9 (exact Jacobians, scale √(g/L) ≈ 4.4 rad/s).
    cm = _pendulum((0.0, 0.0, scale)).compile()
    eig = cm.linearize(x_op={"rev.phi": -np.pi / 2, "rev.w": 0.0}).eigenvalues()
    assert np.allclose(sorted(eig.imag), [-np.sqrt(G / L), np.sqrt(G / L)], rtol=1e-9, atol=0.0)
    assert np.max(np.abs(eig.real)) <= 1e-9 * np.sqrt(G / L)


def test_fixed_rotation_axis_of_huge_length_turns_about_that_axis():
    # FixedRotation about 1e200·x by π/2 takes frame_b's y axis onto world z (exact to 1e-15)
    m = mn.Model("tilt")
    world = m.add(mb.World(name="world"))
    tilt = m.add(mb.FixedRotation(name="tilt", n=[1e200, 0.0, 0.0], angle=np.pi / 2))
    rev = m.add(mb.Revolute(name="rev", n=[0.0, 0.0, 1.0]))
    bob = m.add(mb.Body(name="bob", m=1.0, r_cm=[0.1, 0.0, 0.0], I=np.diag([0.0, 1e-3, 1e-3])))
    for a, b in ((world.frame_b, tilt.frame_a), (tilt.frame_b, rev.frame_a), (rev.frame_b, bob.frame_a)):
        m.connect(a, b)
    frames = mn.kinematics(m.compile(), q={"rev": 0.0})
    R = frames["tilt.frame_b"]["R"]
    assert np.allclose(R, [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]], rtol=0.0, atol=1e-15)
