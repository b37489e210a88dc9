"""Linearisation and equilibria (trim) of a compiled model.

Both read only the `SemiExplicitDAE` (ẋ = f(t,x,z,u,p,d), 0 = g(t,x,z,u,p,d),
y = h(t,x,z,u,p,d)). For an index-1 DAE the algebraic variables are first made
consistent with the operating point (Newton on g = 0) and then eliminated from
the Jacobians with the implicit-function theorem:

    A = f_x − f_z g_z⁻¹ g_x        B = f_u − f_z g_z⁻¹ g_u
    C = h_x − h_z g_z⁻¹ g_x        D = h_u − h_z g_z⁻¹ g_u

`trim` finds a steady state (ẋ = 0, g = 0) with a damped Newton method, either
for given inputs or — with `free_inputs` and `fixed` values — the inputs that
hold a prescribed steady state.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import casadi as ca
import numpy as np

from .caches import builds_symbols
from .core.arguments import mapping, name_list, whole_number
from .core.declarations import finite_number
from .core.errors import InitializationError, InputError, MechnetError, UnknownNameError
from .simulate.initialize import solve_algebraic
from .simulate.integrator import _resolve_params
from .simulate.result import Result, unknown_name

_NEWTON_TOL = 1e-12          # scaled residual at which trim stops iterating
_ACCEPT_TOL = 1e-8           # scaled residual (relative to 1 + |w|) below which a trim point is accepted


@dataclass(frozen=True, eq=False)
class LinearModel:
    """ẋ = A·δx + B·δu, δy = C·δx + D·δu about the operating point (x_op, z_op, u_op) at time t."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    state_names: tuple
    input_names: tuple
    output_names: tuple
    x_op: dict = field(default_factory=dict)
    z_op: dict = field(default_factory=dict)
    u_op: dict = field(default_factory=dict)
    y_op: dict = field(default_factory=dict)
    t: float = 0.0

    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of A (the poles of the linearised model)."""
        if self.A.size == 0:
            return np.zeros(0, dtype=complex)
        return np.linalg.eigvals(self.A)

    def to_scipy(self):
        """The same model as a `scipy.signal.StateSpace`."""
        from scipy.signal import StateSpace
        return StateSpace(self.A, self.B, self.C, self.D)

    def summary(self) -> str:
        eig = self.eigenvalues()
        shown = ", ".join(f"{e.real:.4g}{e.imag:+.4g}j" if e.imag else f"{e.real:.4g}" for e in eig[:8])
        more = f", ... (+{eig.size - 8})" if eig.size > 8 else ""
        return (f"linear model at t = {self.t:g}: {len(self.state_names)} states, {len(self.input_names)} inputs, "
                f"{len(self.output_names)} outputs; eigenvalues: {shown or '-'}{more}")


@dataclass(frozen=True)
class TrimPoint:
    """A steady state: state, algebraic and input values by name, and the largest remaining residual.

    Pass it to `linearize` as the operating point (its inputs and parameters come along).
    """

    x: dict
    z: dict
    u: dict
    residual: float
    t: float = 0.0
    params: dict = field(default_factory=dict)
    iterations: int = 0

    def summary(self) -> str:
        items = ", ".join(f"{k} = {v:.6g}" for k, v in list(self.x.items())[:8])
        inputs = ", ".join(f"{k} = {v:.6g}" for k, v in self.u.items())
        return (f"trim point at t = {self.t:g} ({self.iterations} Newton iterations, residual {self.residual:.3g}): "
                f"{items or '-'}" + (f"; inputs {inputs}" if inputs else ""))


# --------------------------------------------------------------------------------------------- helpers

def _state_values(dae, given: dict, what: str) -> np.ndarray:
    """State vector: given values, else fixed start values, else guesses (declared starts), else 0."""
    for name in given:
        if name not in dae.x_names:
            if name in dae.observed_names:
                raise UnknownNameError(f"{what}: {name!r} is not a state of this model (the states are "
                                       f"{', '.join(dae.x_names) or 'none'}); give the operating point in states")
            raise unknown_name(name, dae.x_names, f"{what}: state")
    return np.array([finite_number(given[n], f"{what}: state {n!r}", InputError) if n in given else
                     float(dae.starts.get(n, dae.guesses.get(n, 0.0))) for n in dae.x_names])


def _input_values(dae, given: dict, what: str) -> np.ndarray:
    u = np.array(dae.u_default, dtype=float).reshape(-1)
    for name, value in given.items():
        if name not in dae.u_names:
            raise unknown_name(name, dae.u_names, f"{what}: input")
        u[dae.u_names.index(name)] = finite_number(value, f"{what}: input {name!r}", InputError)
    return u


def _z_guess(dae, given: dict, what: str) -> np.ndarray:
    return np.array([finite_number(given[n], f"{what}: algebraic {n!r}", InputError) if n in given else
                     float(dae.guesses.get(n, 0.0)) for n in dae.z_names])


def _dense(m) -> np.ndarray:
    return np.asarray(ca.DM(m).full(), dtype=float)


def _jacobians(dae, rows: Optional[list]):
    """Function (t,x,z,u,p,d) -> f_x, f_z, f_u, g_x, g_z, g_u, h_x, h_z, h_u, h (h: observed rows `rows`)."""
    args = [dae.t, dae.x, dae.z, dae.u, dae.p, dae.d]
    f = dae.ode(*args)
    g = dae.alg(*args) if dae.z.numel() else ca.SX(0, 1)
    y = dae.observed(*args)
    h = ca.vertcat(*[y[k] for k in rows]) if rows else ca.SX(0, 1)
    outs = []
    for expr in (f, g, h):
        outs += [ca.jacobian(expr, dae.x), ca.jacobian(expr, dae.z), ca.jacobian(expr, dae.u)]
    return ca.Function("linearize_jacobians", args, outs + [h])


# ------------------------------------------------------------------------------------------- linearize

@builds_symbols
def linearize(cm, x_op=None, u_op=None, *, t: Optional[float] = None, params: Optional[dict] = None,
              outputs=None) -> LinearModel:
    """Linearise the compiled model about an operating point.

    `x_op`: state name -> value (missing states take their start value or
    guess), a `TrimPoint` (its inputs, parameters and algebraics come along) or
    a `Result` (its final state and algebraics, at its final time — inputs and
    parameters of that run are not stored in it: pass `u_op` and `params`).
    `u_op`: input name -> value (default: the inputs' default values). `t`:
    the time (default 0, or the Result's / TrimPoint's time). `outputs`:
    dotted names for the rows of C and D (default: the states, C = I).
    The algebraic variables are solved from the states and eliminated.
    """
    dae = cm.dae
    z_given: dict = {}
    u_given: dict = {}
    p_given: dict = {}
    t_given = 0.0
    if isinstance(x_op, TrimPoint):
        x_given, z_given, u_given = dict(x_op.x), dict(x_op.z), dict(x_op.u)
        p_given, t_given = dict(x_op.params), x_op.t
    elif isinstance(x_op, Result):
        # the compiled model's own states and algebraics at the final point (whatever selection ran there)
        final = x_op.final_values
        x_given = {n: final[n] for n in dae.x_names if n in final}
        z_given = {n: final[n] for n in dae.z_names if n in final}
        t_given = x_op.final_time
    elif x_op is None:
        x_given = {}
    elif isinstance(x_op, dict):
        x_given = dict(x_op)
    else:
        raise MechnetError(f"linearize: x_op must be a dict of state values, a TrimPoint or a Result, "
                           f"not {type(x_op).__name__}")
    t = finite_number(t_given if t is None else t, "linearize(t=...)", InputError)
    u_given.update(mapping(u_op, "linearize(u_op=...)"))
    p_given.update(mapping(params, "linearize(params=...)"))

    x = _state_values(dae, x_given, "linearize(x_op=...)")
    u = _input_values(dae, u_given, "linearize(u_op=...)")
    p = _resolve_params(dae, p_given, "linearize")
    d = np.array(dae.d_value, dtype=float).reshape(-1)
    if dae.z.numel():
        for name in z_given:
            if name not in dae.z_names:
                raise unknown_name(name, dae.z_names, "linearize: algebraic variable")
        try:
            z = solve_algebraic(dae, t, x, _z_guess(dae, z_given, "linearize(x_op=...)"), u, p, d)
        except InitializationError as exc:
            point = ", ".join(f"{n} = {v:g}" for n, v in zip(dae.x_names, x))
            raise InitializationError(f"linearize: the algebraic equations have no solution at the operating "
                                      f"point {point} ({exc})") from None
        z = _polish(dae, t, x, z, u, p, d)
    else:
        z = np.zeros(0)

    out_names = tuple(dae.x_names) if outputs is None else tuple(outputs)
    row = {n: k for k, n in enumerate(dae.observed_names)}
    for name in out_names:
        if name not in row:
            raise unknown_name(name, dae.observed_names, "linearize(outputs=...): output")
    jac = _jacobians(dae, [row[n] for n in out_names])
    fx, fz, fu, gx, gz, gu, hx, hz, hu, h = (_dense(v) for v in jac(t, x, z, u, p, d))
    fx, fu, hx, hu = (m.reshape(r, c) for m, r, c in
                      ((fx, x.size, x.size), (fu, x.size, u.size), (hx, len(out_names), x.size),
                       (hu, len(out_names), u.size)))
    if z.size:
        # singular dependent block: σ_min(g_z) negligible against the size of the algebraic Jacobian
        sigma = np.linalg.svd(gz, compute_uv=False)
        size = max(np.linalg.norm(gx, 2) if gx.size else 0.0, sigma[0], np.linalg.norm(gu, 2) if gu.size else 0.0)
        if not np.all(np.isfinite(sigma)) or sigma[-1] <= 1e-8 * size:
            point = ", ".join(f"{n} = {v:g}" for n, v in zip(dae.x_names, x))
            raise InitializationError(
                f"linearize: the algebraic variables {', '.join(dae.z_names)} are not determined by the states "
                f"at {point} (∂alg/∂z is singular: smallest singular value {sigma[-1]:.3g} against "
                f"{size:.3g} for the algebraic Jacobian); the selected states "
                f"{', '.join(dae.x_names)} do not parametrise the model there — linearise at a nearby point")
        # eliminate z: dz = −g_z⁻¹ (g_x dx + g_u du)
        Zx = -np.linalg.solve(gz, gx)
        Zu = -np.linalg.solve(gz, gu)
        A, B = fx + fz @ Zx, fu + fz @ Zu
        C, D = hx + hz @ Zx, hu + hz @ Zu
    else:
        A, B, C, D = fx, fu, hx, hu
    return LinearModel(A=A, B=B, C=C, D=D, state_names=tuple(dae.x_names), input_names=tuple(dae.u_names),
                       output_names=out_names,
                       x_op=dict(zip(dae.x_names, x.tolist())), z_op=dict(zip(dae.z_names, z.tolist())),
                       u_op=dict(zip(dae.u_names, u.tolist())), y_op=dict(zip(out_names, h.ravel().tolist())),
                       t=t)


def _polish(dae, t, x, z, u, p, d) -> np.ndarray:
    """Newton on alg(z) = 0 until rounding stops it: exact z for the Jacobians, and near a singular
    dependent block z runs into the singularity (linear convergence) where it is detected."""
    zs = ca.SX.sym("z", dae.z.numel())
    g = dae.alg(t, x, zs, u, p, d)
    F = ca.Function("alg_z", [zs], [g])
    J = ca.Function("alg_z_jacobian", [zs], [ca.jacobian(g, zs)])
    z_new, r, _ = _damped_newton(F, J, z, np.ones(dae.z.numel()), 100, tol=0.0)
    return z_new if np.all(np.isfinite(r)) else z


# ------------------------------------------------------------------------------------------------ trim

@builds_symbols
def trim(cm, *, inputs: Optional[dict] = None, fixed: Optional[dict] = None, free_inputs=(),
         guess: Optional[dict] = None, params: Optional[dict] = None, t: float = 0.0,
         max_iter: int = 100) -> TrimPoint:
    """Steady state of the compiled model: ẋ = 0 and alg = 0.

    `inputs`: input name -> value (others take their default). `free_inputs`:
    input names to solve for; `fixed`: dotted name -> value held at the steady
    state (normally states). The system is square only with as many free
    inputs as fixed values. `guess`: starting values for states, algebraics
    and free inputs (default: start values and guesses of the model).
    Raises InitializationError naming the largest residual if Newton fails.
    """
    dae = cm.dae
    inputs, fixed = mapping(inputs, "trim(inputs=...)"), mapping(fixed, "trim(fixed=...)")
    guess = mapping(guess, "trim(guess=...)")
    t = finite_number(t, "trim(t=...)", InputError)
    max_iter = whole_number(max_iter, "trim(max_iter=...)", 1, InputError)
    free_inputs = tuple(name_list(free_inputs, "trim(free_inputs=...)", InputError))
    nx_, nz = dae.x.numel(), dae.z.numel()
    for name in free_inputs:
        if name not in dae.u_names:
            raise unknown_name(name, dae.u_names, "trim(free_inputs=...): input")
    if len(set(free_inputs)) != len(free_inputs):
        raise MechnetError(f"trim: free_inputs {free_inputs} names an input twice")
    for name in fixed:
        if name not in dae.observed_names:
            raise unknown_name(name, dae.observed_names, "trim(fixed=...): variable")
        fixed[name] = finite_number(fixed[name], f"trim(fixed=...): {name!r}", InputError)
    if len(free_inputs) != len(fixed):
        raise InitializationError(
            f"trim: {len(fixed)} fixed value(s) ({', '.join(fixed) or 'none'}) but {len(free_inputs)} free "
            f"input(s) ({', '.join(free_inputs) or 'none'}); the steady-state system is square only with one "
            f"free input per fixed value")
    u0 = _input_values(dae, inputs, "trim(inputs=...)")
    p = _resolve_params(dae, params, "trim")
    d = np.array(dae.d_value, dtype=float).reshape(-1)
    unknown_names = list(dae.x_names) + list(dae.z_names) + list(free_inputs)
    for name in guess:
        if name not in unknown_names:
            raise unknown_name(name, unknown_names, "trim(guess=...): unknown")

    # unknowns w = (x, z, free inputs); residual = (ode, alg, fixed rows)
    free_idx = [dae.u_names.index(n) for n in free_inputs]
    uf = ca.SX.sym("u_free", len(free_idx))
    u_expr = ca.SX(ca.DM(u0))
    for k, j in enumerate(free_idx):
        u_expr[j] = uf[k]
    args = [t, dae.x, dae.z, u_expr, p, d]
    y = dae.observed(*args)
    row = {n: k for k, n in enumerate(dae.observed_names)}
    res = ca.vertcat(dae.ode(*args), dae.alg(*args) if nz else ca.SX(0, 1),
                     *[y[row[n]] - v for n, v in fixed.items()])
    w = ca.vertcat(dae.x, dae.z, uf)
    F = ca.Function("trim_residual", [w], [res])
    J = ca.Function("trim_jacobian", [w], [ca.jacobian(res, w)])

    alg_labels = dae.info.get("alg_labels", ())
    labels = ([f"der({n}) = 0" for n in dae.x_names]
              + [alg_labels[k] if k < len(alg_labels) else f"algebraic equation {k} ({dae.z_names[k]})"
                 for k in range(nz)]
              + [f"fixed value {n} = {float(v):g}" for n, v in fixed.items()])
    # residual scaling: der(x) rows by the state's nominal value, fixed rows by the named value's nominal
    nominal = dae.info.get("nominal", {}) if isinstance(dae.info.get("nominal", {}), dict) else {}
    scale = np.concatenate([np.array(dae.x_nominal, dtype=float).reshape(-1),
                            np.ones(nz),
                            [float(nominal.get(n, 1.0)) for n in fixed]]) if res.numel() else np.zeros(0)
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)

    x0 = _state_values(dae, {n: v for n, v in guess.items() if n in dae.x_names}, "trim(guess=...)")
    for n, v in fixed.items():            # a fixed state starts at its value
        if n in dae.x_names and n not in guess:
            x0[dae.x_names.index(n)] = float(v)
    z0 = _z_guess(dae, guess, "trim(guess=...)")
    f0 = np.array([finite_number(guess[n], f"trim(guess=...): input {n!r}", InputError) if n in guess else u0[j]
                   for n, j in zip(free_inputs, free_idx)])
    w0 = np.concatenate([x0, z0, f0])

    if w0.size == 0:
        return TrimPoint({}, {}, dict(zip(dae.u_names, u0.tolist())), 0.0, t, dict(params or {}), 0)
    sol, r, iterations = _damped_newton(F, J, w0, scale, max_iter)
    rs = r / scale
    tol = _ACCEPT_TOL * (1.0 + np.max(np.abs(sol), initial=0.0))
    if rs.size and not (np.all(np.isfinite(rs)) and np.max(np.abs(rs)) <= tol):
        worst = int(np.nanargmax(np.where(np.isfinite(rs), np.abs(rs), np.inf)))
        given = ", ".join(f"{n} = {v:g}" for n, v in zip(dae.u_names, u0) if n not in free_inputs)
        raise InitializationError(
            f"trim: no steady state found after {iterations} Newton iterations; largest residual "
            f"{r[worst]:.3g} in {labels[worst]}"
            + ("" if np.isfinite(r[worst]) else " (the equations cannot be evaluated at this point)")
            + (f" (inputs {given})" if given else "")
            + (f", solving for {', '.join(free_inputs)}" if free_inputs else "")
            + "; try another guess=, or check that a steady state exists for these inputs")
    u = u0.copy()
    u[free_idx] = sol[nx_ + nz:]
    return TrimPoint(x=dict(zip(dae.x_names, sol[:nx_].tolist())), z=dict(zip(dae.z_names, sol[nx_:nx_ + nz].tolist())),
                     u=dict(zip(dae.u_names, u.tolist())), residual=float(np.max(np.abs(r), initial=0.0)),
                     t=float(t), params=dict(params or {}), iterations=iterations)


def _damped_newton(F, J, w0, scale, max_iter, tol=_NEWTON_TOL):
    """Newton with an Armijo backtracking line search on ½‖r/scale‖²; least squares where J is singular."""
    w = w0.astype(float).copy()
    r = np.asarray(F(w), dtype=float).ravel()
    steps = 0
    for _ in range(max_iter):
        rs = r / scale
        norm = np.linalg.norm(rs)
        if not np.all(np.isfinite(rs)):
            break
        if np.max(np.abs(rs), initial=0.0) <= tol * (1.0 + np.max(np.abs(w), initial=0.0)):
            break
        Jm = _dense(J(w)) / scale[:, None]
        step = None
        if Jm.shape[0] == Jm.shape[1]:
            try:
                if np.linalg.cond(Jm) < 1e13:
                    step = np.linalg.solve(Jm, -rs)
            except np.linalg.LinAlgError:
                step = None
        if step is None:   # singular (e.g. a free rigid-body coordinate): minimum-norm least-squares step
            step = np.linalg.lstsq(Jm, -rs, rcond=None)[0]
        lam, accepted = 1.0, False
        while lam > 1e-8:
            trial = w + lam * step
            rt = np.asarray(F(trial), dtype=float).ravel()
            if np.all(np.isfinite(rt)) and np.linalg.norm(rt / scale) <= (1.0 - 1e-4 * lam) * norm:
                accepted = True
                break
            lam *= 0.5
        if not accepted:      # no decrease along the Newton direction: converged to rounding, or stuck
            break
        w, r = trial, rt
        steps += 1
        if np.max(np.abs(lam * step), initial=0.0) <= 1e-15 * (1.0 + np.max(np.abs(w), initial=0.0)):
            break
    return w, r, steps
