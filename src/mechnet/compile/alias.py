"""Simplify: alias elimination, constants, structurally zero equations.

Connections generate many equations `a = b` and `a + b = 0`; a fixed flange
sets `phi = 0`. Eliminating them shrinks the system without losing a name: the
`AliasMap` keeps every eliminated variable as ±(surviving symbol) or a constant.

When two variables that both have derivatives become aliases (two inertias
connected directly), their derivatives are aliases too — that is the
differentiated alias equation, so the rigid pair gets one set of states.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import casadi as ca

from ..core.errors import StructureError
from .artifacts import AliasMap, FlatSystem

_KIND_RANK = {"state": 4, "algebraic": 3, "output": 2, "across": 1, "through": 1, "derivative": 0}
_PRIORITY_RANK = {"always": 4, "prefer": 3, "default": 2, "avoid": 1, "never": 0}


@dataclass(frozen=True)
class SimplifyOptions:
    eliminate_aliases: bool = True


class _Classes:
    """Union-find with signs: variable i = sign[i] * parent[i]; a root may carry a constant value."""

    def __init__(self, flat: FlatSystem):
        n = len(flat.variables)
        self.flat = flat
        self.parent = list(range(n))
        self.sign = [1.0] * n
        self.const: dict[int, float] = {}
        self.der_of = dict(flat.der_of)           # root -> (index, sign); maintained on roots
        self.log: list[int] = []                  # roots that stopped being free symbols, in order

    def find(self, i):
        s = 1.0
        path = []
        while self.parent[i] != i:
            path.append(i)
            s *= self.sign[i]
            i = self.parent[i]
        # path compression
        acc = s
        for j in path:
            sj = self.sign[j]
            self.parent[j] = i
            self.sign[j] = acc
            acc *= sj
        return i, s

    def _rank(self, i):
        v = self.flat.variables[i]
        return (v.kind == "input", i in self.der_of, _KIND_RANK.get(v.kind, 0),
                _PRIORITY_RANK.get(v.priority, 2), -i)

    def _joinable(self, ra, rb) -> bool:
        """Whether the classes of roots ra and rb may become one, their derivatives included: when two
        states are aliased their derivatives are too, and if those cannot be (a state's speed equal to
        an input), the equation must stay an equation, or the relation between the derivatives is lost."""
        if ra == rb:
            return True
        keep, drop = (ra, rb) if self._rank(ra) > self._rank(rb) else (rb, ra)
        kinds = {self.flat.variables[keep].kind, self.flat.variables[drop].kind}
        if self.flat.variables[drop].kind == "input":
            return False                      # two inputs equal: a constraint, not an alias
        if "input" in kinds and (drop in self.der_of):
            return False                      # a state equal to an input: prescribed motion (index reduction)
        if keep in self.const and drop in self.const:
            return False
        (dj, _), (kj, _) = self.der_of.get(drop, (None, 0)), self.der_of.get(keep, (None, 0))
        if dj is None or kj is None:
            return True
        (rd, _), (rk, _) = self.find(dj), self.find(kj)
        return (rd in self.const and rk in self.const) or self._joinable(rd, rk)

    def union(self, a, b, s) -> bool:
        """Record a = s * b. Returns False when it cannot be used as an alias."""
        ra, sa = self.find(a)
        rb, sb = self.find(b)
        if ra == rb or not self._joinable(ra, rb):
            return False
        rel = s * sb * sa                     # ra = rel * rb
        keep, drop = (ra, rb) if self._rank(ra) > self._rank(rb) else (rb, ra)
        self.parent[drop] = keep
        self.sign[drop] = rel
        self.log.append(drop)
        if drop in self.const:
            self.set_const(keep, rel * self.const.pop(drop))
        if drop in self.der_of:
            dj, ds = self.der_of.pop(drop)
            if keep in self.der_of:
                kj, ks = self.der_of[keep]
                # der(drop) = rel * der(keep):  ds*var(dj) = rel*ks*var(kj)
                self._merge_derivatives(dj, ds, kj, rel * ks)
            else:
                self.der_of[keep] = (dj, ds * rel)
        return True

    def _merge_derivatives(self, dj, ds, kj, ks):
        """The derivatives of two aliased states are aliases too (the differentiated alias equation)."""
        if dj is None or kj is None:
            return
        if self.union(dj, kj, ks / ds):
            return
        (ra, sa), (rb, sb) = self.find(dj), self.find(kj)
        if ra in self.const and rb in self.const:
            self._require_equal(dj, sa * self.const[ra], (ks / ds) * sb * self.const[rb])

    def _require_equal(self, i, a, b):
        if abs(a - b) > 1e-12 * max(1.0, abs(a), abs(b)):
            name = self.flat.variables[i].name
            raise StructureError(f"{name} would have to equal both {a:g} and {b:g}: the model over-determines "
                                 f"it (e.g. a rigid connection to a fixed element plus a prescribed value); "
                                 f"remove one of the constraints on {name}")

    def set_const(self, i, value) -> bool:
        r, s = self.find(i)
        if self.flat.variables[r].kind == "input":
            return False
        if r in self.const:
            return False
        self.const[r] = s * value
        self.log.append(r)
        if r in self.der_of:                   # a constant's derivative is zero
            dj, ds = self.der_of.pop(r)
            if dj is not None and not self.set_const(dj, 0.0):
                rd, sd = self.find(dj)
                if rd in self.const:
                    self._require_equal(dj, sd * self.const[rd], 0.0)
        return True

    def expression(self, i, symbols):
        r, s = self.find(i)
        if r in self.const:
            return ca.SX(s * self.const[r])
        return s * symbols[r] if s != 1.0 else symbols[r]


def simplify(flat: FlatSystem, options: SimplifyOptions = SimplifyOptions()) -> tuple[FlatSystem, AliasMap]:
    symbols = [v.symbol for v in flat.variables]
    index = {s.element_hash(): i for i, s in enumerate(symbols)}
    classes = _Classes(flat)
    residuals = [eq.residual for eq in flat.equations]
    active = [True] * len(residuals)
    removed = 0

    # a work queue: an equation is looked at again only when one of its variables was eliminated,
    # and only that equation is rewritten (large scenes hold long expressions; rescanning is O(N²))
    deps: list[list[int]] = [[] for _ in residuals]
    other = [False] * len(residuals)          # uses time or tunable parameters
    users: dict[int, set] = {}

    def scan(e):
        syms = ca.symvar(residuals[e])
        deps[e] = [index[h] for h in (x.element_hash() for x in syms) if h in index]
        other[e] = len(deps[e]) != len(syms)
        for i in deps[e]:
            users.setdefault(i, set()).add(e)

    eliminated: set[int] = set()
    queue = deque(range(len(residuals)) if options.eliminate_aliases else ())
    for e in queue:
        scan(e)
    queued = set(queue)
    while queue:
        e = queue.popleft()
        queued.discard(e)
        if not active[e]:
            continue
        gone = [i for i in deps[e] if i in eliminated]
        if gone:
            residuals[e] = ca.substitute(residuals[e], ca.vertcat(*[symbols[i] for i in gone]),
                                         ca.vertcat(*[classes.expression(i, symbols) for i in gone]))
            scan(e)
        r, vs = residuals[e], deps[e]
        if not vs and not other[e]:
            if float(ca.evalf(r)) != 0.0:
                raise StructureError(f"{flat.equations[e].describe()} cannot hold: it reduces to "
                                     f"{float(ca.evalf(r)):g} = 0 after eliminating constants")
            active[e] = False
            removed += 1
            continue
        if other[e] or len(vs) > 2:
            continue                       # time, tunable parameters or many variables
        vec = ca.vertcat(*[symbols[i] for i in vs])
        jac = ca.jacobian(r, vec)
        if not jac.is_constant():
            continue
        coeffs = [float(c) for c in ca.evalf(jac).full().ravel()]
        offset = ca.substitute(r, vec, ca.DM.zeros(len(vs)))
        if not offset.is_constant():
            continue
        offset = float(ca.evalf(offset))
        start_log = len(classes.log)
        try:
            if len(vs) == 1 and coeffs[0] != 0.0:
                used = classes.set_const(vs[0], -offset / coeffs[0])
            elif len(vs) == 2 and offset == 0.0 and abs(coeffs[0]) == abs(coeffs[1]) and coeffs[0] != 0:
                used = classes.union(vs[0], vs[1], -coeffs[1] / coeffs[0])
            else:
                used = False
        except StructureError as exc:
            raise StructureError(f"{flat.equations[e].describe()}: {exc}") from None
        if used:
            active[e] = False
        for i in classes.log[start_log:]:
            eliminated.add(i)
            for k in users.get(i, ()):
                if active[k] and k not in queued:
                    queue.append(k)
                    queued.add(k)
    for e in range(len(residuals)):          # bring every surviving equation up to date
        gone = [i for i in deps[e] if i in eliminated]
        if active[e] and gone:
            residuals[e] = ca.substitute(residuals[e], ca.vertcat(*[symbols[i] for i in gone]),
                                         ca.vertcat(*[classes.expression(i, symbols) for i in gone]))

    # what survives
    survivors = [i for i in range(len(symbols)) if classes.find(i)[0] == i and i not in classes.const]
    new_index = {old: k for k, old in enumerate(survivors)}
    variables = tuple(flat.variables[i] for i in survivors)
    der_of = {}
    for i, (j, s) in classes.der_of.items():
        if i not in new_index:
            continue
        rj, sj = classes.find(j)
        if rj in classes.const:
            der_of[new_index[i]] = (None, s * sj * classes.const[rj])  # der = constant
        else:
            der_of[new_index[i]] = (new_index[rj], s * sj)
    expressions = {}
    n_alias = n_const = 0
    for i, v in enumerate(flat.variables):
        r, _ = classes.find(i)
        if r == i and i not in classes.const:
            continue
        expressions[v.name] = classes.expression(i, symbols)
        if r in classes.const:
            n_const += 1
        else:
            n_alias += 1
    equations = tuple(replace(eq, residual=residuals[e]) for e, eq in enumerate(flat.equations) if active[e])
    zero_crossings = _map_zero_crossings(flat, classes, symbols, new_index)
    reduced = FlatSystem(flat.name, variables, equations, flat.parameters, der_of, flat.time,
                         flat.effects, stage="simplify", time_events=flat.time_events,
                         folded_parameters=flat.folded_parameters, zero_crossings=zero_crossings,
                         intermediates=_map_intermediates(flat, classes, symbols), multibody=flat.multibody,
                         observed_only=flat.observed_only, unit_quaternions=flat.unit_quaternions)
    return reduced, AliasMap(expressions, n_alias, n_const, removed + (len(flat.equations) - len(equations) - removed))


def _map_intermediates(flat, classes, symbols):
    """The tree's intermediates in terms of the surviving variables: a joint speed that a Speed source
    fixes to a constant, or a coordinate aliased to a source's angle, is replaced there too."""
    syms, defs = flat.intermediates
    if not syms or flat.multibody is None:
        return flat.intermediates
    index = {v.symbol.element_hash(): i for i, v in enumerate(flat.variables)}
    gone = [index[s.element_hash()] for _, q, qd in flat.multibody.coordinates
            for s in ca.vertsplit(ca.vertcat(q, qd)) if s.element_hash() in index]
    gone = [i for i in gone if classes.find(i)[0] != i or i in classes.const]
    if not gone:
        return flat.intermediates
    new = ca.substitute(ca.vertcat(*defs), ca.vertcat(*[symbols[i] for i in gone]),
                        ca.vertcat(*[classes.expression(i, symbols) for i in gone]))
    return tuple(syms), tuple(new[k] for k in range(new.numel()))


def _map_zero_crossings(flat, classes, symbols, new_index):
    """Conditions and resets in terms of the surviving variables (a reset of an alias resets its representative)."""
    if not flat.zero_crossings:
        return ()
    elim = [i for i in range(len(symbols)) if classes.find(i)[0] != i or i in classes.const]
    olds = ca.vertcat(*[symbols[i] for i in elim]) if elim else None
    news = ca.vertcat(*[classes.expression(i, symbols) for i in elim]) if elim else None

    def sub(expr):
        return ca.substitute(expr, olds, news) if olds is not None else expr

    out = []
    for zc in flat.zero_crossings:
        resets = []
        for i, value in zc.resets:
            r, sign = classes.find(i)
            if r in classes.const:
                raise StructureError(f"{zc.label}: resets {flat.variables[i].name}, which the model fixes "
                                     f"to a constant")
            resets.append((new_index[r], sign * sub(value)))
        out.append(replace(zc, g=sub(zc.g), resets=tuple(resets)))
    return tuple(out)
