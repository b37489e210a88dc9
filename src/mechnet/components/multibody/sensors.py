"""Sensors: relative kinematics between frames, cut forces, and scene-level energy and momentum.

Sensor outputs are observed variables: the integrator never needs them, so
they are pruned from the right-hand side (they cost only when read).
"""
from __future__ import annotations

import casadi as ca

from ...core.component import Component
from ...core.declarations import Output, Param
from ...core.equation import Eq, der
from .interfaces import PartialTreeEdge, PartialTwoFrames


class RelativePosition(PartialTwoFrames):
    """r_rel: frame_b's origin relative to frame_a's, resolved in frame_a."""

    r_rel = Output(unit="m", shape=3, doc="r_0 of frame_b − r_0 of frame_a, resolved in frame_a")

    def equations(self):
        Ra = self.frame_a.rotation()
        return [Eq(self.r_rel, ca.mtimes(Ra.T, self.frame_b.r_0 - self.frame_a.r_0)),
                Eq(self.frame_a.f, 0), Eq(self.frame_a.t, 0), Eq(self.frame_b.f, 0), Eq(self.frame_b.t, 0)]


class RelativeVelocity(PartialTwoFrames):
    """v_rel: velocity of frame_b's origin relative to frame_a's origin (world derivative), resolved in frame_a."""

    v_rel = Output(unit="m/s", shape=3, doc="der(r_0 of frame_b − r_0 of frame_a), resolved in frame_a")

    def equations(self):
        Ra = self.frame_a.rotation()
        return [Eq(self.v_rel, ca.mtimes(Ra.T, der(self.frame_b.r_0) - der(self.frame_a.r_0))),
                Eq(self.frame_a.f, 0), Eq(self.frame_a.t, 0), Eq(self.frame_b.f, 0), Eq(self.frame_b.t, 0)]


class CutForceTorque(PartialTreeEdge):
    """Rigid connection that reports the wrench it transmits: f, t act on frame_b's side, resolved in frame_a.

    Insert it between a joint and a body to read the joint's reaction (every
    tree edge's frame flows are observable too, e.g. `rev.frame_a.f`).
    """

    f = Output(unit="N", shape=3, doc="cut force from frame_a's side onto frame_b's side, frame_a axes")
    t = Output(unit="N*m", shape=3, doc="cut torque about the origin, frame_a axes")

    def relative_motion(self):
        return ca.SX.zeros(3), ca.SX.eye(3)

    def equations(self):
        return [Eq(self.f, self.frame_a.f), Eq(self.t, self.frame_a.t)]


class PartialSceneSensor(Component, abstract=True):
    """A sensor of the whole multibody scene (no frames); the tree pass writes its equations."""


class SystemEnergy(PartialSceneSensor):
    """Kinetic and potential energy of every body, plus the energy stored in force elements.

    Potential energy: −m g·r_cm for uniform gravity (zero at the world origin),
    −mue m/|r_cm| for point gravity, plus the elements' `potential_energy()`
    (springs, gravitation). Dissipation and work of drives are not included.
    """

    kinetic = Output(unit="J", doc="Σ ½ m |v_cm|² + ½ ωᵀ I_cm ω")
    potential = Output(unit="J", doc="gravity and force-element potential energy")
    total = Output(unit="J", doc="kinetic + potential")


class SystemMomentum(PartialSceneSensor):
    """Linear momentum of all bodies and their angular momentum about a point fixed in world."""

    point = Param([0.0, 0.0, 0.0], unit="m", shape=3, doc="reference point of the angular momentum (world)")
    p = Output(unit="kg*m/s", shape=3, doc="Σ m v_cm (world)")
    L = Output(unit="kg*m2/s", shape=3, doc="Σ (r_cm − point) × m v_cm + I_cm ω (world)")
