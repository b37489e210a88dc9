"""Declarations a component or connector makes in its class body.

Each declaration carries the unit, a short description, the default start
value, the nominal value (used to scale tolerances) and, for states, the
priority that index reduction uses when it picks states. Declaration order is
kept (Python class bodies preserve it) so flat names come out in a stable order.
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Callable, Optional

import casadi as ca
import numpy as np

from .errors import ParameterError, StructureError


def not_a_number(value) -> bool:
    """Values Python's float() would take but a user did not mean as a number: text ('2.5'), a truth
    value (True is 1.0), a complex number. One rule for every numeric argument, so J='2.5' and
    Torque(tau='3.0') are refused alike."""
    return isinstance(value, (str, bytes, bool, np.bool_, complex, np.complexfloating))


def number_array(value) -> np.ndarray:
    """`value` (a number or a nested sequence of them) as a float array; TypeError or ValueError where an
    entry is no number a user meant as one (`not_a_number`) or numpy cannot read it. One rule for every
    array argument: its callers name the argument in their own error."""
    if not_a_number(value) or any(not_a_number(v) for v in np.ravel(np.array(value, dtype=object))):
        raise TypeError(f"{value!r:.60} holds something that is not a number")
    return np.asarray(value, dtype=float)


def finite_number(value, what: str, error=ParameterError) -> float:
    """`value` as a finite float, or `error` saying "<what> = <value> is not a number / not finite"."""
    if not_a_number(value):
        raise error(f"{what} = {value!r} is not a number")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise error(f"{what} = {value!r} is not a number") from None
    if not math.isfinite(number):
        raise error(f"{what} = {number} is not finite")
    return number


# ---- parameter checks: each returns an error text or None ---------------------------------

def parameter_check(fn=None, *, value_range=None):
    """Marks a function as a parameter check. A loaded export names its parameters' checks, and `load`
    calls only functions marked so: a model file cannot make it call anything else in mechnet.

    `value_range` = (lower, strict, upper): the interval of numbers the check accepts, where it is one;
    what keeps a value in it by bounds reads it (an FMU's C wrapper, an optimiser's freed parameter)."""
    def mark(f):
        f.is_parameter_check = True
        f.value_range = value_range
        return f
    return mark(fn) if fn is not None else mark


def value_range_text(check) -> str:
    """The check's own words for a value outside its range ('must be > 0', 'must lie in [0, 1] (0
    plastic, 1 elastic)'): asked of the check itself, with a value just outside."""
    lower, _, upper = check.value_range
    return check(lower - 1.0 if lower > float("-inf") else upper + 1.0) or ""


@parameter_check(value_range=(0.0, True, float("inf")))
def positive(value) -> Optional[str]:
    return None if value > 0 else "must be > 0"


@parameter_check(value_range=(0.0, False, float("inf")))
def nonnegative(value) -> Optional[str]:
    return None if value >= 0 else "must be >= 0"


@parameter_check
def nonzero(value) -> Optional[str]:
    return None if value != 0 else "must be non-zero"


@parameter_check
def any_finite(value) -> Optional[str]:
    return None


@parameter_check
def direction(value) -> Optional[str]:
    """An axis: any finite vector but zero (its length does not matter; `unit_vector` normalises it)."""
    return None if np.max(np.abs(value)) > 0 else "must not be the zero vector (it gives a direction)"


def unit_vector(value) -> np.ndarray:
    """value / |value| for a finite non-zero vector, without overflow or underflow: |value| squares the
    entries, so [0, 0, 1e200] or [1e-200, 0, 0] are first scaled by their largest entry."""
    v = np.asarray(value, dtype=float).ravel()
    biggest = np.max(np.abs(v))
    if not 1e-150 < biggest < 1e150:
        v = v / biggest
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class Tunable:
    """Marks a parameter value that stays a symbol (for sweeps, OCP, export) instead of being folded."""

    value: float


def tunable(value: float) -> Tunable:
    """`Spring(c=mn.tunable(100.0))` keeps `c` as a CasADi parameter instead of folding it."""
    return Tunable(float(value))


_EVERY_TUNABLE: ContextVar[bool] = ContextVar("every_parameter_tunable", default=False)


@contextmanager
def every_parameter_tunable():
    """Components built inside keep every scalar parameter symbolic, as if given `tunable(value)`, so an
    export can expose all of them; vectors and matrices stay folded. A ContextVar: other threads and
    tasks keep their own setting."""
    token = _EVERY_TUNABLE.set(True)
    try:
        yield
    finally:
        _EVERY_TUNABLE.reset(token)


def all_tunable() -> bool:
    """True inside `every_parameter_tunable()`."""
    return _EVERY_TUNABLE.get()


class Declaration:
    """Common part of every declaration: the attribute name is filled in by __set_name__."""

    kind = "declaration"

    def __init__(self, *, unit: str = "1", doc: str = "", shape: int = 1):
        self.unit = unit
        self.doc = doc
        self.shape = int(shape)
        self.name: str = ""

    def __set_name__(self, owner, name):
        self.name = name

    def scalar_names(self, prefix: str) -> list[str]:
        base = f"{prefix}.{self.name}" if prefix else self.name
        if self.shape == 1:
            return [base]
        return [f"{base}[{i}]" for i in range(self.shape)]


class Param(Declaration):
    """A parameter: folded into the equations as a number unless given as `tunable(...)`."""

    kind = "parameter"

    def __init__(self, default=None, *, unit="1", doc="", check: Callable = any_finite, shape=1):
        super().__init__(unit=unit, doc=doc)
        self.shape = shape                 # 1, n (a vector) or (n, m) (a matrix)
        self.default = default
        self.check = check

    def validate(self, owner_label: str, value):
        if self.shape != 1:
            return self._validate_array(owner_label, value)
        raw = value.value if isinstance(value, Tunable) else value
        try:
            if not_a_number(raw):
                raise TypeError
            number = float(raw)
        except (TypeError, ValueError):
            raise ParameterError(f"{owner_label}: parameter {self.name} = {raw!r} is not a number "
                                 f"({self.doc}, unit {self.unit})") from None
        if not math.isfinite(number):
            raise ParameterError(f"{owner_label}: parameter {self.name} = {number} is not finite "
                                 f"({self.doc}, unit {self.unit})")
        problem = self.check(number)
        if problem:
            raise ParameterError(f"{owner_label}: parameter {self.name} = {number} {problem} "
                                 f"({self.doc}, unit {self.unit})")
        return number


    def _validate_array(self, owner_label: str, value):
        """A vector or matrix parameter, folded as a CasADi DM (vectors are columns)."""
        what = f"{owner_label}: parameter {self.name}"
        if isinstance(value, Tunable):
            raise ParameterError(f"{what}: only scalar parameters can be tunable")
        shape = (self.shape, 1) if isinstance(self.shape, int) else tuple(self.shape)
        try:
            arr = np.array(number_array(value))           # '123' would become 123.0, (True, 0, 0) a vector
        except (TypeError, ValueError):
            raise ParameterError(f"{what} = {value!r} is not a {_shape_text(shape)} of numbers "
                                 f"({self.doc}, unit {self.unit})") from None
        if arr.size != shape[0] * shape[1] or (arr.ndim == 2 and arr.shape != shape and shape[1] != 1):
            raise ParameterError(f"{what} = {value!r} must be a {_shape_text(shape)} ({self.doc}, unit {self.unit})")
        arr = arr.reshape(shape)
        if not np.all(np.isfinite(arr)):
            raise ParameterError(f"{what} = {value!r} is not finite ({self.doc}, unit {self.unit})")
        problem = self.check(arr)
        if problem:
            raise ParameterError(f"{what} = {arr.tolist()} {problem} ({self.doc}, unit {self.unit})")
        return ca.DM(arr)


def _shape_text(shape) -> str:
    return f"vector of {shape[0]}" if shape[1] == 1 else f"{shape[0]}x{shape[1]} matrix"


class Mode(Declaration):
    """A discrete variable (unit 1): constant between events, changed only by a `When` reset. It enters
    the equations like a parameter, so it never becomes an unknown (a relay: `on = Mode(0.0)`)."""

    kind = "mode"

    def __init__(self, start: float = 0.0, *, values: tuple | None = None, doc: str = ""):
        super().__init__(doc=doc)
        self.start = finite_number(start, "Mode start", StructureError)
        # the values it can take (a friction element's −1, 0, +1), so a start value outside them is refused
        # by name rather than run as a mode no equation means; None: any number
        self.values = None if values is None else tuple(finite_number(v, "Mode values", StructureError)
                                                        for v in values)


class Impulse(Mode):
    """The direction along which an event's `jump` acts (unit 1, always 0 between events). Add it to
    the force the component transmits (`f = ... + impulse`); the compiler differentiates the whole
    scene's accelerations along it to find the velocity jump an impulse there causes."""

    def __init__(self, *, doc: str = ""):
        super().__init__(0.0, doc=doc or "carrier of the impact impulse (0 between events)")


class Flag(Declaration):
    """A structural yes/no choice made at construction (`use_flange=True`); it can switch ports on."""

    kind = "flag"

    def __init__(self, default: bool = False, *, doc: str = ""):
        super().__init__(doc=doc)
        self.default = bool(default)


class Variable(Declaration):
    """A time-varying unknown. `start`: default start value; `nominal`: magnitude for scaling."""

    kind = "variable"

    def __init__(self, *, unit="1", doc="", start: float = 0.0, nominal: float = 1.0,
                 priority: str = "default", shape: int = 1):
        super().__init__(unit=unit, doc=doc, shape=shape)
        if priority not in ("always", "prefer", "default", "avoid", "never"):
            raise ValueError(f"priority {priority!r}: expected always, prefer, default, avoid or never")
        self.start = start
        self.nominal = nominal
        self.priority = priority


class State(Variable):
    """A variable expected to be a state (its derivative appears); `phi_start=` fixes it."""

    kind = "state"

    def __init__(self, *, priority: str = "prefer", **kw):
        super().__init__(priority=priority, **kw)


class Var(Variable):
    """An algebraic variable (or one whose state-ness the compiler decides)."""

    kind = "algebraic"


class Output(Variable):
    """A sensor output: observed, pruned from the integrated equations when nothing needs it."""

    kind = "output"


class Input(Variable):
    """An external input `u`; its value comes from simulate(inputs=...) or its default."""

    kind = "input"

    def __init__(self, *, default: float = 0.0, **kw):
        super().__init__(**kw)
        self.default = default


class Across(Variable):
    """Potential variable of a connector: equal at a connection."""

    kind = "across"


class Through(Variable):
    """Flow variable of a connector: sums to zero at a connection; positive into the component."""

    kind = "through"


class Port(Declaration):
    """A connector instance inside a component: `flange_a = Port(Flange)`."""

    kind = "port"

    def __init__(self, connector_type, *, doc: str = "", enabled_by: str | None = None):
        super().__init__(doc=doc)
        self.connector_type = connector_type
        self.enabled_by = enabled_by       # name of a Flag: the port exists only when it is True
