"""Systems of forces and couples: resultant, moment, reduction to a point, central axis.

A rigid body cannot tell two force systems apart if they have the same
resultant R = Σ F and the same moment about one point (Tenenbaum, *Fundamentals
of Applied Dynamics*, ch. 2). Forces are bound vectors (they act at a point);
couples are free vectors (a torque T acts the same wherever it is applied).
Moments move between points by M_B = M_A + (A − B) × R.

    >>> s = ForceSystem(forces=[([0, 10, 0], [1, 0, 0])])
    >>> s.moment_about([0, 0, 0]).tolist()
    [0.0, 0.0, 10.0]

Units: forces in N, points in m, torques and moments in N·m, world components.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from .core.errors import InputError

ORIGIN = np.zeros(3)
ORIGIN.flags.writeable = False


class CentralAxis(NamedTuple):
    """Where a force system is a wrench: its resultant along a line plus a couple along the same line."""

    point: np.ndarray      # the point of the axis closest to the origin (m)
    direction: np.ndarray  # unit vector along the resultant
    pitch: float           # p = R·M_O / |R|² (m): the couple per unit force along the axis
    moment: np.ndarray     # p R, the smallest moment the system has about any point (N·m)


class ForceSystem:
    """Forces at their points of application and free couples, in world components.

    `forces` is a list of (F, point) pairs, `torques` a list of couples T.
    """

    def __init__(self, forces=(), torques=()):
        self.forces = tuple((_vector(F, f"forces[{k}] force"), _vector(r, f"forces[{k}] point"))
                            for k, (F, r) in enumerate(forces))
        self.torques = tuple(_vector(T, f"torques[{k}]") for k, T in enumerate(torques))

    @classmethod
    def wrench(cls, force, torque, point=ORIGIN) -> ForceSystem:
        """One force acting at `point` plus one couple: a cut force and torque at a frame origin."""
        return cls(forces=[(force, point)], torques=[torque])

    @classmethod
    def from_frame(cls, res, frame: str, index: int = -1) -> ForceSystem:
        """The wrench a simulation result's frame carries at row `index`: the cut force `f` and torque `t`
        into its component (resolved in the frame, Modelica's convention), turned into world components
        and bound to the frame's origin — a joint's reaction (`"rev.frame_b"`), or what a `CutForceTorque`
        sensor reports (`"sensor.frame_a"`: the wrench from frame_a's side onto frame_b's) as a force
        system."""
        try:
            R = np.array([res[f"{frame}.R[{k}]"][index] for k in range(9)]).reshape(3, 3)
            r = np.array([res[f"{frame}.r_0[{k}]"][index] for k in range(3)])
            f = np.array([res[f"{frame}.f[{k}]"][index] for k in range(3)])
            t = np.array([res[f"{frame}.t[{k}]"][index] for k in range(3)])
        except KeyError:
            raise InputError(f"ForceSystem.from_frame: {frame!r} is not a frame of the result (expected "
                             f"'<component>.<frame>', e.g. 'rev.frame_b')") from None
        return cls.wrench(R @ f, R @ t, r)

    @property
    def resultant(self) -> np.ndarray:
        """R = Σ F; couples add nothing to it."""
        return sum((F for F, _r in self.forces), np.zeros(3))

    def moment_about(self, point=ORIGIN) -> np.ndarray:
        """M_P = Σ (r − P) × F + Σ T."""
        P = _vector(point, "point")
        M = sum((np.cross(r - P, F) for F, r in self.forces), np.zeros(3))
        return M + sum(self.torques, np.zeros(3))

    def reduce_to(self, point=ORIGIN) -> tuple[np.ndarray, np.ndarray]:
        """(R, M_P): the single force at `point` and the couple equivalent to the whole system."""
        return self.resultant, self.moment_about(point)

    def equivalent_to(self, other: ForceSystem, rtol: float = 1e-9, atol: float = 1e-12) -> bool:
        """Same resultant and same moment about the origin (np.allclose with rtol, atol).

        One point is enough: with equal resultants, M_B = M_A + (A − B) × R shifts
        both moments by the same amount, so they agree about every point B.
        The origin is the point checked, so atol is in N·m at the scale of the
        world coordinates.
        """
        return (np.allclose(self.resultant, other.resultant, rtol=rtol, atol=atol)
                and np.allclose(self.moment_about(), other.moment_about(), rtol=rtol, atol=atol))

    def central_axis(self, atol: float = 0.0) -> Optional[CentralAxis]:
        """The line about which the moment is smallest and parallel to the resultant, or None.

        With M_O the moment about the origin, the point p = R × M_O / |R|² lies on
        the axis (closest to the origin) and M_p = (R·M_O / |R|²) R. A pure couple
        (|R| ≤ atol, N) has the same moment about every point, so it has no axis:
        then the answer is None.
        """
        R = self.resultant
        R2 = R @ R
        if np.sqrt(R2) <= atol:
            return None
        M = self.moment_about()
        pitch = float(R @ M / R2)
        return CentralAxis(np.cross(R, M) / R2, R / np.sqrt(R2), pitch, pitch * R)

    def __add__(self, other: ForceSystem) -> ForceSystem:
        """Both systems acting at once."""
        if not isinstance(other, ForceSystem):
            return NotImplemented
        return ForceSystem(self.forces + other.forces, self.torques + other.torques)

    def __repr__(self) -> str:
        R, M = self.reduce_to()
        return (f"ForceSystem({len(self.forces)} forces, {len(self.torques)} couples; "
                f"R = {R.tolist()}, M_O = {M.tolist()})")


def _vector(value, what: str) -> np.ndarray:
    """A finite 3-vector (a copy: later edits of the caller's array do not move the system),
    or an InputError naming `what`."""
    try:
        v = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"ForceSystem: {what} = {value!r} is not a vector of numbers") from None
    if v.shape != (3,) or not np.isfinite(v).all():
        raise InputError(f"ForceSystem: {what} = {value!r} must be a finite 3-vector")
    return v
