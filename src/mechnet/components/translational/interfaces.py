"""Translational connector and partial models.

Sign convention (Modelica.Mechanics.Translational): a flange's cut force `f`
is positive when it acts *into* the component, i.e. in the positive `s`
direction on the component; at a connection the positions are equal and the
forces sum to zero.
"""
from __future__ import annotations

from ...core.component import Component, Connector
from ...core.declarations import Across, Port, Through, Var
from ...core.equation import Eq


class Flange(Connector):
    """1D translational flange: absolute position and cut force (positive into the component)."""

    s = Across(unit="m", doc="absolute position of the flange")
    f = Through(unit="N", doc="cut force, positive into the component")


class PartialTwoFlanges(Component, abstract=True):
    """Two flanges, a and b; each flange's f is the force acting on the component there."""

    flange_a = Port(Flange, doc="left flange")
    flange_b = Port(Flange, doc="right flange")


class PartialCompliant(PartialTwoFlanges, abstract=True):
    """A massless element between two flanges: relative position and the force it transmits.

    s_rel = flange_b.s − flange_a.s; flange_b.f = f; flange_a.f = −f. A positive
    f pushes the flanges apart, so the component at flange_b feels −f.
    """

    s_rel = Var(unit="m", doc="relative position flange_b.s - flange_a.s")
    f = Var(unit="N", doc="force transmitted (acting on flange_b)")

    def compliant_equations(self):
        return [Eq(self.s_rel, self.flange_b.s - self.flange_a.s, "relative position"),
                Eq(self.flange_b.f, self.f, "force on flange_b"),
                Eq(self.flange_a.f, -self.f, "force on flange_a")]


class PartialOneFlange(Component, abstract=True):
    """One flange: sources, fixed points and absolute sensors; flange.f is the force into the component."""

    flange = Port(Flange)
