"""Force sources and prescribed-motion sources.

A force source drives its flange with +f: flange.f = −f (cut force into the
source). A motion source (Position, Speed, Accelerate) imposes the motion of
its flange and takes whatever force that needs: flange.f is the cut force into
the source, so the force it exerts on the driven side is −flange.f.
"""
from __future__ import annotations

from ...core.declarations import Input, Param, State, Var
from ...core.equation import Eq, der
from ..rotational.sources import NumberIsConstant
from .interfaces import PartialOneFlange


class Force(PartialOneFlange):
    """External force input `<name>.f` (default value `f=`) pushing the connected flange with +f.

    flange.f = −f: a positive f accelerates an attached mass in the positive s direction.
    """

    f = Input(unit="N", doc="driving force on the flange")

    def equations(self):
        return [Eq(self.flange.f, -self.f, "the source drives its flange with +f")]


class ConstantForce(PartialOneFlange):
    """Constant force f_constant pushing the connected flange: flange.f = −f_constant."""

    f_constant = Param(unit="N", doc="constant driving force on the flange")

    def equations(self):
        return [Eq(self.flange.f, -self.f_constant, "the source drives its flange with +f_constant")]


class Position(NumberIsConstant, PartialOneFlange):
    """Prescribed position: flange.s = s_ref (an input, or a signal such as a road profile).

    Through a compliant element (a tyre spring) this is an ordinary equation.
    Attached rigidly to a mass it fixes a state, which needs index reduction.
    """

    _reference = "s_ref"
    s_ref = Input(unit="m", doc="prescribed position of the flange")

    def equations(self):
        return [Eq(self.flange.s, self.s_ref, "the flange follows s_ref")]


class Speed(NumberIsConstant, PartialOneFlange):
    """Prescribed velocity: der(flange.s) = v_ref (an input, or a signal).

    `s` is the flange position (`s_start=` fixes it when nothing else does).
    flange.f is the cut force into the source (Modelica convention), so the
    force the source exerts on what it drives is −flange.f.

    Through a compliant element this is an ordinary equation. Attached rigidly
    to a mass it fixes that mass's velocity: index reduction differentiates
    this equation and the signal behind v_ref (through `time`) once, for the
    acceleration. A Table or Ramp signal can be differentiated once only
    (enough here), a Step never, a Sine (starting at t = 0) any number of
    times; an external input not at all. When the signal is not smooth
    enough, compilation raises `StructureError` naming this source or its input.
    """

    _reference = "v_ref"
    v_ref = Input(unit="m/s", doc="prescribed velocity of the flange")
    s = Var(unit="m", doc="absolute position of the flange")

    def equations(self):
        return [Eq(self.s, self.flange.s, "the source position is the flange position"),
                Eq(der(self.s), self.v_ref, "the flange moves at v_ref")]


class Accelerate(PartialOneFlange):
    """Prescribed acceleration: der(s) = v, der(v) = a_ref, flange.s = s.

    s and v are states of the source (`s_start=`, `v_start=` fix them); a_ref is
    an input or a signal. flange.f is the cut force into the source (Modelica
    convention), so the force the source exerts is −flange.f.

    Attached rigidly to a mass, the mass's position and velocity coincide with
    the source's states; index reduction resolves this constraint by making one
    copy dependent (fix start values on one side only). a_ref itself is never
    differentiated, so any signal serves, even a Step (a Table or Ramp signal
    can be differentiated once only, a Step never, a Sine any number of times —
    which matters for the Position and Speed sources).
    """

    a_ref = Input(unit="m/s^2", doc="prescribed acceleration of the flange")
    s = State(unit="m", doc="absolute position of the flange")
    v = State(unit="m/s", doc="absolute velocity of the flange")

    def equations(self):
        return [Eq(self.flange.s, self.s, "the flange follows the source position"),
                Eq(der(self.s), self.v, "velocity"),
                Eq(der(self.v), self.a_ref, "the flange accelerates at a_ref")]
