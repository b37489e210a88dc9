"""A component's constructor signature and docstring, generated from its declarations.

Why: `Component.__init__` takes `(name, **kwargs)` and pops what the
declarations allow, so `help()`, `inspect.signature` and IDEs would show no
parameter at all. The declarations already hold each keyword's default, unit,
doc and check; this module renders them. `Component.__init_subclass__` calls
`signature` and `docstring` for every concrete component, and the unknown-
argument message lists `keyword_names`, so the three cannot drift apart.
"""
from __future__ import annotations

import inspect
import types

import numpy as np

from .declarations import any_finite, direction, Flag, Input, nonnegative, nonzero, Param, Port, positive, Variable

KEYWORD = inspect.Parameter.KEYWORD_ONLY
VARIADIC = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
CHECKS = {positive: "must be > 0", nonnegative: "must be >= 0", nonzero: "must be non-zero", any_finite: "",
          direction: "must not be the zero vector"}


def check_text(check) -> str:
    """'must be > 0' for `positive`; other checks describe themselves by their docstring's first line."""
    if check in CHECKS:
        return CHECKS[check]
    own = getattr(check, "__doc__", None) if isinstance(check, (types.FunctionType, types.MethodType)) else None
    doc = inspect.cleandoc(own) if own else ""
    return doc.splitlines()[0].rstrip(".") if doc else f"checked by {getattr(check, '__name__', type(check).__name__)}"


def shape_text(shape) -> str:
    """'' for a scalar, '3-vector' or '3x3 matrix' otherwise."""
    if shape == 1:
        return ""
    return f"{shape}-vector" if isinstance(shape, int) else "x".join(map(str, shape)) + " matrix"


def plain(value):
    """A default as the user would type it: numpy arrays become (nested) lists."""
    return value.tolist() if isinstance(value, np.ndarray) else value


def declared_default(decl):
    """A Param's or Flag's default for a signature; a Param without one is required (no default)."""
    return inspect.Parameter.empty if decl.default is None else plain(decl.default)


def connector_label(connector_type) -> str:
    """'rotational.Flange' for library connectors, 'module.Class' for user-defined ones."""
    parts = connector_type.__module__.split(".")
    domain = parts[-2] if len(parts) >= 2 and parts[0] == "mechnet" else parts[-1]
    return f"{domain}.{connector_type.__name__}"


def declared_keywords(cls) -> list[inspect.Parameter]:
    """The keywords `Component.__init__` pops, in its order: flags and parameters, inputs, then
    `<var>_start`, `<var>_guess`, `<var>_nominal` of every variable declared on the component itself
    (connector variables take none). A parameter without default is required."""
    decls = cls._declarations
    out = [inspect.Parameter(k, KEYWORD, default=declared_default(d))
           for k, d in decls.items() if isinstance(d, (Param, Flag))]
    out += [inspect.Parameter(k, KEYWORD, default=d.default) for k, d in decls.items() if isinstance(d, Input)]
    for key, decl in decls.items():
        if isinstance(decl, Variable):
            out += [inspect.Parameter(f"{key}_start", KEYWORD, default=None),
                    inspect.Parameter(f"{key}_guess", KEYWORD, default=None),
                    inspect.Parameter(f"{key}_nominal", KEYWORD, default=decl.nominal)]
    return out


def _own_init_parameters(cls) -> list[inspect.Parameter]:
    """The parameters of the `__init__` the class runs, without `self` (a subclass may add some before
    `**kwargs`, as WorldForce adds `force` and `resolve_in`)."""
    try:
        sig = inspect.signature(cls.__init__, eval_str=True)
    except (NameError, TypeError):               # an annotation that names something not importable here
        sig = inspect.signature(cls.__init__)
    # `name` defaults to None in the code only so that leaving it out is a ParameterError saying so (not
    # Python's missing-argument TypeError); to a user it is required, and the signature says that
    return [p.replace(default=inspect.Parameter.empty, annotation=p.annotation if p.annotation is p.empty else str)
            if p.name == "name" and p.default is None else p for p in list(sig.parameters.values())[1:]]


def signature(cls) -> inspect.Signature:
    """`(name, *, <declared keywords>)`, behind whatever the class's own `__init__` takes explicitly."""
    own = _own_init_parameters(cls)
    explicit = [p for p in own if p.kind != inspect.Parameter.VAR_KEYWORD]
    if len(explicit) == len(own):                # no **kwargs: the declared keywords cannot reach Component
        return inspect.Signature(explicit)
    taken = {p.name for p in explicit}
    return inspect.Signature(explicit + [p for p in declared_keywords(cls) if p.name not in taken])


def keyword_names(cls) -> list[str]:
    """Every keyword the constructor accepts besides `name`, for the unknown-argument message."""
    return [p.name for p in inspect.signature(cls).parameters.values() if p.name != "name" and p.kind not in VARIADIC]


def extra_arguments(cls) -> list[inspect.Parameter]:
    """Arguments a subclass's `__init__` takes itself (not declared); `_argument_docs` describes them."""
    return [p for p in _own_init_parameters(cls) if p.name != "name" and p.kind not in VARIADIC]


def default_text(default) -> str:
    """'required' for a keyword without default, else its value as the user would type it."""
    return "required" if default is inspect.Parameter.empty else repr(plain(default))


def argument_rows(cls) -> list[tuple[str, str, object, str, str, str]]:
    """(group, keyword, default, unit, shape, description) of every argument a user sets; group is
    "Parameters" (the class's own explicit arguments and its Params), "Flags" or "Inputs"; a required
    argument's default is `inspect.Parameter.empty`; the description ends with the check ("must be > 0").
    Shared by the docstring and docs/components.md, so both say the same."""
    docs = getattr(cls, "_argument_docs", {})          # {keyword: (unit, description)}
    rows = []
    for p in extra_arguments(cls):
        unit, doc = docs.get(p.name, ("", ""))
        rows.append(("Parameters", p.name, p.default, unit, "", doc))
    for key, decl in cls._declarations.items():
        if isinstance(decl, Param):
            doc = "; ".join(t for t in (decl.doc, check_text(decl.check)) if t)
            rows.append(("Parameters", key, declared_default(decl), decl.unit, shape_text(decl.shape), doc))
        elif isinstance(decl, Flag):
            switched = [k for k, d in cls._declarations.items() if isinstance(d, Port) and d.enabled_by == key]
            doc = decl.doc + (f"; switches on {', '.join(switched)}" if switched else "")
            rows.append(("Flags", key, decl.default, "", "", doc))
        elif isinstance(decl, Input):
            rows.append(("Inputs", key, decl.default, decl.unit, shape_text(decl.shape), decl.doc))
    return rows


def connector_rows(cls) -> list[tuple[str, str, str, str]]:
    """(name, connector type, description, condition) of every port; condition is '' or 'only with flag=True'."""
    return [(key, connector_label(decl.connector_type), decl.doc,
             f"only with {decl.enabled_by}=True" if decl.enabled_by else "")
            for key, decl in cls._declarations.items() if isinstance(decl, Port)]


def variable_rows(cls) -> list[tuple[str, str, str, str]]:
    """(name, unit, kind, description) of every variable declared on the component itself."""
    return [(key, decl.unit, ", ".join(t for t in (decl.kind, shape_text(decl.shape)) if t), decl.doc)
            for key, decl in cls._declarations.items() if isinstance(decl, Variable)]


VARIABLE_KEYWORDS = ("Each variable `v` above also takes the keywords `v_start=` (a fixed start value), "
                     "`v_guess=` (a Newton guess) and `v_nominal=` (its typical magnitude, which scales "
                     "the tolerance).")
INPUTS = ("An input takes a number or a signal (mechnet.components.signals); `simulate(inputs=...)` "
          "can also set it at run time.")
TUNABLE = ("A scalar parameter given as `mechnet.tunable(value)` stays a symbol (for sweeps, optimisation "
           "and export) instead of being folded into the equations.")


def _head(key, unit, shape, default) -> str:
    """'J : kg*m^2, required' or 'n : 3-vector, default [0.0, 0.0, 1.0]' (unit "1" left out)."""
    value = "required" if default is inspect.Parameter.empty else f"default {default_text(default)}"
    return f"{key} : " + ", ".join(t for t in (unit if unit != "1" else "", shape, value) if t)


def _section(title: str, items: list[tuple[str, str]], note: str = "") -> str:
    lines = [title, "-" * len(title)]
    for head, doc in items:
        lines += [head] + ([f"    {doc}"] if doc else [])
    return "\n".join(lines) + (f"\n\n{note}" if note else "")


def docstring(cls) -> str:
    """The class's own docstring, then numpydoc-style sections from its declarations (for help() and IDEs)."""
    parts = [cls._own_doc]
    rows = argument_rows(cls)
    for group in ("Parameters", "Flags", "Inputs"):
        items = [(_head(key, unit, shape, default), doc) for g, key, default, unit, shape, doc in rows if g == group]
        if group == "Parameters":
            items.insert(0, ("name : str", "the component's name, the first part of its variables' dotted names"))
            tunable = any(isinstance(d, Param) and d.shape == 1 for d in cls._declarations.values())
            parts.append(_section(group, items, TUNABLE if tunable else ""))
        elif items:
            parts.append(_section(group, items, INPUTS if group == "Inputs" else ""))
    connectors = connector_rows(cls)
    if connectors:
        parts.append(_section("Connectors", [(f"{key} : {', '.join(t for t in (label, only) if t)}", doc)
                                             for key, label, doc, only in connectors]))
    variables = variable_rows(cls)
    if variables:
        parts.append(_section("Variables", [(f"{key} : {unit}, {kind}", doc) for key, unit, kind, doc in variables],
                              VARIABLE_KEYWORDS))
    return "\n\n".join(p for p in parts if p)
