"""Joints (Modelica.Mechanics.MultiBody.Joints): the tree's edges with degrees of freedom.

Joint coordinates and speeds are states by preference over anything geared
to them (priority "always", Modelica's StateSelect.always): the tree's
recursion then stays O(N) with motors attached.

A joint is massless. Its coordinate and speed are states (`phi_start`,
`w_start` fix them); its axis torque (or force) is zero unless
`use_flange=True`, which exposes a 1D `axis` flange and its `support`, so
motors, gears, springs and prescribed-motion sources drive the joint acausally.
The support carries the reaction torque; in the 3D dynamics the reaction acts
on the parent body (the motor housing sits on the link before the joint).
"""
from __future__ import annotations

import casadi as ca

from ...core.declarations import Flag, Param, Port, State, Var, direction, unit_vector
from ...core.equation import Eq, der
from ..rotational.interfaces import Flange as RotationalFlange
from ..translational.interfaces import Flange as TranslationalFlange
from .frames import axis_rotation
from .interfaces import PartialJoint, PartialTreeEdge


def _unit(n) -> ca.DM:
    return ca.DM(unit_vector(n))


class Revolute(PartialJoint):
    """Rotation of frame_b about the axis n (fixed in frame_a and frame_b) by the angle phi."""

    n = Param([0.0, 0.0, 1.0], shape=3, check=direction, doc="axis of rotation, resolved in frame_a")
    use_flange = Flag(False, doc="expose the 1D flanges axis and support to drive the joint")
    axis = Port(RotationalFlange, enabled_by="use_flange", doc="1D flange driving the joint angle")
    support = Port(RotationalFlange, enabled_by="use_flange", doc="1D support flange (reaction)")
    phi = State(unit="rad", priority="always", doc="rotation angle of frame_b relative to frame_a")
    w = State(unit="rad/s", priority="always", doc="relative angular speed der(phi)")
    tau = Var(unit="N*m", doc="driving torque about the axis (from the axis flange)")

    def relative_motion(self):
        return ca.SX.zeros(3), axis_rotation(_unit(self.n), self.phi)

    def coordinate(self):
        return self.phi

    def speed(self):
        return self.w

    def axis_load(self):
        return self.tau

    def motion_axes(self):
        return _unit(self.n), ca.DM.zeros(3)

    def equations(self):
        eqs = [Eq(der(self.phi), self.w)]
        if self.use_flange:
            return eqs + [Eq(self.axis.phi, self.support.phi + self.phi, "relative angle from the flanges"),
                          Eq(self.axis.tau, self.tau), Eq(self.support.tau, -self.tau, "reaction on the support")]
        return eqs + [Eq(self.tau, 0, "no drive without use_flange")]


class Prismatic(PartialJoint):
    """Translation of frame_b along the axis n (fixed in frame_a) by the distance s."""

    n = Param([1.0, 0.0, 0.0], shape=3, check=direction, doc="axis of translation, resolved in frame_a")
    use_flange = Flag(False, doc="expose the 1D flanges axis and support to drive the joint")
    axis = Port(TranslationalFlange, enabled_by="use_flange", doc="1D flange driving the joint distance")
    support = Port(TranslationalFlange, enabled_by="use_flange", doc="1D support flange (reaction)")
    s = State(unit="m", priority="always", doc="distance of frame_b from frame_a along n")
    v = State(unit="m/s", priority="always", doc="relative speed der(s)")
    f = Var(unit="N", doc="driving force along the axis (from the axis flange)")

    def relative_motion(self):
        return _unit(self.n) * self.s, ca.SX.eye(3)

    def coordinate(self):
        return self.s

    def speed(self):
        return self.v

    def axis_load(self):
        return self.f

    def motion_axes(self):
        return ca.DM.zeros(3), _unit(self.n)

    def equations(self):
        eqs = [Eq(der(self.s), self.v)]
        if self.use_flange:
            return eqs + [Eq(self.axis.s, self.support.s + self.s, "relative distance from the flanges"),
                          Eq(self.axis.f, self.f), Eq(self.support.f, -self.f, "reaction on the support")]
        return eqs + [Eq(self.f, 0, "no drive without use_flange")]


class Weld(PartialTreeEdge):
    """frame_b rigidly on frame_a (same origin and orientation); no degree of freedom."""

    def relative_motion(self):
        return ca.SX.zeros(3), ca.SX.eye(3)
