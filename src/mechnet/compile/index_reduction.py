"""Reduce: Pantelides' algorithm, symbolic differentiation and dummy-derivative state selection.

Constraints among states (rigid couplings, gears, prescribed motion, loop
closures, user constraints) make the DAE higher-index. Pantelides finds, on
the integer incidence structure, which equations to differentiate and how
often; CasADi differentiates them (total time derivative by the chain rule).
The dummy-derivative method (Mattsson & Söderlind) then turns as many
derivatives into algebraic "dummies" as there are differentiated equations,
level by level: state priority first, then the conditioning of the
constraint Jacobian at the start point. The original constraints stay in the
system, so the dependent coordinates are solved from them and do not drift.
The choice is kept as data (`IndexReport.levels`) so that a simulator can
re-pivot when the chosen block becomes ill-conditioned.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from ..caches import BUILD_LOCK, built
from ..core.errors import StructureError
from ..numeric import NumpyCall, dense, mapped
from .artifacts import FlatEquation, FlatSystem, FlatVariable
from .structure import maximum_matching

_DUMMY_PREFERENCE = {"never": 0, "avoid": 1, "default": 2, "prefer": 3, "always": 4}


@dataclass(frozen=True)
class IndexReductionOptions:
    method: str = "dummy_derivatives"     # "dummy_derivatives", "none", or "baumgarte" (CasADi's, see baumgarte.py)
    rank_tolerance: float = 1e-10
    # method="baumgarte" only: CasADi's dae_reduce_index takes ONE pole, repeated for every order: an
    # equation differentiated n times becomes e⁽ⁿ⁾ + … with the characteristic polynomial (s − pole)ⁿ.
    # Must be < 0 (0 = plain Pantelides without correction).
    baumgarte_pole: float = -10.0


@dataclass(frozen=True)
class SelectionLevel:
    """One level of the dummy-derivative choice: equations, candidate derivatives, the chosen ones."""

    equations: tuple          # equation indices (in the reduced FlatSystem)
    candidates: tuple         # variable indices
    chosen: tuple             # variable indices that became dummy derivatives


@dataclass(frozen=True)
class IndexReport:
    differentiated: tuple     # (equation label, times differentiated)
    index: int                # structural index (max differentiations + 1; 1 or less without constraints)
    dummies: tuple            # names of dummy derivatives
    levels: tuple             # SelectionLevel, highest level first
    states: tuple             # names of the selected states
    factory: object = None    # SelectionFactory: re-choose and rebuild at another point

    def summary(self) -> str:
        if not self.differentiated:
            return "reduce: no constraint among states, nothing differentiated"
        diffs = grouped_differentiations(self.differentiated)
        return (f"reduce: structural index {self.index}; differentiated {diffs}; "
                f"dummy derivatives {', '.join(self.dummies)}")


def grouped_differentiations(differentiated) -> str:
    """'label ×n' items, '; '-separated. A loop's consecutive closure residuals (labels sharing their
    text up to ', closure residual') are listed once, without their common description:
    'pin_c (Revolute), loop 1 (...): closure residual position x (world axes) ×2, closure residual
    position y (world axes) ×2'."""
    groups: list = []                  # (shared head, [(item, original label, n)])
    for label, n in differentiated:
        head, _, item = label.split(" — ")[0].rpartition(", closure residual ")
        item = f"closure residual {item}" if head else item
        if head and groups and groups[-1][0] == head:
            groups[-1][1].append((item, label, n))
        else:
            groups.append((head, [(item, label, n)]))
    return "; ".join(f"{head}: " + ", ".join(f"{item} ×{n}" for item, _, n in members) if len(members) > 1
                     else f"{members[0][1]} ×{members[0][2]}" for head, members in groups)


class _Graph:
    """The integer structure Pantelides works on, growing as it differentiates."""

    def __init__(self, flat: FlatSystem):
        self.kind = [v.kind for v in flat.variables]
        self.der = {i: j for i, (j, _) in flat.der_of.items() if j is not None}
        # states whose rate is a constant (a crank turned by a Speed source): known, like any state
        self.known_rate = {i for i, (j, _) in flat.der_of.items() if j is None}
        self.antider = {j: i for i, j in self.der.items()}
        index = {v.symbol.element_hash(): i for i, v in enumerate(flat.variables)}
        self.inc = [sorted({index[s.element_hash()] for s in ca.symvar(eq.residual)
                            if s.element_hash() in index}) for eq in flat.equations]
        self.hidden = _Hidden(flat, index)
        self.diff = {}            # equation -> its derivative equation
        self.parent = {}          # derivative equation -> the equation it was differentiated from
        self.assign = {}          # variable -> equation matched to it

    def visible(self, v) -> bool:
        return self.kind[v] != "input" and v not in self.der and v not in self.known_rate

    def new_variable(self, of: int) -> int:
        j = len(self.kind)
        self.kind.append("derivative")
        self.der[of] = j
        self.antider[j] = of
        return j

    def differentiate(self, e: int) -> int:
        # what the equation holds through the tree's intermediates (the coordinates and speeds behind a
        # frame's R and r_0) matters once it is differentiated: its derivative holds their rates
        self.inc[e] = sorted(set(self.inc[e]) | self.hidden.behind(e))
        for v in self.inc[e]:
            if self.kind[v] != "input" and v not in self.der and v not in self.known_rate:
                self.new_variable(v)
        k = len(self.inc)
        self.inc.append(sorted(set(self.inc[e]) | {self.der[v] for v in self.inc[e] if v in self.der}))
        self.diff[e] = k
        self.parent[k] = e
        return k

    def _free(self, e):
        for v in self.inc[e]:
            if self.visible(v) and v not in self.assign:
                return v
        return None

    def augment(self, root, coloured_e, coloured_v) -> bool:
        """Pantelides' augmenting-path search, iterative (deep chains would overflow recursion)."""
        coloured_e.add(root)
        free = self._free(root)
        if free is not None:
            self.assign[free] = root
            return True
        stack, via = [(root, iter(self.inc[root]))], []
        while stack:
            e, it = stack[-1]
            for v in it:
                if not self.visible(v) or v in coloured_v:
                    continue
                coloured_v.add(v)
                e2 = self.assign[v]
                coloured_e.add(e2)
                free = self._free(e2)
                if free is not None:
                    self.assign[free] = e2
                    self.assign[v] = e
                    for k in range(len(via) - 1, -1, -1):
                        self.assign[via[k]] = stack[k][0]
                    return True
                stack.append((e2, iter(self.inc[e2])))
                via.append(v)
                break
            else:
                stack.pop()
                if via:
                    via.pop()
        return False

    def pantelides(self, n_equations: int, max_rounds: int):
        if self._perfectly_matched(n_equations):
            return True
        # constraints (equations with no unknown to match) first: while few equations are matched,
        # their augmenting searches stay short (O(N) on a geared chain instead of O(N²))
        order = sorted(range(n_equations), key=lambda e: sum(1 for v in self.inc[e] if self.visible(v)))
        for k in order:
            i = k
            rounds = 0
            while True:
                coloured_e, coloured_v = set(), set()
                if self.augment(i, coloured_e, coloured_v):
                    break
                rounds += 1
                if rounds > max_rounds:
                    self.stuck = sorted(coloured_e)
                    return False
                for v in coloured_v:
                    if v not in self.der:
                        self.new_variable(v)
                for e in coloured_e:
                    self.differentiate(e)
                for v in coloured_v:
                    self.assign[self.der[v]] = self.diff[self.assign[v]]
                i = self.diff[i]
        return True


    def _perfectly_matched(self, n_equations: int) -> bool:
        """Every equation has an unknown of its own (one maximum matching, in C): then Pantelides would
        find an augmenting path for each and differentiate nothing. Why ask first: on a long chain its
        ~7 searches per body each walk O(N) of the matched graph (a 1000-body chain: 70 s)."""
        unknowns = [v for v in range(len(self.kind)) if self.visible(v)]
        if len(unknowns) != n_equations:
            return False
        position = {v: k for k, v in enumerate(unknowns)}
        rows = [[position[v] for v in self.inc[e] if v in position] for e in range(n_equations)]
        matched = maximum_matching(rows, len(unknowns))
        if len(matched) < n_equations:
            return False
        self.assign = {unknowns[k]: e for e, k in matched.items()}
        return True


class _Hidden:
    """The variables an original equation depends on through the tree's intermediates.

    A user's element that holds a frame's orientation R (an intermediate of the joint coordinates)
    depends on those coordinates; Pantelides must see them when it differentiates the element, or the
    derivatives lose every term through R (a point held on a body moved wrongly). Found only for the
    equations Pantelides differentiates: the tree's own equations use thousands of intermediates and
    are differentiated rarely (the intermediates are all state-only, which matching ignores)."""

    def __init__(self, flat: FlatSystem, index: dict):
        self.flat, self.index = flat, index
        syms, _ = flat.intermediates
        self.position = {s.element_hash(): k for k, s in enumerate(syms)}
        self.deps: dict = {}                     # intermediate position -> frozenset of variables

    def behind(self, e: int) -> set:
        if e >= len(self.flat.equations) or not self.position:
            return set()                         # a derivative inherits its parent's (widened) row
        out = set()
        for k in self._resolve(self.flat.equations[e].residual):
            out |= self.deps[k]
        return out

    def _resolve(self, expr) -> list:
        """The positions of the intermediates in expr, each with its `deps` filled in (definitions refer
        only to intermediates before them: filled in increasing order, no recursion)."""
        direct = [self.position[s.element_hash()] for s in ca.symvar(expr) if s.element_hash() in self.position]
        needed, stack = set(), [k for k in direct if k not in self.deps]
        defs = self.flat.intermediates[1]
        while stack:
            k = stack.pop()
            if k in needed:
                continue
            needed.add(k)
            stack.extend(j for j in self._inner(defs[k]) if j not in self.deps and j not in needed)
        for k in sorted(needed):
            deps = set()
            for s in ca.symvar(defs[k]):
                h = s.element_hash()
                if h in self.index:
                    deps.add(self.index[h])
                elif h in self.position:
                    deps |= self.deps[self.position[h]]
            self.deps[k] = frozenset(deps)
        return direct

    def _inner(self, definition) -> list:
        return [self.position[s.element_hash()] for s in ca.symvar(definition) if s.element_hash() in self.position]


def _order(graph: _Graph, e: int) -> int:
    n = 0
    while e in graph.parent:
        e = graph.parent[e]
        n += 1
    return n


def reduce_index(flat: FlatSystem, options: IndexReductionOptions = IndexReductionOptions()
                 ) -> tuple[FlatSystem, IndexReport]:
    graph = _Graph(flat)
    n_eq0 = len(flat.equations)
    if options.method == "none":
        return flat, IndexReport((), 1, (), (), tuple(flat.variables[i].name for i in sorted(flat.der_of)))
    unchanged = (flat, IndexReport((), 1, (), (), tuple(flat.variables[i].name for i in sorted(flat.der_of))))
    if len(flat.unknowns()) != n_eq0:
        return unchanged              # unbalanced: the structure stage names the culprits
    if not graph.pantelides(n_eq0, max_rounds=len(flat.variables) + 2):
        roots = set()
        for e in getattr(graph, "stuck", []):
            while e in graph.parent:
                e = graph.parent[e]
            if e < n_eq0:
                roots.add(e)
        names = "\n".join(f"    {flat.equations[e].describe()}" for e in sorted(roots)[:12])
        raise StructureError(
            f"model {flat.name!r} is structurally singular: these equations cannot all hold however often "
            f"they are differentiated — constraints fighting each other, typically two prescribed motions on "
            f"one body, or a prescribed motion fighting a rigid constraint:\n{names}")
    if not graph.parent:
        return flat, IndexReport((), 1, (), (), tuple(flat.variables[i].name for i in sorted(flat.der_of)))

    variables = list(flat.variables)
    symbols = [v.symbol for v in variables]
    for j in range(len(variables), len(graph.kind)):
        base = variables[graph.antider[j]]
        sym = ca.SX.sym(f"der({base.name})")
        variables.append(FlatVariable(name=f"der({base.name})", symbol=sym, kind="derivative",
                                      unit=f"({base.unit})/s", nominal=base.nominal, priority=base.priority,
                                      origin=base.origin, component_type=base.component_type))
        symbols.append(sym)
    derivative_expr = {}
    for i, j in graph.der.items():
        if i in flat.der_of:
            jj, sign = flat.der_of[i]
            derivative_expr[i] = sign * symbols[jj] if jj is not None else ca.SX(sign)
        else:
            derivative_expr[i] = symbols[j]
    for i, (jj, c) in flat.der_of.items():
        if jj is None:
            derivative_expr[i] = ca.SX(c)

    equations = list(flat.equations)
    where = {s.element_hash(): v for v, s in enumerate(symbols)}
    for k in range(n_eq0, len(graph.inc)):
        parent = graph.parent[k]
        source = equations[parent]
        order = _order(graph, k)
        if order > source.smoothness:
            raise StructureError(
                f"{source.describe()} would have to be differentiated {order} time(s) for index reduction, "
                f"but its signal is smooth only to order {source.smoothness:g}: a prescribed motion needs a "
                f"signal with continuous derivatives (e.g. Sine, or a smoother profile) when it drives an "
                f"element rigidly")
        equations.append(_differentiate(source, flat, graph, where, symbols, derivative_expr, order))
    for e in graph.diff:
        if e < n_eq0:
            equations[e] = replace(equations[e], constraint=True)

    factory = SelectionFactory(flat, graph, variables, equations, symbols, options)
    dummies, levels = factory.choose(_start_values(flat, variables))
    reduced = factory.build(dummies)
    counts = {}
    for k in graph.parent:
        root = k
        while root in graph.parent:
            root = graph.parent[root]
        counts[root] = max(counts.get(root, 0), _order(graph, k))
    report = IndexReport(tuple((flat.equations[e].describe(), n) for e, n in sorted(counts.items())),
                         max(counts.values()) + 1, tuple(variables[d].name for d in sorted(dummies)),
                         tuple(levels), tuple(reduced.variables[i].name for i in sorted(reduced.der_of)),
                         factory)
    return reduced, report


class SelectionFactory:
    """Redoes the dummy-derivative choice at any point and builds the system for a choice.

    The simulator asks `choose(values)` at accepted points; when the best choice
    differs from the running one by a clear margin (`quality`), it switches to
    `build(dummies)` compiled by the later stages.
    """

    def __init__(self, flat, graph, variables, equations, symbols, options):
        self.flat, self.graph, self.options = flat, graph, options
        self.variables, self.equations, self.symbols = variables, equations, symbols
        self.names = [v.name for v in variables]
        all_syms = ca.vertcat(*symbols)
        params = ca.vertcat(*[p.symbol for p in flat.parameters]) if flat.parameters else ca.SX(0, 1)
        self._pvals = [p.value for p in flat.parameters]
        self._args = (all_syms, flat.time, params)
        self._jacobians = {}

    def __getstate__(self):
        """Pickled without what runs built and cached on it (Jacobian maps, the branch check's traces):
        rebuilt on first use in the receiving process."""
        state = {k: v for k, v in self.__dict__.items() if not k.startswith("_") or k in ("_pvals", "_args")}
        state["_jacobians"] = {}
        return state

    def jacobian(self, rows: tuple, cols: tuple, values, params=None, memo: dict | None = None) -> np.ndarray:
        """∂(rows)/∂(cols) at one point; `memo` keeps those already evaluated at this point."""
        if memo is not None and (rows, cols) in memo:
            return memo[(rows, cols)]
        pvals = self._pvals if params is None else params
        J = self._jacobian_function(rows, cols, 1)(values, 0.0, pvals)[0]
        if memo is not None:
            memo[(rows, cols)] = J
        return J

    def _jacobian_function(self, rows: tuple, cols: tuple, n: int | None = None) -> ca.Function:
        """∂(rows)/∂(cols) as a Function of (all variables, time, parameters); mapped over n points when
        n is given. Built once per block (and n)."""
        key = (rows, cols)

        def build():
            residuals = self.flat.expand([self.equations[e].residual for e in rows])
            jac = ca.jacobian(ca.vertcat(*residuals), ca.vertcat(*[self.symbols[v] for v in cols]))
            return ca.Function("dd_jacobian", list(self._args), [jac])
        single = built(self._jacobians, key, build)
        if n is None:
            return single
        # n = 1: one point, through numpy buffers all the same
        return built(self._jacobians, (key, n), lambda: mapped(single, n) if n > 1 else NumpyCall(dense(single)))

    def quality_batch(self, levels, values_matrix: np.ndarray, params=None) -> np.ndarray:
        """Signed `quality` at many points at once (rows of values_matrix), with one mapped evaluation."""
        n = values_matrix.shape[0]
        q = np.ones(n)
        pvals = np.asarray(self._pvals if params is None else params, dtype=float).reshape(-1, 1)
        for level in levels:
            rows, cols = tuple(level.equations), tuple(level.candidates)
            f = self._jacobian_function(rows, cols, n)
            J = f(values_matrix.T, np.zeros((1, n)), np.tile(pvals, n))[0]
            J = J.reshape(len(rows), n, len(cols)).transpose(1, 0, 2)  # (point, row, candidate)
            norms = np.prod(np.linalg.norm(J, axis=2), axis=1)
            chosen = [level.candidates.index(v) for v in level.chosen]
            if len(chosen) != len(rows):
                return np.zeros(n)
            det = np.linalg.det(J[:, :, chosen])
            with np.errstate(all="ignore"):
                q *= np.where(norms > 0, det / norms, 0.0)
        return q

    def watched_indices(self) -> list:
        """Variables the selection Jacobians can depend on: those in the derivatives of the
        differentiated constraints with respect to every possible candidate (a variable with an
        antiderivative). The monitor evaluates only these along a run: for holonomic loops the
        coordinates alone, not the speeds and accelerations the constraints also hold (which cost as
        much to evaluate as the model's right-hand side)."""
        if not hasattr(self, "_watched"):
            with BUILD_LOCK:
                self._watched = self._find_watched()
        return self._watched

    def _find_watched(self) -> list:
        rows = [e for e in range(len(self.equations)) if e in self.graph.parent or e in self.graph.diff]
        exprs = self.flat.expand([self.equations[e].residual for e in rows])
        cols = [self.symbols[v] for v in range(len(self.variables)) if v in self.graph.antider]
        jac = ca.jacobian(ca.vertcat(*exprs), ca.vertcat(*cols)) if exprs and cols else ca.SX(0, 1)
        used = {s.element_hash() for s in ca.symvar(jac)}
        return [k for k, sym in enumerate(self.symbols) if sym.element_hash() in used]

    def can_degrade(self) -> bool:
        """False when every selection Jacobian is constant (a gear): the choice never needs revisiting.
        Found once (every run asks)."""
        if not hasattr(self, "_can_degrade"):
            self._can_degrade = self._jacobians_vary()
        return self._can_degrade

    def _jacobians_vary(self) -> bool:
        graph = self.graph
        h = [e for e in range(len(self.equations)) if e not in graph.diff and e in graph.parent]
        rows = set()
        while h:
            rows.update(h)
            h = [graph.parent[e] for e in h if graph.parent[e] in graph.parent]
        for e in rows:
            cand = [self.symbols[v] for v in graph.inc[e] if v in graph.antider or v in graph.der]
            if cand:
                jac = ca.jacobian(self.equations[e].residual, ca.vertcat(*cand))
                if ca.depends_on(jac, self._args[0]):
                    return True
        return False

    def base_priority(self, v) -> int:
        cache = self.__dict__.setdefault("_priorities", {})
        if v not in cache:
            u = v
            while u in self.graph.antider:
                u = self.graph.antider[u]
            cache[v] = _DUMMY_PREFERENCE.get(self.variables[u].priority, 2)
        return cache[v]

    def choose(self, values, params=None, memo: dict | None = None):
        """Mattsson–Söderlind, highest level first; columns by state priority, then numerically."""
        graph, equations = self.graph, self.equations
        h, candidates = self._top_level()
        dummies, levels = set(), []
        while h:
            cand = [v for v in candidates if any(v in graph.inc[e] for e in h)]
            if len(cand) < len(h):
                raise StructureError(_no_selection(h, equations))
            J = self.jacobian(tuple(h), tuple(cand), values, params, memo)
            chosen = _pick_columns(J, cand, len(h), self.base_priority, self.options.rank_tolerance)
            if chosen is None:
                raise StructureError(_no_selection(h, equations))
            dummies.update(chosen)
            levels.append(SelectionLevel(tuple(h), tuple(cand), tuple(chosen)))
            below = [graph.parent[e] for e in h]
            h = [e for e in below if e in graph.parent]
            candidates = [graph.antider[v] for v in chosen if graph.antider[v] in graph.antider]
        return frozenset(dummies), levels

    def quality(self, levels, values, signed: bool = False, params=None, memo: dict | None = None) -> float:
        """|det| of the chosen columns over the Hadamard bound of all candidate rows: 1 ideal, 0 singular.

        `signed` keeps the sign of the determinant, so a pass through a singular
        configuration between two evaluations shows as a sign change.
        """
        q = 1.0
        for level in levels:
            J = self.jacobian(tuple(level.equations), tuple(level.candidates), values, params, memo)
            rows = np.linalg.norm(J, axis=1)
            if np.any(rows == 0) or len(level.chosen) != J.shape[0]:
                return 0.0
            cols = [level.candidates.index(v) for v in level.chosen]
            det = np.linalg.det(J[:, cols])
            q *= (det if signed else abs(det)) / float(np.prod(rows))
        return q

    def _top_level(self):
        """(equations, candidates) of the highest level: fixed by the reduced graph, found once (the
        monitor asks at every check)."""
        if not hasattr(self, "_top"):
            graph = self.graph
            self._top = ([e for e in range(len(self.equations)) if e not in graph.diff and e in graph.parent],
                         [v for v in range(len(self.variables)) if graph.visible(v) and v in graph.antider])
        return self._top

    def levels_for(self, dummies):
        """The levels of a given dummy set, walked like `choose` but with the picks given (cached)."""
        cache = self.__dict__.setdefault("_levels_for", {})
        if dummies not in cache:
            cache[dummies] = self._walk_levels(dummies)
        return cache[dummies]

    def _walk_levels(self, dummies):
        graph = self.graph
        h, candidates = self._top_level()
        levels = []
        while h:
            cand = [v for v in candidates if any(v in graph.inc[e] for e in h)]
            chosen = [v for v in cand if v in dummies]
            levels.append(SelectionLevel(tuple(h), tuple(cand), tuple(chosen)))
            h = [graph.parent[e] for e in h if graph.parent[e] in graph.parent]
            candidates = [graph.antider[v] for v in chosen if graph.antider[v] in graph.antider]
        return levels

    def build(self, dummies) -> FlatSystem:
        der_of = {}
        for i, j in self.graph.der.items():
            if j in dummies:
                continue
            der_of[i] = self.flat.der_of[i] if i in self.flat.der_of else (j, 1.0)
        for i, (jj, c) in self.flat.der_of.items():
            if jj is None:
                der_of[i] = (None, c)
        built = replace(self.flat, variables=tuple(self.variables), equations=tuple(self.equations),
                        der_of=der_of, stage="reduce")
        return expand_unless_states(built)


def expand_unless_states(flat: FlatSystem) -> FlatSystem:
    """The tree's intermediates stand for expressions of the joint coordinates and speeds, which the
    later stages may treat as known only while those are states. When a selection makes one of them a
    dummy (a joint driven by a prescribed motion, or geared to a motor that keeps the state), the
    equations get the expressions themselves: correct, at the price of larger residuals."""
    syms, _ = flat.intermediates
    if not syms or flat.multibody is None:
        return flat
    states = {flat.variables[i].symbol.element_hash() for i in flat.der_of}
    needed = [s for _, q, qd in flat.multibody.coordinates for s in ca.vertsplit(ca.vertcat(q, qd))]
    if all(s.element_hash() in states for s in needed):
        return flat
    touched = [k for k, eq in enumerate(flat.equations) if flat.uses_intermediates(eq.residual)]
    expanded = flat.expand([flat.equations[k].residual for k in touched])
    equations = list(flat.equations)
    for k, r in zip(touched, expanded):
        equations[k] = replace(equations[k], residual=r)
    return replace(flat, equations=tuple(equations), intermediates=((), ()))


def _differentiate(source: FlatEquation, flat, graph, where, symbols, derivative_expr, order) -> FlatEquation:
    """d/dt of `source`: through what the intermediates stand for, with respect to every variable its
    expression holds (`where`: element hash -> variable index) and time."""
    r = source.residual
    if flat.uses_intermediates(r):        # differentiate what the intermediates stand for
        r = flat.expand([r])[0]
    # every variable the expression holds, not the structural row: a row that missed one would drop
    # its terms from the derivative silently
    incidence = sorted({where[s.element_hash()] for s in ca.symvar(r) if s.element_hash() in where})
    missing = [v for v in incidence if graph.kind[v] != "input" and v not in derivative_expr]
    if missing:
        raise StructureError(
            f"internal: {source.describe()} is differentiated, but the structural analysis did not see "
            f"{', '.join(flat.variables[v].name if v < len(flat.variables) else symbols[v].name() for v in missing)} "
            f"in it")
    vs, ds = [flat.time], [ca.SX(1.0)]
    for v in incidence:
        if graph.kind[v] == "input":
            if ca.depends_on(r, symbols[v]):
                raise StructureError(
                    f"{source.describe()} would have to be differentiated for index reduction, but it "
                    f"contains the external input {flat.variables[v].name}, whose derivative is unknown; "
                    f"drive it with a smooth signal (mechnet.components.signals) instead")
            continue
        vs.append(symbols[v])
        ds.append(derivative_expr[v])
    dr = ca.jtimes(r, ca.vertcat(*vs), ca.vertcat(*ds))
    label = f"d/dt {source.label}" if order == 1 else f"d{order}/dt{order} {source.label.split('d/dt ', 1)[-1]}"
    base = source
    return FlatEquation(dr, source.origin, label, source.doc, order=order,
                        smoothness=base.smoothness, regular=base.regular)


def _start_values(flat: FlatSystem, variables) -> np.ndarray:
    out = []
    for v in variables:
        if v.start is not None:
            out.append(v.start)
        elif v.guess is not None:
            out.append(v.guess)
        else:
            out.append(v.default_start)
    return np.array(out, dtype=float)


def _pick_columns(J, cand, m, priority, tol):
    """Columns for the dummies: dummy-preferred priority groups first, pivoted QR (LAPACK) within each."""
    from scipy.linalg import qr

    scale = max(np.max(np.abs(J)) if J.size else 0.0, 1e-300)
    Q = np.zeros((J.shape[0], 0))
    chosen = []
    for g in sorted({priority(v) for v in cand}):
        need = m - len(chosen)
        if need == 0:
            break
        cols = [k for k, v in enumerate(cand) if priority(v) == g]
        A = J[:, cols]
        if Q.shape[1]:
            A = A - Q @ (Q.T @ A)
        q, r, piv = qr(A, mode="economic", pivoting=True, check_finite=False)
        diag = np.abs(np.diag(r))
        take = min(int(np.sum(diag > tol * scale)), need)
        chosen.extend(cand[cols[piv[k]]] for k in range(take))
        Q = np.hstack([Q, q[:, :take]])
    return chosen if len(chosen) == m else None


def _no_selection(h, equations) -> str:
    names = "\n".join(f"    {equations[e].describe()}" for e in h)
    return ("no consistent choice of states: the differentiated constraints are singular at the start "
            "point (conflicting or redundant constraints, or a prescribed motion fighting a constraint):\n"
            + names)

