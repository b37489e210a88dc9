"""Inertia tensors: checks, transfer of axes, rotation, composite bodies and the shape table.

Formulas as in Tenenbaum, *Fundamentals of Applied Dynamics* (inertia tensors,
transfer of axes, Appendix C): a tensor about the mass centre C becomes
I_P = I_C + m (|d|² 1 − d dᵀ) about a point P at offset d from C, and
I' = R I Rᵀ in axes rotated by R. Every shape returns a 3x3 tensor (kg·m²)
about its mass centre, in axes along its edges or its symmetry `axis`
(0, 1, 2 = x, y, z), ready for `multibody.Body(I=...)`. Rod, ring, disc,
plate and spherical shell are of zero thickness. Masses and lengths must be
finite and > 0 (a ParameterError names the function, argument and value).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from .core.declarations import finite_number, number_array
from .core.errors import ParameterError


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
    return _array(I_cm, (3, 3), "transfer: I_cm") + _steiner(m, d, "transfer")


def _steiner(m: float, d, what: str = "inertia") -> np.ndarray:
    """m (|d|² 1 − d dᵀ): what a point mass m at offset d adds to a tensor (the parallel-axis term)."""
    m = finite_number(m, f"{what}: m")
    d = _array(d, (3,), f"{what}: d (offset)")
    return m * (d @ d * np.eye(3) - np.outer(d, d))


def _array(value, shape: tuple, what: str) -> np.ndarray:
    """`value` as finite numbers of `shape` (a tensor 3x3 or 9, a vector 3), else a ParameterError naming
    it: numpy's reshape error, or eigh failing on a NaN, named nothing (fuzz, issue 32)."""
    try:
        arr = number_array(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} = {value!r:.60} is not an array of numbers") from None
    if arr.size != int(np.prod(shape)) or not np.isfinite(arr).all():
        raise ParameterError(f"{what} = {arr.tolist()} must be {' x '.join(map(str, shape))} finite numbers")
    return arr.reshape(shape)


def about_point(I_cm, m: float, r_cm, point) -> np.ndarray:
    """The tensor about `point`, from the one about the mass centre at `r_cm` (same axes, same frame)."""
    return transfer(I_cm, m, np.subtract(point, r_cm))


def about_mass_centre(I_point, m: float, r_cm, point) -> np.ndarray:
    """The inverse of `about_point`: a CAD tool or a data sheet often gives the tensor about a
    part's origin, but `Body(I=...)` wants it about the mass centre."""
    offset = np.subtract(_array(point, (3,), "about_mass_centre: point"), _array(r_cm, (3,), "about_mass_centre: r_cm"))
    return _array(I_point, (3, 3), "about_mass_centre: I_point") - _steiner(m, offset, "about_mass_centre")


def rotate(I, R) -> np.ndarray:
    """R I Rᵀ: the tensor in the frame into which the rotation matrix R maps the body's axes.

    R must be a proper rotation (orthonormal, det +1); a reflection would turn a
    right-handed body frame into a left-handed one.
    """
    R = _rotation(R, "rotate: R")
    return R @ np.asarray(I, dtype=float).reshape(3, 3) @ R.T


def composite(parts) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, mass centre and tensor about that mass centre of a body made of rigidly joined parts.

    Each part is (m, r_cm, I_cm) or (m, r_cm, I_cm, R): its mass, its mass centre
    in the composite frame, its tensor about its own mass centre in its own axes,
    and the rotation R of its axes into the composite frame (identity if left out).
    Each part is rotated (R I Rᵀ) and moved to the common mass centre (parallel axes).
    """
    if not parts:
        raise ParameterError("composite: parts is empty; a body needs at least one part")
    masses, centres, tensors = [], [], []
    for k, part in enumerate(parts):
        if isinstance(part, (str, bytes)) or not hasattr(part, "__len__") or len(part) not in (3, 4):
            raise ParameterError(f"composite: parts[{k}] = {part!r:.60} must be (m, r_cm, I_cm) or "
                                 f"(m, r_cm, I_cm, R)")
        m, r_cm, I_cm, *R = part
        _positive("composite", **{f"parts[{k}].m": m})
        R = _rotation(R[0] if R else np.eye(3), f"composite: parts[{k}].R")
        masses.append(float(m))
        centres.append(_array(r_cm, (3,), f"composite: parts[{k}].r_cm"))
        tensors.append(R @ _array(I_cm, (3, 3), f"composite: parts[{k}].I_cm") @ R.T)
    m_total = sum(masses)
    r_total = sum(m * r for m, r in zip(masses, centres)) / m_total
    I_total = sum(transfer(I, m, r - r_total) for m, r, I in zip(masses, centres, tensors))
    return m_total, r_total, I_total


def principal_axes(I) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (ascending) and the axes as columns of a rotation matrix."""
    moments, axes = np.linalg.eigh(_array(I, (3, 3), "principal_axes: I"))
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


# ---- the shape table (Tenenbaum, Appendix C); all about the mass centre -------------------

def rod(m: float, length: float, axis: int = 0) -> np.ndarray:
    """Thin rod along coordinate `axis`, about its centre: m L²/12 across, 0 along."""
    _positive("rod", m=m, length=length)
    return _axisymmetric(0.0, m * length ** 2 / 12.0, axis, "rod")


def ring(m: float, radius: float, axis: int = 2) -> np.ndarray:
    """Thin hoop with normal `axis`, about its centre: m r² about the normal, m r²/2 across."""
    _positive("ring", m=m, radius=radius)
    return _axisymmetric(m * radius ** 2, m * radius ** 2 / 2.0, axis, "ring")


def disc(m: float, radius: float, axis: int = 2) -> np.ndarray:
    """Thin uniform disc with normal `axis`: m r²/2 about the normal, m r²/4 across."""
    _positive("disc", m=m, radius=radius)
    return _axisymmetric(m * radius ** 2 / 2.0, m * radius ** 2 / 4.0, axis, "disc")


def cylinder(m: float, radius: float, length: float, axis: int = 2) -> np.ndarray:
    """Solid circular cylinder about its centre: m r²/2 about the axis, m(3r² + L²)/12 across."""
    _positive("cylinder", m=m, radius=radius, length=length)
    return _axisymmetric(m * radius ** 2 / 2.0, m * (3 * radius ** 2 + length ** 2) / 12.0, axis, "cylinder")


def hollow_cylinder(m: float, inner: float, outer: float, length: float, axis: int = 2) -> np.ndarray:
    """Thick-walled tube with radii inner ≤ outer, about its centre:
    m(r₁² + r₂²)/2 about the axis, m(3(r₁² + r₂²) + L²)/12 across.

    inner = outer is the thin-walled tube (m r² about the axis); inner = 0 the solid cylinder.
    """
    _positive("hollow_cylinder", m=m, outer=outer, length=length)
    if not 0 <= finite_number(inner, "hollow_cylinder: inner") <= outer:
        raise ParameterError(f"hollow_cylinder: inner = {inner!r} must lie in [0, outer = {outer!r}] "
                             f"(the radius of the bore, in m)")
    squares = inner ** 2 + outer ** 2
    return _axisymmetric(m * squares / 2.0, m * (3 * squares + length ** 2) / 12.0, axis, "hollow_cylinder")


def cone(m: float, radius: float, height: float, axis: int = 2) -> np.ndarray:
    """Solid right circular cone about its MASS CENTRE (see `cone_mass_centre`), not its apex:
    3 m r²/10 about the axis, 3 m (4r² + h²)/80 across.

    (About the apex the cross moment is 3 m (r² + 4h²)/20, the value many tables give.)
    """
    _positive("cone", m=m, radius=radius, height=height)
    return _axisymmetric(0.3 * m * radius ** 2, 3.0 * m * (4 * radius ** 2 + height ** 2) / 80.0, axis, "cone")


def cone_mass_centre(height: float) -> float:
    """Distance of a solid cone's mass centre from its base plane, along the axis: h/4 (3h/4 from the apex)."""
    _positive("cone_mass_centre", height=height)
    return height / 4.0


def box(m: float, a: float, b: float, c: float) -> np.ndarray:
    """Solid cuboid with edges a, b, c along x, y, z, about its centre."""
    _positive("box", m=m, a=a, b=b, c=c)
    return np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12.0


def plate(m: float, a: float, b: float, axis: int = 2) -> np.ndarray:
    """Thin rectangular plate with normal `axis`, about its centre; edge a lies along the lower
    of the two other axes, b along the higher (axis=2: a along x, b along y).
    m(a² + b²)/12 about the normal, m b²/12 about the axis parallel to a, m a²/12 about the one parallel to b.
    """
    _positive("plate", m=m, a=a, b=b)
    _check_axis(axis, "plate")
    along_a, along_b = (k for k in range(3) if k != axis)
    moments = np.empty(3)
    moments[[axis, along_a, along_b]] = m * (a * a + b * b) / 12.0, m * b * b / 12.0, m * a * a / 12.0
    return np.diag(moments)


def sphere(m: float, radius: float) -> np.ndarray:
    """Solid sphere: 2 m r²/5 about any axis through the centre."""
    _positive("sphere", m=m, radius=radius)
    return np.eye(3) * 0.4 * m * radius ** 2


def spherical_shell(m: float, radius: float) -> np.ndarray:
    """Thin spherical shell: 2 m r²/3 about any axis through the centre."""
    _positive("spherical_shell", m=m, radius=radius)
    return np.eye(3) * 2.0 * m * radius ** 2 / 3.0


# ---- shared checks -------------------------------------------------------------------------

def _axisymmetric(about: float, across: float, axis: int, shape: str) -> np.ndarray:
    """diag with `about` on the symmetry axis and `across` on the other two."""
    _check_axis(axis, shape)
    moments = np.full(3, across)
    moments[axis] = about
    return np.diag(moments)


def _positive(shape: str, **values) -> None:
    """One check for every mass and length in the table: a finite number > 0, or a
    ParameterError naming the function, the argument and its value."""
    for name, value in values.items():
        if not finite_number(value, f"{shape}: {name}") > 0:
            raise ParameterError(f"{shape}: {name} = {value!r} must be > 0")


def _check_axis(axis, shape: str) -> None:
    if axis not in (0, 1, 2) or isinstance(axis, bool):
        raise ParameterError(f"{shape}: axis = {axis!r} must be 0, 1 or 2 (x, y, z)")


def _rotation(R, what: str, rtol: float = 1e-9) -> np.ndarray:
    """R as a 3x3 array if it is a proper rotation (Rᵀ R = 1, det R = +1), else a ParameterError.
    rtol allows the rounding of a matrix built from sines and cosines, not a sloppy one."""
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3) or not np.isfinite(R).all():
        raise ParameterError(f"{what} must be a finite 3x3 rotation matrix, got {R.tolist()}")
    if np.abs(R.T @ R - np.eye(3)).max() > rtol or np.linalg.det(R) < 0:
        raise ParameterError(f"{what} = {np.round(R, 6).tolist()} is not a rotation matrix "
                             f"(needs Rᵀ R = 1 and det R = +1; det R = {np.linalg.det(R):.6g})")
    return R
