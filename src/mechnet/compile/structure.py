"""Analyze: incidence, matching, balance and BLT on integers.

The unknowns at each instant are the highest-order variables (everything but
states and inputs). A perfect matching between equations and unknowns means
the system can be solved for them (index 1 at most); otherwise the
Dulmage–Mendelsohn parts name what is over- and under-determined. A
constraint among states shows up as an equation that matches nothing: that is
what a higher-index model looks like, and it is reported as such.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import networkx as nx

from ..core.errors import HigherIndexError, UnbalancedModelError
from .artifacts import FlatSystem, StructureReport

_LIST_MAX = 12


@dataclass(frozen=True)
class StructureOptions:
    pass


def incidence_of(flat: FlatSystem, unknowns: list[int]) -> list[list[int]]:
    position = {flat.variables[i].symbol.element_hash(): k for k, i in enumerate(unknowns)}
    rows = []
    for eq in flat.equations:
        rows.append(sorted({position[s.element_hash()] for s in ca.symvar(eq.residual)
                            if s.element_hash() in position}))
    return rows


def maximum_matching(incidence: list[list[int]], n_unknowns: int) -> dict[int, int]:
    """Equation index -> unknown position, a maximum matching (SciPy's Hopcroft–Karp, in C: a
    recursive matching overflows Python's stack on a chain of a few hundred bodies)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import maximum_bipartite_matching

    if not incidence or n_unknowns == 0:
        return {}
    rows = [e for e, row in enumerate(incidence) for _ in row]
    cols = [k for row in incidence for k in row]
    graph = csr_matrix(([1.0] * len(rows), (rows, cols)), shape=(len(incidence), n_unknowns))
    var_of_eq = maximum_bipartite_matching(graph, perm_type="column")
    return {e: int(k) for e, k in enumerate(var_of_eq) if k >= 0}


def _alternating_reach(incidence, matching, unmatched_eqs, unmatched_vars, n_unknowns):
    """Over-determined equations (reached from unmatched equations) and under-determined variables."""
    eq_of_var = {k: e for e, k in matching.items()}
    users: dict[int, list[int]] = {k: [] for k in range(n_unknowns)}
    for e, row in enumerate(incidence):
        for k in row:
            users[k].append(e)
    over = set(unmatched_eqs)
    stack = list(unmatched_eqs)
    while stack:
        e = stack.pop()
        for k in incidence[e]:
            e2 = eq_of_var.get(k)
            if e2 is not None and e2 not in over:
                over.add(e2)
                stack.append(e2)
    under = set(unmatched_vars)
    stack = list(unmatched_vars)
    while stack:
        k = stack.pop()
        for e in users[k]:
            k2 = matching.get(e)
            if k2 is not None and k2 not in under:
                under.add(k2)
                stack.append(k2)
    return over, under


def _listing(items: list[str]) -> str:
    shown = [f"    {s}" for s in items[:_LIST_MAX]]
    if len(items) > _LIST_MAX:
        shown.append(f"    ... and {len(items) - _LIST_MAX} more")
    return "\n".join(shown)


def _describe_var(flat: FlatSystem, i: int) -> str:
    v = flat.variables[i]
    where = f" ({v.origin}, {v.component_type})" if v.origin else ""
    return f"{v.name}{where}"


def analyze_structure(flat: FlatSystem, options: StructureOptions = StructureOptions()) -> StructureReport:
    unknowns = flat.unknowns()
    incidence = incidence_of(flat, unknowns)
    n_eq, n_var = len(incidence), len(unknowns)
    matching = maximum_matching(incidence, n_var)
    if len(matching) < max(n_eq, n_var):
        _raise_unbalanced(flat, unknowns, incidence, matching)
    # BLT: equation a -> equation b when b uses the variable matched to a
    eq_of_var = {k: e for e, k in matching.items()}
    g = nx.DiGraph()
    g.add_nodes_from(range(n_eq))
    for b, row in enumerate(incidence):
        for k in row:
            a = eq_of_var[k]
            if a != b:
                g.add_edge(a, b)
    cond = nx.condensation(g)
    blocks = tuple(tuple(sorted(cond.nodes[c]["members"])) for c in nx.topological_sort(cond))
    return StructureReport(tuple(unknowns), tuple(tuple(r) for r in incidence),
                           tuple(matching[e] for e in range(n_eq)), blocks, n_eq)


def _raise_unbalanced(flat, unknowns, incidence, matching):
    n_eq, n_var = len(incidence), len(unknowns)
    unmatched_eqs = [e for e in range(n_eq) if e not in matching]
    matched_vars = set(matching.values())
    unmatched_vars = [k for k in range(n_var) if k not in matched_vars]
    over, under = _alternating_reach(incidence, matching, unmatched_eqs, unmatched_vars, n_var)
    state_hashes = {flat.variables[i].symbol.element_hash(): i for i in flat.der_of}
    constraint_eqs = [e for e in sorted(over)
                      if any(s.element_hash() in state_hashes for s in ca.symvar(flat.equations[e].residual))]
    header = f"model {flat.name!r}: {n_eq} equations for {n_var} unknowns"
    eq_lines = [flat.equations[e].describe() for e in sorted(over)]
    var_lines = [_describe_var(flat, unknowns[k]) for k in sorted(under)]
    if n_eq == n_var and constraint_eqs:
        states = sorted({flat.variables[state_hashes[s.element_hash()]].name
                         for e in constraint_eqs for s in ca.symvar(flat.equations[e].residual)
                         if s.element_hash() in state_hashes})
        raise HigherIndexError(
            f"{header}, but these equations constrain variables that are states "
            f"({', '.join(states)}), so the model has index > 1 and needs index reduction "
            f"(Pantelides / dummy derivatives; switched off by CompileOptions.reduce):\n{_listing(eq_lines)}\n"
            f"Typical causes: a prescribed motion or a rigid coupling between two masses or inertias "
            f"that are not directly connected.")
    parts = [header + "."]
    if n_eq == n_var:
        parts.append("The counts balance, so the structure itself is singular: typically a prescribed motion "
                     "fighting a constraint (a Position/Speed source on a fixed flange), or two sources driving "
                     "the same quantity.")
    if over:
        parts.append(f"Over-determined: these {len(over)} equations compete for too few unknowns "
                     f"(remove one, or check for a duplicated connection or a fixed start written as an equation):\n"
                     + _listing(eq_lines))
    if under:
        parts.append(f"Under-determined: these {len(under)} variables are not fixed by any equation "
                     f"(a missing connection, a missing component, or a connector left open?):\n"
                     + _listing(var_lines))
    error = UnbalancedModelError("\n".join(parts))
    error.equations = eq_lines
    error.variables = var_lines
    raise error
