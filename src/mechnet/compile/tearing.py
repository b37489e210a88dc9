"""Solving one BLT block symbolically, tearing what cannot be solved.

A linear block is eliminated the same way and then closed: the few tearing
variables are solved from their (linear) residuals and substituted back, so
a large sparse block never becomes a dense symbolic solve.

Within a block: an equation with one unknown left, linear in it with a
coefficient that cannot vanish (a number or a function of parameters only, or
the equation's pivot: a joint acceleration's articulated inertia), is solved
explicitly. An unknown that no equation can be solved for must be torn, so
those are torn first (a loop's cut wrench: given it, the tree's accelerations
follow one by one, and a four-bar's acceleration block closes with two tears,
not six). When no equation is left to solve, the unknown that occurs in most
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
    linear: bool = False    # the tears close a linear block too large to solve symbolically (SYMBOLIC_TEARS_MAX)


def solvable_coefficient(coef: ca.SX, known_symbols: set) -> bool:
    """A coefficient that cannot vanish: a non-zero number, or built only from parameters whose
    check forbids zero (`known_symbols`; emit passes those)."""
    if coef.is_constant():
        return float(ca.evalf(coef)) != 0.0
    return all(s.element_hash() in known_symbols for s in ca.symvar(coef))


def solve_linear_for(residual: ca.SX, var: ca.SX, parameter_hashes: set):
    """Return var's explicit solution of residual = 0, or None if not safely linear. A constant
    coefficient must also be more than round-off of the row's largest constant one: a row
    1e-17·x + 1·y (the identity of a tilted mount's Rᵀ·R, to round-off) is no equation for x."""
    coef = ca.jacobian(residual, var)
    if ca.depends_on(coef, var) or not solvable_coefficient(coef, parameter_hashes):
        return None
    if coef.is_constant() and abs(float(ca.evalf(coef))) < ROUND_OFF * _largest_constant_coefficient(residual):
        return None
    rest = ca.substitute(residual, var, ca.SX(0.0))
    return -rest / coef


ROUND_OFF = 1e-12
SYMBOLIC_TEARS_MAX = 16     # a linear block closed by more tearing variables keeps them as algebraic unknowns:
                            # a dense symbolic solve grows as n³ (IFToMM A02, ten parallelograms: 30 tears,
                            # 63 891 instructions of ODE; forty would not compile in minutes)


def _largest_constant_coefficient(residual: ca.SX) -> float:
    """The largest |constant coefficient| of the residual's variables (0 when none is constant)."""
    syms = ca.symvar(residual)
    J = ca.jacobian(residual, ca.vertcat(*syms)) if syms else ca.SX(1, 0)
    # the structural nonzeros only, each read as a number directly (evalf would build a Function each)
    values = [abs(float(ca.DM(e))) for e in J.nonzeros() if e.is_constant()]
    return max(values, default=0.0)


def compose(symbols_in_order: list, local: list, extra: list):
    """Substitute a chain v_k = e_k(v_<k, ...) into itself and into `extra`, in one pass."""
    if not symbols_in_order:
        return list(local), list(extra)
    defs, ex = ca.substitute_inplace(symbols_in_order, local, extra, False)
    return list(defs), list(ex)


def _divide_for(residual: ca.SX, var: ca.SX, unknowns: ca.SX):
    """var from a residual linear in it, dividing by a coefficient known never to vanish (a pivot)."""
    coef = ca.jacobian(residual, var)
    if ca.depends_on(coef, unknowns):
        return None
    return -ca.substitute(residual, var, ca.SX(0.0)) / coef


def solve_block(residuals: list, variables: list, symbols: list, parameter_hashes: set,
                guarded: bool = False, pivots: dict | None = None) -> BlockSolution:
    """Solve a block's residuals for its variables (indices; symbols[i] their SX).

    Works on the *local* equations: variables solved earlier (inside or outside
    the block) stay symbols, so every step costs the size of one equation, not
    of everything substituted into it. `solved` lists (variable, expression) in
    order — an expression may use variables solved before it and the tearing
    variables; the caller composes them (`compose`). `guarded`: the block holds
    differentiated constraints, whose regularity the dummy-derivative selection
    guarantees (and the simulator monitors), so a block linear in its unknowns
    is solved whatever its coefficients depend on (torn, then its tearing variables solved
    symbolically). `pivots` maps a row to the unknown it may be divided for (FlatEquation.pivot).
    """
    n = len(variables)
    pivots = pivots or {}
    vec = ca.vertcat(*[symbols[v] for v in variables])
    jac = ca.jacobian(ca.vertcat(*residuals), vec)
    constant_coefficients = all(s.element_hash() in parameter_hashes for s in ca.symvar(jac))
    guarded_linear = guarded and not constant_coefficients and not ca.depends_on(jac, vec)
    if guarded_linear and n == 1:
        return BlockSolution([(variables[0], -ca.substitute(residuals[0], vec, ca.DM.zeros(1)) / jac)], [], [], [])
    # a linear block is torn like any other and closed by a symbolic solve of its tearing variables
    # only (the millimetre six-bar's acceleration block: 29 unknowns, 11 tears; its ODE shrank fivefold)
    linear = n > 1 and (constant_coefficients or guarded_linear)
    unknown = {symbols[v].element_hash(): v for v in variables}
    solved, tears, out_res, rows = [], [], [], []
    remaining = set(variables)
    holds = [{unknown[s.element_hash()] for s in ca.symvar(r) if s.element_hash() in unknown} for r in residuals]

    def unknowns_of(k):
        return [v for v in holds[k] if v in remaining]

    users = {v: [] for v in variables}
    for k, vs in enumerate(holds):
        for v in vs:
            users[v].append(k)
    explicit = {}                          # (equation, unknown) -> its explicit solution, or None

    def solution(k, v):
        if (k, v) not in explicit:
            sol = solve_linear_for(residuals[k], symbols[v], parameter_hashes)
            if sol is None and pivots.get(k) == v:
                sol = _divide_for(residuals[k], symbols[v], vec)
            explicit[(k, v)] = sol
        return explicit[(k, v)]

    # an unknown no equation can be solved for explicitly must be a tearing variable: tear those first
    # (a loop's cut wrench, whose coefficients are rotations: given it, the tree's accelerations follow)
    forced = sorted(v for v in variables if not any(solution(k, v) is not None for k in users[v]))
    tears.extend(forced)
    remaining.difference_update(forced)
    open_eqs = set(range(n))
    queue = list(range(n))                 # equations to look at again (their unknowns may have gone)
    while open_eqs:
        while queue:
            k = queue.pop()
            if k not in open_eqs:
                continue
            unk = unknowns_of(k)
            if not unk:
                out_res.append(residuals[k])
                rows.append(k)
                open_eqs.discard(k)
            elif len(unk) == 1:
                sol = solution(k, unk[0])
                if sol is None:
                    continue
                solved.append((unk[0], sol))
                remaining.discard(unk[0])
                open_eqs.discard(k)
                queue.extend(j for j in users[unk[0]] if j in open_eqs)
        if open_eqs:
            counts = {v: 0 for v in remaining}
            for k in open_eqs:
                for v in unknowns_of(k):
                    counts[v] += 1
            tear = max(sorted(counts), key=lambda v: counts[v])
            tears.append(tear)
            remaining.discard(tear)
            queue.extend(j for j in users[tear] if j in open_eqs)
            queue.extend(k for k in open_eqs if len(unknowns_of(k)) <= 1)
    if len(tears) != len(out_res):
        # tearing did not come out square (should not happen for a matched block): keep it whole
        return BlockSolution([], list(variables), list(residuals), list(range(n)))
    if linear and tears and len(tears) <= SYMBOLIC_TEARS_MAX:
        # block elimination: composed, the torn residuals are linear in the tearing variables;
        # solve that small system symbolically and substitute back, all in single passes
        defs, res = compose([symbols[v] for v, _ in solved], [e for _, e in solved], out_res)
        t_vec = ca.vertcat(*[symbols[v] for v in tears])
        r_vec = ca.vertcat(*res)
        a = ca.jacobian(r_vec, t_vec)
        b = ca.substitute(r_vec, t_vec, ca.DM.zeros(len(tears)))
        t_sol = refined_solve(a, -b)
        back = ca.substitute(ca.vertcat(*defs), t_vec, t_sol) if defs else []
        return BlockSolution([(v, t_sol[k]) for k, v in enumerate(tears)]
                             + [(v, back[k]) for k, (v, _) in enumerate(solved)], [], [], [])
    return BlockSolution(solved, tears, out_res, rows, linear=bool(linear and tears))


def refined_solve(a, b):
    """x = a⁻¹b symbolically, with one step of iterative refinement.

    CasADi's symbolic solve factors with modified Gram-Schmidt, whose error grows with the
    conditioning. The acceleration block of a millimetre six-bar (tests/models.py: stephenson_mm) has
    rows in newtons next to m/s². Solved whole (29×29, condition 2e8), it came out with 4e-7 relative
    error; solved through its 11 tearing variables, the accelerations still carried 2e-7 relative
    noise. That noise stalled IDAS at tight tolerances. One refinement step, x₀ + a⁻¹(b − a·x₀),
    brings the noise to 1e-14. The compiled functions use common-subexpression elimination (`cse`),
    which merges the duplicated factorisation; the step still costs 10–30 % more instructions for the
    solve, depending on the block.

    A 2×2 block (a planar loop's two cut forces, its two dependent speeds) is solved by Cramer's rule,
    which is forward stable for n = 2 (Higham, Accuracy and Stability of Numerical Algorithms, §1.10)
    and invariant under row scaling: no refinement, and 7 % fewer instructions in a slider-crank's ODE."""
    if a.shape == (2, 2):
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        return ca.vertcat(a[1, 1] * b[0, :] - a[0, 1] * b[1, :], a[0, 0] * b[1, :] - a[1, 0] * b[0, :]) / det
    x0 = ca.solve(a, b)
    return x0 + ca.solve(a, b - ca.mtimes(a, x0))
