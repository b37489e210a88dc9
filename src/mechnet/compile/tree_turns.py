"""Planar orientations as angle sums: a frame reached from the world by turns about one fixed axis only.

Its orientation R = A·Rz(angle)·B (A, B constant) is built from the sum of the joint angles instead of
the product of the joints' rotations, which grows with every link and every time derivative. The tree
pass (`tree_kinematics`) carries one `Turn` per node while the chain stays planar.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..components.multibody.frames import axis_rotation, exact


def rotation_about_z(angle):
    """Rz(angle) with its structural zeros."""
    c, s = ca.cos(angle), ca.sin(angle)
    R = ca.SX(3, 3)
    R[0, 0], R[0, 1], R[1, 0], R[1, 1], R[2, 2] = c, -s, s, c, 1.0
    return R


def constant_rotation(n, angle):
    """axis_rotation as numbers, round-off made exact."""
    return exact(np.asarray(ca.evalf(ca.SX(axis_rotation(ca.DM(n), angle))).full(), dtype=float), 1e-14)


def onto_z(n):
    """A constant rotation B with B·n = z to 1e-14 (n a unit vector), or None. The angle comes from
    atan2(|n × z|, n·z): arccos(n·z) loses an axis 1e-8 off z entirely (n·z rounds to 1)."""
    if not (n[0] or n[1]):
        return np.eye(3) if n[2] > 0 else np.diag([1.0, -1.0, -1.0])
    k = np.cross(n, [0.0, 0.0, 1.0])
    sin = np.linalg.norm(k)
    B = constant_rotation(k / sin, np.arctan2(sin, n[2]))
    return B if np.max(np.abs(B @ n - [0.0, 0.0, 1.0])) <= 1e-14 else None


@dataclass(frozen=True)
class Turn:
    """A frame's orientation R = A·Rz(angle)·B with A, B constant: reached from the world by rotations
    about one fixed axis (A·z) only. Its angle is then a sum of joint angles, and R is built from that
    sum: the product of the joints' rotations grows with every link and every time derivative."""

    A: np.ndarray
    angle: ca.SX
    B: np.ndarray

    def rotation(self):
        Rz = rotation_about_z(self.angle)
        return ca.mtimes(ca.DM(self.A), ca.mtimes(Rz, ca.DM(self.B)))

    def fixed(self):
        """R as numbers when the angle is a number, else None."""
        a = ca.SX(self.angle)
        return exact(self.A @ constant_rotation([0, 0, 1], float(ca.evalf(a))) @ self.B, 1e-14) \
            if a.is_constant() else None


def motion_axes(e):
    """A joint's (angular, linear) unit axes as numbers."""
    return tuple(np.asarray(ca.DM(a).full(), dtype=float).ravel() for a in e.motion_axes())


def next_turn(e, R_rel, turn, forward):
    """The child's Turn across edge e (R_child = R_parent·R_rel, or ·R_relᵀ when the edge is walked
    backwards), or None when the edge turns about another axis. R_rel itself is checked, not only the
    joint's motion axes (a joint class of the user's may turn by more than its coordinate)."""
    if turn is None:
        return None
    R = ca.SX(R_rel)
    fixed = turn.fixed()
    if e.dof == 0:
        if not R.is_constant():
            return None
        M = np.asarray(ca.evalf(R).full(), dtype=float)
        M = M if forward else M.T
        if fixed is not None:
            return Turn(exact(fixed @ M, 1e-14), ca.SX(0.0), np.eye(3))
        C = exact(turn.B @ M @ turn.B.T)           # B·M = C·B: C must turn about z
        if C[2, 2] != 1.0 or np.any(C[2, :2]) or np.any(C[:2, 2]):
            return None
        return Turn(turn.A, turn.angle + float(np.arctan2(C[1, 0], C[0, 0])), turn.B)
    if e.dof != 1:
        return None
    q = e.coordinate()
    n, s_lin = motion_axes(e)
    if any(not ca.is_equal(v, q) for v in ca.symvar(R)):
        return None
    if not np.any(n):
        return turn if R.is_constant() and R.is_eye() else None          # a prismatic: the same turn
    if np.any(s_lin):
        return None
    gap = ca.Function("gap", [q], [R - axis_rotation(ca.DM(n), q)])
    if not all(np.max(np.abs(np.asarray(gap(v)))) <= 1e-12 for v in (0.3, -1.7)):
        return None
    sign = 1.0 if forward else -1.0
    if fixed is not None:                                    # a new axis: Rot_n(x) = Bᵀ·Rz(x)·B with B·n = z
        B = onto_z(n)
        return None if B is None else Turn(exact(fixed @ B.T, 1e-14), sign * q, B)
    m = turn.B @ n                                           # B·Rot_n(x) = Rot_{B·n}(x)·B: B·n must be ±z,
    if abs(m[0]) > 1e-14 or abs(m[1]) > 1e-14:               # measured by the tilt (not by 1 − cos(tilt))
        return None
    return Turn(turn.A, turn.angle + sign * float(np.sign(m[2])) * q, turn.B)
