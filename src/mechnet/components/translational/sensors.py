"""Ideal sensors: they take no force (absolute sensors) or pass it through (relative ones)."""
from __future__ import annotations

from ...core.declarations import Output
from ...core.equation import Eq, der
from .interfaces import PartialOneFlange, PartialTwoFlanges


class PositionSensor(PartialOneFlange):
    """Absolute position of the flange; flange.f = 0 (takes no force)."""

    s = Output(unit="m", doc="measured position")

    def equations(self):
        return [Eq(self.s, self.flange.s, "measured position"), Eq(self.flange.f, 0.0, "ideal sensor")]


class SpeedSensor(PartialOneFlange):
    """Absolute velocity of the flange, v = der(flange.s); flange.f = 0 (takes no force)."""

    v = Output(unit="m/s", doc="measured velocity")

    def equations(self):
        return [Eq(self.v, der(self.flange.s), "measured velocity"), Eq(self.flange.f, 0.0, "ideal sensor")]


class ForceSensor(PartialTwoFlanges):
    """Force transmitted from flange_a to flange_b (placed in series, rigid): f = flange_a.f = −flange_b.f."""

    f = Output(unit="N", doc="measured force, = flange_a.f")

    def equations(self):
        return [Eq(self.flange_a.s, self.flange_b.s, "rigid"),
                Eq(self.flange_a.f + self.flange_b.f, 0.0, "massless"),
                Eq(self.f, self.flange_a.f, "measured force")]


class PowerSensor(PartialTwoFlanges):
    """Power flowing through the sensor from flange_a to flange_b: power = flange_a.f·der(flange_a.s)."""

    power = Output(unit="W", doc="measured power, flange_a.f * der(flange_a.s)")

    def equations(self):
        return [Eq(self.flange_a.s, self.flange_b.s, "rigid"),
                Eq(self.flange_a.f + self.flange_b.f, 0.0, "massless"),
                Eq(self.power, self.flange_a.f * der(self.flange_a.s), "measured power")]
