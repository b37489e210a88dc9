"""Consistent initialisation: fixed start values enforced, guesses only guessed.

The initial system is the algebraic equations plus one equation per fixed
start value (whatever variable it names: a state, an alias, a connector
variable), or der(x) = 0 for a steady start. It must be square: a fixed value
that competes with another for the same state is reported by name, and states
that no fixed value reaches are reported as free (an error, DESIGN.md).
Guesses (and the fixed values themselves) seed the Newton iteration.
The system is solved with a damped Newton method built from CasADi functions.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import casadi as ca
import networkx as nx
import numpy as np

from ..caches import built
from ..compile.structure import maximum_matching
from ..core.errors import InitializationError
from ..numeric import NumpyCall, dense

_TOL = 1e-10


@dataclass
class InitialPoint:
    x: np.ndarray
    z: np.ndarray
    fixed: list          # names whose values were enforced
    free_states: list    # states that took their guess
    residual: float


def _newton(residual: ca.Function, jacobian: ca.Function, w0: np.ndarray, args: tuple = (),
            max_iter: int = 50):
    """Damped Newton on residual(w, *args) = 0 with a backtracking line search."""
    w_val = w0.copy()
    r = residual(w_val, *args)[0].ravel()
    for _ in range(max_iter):
        norm = np.max(np.abs(r)) if r.size else 0.0
        if norm < _TOL * (1.0 + np.max(np.abs(w_val), initial=0.0)):
            break
        step = _newton_step(jacobian(w_val, *args), r)
        if step is None:
            break                              # the caller reports the residual by equation
        lam = 1.0
        while lam > 1e-6:
            trial = w_val + lam * step
            rt = residual(trial, *args)[0].ravel()
            if np.all(np.isfinite(rt)) and np.max(np.abs(rt)) < (1 - 1e-4 * lam) * norm:
                break
            lam *= 0.5
        w_val, r = trial, rt
    return w_val, r


def _newton_step(J: ca.DM, r: np.ndarray):
    """The Newton step from the Jacobian J (sparse DM): sparse LU (a chain stays O(N)); least squares
    when J is singular or not square; None when J or r is not finite."""
    from scipy.sparse import csc_matrix
    from scipy.sparse.linalg import spsolve

    step = None
    if J.shape[0] == J.shape[1] and J.shape[0] > 0:
        rows, cols = J.sparsity().get_triplet()
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            step = spsolve(csc_matrix((np.asarray(J.nonzeros(), dtype=float), (rows, cols)), shape=J.shape), -r)
    if step is None or not np.all(np.isfinite(step)):
        dense = np.asarray(J.full(), dtype=float)
        if not (np.all(np.isfinite(dense)) and np.all(np.isfinite(r))):
            return None
        try:
            step = np.linalg.lstsq(dense, -r, rcond=None)[0]
        except np.linalg.LinAlgError:
            return None
    return step


def _residual_pair(name: str, w: ca.SX, args: list, expr: ca.SX) -> tuple:
    """Residual (on numpy memory: called at every start) and its sparse Jacobian in w, as functions of
    (w, *args)."""
    return (NumpyCall(dense(ca.Function(name, [w, *args], [expr]))),
            ca.Function(name + "_jacobian", [w, *args], [ca.jacobian(expr, w)]))


def _start_terms(dae, names: tuple):
    """The start-value expressions in (x, z) with time, inputs and parameters left symbolic: their
    dependence pattern, which are linear in one variable (k -> j), and a Function of (w, t, u, p)
    giving their values and coefficients at w = 0. Built once per model and set of start names: the
    symbolic work costs more than the rest of a short simulation."""
    return built(dae.info.setdefault("_start_terms", {}), names, lambda: _build_start_terms(dae, names))


def _build_start_terms(dae, names: tuple):
    y = _symbolic_observed(dae)
    row = {n: k for k, n in enumerate(dae.observed_names)}
    w = ca.vertcat(dae.x, dae.z)
    exprs = ca.vertcat(*[y[row[n]] for n in names]) if names else ca.SX(0, 1)
    pattern = _pattern(exprs, w)
    jac = ca.jacobian(exprs, w)
    linear = {k: pattern[k][0] for k in range(len(names))
              if len(pattern[k]) == 1 and not ca.depends_on(jac[k, pattern[k][0]], w)}
    coefficients = ca.vertcat(*[jac[k, linear[k]] if k in linear else ca.SX(0) for k in range(len(names))]) \
        if names else ca.SX(0, 1)
    at_zero = NumpyCall(dense(ca.Function("start_values_at_zero", [w, dae.t, dae.u, dae.p, dae.d],
                                          [exprs, coefficients])))
    return exprs, pattern, linear, at_zero


def start_conditions(dae, t0: float, u: np.ndarray, p: np.ndarray, start: dict, steady_state: bool = False,
                     d: np.ndarray | None = None):
    """The fixed start values that become equations of the initial system, at (t0, u, p) and modes d
    (default: the model's start modes).

    Those that are constants of the model are checked and dropped, equal ones through an alias
    kept once. Returns (names, conditions, implied): `names` the start names in order, `conditions`
    (name, position among the start expressions or None for der(x) = 0, value), `implied` {position
    in (x, z): (name, value)} for starts that fix one variable linearly (the best Newton start)."""
    nx_, nz = dae.x.numel(), dae.z.numel()
    args = (t0, u, p, _modes(dae, d))
    conditions = []
    implied: dict[int, tuple[str, float]] = {}   # state/algebraic -> (name, value) for x_j = const conditions
    names = tuple(start)
    _, pattern, linear, at_zero = _start_terms(dae, names)
    # every coefficient and every value at w = 0 in one evaluation (not one CasADi call per start value)
    offsets, coefs = (out.ravel() for out in at_zero(np.zeros(nx_ + nz), *args))
    for k, name in enumerate(names):
        value = start[name]
        # constant at this start: no variable in it, or its one coefficient zero at these parameters
        # (y = k·x with a tunable k = 0 holds y = 0 whatever x is)
        if not pattern[k] or (k in linear and coefs[k] == 0.0):
            const = float(offsets[k])
            if abs(const - value) > 1e-9 * max(1.0, abs(value)):
                raise InitializationError(
                    f"start value {name} = {value:g} cannot hold: at the start the model fixes {name} = "
                    f"{const:g} (a fixed element, a prescribed motion or an input determines it); remove this "
                    f"start value")
            continue
        if k in linear:                           # its coefficient is not zero: that was a constant above
            j = linear[k]
            val = (value - float(offsets[k])) / float(coefs[k])
            if j in implied:
                other, other_val = implied[j]
                if abs(other_val - val) > 1e-9 * max(1.0, abs(val)):
                    raise InitializationError(
                        f"start values {other} and {name} = {value:g} conflict: both fix the same "
                        f"quantity (they are aliases through a connection), to {other_val:g} and {val:g}")
                continue
            implied[j] = (name, val)
        conditions.append((name, k, float(value)))
    if steady_state:                  # der(x) = 0 for every state, in place of start values for them
        conditions.extend((f"der({n})", None, 0.0) for n in dae.x_names)
    return names, conditions, implied


def initialize(dae, t0: float, u: np.ndarray, p: np.ndarray, start: dict, guess: dict,
               steady_state: bool = False, d: np.ndarray | None = None) -> InitialPoint:
    """The consistent start: fixed start values enforced, guesses only guessed (module docstring), in
    the modes d (default: the model's start modes)."""
    nx_, nz = dae.x.numel(), dae.z.numel()
    d = _modes(dae, d)
    args = (t0, u, p, d)
    names, conditions, implied = start_conditions(dae, t0, u, p, start, steady_state, d)
    if nx_ + nz == 0:
        return InitialPoint(np.zeros(0), np.zeros(0), [c[0] for c in conditions], [], 0.0)
    # 2. structure (checked once per model, start names and kept conditions)
    residual, jacobian = _initial_system(dae, names, tuple(c[1] for c in conditions), conditions)
    if nz == 0 and len(conditions) == nx_ and sorted(implied) == list(range(nx_)):
        # an ODE whose start values each fix one state linearly: that is the solution, no Newton
        # (a third of a small model's fixed cost per run)
        return InitialPoint(np.array([implied[j][1] for j in range(nx_)]), np.zeros(0),
                            [c[0] for c in conditions], [], 0.0)
    # 3. guesses seed Newton; a fixed value is the best start for Newton too
    names_w = list(dae.x_names) + list(dae.z_names)
    w0 = np.array([float(guess.get(n, dae.guesses.get(n, 0.0))) for n in names_w])
    for j, (_, val) in implied.items():
        w0[j] = val
    sol, r = _newton(residual, jacobian, w0, args + (np.array([c[2] for c in conditions]),))
    tol = 1e-8 * (1.0 + np.max(np.abs(sol), initial=0.0))
    if r.size and not (np.all(np.isfinite(r)) and np.max(np.abs(r)) < tol):
        alg_labels = dae.info.get("alg_labels", ())
        labels = [f"start value {c[0]} = {c[2]:g}" for c in conditions] + \
                 [alg_labels[k] if k < len(alg_labels) else f"algebraic equation {k}" for k in range(nz)]
        bad = np.flatnonzero(~(np.abs(r) < tol))
        worst = max(bad, key=lambda k: (k >= len(conditions), abs(r[k]) if np.isfinite(r[k]) else np.inf))
        fixed = ", ".join(f"{c[0]} = {c[2]:g}" for c in conditions) or "none"
        raise InitializationError(f"consistent initialisation failed: no solution found for {labels[worst]} "
                                  f"(residual {r[worst]:.3g}) with the fixed values {fixed}; "
                                  f"check the start values and guesses")
    return InitialPoint(sol[:nx_], sol[nx_:], [c[0] for c in conditions], [],
                        float(np.max(np.abs(r))) if r.size else 0.0)


def ready_to_integrate(dae, t0: float, init: InitialPoint, u: np.ndarray, p: np.ndarray,
                       d: np.ndarray) -> InitialPoint:
    """The start of a run as the integrator gets it, or InitializationError naming why it cannot be one.

    Quaternion states are scaled to |Q| = 1, as at every restart (R uses Q/|Q|: only the numbers
    recorded change; a Q_start of [2, 0, 0, 0] used to show |Q| = 2 in the first row); a zero quaternion
    is no orientation and is refused (|Q| <= 1e-12, as Q_start is). A state, algebraic variable or derivative that is not finite at the
    start (a start of 1e308 whose spring torque overflows, der(x) = 1/x at x = 0) is refused by name: the
    integrator would stop at once and return a partial result of that one non-finite row."""
    x, z = init.x, init.z
    fixed = ", ".join(init.fixed) or "none"
    for index in dae.info.get("quaternions", ()):
        q = x[list(index)]
        norm = np.linalg.norm(q)
        if not norm > 1e-12:            # as a Q_start is judged when the joint is built
            names = ", ".join(dae.x_names[k] for k in index)
            raise InitializationError(f"the quaternion {names} starts at {q.tolist()}, the zero quaternion, which "
                                      f"is no orientation (start values fixed: {fixed}); the identity is [1, 0, 0, 0]")
        if np.isfinite(norm) and norm != 1.0:
            x = x.copy()
            x[list(index)] = q / norm
    if x is not init.x and z.size:
        z = solve_algebraic(dae, t0, x, z, u, p, d)
    for names, values in ((dae.x_names, x), (dae.z_names, z)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise InitializationError(f"{names[bad[0]]} = {values[bad[0]]} at the start is not finite (start values "
                                      f"fixed: {fixed}); check the start values, guesses and parameters")
    if x.size:
        xdot = np.asarray(dae.ode(t0, x, z, u, p, d)).ravel()
        bad = np.flatnonzero(~np.isfinite(xdot))
        if bad.size:
            states = ", ".join(f"{n} = {v:g}" for n, v in list(zip(dae.x_names, x))[:6]) + \
                (", ..." if x.size > 6 else "")
            raise InitializationError(f"der({dae.x_names[bad[0]]}) = {xdot[bad[0]]} at the start, from {states} "
                                      f"(start values fixed: {fixed}): the model cannot be integrated from there; "
                                      f"check the start values and parameters")
    if x is init.x:
        return init
    return InitialPoint(x, z, init.fixed, init.free_states, init.residual)


def _initial_system(dae, names: tuple, kept: tuple, conditions: list):
    """Residual and Jacobian Functions of (w, t, u, p, fixed values) of the initial system: the kept
    start conditions (positions among the start expressions; None: der(x) = 0, one per state in
    order) and the algebraic equations. Its structure is checked as it is built: a fixed value that
    competes with another for the same quantity, or a state nothing fixes, is reported by name.
    Cached per model, start names and kept conditions."""
    return built(dae.info.setdefault("_initial_systems", {}), (names, kept),
                 lambda: _build_initial_system(dae, names, kept, conditions))


def _build_initial_system(dae, names: tuple, kept: tuple, conditions: list):
    w, args, res_expr = initial_equations(dae, names, kept, conditions)
    return _residual_pair("init_residual", w, args, res_expr)


def initial_equations(dae, names: tuple, kept: tuple, conditions: list):
    """(w, [t, u, p, d, fixed], residual): the initial system in the unknowns w = (x, z), checked as
    `_initial_system` says; the exported `init` solves the same system (`export/contract.py`)."""
    nx_, nz = dae.x.numel(), dae.z.numel()
    exprs = _start_terms(dae, names)[0]
    w = ca.vertcat(dae.x, dae.z)
    alg = dae.alg(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d)
    ode = dae.ode(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d) if None in kept else None
    states = iter(range(nx_))
    rows = [exprs[k] if k is not None else ode[next(states)] for k in kept]
    rows_expr = rows + [alg[k] for k in range(nz)]
    rows_pattern = _pattern(ca.vertcat(*rows_expr), w) if rows_expr else []
    row_of_w = _match(rows_pattern, nx_ + nz)
    matched_rows = {k for k in row_of_w if k >= 0}
    unmatched = [k for k in range(len(rows_expr)) if k not in matched_rows]
    if unmatched:
        g = nx.Graph()
        g.add_nodes_from(("r", k) for k in range(len(rows_expr)))
        g.add_nodes_from(("w", j) for j in range(nx_ + nz))
        g.add_edges_from((("r", k), ("w", j)) for k, cols in enumerate(rows_pattern) for j in cols)
        _too_many(conditions, unmatched, g, dae)
    missing = int(np.sum(row_of_w < 0))
    if missing:
        _too_few(missing, _underdetermined(rows_pattern, row_of_w), nx_, list(dae.x_names) + list(dae.z_names))
    fixed = ca.SX.sym("fixed", len(rows))
    res_expr = ca.vertcat(ca.vertcat(*rows) - fixed, alg) if rows_expr else ca.SX(0, 1)
    return w, [dae.t, dae.u, dae.p, dae.d, fixed], res_expr


def _modes(dae, d) -> np.ndarray:
    return np.array(dae.d_value if d is None else d, dtype=float).reshape(-1)


def _symbolic_observed(dae):
    """The observed expressions in the model's own symbols, built once per compiled model (a symbolic
    call of the observed function costs as much as the rest of a short simulation)."""
    return built(dae.info, "_observed_symbolic", lambda: dae.observed(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d))


def _match(rows_pattern, n_cols) -> np.ndarray:
    """Maximum bipartite matching rows ↔ columns (`structure.maximum_matching`): for each column its row
    or -1."""
    row_of = np.full(n_cols, -1)
    for row, col in maximum_matching(rows_pattern, n_cols).items():
        row_of[col] = row
    return row_of


def _underdetermined(rows_pattern, row_of_w) -> list[int]:
    """The under-determined part (Dulmage–Mendelsohn) of the initial system: every unknown that an
    alternating path reaches from an unmatched one, i.e. every unknown that some maximum matching leaves
    unmatched. It does not depend on the matching, so an algebraic equation that happened to be matched
    to a state cannot hide that state's missing start value."""
    users = [[] for _ in row_of_w]
    for k, cols in enumerate(rows_pattern):
        for j in cols:
            users[j].append(k)
    col_of_row = {int(k): j for j, k in enumerate(row_of_w) if k >= 0}
    reached = {j for j, k in enumerate(row_of_w) if k < 0}
    stack = list(reached)
    while stack:
        for k in users[stack.pop()]:
            j = col_of_row[k]               # the row is matched, else the matching was not maximum
            if j not in reached:
                reached.add(j)
                stack.append(j)
    return sorted(reached)


def _too_few(missing: int, under: list[int], n_states: int, names_w: list):
    """Name the states among which `missing` start values are needed (algebraic variables only when
    no state is in the under-determined part, which a structurally sound DAE never gives)."""
    states = [j for j in under if j < n_states] or under
    listed = ", ".join(names_w[j] for j in states)
    what = (f"nothing fixes the states {listed}" if len(states) == missing else
            f"{missing} more fixed value{'s are' if missing > 1 else ' is'} needed among the states {listed}")
    raise InitializationError(
        f"too few fixed start values: {what}; give them start values (component arguments such as "
        f"phi_start=, or simulate(start={{...}})), or use simulate(steady_state=True) (guesses do not fix)")


def _pattern(exprs, w) -> list[list[int]]:
    """For each row of exprs, the positions of w it depends on (one sparsity pass, not N² queries)."""
    if exprs.numel() == 0 or w.numel() == 0:
        return [[] for _ in range(exprs.numel())]
    sp = ca.jacobian_sparsity(exprs, w)
    rows = [[] for _ in range(exprs.numel())]
    for r, c in zip(*sp.get_triplet()):
        rows[r].append(c)
    return rows


def _too_many(conditions, unmatched, graph, dae):
    """Name each surplus fixed value with everything it competes with (its connected part of the graph)."""
    alg_labels = dae.info.get("alg_labels", ())
    names_w = list(dae.x_names) + list(dae.z_names)

    def row_label(k):
        if k < len(conditions):
            return f"{conditions[k][0]} = {conditions[k][2]:g}"
        j = k - len(conditions)
        return alg_labels[j] if j < len(alg_labels) else f"algebraic equation {j}"

    lines = []
    for k in unmatched:
        if graph.degree(("r", k)) == 0 and k < len(conditions) and conditions[k][1] is None:
            # der(x) = 0 with a derivative that depends on no unknown: a constant that cannot vanish
            raise InitializationError(
                f"no steady state exists: {conditions[k][0]} is a constant of the model (a constant force or "
                f"torque, a prescribed rate), so steady_state=True cannot make it 0; give start values instead")
        part = nx.node_connected_component(graph, ("r", k))
        rows = sorted(r for side, r in part if side == "r")
        fixed = [row_label(r) for r in rows if r < len(conditions)]
        eqs = [row_label(r) for r in rows if r >= len(conditions)]
        unknowns = sorted(names_w[j] for side, j in part if side == "w")
        lines.append(f"    fixed values {', '.join(fixed)} compete for {', '.join(unknowns)}"
                     + (f" (related by {'; '.join(eqs)})" if eqs else ""))
    steady = any(c[1] is None and c[0].startswith("der(") for c in conditions)
    raise InitializationError("too many fixed start values: more values are fixed than the model has "
                              "free quantities for them; remove one of each group (or make it a guess "
                              "with *_guess=)" + (" — the der(...) = 0 are steady_state=True's, which fixes "
                                                   "every state's rate" if steady else "") + ":\n" + "\n".join(lines))


def solve_algebraic(dae, t: float, x: np.ndarray, z_guess: np.ndarray, u: np.ndarray, p: np.ndarray,
                    d: np.ndarray) -> np.ndarray:
    """Algebraic variables consistent with the states at time t (after an event, or without states)."""
    if dae.z.numel() == 0:
        return np.zeros(0)
    residual, jacobian = built(dae.info, "_algebraic_newton", lambda: _residual_pair(   # once: restarts are frequent
        "alg_at_t", dae.z, [dae.t, dae.x, dae.u, dae.p, dae.d], dae.alg(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d)))
    z, r = _newton(residual, jacobian, np.asarray(z_guess, dtype=float).copy(), (t, x, u, p, d))
    if not np.all(np.isfinite(r)) or np.max(np.abs(r)) > 1e-8 * (1.0 + np.max(np.abs(z))):
        raise InitializationError(f"re-initialisation at t = {t:g} s failed: algebraic residual "
                                  f"{np.max(np.abs(r)):.3g} (variables {', '.join(dae.z_names[:5])})")
    return z
