"""Solving one BLT block symbolically, tearing what cannot be solved.

A linear block is eliminated the same way and then closed: the few tearing
variables are solved from their (linear) residuals and substituted back, so
a large sparse block never becomes a dense symbolic solve.

Within a block: an equation with one unknown left, linear in it with a
coefficient that cannot vanish (a number or a function of parameters only),
is solved explicitly; when none is left, the unknown that occurs in most
remaining equations becomes a tearing variable (Cellier's heuristic). What is
left are residual equations in the tearing variables: the only algebraic
part the integrator sees.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca


@dataclass
class BlockSolution:
    solved: list            # (variable index, expression) in solving order
    tears: list             # variable indices kept as algebraic unknowns
    residuals: list         # expressions that must vanish
    rows: list = field(default_factory=list)  # for each residual, its position in the block (to name the equation)


def solvable_coefficient(coef: ca.SX, known_symbols: set) -> bool:
    """A coefficient that cannot vanish: a non-zero number, or built from parameters only."""
    if coef.is_constant():
        return float(ca.evalf(coef)) != 0.0
    return all(s.element_hash() in known_symbols for s in ca.symvar(coef))


def solve_linear_for(residual: ca.SX, var: ca.SX, parameter_hashes: set):
    """Return var's explicit solution of residual = 0, or None if not safely linear."""
    coef = ca.jacobian(residual, var)
    if ca.depends_on(coef, var) or not solvable_coefficient(coef, parameter_hashes):
        return None
    rest = ca.substitute(residual, var, ca.SX(0.0))
    return -rest / coef


def solve_block(residuals: list, variables: list, symbols: list, parameter_hashes: set,
                guarded: bool = False) -> BlockSolution:
    """Solve residuals (already in known terms) for variables (indices; symbols[i] their SX).

    `guarded`: the block holds differentiated constraints, whose regularity the
    dummy-derivative selection guarantees (and the simulator monitors), so a
    block linear in its unknowns is solved whatever its coefficients depend on.
    """
    n = len(variables)
    vec = ca.vertcat(*[symbols[v] for v in variables])
    linear = False
    jac = ca.jacobian(ca.vertcat(*residuals), vec)
    constant_coefficients = all(s.element_hash() in parameter_hashes for s in ca.symvar(jac))
    if guarded and not constant_coefficients and not ca.depends_on(jac, vec):
        rhs = -ca.substitute(ca.vertcat(*residuals), vec, ca.DM.zeros(n))
        sol = rhs / jac if n == 1 else ca.solve(jac, rhs)
        return BlockSolution([(v, sol[k]) for k, v in enumerate(variables)], [], [], [])
    if n > 1:
        linear = constant_coefficients
    unknown = {symbols[v].element_hash(): v for v in variables}
    pending = list(range(n))
    current = list(residuals)
    solved, tears, out_res, rows = [], [], [], []
    remaining = set(variables)
    # which unknowns each equation holds, and which equations hold each unknown (kept up to date)
    holds = [{unknown[s.element_hash()] for s in ca.symvar(r) if s.element_hash() in unknown} for r in current]
    users = {v: set() for v in variables}
    for k, vs in enumerate(holds):
        for v in vs:
            users[v].add(k)

    def unknowns_of(k):
        return [v for v in holds[k] if v in remaining]

    open_eqs = set(pending)
    while open_eqs:
        progress = False
        for k in sorted(open_eqs):
            unk = unknowns_of(k)
            if not unk:
                out_res.append(current[k])
                rows.append(k)
                open_eqs.discard(k)
                progress = True
            elif len(unk) == 1:
                sol = solve_linear_for(current[k], symbols[unk[0]], parameter_hashes)
                if sol is None:
                    continue
                v = unk[0]
                solved.append((v, sol))
                remaining.discard(v)
                open_eqs.discard(k)
                brought = {unknown[s.element_hash()] for s in ca.symvar(sol) if s.element_hash() in unknown}
                for j in users[v] & open_eqs:
                    current[j] = ca.substitute(current[j], symbols[v], sol)
                    holds[j] |= brought
                    for b in brought:
                        users[b].add(j)
                progress = True
        if not progress:
            counts = {v: 0 for v in remaining}
            for k in open_eqs:
                for v in unknowns_of(k):
                    counts[v] += 1
            tear = max(sorted(counts), key=lambda v: counts[v])
            tears.append(tear)
            remaining.discard(tear)
    if len(tears) != len(out_res):
        # tearing did not come out square (should not happen for a matched block): keep it whole
        return BlockSolution([], list(variables), list(residuals), list(range(n)))
    if linear and tears:
        # block elimination: the torn residuals are linear in the tearing variables; solve that
        # small system symbolically and substitute back into the sequentially solved variables
        t_vec = ca.vertcat(*[symbols[v] for v in tears])
        r_vec = ca.vertcat(*out_res)
        a = ca.jacobian(r_vec, t_vec)
        b = ca.substitute(r_vec, t_vec, ca.DM.zeros(len(tears)))
        t_sol = ca.solve(a, -b)
        back = ca.substitute(ca.vertcat(*[e for _, e in solved]), t_vec, t_sol) if solved else []
        return BlockSolution([(v, back[k]) for k, (v, _) in enumerate(solved)]
                             + [(v, t_sol[k]) for k, v in enumerate(tears)], [], [], [])
    return BlockSolution(solved, tears, out_res, rows)
