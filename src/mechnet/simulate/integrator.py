"""Simulation with SUNDIALS through `casadi.integrator`.

States are integrated in scaled form (x = nominal · xs) so that one absolute
tolerance means `atol · nominal` for each variable. Plain segments run on their
own real-time grid (cached, so simulating the same grid again reuses it);
monitored pieces and failure recovery use a time normalised over the piece
(t = t0 + τ·h, τ ∈ [0, 1], t0 and h parameters), so one integrator serves every
piece with the same output pattern.

The run is split into segments at time events (signal steps, table knots)
and, for long grids, into a fixed number of chunks (for the progress bar):
the integrator restarts exactly at each boundary, deterministically.

A failed integration never surfaces as a CasADi traceback: the failing
segment is re-integrated interval by interval up to the failure, and the
partial result comes back with an `IntegrationError` describing the time, the
step size and the worst variable.
"""
from __future__ import annotations

import re
import time as _time
import warnings

import casadi as ca
import numpy as np

from ..core.errors import IntegrationError, MechnetError, ParameterError, UnknownNameError
from .events import Event, breakpoints, chunk_bounds, output_grid
from .initialize import initialize, solve_algebraic
from .inputs import plan_inputs
from .result import Result, unknown_name

METHODS = ("auto", "idas", "cvodes-bdf", "cvodes-adams")
PROGRESS_CHUNKS = 20
PROGRESS_MIN_POINTS = 1000
PROGRESS_AFTER_SECONDS = 1.0


class IntegrationWarning(UserWarning):
    """Issued when simulate() returns a partial result after a solver failure."""


def _plugin(dae, method: str) -> tuple[str, str, dict]:
    if method not in METHODS:
        raise MechnetError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if method == "auto":
        method = "cvodes-bdf" if dae.is_ode else "idas"
    if method.startswith("cvodes") and not dae.is_ode:
        raise MechnetError(f"method {method!r} needs an explicit ODE, but this model keeps "
                           f"{dae.z.numel()} algebraic variables ({', '.join(dae.z_names[:5])}); use 'idas' or 'auto'")
    if method == "idas":
        return method, "idas", {}
    if method == "cvodes-bdf":
        return method, "cvodes", {"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton"}
    return method, "cvodes", {"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"}


class _Integrators:
    """Builds and caches one integrator per output pattern (normalised grid)."""

    def __init__(self, cm, dae, plugin, extra, rtol, atol, max_steps, inputs):
        self.cm, self.dae, self.plugin, self.extra = cm, dae, plugin, extra
        self.rtol, self.atol, self.max_steps = rtol, atol, max_steps
        self.inputs = inputs
        self.base_key = (id(dae), plugin, tuple(sorted(extra.items())), rtol, atol, max_steps, inputs.key())

    def get(self, tau: tuple):
        """Integrator over a normalised grid (t = t0 + τ·h): reusable for every segment of that pattern."""
        key = self.base_key + (tau,)
        if key not in self.cm._integrators:
            self.cm._integrators[key] = self._build(tau)
        return self.cm._integrators[key]

    def get_real(self, points: tuple):
        """Integrator over a fixed grid in real time: no time scaling in the right-hand side.

        Used for plain segments (reused when the same grid is simulated again);
        the parameters keep the [u; p; d; t0; h] layout, t0 and h unused.
        """
        key = self.base_key + ("real", points)
        if key not in self.cm._integrators:
            self.cm._integrators[key] = self._build(tuple(points[1:]), t0_real=points[0])
        return self.cm._integrators[key]

    def _build(self, tau: tuple, t0_real=None):
        """Parameters of the integrator: [u; p; d; t0; h]."""
        dae = self.dae
        sym = ca.MX if self.inputs.varying else ca.SX
        xs, zs = sym.sym("xs", dae.x.numel()), sym.sym("zs", dae.z.numel())
        s, t0, h = sym.sym("tau"), sym.sym("t0"), sym.sym("h")
        u, p, d = sym.sym("u", dae.u.numel()), sym.sym("p", dae.p.numel()), sym.sym("d", dae.d.numel())
        xn = ca.DM(list(dae.x_nominal)) if dae.x_nominal else ca.DM(0, 1)
        zn = ca.DM(list(dae.z_nominal)) if dae.z_nominal else ca.DM(0, 1)
        t = t0 + s * h if t0_real is None else s
        if self.inputs.varying:
            interp = self.inputs.interpolants()
            u_t = ca.vertcat(*[interp[k](t) if k in interp else u[k] for k in range(dae.u.numel())])
        else:
            u_t = u
        args = (t, xn * xs, zn * zs, u_t, p, d)
        rate = dae.ode(*args) / xn
        spec = {"x": xs, "t": s, "p": ca.vertcat(u, p, d, t0, h), "ode": h * rate if t0_real is None else rate}
        if dae.z.numel():
            spec["z"] = zs
            spec["alg"] = dae.alg(*args)
        opts = dict(self.extra, reltol=self.rtol, abstol=self.atol, max_num_steps=self.max_steps,
                    disable_internal_warnings=True, show_eval_warnings=False)
        return ca.integrator("F", self.plugin, spec, 0.0 if t0_real is None else float(t0_real), list(tau), opts)


def simulate(cm, t_end: float, *, t_start: float = 0.0, rtol: float = 1e-6, atol: float = 1e-8,
             method: str = "auto", n_out: int | None = None, t_out=None, params: dict | None = None,
             inputs: dict | None = None, start: dict | None = None, guess: dict | None = None,
             max_steps: int = 20_000, progress: bool | None = None, steady_state: bool = False) -> Result:
    """Integrate the compiled model from `t_start` to `t_end`.

    `start` fixes values (any dotted name), `guess` only seeds the Newton
    iteration; `inputs` maps input names to numbers, callables f(t), (times,
    values) pairs or N×2 arrays. `steady_state=True` starts from der(x) = 0
    (every state; fixed start values then over-specify). `progress=None` shows a bar when a long grid
    (≥ 1000 points) takes more than a second. A solver failure returns the
    partial result with `result.failure` set (and a warning); it does not raise.
    """
    dae = cm.dae
    method, plugin, extra = _plugin(dae, method)
    if t_out is not None:
        grid = np.asarray(t_out, dtype=float)
        if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0) or not np.all(np.isfinite(grid)):
            raise MechnetError("t_out must be an increasing sequence of at least two finite times")
        t_start, t_end = float(grid[0]), float(grid[-1])
    else:
        if not (np.isfinite(t_end) and np.isfinite(t_start) and t_end > t_start):
            raise MechnetError(f"t_end = {t_end} must be finite and greater than t_start = {t_start}")
        grid = np.linspace(t_start, t_end, int(n_out or 501))
    plan = plan_inputs(dae, inputs, t_start, t_end, max(grid.size, 2001))
    p = _resolve_params(dae, params)
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
    init = initialize(dae, t_start, plan.constant, p, starts, guess or {}, steady_state)
    events = breakpoints(dae.time_events, t_start, t_end)
    grid = output_grid(grid, events)
    run = _Run(cm, dae, plugin, extra, rtol, atol, max_steps, plan, p, d, init)
    run.integrate(grid, events, progress)
    stats = run.stats
    stats["wall_time"] = _time.perf_counter() - wall
    stats["method"], stats["plugin"] = method, plugin
    T = np.array(run.T)
    values = np.empty((T.size, len(dae.observed_names)))
    k = 0
    while k < T.size:                      # rows integrated with the same selection, observed together
        j = k
        while j + 1 < T.size and run.D[j + 1] is run.D[k]:
            j += 1
        sel = run.D[k]
        X = np.array(run.X[k: j + 1]).reshape(j + 1 - k, -1)
        Z = np.array(run.Z[k: j + 1]).reshape(j + 1 - k, -1)
        values[k: j + 1] = _observe(sel, T[k: j + 1], X, Z, plan, p, d)
        k = j + 1
    column = {n: c for c, n in enumerate(dae.observed_names)}
    final = run.D[-1] if run.D else dae
    X = values[:, [column[n] for n in final.x_names if n in column]] \
        if all(n in column for n in final.x_names) else np.array(run.X)
    Z = np.zeros((T.size, 0))
    result = Result(T, values, dae.observed_names, dae.units, stats, X, Z, final.x_names,
                    events=run.events, failure=run.failure,
                    initial={"fixed": init.fixed, "free_states": init.free_states, "residual": init.residual})
    if run.failure is not None:
        run.failure.result = result
        warnings.warn(str(run.failure), IntegrationWarning, stacklevel=3)
    return result


def _resolve_params(dae, given: dict | None) -> np.ndarray:
    values = np.array(dae.p_value, dtype=float)
    checks = dae.info.get("parameter_checks", {})
    for name, value in (given or {}).items():
        if name not in dae.p_names:
            if name in dae.info.get("folded_parameters", ()):
                short = name.rsplit(".", 1)[-1]
                raise UnknownNameError(f"parameter {name!r} was folded into the equations as a number at compile "
                                     f"time; declare it as {short}=mn.tunable(...) to change it per run")
            raise unknown_name(name, dae.p_names, "tunable parameter")
        declaration, owner = checks.get(name, (None, name))
        if declaration is not None:
            try:
                values[dae.p_names.index(name)] = declaration.validate(owner, value)
            except ParameterError as exc:
                raise ParameterError(f"simulate(params={{{name!r}: ...}}): {exc}") from None
        else:
            values[dae.p_names.index(name)] = float(value)
    return values


class _Run:
    """The segment loop: integrate between boundaries, restart at events, stop at a failure."""

    def __init__(self, cm, dae, plugin, extra, rtol, atol, max_steps, plan, p, d, init):
        self.cm, self.plan, self.p, self.d = cm, plan, p, d
        self.settings = (plugin, extra, rtol, atol, max_steps)
        self._use(dae)
        self.T, self.X, self.Z, self.D = [], [], [], []
        self.events: list[Event] = []
        self.failure = None
        self.stats = {"nsteps": 0, "nfevals": 0, "netfails": 0, "segments": 0}
        self.x, self.z = init.x.copy(), init.z.copy()

    def _use(self, dae):
        plugin, extra, rtol, atol, max_steps = self.settings
        self.dae = dae
        self.integrators = _Integrators(self.cm, dae, plugin, extra, rtol, atol, max_steps, self.plan)
        self.xn = np.array(dae.x_nominal, dtype=float)
        self.zn = np.array(dae.z_nominal, dtype=float)

    def _record(self, t):
        self.T.append(t)
        self.X.append(self.x.copy())
        self.Z.append(self.z.copy())
        self.D.append(self.dae)

    def pvec(self, t0, h):
        return np.concatenate([self.plan.constant, self.p, self.d, [t0, h]])

    def integrate(self, grid, events, progress):
        self.monitor = _SelectionMonitor.create(self.cm, self.dae)
        if self.monitor is not None:
            self._reselect(grid[0])
        self._record(grid[0])
        if self.dae.x.numel() == 0:
            for t in grid[1:]:
                self.z = solve_algebraic(self.dae, t, self.x, self.z, self._u_at(t), self.p, self.d)
                self._record(t)
            return
        event_at = {t: cause for t, cause in events}
        if self.monitor is not None or self.dae.zero_labels:
            self._integrate_monitored(grid, event_at)
            return
        cuts = sorted({int(np.searchsorted(grid, t)) for t in event_at}
                      | set(chunk_bounds(grid.size, PROGRESS_CHUNKS if grid.size >= PROGRESS_MIN_POINTS else 1)))
        bounds = [0] + [c for c in cuts if 0 < c < grid.size - 1] + [grid.size - 1]
        bar, started = None, _time.perf_counter()
        t_cur, a = grid[0], 0
        for b in bounds[1:]:
            while True:                       # a state event restarts the rest of this segment
                points = np.concatenate([[t_cur], grid[a + 1: b + 1]])
                n_before = len(self.T)
                if not self._segment(points):
                    if bar is not None:
                        bar.close()
                    return
                event = self._state_event(points, n_before)
                if event is None:
                    break
                t_cur = event
                a = int(np.searchsorted(grid, t_cur, side="right")) - 1
                if self.failure is not None:
                    return
            t_cur, a = grid[b], b
            if grid[b] in event_at:
                self._restart_at(grid[b], event_at[grid[b]])
            if progress is not False and bar is None and len(bounds) > 2:
                elapsed = _time.perf_counter() - started
                expected = elapsed * (grid[-1] - grid[0]) / max(grid[b] - grid[0], 1e-300)
                if progress or expected > PROGRESS_AFTER_SECONDS:
                    from tqdm import tqdm
                    bar = tqdm(total=float(grid[-1] - grid[0]), unit="s", desc="simulate", leave=False,
                               bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")
                    bar.update(float(grid[b] - grid[0]))
            elif bar is not None:
                bar.update(float(grid[b] - grid[bounds[bounds.index(b) - 1]]))
        if bar is not None:
            bar.close()

    # ---- state events -------------------------------------------------------------------------

    def _g(self, t, x, z):
        return np.asarray(self.dae.zero(t, x, z, self._u_at(t), self.p, self.d)).ravel()

    def _crossed(self, g_a, g_b):
        """Which zero functions changed sign between two points, in their direction."""
        dirs = np.array(self.dae.zero_directions)
        falling = (g_a > 0) & (g_b <= 0)
        rising = (g_a < 0) & (g_b >= 0)
        return np.flatnonzero((falling & (dirs <= 0)) | (rising & (dirs >= 0)))

    def _state_event(self, points, n_before):
        """After a segment: find the first zero crossing between recorded points, locate and apply it.

        Returns the event time (the segment must continue from there) or None.
        """
        if not self.dae.zero_labels:
            return None
        rows = range(n_before - 1, len(self.T))
        G = [self._g(self.T[k], self.X[k], self.Z[k]) for k in rows]
        for j in range(1, len(G)):
            hit = self._crossed(G[j - 1], G[j])
            if hit.size:
                k = n_before - 1 + j - 1              # last recorded point before the crossing
                t_a, x_a, z_a = self.T[k], self.X[k].copy(), self.Z[k].copy()
                t_b = self.T[k + 1]
                del self.T[k + 1:], self.X[k + 1:], self.Z[k + 1:], self.D[k + 1:]
                return self._handle_event(t_a, x_a, z_a, t_b)
        return None

    def _advance_to(self, t_a, x_a, z_a, t):
        F1 = self.integrators.get((1.0,))
        out = F1(x0=x_a / self.xn, z0=z_a / self.zn if self.zn.size else np.zeros(0), p=self.pvec(t_a, t - t_a))
        x = np.asarray(out["xf"]).ravel() * self.xn
        z = np.asarray(out["zf"]).ravel() * self.zn if self.zn.size else np.zeros(0)
        return x, z

    def _handle_event(self, t_a, x_a, z_a, t_b):
        """Illinois iteration on the earliest crossing, then the transition and re-initialisation."""
        x_b, z_b = self._advance_to(t_a, x_a, z_a, t_b)
        g_a, g_b = self._g(t_a, x_a, z_a), self._g(t_b, x_b, z_b)
        hit = self._crossed(g_a, g_b)
        i = int(hit[0])
        if hit.size > 1:                              # earliest by the secant estimate
            est = [t_a - g_a[h] * (t_b - t_a) / (g_b[h] - g_a[h]) for h in hit]
            i = int(hit[int(np.argmin(est))])
        lo, hi, f_lo, f_hi = t_a, t_b, g_a[i], g_b[i]
        x_hi, z_hi = x_b, z_b
        side = 0
        tol = 1e-12 * max(1.0, abs(t_b))
        for _ in range(200):
            if hi - lo <= tol:
                break
            t = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
            if not (lo < t < hi):
                t = 0.5 * (lo + hi)
            x_t, z_t = self._advance_to(t_a, x_a, z_a, t)
            g_t = self._g(t, x_t, z_t)
            crossed = self._crossed(g_a, g_t)
            early = [h for h in crossed if h != i]
            if early:                                 # another function crosses before t: it comes first
                i = int(early[0])
                lo, f_lo, hi, f_hi, x_hi, z_hi, side = t_a, g_a[i], t, g_t[i], x_t, z_t, 0
                continue
            if i in crossed:                          # the crossing lies in (lo, t]
                hi, f_hi, x_hi, z_hi = t, g_t[i], x_t, z_t
                if side == -1:
                    f_lo *= 0.5                       # Illinois: the same end kept twice
                side = -1
            else:
                lo, f_lo = t, g_t[i]
                if side == 1:
                    f_hi *= 0.5
                side = 1
        t_e = hi
        self._record_at(t_e, x_hi, z_hi)
        x_plus, _ = self.dae.transition[i](t_e, x_hi, z_hi, self._u_at(t_e), self.p, self.d)
        self.x = np.asarray(x_plus).ravel()
        self.z = solve_algebraic(self.dae, t_e, self.x, z_hi, self._u_at(t_e), self.p, self.d)
        self._record_at(t_e, self.x, self.z)
        self.events.append(Event(float(t_e), "state", self.dae.zero_labels[i]))
        return t_e

    def _record_at(self, t, x, z):
        self.x, self.z = np.asarray(x, dtype=float).copy(), np.asarray(z, dtype=float).copy()
        self._record(t)

    def _u_at(self, t):
        u = self.plan.constant.copy()
        for k, (times, values) in self.plan.varying.items():
            u[k] = float(np.interp(t, times, values))
        return u

    def _segment(self, points) -> bool:
        ok, message = self._attempt(points)
        if not ok:
            self._recover(points, message)
        return ok

    def _attempt(self, points) -> tuple[bool, str]:
        """Integrate over `points` in one call; on success append the outputs and move the state."""
        t0, h = points[0], points[-1] - points[0]
        F = self.integrators.get_real(tuple(float(v) for v in points))
        xs = self.x / self.xn
        zs = self.z / self.zn if self.zn.size else np.zeros(0)
        try:
            out = F(x0=xs, z0=zs, p=self.pvec(t0, h))
        except RuntimeError as exc:
            return False, str(exc)
        xf = np.asarray(out["xf"]).reshape(self.xn.size, -1).T * self.xn
        zf = (np.asarray(out["zf"]).reshape(self.zn.size, -1).T * self.zn) if self.zn.size \
            else np.zeros((xf.shape[0], 0))
        self.T.extend(points[1:])
        self.X.extend(xf)
        self.Z.extend(zf)
        self.D.extend([self.dae] * len(xf))
        self.x, self.z = xf[-1].copy(), zf[-1].copy()
        s = F.stats()
        for k in ("nsteps", "nfevals", "netfails"):
            self.stats[k] += int(s.get(k, 0))
        self.stats["segments"] += 1
        self.stats["hlast"] = float(s.get("hlast", float("nan"))) * h
        return True, ""

    def _integrate_monitored(self, grid, event_at):
        """Integrate long pieces with dense monitor points, switching states where a block degrades.

        The integrator reports the solution at extra monitor points inside each
        piece (interpolated, no restart). After the piece, the conditioning of
        the running selection is evaluated at every monitor point; at the
        first point where a better selection wins by the hysteresis factor, the
        piece is cut, the states are re-chosen and the integrator restarts —
        re-initialised — there (a "reselection" event). Monitor density adapts
        so the running selection's quality moves by at most ~0.05 between points; a piece
        covers a twentieth of the run, so restarts stay few.
        """
        n_int = grid.size - 1
        longest = max(1, n_int // 20)
        per_piece = 1
        density = 4                                   # monitor points per output interval
        fraction = 1.0                                # of the first interval, when pieces must be short
        grid_set = set(grid.tolist())
        t_cur, k = grid[0], 0                         # current time; next output index is k + 1
        while k < n_int:
            k_end = min(k + per_piece, n_int)
            for j in range(k + 1, k_end + 1):
                if grid[j] in event_at:
                    k_end = j
                    break
            first_end = t_cur + fraction * (grid[k + 1] - t_cur)
            spans = [(t_cur, first_end)] + [(grid[j], grid[j + 1]) for j in range(k + 1, k_end)]
            pts = [t_cur]
            is_output = [False]
            for a, b in spans:
                pts.extend(np.linspace(a, b, density + 1)[1:])
                is_output.extend([False] * (density - 1) + [b == grid[k + 1] or b in grid_set])
            pts = np.array(pts)
            ok, message, xs, zs = self._dense(pts)
            if not ok and per_piece > 1:
                per_piece //= 2                       # maybe a switch was due inside: look closer
                continue
            if not ok and self.monitor is not None and fraction > 1e-3:
                fraction /= 4                         # a switch due within this interval: take part of it
                density = min(256, density * 2)
                continue
            if not ok:
                self._recover(np.concatenate([[t_cur], grid[k + 1: k_end + 1]]), message)
                return
            fraction = 1.0
            ratios, switch_at = self._ratios(pts, xs, zs)
            crossing = self._first_crossing(pts, xs, zs, switch_at)
            if crossing is not None:
                switch_at = None
            stop = crossing if crossing is not None else (switch_at if switch_at is not None else len(pts) - 1)
            for m in range(1, stop + 1):
                if is_output[m]:
                    self.x, self.z = xs[m], zs[m]
                    self._record(pts[m])
            self.x, self.z = xs[stop].copy(), zs[stop].copy()
            t_cur = pts[stop]
            if crossing is not None:
                t_cur = self._handle_event(pts[stop], xs[stop].copy(), zs[stop].copy(), pts[stop + 1])
                if self.failure is not None:
                    return
                density = self._event_density(density, grid[1] - grid[0])
                if self.failure is not None:
                    return
                per_piece = 1
            k = int(np.searchsorted(grid, t_cur, side="right")) - 1
            if t_cur == grid[k] and k > 0 and grid[k] in event_at:
                self._restart_at(grid[k], event_at[grid[k]])
            if switch_at is not None:
                self._reselect(t_cur)
                # a switch cut the piece: what came after it was wasted, so aim shorter next time
                per_piece = max(1, min(per_piece, int(np.ceil((stop / density) * 1.5))))
            else:
                per_piece = min(longest, 2 * per_piece)
                if self.monitor is not None and stop >= 2:
                    # aim the next piece to end near the predicted switch (quality falling to ~0.45)
                    slope = (ratios[stop] - ratios[stop - 1]) / max(pts[stop] - pts[stop - 1], 1e-300)
                    if slope < 0:
                        horizon = (ratios[stop] - 0.45) / -slope
                        per_piece = int(min(per_piece, max(1, horizon // (grid[1] - grid[0]))))
            steps = np.abs(np.diff(ratios[: stop + 1])) if stop > 0 else np.zeros(1)
            worst = float(np.max(steps)) if steps.size else 0.0
            if worst > 0.05 and density < 256:
                density *= 2
            elif worst < 0.01 and density > 1 and self.monitor is not None:
                density //= 2

    def _dense(self, pts):
        """One integrator call over pts (unrecorded); returns the states at every point."""
        t0, h = pts[0], pts[-1] - pts[0]
        tau = tuple(float(v) for v in np.round((pts[1:] - t0) / h, 14))
        F = self.integrators.get(tau)
        try:
            out = F(x0=self.x / self.xn, z0=self.z / self.zn if self.zn.size else np.zeros(0),
                    p=self.pvec(t0, h))
        except RuntimeError as exc:
            return False, str(exc), None, None
        s = F.stats()
        for key in ("nsteps", "nfevals", "netfails"):
            self.stats[key] += int(s.get(key, 0))
        self.stats["segments"] += 1
        self.stats["hlast"] = float(s.get("hlast", float("nan"))) * h
        xf = np.asarray(out["xf"]).reshape(self.xn.size, -1).T * self.xn
        zf = (np.asarray(out["zf"]).reshape(self.zn.size, -1).T * self.zn) if self.zn.size \
            else np.zeros((xf.shape[0], 0))
        return True, "", np.vstack([self.x, xf]), np.vstack([self.z.reshape(1, -1), zf])

    def _first_crossing(self, pts, xs, zs, limit):
        """Index of the last point before the first zero crossing among pts (up to `limit`), or None."""
        if not self.dae.zero_labels:
            return None
        n = pts.size if limit is None else limit + 1
        U = np.column_stack([self._u_at(t) for t in pts[:n]]) if self.plan.varying else \
            np.tile(self.plan.constant.reshape(-1, 1), n)
        G = np.asarray(self.dae.zero.map(n)(pts[:n].reshape(1, -1), xs[:n].T, zs[:n].T, U,
                                            np.tile(self.p.reshape(-1, 1), n),
                                            np.tile(self.d.reshape(-1, 1), n))).T
        dirs = np.array(self.dae.zero_directions)
        falling = (G[:-1] > 0) & (G[1:] <= 0) & (dirs <= 0)
        rising = (G[:-1] < 0) & (G[1:] >= 0) & (dirs >= 0)
        hits = np.flatnonzero(np.any(falling | rising, axis=1))
        return int(hits[0]) if hits.size else None

    def _event_density(self, density, out_interval):
        """Monitor points close enough to resolve the spacing of recent state events (or stop at a Zeno point)."""
        times = [e.t for e in self.events if e.kind == "state"]
        if len(times) < 2:
            return density
        gap = times[-1] - times[-2]
        needed = 8.0 * out_interval / max(gap, 1e-300)
        if needed > 4096:
            self.failure = IntegrationError(
                f"event accumulation at t = {times[-1]:.9g} s: state events {gap:.3g} s apart, too close to "
                f"resolve (chattering or a Zeno point such as a bouncing ball coming to rest); the result "
                f"holds the solution up to there", t=float(times[-1]), step=float("nan"),
                worst=self.events[-1].cause, solver_message="event accumulation")
            return density
        return int(min(4096, max(density, 2 ** int(np.ceil(np.log2(max(needed, 1.0)))))))

    def _ratios(self, pts, xs, zs):
        """Conditioning ratio (running / best selection) at each point, and the first point to switch at."""
        n = pts.size
        if self.monitor is None:
            return np.ones(n), None
        U = np.column_stack([self._u_at(t) for t in pts]) if self.plan.varying else \
            np.tile(self.plan.constant.reshape(-1, 1), n)
        Y = np.asarray(self.dae.observed.map(n)(pts.reshape(1, -1), xs.T, zs.T, U,
                                                np.tile(self.p.reshape(-1, 1), n),
                                                np.tile(self.d.reshape(-1, 1), n))).T
        ratios = np.ones(n)
        for m in range(n):
            quality, switch = self.monitor.better(Y[m], probe=True)
            ratios[m] = 1.0 if quality is None else quality
            if switch and m > 0:
                return ratios[: m + 1], m
        return ratios, None

    def _reselect(self, t):
        """Switch to a better state selection when the running one degrades (hysteresis factor 2).

        Returns the quality ratio (running / best) after the check.
        """
        u = self._u_at(t)
        values = np.asarray(self.dae.observed(t, self.x, self.z, u, self.p, self.d)).ravel()
        quality, switch = self.monitor.better(values)
        if switch is None:
            return quality
        dummies, new_dae, cause = switch
        named = dict(zip(self.dae.observed_names, values))
        x_new = np.array([named.get(n, 0.0) for n in new_dae.x_names])
        z_guess = np.array([named.get(n, 0.0) for n in new_dae.z_names])
        self._use(new_dae)
        self.x = x_new
        self.z = solve_algebraic(new_dae, t, x_new, z_guess, u, self.p, self.d)
        self.monitor.current = dummies
        self.events.append(Event(float(t), "reselection", cause))
        if self.T and self.T[-1] == t:
            self.X[-1], self.Z[-1], self.D[-1] = self.x.copy(), self.z.copy(), new_dae
        return 1.0

    def _restart_at(self, t, cause):
        """A time event: states are continuous; algebraic variables are re-solved at the new time."""
        if self.zn.size:
            self.z = solve_algebraic(self.dae, t, self.x, self.z, self._u_at(t), self.p, self.d)
            self.Z[-1] = self.z.copy()
        self.events.append(Event(float(t), "time", cause))

    def _recover(self, points, message):
        """Keep what can be integrated before the failure, with few restarts, then close in on it.

        The failing segment is retried in halves (a successful piece keeps its
        length), so restarts stay O(log n); the failing output interval is then
        split in eight, three times over: the result ends within 1/512 of an
        output interval of the failure.
        """
        solver = _solver_message(message)
        n = points.size - 1
        a, chunk = 0, max(1, n // 2)
        while a < n:
            b = min(a + chunk, n)
            ok, text = self._attempt(points[a: b + 1])
            if ok:
                a = b
                continue
            solver = _solver_message(text)
            if b - a == 1:
                break
            chunk = max(1, (b - a) // 2)
        t_fail = points[min(a + 1, n)]
        if a < n:
            lo, hi = points[a], points[a + 1]
            for _ in range(3):
                pieces = np.linspace(lo, hi, 9)
                j = 0
                while j < 8:
                    ok, text = self._attempt(pieces[j: j + 2])
                    if not ok:
                        solver = _solver_message(text)
                        break
                    j += 1
                lo, hi = pieces[j], pieces[min(j + 1, 8)]
            t_fail = hi
        t_good = self.T[-1]
        step = self.stats.get("hlast", float("nan"))
        worst = _worst_variable(self.dae, t_good, self.x, self.z, self._u_at(t_good), self.p, self.d, self.xn)
        self.failure = IntegrationError(
            f"integration failed between t = {t_good:.6g} s and {t_fail:.6g} s (last step size {step:.3g} s); "
            f"worst variable: {worst}; solver: {solver}. The result holds the solution up to t = {t_good:.6g} s",
            t=float(t_good), step=step, worst=worst, solver_message=solver)
        self.stats["failed_at"] = float(t_good)


class _SelectionMonitor:
    """Watches the conditioning of the dependent block and proposes a better selection."""

    HYSTERESIS = 0.5

    def __init__(self, cm, factory, current):
        self.cm, self.factory, self.current = cm, factory, current
        self.names = factory.names

    @classmethod
    def create(cls, cm, dae):
        factory = cm.selection_factory
        if factory is None:
            return None
        index = cm.stages["index"]
        if not any(len(level.candidates) > len(level.chosen) for level in index.levels):
            return None
        if not factory.can_degrade():
            return None
        current = frozenset(factory.names.index(n) for n in index.dummies)
        if dae is not cm.dae:
            current = next((k for k, v in cm._selections.items() if v is dae), current)
        return cls(cm, factory, current)

    def better(self, observed_values, probe=False):
        """(quality, switch): the running selection's quality in [0, 1] (1: ideal, 0: singular) and
        None, or — when another selection is better by the hysteresis factor — (dummies, compiled
        selection, cause); when probing, just True."""
        dae = self.cm.dae
        named = dict(zip(dae.observed_names, observed_values))
        values = np.array([named.get(n, 0.0) for n in self.names])
        try:
            best, levels = self.factory.choose(values)
        except MechnetError:
            return None, None
        q_now = self.factory.quality(self.factory.levels_for(self.current), values)
        if best == self.current:
            return q_now, None
        q_best = self.factory.quality(levels, values)
        if q_now >= self.HYSTERESIS * q_best:
            return q_now, None
        if probe:
            return q_now, True
        old = _state_names(self.factory, self.current)
        new = _state_names(self.factory, best)
        cause = (f"dependent block conditioning {q_now:.2g} vs {q_best:.2g}: states "
                 f"{', '.join(old)} -> {', '.join(new)}")
        return q_now, (best, self.cm.selection(best), cause)


def _state_names(factory, dummies) -> list:
    return sorted(factory.names[i] for i, j in factory.graph.der.items() if j not in dummies)


def _observe(dae, T, X, Z, plan, p, d) -> np.ndarray:
    n = T.size
    if n == 0:
        return np.zeros((0, len(dae.observed_names)))
    U = np.tile(plan.constant.reshape(-1, 1), n)
    for k, (times, values) in plan.varying.items():
        U[k] = np.interp(T, times, values)
    maps = dae.info.setdefault("_observed_maps", {})       # Function.map costs as much as evaluating
    if n not in maps:
        maps[n] = dae.observed.map(n)
    y = maps[n](T.reshape(1, -1), X.T, Z.T, U, np.tile(p.reshape(-1, 1), n), np.tile(d.reshape(-1, 1), n))
    return np.asarray(y).T


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
