"""Translational elements: mass, spring, damper, spring–damper, fixed flange."""
from __future__ import annotations

from ...core.declarations import Param, State, Var, nonnegative, positive
from ...core.equation import Eq, der
from .interfaces import PartialCompliant, PartialOneFlange, PartialTwoFlanges


class Mass(PartialTwoFlanges):
    """Sliding mass with two rigidly attached flanges (no length): m·a = flange_a.f + flange_b.f.

    Both flange forces act on the mass in the positive s direction when positive.
    """

    m = Param(unit="kg", doc="mass", check=positive)
    s = State(unit="m", doc="absolute position")
    v = State(unit="m/s", doc="absolute velocity")
    a = Var(unit="m/s^2", doc="absolute acceleration")

    def equations(self):
        return [Eq(self.s, self.flange_a.s, "flange_a is rigidly attached"),
                Eq(self.s, self.flange_b.s, "flange_b is rigidly attached"),
                Eq(self.v, der(self.s), "velocity"),
                Eq(self.a, der(self.v), "acceleration"),
                Eq(self.m * self.a, self.flange_a.f + self.flange_b.f, "Newton's second law")]


class Spring(PartialCompliant):
    """Linear spring: f = c·(s_rel − s_rel0), flange_b.f = f, flange_a.f = −f.

    A stretched spring (s_rel > s_rel0) pulls the component at flange_b back
    (it feels −f) and the one at flange_a forward.
    """

    c = Param(unit="N/m", doc="spring constant", check=nonnegative)
    s_rel0 = Param(0.0, unit="m", doc="unstretched relative position")

    def equations(self):
        return self.compliant_equations() + [
            Eq(self.f, self.c * (self.s_rel - self.s_rel0), "Hooke's law")]


class Damper(PartialCompliant):
    """Linear damper: f = d·der(s_rel), flange_b.f = f, flange_a.f = −f.

    The relative speed is written as der(flange_b.s − flange_a.s) so that the
    flange positions — not s_rel — carry the derivatives: the connected masses'
    states serve, and no constraint among states appears.
    """

    d = Param(unit="N*s/m", doc="damping constant", check=nonnegative)
    v_rel = Var(unit="m/s", doc="relative velocity")

    def equations(self):
        return self.compliant_equations() + [
            Eq(self.v_rel, der(self.flange_b.s - self.flange_a.s), "relative velocity"),
            Eq(self.f, self.d * self.v_rel, "viscous damping")]


class SpringDamper(PartialCompliant):
    """Spring and damper in parallel: f = c·(s_rel − s_rel0) + d·der(s_rel), flange_b.f = f, flange_a.f = −f."""

    c = Param(unit="N/m", doc="spring constant", check=nonnegative)
    d = Param(unit="N*s/m", doc="damping constant", check=nonnegative)
    s_rel0 = Param(0.0, unit="m", doc="unstretched relative position")
    v_rel = Var(unit="m/s", doc="relative velocity")

    def equations(self):
        return self.compliant_equations() + [
            Eq(self.v_rel, der(self.flange_b.s - self.flange_a.s), "relative velocity"),
            Eq(self.f, self.c * (self.s_rel - self.s_rel0) + self.d * self.v_rel, "spring and damper")]


class Fixed(PartialOneFlange):
    """Flange fixed at the position s0 (the housing); flange.f is the reaction force on the housing."""

    s0 = Param(0.0, unit="m", doc="fixed position")

    def equations(self):
        return [Eq(self.flange.s, self.s0, "flange is fixed")]
