"""Simulation with SUNDIALS through `casadi.integrator`.

States are integrated in scaled form (x = nominal · xs) so that one absolute
tolerance means `atol · nominal` for each variable. Time is normalised over a
segment (t = t0 + τ·h, τ ∈ [0, 1]) with t0 and h as parameters, so one
integrator serves every segment with the same output pattern: the event loop
of later issues restarts segments without rebuilding anything.

A failed integration never surfaces as a CasADi traceback: the grid is
re-integrated interval by interval up to the failure, and the partial result
comes back with an `IntegrationError` describing the time, the step size and
the worst variable.
"""
from __future__ import annotations

import re
import time as _time
import warnings

import casadi as ca
import numpy as np

from ..core.errors import IntegrationError, MechnetError
from .initialize import initialize
from .result import Result, unknown_name

METHODS = ("auto", "idas", "cvodes-bdf", "cvodes-adams")


class IntegrationWarning(UserWarning):
    """Issued when simulate() returns a partial result after a solver failure."""


def _plugin(dae, method: str) -> tuple[str, dict]:
    if method not in METHODS:
        raise MechnetError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if method == "auto":
        method = "cvodes-bdf" if dae.is_ode else "idas"
    if method.startswith("cvodes") and not dae.is_ode:
        raise MechnetError(f"method {method!r} needs an explicit ODE, but this model keeps "
                           f"{dae.z.numel()} algebraic variables ({', '.join(dae.z_names[:5])}); use 'idas' or 'auto'")
    if method == "idas":
        return "idas", {}
    if method == "cvodes-bdf":
        return "cvodes", {"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton"}
    return "cvodes", {"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"}


def _build(dae, plugin: str, extra: dict, grid: tuple, rtol: float, atol: float, max_steps: int):
    """One integrator on the normalised grid; parameters are [u; p; d; t0; h]."""
    xs = ca.SX.sym("xs", dae.x.numel())
    zs = ca.SX.sym("zs", dae.z.numel())
    tau = ca.SX.sym("tau")
    t0, h = ca.SX.sym("t0"), ca.SX.sym("h")
    xn = ca.DM(list(dae.x_nominal)) if dae.x_nominal else ca.DM(0, 1)
    zn = ca.DM(list(dae.z_nominal)) if dae.z_nominal else ca.DM(0, 1)
    t = t0 + tau * h
    x = xn * xs
    z = zn * zs
    args = (t, x, z, dae.u, dae.p, dae.d)
    ode = h * dae.ode(*args) / xn
    spec = {"x": xs, "t": tau, "p": ca.vertcat(dae.u, dae.p, dae.d, t0, h), "ode": ode}
    if dae.z.numel():
        spec["z"] = zs
        spec["alg"] = dae.alg(*args)
    opts = dict(extra, reltol=rtol, abstol=atol, max_num_steps=max_steps,
                disable_internal_warnings=True, show_eval_warnings=False)
    return ca.integrator("F", plugin, spec, 0.0, list(grid), opts)


def _resolve(kind: str, given: dict | None, names: tuple, defaults: tuple) -> np.ndarray:
    values = np.array(defaults, dtype=float)
    for name, value in (given or {}).items():
        if name not in names:
            raise unknown_name(name, names, kind)
        if not np.isscalar(value):
            raise MechnetError(f"{kind} {name!r}: only constant values are supported here, got {type(value).__name__}")
        value = float(value)
        if not np.isfinite(value):
            raise MechnetError(f"{kind} {name!r} = {value}: must be finite")
        values[names.index(name)] = value
    return values


def simulate(cm, t_end: float, *, t_start: float = 0.0, rtol: float = 1e-6, atol: float = 1e-8,
             method: str = "auto", n_out: int | None = None, t_out=None, params: dict | None = None,
             inputs: dict | None = None, start: dict | None = None, guess: dict | None = None,
             max_steps: int = 20_000) -> Result:
    """Integrate the compiled model; see DESIGN.md for the meaning of each argument.

    `start` fixes values (any dotted name), `guess` only seeds the Newton
    iteration. A solver failure returns the partial result with `result.failure`
    set (and a warning); it does not raise.
    """
    dae = cm.dae
    plugin, extra = _plugin(dae, method)
    if not (np.isfinite(t_end) and t_end > t_start):
        raise MechnetError(f"t_end = {t_end} must be finite and greater than t_start = {t_start}")
    if t_out is not None:
        grid = np.asarray(t_out, dtype=float)
        if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0):
            raise MechnetError("t_out must be an increasing sequence of at least two times")
        t_start, t_end = float(grid[0]), float(grid[-1])
    else:
        grid = np.linspace(t_start, t_end, int(n_out or 501))
    u = _resolve("input", inputs, dae.u_names, dae.u_default)
    p = _resolve("parameter", params, dae.p_names, dae.p_value)
    d = np.array(dae.d_value, dtype=float)
    starts = dict(dae.starts)
    for name, value in (start or {}).items():
        if name not in dae.observed_names:
            raise unknown_name(name, dae.observed_names, "start value for")
        starts[name] = float(value)
    for name in (guess or {}):
        if name not in dae.observed_names:
            raise unknown_name(name, dae.observed_names, "guess for")

    wall = _time.perf_counter()
    init = initialize(dae, t_start, u, p, starts, guess or {})
    xn = np.array(dae.x_nominal, dtype=float)
    zn = np.array(dae.z_nominal, dtype=float)
    h = t_end - t_start
    tau = tuple(float(v) for v in (grid[1:] - t_start) / h)
    pvec = np.concatenate([u, p, d, [t_start, h]])
    key = (plugin, tuple(sorted(extra.items())), tau, rtol, atol, max_steps)
    failure = None
    stats = {}
    if dae.x.numel() == 0:
        X = np.zeros((grid.size, 0))
        Z = np.tile(init.z, (grid.size, 1))
    else:
        if key not in cm._integrators:
            cm._integrators[key] = _build(dae, plugin, extra, tau, rtol, atol, max_steps)
        F = cm._integrators[key]
        try:
            out = F(x0=init.x / xn, z0=init.z / zn if zn.size else [], p=pvec)
            X = np.vstack([init.x, (np.asarray(out["xf"]).T * xn)])
            Z = np.vstack([init.z, (np.asarray(out["zf"]).T * zn)]) if zn.size else np.zeros((grid.size, 0))
            stats = _stats(F, h)
        except RuntimeError as exc:
            grid, X, Z, failure, stats = _recover(cm, dae, plugin, extra, grid, init, pvec, xn, zn, rtol,
                                                 atol, max_steps, u, p, d, str(exc))
    stats["wall_time"] = _time.perf_counter() - wall
    stats["method"] = method if method != "auto" else ("cvodes-bdf" if dae.is_ode else "idas")
    stats["plugin"] = plugin
    values = _observe(dae, grid, X, Z, u, p, d)
    result = Result(grid, values, dae.observed_names, dae.units, stats, X, Z, dae.x_names,
                    failure=failure, initial={"fixed": init.fixed, "free_states": init.free_states,
                                              "residual": init.residual})
    if failure is not None:
        failure.result = result
        warnings.warn(str(failure), IntegrationWarning, stacklevel=2)
    return result


def _stats(F, h: float) -> dict:
    s = F.stats()
    keys = ("nsteps", "nfevals", "nlinsetups", "netfails", "nniters", "nncfails", "qlast")
    out = {k: s[k] for k in keys if k in s}
    out["hlast"] = float(s.get("hlast", float("nan"))) * h     # the solver runs in normalised time
    return out


def _observe(dae, grid, X, Z, u, p, d) -> np.ndarray:
    n = grid.size
    if n == 0:
        return np.zeros((0, len(dae.observed_names)))
    obs = dae.observed.map(n)
    y = obs(grid.reshape(1, -1), X.T, Z.T, np.tile(u.reshape(-1, 1), n),
            np.tile(p.reshape(-1, 1), n), np.tile(d.reshape(-1, 1), n))
    return np.asarray(y).T


def _recover(cm, dae, plugin, extra, grid, init, pvec, xn, zn, rtol, atol, max_steps, u, p, d, message):
    """Re-integrate one output interval at a time up to the failure, then close in on it.

    The failing interval is split in eight, three times over, so the partial
    result ends within 1/512 of an output interval of the failure.
    """
    key = (plugin, tuple(sorted(extra.items())), (1.0,), rtol, atol, max_steps)
    if key not in cm._integrators:
        cm._integrators[key] = _build(dae, plugin, extra, (1.0,), rtol, atol, max_steps)
    F1 = cm._integrators[key]
    xs, zs = init.x / xn, (init.z / zn if zn.size else np.zeros(0))
    T, X, Z = [grid[0]], [init.x], [init.z]
    step = float("nan")
    solver = _solver_message(message)

    def advance(t_a, t_b):
        nonlocal xs, zs, step, solver
        pk = pvec.copy()
        pk[-2], pk[-1] = t_a, t_b - t_a
        try:
            out = F1(x0=xs, z0=zs, p=pk)
        except RuntimeError as exc:
            solver = _solver_message(str(exc))
            return False
        step = float(F1.stats().get("hlast", float("nan"))) * (t_b - t_a)
        xs = np.asarray(out["xf"]).ravel()
        zs = np.asarray(out["zf"]).ravel() if zn.size else np.zeros(0)
        T.append(t_b)
        X.append(xs * xn)
        Z.append(zs * zn)
        return True

    k = 0
    while k < grid.size - 1 and advance(grid[k], grid[k + 1]):
        k += 1
    t_fail = grid[min(k + 1, grid.size - 1)]
    if k < grid.size - 1:
        lo, hi = grid[k], grid[k + 1]
        for _ in range(3):
            pieces = np.linspace(lo, hi, 9)
            j = 0
            while j < 8 and advance(pieces[j], pieces[j + 1]):
                j += 1
            lo, hi = pieces[j], pieces[min(j + 1, 8)]
        t_fail = hi
    X, Z = np.array(X), np.array(Z).reshape(len(X), -1)
    worst = _worst_variable(dae, T[-1], X[-1], Z[-1], u, p, d, xn)
    err = IntegrationError(
        f"integration failed between t = {T[-1]:.6g} s and {t_fail:.6g} s (last step size {step:.3g} s); "
        f"worst variable: {worst}; solver: {solver}. The result holds the solution up to t = {T[-1]:.6g} s",
        t=float(T[-1]), step=step, worst=worst, solver_message=solver)
    return np.array(T), X, Z, err, {"failed_at": float(T[-1])}


def _solver_message(text: str) -> str:
    """The SUNDIALS return code out of CasADi's error text (e.g. CV_TOO_MUCH_WORK)."""
    found = re.search(r'returned "?([A-Z_]+)"?', text)
    if found:
        return found.group(1)
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else "unknown solver error"


def _worst_variable(dae, t, x, z, u, p, d, xn) -> str:
    """The state changing fastest relative to its size at the last good point (or a non-finite one)."""
    if x.size == 0:
        return "-"
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        return dae.x_names[bad[0]]
    xdot = np.asarray(dae.ode(t, x, z, u, p, d)).ravel()
    if not np.all(np.isfinite(xdot)):
        return dae.x_names[int(np.flatnonzero(~np.isfinite(xdot))[0])]
    rate = np.abs(xdot) / np.maximum(np.abs(x), xn)
    k = int(np.argmax(rate))
    return f"{dae.x_names[k]} (value {x[k]:.4g}, rate {xdot[k]:.4g}/s)"
