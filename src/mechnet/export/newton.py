"""A damped Newton method built from CasADi Functions, so it code-generates.

CasADi 3.8's own `rootfinder` generates C only as 'fast_newton' (no damping),
and the simulator's Newton calls SciPy; an FMU needs the same damped iteration
as the simulator, in C. Each iteration is a `Function.conditional`, so the
generated code evaluates only the branch taken: once converged the remaining
iterations cost nothing, and the line search tries halved steps one after
another, stopping at the first that decreases the residual.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

MAX_ITER = 40          # iterations (a loop in C); a start from a guess needs ~5-15, a warm start 1-3
BACKTRACKS = 12        # step halvings tried before the smallest is taken (as the simulator's Newton)
TOL = 1e-10            # converged: max |residual| <= TOL * (1 + max |w|) (the simulator's criterion)


def _inf_norm(v):
    return ca.mmax(ca.fabs(v)) if v.numel() else ca.MX(0)


def linear_solve(A, b):
    """A⁻¹ b by CasADi's sparse QR (it generates C); a diagonal A by division, which is exact and
    cheaper, and which CasADi 3.8 can also read back (a QR solve of a diagonal pattern does not load)."""
    if A.sparsity().is_diag() and A.size1() > 1:
        return b / ca.diag(A)
    return ca.solve(A, b, "qr")


def damped_newton(name: str, residual: ca.SX, w: ca.SX, args: list, max_iter: int = MAX_ITER,
                  backtracks: int = BACKTRACKS, tol: float = TOL) -> ca.Function:
    """Function name(w0, *args) -> (w, residual_norm) solving residual(w, *args) = 0 from w0 (args:
    column SX symbols). `residual_norm` is max |residual| at the returned w: the caller decides whether
    that is converged (a singular Jacobian leaves non-finite values there). One plain Newton step
    follows convergence: it costs one Jacobian and takes a quadratically converging iterate from the
    stopping tolerance to round-off (derivatives taken by differences of the result need that)."""
    n = w.numel()
    res = ca.Function(f"{name}_residual", [w, *args], [residual])
    jac = ca.Function(f"{name}_jacobian", [w, *args], [ca.jacobian(residual, w)])
    wm, step, norm0 = ca.MX.sym("w", n), ca.MX.sym("step", n), ca.MX.sym("norm0")
    # the arguments travel packed in one vector, and not at all when empty: a zero-size argument through
    # mapaccum generates C that newer compilers refuse (an int passed as a pointer)
    sizes = [a.numel() for a in args]
    packed = ca.MX.sym("args", sum(sizes))
    extra = [packed] if sum(sizes) else []
    pm = ca.vertsplit(packed, list(np.cumsum([0, *sizes]))) if extra else [ca.MX(k, 1) for k in sizes]
    search_in = [wm, step, norm0, *extra]

    # the line search from its last resort (the smallest step, taken whatever it gives) outwards
    search = ca.Function(f"{name}_try{backtracks}", search_in, [wm + 0.5 ** backtracks * step])
    for k in range(backtracks - 1, -1, -1):
        trial = wm + 0.5 ** k * step
        decreased = _inf_norm(res(trial, *pm)) < (1 - 1e-4 * 0.5 ** k) * norm0
        take = ca.Function(f"{name}_take{k}", search_in, [trial])
        pick = ca.Function.conditional(f"{name}_pick{k}", [search], take)       # 0: try a smaller step
        search = ca.Function(f"{name}_try{k}", search_in, [pick(decreased, *search_in)])

    # one iteration on (w, done): a finished iteration passes its point through untouched
    done = ca.MX.sym("done")
    r = res(wm, *pm)
    norm = _inf_norm(r)
    converged = norm <= tol * (1 + _inf_norm(wm))
    moved = search(wm, -linear_solve(jac(wm, *pm), r), norm, *extra)
    work = ca.Function(f"{name}_work", [wm, done, *extra], [ca.if_else(converged, wm, moved), converged])
    keep = ca.Function(f"{name}_keep", [wm, done, *extra], [wm, done])
    iterate = ca.Function.conditional(f"{name}_iterate", [work], keep)          # 0: not done yet
    carried = ca.vertcat(*iterate(done, wm, done, *extra))
    body = ca.Function(f"{name}_body", [ca.vertcat(wm, done), *extra], [carried])

    w0 = ca.MX.sym("w0", n)
    loop = body.mapaccum(f"{name}_loop", max_iter)
    out = loop(ca.vertcat(w0, 0), *[ca.repmat(a, 1, max_iter) for a in extra])
    w_end = out[:n, -1]
    polished = w_end - linear_solve(jac(w_end, *pm), res(w_end, *pm))
    w_end = ca.if_else(_inf_norm(res(polished, *pm)) <= _inf_norm(res(w_end, *pm)), polished, w_end)
    solve = ca.Function(f"{name}_packed", [w0, *extra], [w_end, _inf_norm(res(w_end, *pm))])
    outer = [ca.MX.sym(f"arg{k}", k_size) for k, k_size in enumerate(sizes)]
    return ca.Function(name, [w0, *outer], solve(w0, *([ca.vertcat(*outer)] if extra else [])),
                       ["w0", *[f"arg{k}" for k in range(len(outer))]], ["w", "residual_norm"])
