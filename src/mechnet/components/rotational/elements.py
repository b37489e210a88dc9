"""Rotational elements: inertia, spring, damper, spring–damper, fixed flange, ideal gear."""
from __future__ import annotations

from ...core.declarations import Param, State, Var, nonnegative, nonzero, positive
from ...core.equation import Eq, der
from .interfaces import PartialCompliant, PartialOneFlange, PartialTwoFlanges


class Inertia(PartialTwoFlanges):
    """Rigid rotor with two rigidly attached flanges: J·a = flange_a.tau + flange_b.tau."""

    J = Param(unit="kg*m^2", doc="moment of inertia about the axis", check=positive)
    phi = State(unit="rad", doc="absolute rotation angle")
    w = State(unit="rad/s", doc="angular velocity")
    a = Var(unit="rad/s^2", doc="angular acceleration")

    def equations(self):
        return [Eq(self.phi, self.flange_a.phi, "flange_a is rigidly attached"),
                Eq(self.phi, self.flange_b.phi, "flange_b is rigidly attached"),
                Eq(self.w, der(self.phi), "angular velocity"),
                Eq(self.a, der(self.w), "angular acceleration"),
                Eq(self.J * self.a, self.flange_a.tau + self.flange_b.tau, "Euler's equation about the axis")]


class Spring(PartialCompliant):
    """Linear torsional spring: tau = c·(phi_rel − phi_rel0)."""

    c = Param(unit="N*m/rad", doc="spring constant", check=nonnegative)
    phi_rel0 = Param(0.0, unit="rad", doc="unstretched relative angle")

    def equations(self):
        return self.compliant_equations() + [
            Eq(self.tau, self.c * (self.phi_rel - self.phi_rel0), "Hooke's law")]


class Damper(PartialCompliant):
    """Linear torsional damper: tau = d·der(phi_rel).

    The relative speed is written as der(flange_b.phi) − der(flange_a.phi) so
    that the flange angles — not phi_rel — carry the derivatives: the connected
    inertias' states serve, and no constraint among states appears.
    """

    d = Param(unit="N*m*s/rad", doc="damping constant", check=nonnegative)
    w_rel = Var(unit="rad/s", doc="relative angular velocity")

    def equations(self):
        return self.compliant_equations() + [
            Eq(self.w_rel, der(self.flange_b.phi - self.flange_a.phi), "relative angular velocity"),
            Eq(self.tau, self.d * self.w_rel, "viscous damping")]


class SpringDamper(PartialCompliant):
    """Spring and damper in parallel: tau = c·(phi_rel − phi_rel0) + d·der(phi_rel)."""

    c = Param(unit="N*m/rad", doc="spring constant", check=nonnegative)
    d = Param(unit="N*m*s/rad", doc="damping constant", check=nonnegative)
    phi_rel0 = Param(0.0, unit="rad", doc="unstretched relative angle")
    w_rel = Var(unit="rad/s", doc="relative angular velocity")

    def equations(self):
        return self.compliant_equations() + [
            Eq(self.w_rel, der(self.flange_b.phi - self.flange_a.phi), "relative angular velocity"),
            Eq(self.tau, self.c * (self.phi_rel - self.phi_rel0) + self.d * self.w_rel, "spring and damper")]


class Fixed(PartialOneFlange):
    """Flange fixed at the angle phi0 (the housing); takes whatever reaction torque is needed."""

    phi0 = Param(0.0, unit="rad", doc="fixed angle")

    def equations(self):
        return [Eq(self.flange.phi, self.phi0, "flange is fixed")]


class IdealGear(PartialTwoFlanges):
    """Ideal gear without inertia, elasticity, backlash or losses (Modelica convention).

    phi_a = ratio·phi_b and 0 = ratio·flange_a.tau + flange_b.tau, so flange_a
    turns `ratio` times as far as flange_b and the power flowing in at flange_a
    leaves at flange_b. The angle relation is a rigid constraint between the
    connected elements: attached to inertias on both sides it is resolved by
    index reduction (one of the two inertias' coordinates becomes dependent),
    and the inertia on flange_b appears at flange_a as J_b / ratio².
    """

    ratio = Param(unit="1", doc="transmission ratio phi_a / phi_b (non-zero)", check=nonzero)

    def equations(self):
        return [Eq(self.flange_a.phi, self.ratio * self.flange_b.phi, "gear kinematics: phi_a = ratio·phi_b"),
                Eq(self.ratio * self.flange_a.tau + self.flange_b.tau, 0.0, "power balance of a lossless gear")]
