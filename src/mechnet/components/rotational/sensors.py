"""Ideal sensors: they take no torque (absolute sensors) or pass it through (relative ones)."""
from __future__ import annotations

from ...core.declarations import Output
from ...core.equation import Eq, der
from .interfaces import PartialOneFlange, PartialTwoFlanges


class AngleSensor(PartialOneFlange):
    """Absolute angle of the flange."""

    phi = Output(unit="rad", doc="measured angle")

    def equations(self):
        return [Eq(self.phi, self.flange.phi, "measured angle"), Eq(self.flange.tau, 0.0, "ideal sensor")]


class SpeedSensor(PartialOneFlange):
    """Absolute angular velocity of the flange."""

    w = Output(unit="rad/s", doc="measured angular velocity")

    def equations(self):
        return [Eq(self.w, der(self.flange.phi), "measured speed"), Eq(self.flange.tau, 0.0, "ideal sensor")]


class TorqueSensor(PartialTwoFlanges):
    """Torque transmitted from flange_a to flange_b (placed in series, rigid)."""

    tau = Output(unit="N*m", doc="measured torque, = flange_a.tau")

    def equations(self):
        return [Eq(self.flange_a.phi, self.flange_b.phi, "rigid"),
                Eq(self.flange_a.tau + self.flange_b.tau, 0.0, "massless"),
                Eq(self.tau, self.flange_a.tau, "measured torque")]


class PowerSensor(PartialTwoFlanges):
    """Power flowing through the sensor from flange_a to flange_b: tau·w."""

    power = Output(unit="W", doc="measured power, flange_a.tau * der(flange_a.phi)")

    def equations(self):
        return [Eq(self.flange_a.phi, self.flange_b.phi, "rigid"),
                Eq(self.flange_a.tau + self.flange_b.tau, 0.0, "massless"),
                Eq(self.power, self.flange_a.tau * der(self.flange_a.phi), "measured power")]
