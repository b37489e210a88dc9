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
import numpy as np

from ...core.declarations import Flag, Param, Port, State, Var, direction, finite_number, unit_vector
from ...core.equation import Eq, der
from ...core.errors import ParameterError
from ..rotational.interfaces import Flange as RotationalFlange
from ..translational.interfaces import Flange as TranslationalFlange
from .frames import (axis_rotation, matrix_of_quaternion, quaternion_of_axis_angle, quaternion_of_matrix,
                     quaternion_rate, quaternion_rotation)
from .interfaces import PartialJoint, PartialMultiJoint, PartialTreeEdge


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


QUATERNION_PULL = 1.0     # 1/s: how fast a drifted |Q| returns to 1


class _Rotation3D(PartialMultiJoint, abstract=True):
    """The free rotation shared by Spherical and FreeMotion: an unnormalised quaternion Q of frame_b
    relative to frame_a (R_b = R_a·R(Q/|Q|)) and the relative angular velocity w_rel resolved in frame_b
    (DESIGN.md, "Orientation in 3D": no Euler angles, no gimbal lock)."""

    Q = State(shape=4, unit="1", priority="always",
              doc="quaternion (w, x, y, z) of frame_b relative to frame_a, unnormalised (R uses Q/|Q|)")
    w_rel = State(shape=3, unit="rad/s", priority="always",
                  doc="angular velocity of frame_b relative to frame_a, resolved in frame_b")
    quaternions = ("Q",)
    _argument_docs = {
        "R_rel_start": ("", "start orientation of frame_b relative to frame_a as a rotation matrix (frame_b's "
                            "axes as columns, resolved in frame_a); sets Q_start"),
        "axis_start": ("", "start orientation as a turn about this axis (resolved in frame_a) ..."),
        "angle_start": ("rad", "... by this angle; sets Q_start"),
        "w_rel_a_start": ("rad/s", "start relative angular velocity resolved in frame_a; sets w_rel_start"),
    }

    def __init__(self, name: str | None = None, R_rel_start=None, axis_start=None, angle_start=None,
                 w_rel_a_start=None, **kwargs):
        label = f"{name} ({type(self).__name__})"
        given = [k for k, v in (("Q_start", kwargs.get("Q_start")), ("R_rel_start", R_rel_start),
                                ("axis_start", axis_start)) if v is not None]
        if len(given) > 1:
            raise ParameterError(f"{label}: give the start orientation once, not as {' and '.join(given)}")
        if (axis_start is None) != (angle_start is None):
            raise ParameterError(f"{label}: axis_start and angle_start go together (a turn about an axis)")
        try:
            if R_rel_start is not None:
                kwargs["Q_start"] = quaternion_of_matrix(R_rel_start, "R_rel_start")
            elif axis_start is not None:
                angle = finite_number(angle_start, "angle_start", ValueError)
                kwargs["Q_start"] = quaternion_of_axis_angle(axis_start, angle, "axis_start")
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"{label}: {exc}") from None
        if w_rel_a_start is not None:
            if kwargs.get("w_rel_start") is not None:
                raise ParameterError(f"{label}: give the start angular velocity once, not as w_rel_start and "
                                     f"w_rel_a_start")
            if kwargs.get("Q_start") is None:
                raise ParameterError(f"{label}: w_rel_a_start (resolved in frame_a) needs the start orientation "
                                     f"(Q_start, R_rel_start or axis_start/angle_start)")
            # both checked as the base class checks a start value, before they are multiplied (a Q_start of 3
            # numbers or a w_rel_a_start of 2 escaped as numpy's matmul error, issue 32)
            Q = self._vector(label, "Q", "start", kwargs["Q_start"], 4)
            w_a = self._vector(label, "w_rel_a", "start", w_rel_a_start, 3)
            kwargs["w_rel_start"] = matrix_of_quaternion(Q).T @ w_a
        super().__init__(name, **kwargs)

    def check(self):
        start = next(v.start for v in self.variables() if v.local_name == "Q")
        if start is not None and not np.linalg.norm(start) > 1e-12:
            raise ParameterError(f"{self.name} ({type(self).__name__}): Q_start = {start.tolist()} is the zero "
                                 f"quaternion, which is no orientation; the identity is [1, 0, 0, 0]")

    def rotation(self):
        return quaternion_rotation(self.Q)

    def rotation_equations(self):
        # + λ(1 − |Q|²)·Q pulls |Q| back to 1 within one integrator call (R uses Q/|Q|: nothing physical
        # changes); λ = 1/s is far slower than any motion the integrator resolves, so it adds no stiffness
        return [Eq(der(self.Q), quaternion_rate(self.Q, self.w_rel) + QUATERNION_PULL * (1 - ca.sumsqr(self.Q)) * self.Q,
                   "quaternion kinematics: ½·Q ⊗ (0, w_rel), |Q| held near 1")]


class Spherical(_Rotation3D):
    """A ball joint: frame_b turns freely about frame_a's origin (three rotational freedoms, no drive).

    The orientation is an unnormalised quaternion (four states for three freedoms, renormalised at every
    integrator restart, |Q| − 1 reported as an invariant). Give the start as Q_start, R_rel_start or
    axis_start/angle_start, and the start angular velocity as w_rel_start (frame_b) or w_rel_a_start
    (frame_a). Inside a kinematic loop it is not supported yet."""

    dof = 3

    def relative_motion(self):
        return ca.SX.zeros(3), self.rotation()

    def coordinate(self):
        return self.Q

    def speed(self):
        return self.w_rel

    def motion_subspace(self, R_a, R_b):
        return ca.vertcat(ca.SX(R_b), ca.SX.zeros(3, 3))

    def equations(self):
        return self.rotation_equations()


class FreeMotion(_Rotation3D):
    """Six freedoms between frame_a and frame_b: a free body hangs on one from the world (Modelica's
    FreeMotion). The position r_rel and velocity v_rel of frame_b's origin are resolved in frame_a, the
    orientation and angular velocity as in Spherical (r_rel_start, v_rel_start fix the translation)."""

    dof = 6
    # "prefer", a step below the rotation's "always": where a user's constraint holds a point of the body,
    # the position is solved from it before any part of the quaternion is (dummy derivatives take the
    # lower priority first), so a held point leaves Q and w_rel the states, as a ball joint has them
    r_rel = State(shape=3, unit="m", priority="prefer", doc="position of frame_b's origin from frame_a's, "
                                                            "resolved in frame_a")
    v_rel = State(shape=3, unit="m/s", priority="prefer", doc="der(r_rel): velocity of frame_b's origin "
                                                              "relative to frame_a, resolved in frame_a")

    def relative_motion(self):
        return self.r_rel, self.rotation()

    def coordinate(self):
        return ca.vertcat(self.r_rel, self.Q)

    def speed(self):
        return ca.vertcat(self.v_rel, self.w_rel)

    def motion_subspace(self, R_a, R_b):
        zero = ca.SX.zeros(3, 3)
        return ca.vertcat(ca.horzcat(zero, ca.SX(R_b)), ca.horzcat(ca.SX(R_a), zero))

    def equations(self):
        return [Eq(der(self.r_rel), self.v_rel)] + self.rotation_equations()


class _PlaneAxes:
    """Two unit vectors across the axis n (numbers): the in-plane directions of Planar."""

    @staticmethod
    def across(n):
        n = unit_vector(n)
        helper = np.eye(3)[int(np.argmin(np.abs(n)))]
        e_x = np.cross(helper, n)
        e_x /= np.linalg.norm(e_x)
        return e_x, np.cross(n, e_x)


class Cylindrical(PartialMultiJoint):
    """Rotation about and translation along one axis n (fixed in frame_a): phi and s (Modelica's
    Cylindrical)."""

    dof = 2
    n = Param([1.0, 0.0, 0.0], shape=3, check=direction, doc="axis of rotation and translation, resolved in frame_a")
    s = State(unit="m", priority="always", doc="distance of frame_b from frame_a along n")
    phi = State(unit="rad", priority="always", doc="rotation angle of frame_b about n")
    v = State(unit="m/s", priority="always", doc="der(s)")
    w = State(unit="rad/s", priority="always", doc="der(phi)")

    def relative_motion(self):
        n = _unit(self.n)
        return n * self.s, axis_rotation(n, self.phi)

    def coordinate(self):
        return ca.vertcat(self.s, self.phi)

    def speed(self):
        return ca.vertcat(self.v, self.w)

    def motion_subspace(self, R_a, R_b):
        axis = ca.mtimes(R_a, _unit(self.n))
        zero = ca.SX.zeros(3, 1)
        return ca.vertcat(ca.horzcat(zero, axis), ca.horzcat(axis, zero))

    def equations(self):
        return [Eq(der(self.s), self.v), Eq(der(self.phi), self.w)]


class Planar(PartialMultiJoint):
    """frame_b moves in the plane across n (two translations s_x, s_y along directions made from n) and
    turns about n by phi (Modelica's Planar; the in-plane axes: e_x across n, e_y = n × e_x)."""

    dof = 3
    n = Param([0.0, 0.0, 1.0], shape=3, check=direction, doc="normal of the plane, resolved in frame_a")
    s_x = State(unit="m", priority="always", doc="displacement along e_x (across n)")
    s_y = State(unit="m", priority="always", doc="displacement along e_y = n × e_x")
    phi = State(unit="rad", priority="always", doc="rotation angle about n")
    v_x = State(unit="m/s", priority="always", doc="der(s_x)")
    v_y = State(unit="m/s", priority="always", doc="der(s_y)")
    w = State(unit="rad/s", priority="always", doc="der(phi)")

    def relative_motion(self):
        e_x, e_y = _PlaneAxes.across(self.n)
        return ca.DM(e_x) * self.s_x + ca.DM(e_y) * self.s_y, axis_rotation(_unit(self.n), self.phi)

    def coordinate(self):
        return ca.vertcat(self.s_x, self.s_y, self.phi)

    def speed(self):
        return ca.vertcat(self.v_x, self.v_y, self.w)

    def motion_subspace(self, R_a, R_b):
        e_x, e_y = _PlaneAxes.across(self.n)
        zero = ca.SX.zeros(3, 1)
        return ca.vertcat(ca.horzcat(zero, zero, ca.mtimes(R_a, _unit(self.n))),
                          ca.horzcat(ca.mtimes(R_a, ca.DM(e_x)), ca.mtimes(R_a, ca.DM(e_y)), zero))

    def equations(self):
        return [Eq(der(self.s_x), self.v_x), Eq(der(self.s_y), self.v_y), Eq(der(self.phi), self.w)]


class Universal(PartialMultiJoint):
    """Two rotations (a Cardan or Hooke's joint): about n_a (fixed in frame_a) by phi_a, then about n_b
    (fixed in frame_b) by phi_b; n_a and n_b must not be parallel (Modelica's Universal)."""

    dof = 2
    n_a = Param([1.0, 0.0, 0.0], shape=3, check=direction, doc="first axis, resolved in frame_a")
    n_b = Param([0.0, 1.0, 0.0], shape=3, check=direction, doc="second axis, resolved in frame_b")
    phi_a = State(unit="rad", priority="always", doc="rotation angle about n_a")
    phi_b = State(unit="rad", priority="always", doc="rotation angle about n_b")
    w_a = State(unit="rad/s", priority="always", doc="der(phi_a)")
    w_b = State(unit="rad/s", priority="always", doc="der(phi_b)")

    def check(self):
        a, b = unit_vector(self.n_a), unit_vector(self.n_b)
        if np.linalg.norm(np.cross(a, b)) < 1e-6:
            raise ParameterError(f"{self.name} (Universal): n_a = {np.asarray(self.n_a).tolist()} and n_b = "
                                 f"{np.asarray(self.n_b).tolist()} are parallel; a universal joint's two axes "
                                 f"must cross (they are usually perpendicular)")

    def relative_motion(self):
        return ca.SX.zeros(3), ca.mtimes(axis_rotation(_unit(self.n_a), self.phi_a),
                                         axis_rotation(_unit(self.n_b), self.phi_b))

    def coordinate(self):
        return ca.vertcat(self.phi_a, self.phi_b)

    def speed(self):
        return ca.vertcat(self.w_a, self.w_b)

    def motion_subspace(self, R_a, R_b):
        zero = ca.SX.zeros(3, 2)
        return ca.vertcat(ca.horzcat(ca.mtimes(R_a, _unit(self.n_a)), ca.mtimes(R_b, _unit(self.n_b))), zero)

    def motion_bias(self, S, nu):
        """n_b turns with the first rotation: d/dt(S_b)·w_b gains (S_a·w_a) × (S_b·w_b)."""
        return ca.vertcat(ca.cross(S[:3, 0] * nu[0], S[:3, 1] * nu[1]), ca.SX.zeros(3))

    def equations(self):
        return [Eq(der(self.phi_a), self.w_a), Eq(der(self.phi_b), self.w_b)]
