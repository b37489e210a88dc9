"""The simulation loop: integrate between boundaries, restart at events, stop at a failure.

The run is split into segments at time events (signal steps, table knots) and, for long grids, into a
fixed number of chunks (for the progress bar): the integrator restarts exactly at each boundary,
deterministically. Scenes with state events or a state-selection monitor run in monitored pieces
(`pieces.py`).

A failed integration never surfaces as a CasADi traceback: the failing segment is re-integrated interval
by interval up to the failure, and the partial result comes back with an `IntegrationError` describing
the time, the step size and the worst variable.
"""
from __future__ import annotations

import time as _time

import numpy as np

from ..caches import BUILD_LOCK
from ..core.errors import IntegrationError, MechnetError
from ..interrupts import Interrupted, interrupted
from ..solver_output import terminal
from .branch import Verdict, state_names
from .change_points import ChangePoints
from .events import Event, chunk_bounds
from .initialize import solve_algebraic
from .pieces import MonitoredPieces
from .reselection import Reselection, SelectionMonitor
from .rows import Rows
from .solvers import Integrators, MethodChoice, call, solver_message
from .state_events import StateEvents
from .winding import WINDING_POINTS, turns_of, whole_turns, winding_reach

PROGRESS_CHUNKS = 20
PROGRESS_MIN_POINTS = 1000
PROGRESS_AFTER_SECONDS = 1.0
ADAMS_PROBE_STEPS = 4096        # steps per output interval Adams may take under "auto" before BDF is tried
STIFF_GAIN = 8                   # BDF's steps below the probe budget / STIFF_GAIN: stiff (else a long interval)
STIFF_SHARE = 0.1                # of an Adams call's steps failing to converge: stiff (measured: stiff scenes
STIFF_MIN_STEPS = 200            # 0.36, the examples at most 0.036, examples/drive_line.py)
ATOL_RESOLVED = 1e-14            # (per unit of nominal) an atol below this is named when a run fails
UNRECORDED = np.array([False])   # `_attempt(points, keep)` of a piece whose end is not an output


class Run(StateEvents, Reselection, ChangePoints, MonitoredPieces):
    """The segment loop: integrate between boundaries, restart at events, stop at a failure."""

    def __init__(self, cm, dae, choice, rtol, atol, max_steps, plan, p, d, init):
        self.cm, self.plan, self.p = cm, plan, p
        self.d = np.asarray(d, dtype=float).copy()    # the modes, changed by state events
        self.choice = choice
        self.settings = (choice.plugin, choice.options, rtol, atol, max_steps)
        self._probing = choice.fallback is not None
        self._pending = None                           # a method switch not yet stamped with its time
        self._use(dae)
        self.rows = Rows()
        self.events: list[Event] = []
        self.failure = None
        self.stats = {"nsteps": 0, "nfevals": 0, "netfails": 0, "nncfails": 0, "segments": 0,
                      "method": choice.method, "method_reason": choice.reason}
        self.x, self.z = init.x.copy(), init.z.copy()

    def _use(self, dae):
        self.dae = dae
        self._fold_floor = None                        # a new selection: no failed step over to remember
        self.integrators = self._integrators(dae)
        self.xn = np.array(dae.x_nominal, dtype=float)
        self.zn = np.array(dae.z_nominal, dtype=float)
        self.quaternions = [list(index) for index in dae.info.get("quaternions", ())]

    def _renormalise(self):
        """Quaternion states back to unit length before an integrator call: R uses Q/|Q|, so nothing
        else changes, and the drift of |Q| cannot add up across calls (DESIGN.md, "Orientation in 3D").
        Within one call it is the integrator's error (an event-free run is one call)."""
        if self.quaternions:
            self.x = self.x.copy()                     # it may be a row of a piece's output: never write into it
        for index in self.quaternions:
            self.x[index] = self.x[index] / np.linalg.norm(self.x[index])

    def _integrators(self, dae, max_steps=None) -> Integrators:
        plugin, extra, rtol, atol, limit = self.settings
        if max_steps is None:
            max_steps = min(limit, ADAMS_PROBE_STEPS) if self._probing else limit
        return Integrators(self.cm, dae, plugin, extra, rtol, atol, max_steps, self.plan)

    def _record(self, t):
        self.rows.add_row(t, self.x, self.z, self.dae, self.d)

    def pvec(self, t0, h):
        """Parameters of an integrator call from t0 over h: the input tables' values depend on t0 (each
        knot's value after a jump once the call starts at or after it, `InputPlan.table_data`)."""
        return np.concatenate([self.plan.constant, self.p, self.d, [t0, h], self.plan.table_data(t0)])

    def integrate(self, grid, events, progress):
        with BUILD_LOCK:             # the branch check builds its functions on a model's first run
            self.monitor = SelectionMonitor.create(self.cm, self.dae)
            if self.monitor is not None:
                self._select_for_branch(grid[0])
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
        barred = any(0 < c < grid.size - 1 for c in cuts)
        bounds = [0] + [c for c in cuts if 0 < c < grid.size - 1] + [grid.size - 1]
        bar, started = None, _time.perf_counter()
        t_cur, a = grid[0], 0
        for b in bounds[1:]:
            while True:                       # (state events run monitored: none here) a change point
                points = np.concatenate([[t_cur], grid[a + 1: b + 1]])      # passed restarts the rest
                if self._segment(points):
                    break
                t_next = self._pass_change_point(grid, limit=grid[b])
                if t_next is None:
                    if bar is not None:
                        bar.close()
                    return
                t_cur = t_next
                a = int(np.searchsorted(grid, t_cur, side="right")) - 1
            t_cur, a = grid[b], b
            if grid[b] in event_at:
                self._restart_at(grid[b], event_at[grid[b]])
            if progress is not False and bar is None and barred:
                elapsed = _time.perf_counter() - started
                expected = elapsed * (grid[-1] - grid[0]) / max(grid[b] - grid[0], 1e-300)
                if progress or expected > PROGRESS_AFTER_SECONDS:
                    from tqdm import tqdm
                    bar = tqdm(total=float(grid[-1] - grid[0]), unit="s", desc="simulate", leave=False, file=terminal(),
                               bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")
                    bar.update(float(grid[b] - grid[0]))
            elif bar is not None:
                bar.update(float(grid[b] - grid[bounds[bounds.index(b) - 1]]))
        if bar is not None:
            bar.close()

    def _select_for_branch(self, t):
        """Run without the monitor when a selection holds on the whole branch (`branch.py`), switching
        to it first if it is not the running one; else check the start, and monitor the run."""
        verdict = self.monitor.whole_branch(
            self.monitor.values_at(self.dae, t, self.x, self.z, self._u_at(t), self.p, self.d), self.p)
        if verdict.holds and verdict.dummies != self.monitor.current:
            try:
                other = self.cm.selection(verdict.dummies)
            except MechnetError:           # that choice cannot hold the model's resets
                verdict = Verdict(False, f"states {', '.join(verdict.states)} cannot hold the model's resets")
            else:
                old = state_names(self.monitor.factory, self.monitor.current)
                self._switch_selection(t, self._observed_at(t), verdict.dummies, other,
                                       f"whole-branch selection: states {', '.join(old)} -> "
                                       f"{', '.join(verdict.states)}")
        self.stats["selection"] = verdict.describe()
        if verdict.holds:
            self.monitor = None               # it would never act on this branch: integrate in one piece
        else:
            self._reselect(t)

    def _observed_at(self, t) -> np.ndarray:
        return np.asarray(self.dae.observed(t, self.x, self.z, self._u_at(t), self.p, self.d)).ravel()

    def _u_at(self, t):
        return self.plan.at(t)[:, 0]

    def _turns(self, x, z):
        """The whole turns in (x, z) of the coordinates the equations see only through sine and cosine
        (`winding.whole_turns`): left out of each integrator call, so an angle of thousands of turns
        keeps the precision of one near zero (added back to the outputs)."""
        px, pz = whole_turns(self.dae)
        return turns_of(x, px), turns_of(z, pz)

    def _winding_reach(self, t) -> float:
        """How long (s) the next integrator call from (t, self.x, self.z) may last (`winding_reach`)."""
        return winding_reach(self.dae, t, self.x, self.z, self._u_at, self.p, self.d)

    def _inputs_at(self, ts):
        """The inputs at each of the times ts, one column per time."""
        return self.plan.at(ts)

    def _segment(self, points) -> bool:
        """Integrate from points[0] (the state's time) over the output times points[1:], in calls that
        wind no periodic state more than TURN_LIMIT (`_winding_reach`, measured before each call): a
        call ends at the last output time within reach, or, when the next output lies beyond, at an
        unrecorded time splitting the way there evenly; an interval longer than a WINDING_POINTS-th of
        the reach gets unrecorded points between (IDAS's initial-value search scales its trial step to
        the first interval: over a whole 0.8 s piece of the 3000-rpm crank it failed at rtol 1e-10).
        False after a failure (`_recover`)."""
        t_cur, i, n = points[0], 0, points.size - 1
        reach = self._winding_reach(t_cur)
        if t_cur + reach >= points[-1]:
            ok, message = self._attempt(points)            # one call (a real-time integrator, reused)
            return ok or self._recover(points, message)
        while i < n:
            j = max(i, int(np.searchsorted(points, t_cur + reach, side="right")) - 1)
            if j > i:
                call, keep = np.concatenate([[t_cur], points[i + 1: j + 1]]), np.ones(j - i, dtype=bool)
            else:
                gap = points[i + 1] - t_cur
                pieces = int(np.ceil(gap / reach))
                end = t_cur + gap / pieces if pieces > 1 else points[i + 1]
                call, keep, j = np.array([t_cur, end]), np.array([pieces == 1]), i + (pieces == 1)
            call, keep = _split_intervals(call, keep, reach / WINDING_POINTS)
            ok, message = self._attempt(call, keep)
            if not ok and not self._recover(call, message, keep):
                return False
            t_cur, i = call[-1], j
            if i < n:
                reach = self._winding_reach(t_cur)
        return True

    def _attempt(self, points, keep=None) -> tuple[bool, str]:
        """Integrate over `points` in one call; on success append the outputs and move the state.
        `keep`: which of points[1:] are recorded (None: all, in a real-time integrator kept for the
        grid; else a normalised one, shared by calls of one pattern: `_segment`'s pieces)."""
        t0, h = points[0], points[-1] - points[0]
        if keep is None:
            def get():
                return self.integrators.get_real(tuple(np.asarray(points, dtype=float).tolist()))
        else:
            def get():
                return self.integrators.get(tuple(np.round((points[1:] - t0) / h, 12).tolist()))
        self._renormalise()
        ox, oz = self._turns(self.x, self.z)
        xs = (self.x - ox) / self.xn
        zs = (self.z - oz) / self.zn if self.zn.size else np.zeros(0)
        try:
            stats, out = self._call(t0, h, get, xs, zs, self.pvec(t0, h))
        except RuntimeError as exc:
            return False, str(exc)
        except Interrupted as stop:              # keep the output times the call reached before Ctrl-C
            if isinstance(stop.result, dict):
                self._store(points, keep, stop.result, ox, oz, reached=True)
            raise Interrupted("simulate") from None
        self._store(points, keep, out, ox, oz)
        self._count(stats, h)
        return True, ""

    def _store(self, points, keep, out, ox, oz, reached=False):
        """Record the outputs `out` of a call over `points` (`_attempt`) and move the state to its end;
        `reached`: of an interrupted call, only the output times it reached (the columns after are NaN)."""
        xf = np.asarray(out["xf"]).reshape(self.xn.size, -1).T * self.xn + ox
        zf = (np.asarray(out["zf"]).reshape(self.zn.size, -1).T * self.zn + oz) if self.zn.size \
            else np.zeros((xf.shape[0], 0))
        ts = points[1:]
        finite = np.isfinite(xf).all(axis=1) & np.isfinite(zf).all(axis=1) if reached else None
        if reached and not finite.all():
            n = int(np.argmin(finite))
            xf, zf, ts = xf[:n], zf[:n], ts[:n]
            keep = None if keep is None else keep[:n]
            if n == 0:
                return
        self.x, self.z = xf[-1].copy(), zf[-1].copy()
        if keep is not None:
            xf, zf, ts = xf[keep], zf[keep], ts[keep]
        self.rows.add(ts, xf, zf, self.dae, self.d)

    def _count(self, s, h):
        """Add one successful call's solver statistics (`s`: F.stats(), over a call of length h)."""
        for k in ("nsteps", "nfevals", "netfails", "nncfails"):
            self.stats[k] += int(s.get(k, 0))
        self.stats["segments"] += 1
        self.stats["hlast"] = float(s.get("hlast", float("nan"))) * h

    def _call(self, t0, h, get, xs, zs, p, budgeted=False):
        """One integrator call, F = get() from (xs, zs) with parameters p over [t0, t0 + h]: every call of
        the run goes through here. Returns (statistics, outputs) or raises `solvers.SolverFailure`.

        Under method="auto" an ODE starts with Adams' functional iteration, which stiffness defeats: its
        steps shrink to the fast time scale and fail to converge on a good share of them (a 1e8 N/m
        spring-damper on 1 g: 2.7e6 failures in 7.4e6 steps and 30 s, where BDF takes 372 steps). So
        Adams runs on a step budget of ADAMS_PROBE_STEPS per output interval, and a failed Adams call
        (other than on a budget a monitored piece set itself) is decided by `_after_adams_failed`; a
        successful one whose iteration failed on STIFF_SHARE of its steps hands the rest to BDF.

        Ctrl-C fails the call (CasADi swallows the KeyboardInterrupt, the solver reports its right-hand side
        failed): `Interrupted` is raised instead of any retry, and before the next call when the interrupt
        came between calls (`mechnet.interrupts`)."""
        if interrupted():
            raise Interrupted("simulate")
        if self._pending is not None:            # a switch takes effect with the first call that uses it
            self._record_switch(t0)
        try:
            s, out = call(get(), xs, zs, p)
        except RuntimeError as exc:
            if interrupted():                    # (with the outputs the call reached: `_attempt`)
                raise Interrupted("simulate", getattr(exc, "outputs", None)) from None
            code = solver_message(str(exc))
            if self.choice.fallback is None or (budgeted and code.endswith("TOO_MUCH_WORK")):
                raise
            try:
                return self._after_adams_failed(code, t0, get, xs, zs, p)
            except RuntimeError as again:
                if interrupted():
                    raise Interrupted("simulate", getattr(again, "outputs", None)) from None
                raise
        if self.choice.fallback is not None:
            steps, failures = int(s.get("nsteps", 0)), int(s.get("nncfails", 0))
            if steps >= STIFF_MIN_STEPS and failures >= STIFF_SHARE * steps:
                self._switch("cvodes-bdf", None, f"stiff: Adams' functional iteration failed to converge on "
                                                 f"{failures} of {steps} steps")
        return s, out

    def _after_adams_failed(self, code, t0, get, xs, zs, p):
        """The Adams call of `_call` failed with solver code `code`: the call again with BDF. When Adams ran
        out of its probe budget, BDF gets 1/STIFF_GAIN of it: if that is enough, the scene is stiff and
        BDF goes on; if BDF runs out too, the output intervals were long, not stiff, and Adams takes the
        call again without the probe budget. Any other failure goes to BDF for good."""
        if not (self._probing and code.endswith("TOO_MUCH_WORK")):
            self._switch("cvodes-bdf", None, f"Adams failed ({code})")
            self._record_switch(t0)
            return call(get(), xs, zs, p)
        probe = self.integrators.max_steps
        adams = self.choice
        self.choice = MethodChoice("cvodes-bdf", adams.reason)
        self.settings = (self.choice.plugin, self.choice.options, *self.settings[2:])
        self.integrators = self._integrators(self.dae, max(1, probe // STIFF_GAIN))
        try:
            done = call(get(), xs, zs, p)
        except RuntimeError as again:
            if interrupted():
                raise Interrupted("simulate", getattr(again, "outputs", None)) from None
            if not solver_message(str(again)).endswith("TOO_MUCH_WORK"):
                self._switch("cvodes-bdf", None, f"Adams failed ({code}), and BDF after it")
                self._record_switch(t0)
                raise
            self.choice = adams
            self._switch("cvodes-adams", "cvodes-bdf", f"Adams ran out of its probe budget ({probe} steps per "
                                                       f"output interval) and BDF of {probe // STIFF_GAIN}: long "
                                                       f"intervals, not stiffness; Adams without the probe budget")
            self._record_switch(t0)
            return call(get(), xs, zs, p)
        self._switch("cvodes-bdf", None, f"stiff: Adams ran out of its probe budget ({probe} steps per output "
                                         f"interval) where BDF needed at most {probe // STIFF_GAIN}")
        self._record_switch(t0)
        return done

    def _switch(self, method, fallback, why):
        """Integrate with `method` from the next call on (falling back to `fallback` on stiffness); the
        "method" event is stamped with that call's start (`_record_switch`). Adams probes on a budget of
        ADAMS_PROBE_STEPS only until the first switch."""
        self._pending = (self.stats["method"], method, why)
        self.choice = MethodChoice(method, self.choice.reason, fallback)
        self._probing = False
        self.settings = (self.choice.plugin, self.choice.options, *self.settings[2:])
        self.integrators = self._integrators(self.dae)

    def _record_switch(self, t):
        old, method, why = self._pending
        self._pending = None
        cause = f"{old} -> {method} at t = {t:.6g} s: {why}" if old != method else f"{method} at t = {t:.6g} s: {why}"
        self.events.append(Event(float(t), "method", cause))
        self.stats["method"] = method
        self.stats["method_reason"] += f"; {cause}"

    def _advice(self, solver: str) -> str:
        """Which argument of simulate() to change, when the solver's code says it was the arguments (too
        many steps, tolerances too tight) rather than the model."""
        _, _, rtol, atol, max_steps = self.settings
        if atol < ATOL_RESOLVED and solver.endswith(("TOO_MUCH_WORK", "TOO_MUCH_ACC", "ERR_FAIL")):
            return (f" (atol = {atol:g} asks for an absolute error no double resolves near zero, where a "
                    f"variable's error is held to atol alone: raise atol)")
        if solver.endswith("TOO_MUCH_WORK"):
            return (f" (the step budget max_steps = {max_steps} ran out: raise max_steps, shorten t_end, or "
                    f"loosen rtol = {rtol:g})")
        if solver.endswith("TOO_MUCH_ACC"):
            return f" (rtol = {rtol:g}, atol = {atol:g} ask more than double precision gives: loosen them)"
        return ""

    def _restart_at(self, t, cause):
        """A time event: states are continuous; algebraic variables are re-solved at the new time."""
        if self.zn.size:
            self.z = solve_algebraic(self.dae, t, self.x, self.z, self._u_at(t), self.p, self.d)
            last = self.rows.last
            self.rows.replace_last(last.x, self.z, last.dae)
        self.events.append(Event(float(t), "time", cause))
        self._after_time_event(t)

    def _recover(self, points, message, keep=None):
        """Keep what can be integrated before the failure, with few restarts, then close in on it.

        The failing segment is retried in halves (a successful piece keeps its
        length), so restarts stay O(log n); the failing output interval is then
        split in eight, three times over: the result ends within 1/512 of an
        output interval of the failure. True when every piece integrated after all (the
        failed call had a step budget, or several output intervals at once). `keep`: as in `_attempt`
        (the state starts at points[0], recorded or not; on failure it is recorded where it stopped).
        """
        solver = solver_message(message)
        n = points.size - 1
        if self.zn.size and len(self.rows):
            # restart from algebraics consistent to Newton's precision, not just to the integrator's:
            # IDAS's own initial-condition search can fail on a point that is consistent only to rtol
            try:
                self.z = solve_algebraic(self.dae, points[0], self.x, self.z, self._u_at(points[0]),
                                         self.p, self.d)
            except MechnetError:
                pass
        a, chunk = 0, max(1, n // 2)
        t_state, t_fail = points[0], points[-1]
        while a < n:
            b = min(a + chunk, n)
            ok, text = self._attempt(points[a: b + 1], None if keep is None else keep[a: b])
            if ok:
                a = b
                continue
            solver = solver_message(text)
            if b - a > 1:
                chunk = max(1, (b - a) // 2)
                continue
            t_state, t_fail, solver = self._close_in(points[a], points[a + 1], solver)
            break
        if a == n:
            return True                                # every piece integrated: no failure after all
        if self.rows.last.t != t_state:
            self._record(t_state)                 # an unrecorded piece end: the partial result ends there
        t_good = self.rows.last.t
        step = self.stats.get("hlast", float("nan"))
        worst = _worst_variable(self.dae, t_good, self.x, self.z, self._u_at(t_good), self.p, self.d, self.xn)
        where = f"between t = {t_good:.6g} s and {t_fail:.6g} s" if t_fail > t_good else \
            f"at t = {t_good:.6g} s, the end of an output interval it had to cross in pieces"
        self.failure = IntegrationError(
            f"integration failed {where} (last step size {step:.3g} s); "
            f"worst variable: {worst}; solver: {solver}{self._advice(solver)}. The result holds the solution "
            f"up to t = {t_good:.6g} s", t=float(t_good), step=step, worst=worst, solver_message=solver)
        self.stats["failed_at"] = float(t_good)
        return False

    def _close_in(self, t0, t1, solver):
        """Integrate [t0, t1], whose one call failed, in eighths, three times closer to the failure:
        (time the state reached, time of the failure, solver code). When the first eight pieces all pass,
        the call had simply run out of its step budget (max_steps counts per output interval, as SUNDIALS
        does): the run stops at t1, which the state reached."""
        lo, hi = t0, t1
        for _ in range(3):
            pieces = np.linspace(lo, hi, 9)
            for j in range(8):
                ok, text = self._attempt(pieces[j: j + 2], UNRECORDED)
                if not ok:
                    solver = solver_message(text)
                    break
            else:
                return hi, hi, solver
            lo, hi = pieces[j], pieces[j + 1]
        return lo, hi, solver


def _split_intervals(points, keep, longest) -> tuple[np.ndarray, np.ndarray]:
    """points with unrecorded ones splitting each interval longer than `longest` evenly, and keep with
    False for them."""
    ts, ks = [points[:1]], []
    for a, b, k in zip(points[:-1], points[1:], keep):
        m = int(np.ceil((b - a) / longest * (1 - 1e-12)))
        if m > 1:
            ts.append(a + (b - a) * np.arange(1, m) / m)
            ks.append(np.zeros(m - 1, dtype=bool))
        ts.append([b])
        ks.append([k])
    return np.concatenate(ts), np.concatenate(ks).astype(bool)


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
