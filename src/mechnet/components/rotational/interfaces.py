"""Rotational connector and partial models.

Sign convention (Modelica): a flange's cut torque `tau` is positive when it
acts *into* the component; at a connection the angles are equal and the
torques sum to zero.
"""
from __future__ import annotations

from ...core.component import Component, Connector
from ...core.declarations import Across, Port, Through, Var
from ...core.equation import Eq


class Flange(Connector):
    """1D rotational flange: absolute angle and cut torque."""

    phi = Across(unit="rad", doc="absolute rotation angle of the flange")
    tau = Through(unit="N*m", doc="cut torque, positive into the component")


class PartialTwoFlanges(Component, abstract=True):
    """Two flanges, a and b."""

    flange_a = Port(Flange, doc="left flange")
    flange_b = Port(Flange, doc="right flange")


class PartialCompliant(PartialTwoFlanges, abstract=True):
    """A massless element between two flanges: relative angle and the torque it transmits.

    phi_rel = flange_b.phi − flange_a.phi; flange_b.tau = tau; flange_a.tau = −tau.
    """

    phi_rel = Var(unit="rad", doc="relative angle flange_b.phi - flange_a.phi")
    tau = Var(unit="N*m", doc="torque transmitted (acting on flange_b)")

    def compliant_equations(self):
        return [Eq(self.phi_rel, self.flange_b.phi - self.flange_a.phi, "relative angle"),
                Eq(self.flange_b.tau, self.tau, "torque on flange_b"),
                Eq(self.flange_a.tau, -self.tau, "torque on flange_a")]


class PartialOneFlange(Component, abstract=True):
    """One flange: sources, fixed points and absolute sensors."""

    flange = Port(Flange)
