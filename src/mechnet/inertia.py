"""Inertia tensors: checks, transfer of axes, principal axes, and the standard shape tables.

Formulas as in Tenenbaum, *Fundamentals of Applied Dynamics* (inertia tensors
and transfer of axes) and the usual tables: a tensor about the mass centre
becomes I_P = I_C + m (|d|² 1 − d dᵀ) about a point P at offset d from C.
"""
from __future__ import annotations

from typing import Optional

import numpy as np


def inertia_problem(I, rtol: float = 1e-9) -> Optional[str]:
    """Why `I` (3x3, about the mass centre) is not a physical inertia tensor, or None.

    Physical: symmetric, positive semi-definite principal moments that obey the
    triangle inequality I1 + I2 ≥ I3 (a body's mass lies in space, not in a
    negative-distance shell). A zero tensor (a point mass) is allowed.
    """
    I = np.asarray(I, dtype=float).reshape(3, 3)
    scale = max(np.abs(I).max(), 1e-300)
    if np.abs(I - I.T).max() > rtol * scale:
        return "is not symmetric"
    moments = np.linalg.eigvalsh(0.5 * (I + I.T))
    if moments.min() < -rtol * scale:
        return f"is not positive semi-definite (principal moments {moments.tolist()})"
    a, b, c = sorted(moments)
    if a + b < c * (1 - rtol) - rtol * scale:
        return (f"violates the triangle inequality of principal moments: {a:.6g} + {b:.6g} < {c:.6g} "
                f"(no distribution of mass has these moments)")
    return None


def transfer(I_cm, m: float, d) -> np.ndarray:
    """Parallel-axis theorem: the tensor about a point at offset `d` from the mass centre."""
    d = np.asarray(d, dtype=float).reshape(3)
    return np.asarray(I_cm, dtype=float).reshape(3, 3) + m * (d @ d * np.eye(3) - np.outer(d, d))


def principal_axes(I) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and the axes as columns of a rotation matrix."""
    moments, axes = np.linalg.eigh(np.asarray(I, dtype=float).reshape(3, 3))
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


def rod(m: float, length: float, axis: int = 0) -> np.ndarray:
    """Thin rod along coordinate `axis`, about its centre: m L²/12 across, 0 along."""
    I = np.full(3, m * length ** 2 / 12.0)
    I[axis] = 0.0
    return np.diag(I)


def box(m: float, a: float, b: float, c: float) -> np.ndarray:
    """Solid cuboid with edges a, b, c along x, y, z, about its centre."""
    return np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12.0


def cylinder(m: float, radius: float, length: float, axis: int = 2) -> np.ndarray:
    """Solid circular cylinder about its centre: m r²/2 about the axis, m(3r² + L²)/12 across."""
    I = np.full(3, m * (3 * radius ** 2 + length ** 2) / 12.0)
    I[axis] = m * radius ** 2 / 2.0
    return np.diag(I)


def sphere(m: float, radius: float) -> np.ndarray:
    """Solid sphere: 2 m r²/5 about any axis through the centre."""
    return np.eye(3) * 0.4 * m * radius ** 2
