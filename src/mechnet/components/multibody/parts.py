"""World, bodies and rigid connections (Modelica.Mechanics.MultiBody.Parts)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ...core.component import Component
from ...core.declarations import Flag, Param, Port, direction, positive, unit_vector
from ...inertia import inertia_problem
from .frames import axis_rotation
from .interfaces import Frame, PartialBody, PartialTreeEdge


def physical_inertia(value):
    """must be a physical inertia tensor (symmetric, positive semi-definite, triangle inequality)

    (The first line describes the check in help(Body) and docs/components.md.)
    """
    return inertia_problem(value)


class World(Component):
    """The inertial frame (origin, axes = world) and the gravity field; exactly one per scene.

    Uniform gravity `g` (m/s², world components) by default; with
    `point_gravity=True` a central field g(r) = −mue·r/|r|³ about the origin instead.
    """

    g = Param([0.0, -9.81, 0.0], unit="m/s2", shape=3, doc="uniform gravity acceleration, world components")
    point_gravity = Flag(False, doc="central gravity field about the world origin instead of uniform g")
    mue = Param(3.986004418e14, unit="m3/s2", check=positive, doc="gravity constant of the central field")
    frame_b = Port(Frame, doc="the world frame")

    def gravity_at(self, r):
        """Gravity acceleration (world components) at the world position r."""
        if self.point_gravity:
            return -self.mue * r / ca.power(ca.sumsqr(r), 1.5)
        return self.g


class Body(PartialBody):
    """A rigid body: mass m, mass centre r_cm (in frame_a) and inertia I about the mass centre (frame_a axes)."""

    m = Param(unit="kg", check=positive, doc="mass")
    r_cm = Param([0.0, 0.0, 0.0], unit="m", shape=3, doc="mass centre, resolved in frame_a")
    I = Param(np.zeros((3, 3)), unit="kg*m2", shape=(3, 3), check=physical_inertia,
              doc="inertia tensor about the mass centre, frame_a axes")

    def mass_properties(self):
        return self.m, self.r_cm, self.I


class Particle(PartialBody):
    """A point mass at the origin of frame_a."""

    m = Param(unit="kg", check=positive, doc="mass")

    def mass_properties(self):
        return self.m, ca.DM.zeros(3), ca.DM.zeros(3, 3)


class FixedTranslation(PartialTreeEdge):
    """frame_b rigidly fixed at r (resolved in frame_a) from frame_a, same orientation."""

    r = Param(unit="m", shape=3, doc="origin of frame_b, resolved in frame_a")

    def relative_motion(self):
        return ca.SX(self.r), ca.SX.eye(3)


class FixedRotation(PartialTreeEdge):
    """frame_b fixed at r from frame_a and rotated by `angle` (rad) about the axis n (frame_a)."""

    r = Param([0.0, 0.0, 0.0], unit="m", shape=3, doc="origin of frame_b, resolved in frame_a")
    n = Param([0.0, 0.0, 1.0], shape=3, check=direction, doc="rotation axis, resolved in frame_a")
    angle = Param(0.0, unit="rad", doc="rotation angle from frame_a to frame_b")

    def relative_motion(self):
        n = ca.DM(unit_vector(self.n))
        return ca.SX(self.r), axis_rotation(n, self.angle)
