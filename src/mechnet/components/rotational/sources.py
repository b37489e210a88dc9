"""Torque sources and prescribed-motion sources.

A torque source drives its flange with +tau: flange.tau = −tau (cut torque into
the source). A motion source (Position, Speed, Accelerate) imposes the motion
of its flange and takes whatever torque that needs: flange.tau is the cut
torque into the source, so the torque it delivers to the driven side is
−flange.tau.
"""
from __future__ import annotations

import math
import numbers

from ...core.declarations import Input, not_a_number, Param, State, Var
from ...core.equation import Eq, der
from ..signals import Constant
from .interfaces import PartialOneFlange


class NumberIsConstant:
    """Mixin for a motion source whose reference index reduction differentiates (Position, Speed): a number
    given for it (`Speed(w_ref=2.0)`) is the constant signal `Constant(2.0)`, which can be differentiated,
    not an external input with that default, which cannot (a rigid attachment failed to compile). Left out,
    the reference stays an external input."""

    _reference: str = ""

    def __init__(self, name: str | None = None, **kwargs):
        value = kwargs.get(self._reference)
        if (isinstance(value, numbers.Real) and not not_a_number(value) and math.isfinite(value)):
            kwargs[self._reference] = Constant(value)
        super().__init__(name, **kwargs)


class Torque(PartialOneFlange):
    """External torque input `<name>.tau` (default value `tau=`), acting on the connected flange."""

    tau = Input(unit="N*m", doc="driving torque on the flange")

    def equations(self):
        return [Eq(self.flange.tau, -self.tau, "the source drives its flange with +tau")]


class ConstantTorque(PartialOneFlange):
    """Constant torque tau_constant acting on the connected flange."""

    tau_constant = Param(unit="N*m", doc="constant driving torque on the flange")

    def equations(self):
        return [Eq(self.flange.tau, -self.tau_constant, "the source drives its flange with +tau_constant")]


class Position(NumberIsConstant, PartialOneFlange):
    """Prescribed angle: flange.phi = phi_ref (an input, or a signal such as a Sine).

    flange.tau is the cut torque into the source (Modelica convention), so the
    torque the source delivers to what it drives is −flange.tau.

    Through a compliant element (a spring, a damper) this is an ordinary
    equation. Attached rigidly to an inertia (directly or through a gear) it
    fixes a state: index reduction differentiates this equation and the signal
    behind phi_ref (through `time`) twice, for the speed and the acceleration.
    A Table or Ramp signal can be differentiated once only, a Step never, a
    Sine (starting at t = 0) any number of times; an external input not at
    all. When the signal is not smooth enough, compilation raises
    `StructureError` naming this source or its input.
    """

    _reference = "phi_ref"
    phi_ref = Input(unit="rad", doc="prescribed angle of the flange")

    def equations(self):
        return [Eq(self.flange.phi, self.phi_ref, "the flange follows phi_ref")]


class Speed(NumberIsConstant, PartialOneFlange):
    """Prescribed angular velocity: der(flange.phi) = w_ref (an input, or a signal).

    `phi` is the flange angle (`phi_start=` fixes it when nothing else does).
    flange.tau is the cut torque into the source (Modelica convention), so the
    torque the source delivers to what it drives is −flange.tau.

    Through a compliant element this is an ordinary equation. Attached rigidly
    to an inertia it fixes that inertia's speed: index reduction
    differentiates this equation and the signal behind w_ref (through `time`)
    once, for the acceleration. A Table or Ramp signal can be differentiated
    once only (enough here), a Step never, a Sine (starting at t = 0) any
    number of times; an external input not at all. When the signal is not
    smooth enough, compilation raises `StructureError` naming this source or
    its input.
    """

    _reference = "w_ref"
    w_ref = Input(unit="rad/s", doc="prescribed angular velocity of the flange")
    phi = Var(unit="rad", doc="absolute angle of the flange")

    def equations(self):
        return [Eq(self.phi, self.flange.phi, "the source angle is the flange angle"),
                Eq(der(self.phi), self.w_ref, "the flange turns at w_ref")]


class Accelerate(PartialOneFlange):
    """Prescribed angular acceleration: der(phi) = w, der(w) = a_ref, flange.phi = phi.

    phi and w are states of the source (`phi_start=`, `w_start=` fix them); a_ref
    is an input or a signal. flange.tau is the cut torque into the source
    (Modelica convention), so the torque the source delivers is −flange.tau.

    Attached rigidly to an inertia, the inertia's angle and speed coincide with
    the source's states; index reduction resolves this constraint by making one
    copy dependent (fix start values on one side only). a_ref itself is never
    differentiated, so any signal serves, even a Step (a Table or Ramp signal
    can be differentiated once only, a Step never, a Sine any number of times —
    which matters for the Position and Speed sources).
    """

    a_ref = Input(unit="rad/s^2", doc="prescribed angular acceleration of the flange")
    phi = State(unit="rad", doc="absolute angle of the flange")
    w = State(unit="rad/s", doc="absolute angular velocity of the flange")

    def equations(self):
        return [Eq(self.flange.phi, self.phi, "the flange follows the source angle"),
                Eq(der(self.phi), self.w, "angular velocity"),
                Eq(der(self.w), self.a_ref, "the flange accelerates at a_ref")]
