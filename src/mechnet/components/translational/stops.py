"""Translational stops and contacts: rigid impacts with restitution (switched.py), and a compliant gap.

A rigid impact is solved through the whole scene's impulse–momentum equations, so whatever is
connected (a mass, a prismatic joint in a linkage) takes its share of the jump.
"""
from __future__ import annotations

import casadi as ca

from ...core.declarations import Impulse, Mode, Param, Var, nonnegative
from ...core.equation import Eq, When, der
from ..switched import SwitchedStop, restitution
from .interfaces import PartialCompliant


class PartialRigidContact(SwitchedStop, PartialCompliant, abstract=True):
    v_rel = Var(unit="m/s", doc="relative velocity der(flange_b.s - flange_a.s)")
    a_rel = Var(unit="m/s^2", doc="relative acceleration")
    sa = Var(unit="N", doc="path parameter: the contact force while resting, a_rel while free")
    mode = Mode(0.0, values=(-1.0, 0.0, 1.0), doc="0 free, -1 resting on the lower limit, +1 on the upper one")
    impulse = Impulse(doc="carrier of the impact impulse (0 between events)")
    e = Param(1.0, unit="1", doc="coefficient of restitution (0 plastic, 1 elastic)", check=restitution)
    v_rest = Param(0.0, unit="m/s", doc="impact speed at or below which the body rests (0: only when its "
                                        "impacts accumulate)", check=nonnegative)

    def _flow(self):
        return self.f

    def _position(self):
        return self.flange_b.s - self.flange_a.s


class HardStop(PartialRigidContact):
    """flange_b moves relative to flange_a between s_min and s_max (s_rel = s_b − s_a); at a limit it
    rebounds with restitution e or rests there until it is pulled away (on a prismatic joint: connect
    its support and axis)."""

    s_min = Param(unit="m", doc="lower limit of s_rel")
    s_max = Param(unit="m", doc="upper limit of s_rel")

    def _limit_keys(self):
        return "s_min", "s_max"


class Contact(PartialRigidContact):
    """A rigid one-sided contact: flange_b stays at least s_contact above flange_a (a ball of radius
    s_contact on a floor at flange_a; two spheres on a line, s_contact their centre distance)."""

    s_contact = Param(0.0, unit="m", doc="s_rel at which the two touch")

    def _limit_keys(self):
        return "s_contact", None


class ElastoGap(PartialCompliant):
    """A compliant contact (Modelica's ElastoGap): free while s_rel > s_rel0; closed, a spring-damper
    that only pushes, f = min(0, c·(s_rel − s_rel0) + d·v_rel). Events mark the closing and opening so the
    integrator restarts at the kinks."""

    c = Param(unit="N/m", doc="contact stiffness", check=nonnegative)
    d = Param(0.0, unit="N*s/m", doc="contact damping", check=nonnegative)
    s_rel0 = Param(0.0, unit="m", doc="s_rel at which the gap closes")
    v_rel = Var(unit="m/s", doc="relative velocity")

    def equations(self):
        push = self.c * (self.s_rel - self.s_rel0) + self.d * self.v_rel
        closed = self.s_rel < self.s_rel0
        return self.compliant_equations() + [
            Eq(self.v_rel, der(self.flange_b.s - self.flange_a.s), "relative velocity"),
            Eq(self.f, ca.if_else(closed, ca.fmin(0.0, push), 0.0), "spring-damper while closed, pushing only")]

    def events(self):
        push = self.c * (self.s_rel - self.s_rel0) + self.d * self.v_rel
        return [When(self.s_rel - self.s_rel0, doc=f"{self.name} closes or opens"),
                When(ca.if_else(self.s_rel < self.s_rel0, push, -1.0), doc=f"{self.name} stops pushing")]
