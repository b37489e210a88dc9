"""The `Frame` connector and the roles multibody components play in the frame tree.

Modelica's names: a frame carries its origin `r_0` and orientation `R`
(potentials) and the cut force `f` and cut torque `t` (flows, resolved in the
frame, positive into the component). The compiler's tree pass
(compile/spanning_tree.py) gives every frame's `r_0` and `R` as expressions of
the joint coordinates, so orientation is never an unknown; components only
say which role they play:

- `PartialTreeEdge`: a massless connection of frame_a to frame_b that the tree
  is built from (joints, fixed translations and rotations). It balances the
  wrench across itself; the pass supplies the relative motion.
- `PartialBody`: mass properties at frame_a; the pass writes its Newton–Euler
  equations inside the tree recursion.
- anything else with frames (force elements, sensors) writes its own
  equations in terms of the frame variables; its cut forces are external
  loads on the tree.
"""
from __future__ import annotations

import casadi as ca

from ...core.component import Component, Connector
from ...core.declarations import Across, Port, Through
from .frames import to_matrix


class Frame(Connector):
    r_0 = Across(unit="m", shape=3, priority="avoid", doc="position of the frame origin, resolved in world")
    R = Across(unit="1", shape=9, priority="avoid", nominal=1.0,
               doc="orientation: the frame axes as columns, resolved in world (row-major, v_0 = R·v)")
    f = Through(unit="N", shape=3, doc="cut force, resolved in the frame, positive into the component")
    t = Through(unit="N*m", shape=3,
                doc="cut torque about the origin, resolved in the frame, positive into the component")

    def rotation(self) -> ca.SX:
        """R as a 3x3 matrix."""
        return to_matrix(self._values["R"])


class PartialTreeEdge(Component, abstract=True):
    """A massless link from frame_a to frame_b that can carry the tree.

    Subclasses give the motion of frame_b relative to frame_a (`relative_motion`)
    and, for joints, their coordinate, speed, axis torque and motion axes.
    """

    frame_a = Port(Frame, doc="first frame")
    frame_b = Port(Frame, doc="second frame")

    dof = 0

    def relative_motion(self):
        """(r_rel, R_rel): frame_b's origin resolved in frame_a, and R_b = R_a · R_rel."""
        raise NotImplementedError

    def equations(self):
        """None of its own: the tree pass writes the wrench balance across the edge (massless), oriented
        parent → child so each cut force is solved with a constant coefficient."""
        return []


class PartialJoint(PartialTreeEdge, abstract=True):
    """A tree edge with one degree of freedom: coordinate q, speed q̇ and the force or torque along it."""

    dof = 1

    def coordinate(self) -> ca.SX:
        raise NotImplementedError

    def speed(self) -> ca.SX:
        raise NotImplementedError

    def axis_load(self) -> ca.SX:
        """The torque (revolute) or force (prismatic) that drives the joint coordinate."""
        raise NotImplementedError

    def motion_axes(self):
        """(angular, linear) unit motion per unit q̇, resolved in frame_a (3-vectors)."""
        raise NotImplementedError


class PartialMultiJoint(PartialTreeEdge, abstract=True):
    """A tree edge with several degrees of freedom (`dof`): coordinates (a quaternion among them, so more
    coordinates than freedoms), speeds ν (one per freedom) and the motion subspace S: the spatial
    velocity across the joint is S·ν. Walked from frame_a to frame_b only (frame_a towards the world)."""

    dof = 3
    quaternions: tuple = ()          # keys of quaternion states: renormalised at restarts, |Q| − 1 reported

    def coordinate(self) -> ca.SX:
        raise NotImplementedError

    def speed(self) -> ca.SX:
        raise NotImplementedError

    def axis_load(self) -> ca.SX:
        """Generalised forces along ν (none: these joints are not driven)."""
        return ca.SX.zeros(self.dof)

    def motion_subspace(self, R_a, R_b) -> ca.SX:
        """S (6 x dof, angular rows first, world axes) for frame orientations R_a and R_b."""
        raise NotImplementedError

    def motion_bias(self, S, nu) -> ca.SX:
        """dS/dt·ν beyond ω_parent × (S·ν): nonzero where a column of S is carried by a frame the joint
        itself turns relative to the parent (a universal joint's second axis). Zero for columns fixed in
        frame_a, and for Spherical's S = R_b (ω_b × R_b·ν = ω_a × R_b·ν)."""
        return ca.SX.zeros(6)


class PartialBody(Component, abstract=True):
    """Mass properties attached at frame_a: mass, mass centre (in frame_a) and inertia about it (frame_a axes)."""

    frame_a = Port(Frame, doc="the frame the body is attached at")

    def mass_properties(self):
        raise NotImplementedError


class PartialTwoFrames(Component, abstract=True):
    """Base of force elements and sensors between two frames (their cut forces load the tree)."""

    frame_a = Port(Frame, doc="first frame")
    frame_b = Port(Frame, doc="second frame")
