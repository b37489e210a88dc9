"""Force sources. A source drives its flange with +f: flange.f = −f (cut force into the source)."""
from __future__ import annotations

from ...core.declarations import Input, Param
from ...core.equation import Eq
from .interfaces import PartialOneFlange


class Force(PartialOneFlange):
    """External force input `<name>.f` (default value `f=`) pushing the connected flange with +f.

    flange.f = −f: a positive f accelerates an attached mass in the positive s direction.
    """

    f = Input(unit="N", doc="driving force (input)")

    def equations(self):
        return [Eq(self.flange.f, -self.f, "the source drives its flange with +f")]


class ConstantForce(PartialOneFlange):
    """Constant force f_constant pushing the connected flange: flange.f = −f_constant."""

    f_constant = Param(unit="N", doc="driving force")

    def equations(self):
        return [Eq(self.flange.f, -self.f_constant, "the source drives its flange with +f_constant")]


class Position(PartialOneFlange):
    """Prescribed position: flange.s = s_ref (an input, or a signal such as a road profile).

    Through a compliant element (a tyre spring) this is an ordinary equation.
    Attached rigidly to a mass it fixes a state, which needs index reduction.
    """

    s_ref = Input(unit="m", doc="prescribed position of the flange")

    def equations(self):
        return [Eq(self.flange.s, self.s_ref, "the flange follows s_ref")]
