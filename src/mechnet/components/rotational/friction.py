"""Rotational friction with true stiction (the path form of `components/switched.py`).

Between flange_a (a housing, or the driving shaft) and flange_b: w_rel = der(phi_b − phi_a); tau is the
friction torque transmitted (flange_b feels −tau). Each element sticks, breaks away and slides with
modes, or, with `smooth=True` (or inside `smooth_friction()`), uses its regularised form.
"""
from __future__ import annotations

import casadi as ca

from ...core.declarations import Flag, Impulse, Input, Mode, Param, Var, nonnegative, positive
from ...core.equation import Eq, When
from ..switched import SwitchedFriction, contact_equations, relative_motion, release_event, resting_release
from .interfaces import PartialCompliant


class PartialFriction(SwitchedFriction, PartialCompliant, abstract=True):
    """Relative motion, the friction path and the switched-or-smooth choice, shared by the elements."""

    v_rel = Var(unit="rad/s", doc="relative angular velocity der(flange_b.phi - flange_a.phi)")
    a_rel = Var(unit="rad/s^2", doc="relative angular acceleration")
    sa = Var(unit="N*m", doc="path parameter: the holding torque while stuck, tau_static + a_rel sliding")
    mode = Mode(0.0, values=(-1.0, 0.0, 1.0), doc="0 stuck, +1 sliding forward, -1 sliding backward")
    impulse = Impulse(doc="carrier of the sticking jump (0 between events)")
    smooth = Flag(False, doc="regularised friction (no modes, creeps) instead of true stiction")
    v_smooth = Param(1e-4, unit="rad/s", doc="speed of the regularised form's transition", check=positive)
    v_small = Param(1e-6, unit="rad/s", doc="relative speed above which a run starts sliding", check=positive)

    def _flow(self):
        return self.tau

    def _position(self):
        return self.flange_b.phi - self.flange_a.phi

    def equations(self):
        return self.compliant_equations() + self.switched_equations()


class BearingFriction(PartialFriction):
    """Coulomb, viscous and Stribeck friction in a bearing (flange_a: the housing, flange_b: the shaft).

    Sliding: tau = tau_Coulomb + tau_prop·|w| + tau_Stribeck·exp(−|w|/w_Stribeck) against the motion;
    stuck up to tau_Coulomb + tau_Stribeck (w_Stribeck = 0: the excess holds only at rest).
    """

    tau_Coulomb = Param(unit="N*m", doc="Coulomb (kinetic) friction torque", check=nonnegative)
    tau_Stribeck = Param(0.0, unit="N*m", doc="static torque in excess of tau_Coulomb", check=nonnegative)
    tau_prop = Param(0.0, unit="N*m*s/rad", doc="viscous friction coefficient", check=nonnegative)
    w_Stribeck = Param(0.0, unit="rad/s", doc="speed over which the Stribeck excess decays (0: at once)",
                       check=nonnegative)

    def _characteristic(self):
        return self.tau_Coulomb, self.tau_prop, self.tau_Stribeck, self.w_Stribeck

    def _coefficient_keys(self):
        return ("tau_Coulomb", "tau_Stribeck", "tau_prop")


class Clutch(PartialFriction):
    """A friction clutch between two shafts, pressed by fn = fn_max·f_normalized (an input in [0, 1]):
    tau = cgeo·fn·μ(w) sliding, μ = mu_k + mu_v·|w| (+ the static excess decaying over w_Stribeck),
    stuck up to cgeo·fn·mu_s. Modelica's Clutch names (cgeo, fn_max, f_normalized)."""

    fn_max = Param(unit="N", doc="normal force at f_normalized = 1", check=nonnegative)
    cgeo = Param(1.0, unit="m", doc="geometry constant: effective friction radius × number of surfaces",
                 check=nonnegative)
    mu_k = Param(unit="1", doc="kinetic friction coefficient", check=nonnegative)
    mu_s = Param(None, unit="1", doc="static friction coefficient (>= mu_k)", check=nonnegative)
    mu_v = Param(0.0, unit="s/rad", doc="viscous friction coefficient per unit normal force", check=nonnegative)
    w_Stribeck = Param(0.0, unit="rad/s", doc="speed over which the static excess decays (0: at once)",
                       check=nonnegative)
    f_normalized = Input(default=1.0, unit="1", doc="normalised normal force (0 open, 1 fully pressed)")

    def _characteristic(self):
        scale = self.cgeo * self.fn_max * ca.fmax(self.f_normalized, 0.0)
        return self.mu_k * scale, self.mu_v * scale, (self.mu_s - self.mu_k) * scale, self.w_Stribeck

    def _coefficient_keys(self):
        return ("fn_max",) if "fn_max" not in self.tunable and self._values["fn_max"] == 0 else \
            ("mu_k", "mu_s", "mu_v")


class Brake(Clutch):
    """A brake: the clutch's law between a housing (flange_a, usually fixed) and a shaft (flange_b)."""


class OneWayClutch(PartialCompliant):
    """A freewheel: flange_b may overrun flange_a forward (w_rel = w_b − w_a > 0) freely; it cannot turn
    backwards relative to it. Locked (mode −1) it carries any torque that holds it (tau ≤ 0); it frees
    when that torque would pull, and locks, with a plastic jump, when w_rel falls to 0."""

    v_rel = Var(unit="rad/s", doc="relative angular velocity der(flange_b.phi - flange_a.phi)")
    a_rel = Var(unit="rad/s^2", doc="relative angular acceleration")
    sa = Var(unit="N*m", doc="path parameter: the locking torque while locked, a_rel while free")
    mode = Mode(0.0, values=(-1.0, 0.0), doc="0 free (overrunning), -1 locked")
    impulse = Impulse(doc="carrier of the locking jump (0 between events)")

    def equations(self):
        v, a = relative_motion(self.flange_b.phi - self.flange_a.phi)
        return self.compliant_equations() + [Eq(self.v_rel, v, "relative velocity"),
                                             Eq(self.a_rel, a, "relative acceleration")] + \
            contact_equations(self.a_rel, self.tau, self.sa, self.mode, self.impulse)

    def jump_releases(self):
        return [resting_release(self.mode, self.v_rel, 0.0)]

    def events(self):
        return [When(ca.if_else(self.mode == 0, self.v_rel, 1.0), reset={self.mode: -1.0},
                     jump={self.impulse: (self.v_rel, 0.0)}, release=False, direction="falling",
                     doc=f"{self.name} locks"),
                release_event(self.sa, self.mode, self.name)]
