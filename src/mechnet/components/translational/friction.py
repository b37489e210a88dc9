"""Translational friction with true stiction (the path form of `components/switched.py`).

Between flange_a (the surface, or a support) and flange_b (the sliding body): v_rel = der(s_b − s_a),
f is the friction force transmitted (flange_b feels −f, so it opposes sliding forward). Each element
sticks, breaks away and slides with modes, or, with `smooth=True` (or inside `smooth_friction()`),
uses its regularised form.
"""
from __future__ import annotations

from ...core.declarations import Flag, Impulse, Mode, Param, Var, nonnegative, positive
from ..switched import SwitchedFriction
from .interfaces import PartialCompliant


class PartialFriction(SwitchedFriction, PartialCompliant, abstract=True):
    """Relative motion, the friction path and the switched-or-smooth choice, shared by the elements."""

    v_rel = Var(unit="m/s", doc="relative velocity der(flange_b.s - flange_a.s)")
    a_rel = Var(unit="m/s^2", doc="relative acceleration")
    sa = Var(unit="N", doc="path parameter: the holding force while stuck, f_static + a_rel while sliding")
    mode = Mode(0.0, values=(-1.0, 0.0, 1.0), doc="0 stuck, +1 sliding forward, -1 sliding backward")
    impulse = Impulse(doc="carrier of the sticking jump (0 between events)")
    smooth = Flag(False, doc="regularised friction (no modes, creeps) instead of true stiction")
    v_smooth = Param(1e-4, unit="m/s", doc="speed of the regularised form's transition", check=positive)
    v_small = Param(1e-6, unit="m/s", doc="relative speed above which a run starts sliding", check=positive)

    def _flow(self):
        return self.f

    def _position(self):
        return self.flange_b.s - self.flange_a.s

    def equations(self):
        return self.compliant_equations() + self.switched_equations()


class SupportFriction(PartialFriction):
    """Coulomb, viscous and Stribeck friction between a body (flange_b) and its support (flange_a).

    Sliding: f = F_Coulomb + F_prop·|v| + F_Stribeck·exp(−|v|/v_Stribeck), against the motion; stuck up
    to F_Coulomb + F_Stribeck. Names as Modelica's MassWithStopAndFriction (its fexp = 1/v_Stribeck);
    v_Stribeck = 0 drops the force to F_Coulomb as soon as the body slides.
    """

    F_Coulomb = Param(unit="N", doc="Coulomb (kinetic) friction force", check=nonnegative)
    F_Stribeck = Param(0.0, unit="N", doc="static force in excess of F_Coulomb", check=nonnegative)
    F_prop = Param(0.0, unit="N*s/m", doc="viscous friction coefficient", check=nonnegative)
    v_Stribeck = Param(0.0, unit="m/s", doc="speed over which the Stribeck excess decays (0: at once)",
                       check=nonnegative)

    def _characteristic(self):
        return self.F_Coulomb, self.F_prop, self.F_Stribeck, self.v_Stribeck

    def _coefficient_keys(self):
        return ("F_Coulomb", "F_Stribeck", "F_prop")


class Friction(PartialFriction):
    """A block on a surface: friction force μ·fn with static μ_s and kinetic μ_k (plus viscous μ_v·|v|
    and a Stribeck decay of the static excess over v_Stribeck; 0: at once)."""

    fn = Param(unit="N", doc="normal force pressing the block on the surface", check=nonnegative)
    mu_k = Param(unit="1", doc="kinetic (Coulomb) friction coefficient", check=nonnegative)
    mu_s = Param(None, unit="1", doc="static friction coefficient (>= mu_k)", check=nonnegative)
    mu_v = Param(0.0, unit="s/m", doc="viscous friction per newton of normal force", check=nonnegative)
    v_Stribeck = Param(0.0, unit="m/s", doc="speed over which the static excess decays (0: at once)",
                       check=nonnegative)

    def _characteristic(self):
        return (self.mu_k * self.fn, self.mu_v * self.fn, (self.mu_s - self.mu_k) * self.fn, self.v_Stribeck)

    def _coefficient_keys(self):
        return ("fn",) if "fn" not in self.tunable and self._values["fn"] == 0 else ("mu_k", "mu_s", "mu_v")
