"""Switched 1D elements in the path form: friction that sticks, stops that hold, freewheels.

Every element here relates a relative motion (position s, velocity v, acceleration a) to the force f
it transmits. Its discrete `mode` picks which of the two is given: held (stuck, resting on a stop,
freewheel locked) means a = 0 and f free; moving (sliding, free flight) means f given and a free.
Both are written with one extra unknown, the path parameter `sa` (Modelica Standard Library's
friction formulation): held: a = 0, f = sa; sliding forward: a = sa − f_static, f = f_kinetic(v); free:
a = sa, f = 0. No mode divides by zero, the equations keep one structure (`Eq(..., regular=True)`:
the compiler solves them symbolically with the mode inside), and at each switch sa is continuous, so
the events that decide the next mode read it directly:

- held → moving when the force needed to hold (sa) passes the static limit (friction), or would pull
  (a stop: contact forces only push);
- moving → held when v crosses 0 (friction sticking; a freewheel locking) or the gap closes slowly
  enough to rest. The velocity is then made exactly 0 by a plastic jump through the whole scene's
  impulse–momentum equations (`When.jump`): what the event location leaves (~1e-12) does not creep.

An impact (a closing gap) is a jump v → −e·v along the element's `Impulse`, solved for the whole scene
(`compile/casadi_dae.py`, `_jump`). Events of a stop that accumulate (a ball bouncing ever lower) end in
its rest mode (`When.rest`).

`smooth=True`, or compiling inside `smooth_friction()`, gives friction its regularised form instead:
f = f_kinetic(|v|)·v/√(v² + v_smooth²), no modes, no events, differentiable everywhere (what an
optimiser needs). Its price is creep: held by a force F below the Coulomb level F_C, the element
slides at the steady speed v = v_smooth·F/√(F_C² − F²) instead of sticking.
"""
from __future__ import annotations

from contextlib import contextmanager
from contextvars import ContextVar

import casadi as ca

from ..core.declarations import parameter_check
from ..core.equation import Eq, When, der
from ..core.requirements import Requirement

HELD, FORWARD, BACKWARD = 0.0, 1.0, -1.0

_SMOOTH: ContextVar[bool] = ContextVar("smooth_friction", default=False)


@contextmanager
def smooth_friction():
    """Models compiled inside this block give every friction element its regularised form (the
    optimal-control layer compiles this way by itself)."""
    token = _SMOOTH.set(True)
    try:
        yield
    finally:
        _SMOOTH.reset(token)


def smoothing_everywhere() -> bool:
    return _SMOOTH.get()


def relative_motion(position):
    """(v, a) of a relative position written through the flanges, so the connected bodies' states
    carry the derivatives (as the dampers do)."""
    v = der(position)
    return v, der(v)


def kinetic(speed, coulomb, viscous, stribeck, v_stribeck):
    """The sliding force at |v| = speed: Coulomb + viscous·|v| + Stribeck·exp(−|v|/v_Stribeck). With
    v_Stribeck = 0 the static excess holds only at rest: the force drops to Coulomb as it slides."""
    force = coulomb + viscous * speed
    if isinstance(v_stribeck, (int, float)):
        return force + stribeck * ca.exp(-speed / v_stribeck) if v_stribeck > 0 else force
    # tunable: 0 must not divide (exp(−0/0) is NaN at rest)
    return force + ca.if_else(v_stribeck > 0, stribeck * ca.exp(-speed / ca.fmax(v_stribeck, 1e-300)), 0.0)


def friction_equations(v, a, f, sa, mode, impulse, f_kinetic, f_static):
    """Path form of friction: stuck a = 0, f = sa; sliding a = sa ∓ f_static, f = ±f_kinetic(|v|).
    `impulse` adds to f (0 between events: the direction of the sticking jump).

    With no static limit (a clutch or brake not pressed: f_static = 0) nothing can hold, whatever the
    mode: the element is open, a = sa, f = sign(v)·f_kinetic(|v|) (0 at rest, since f_kinetic(0) =
    f_static: continuous through v = 0, so it needs no modes and makes no events). Counted as held, a
    brake without normal force "held" the load until a clutch's torque broke it away, and the row of
    that instant showed the torque it held."""
    stuck, opened = mode == HELD, is_open(f_static)
    return [Eq(a, ca.if_else(opened, sa, ca.if_else(stuck, 0.0, sa - mode * f_static)),
               "relative acceleration on the friction path", regular=True),
            Eq(f, ca.if_else(opened, ca.sign(v) * f_kinetic, ca.if_else(stuck, sa, mode * f_kinetic)) + impulse,
               "friction force on the friction path", regular=True)]


def is_open(f_static):
    """No static limit: the element holds nothing (Modelica's `free`)."""
    return f_static <= 0


def friction_events(v, sa, mode, impulse, f_static, v_small, name):
    """Break away (at the start too, when already pushed past the limit), stick with a plastic jump, and
    start sliding when the run begins with the surfaces moving (|v| > v_small) — all while the element
    can hold (a static limit above 0). An open element (no limit) is kept in the held mode: a sliding
    one whose limit falls to 0 opens, and when the limit rises again it starts sliding if it moves,
    else it is held (`friction_equations`)."""
    opened = is_open(f_static)
    stuck = ca.logic_and(mode == HELD, ca.logic_not(opened))
    # v reaching 0 sticks (plastically: v is made exactly 0); v thrown across 0 by another element's
    # jump (a block rebounding off a stop) keeps it sliding, the other way
    thrown = ca.fabs(v) > v_small
    # only a still element breaks away: one pressed while its surfaces move starts sliding instead
    still = ca.logic_and(stuck, ca.logic_not(thrown))
    return [When(ca.if_else(still, ca.fabs(sa) - f_static, -1.0), reset={mode: ca.sign(sa)},
                 direction="rising", at_start=True, doc=f"{name} breaks away"),
            When(ca.if_else(ca.logic_or(mode == HELD, opened), 1.0, mode * v),
                 reset={mode: ca.if_else(thrown, ca.sign(v), HELD)},
                 jump={impulse: (v, ca.if_else(thrown, v, 0.0))}, release=False, direction="falling",
                 doc=f"{name} sticks"),
            When(ca.if_else(stuck, ca.fabs(v) - v_small, -1.0), reset={mode: ca.sign(v)},
                 direction="rising", at_start=True, doc=f"{name} starts sliding"),
            When(ca.if_else(mode == HELD, 1.0, f_static), reset={mode: HELD}, direction="falling",
                 doc=f"{name} opens")][: 3 if always_holds(f_static) else 4]


def always_holds(f_static) -> bool:
    """A static limit that is a positive number (folded parameters, no input): the element never opens
    and needs no condition for it."""
    limit = ca.SX(f_static)
    return bool(limit.is_constant() and float(ca.DM(limit)) > 0)


def smooth_friction_force(v, f_kinetic_at_speed, v_smooth):
    """The regularised force: f_kinetic(|v|)·v/√(v² + v_smooth²)."""
    return f_kinetic_at_speed * v / ca.sqrt(v * v + v_smooth * v_smooth)


def contact_equations(a, f, sa, mode, impulse):
    """Path form of a unilateral contact: resting (mode ±1) a = 0, f = sa; free (0) a = sa, f = 0."""
    free = mode == 0
    return [Eq(a, ca.if_else(free, sa, 0.0), "relative acceleration on the contact path", regular=True),
            Eq(f, ca.if_else(free, 0.0, sa) + impulse, "contact force on the contact path", regular=True)]


def impact_event(gap, v, e, v_rest, mode, side, impulse, name, what):
    """`gap` (≥ 0 while apart) closing at the speed v (> 0 approaching): v → −e·v through the whole
    scene, or rest (mode := side, v → 0) when the approach is at most v_rest (a body placed on its stop:
    v = 0) or the impacts accumulate. A contact found "closing" while it separates (v < 0: a round-off
    crossing just after its own impact) is left as it is. `side` is +1 at an upper limit (contact
    pushes the b side back: f > 0), −1 at a lower one."""
    resting = ca.logic_and(v >= 0, v <= v_rest)
    return When(ca.if_else(mode == 0, gap, 1.0), direction="falling",
                reset={mode: ca.if_else(resting, side, 0.0)},
                jump={impulse: (v, ca.if_else(resting, 0.0, ca.if_else(v > 0, -e * v, v)))},
                rest={mode: side}, doc=f"{name} {what}")


def resting_release(mode, v, v_rest):
    """A resting contact is free during another element's jump (it can only push). It stays resting —
    held rigidly in the jump, its speed exactly 0 — when the freed jump would drive it into its limit no
    faster than v_rest (or leave it still); else it is free (0) and, driven into its limit, has its own
    impact in the same event iteration (sequential impacts). `mode·v` is the speed into the limit."""
    into = mode * v
    return (mode, 0.0, ca.logic_and(into >= -1e-12, into <= ca.fmax(v_rest, 1e-12)), 0.0)


def release_event(sa, mode, name):
    """A resting contact lets go when the force it needs to hold would pull (side·sa falls through 0)."""
    return When(ca.if_else(mode == 0, 1.0, mode * sa), reset={mode: 0.0}, direction="falling",
                doc=f"{name} lets go")


@parameter_check(value_range=(0.0, False, 1.0))
def restitution(value):
    """The check of a coefficient of restitution (a Param check: also where it is tuned at run time)."""
    return None if 0.0 <= value <= 1.0 else "must lie in [0, 1] (0 plastic, 1 elastic)"


def folded_zero(component, key) -> bool:
    return key not in component.tunable and component._values[key] == 0


class SwitchedFriction:
    """Mixin of the friction elements: equations, events and form (switched, smooth or absent) from
    four hooks: `_flow()` the transmitted force or torque, `_position()` the relative position,
    `_characteristic()` → (Coulomb, viscous, Stribeck, v_Stribeck), `_coefficient_keys()` the parameters
    whose all being folded zeros makes the element absent."""

    def requirements(self):
        """mu_s >= mu_k for the μ-form elements (checked wherever a value enters: `core/requirements.py`)."""
        if "mu_s" not in self._declarations:
            return []
        return [Requirement("mu_s", ">=", "mu_k", "a surface holds at least what it resists sliding with")]

    def _inert(self) -> bool:
        return all(folded_zero(self, k) for k in self._coefficient_keys())

    def _smooth_form(self) -> bool:
        return bool(self.smooth) or smoothing_everywhere()

    def form(self) -> str:
        """'absent' (nothing to switch: f = 0), 'smooth' (regularised) or 'switched' (modes and events)."""
        return "absent" if self._inert() else ("smooth" if self._smooth_form() else "switched")

    def modes_in_use(self) -> dict:
        return self.modes if self.form() == "switched" else {}

    def _static_limit(self):
        coulomb, _, stribeck, _ = self._characteristic()
        return coulomb + stribeck

    def switched_equations(self):
        v, a = relative_motion(self._position())
        out = [Eq(self.v_rel, v, "relative velocity"), Eq(self.a_rel, a, "relative acceleration")]
        form = self.form()
        if form == "absent":
            return out + [Eq(self._flow(), 0.0, "no friction"), Eq(self.sa, 0.0, "no friction path")]
        coulomb, viscous, stribeck, v_stribeck = self._characteristic()
        force = kinetic(ca.fabs(self.v_rel), coulomb, viscous, stribeck, v_stribeck)
        if form == "smooth":
            return out + [Eq(self._flow(), smooth_friction_force(self.v_rel, force, self.v_smooth),
                             "regularised friction"), Eq(self.sa, 0.0, "no friction path")]
        return out + friction_equations(self.v_rel, self.a_rel, self._flow(), self.sa, self.mode, self.impulse,
                                        force, self._static_limit())

    def jump_releases(self):
        """Stuck, it slides during another element's jump (its force is bounded, its impulse none; any
        sliding sign gives the same ∂ẋ/∂λ). It stays stuck — held rigidly in the jump, its speed exactly
        0 — when the freed jump would move it by no more than v_small; else it slides on in the direction
        the jump gave it."""
        if self.form() != "switched":
            return []
        stays = ca.logic_or(ca.logic_or(self.mode != HELD, ca.fabs(self.v_rel) <= self.v_small),
                            is_open(self._static_limit()))     # an open element stays in the held mode
        return [(self.mode, FORWARD, stays, ca.sign(self.v_rel))]

    def events(self):
        if self.form() != "switched":
            return []
        return friction_events(self.v_rel, self.sa, self.mode, self.impulse, self._static_limit(), self.v_small,
                               self.name)


class SwitchedStop:
    """Mixin of the stops and rigid contacts: free between limits, impacts with restitution e, resting
    against a limit. Hooks: `_flow()`, `_position()`, `_limits()` → (lower or None, upper or None)."""

    def requirements(self):
        lower, upper = self._limit_keys()
        return [Requirement(upper, ">", lower, "limits reversed or equal")] if lower and upper else []

    def equations(self):
        v, a = relative_motion(self._position())
        return self.compliant_equations() + [Eq(self.v_rel, v, "relative velocity"),
                                             Eq(self.a_rel, a, "relative acceleration")] + \
            contact_equations(self.a_rel, self._flow(), self.sa, self.mode, self.impulse)

    def jump_releases(self):
        return [resting_release(self.mode, self.v_rel, self.v_rest)]

    def start_requirements(self):
        lower, upper = self._limit_keys()
        rel = self._position()
        out = []
        if lower:
            out.append((rel - getattr(self, lower), f"{self.name} ({type(self).__name__}): the relative position must "
                                                    f"start at or above {lower}"))
        if upper:
            out.append((getattr(self, upper) - rel, f"{self.name} ({type(self).__name__}): the relative position must "
                                                    f"start at or below {upper}"))
        return out

    def events(self):
        lower, upper = self._limit_keys()
        rel = self._position()
        out = []
        if upper:
            out.append(impact_event(getattr(self, upper) - rel, self.v_rel, self.e, self.v_rest, self.mode, 1.0,
                                    self.impulse, self.name, f"hits {upper}"))
        if lower:
            out.append(impact_event(rel - getattr(self, lower), -self.v_rel, self.e, self.v_rest, self.mode,
                                    -1.0, self.impulse, self.name, f"hits {lower}"))
        return out + [release_event(self.sa, self.mode, self.name)]
