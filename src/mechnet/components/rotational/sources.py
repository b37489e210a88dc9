"""Torque sources. A source drives its flange with +tau: flange.tau = −tau (cut torque into the source)."""
from __future__ import annotations

from ...core.declarations import Input, Param
from ...core.equation import Eq
from .interfaces import PartialOneFlange


class Torque(PartialOneFlange):
    """External torque input `<name>.tau` (default value `tau=`), acting on the connected flange."""

    tau = Input(unit="N*m", doc="driving torque (input)")

    def equations(self):
        return [Eq(self.flange.tau, -self.tau, "the source drives its flange with +tau")]


class ConstantTorque(PartialOneFlange):
    """Constant torque tau_constant acting on the connected flange."""

    tau_constant = Param(unit="N*m", doc="driving torque")

    def equations(self):
        return [Eq(self.flange.tau, -self.tau_constant, "the source drives its flange with +tau_constant")]
