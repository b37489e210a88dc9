"""An optimal control problem on a compiled model, described apart from how it is transcribed.

Expressions are CasADi expressions of placeholders: `prob.var("cart.s")` stands for a named quantity
along the path (any dotted name of the model: a state, an algebraic, an input, an observed frame
position or cut force, a tunable parameter), `prob.at_start(e)`/`prob.at_end(e)` for a path
expression's value at either end, `prob.integral(e)` for its integral over the horizon and
`prob.t_final` for the final time. A transcription (`collocation.py`, `shooting.py`) evaluates the
placeholders on its own grid, so the same problem is solved by either method (as in rockit).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..core.declarations import finite_number, not_a_number
from ..core.errors import OcpError
from ..simulate.integrator import _resolve_params
from ..simulate.result import unknown_name


def _bound(value, default, what) -> float:
    """A bound: a number or ±inf (None: no bound)."""
    if value is None:
        return default
    if not_a_number(value):
        raise OcpError(f"{what} = {value!r} is not a number")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise OcpError(f"{what} = {value!r} is not a number") from None
    if math.isnan(number):
        raise OcpError(f"{what} is NaN")
    return number


# The largest transcription posed: about 3 kB of memory a variable while the NLP is built (a double integrator
# at N = 20000: 180 k variables, 0.5 GB and 150 s), so 10**6 is 3 GB and many minutes; beyond it a mistyped N
# would run for an hour into a MemoryError
MAX_VARIABLES = 10 ** 6


def _mapping(value, what) -> dict:
    """{dotted name: value} as given to `start=` or `params=` (None: none), or an OcpError naming the argument."""
    if value is None:
        return {}
    if not hasattr(value, "items"):
        raise OcpError(f"Problem({what}=...) takes a mapping {{'dotted.name': value}}, got {type(value).__name__} "
                       f"{value!r:.60}")
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise OcpError(f"Problem({what}=...): keys are dotted names such as 'mass.s', got {bad[0]!r}")
    return dict(value)


@dataclass(frozen=True)
class Constraint:
    expr: ca.SX            # scalar
    lower: float
    upper: float
    label: str             # what the user wrote, for reports


def _constants(expr) -> list:
    """The numbers written into an expression (a NaN bound in `x <= nan` is one)."""
    f = ca.Function("f", ca.symvar(expr), [expr])
    return [f.instruction_constant(k) for k in range(f.n_instructions()) if f.instruction_id(k) == ca.OP_CONST]


class Problem:
    """`Problem(cm, t_final=T)` or `t_final=(lower, upper)` for a free final time. The controls are the
    model's inputs; `start={name: value}` adds fixed start values to the model's own (as in simulate)."""

    def __init__(self, cm, t_final, *, start: dict | None = None, params: dict | None = None):
        from ..compile.compiled import CompiledModel
        if not isinstance(cm, CompiledModel):
            raise OcpError(f"Problem takes a compiled model (Model.compile()), got {type(cm).__name__}")
        # friction with true stiction switches modes at events an optimiser cannot differentiate
        # through: the problem is posed on the smooth (regularised) forms, and says which it smoothed
        cm, self.smoothed = cm.smoothed()
        switched = [f"{path} ({kind})" for path, kind, form in cm.stages["flat"].switched if form == "switched"]
        if switched:
            raise OcpError(f"model {cm.name!r}: {', '.join(switched)} switch modes at events, which an optimiser "
                           f"cannot differentiate through; friction is posed in its smooth form when the compiled "
                           f"model still has its scene (not after crossing a process boundary), and a stop or a "
                           f"rigid contact needs its compliant form (tr.ElastoGap) in an optimal control problem")
        self.cm, self.dae = cm, cm.dae
        if not self.dae.u_names:
            raise OcpError(f"model {cm.name!r} has no inputs to optimise: add an input component such as "
                           f"rot.Torque(name='motor') (its input 'motor.tau' becomes a control)")
        self.t_final = ca.SX.sym("t_final")
        self.time = ca.SX.sym("t")
        if isinstance(t_final, (tuple, list)):
            if len(t_final) != 2:
                raise OcpError(f"t_final = {t_final!r}: give a time, or (lower, upper) bounds of a free final time")
            lo, hi = (finite_number(v, "t_final bound", OcpError) for v in t_final)
            if not 0 < lo <= hi:
                raise OcpError(f"t_final bounds ({lo:g}, {hi:g}) must satisfy 0 < lower <= upper")
            self.t_bounds = (lo, hi)
        else:
            if t_final is None:
                raise OcpError("a free final time needs bounds: t_final=(lower, upper)")
            value = finite_number(t_final, "t_final (s)", OcpError)
            if value <= 0:
                raise OcpError(f"t_final = {value:g} s must be > 0")
            self.t_bounds = (value, value)
        self.start = dict(self.dae.starts)
        for name, value in _mapping(start, "start").items():
            if name not in self.dae.observed_names:
                raise unknown_name(name, self.dae.observed_names, "start value for")
            self.start[name] = finite_number(value, f"start value {name}", OcpError)
        self.p_value = np.array(self.dae.p_value, dtype=float)
        for name, value in _mapping(params, "params").items():
            self.p_value[self._parameter(name)] = finite_number(value, f"params[{name!r}]", OcpError)
        if params:      # each value's check and the requirements between parameters, as in simulate
            self.p_value = _resolve_params(self.dae, dict(params), "Problem")
        self.free_params: dict[str, tuple[float, float]] = {}
        self._vars: dict[str, ca.SX] = {}
        self._boundary: dict[str, tuple[str, ca.SX]] = {}      # placeholder -> (start|end|integral, path expr)
        self._boundary_syms: dict[str, ca.SX] = {}
        self.bounds_of: dict[str, tuple[float, float]] = {}
        self.rate_bounds_of: dict[str, tuple[float, float]] = {}
        self.path: list[Constraint] = []
        self.point: list[Constraint] = []
        self.objective = None

    @property
    def free_time(self) -> bool:
        return self.t_bounds[0] < self.t_bounds[1]

    # ---- placeholders ----------------------------------------------------------------------------

    def var(self, name: str) -> ca.SX:
        """The named quantity along the path."""
        if not isinstance(name, str) or name not in self.dae.observed_names:
            raise unknown_name(str(name), self.dae.observed_names)
        if name not in self._vars:
            self._vars[name] = ca.SX.sym(name)
        return self._vars[name]

    def at_start(self, expr) -> ca.SX:
        return self._placeholder("start", expr)

    def at_end(self, expr) -> ca.SX:
        return self._placeholder("end", expr)

    def integral(self, expr) -> ca.SX:
        """∫ expr dt over the horizon (quadrature of the transcription's own order)."""
        return self._placeholder("integral", expr)

    def _placeholder(self, kind, expr):
        expr = self._scalar(expr, f"{kind}(...)")
        self._known(expr, f"{kind}(...)")
        if ca.depends_on(expr, self._boundary_vector()):
            raise OcpError(f"{kind}(...) takes an expression along the path (of prob.var(...) and prob.time), "
                           f"not one holding at_start/at_end/integral")
        name = f"{kind}_{len(self._boundary)}"
        sym = ca.SX.sym(f"{kind}({expr})")             # as reports show it
        self._boundary[name] = (kind, expr)
        self._boundary_syms[name] = sym
        return sym

    # ---- what is asked -----------------------------------------------------------------------------

    def bounds(self, name: str, lower=-math.inf, upper=math.inf) -> None:
        """lower <= name <= upper along the whole path (an input, a state, any named quantity), or for a
        tunable parameter freed by `free_parameter`."""
        self.var(name)
        lo, hi = self._pair(lower, upper, f"bounds({name!r})")
        if name in self.dae.p_names and name not in self.free_params:
            value = self.p_value[self.dae.p_names.index(name)]
            if not lo <= value <= hi:
                raise OcpError(f"bounds({name!r}, {lo:g}, {hi:g}): the parameter is fixed at {value:g}; free it with "
                               f"prob.free_parameter({name!r}, ...) to optimise it")
        if name in self.start and not lo <= self.start[name] <= hi:
            raise OcpError(f"bounds({name!r}, {lo:g}, {hi:g}) cannot hold at t = 0, where the start value fixes "
                           f"{name} = {self.start[name]:g}")
        self.bounds_of[name] = lo, hi

    def rate_bounds(self, name: str, lower=-math.inf, upper=math.inf) -> None:
        """lower <= d(input)/dt <= upper (per second) between control nodes: a motor's slew limit."""
        if name not in self.dae.u_names:
            raise unknown_name(str(name), self.dae.u_names, "input (a control) for rate_bounds")
        self.rate_bounds_of[name] = self._pair(lower, upper, f"rate_bounds({name!r})")

    def free_parameter(self, name: str, lower=-math.inf, upper=math.inf) -> None:
        """Make a tunable parameter (`mn.tunable`) a decision variable within [lower, upper]."""
        self._parameter(name)
        self.free_params[name] = self._pair(lower, upper, f"free_parameter({name!r})")

    def subject_to(self, constraint, label: str | None = None) -> None:
        """`a <= b`, `a >= b` or `a == b` (elementwise for vectors): a path constraint when it holds
        prob.var(...) or prob.time, else a boundary constraint (at_start, at_end, integral, t_final)."""
        if isinstance(constraint, (bool, np.bool_)):
            raise OcpError(f"subject_to({constraint!r}): the comparison was decided in Python (no prob.var(...) "
                           f"in it); write it with CasADi expressions")
        if not isinstance(constraint, (ca.SX, ca.DM)):
            raise OcpError(f"subject_to takes a comparison of the problem's expressions (prob.var, at_end, ...; "
                           f"CasADi SX) such as prob.var('x') <= 1, got {type(constraint).__name__}")
        if label is not None and not isinstance(label, str):
            raise OcpError(f"subject_to(..., label={label!r}): the label is the text reports show, a string")
        constraint = ca.SX(constraint)
        self._known(constraint, "subject_to(...)")
        for k in range(constraint.numel()):
            item = constraint[k]
            text = label or str(item)
            if not all(np.isfinite(_constants(item))):
                raise OcpError(f"subject_to({text}): holds a NaN or infinite number")
            if item.is_op(ca.OP_LE) or item.is_op(ca.OP_LT):
                expr, lo, hi = item.dep(0) - item.dep(1), -math.inf, 0.0
            elif item.is_op(ca.OP_EQ):
                expr, lo, hi = item.dep(0) - item.dep(1), 0.0, 0.0
            else:
                raise OcpError(f"subject_to({text}): not a comparison; write a <= b, a >= b or a == b")
            self._classify(expr, lo, hi, text)

    def minimize(self, objective) -> None:
        """The objective: a scalar of at_start/at_end/integral placeholders, t_final and free parameters
        (Mayer and Lagrange terms)."""
        objective = self._scalar(objective, "minimize(...)")
        if not all(np.isfinite(_constants(objective))):
            raise OcpError(f"minimize({objective}): holds a NaN or infinite number")
        self._known(objective, "minimize(...)")
        if ca.depends_on(objective, self._path_vector()):
            raise OcpError("minimize(...): the objective holds a path quantity (prob.var or prob.time); wrap it "
                           "in prob.integral(...) or prob.at_end(...)")
        self.objective = objective

    def end_targets(self) -> dict:
        """{state: value} for each terminal equality `at_end(var(state)) == value` (affine in it): what
        the "interpolate" guess runs the states towards."""
        targets = {}
        by_sym = {id(sym): name for name, sym in self._boundary_syms.items()}
        for c in self.point:
            if c.lower != c.upper:
                continue
            syms = [sym for sym in self._boundary_syms.values() if ca.depends_on(c.expr, sym)]
            if len(syms) != 1 or ca.depends_on(c.expr, self.t_final):
                continue
            kind, path = self._boundary[by_sym[id(syms[0])]]
            name = next((n for n, v in self._vars.items() if ca.is_equal(path, v)), None)
            if kind != "end" or name not in self.dae.x_names or not ca.is_linear(c.expr, syms[0]):
                continue
            f = ca.Function("affine", [syms[0]], [c.expr])
            offset, slope = float(f(0.0)), float(f(1.0)) - float(f(0.0))
            if slope != 0.0:
                targets[name] = c.lower / slope - offset / slope
        return targets

    # ---- helpers -------------------------------------------------------------------------------

    def _classify(self, expr, lo, hi, text):
        if ca.depends_on(expr, self._path_vector()):
            if ca.depends_on(expr, self._boundary_vector()):
                raise OcpError(f"subject_to({text}): mixes path quantities with at_start/at_end/integral")
            self.path.append(Constraint(expr, lo, hi, text))
        else:
            self.point.append(Constraint(expr, lo, hi, text))

    def _scalar(self, expr, what):
        try:
            expr = ca.SX(expr)
        except (NotImplementedError, TypeError, RuntimeError):
            raise OcpError(f"{what}: {expr!r:.60} is not a CasADi expression") from None
        if expr.numel() != 1:
            raise OcpError(f"{what}: the expression must be a scalar, got shape {expr.shape}")
        return expr

    def _symbols(self) -> list:
        """Every symbol the problem made: t_final, time, the path quantities, the boundary placeholders."""
        return [self.t_final, self.time, *self._vars.values(), *self._boundary_syms.values()]

    def _known(self, expr, what) -> None:
        """Refuse a CasADi symbol the problem did not make (`ca.SX.sym("x")`): no transcription can give it
        a value, and IPOPT would fail on it later with CasADi's "free variables" message."""
        known = self._symbols()
        foreign = [v for v in ca.symvar(ca.SX(expr)) if not any(ca.is_equal(v, k) for k in known)]
        if foreign:
            names = ", ".join(str(v) for v in foreign[:3])
            raise OcpError(f"{what}: {names} is not one of the problem's quantities; write expressions of "
                           f"prob.var('name'), prob.time, prob.t_final and at_start/at_end/integral")

    def _pair(self, lower, upper, what):
        lo, hi = _bound(lower, -math.inf, f"{what} lower"), _bound(upper, math.inf, f"{what} upper")
        if lo > hi:
            raise OcpError(f"{what}: lower bound {lo:g} is above upper bound {hi:g}")
        return lo, hi

    def _parameter(self, name):
        if not isinstance(name, str):
            raise OcpError(f"parameter names are dotted strings such as 'spring.c', got {name!r}")
        if name not in self.dae.p_names:
            folded = name in self.dae.info.get("folded_parameters", ())
            if folded:
                raise OcpError(f"parameter {name!r} was folded at compile time; declare it mn.tunable(...) to "
                               f"change or optimise it")
            raise unknown_name(name, self.dae.p_names, "tunable parameter")
        return self.dae.p_names.index(name)

    def _path_vector(self):
        """What varies along the path: time and every named quantity but the tunable parameters (constant
        over the horizon, so they may appear in the objective and boundary constraints too)."""
        return ca.vertcat(self.time, *[v for n, v in self._vars.items() if n not in self.dae.p_names])

    def parameter_vars(self) -> list[str]:
        """The tunable parameters named by prob.var(...), in the order the boundary function takes them."""
        return [n for n in self._vars if n in self.dae.p_names]

    def _boundary_vector(self):
        return ca.vertcat(*self._boundary_syms.values()) if self._boundary_syms else ca.SX(0, 1)

    # ---- pickling ------------------------------------------------------------------------------

    def __getstate__(self):
        """CasADi's symbols do not pickle one by one, and pickled apart they would lose who is who (the
        `prob.var("x")` in a constraint is the one in the objective). So every expression the problem
        holds is packed into one CasADi Function of the problem's symbols, which pickles, and unpacked by
        calling it on fresh symbols of the same names."""
        state = dict(self.__dict__)
        symbols = self._symbols()
        expressions = ([e for _, e in self._boundary.values()] + [c.expr for c in self.path + self.point]
                       + ([self.objective] if self.objective is not None else []))
        state["_packed"] = (ca.Function("problem", symbols, expressions), [s.name() for s in symbols])
        # the DAE pickles with its compiled model (as a sweep sends it to its workers), not alone
        for key in ("dae", "t_final", "time", "_vars", "_boundary", "_boundary_syms", "path", "point", "objective"):
            del state[key]
        bounds = [[(c.lower, c.upper, c.label) for c in constraints] for constraints in (self.path, self.point)]
        state["_keys"] = (list(self._vars), [(n, kind) for n, (kind, _) in self._boundary.items()], *bounds,
                          self.objective is not None)
        return state

    def __setstate__(self, state):
        (function, names), (var_names, boundary, path, point, has_objective) = state.pop("_packed"), state.pop("_keys")
        self.__dict__.update(state)
        self.dae = self.cm.dae
        symbols = [ca.SX.sym(n) for n in names]
        out = function.call(symbols) if function.n_out() else []
        self.t_final, self.time = symbols[:2]
        self._vars = dict(zip(var_names, symbols[2:2 + len(var_names)]))
        self._boundary_syms = {n: s for (n, _), s in zip(boundary, symbols[2 + len(var_names):])}
        self._boundary = {n: (kind, e) for (n, kind), e in zip(boundary, out)}
        out = out[len(boundary):]
        self.path = [Constraint(e, *rest) for e, rest in zip(out, path)]
        out = out[len(path):]
        self.point = [Constraint(e, *rest) for e, rest in zip(out, point)]
        self.objective = out[len(point)] if has_objective else None

    def solve(self, method, *, guess=None, ipopt: dict | None = None, progress=None, verbose=False):
        """Transcribe with `method` (`Collocation(...)`, `MultipleShooting(...)`) and solve with IPOPT.
        `guess`: a Result of a simulation (with the input to try), a previous Solution (a warm start, at
        any N), "interpolate" (states linear from the start to their terminal equalities) or None (the
        start point held)."""
        from .transcription import Transcription
        if self.objective is None:
            raise OcpError("no objective: call prob.minimize(...) first")
        if not isinstance(method, Transcription):
            raise OcpError(f"solve takes Collocation(...) or MultipleShooting(...), got {type(method).__name__}")
        return method.solve(self, guess=guess, ipopt=ipopt or {}, progress=progress, verbose=verbose)
