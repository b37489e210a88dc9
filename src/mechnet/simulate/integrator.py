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

import contextlib
import io
import re
import time as _time
import warnings

import casadi as ca
import numpy as np

from ..caches import BUILD_LOCK
from ..core.errors import InitializationError, IntegrationError, MechnetError, ParameterError, UnknownNameError
from ..core.declarations import finite_number
from ..numeric import mapped_in
from .events import Event, breakpoints, chunk_bounds, output_grid
from .change_points import ChangePoints
from .branch import TURN_LIMIT, Verdict, selections, state_names, turns_of, whole_turns
from .reselection import Reselection, SelectionMonitor
from .state_events import StateEvents
from .initialize import initialize, solve_algebraic
from .inputs import plan_inputs
from .result import Result, unknown_name

METHODS = ("auto", "idas", "cvodes-bdf", "cvodes-adams")
PROGRESS_CHUNKS = 20
PROGRESS_MIN_POINTS = 1000
PROGRESS_AFTER_SECONDS = 1.0
SOLVER_STEPS_PER_CHECK = 16.0   # the state-selection monitor checks its quality about this often
HORIZON_REACH = 2.0             # a piece aimed at a predicted switch reaches this many times as far,
PIECE_GROWTH = 4                # and one that needed no cut makes the next this many times longer (both
                                # while the run has had no switch, change point or state event)
RTOL_RANGE = (1e-14, 1.0)        # a relative error per step: 1 or more lets a step be wrong by its whole
                                # size; below 1e-14 round-off in double precision cannot meet it
MAX_PIECE_POINTS = 20_000       # monitor points in one piece at most


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
    """Builds and caches one integrator per output pattern (normalised grid), in this thread's cache of the
    compiled model (`caches.py`: an integrator cannot serve two threads at once)."""

    def __init__(self, cm, dae, plugin, extra, rtol, atol, max_steps, inputs):
        self.cm, self.dae, self.plugin, self.extra = cm, dae, plugin, extra
        self.rtol, self.atol, self.max_steps = rtol, atol, max_steps
        self.inputs = inputs
        self.base_key = (id(dae), plugin, tuple(sorted(extra.items())), rtol, atol, max_steps, inputs.key())

    def get(self, tau: tuple, max_steps: int | None = None):
        """Integrator over a normalised grid (t = t0 + τ·h): reusable for every segment of that pattern.
        `max_steps` lowers the step limit of this call (a power of two, so few variants are built)."""
        return self._cached(self.base_key + (tau, max_steps), lambda: self._build(tau, max_steps=max_steps))

    def get_real(self, points: tuple):
        """Integrator over a fixed grid in real time: no time scaling in the right-hand side.

        Used for plain segments (reused when the same grid is simulated again);
        the parameters keep the [u; p; d; t0; h; tables] layout, t0 and h unused.
        """
        return self._cached(self.base_key + ("real", points),
                            lambda: self._build(tuple(points[1:]), t0_real=points[0]))

    def _cached(self, key, build):
        cache = self.cm.integrators()
        if key not in cache:
            with BUILD_LOCK:
                cache[key] = build()
        return cache[key]

    def _build(self, tau: tuple, t0_real=None, max_steps=None):
        """Parameters of the integrator: [u; p; d; t0; h; tables] (tables: `InputPlan.table_data`)."""
        dae = self.dae
        sym = ca.MX if self.inputs.varying else ca.SX
        xs, zs = sym.sym("xs", dae.x.numel()), sym.sym("zs", dae.z.numel())
        s, t0, h = sym.sym("tau"), sym.sym("t0"), sym.sym("h")
        u, p, d = sym.sym("u", dae.u.numel()), sym.sym("p", dae.p.numel()), sym.sym("d", dae.d.numel())
        tables = sym.sym("tables", self.inputs.table_data().size)
        xn = ca.DM(list(dae.x_nominal)) if dae.x_nominal else ca.DM(0, 1)
        zn = ca.DM(list(dae.z_nominal)) if dae.z_nominal else ca.DM(0, 1)
        t = t0 + s * h if t0_real is None else s
        if self.inputs.varying:
            interp = self.inputs.interpolated(t, tables)
            u_t = ca.vertcat(*[interp[k] if k in interp else u[k] for k in range(dae.u.numel())])
        else:
            u_t = u
        args = (t, xn * xs, zn * zs, u_t, p, d)
        rate = dae.ode(*args) / xn
        spec = {"x": xs, "t": s, "p": ca.vertcat(u, p, d, t0, h, tables),
                "ode": h * rate if t0_real is None else rate}
        if dae.z.numel():
            spec["z"] = zs
            spec["alg"] = dae.alg(*args)
            if sym is ca.SX:              # ode and alg share the loop's trigonometry: one elimination for both
                spec["ode"], spec["alg"] = ca.cse([spec["ode"], spec["alg"]])
        opts = dict(self.extra, reltol=self.rtol, abstol=self.atol, max_num_steps=max_steps or self.max_steps,
                    disable_internal_warnings=True, show_eval_warnings=False)
        opts["common_options"] = jacobian_options(dae, self.plugin, self.extra)
        return ca.integrator("F", self.plugin, spec, 0.0 if t0_real is None else float(t0_real), list(tau), opts)


JACOBIAN_CHOICE_MAX = 50_000     # residual instructions × unknowns: above it (a 10-link chain's ODE) comparing costs
                                 # more than it can save in one run, and forward and reverse cost the same there


def jacobian_options(dae, plugin: str, extra: dict) -> dict:
    """How the integrator differentiates the residual for its Newton matrix: the cheaper of forward and
    reverse mode, counted once per selection. CasADi's default picks forward mode for a loop's residual,
    whose few state rows hold most of the work: reverse mode halves that Jacobian (slider-crank 3161 ->
    1713 instructions, four-bar 4445 -> 2204; docs/benchmarks.md). Functional iteration (Adams) needs
    no Jacobian."""
    if plugin == "cvodes" and extra.get("nonlinear_solver_iteration") == "functional":
        return {}
    if "_jacobian_options" not in dae.info:            # per compiled selection, across runs
        size = (dae.ode.n_instructions() + dae.alg.n_instructions()) * (dae.x.numel() + dae.z.numel())
        choice = {}
        if size <= JACOBIAN_CHOICE_MAX:
            args = [dae.t, dae.x, dae.z, dae.u, dae.p, dae.d]
            res, unknowns = ca.vertcat(dae.ode(*args), dae.alg(*args)), ca.vertcat(dae.x, dae.z)

            def cost(opts):
                return ca.Function("newton_matrix", args, [ca.jacobian(res, unknowns, opts)]).n_instructions()
            if cost({"allow_forward": False}) < cost({}):
                choice = {"allow_forward": False}
        dae.info["_jacobian_options"] = choice
    return dae.info["_jacobian_options"]


def _solver_messages_muted(mute: bool):
    """SUNDIALS's error messages reach Python's sys.stderr through CasADi, also when a piece runs out of
    the step budget it was given on purpose (`_step_budget`): the run retries it shorter, and the
    message only confused users (the demo's Cartesian pendulum printed six). Muted for those calls;
    a real failure is reported by the run itself (IntegrationError)."""
    return contextlib.redirect_stderr(io.StringIO()) if mute else contextlib.nullcontext()


def _call(F, xs, zs, p):
    """One integrator call. IDAS's consistent-initial-condition search can fail on a point that is
    already consistent (its line search cannot shrink a residual that is round-off): retried once from
    algebraic values nudged by 1e-6 relative, which it then corrects in a genuine Newton step (without
    this, tests/analytic/test_loops.py's kinematic four-bar fails at t = 3.09 s)."""
    try:
        return F(x0=xs, z0=zs, p=p)
    except RuntimeError as exc:
        if "LINESEARCH" not in str(exc).upper() or not np.size(zs):
            raise
        return F(x0=xs, z0=np.asarray(zs) * (1 + 1e-6) + 1e-9, p=p)


def simulate(cm, t_end: float, *, t_start: float = 0.0, rtol: float = 1e-6, atol: float = 1e-8,
             method: str = "auto", n_out: int | None = None, t_out=None, params: dict | None = None,
             inputs: dict | None = None, start: dict | None = None, guess: dict | None = None,
             max_steps: int = 20_000, progress: bool | None = None, steady_state: bool = False,
             continue_from: Result | None = None) -> Result:
    """Integrate the compiled model from `t_start` to `t_end`.

    `start` fixes values (any dotted name), `guess` only seeds the Newton
    iteration; `inputs` maps input names to numbers, callables f(t), (times,
    values) pairs or N×2 arrays. `steady_state=True` starts from der(x) = 0
    (every state; fixed start values then over-specify). `progress=None` shows a bar when a long grid
    (≥ 1000 points) takes more than a second. A solver failure returns the
    partial result with `result.failure` set (and a warning); it does not raise.
    `continue_from=res` continues a run: it starts at res's final time from its
    final states (fixed) with every other final value as a guess, so dependent
    coordinates stay on their branch; the components' own start values do not apply.
    """
    dae = cm.dae
    t_start, t_end = _check_time(t_start, "t_start"), _check_time(t_end, "t_end")
    rtol, atol = _check_tolerance(rtol, "rtol"), _check_tolerance(atol, "atol")
    if not RTOL_RANGE[0] <= rtol < RTOL_RANGE[1]:
        why = "each step could be wrong by its whole size" if rtol >= 1 else "double precision cannot meet it"
        raise MechnetError(f"rtol = {rtol!r} must lie in [{RTOL_RANGE[0]:g}, {RTOL_RANGE[1]:g}): it is the relative "
                           f"error each step may make, and at {rtol:g} {why}")
    if continue_from is not None:
        if not isinstance(continue_from, Result):
            raise MechnetError(f"continue_from takes a Result, got {type(continue_from).__name__}")
        t_start = continue_from.final_time
        guess = {**continue_from.final_values, **(guess or {})}
        dae = _selection_with_states(cm, continue_from.state_names) or dae
    method, plugin, extra = _plugin(dae, method)
    if t_out is not None:
        if n_out is not None:
            raise MechnetError("give either n_out or t_out, not both")
        grid = np.asarray(t_out, dtype=float)
        if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0) or not np.all(np.isfinite(grid)):
            raise MechnetError("t_out must be an increasing sequence of at least two finite times")
        if abs(t_end - grid[-1]) > 1e-12 * max(1.0, abs(t_end)):
            raise MechnetError(f"t_end = {t_end:g} but t_out ends at {grid[-1]:g}; pass t_end = t_out[-1]")
        t_start, t_end = float(grid[0]), float(grid[-1])
    else:
        if not (np.isfinite(t_end) and np.isfinite(t_start) and t_end > t_start):
            raise MechnetError(f"t_end = {t_end} must be finite and greater than t_start = {t_start}")
        if n_out is not None and (not isinstance(n_out, (int, np.integer)) or n_out < 2):
            raise MechnetError(f"n_out = {n_out!r} must be a whole number of at least 2 output points")
        grid = np.linspace(t_start, t_end, int(n_out or 501))
    plan = plan_inputs(dae, inputs, t_start, t_end, max(grid.size, 2001))
    p = _resolve_params(dae, params)
    d = np.array(dae.d_value, dtype=float)
    starts = dict(continue_from.final_state) if continue_from is not None else dict(dae.starts)
    for name, value in (start or {}).items():
        if name not in dae.observed_names:
            raise unknown_name(name, dae.observed_names, "start value for")
        starts[name] = _check_value(value, f"start value {name}")
    for name, value in (guess or {}).items():
        if name not in dae.observed_names:
            raise unknown_name(name, dae.observed_names, "guess for")
        _check_value(value, f"guess {name}")

    wall = _time.perf_counter()
    with BUILD_LOCK:                 # builds the initial system on a model's first run (caches.py)
        init = initialize(dae, t_start, plan.constant, p, starts, guess or {}, steady_state)
    events = breakpoints(dae.time_events, t_start, t_end)
    grid = output_grid(grid, events)
    run = _Run(cm, dae, plugin, extra, rtol, atol, max_steps, plan, p, d, init)
    run.integrate(grid, events, progress)
    stats = run.stats
    stats["wall_time"] = _time.perf_counter() - wall
    stats["method"], stats["plugin"] = method, plugin
    T = np.array(run.T)

    def observe() -> np.ndarray:
        values = np.empty((T.size, len(dae.observed_names)))
        k = 0
        while k < T.size:                  # rows integrated with the same selection, observed together
            j = k
            while j + 1 < T.size and run.D[j + 1] is run.D[k]:
                j += 1
            X = np.array(run.X[k: j + 1]).reshape(j + 1 - k, -1)
            Z = np.array(run.Z[k: j + 1]).reshape(j + 1 - k, -1)
            values[k: j + 1] = _observe(run.D[k], T[k: j + 1], X, Z, plan, p, d)
            k = j + 1
        return values

    final = run.D[-1] if run.D else dae
    known = {}
    if T.size and all(sel is final for sel in run.D):
        # one selection throughout: its states and algebraics are the run's own; every other name is
        # computed when first asked for (most callers read a few names of hundreds)
        X = np.array(run.X).reshape(T.size, -1)
        Z = np.array(run.Z).reshape(T.size, -1)
        known = {**{n: X[:, k] for k, n in enumerate(final.x_names)},
                 **{n: Z[:, k] for k, n in enumerate(final.z_names)}}
        observed = observe
    else:
        observed = observe()
        column = {n: c for c, n in enumerate(dae.observed_names)}
        X = observed[:, [column[n] for n in final.x_names if n in column]] \
            if all(n in column for n in final.x_names) else np.array(run.X)
    result = Result(T, observed, dae.observed_names, dae.units, stats, X, np.zeros((T.size, 0)), final.x_names,
                    events=run.events, failure=run.failure, known=known,
                    initial={"fixed": init.fixed, "free_states": init.free_states, "residual": init.residual})
    if run.failure is not None:
        run.failure.result = result
        warnings.warn(str(run.failure), IntegrationWarning, stacklevel=3)
    return result


def _selection_with_states(cm, names):
    """The compiled selection whose states are `names` (a continued run goes on with the states it ended
    with; else the monitor switches back to them at its start), compiled if needed (a result loaded
    from a file into a fresh model); None when no selection has them."""
    for sel in (cm.dae, *cm._selections.values()):
        if set(sel.x_names) == set(names):
            return sel
    factory = cm.selection_factory
    if factory is None:
        return None
    for dummies in selections(factory) or []:                  # None past MAX_SELECTIONS: the default one
        if set(state_names(factory, dummies)) == set(names):
            try:
                return cm.selection(dummies)
            except (MechnetError, RuntimeError):      # that selection cannot be compiled: the default one
                return None
    return None


def _check_time(value, what: str) -> float:
    return finite_number(value, f"{what} (s)", MechnetError)


def _check_tolerance(value, what: str) -> float:
    number = finite_number(value, what, MechnetError)
    if not number > 0:
        raise MechnetError(f"{what} = {value!r} must be a positive number")
    return number


def _check_value(value, what: str) -> float:
    return finite_number(value, what, InitializationError)


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


class _Run(StateEvents, Reselection, ChangePoints):
    """The segment loop: integrate between boundaries, restart at events, stop at a failure."""

    def __init__(self, cm, dae, plugin, extra, rtol, atol, max_steps, plan, p, d, init):
        self.cm, self.plan, self.p, self.d = cm, plan, p, d
        self.tables = plan.table_data()
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
        self._fold_floor = None                        # a new selection: no failed step over to remember
        self.integrators = _Integrators(self.cm, dae, plugin, extra, rtol, atol, max_steps, self.plan)
        self.xn = np.array(dae.x_nominal, dtype=float)
        self.zn = np.array(dae.z_nominal, dtype=float)

    def _record(self, t):
        self.T.append(t)
        self.X.append(self.x.copy())
        self.Z.append(self.z.copy())
        self.D.append(self.dae)

    def pvec(self, t0, h):
        return np.concatenate([self.plan.constant, self.p, self.d, [t0, h], self.tables])

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
        barred = any(0 < c < grid.size - 1 for c in cuts)     # the cuts for winding alone show no bar
        cuts = sorted(set(cuts) | set(chunk_bounds(grid.size, self._winding_chunks(grid))))
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
                    bar = tqdm(total=float(grid[-1] - grid[0]), unit="s", desc="simulate", leave=False,
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

    def _turns(self, t):
        """The whole turns of the coordinates the equations see only through sine and cosine
        (`branch.whole_turns`): left out of each integrator call, so an angle of thousands of turns
        keeps the precision of one near zero (added back to the outputs)."""
        px, pz = whole_turns(self.dae, self.x, self.z, self._u_at(t), self.p, self.d)
        return turns_of(self.x, px), turns_of(self.z, pz)

    def _winding_chunks(self, grid) -> int:
        """Calls enough that no periodic state winds more than TURN_LIMIT in one (at its starting rate):
        within a call the angle grows again, and with it the round-off in everything computed from it."""
        px, _ = whole_turns(self.dae, self.x, self.z, self._u_at(grid[0]), self.p, self.d)
        if not px.any():
            return 1
        rate = np.abs(np.asarray(self.dae.ode(grid[0], self.x, self.z, self._u_at(grid[0]), self.p, self.d))).ravel()
        wind = float(np.max(np.where(px > 0, rate, 0.0))) * (grid[-1] - grid[0])
        return int(min(np.ceil(wind / TURN_LIMIT), grid.size // 2)) if np.isfinite(wind) else 1

    def _inputs_at(self, ts):
        """The inputs at each of the times ts, one column per time."""
        return self.plan.at(ts)

    def _segment(self, points) -> bool:
        ok, message = self._attempt(points)
        return ok or self._recover(points, message)

    def _attempt(self, points) -> tuple[bool, str]:
        """Integrate over `points` in one call; on success append the outputs and move the state."""
        t0, h = points[0], points[-1] - points[0]
        F = self.integrators.get_real(tuple(float(v) for v in points))
        ox, oz = self._turns(t0)
        xs = (self.x - ox) / self.xn
        zs = (self.z - oz) / self.zn if self.zn.size else np.zeros(0)
        try:
            out = _call(F, xs, zs, self.pvec(t0, h))
        except RuntimeError as exc:
            return False, str(exc)
        xf = np.asarray(out["xf"]).reshape(self.xn.size, -1).T * self.xn + ox
        zf = (np.asarray(out["zf"]).reshape(self.zn.size, -1).T * self.zn + oz) if self.zn.size \
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
        so the running selection's quality moves by at most ~0.05 between points. While
        nothing has happened, a piece that needed no cut makes the next PIECE_GROWTH times
        longer, up to the rest of the run: each restart costs IDAS ~30 ramp-up steps, so the
        benchmark's loops run in 5 calls (were 11–14). A failed piece is retried at half its
        length, and at most half-way to the last point it reached. A piece holds at most MAX_PIECE_POINTS
        monitor points (memory: the monitor batches them all).
        """
        n_int = grid.size - 1
        longest = n_int
        per_piece = 1
        density = 4                                   # monitor points per output interval
        fraction = 1.0                                # of the first interval, when pieces must be short
        grid_set = set(grid.tolist())
        t_cur, k = grid[0], 0                         # current time; next output index is k + 1
        if not self._arm(t_cur):                      # a condition crossing at the start fired at once
            return
        while k < n_int:
            per_piece = max(1, min(per_piece, MAX_PIECE_POINTS // density))
            k_end = min(k + per_piece, n_int)
            for j in range(k + 1, k_end + 1):
                if grid[j] in event_at:
                    k_end = j
                    break
            first_end = t_cur + fraction * (grid[k + 1] - t_cur)
            starts = np.concatenate([[t_cur], grid[k + 1: k_end]])
            ends = np.concatenate([[first_end], grid[k + 2: k_end + 1]])
            steps = np.arange(1, density + 1) / density          # density points per span, its end last
            inner = starts[:, None] + (ends - starts)[:, None] * steps[None, :]
            inner[:, -1] = ends                                   # ends exactly on the output times
            pts = np.concatenate([[t_cur], inner.ravel()])
            is_output = [False] * pts.size
            for j, b in enumerate(ends):
                is_output[(j + 1) * density] = bool(b == grid[k + 1] or b in grid_set)
            ok, message, xs, zs = self._dense(pts, budgeted=per_piece > 1 or fraction < 1)
            t_next = self._step_over_from(t_cur, grid) if not ok else None
            if t_next is not None:                    # failed at a change point: shorter pieces cannot help
                t_cur, per_piece, fraction = t_next, 1, 1.0
                k = int(np.searchsorted(grid, t_cur, side="right")) - 1
                continue
            if not ok and per_piece > 1:
                # maybe a switch was due inside: look closer. Halve, and end at most half-way to the
                # last point the failed call reached (from its statistics): a piece ending just before
                # it failed again on the triple rocker (the solver crawls for a while before it gives up)
                reached = int(np.searchsorted(grid, self._failed_at, side="left")) - 1 - k \
                    if self._failed_at is not None else 0
                per_piece = max(1, min(per_piece // 2, reached // 2)) if reached > 0 else per_piece // 2
                continue
            if not ok and self.monitor is not None and fraction > 1e-3:
                fraction /= 4                         # a switch due within this interval: take part of it
                density = min(256, density * 2)
                continue
            if not ok:
                if self._recover(np.concatenate([[t_cur], grid[k + 1: k_end + 1]]), message):
                    t_next = self.T[-1]                # integrated after all (one output interval at a time)
                else:
                    t_next = self._pass_change_point(grid)
                if t_next is None:
                    return
                t_cur, per_piece, fraction = t_next, 1, 1.0
                k = int(np.searchsorted(grid, t_cur, side="right")) - 1
                continue
            self.refine_at = None
            ratios, switch_at = self._ratios(pts, xs, zs)
            self._last_conditioning = None
            found = self._first_fold(pts, xs, zs) if self.refine_at is None else None
            fold, conds = found if found is not None else (None, None)
            before = [j for j in range(fold) if pts[j] < pts[fold]] if fold is not None else []
            if before and pts[fold] > t_cur and (switch_at is None or fold <= switch_at):
                # a change point ahead: keep the piece up to it, then step over it with the velocity
                for m in range(1, fold + 1):
                    if is_output[m]:
                        self.x, self.z = xs[m], zs[m]
                        self._record(pts[m])
                self.x, self.z = xs[fold].copy(), zs[fold].copy()
                ts, xh, zh = self._history(pts[: fold + 1], xs[: fold + 1], zs[: fold + 1])
                t_b = self._step_over(grid, grid[-1], ts, xh, zh, self._conditioning(ts, xh, zh))
                if t_b is None:                       # not passed from here: look again only much closer
                    self._fold_floor = conds[fold] / 10
                t_cur, per_piece, fraction = (t_b if t_b is not None else pts[fold]), 1, 1.0
                k = int(np.searchsorted(grid, t_cur, side="right")) - 1
                continue
            limit = switch_at if self.refine_at is None else self.refine_at
            crossing = self._first_crossing(pts, xs, zs, limit)
            if crossing is not None:
                switch_at = None
            if self.refine_at is not None and crossing is None:
                # the monitor was too coarse for this stretch: keep what is safe, look closer from there
                stop = self.refine_at
                density = min(1024, density * 4)
                per_piece = 1
                if stop == 0:
                    fraction = max(fraction / 4, 1e-6)
                    continue
            else:
                stop = crossing if crossing is not None else (switch_at if switch_at is not None else len(pts) - 1)
            fraction = 1.0
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
                # while nothing but time events has happened, pieces grow fast and far (a mechanism that
                # never switches pays few restarts); once the run has switched, stepped over a change
                # point or stopped at a state event, more will likely come: pieces grow by 2 up to a fifth
                # of the run and aim at the straight-line horizon, so little is integrated past each
                # (the Cartesian pendulum's 40 switches took 78 % more steps with fast growth)
                quiet = all(e.kind == "time" for e in self.events)
                reach = HORIZON_REACH if quiet else 1.0
                per_piece = min(longest, PIECE_GROWTH * per_piece) if quiet else \
                    min(max(1, n_int // 5), 2 * per_piece)
                if self.monitor is not None and stop >= 2:
                    # aim the next piece to end near the predicted switch: the quality falling to 0.9× the
                    # hysteresis share of the best choice's quality at the last full check (~0.45 when
                    # the best is ideal; a loop's choices all sit lower). The straight line through the
                    # last slope runs out early when the quality oscillates with the crank (a switch then
                    # rarely comes): the piece reaches HORIZON_REACH times as far, so a wrong guess costs
                    # at most that much integration past a switch, a too-short one a restart
                    slope = (ratios[stop] - ratios[stop - 1]) / max(pts[stop] - pts[stop - 1], 1e-300)
                    switch_level = 0.9 * self.monitor.HYSTERESIS * self.monitor.last_best
                    if slope < 0 and ratios[stop] > switch_level:
                        horizon = reach * (ratios[stop] - switch_level) / -slope
                        per_piece = int(min(per_piece, max(1, horizon // (grid[1] - grid[0]))))
                ahead = self._fold_ahead(pts[: stop + 1])
                if ahead is not None and ahead > t_cur:
                    # a change point ahead: end the next piece half-way to it (an integrator running
                    # into the rank loss crawls to its step limit before it fails)
                    reach = 0.5 * (ahead - t_cur)
                    per_piece = int(min(per_piece, max(1, reach // (grid[1] - grid[0]))))
                    if k + 1 < grid.size and reach < grid[k + 1] - t_cur:
                        fraction = max(reach / (grid[k + 1] - t_cur), 1e-3)
            steps = np.abs(np.diff(ratios[: stop + 1])) if stop > 0 else np.zeros(1)
            worst = float(np.max(steps)) if steps.size else 0.0
            if worst > 0.05 and density < 256:
                density *= 2
            elif worst < 0.01 and density > 1 and self.monitor is not None:
                density //= 2
            # never coarser than about two solver steps with zero crossings to find (what the solver
            # resolves, the crossing search sees), or SOLVER_STEPS_PER_CHECK for the quality alone
            h_solver = getattr(self, "_mean_step", 0.0)
            if np.isfinite(h_solver) and h_solver > 0:
                per_check = 2.0 if self.dae.zero_labels else SOLVER_STEPS_PER_CHECK
                density = int(min(1024, max(density, np.ceil((grid[1] - grid[0]) / (per_check * h_solver)))))

    def _dense(self, pts, budgeted=False):
        """One integrator call over pts (unrecorded); returns the states at every point. `budgeted`:
        with the step limit of `_step_budget`."""
        t0, h = pts[0], pts[-1] - pts[0]
        tau = tuple(float(v) for v in np.round((pts[1:] - t0) / h, 12))   # 12 digits: grid round-off shares keys
        budget = self._step_budget(float(np.max(np.diff(pts)))) if budgeted else None
        F = self.integrators.get(tau, budget)
        self._failed_at = None
        try:
            with _solver_messages_muted(budget is not None):
                ox, oz = self._turns(t0)
                out = _call(F, (self.x - ox) / self.xn, (self.z - oz) / self.zn if self.zn.size else np.zeros(0),
                            self.pvec(t0, h))
        except RuntimeError as exc:
            # after a failure CasADi's `tcur` is the last output time the solver reached (normalised; 0
            # when it failed before the first): the failure lies after it
            reached = F.stats().get("tcur", float("nan"))
            self._failed_at = t0 + reached * h if np.isfinite(reached) and 0 < reached < 1 else None
            return False, str(exc), None, None
        s = F.stats()
        for key in ("nsteps", "nfevals", "netfails"):
            self.stats[key] += int(s.get(key, 0))
        self.stats["segments"] += 1
        self.stats["hlast"] = float(s.get("hlast", float("nan"))) * h
        # the mean step of this piece (the last step alone can be tiny: a restart, an output time)
        self._mean_step = h / max(int(s.get("nsteps", 0)), 1)
        xf = np.asarray(out["xf"]).reshape(self.xn.size, -1).T * self.xn + ox
        zf = (np.asarray(out["zf"]).reshape(self.zn.size, -1).T * self.zn + oz) if self.zn.size \
            else np.zeros((xf.shape[0], 0))
        return True, "", np.vstack([self.x, xf]), np.vstack([self.z.reshape(1, -1), zf])

    def _step_budget(self, gap):
        """Step limit of a monitored piece whose monitor points lie at most `gap` apart (SUNDIALS counts
        steps per output time): 8× the steps the run has needed per second so far over that gap (at
        least 1024, a power of two, below max_steps). A long piece that runs into a change point the
        monitor did not foresee then fails after about a thousand steps per monitor interval instead
        of crawling to max_steps (0.7 s each on the parallelogram); it is retried shorter, and a piece
        of one output interval runs without the limit."""
        steps, t_done = self.stats["nsteps"], (self.T[-1] - self.T[0]) if len(self.T) > 1 else 0.0
        if steps < 100 or t_done <= 0:
            return None
        budget = 2 ** int(np.ceil(np.log2(max(1024.0, 8.0 * steps / t_done * gap))))
        return budget if budget < self.settings[4] else None

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
        output interval of the failure. True when every piece integrated after all (the
        failed call had a step budget, or several output intervals at once).
        """
        solver = _solver_message(message)
        n = points.size - 1
        if self.zn.size and self.T:
            # restart from algebraics consistent to Newton's precision, not just to the integrator's:
            # IDAS's own initial-condition search can fail on a point that is consistent only to rtol
            try:
                self.z = solve_algebraic(self.dae, self.T[-1], self.x, self.z, self._u_at(self.T[-1]),
                                         self.p, self.d)
            except MechnetError:
                pass
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
        if a == n:
            return True                                # every piece integrated: no failure after all
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
        return False


def _observe(dae, T, X, Z, plan, p, d) -> np.ndarray:
    n = T.size
    if n == 0:
        return np.zeros((0, len(dae.observed_names)))
    U = plan.at(T)
    observed = mapped_in(dae.info.setdefault("_observed_maps", {}), dae.observed, n)
    y, = observed(T.reshape(1, -1), X.T, Z.T, U, np.tile(p.reshape(-1, 1), n), np.tile(d.reshape(-1, 1), n))
    return y.T


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
