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
