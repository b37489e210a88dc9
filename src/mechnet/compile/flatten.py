"""Flatten: a Model becomes one list of scalar variables and residual equations.

Variables get dotted names (`subsystem.component.connector.var[i]`); the
connection sets are the connected components of the connector graph: across
variables are equal, through variables sum to zero (so an unconnected flow is
zero). Derivative symbols used by `der()` become variables of their own.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca

from ..core.declarations import Across, Impulse, Input, Output, State, Through
from ..core.equation import derivative_parent, time
from ..core.errors import StructureError
from ..core.model import Model
from ..core.requirements import compiled
from .artifacts import FlatEquation, FlatMode, FlatSystem, FlatVariable, Parameter, ZeroCrossing
from .connections import connection_equations
from .spanning_tree import build_tree
from ..components.multibody.interfaces import Frame


@dataclass(frozen=True)
class FlattenOptions:
    """Nothing to choose yet; kept so every stage has its own options object."""


def _kind(decl) -> str:
    if isinstance(decl, State):
        return "state"
    if isinstance(decl, Input):
        return "input"
    if isinstance(decl, Output):
        return "output"
    if isinstance(decl, Across):
        return "across"
    if isinstance(decl, Through):
        return "through"
    return "algebraic"


def flatten(model: Model, options: FlattenOptions = FlattenOptions()) -> FlatSystem:
    variables: list[FlatVariable] = []
    by_hash: dict[int, int] = {}
    parameters: list[Parameter] = []
    equations: list[FlatEquation] = []
    effects: dict[str, int] = {}
    time_events: list[tuple[float, str]] = []
    folded: list[str] = []
    modes: list[FlatMode] = []

    def add_variable(var: FlatVariable):
        by_hash[var.symbol.element_hash()] = len(variables)
        variables.append(var)

    components = model.components()
    graph = model.connection_graph()
    tree = build_tree(components, graph)          # multibody frames: expressions along the spanning tree
    replaced = tree.replaced if tree is not None else {}
    for comp in components:
        ctype = type(comp).__name__
        effects[ctype] = effects.get(ctype, 0) + 1
        time_events.extend(comp.time_events())
        for info in comp.variables():
            names = info.declaration.scalar_names(f"{comp.path}.{info.local_name.rsplit('.', 1)[0]}"
                                                  if "." in info.local_name else comp.path)
            scalars = ca.vertsplit(info.symbol)
            for i, name in enumerate(names):
                if scalars[i].element_hash() in replaced:
                    continue                      # a frame quantity: an observed expression of the tree
                add_variable(FlatVariable(
                    name=name, symbol=scalars[i],
                    kind="algebraic" if info.driven else _kind(info.declaration),
                    unit=info.declaration.unit,
                    start=None if info.start is None else float(info.start[i]),
                    guess=None if info.guess is None else float(info.guess[i]),
                    default_start=float(getattr(info.declaration, "start", 0.0) or 0.0),
                    nominal=float(info.nominal[i]), priority=info.declaration.priority,
                    origin=comp.path, component_type=ctype,
                    input_default=comp.input_defaults.get(info.local_name, 0.0)))
        for key, (sym, value) in comp.tunable.items():
            decl = type(comp)._declarations[key]
            parameters.append(Parameter(f"{comp.path}.{key}", sym, value, decl.unit, decl,
                                        f"{comp.path} ({ctype})"))
        modes.extend(FlatMode(f"{comp.path}.{key}", sym, start, isinstance(type(comp)._declarations[key], Impulse),
                              getattr(type(comp)._declarations[key], "values", None))
                     for key, (sym, start) in comp.modes_in_use().items())
        for key in comp.parameter_names():
            if key not in comp.tunable:
                folded.append(f"{comp.path}.{key}")

    whens = []
    for comp in components:
        label = f"{comp.path} ({type(comp).__name__})"
        try:
            produced = comp.events() or []
        except StructureError as exc:                  # a When refused where it was written: name the component
            raise StructureError(f"{label}, events(): {exc}") from None
        if not isinstance(produced, (list, tuple)):
            raise StructureError(f"{label}: events() must return a list of When(...), got {produced!r}")
        for k, when in enumerate(produced):
            if not hasattr(when, "condition"):
                raise StructureError(f"{label}, event {k + 1}: {when!r} is not a When(...)")
            whens.append((comp, k, when, label))
        for number, element, residual, doc, smooth, regular in comp.residuals():
            suffix = f"[{element}]" if element is not None else ""
            equations.append(FlatEquation(residual, comp.path, f"{label}, equation {number}{suffix}", doc,
                                          smoothness=smooth, regular=regular))

    if tree is not None:
        _substitute_frames(equations, tree)
        graph = graph.subgraph([c for c in graph.nodes if not isinstance(c, Frame)])
    equations.extend(connection_equations(graph))
    if tree is not None:
        for var in tree.variables:
            add_variable(var)
        equations.extend(tree.equations)

    # derivative symbols become variables; anything else unknown is a user error
    param_hashes = {p.symbol.element_hash() for p in parameters}
    der_of: dict[int, tuple[int, float]] = {}
    mode_at = {m.symbol.element_hash(): k for k, m in enumerate(modes)}
    skip = param_hashes | set(mode_at) | {time.element_hash()}
    if tree is not None:
        skip |= {s.element_hash() for s in tree.intermediates[0]}

    def ensure(symbol, eq) -> int:
        h = symbol.element_hash()
        if h in by_hash:
            return by_hash[h]
        parent = derivative_parent(symbol)
        if parent is None:
            raise StructureError(f"{eq.label} uses the symbol {symbol.name()!r}, which no component of "
                                 f"model {model.name!r} declares (was a component left out of model.add()?)")
        base = variables[ensure(parent, eq)]
        add_variable(FlatVariable(name=f"der({base.name})", symbol=symbol, kind="derivative",
                                  unit=f"({base.unit})/s", nominal=base.nominal, origin=base.origin,
                                  component_type=base.component_type))
        der_of[by_hash[parent.element_hash()]] = (by_hash[h], 1.0)
        return by_hash[h]

    for eq in equations:
        for s in ca.symvar(eq.residual):
            if s.element_hash() not in skip:
                ensure(s, eq)

    zero_crossings = []
    for comp, k, when, label in whens:
        g = _frames_in(ca.SX(when.condition), tree)
        if g.numel() != 1:
            raise StructureError(f"{label}, event {k + 1}: the When condition must be a scalar expression")
        for s in ca.symvar(g):
            if s.element_hash() not in by_hash and s.element_hash() not in skip:
                raise StructureError(f"{label}, event {k + 1}: the condition uses {s.name()!r}, which is "
                                     f"not a variable of the model")
        def scalar_value(value, what):
            value = _frames_in(ca.SX(value), tree)
            if value.numel() != 1:
                raise StructureError(f"{label}, event {k + 1}: {what} must be a scalar")
            for s in ca.symvar(value):
                if s.element_hash() not in by_hash and s.element_hash() not in skip:
                    raise StructureError(f"{label}, event {k + 1}: {what} uses {s.name()!r}, which is not a "
                                         f"variable of the model")
            return value

        def mode_of(target, what, impulse):
            target = ca.SX(target)
            h = target.element_hash() if target.is_scalar() and target.is_symbolic() else None
            if h not in mode_at or modes[mode_at[h]].impulse != impulse:
                raise StructureError(f"{label}, event {k + 1}: {what} must be {'an Impulse' if impulse else 'a Mode'}"
                                     f" of the component (got {target})")
            return mode_at[h]

        jumps = tuple((mode_of(imp, "a jump's key", True), scalar_value(v, "a jump's velocity"),
                       scalar_value(goal, "a jump's target")) for imp, (v, goal) in (when.jump or {}).items())
        rest = None if when.rest is None else tuple(
            (mode_of(target, "a rest target", False), scalar_value(value, f"the rest value of {target}"))
            for target, value in when.rest.items())
        resets, mode_resets = [], []
        for target, value in (when.reset or {}).items():
            target = ca.SX(target)
            h = target.element_hash() if target.is_scalar() and target.is_symbolic() else None
            if h not in by_hash and h not in mode_at:
                raise StructureError(f"{label}, event {k + 1}: reset targets must be variables or modes of the "
                                     f"model (got {target})")
            value = _frames_in(ca.SX(value), tree)
            if value.numel() != 1:
                raise StructureError(f"{label}, event {k + 1}: the new value of {target} must be a scalar")
            for s in ca.symvar(value):
                if s.element_hash() not in by_hash and s.element_hash() not in skip:
                    raise StructureError(f"{label}, event {k + 1}: the new value of {target} uses {s.name()!r}, "
                                         f"which is not a variable of the model")
            if h in mode_at:
                mode_resets.append((mode_at[h], value))
            else:
                resets.append((by_hash[h], value))
        try:
            direction = when.sign()
        except ValueError as exc:
            raise StructureError(f"{label}, event {k + 1}: {exc}") from None
        zero_crossings.append(ZeroCrossing(g, tuple(resets), direction,
                                           f"{label}, event {k + 1}" + (f" — {when.doc}" if when.doc else ""),
                                           tuple(mode_resets), jumps, rest, bool(when.at_start),
                                           bool(when.release)))

    switched = tuple((comp.path, type(comp).__name__, comp.form() if hasattr(comp, "form") else "switched")
                     for comp in components if comp.modes)
    requirements = tuple((_frames_in(ca.SX(expr), tree), text) for comp in components
                         for expr, text in comp.start_requirements())
    releases = []
    for comp in components:
        for mode, during, stays, after in comp.jump_releases():
            h = ca.SX(mode).element_hash()
            if h not in mode_at:
                raise StructureError(f"{comp.path} ({type(comp).__name__}): jump_releases() names {mode}, which "
                                     f"is not one of its modes in use")
            releases.append((mode_at[h], float(during), _frames_in(ca.SX(stays), tree),
                             _frames_in(ca.SX(after), tree)))
    return FlatSystem(model.name, tuple(variables), tuple(equations), tuple(parameters), der_of, time,
                      tuple(sorted(effects.items())), time_events=tuple(sorted(time_events)),
                      folded_parameters=tuple(folded), zero_crossings=tuple(zero_crossings),
                      multibody=tree, observed_only=tuple(tree.observed) if tree is not None else (),
                      intermediates=tree.intermediates if tree is not None else ((), ()), modes=tuple(modes),
                      unit_quaternions=_unit_quaternions(components), switched=switched,
                      releases=tuple(releases), requirements=requirements,
                      parameter_requirements=tuple(entry for comp in components
                                                   for entry in compiled(comp, comp.path)))


def _unit_quaternions(components) -> tuple:
    """(what, names) of every quaternion a component declares (`quaternions`: the spherical and free
    joints' orientations)."""
    return tuple((f"{c.path} ({type(c).__name__}): |{key}| − 1", tuple(f"{c.path}.{key}[{i}]" for i in range(4)))
                 for c in components for key in getattr(c, "quaternions", ()))


def _frames_in(expr, tree):
    """An event condition or reset value with frame quantities replaced by the tree's expressions."""
    if tree is None:
        return expr
    holder = [FlatEquation(expr, "", "")]
    _substitute_frames(holder, tree)
    return holder[0].residual


def _substitute_frames(equations: list, tree) -> None:
    """Frame positions and orientations in component equations become tree expressions, and `der` of
    them the tree's velocities (so a damper or a velocity sensor needs no differentiation)."""
    def value_of(s):
        h = s.element_hash()
        if h in tree.replaced:
            return tree.replaced[h]
        parent = derivative_parent(s)
        if parent is not None and parent.element_hash() in tree.rates:
            return tree.rates[parent.element_hash()]
        return None

    olds, news, touched, seen = [], [], [], set()
    for k, eq in enumerate(equations):
        hit = False
        for s in ca.symvar(eq.residual):
            h = s.element_hash()
            if h in seen:
                hit = True
                continue
            v = value_of(s)
            if v is not None:
                seen.add(h)
                olds.append(s)
                news.append(v)
                hit = True
        if hit:
            touched.append(k)
    if not touched:
        return
    out = ca.substitute(ca.vertcat(*[equations[k].residual for k in touched]), ca.vertcat(*olds), ca.vertcat(*news))
    for j, k in enumerate(touched):
        equations[k] = replace(equations[k], residual=out[j])
