"""Components and connectors: declarations in the class body, equations in one method.

A component instance owns CasADi symbols for all its variables (and those of
its connectors), created at construction and registered for `der()`.
Parameters are validated at construction; a parameter is a plain float unless
given as `tunable(...)` (or built inside `every_parameter_tunable()`), so zero
terms fold away symbolically. A `Mode` is a symbol like a tunable parameter, but
one the events reset.
"""
from __future__ import annotations

import difflib
import inspect
import keyword
from dataclasses import dataclass
from typing import Optional

import casadi as ca
import numpy as np

from .declarations import (Across, all_tunable, Declaration, finite_number, Flag, Input, Mode,
                           number_array, Param, Port, Through, Tunable, Variable)
from .equation import Eq, register, time
from .errors import ConnectError, ParameterError, StructureError
from .requirements import check_component
from .signatures import docstring, keyword_names, signature


@dataclass
class VariableInfo:
    """What flatten needs to know of one declared (possibly vector) variable."""

    local_name: str          # "phi" or "flange_a.phi"
    declaration: Variable
    symbol: ca.SX            # column of scalar symbols
    start: Optional[np.ndarray]   # fixed start values, or None
    guess: Optional[np.ndarray]   # Newton guesses, or None
    nominal: np.ndarray
    driven: bool = False          # an input driven by a signal: an ordinary variable with an equation


def _collect(cls) -> dict[str, Declaration]:
    decls: dict[str, Declaration] = {}
    for klass in reversed(cls.__mro__):
        for key, value in vars(klass).items():
            if isinstance(value, Declaration):
                decls[key] = value
    return decls


def _check_name(name, what) -> str:
    if name is None:           # `Inertia(J=1.0)`: said as a mechnet error, not Python's missing-argument TypeError
        raise ParameterError(f"{what}: name is required (it becomes part of dotted names), "
                             f"e.g. {what}(name=\"j1\", ...)")
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise ParameterError(f"{what}: name {name!r} must be a Python identifier (it becomes part of dotted names)")
    return name


def _make_symbols(label: str, decl: Variable) -> ca.SX:
    if decl.shape == 1:
        syms = [ca.SX.sym(label)]
    else:
        syms = [ca.SX.sym(f"{label}[{i}]") for i in range(decl.shape)]
    for s in syms:
        register(s)
    return ca.vertcat(*syms)


class Connector:
    """Base of connector types. Subclasses declare `Across` and `Through` variables.

    An instance belongs to one component port; `owner` and `port` say which.
    """

    _declarations: dict[str, Declaration] = {}

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        cls._declarations = _collect(cls)

    def __init__(self, owner: "Component", port: str):
        self.owner = owner
        self.port = port
        self._values: dict[str, ca.SX] = {}
        for key, decl in self._declarations.items():
            self._values[key] = _make_symbols(f"{owner.name}.{port}.{key}", decl)

    def __getattribute__(self, key):
        if not key.startswith("_"):
            values = object.__getattribute__(self, "_values")
            if key in values:
                return values[key]
        return object.__getattribute__(self, key)

    @property
    def label(self) -> str:
        return f"{self.owner.path}.{self.port}"

    def across(self):
        return [(k, self._values[k]) for k, d in self._declarations.items() if isinstance(d, Across)]

    def through(self):
        return [(k, self._values[k]) for k, d in self._declarations.items() if isinstance(d, Through)]

    def __repr__(self):
        return f"<{type(self).__name__} {self.label}>"


class Component:
    """Base of every component. Subclass, declare, and write `equations()`.

    Keyword arguments: one per parameter; `<var>_start=` fixes a start value,
    `<var>_guess=` gives a Newton guess, `<var>_nominal=` a scale. Every
    concrete subclass gets a `__signature__` and a docstring listing exactly
    these (core/signatures.py), since `(name, **kwargs)` would show none.
    """

    _declarations: dict[str, Declaration] = {}
    abstract = True

    def __init_subclass__(cls, abstract: bool = False, **kw):
        super().__init_subclass__(**kw)
        cls._declarations = _collect(cls)
        cls.abstract = abstract
        cls._own_doc = inspect.cleandoc(cls.__dict__.get("__doc__") or "")
        if not abstract:
            cls.__signature__ = signature(cls)
            cls.__doc__ = docstring(cls)

    def __init__(self, name: str | None = None, **kwargs):
        if type(self).abstract:
            raise TypeError(f"{type(self).__name__} is an abstract base; use one of its subclasses")
        self.name = _check_name(name, type(self).__name__)
        self.path = name                 # dotted path, extended when a subsystem is added to a model
        self._values: dict[str, object] = {}
        self._variables: list[VariableInfo] = []
        self._ports: dict[str, Connector] = {}
        self.tunable: dict[str, tuple[ca.SX, float]] = {}
        self.modes: dict[str, tuple[ca.SX, float]] = {}       # key -> (symbol, start)
        self.input_defaults: dict[str, float] = {}
        self.signals: dict[str, object] = {}
        label = f"{name} ({type(self).__name__})"
        unknown = sorted(set(kwargs) - self._accepted_keywords())
        if unknown:        # first: a misspelled `phimin=` is the error, not the `phi_min` it leaves missing
            raise ParameterError(self._unknown_arguments(label, unknown))
        for key, decl in self._declarations.items():
            if isinstance(decl, Flag):
                value = kwargs.pop(key, decl.default)
                if not isinstance(value, (bool, np.bool_)):
                    raise ParameterError(f"{label}: {key} = {value!r} must be True or False ({decl.doc})")
                self._values[key] = bool(value)
        for key, decl in self._declarations.items():
            if isinstance(decl, Param):
                value = kwargs.pop(key, decl.default)
                if value is None:
                    raise ParameterError(f"{label}: parameter {key} is required ({decl.doc}, unit {decl.unit})")
                number = decl.validate(label, value)
                if isinstance(value, Tunable) or (decl.shape == 1 and all_tunable()):
                    sym = ca.SX.sym(f"{name}.{key}")
                    self.tunable[key] = (sym, number)
                    self._values[key] = sym
                else:
                    self._values[key] = number
            elif isinstance(decl, Mode):
                sym = ca.SX.sym(f"{name}.{key}")         # not registered: der() of a mode is 0
                self.modes[key] = (sym, decl.start)
                self._values[key] = sym
            elif isinstance(decl, Port):
                if decl.enabled_by is not None and not self._values[decl.enabled_by]:
                    self._values[key] = DisabledPort(label, key, decl.enabled_by)
                    continue
                connector = decl.connector_type(self, key)
                self._ports[key] = connector
                self._values[key] = connector
        for key, decl in self._declarations.items():
            if isinstance(decl, Variable):
                sym = _make_symbols(f"{name}.{key}", decl)
                self._values[key] = sym
                if isinstance(decl, Input):
                    value = kwargs.pop(key, decl.default)
                    if hasattr(value, "expr") and hasattr(value, "events"):
                        self.signals[key] = value           # a Signal: symbolic in time
                    else:
                        self.input_defaults[key] = decl_value(label, key, value)
                self._variables.append(VariableInfo(
                    key, decl, sym,
                    self._vector(label, key, "start", kwargs.pop(f"{key}_start", None), decl.shape),
                    self._vector(label, key, "guess", kwargs.pop(f"{key}_guess", None), decl.shape),
                    self._vector(label, key, "nominal", kwargs.pop(f"{key}_nominal", decl.nominal), decl.shape),
                    driven=key in self.signals))
        for port, connector in self._ports.items():
            for key, decl in connector._declarations.items():
                self._variables.append(VariableInfo(
                    f"{port}.{key}", decl, connector._values[key], None, None,
                    np.full(decl.shape, float(decl.nominal))))
        if kwargs:
            raise ParameterError(self._unknown_arguments(label, sorted(kwargs)))
        check_component(self, label)
        self.check()

    @staticmethod
    def _vector(label, key, what, value, shape):
        if value is None:
            return None
        try:
            arr = np.atleast_1d(number_array(value)).ravel()   # True as 1.0, '0.5' as 0.5: not what a user meant
        except (TypeError, ValueError):
            raise ParameterError(f"{label}: {key}_{what} = {value!r} is not a number") from None
        if arr.size == 1 and shape > 1:
            arr = np.full(shape, arr[0])
        if arr.size != shape or not np.all(np.isfinite(arr)):
            raise ParameterError(f"{label}: {key}_{what} = {value!r} must be {shape} finite number(s)")
        if what == "nominal" and not np.all(arr > 0):
            raise ParameterError(f"{label}: {key}_nominal = {value!r} must be > 0 (it scales the tolerance)")
        return arr

    @classmethod
    def _accepted_keywords(cls) -> set:
        """The keywords __init__ takes from **kwargs below: flags, params, inputs, <variable>_start/_guess/_nominal."""
        accepted = set()
        for key, decl in cls._declarations.items():
            if isinstance(decl, (Flag, Param, Input)):
                accepted.add(key)
            if isinstance(decl, Variable):
                accepted.update(f"{key}_{what}" for what in ("start", "guess", "nominal"))
        return accepted

    def _unknown_arguments(self, label: str, unknown: list) -> str:
        valid = keyword_names(type(self))       # the same list the signature shows
        hints = []
        for word in unknown:
            close = difflib.get_close_matches(word, valid, n=1)
            if close:
                hints.append(f"{word} (did you mean {close[0]}?)")
            else:
                hints.append(word)
        return (f"{label}: unknown argument(s) {', '.join(hints)}; "
                f"valid arguments are {', '.join(valid) or 'none'}")

    def __getattribute__(self, key):
        if not key.startswith("_"):
            values = object.__getattribute__(self, "_values")
            if key in values:
                return values[key]
        return object.__getattribute__(self, key)

    def __setattr__(self, key, value):
        if not key.startswith("_") and key in type(self)._declarations and "_values" in self.__dict__:
            raise ParameterError(f"{self.name} ({type(self).__name__}): {key} is set at construction; "
                                 f"build a new component to change it")
        object.__setattr__(self, key, value)

    # ---- hooks for subclasses ---------------------------------------------------------------

    def check(self) -> None:
        """Checks at construction that are not a comparison of two scalar parameters (axes that must
        cross, a hollow inside its solid); raise ParameterError naming the component."""

    def requirements(self) -> list:
        """Comparisons between two scalar parameters that must hold (`core/requirements.Requirement`):
        checked at construction and wherever a tunable one is given a new value (simulate(params=),
        prepared runs, a loaded export, an FMU's parameter setter)."""
        return []

    def equations(self) -> list:
        """The component's equations (`Eq` or residual expressions), in a fixed order."""
        return []

    # ---- introspection ----------------------------------------------------------------------

    def parameter_names(self) -> list[str]:
        return [k for k, d in self._declarations.items() if isinstance(d, (Param, Flag))]

    def ports(self) -> dict[str, Connector]:
        return dict(self._ports)

    def variables(self) -> list[VariableInfo]:
        return list(self._variables)

    def events(self) -> list:
        """State events (`When`), for components with impacts, switches or resets."""
        return []

    def start_requirements(self) -> list:
        """(expression, what) pairs that must be >= 0 at the start of a run (a body inside its stops);
        the simulator refuses a start that breaks one, naming it."""
        return []

    def jump_releases(self) -> list:
        """(mode, value while released, stays, value when released) for each mode that holds something
        another element's impact must not be held by (stuck friction: its force is bounded; a resting
        contact: it only pushes). The impact is solved once with every such mode released; `stays` (an
        expression of that jump's state) says which keep their mode — they are held rigidly in the final
        jump, so a held element's speed stays exactly 0 — and the others get `value when released`,
        evaluated at the final state."""
        return []

    def modes_in_use(self) -> dict:
        """The modes this component's equations use (all it declares; a friction element in its smooth
        form, or with nothing to switch, uses none and so adds none to the compiled model)."""
        return self.modes

    def time_events(self) -> list[tuple[float, str]]:
        """Times where a driving signal jumps or kinks, with what causes them."""
        return [(float(t), f"{self.path}.{key}: {sig!r}") for key, sig in self.signals.items()
                for t in sig.events()]

    def residuals(self) -> list[tuple[int, int, ca.SX, str]]:
        """Scalar residuals: (equation number, element or None if scalar, expression, doc, smoothness,
        regular)."""
        out = []
        label = f"{self.path} ({type(self).__name__})"
        produced = self.equations()
        if produced is None or isinstance(produced, (str, bytes)) or not hasattr(produced, "__iter__"):
            raise StructureError(f"{label}: equations() must return a list of Eq(...), got {produced!r} "
                                 f"(a missing return statement?)")
        equations = list(produced)
        smooth = [float("inf")] * len(equations)
        regular = [isinstance(eq, Eq) and eq.regular for eq in equations]
        for key, sig in self.signals.items():
            equations.append(Eq(self._values[key], sig.expr(time), f"{key} driven by {sig!r}"))
            smooth.append(float(getattr(sig, "smoothness", float("inf"))))
            regular.append(False)
        for k, eq in enumerate(equations):
            doc = eq.doc if isinstance(eq, Eq) else ""
            try:
                res = eq.residual() if isinstance(eq, Eq) else ca.SX(eq)
            except (NotImplementedError, TypeError, ValueError, RuntimeError):
                raise StructureError(f"{label}, equation {k + 1}: {eq!r} is not an equation; write "
                                     f"Eq(lhs, rhs) with numbers and variables (not `==`, not strings)") from None
            if res.is_scalar() and not res.is_constant() and not res.is_symbolic() and any(
                    res.is_op(op) for op in (ca.OP_EQ, ca.OP_NE, ca.OP_LE, ca.OP_LT)):
                raise StructureError(f"{label}, equation {k + 1}: {eq!r} is a comparison, not an equation; "
                                     f"write Eq(lhs, rhs) instead of `lhs == rhs`")
            if isinstance(eq, bool) or res.is_constant():
                raise StructureError(f"{label}, equation {k + 1}: {eq!r} contains no variable "
                                     f"(did you write `==` instead of Eq(lhs, rhs)?)")
            res = ca.reshape(res, -1, 1)
            for i in range(res.numel()):
                out.append((k + 1, i if res.numel() > 1 else None, res[i], doc, smooth[k], regular[k]))
        return out

    def __repr__(self):
        return f"<{type(self).__name__} {self.path}>"


class DisabledPort:
    """Stands for a port switched off by a flag; using it says which flag switches it on."""

    def __init__(self, label: str, port: str, flag: str):
        self._message = f"{label}: connector {port} exists only with {flag}=True"

    def __getattr__(self, key):
        raise ConnectError(self._message)

    def __repr__(self):
        return f"<disabled port: {self._message}>"


def decl_value(label: str, key: str, value) -> float:
    """A constant input default (a Signal is handled by the caller)."""
    return finite_number(value, f"{label}: {key} (a number or a signal from mechnet.components.signals)")
