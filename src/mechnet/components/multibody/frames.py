"""Rotation and vector helpers shared by the multibody components and the tree pass.

Conventions (docs/conventions.md): a frame's orientation `R` has the frame's
axes as columns, resolved in world, so v_world = R · v_frame. The connector
stores it as 9 numbers in row-major order. Functions accept CasADi SX/DM and
return SX (or DM for numbers), so folded parameters stay numbers.
"""
from __future__ import annotations

import casadi as ca
import numpy as np


def skew(v):
    """[v]×: skew(v) @ u = v × u."""
    return ca.vertcat(ca.horzcat(0, -v[2], v[1]),
                      ca.horzcat(v[2], 0, -v[0]),
                      ca.horzcat(-v[1], v[0], 0))


def cross(a, b):
    return ca.vertcat(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def axis_rotation(n, angle):
    """Rotation by `angle` about the unit vector `n` (Rodrigues): R = cos·1 + sin·[n]× + (1 − cos)·n nᵀ.

    With a numeric axis, terms whose coefficient is zero are left out, so a
    coordinate axis gives structural zeros and a planar scene keeps the planar size.
    """
    c, s = ca.cos(angle), ca.sin(angle)
    if isinstance(n, (ca.SX, ca.MX)):
        return c * ca.SX.eye(3) + s * skew(n) + (1 - c) * ca.mtimes(n, n.T)
    n = np.asarray(ca.DM(n).full(), dtype=float).ravel()
    k = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    nn = np.outer(n, n)
    out = ca.SX(3, 3)
    for i in range(3):
        for j in range(3):
            term = ca.SX(0)
            if i == j:
                term = c if nn[i, j] == 0 else (c + (1 - c) * nn[i, j] if nn[i, j] != 1 else ca.SX(1))
            elif nn[i, j] != 0:
                term = (1 - c) * nn[i, j]
            if k[i, j] != 0:
                term = term + s * k[i, j]
            term = ca.SX(term)
            if not (term.is_constant() and float(term) == 0.0):
                out[i, j] = term
    return out


def exact(M, tol=1e-12):
    """A constant rotation (or projector) with its round-off made exact: ~0 to 0 and ~±1 to ±1, so
    structural zeros survive and products with it stay small."""
    M = np.where(np.abs(M) < tol, 0.0, M)
    return np.where(np.abs(np.abs(M) - 1.0) < tol, np.sign(M), M)


def to_matrix(R9):
    """The 3x3 matrix of a row-major 9-vector (the connector's `R`)."""
    return ca.reshape(R9, 3, 3).T


def to_row_major(R):
    return ca.reshape(R.T, 9, 1)


def resolve(R, v):
    """World components of a vector given in the frame with orientation R."""
    return ca.mtimes(R, v)


def resolve_in_frame(R, v_world):
    return ca.mtimes(R.T, v_world)


# ---- quaternions (w, x, y, z), unnormalised: the orientation of the spherical and free joints ------------

def quaternion_rotation(Q):
    """R(Q/|Q|) without a square root: 1 + (2/|Q|²)(w·[v]× + [v]×²). Exactly a rotation whatever |Q| is
    (the integrator lets |Q| drift; DESIGN.md, "Orientation in 3D")."""
    w, v = Q[0], Q[1:4]
    V = skew(v)
    return ca.SX.eye(3) + (2 / ca.sumsqr(Q)) * (w * V + ca.mtimes(V, V))


def quaternion_rate(Q, w_b):
    """der(Q) for the body angular velocity w_b (resolved in the rotated frame): ½·Q ⊗ (0, w_b). It keeps
    |Q| constant in exact arithmetic (Q·der(Q) = 0)."""
    w, v = Q[0], Q[1:4]
    return 0.5 * ca.vertcat(-ca.dot(v, w_b), w * w_b + cross(v, w_b))


def quaternion_of_matrix(R, what: str = "R") -> np.ndarray:
    """The unit quaternion (w ≥ 0) of a rotation matrix; ValueError naming `what` when R is not one."""
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ValueError(f"{what} must be a 3x3 matrix of finite numbers, got shape {R.shape}")
    if np.max(np.abs(R.T @ R - np.eye(3))) > 1e-9 or np.linalg.det(R) < 0:
        raise ValueError(f"{what} = {R.tolist()} is not a rotation (orthonormal with determinant +1): "
                         f"|RᵀR − 1| = {np.max(np.abs(R.T @ R - np.eye(3))):.3g}, det = {np.linalg.det(R):.6g}")
    # the largest of the four squares first: no division by a small number
    t = np.trace(R)
    squares = [1 + t, 1 + 2 * R[0, 0] - t, 1 + 2 * R[1, 1] - t, 1 + 2 * R[2, 2] - t]
    k = int(np.argmax(squares))
    s = 2 * np.sqrt(squares[k])
    if k == 0:
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s]
    else:
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4]
    q = np.array(q)
    return q if q[0] >= 0 else -q


def quaternion_of_axis_angle(n, angle: float, what: str = "axis") -> np.ndarray:
    """The unit quaternion of a turn by `angle` (rad) about the axis n (any length but zero)."""
    n = np.asarray(n, dtype=float).ravel()
    if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.isfinite(angle):
        raise ValueError(f"{what} must be 3 finite numbers and the angle a finite number")
    norm = np.linalg.norm(n)
    if norm == 0:
        raise ValueError(f"{what} = {n.tolist()} is the zero vector: a turn needs an axis")
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * n / norm]


def matrix_of_quaternion(Q) -> np.ndarray:
    """R(Q/|Q|) as numbers."""
    return np.asarray(ca.evalf(quaternion_rotation(ca.SX(ca.DM(np.asarray(Q, dtype=float))))).full())
