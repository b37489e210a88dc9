"""`simulate`: check the arguments, initialise, run the simulation loop (`run.py`), assemble the `Result`."""
from __future__ import annotations

import os
import sys
import time as _time
import warnings
from contextvars import ContextVar

import casadi as ca
import numpy as np

from ..caches import BUILD_LOCK
from ..core.errors import InitializationError, IntegrationError, MechnetError, ParameterError, UnknownNameError
from ..core.arguments import flag, mapping, whole_number
from ..core.declarations import finite_number, number_array
from ..core.requirements import check_values
from ..interrupts import Interrupted, interrupted, watched
from ..solver_output import captured
from .branch import selections, state_names
from .events import breakpoints, output_grid
from .initialize import initialize, ready_to_integrate
from .inputs import plan_inputs
from .result import Result, unknown_name
from .rows import observe
from .run import Run
from .solvers import choose_method

RTOL_RANGE = (1e-14, 1.0)        # a relative error per step: 1 or more lets a step be wrong by its whole
                                # size; below 1e-14 round-off in double precision cannot meet it


TEMPLATE: ContextVar = ContextVar("template", default=None)   # a dict `prepared.py` asks a run to fill


class IntegrationWarning(UserWarning):
    """Issued when simulate() returns a partial result after a solver failure."""


@watched("simulate")
def simulate(cm, t_end: float, *, t_start: float | None = None, rtol: float = 1e-6, atol: float = 1e-8,
             method: str = "auto", n_out: int | None = None, t_out=None, params: dict | None = None,
             inputs: dict | None = None, start: dict | None = None, guess: dict | None = None,
             max_steps: int = 20_000, progress: bool | None = None, steady_state: bool = False,
             continue_from: Result | None = None) -> Result:
    """Integrate the compiled model from `t_start` to `t_end`.

    `start` fixes values (any dotted name), `guess` only seeds the Newton iteration. `inputs` maps input
    names to numbers, callables f(t) (sampled: jumps are smeared), (times, values) pairs or N×2 arrays (a
    time given twice is a jump), or a `Table`/`Signal` (exact, its knots time events).
    `method="auto"`: CVODES Adams for an explicit ODE, BDF from the first sign of stiffness on; IDAS for
    a DAE (`res.stats["method"]`, `res.stats["method_reason"]`). `steady_state=True` starts from
    der(x) = 0 (every state; fixed start values then over-specify). `progress=None` shows a bar when a
    long grid (≥ 1000 points) takes more than a second. A solver failure returns the partial result with
    `result.failure` set (and a warning); it does not raise. Ctrl-C raises `mechnet.Interrupted` (a
    KeyboardInterrupt) at once, the partial result in its `.result` (`failure.reason == "interrupted"`).
    `continue_from=res` continues a run: it starts at res's final time from its
    final states (fixed) with every other final value as a guess, so dependent
    coordinates stay on their branch; the components' own start values do not apply.
    A `t_start` (or `t_out`) other than res's final time, or `start` values, would make it no
    continuation (a jump in time or state): they are refused.
    """
    dae = cm.dae
    if _nothing_moves(dae):
        raise MechnetError(f"model {cm.name!r} has nothing to simulate: no state or algebraic variable, and "
                           f"nothing depends on time or an input (add an Inertia, a Mass or a Body)")
    params, inputs = mapping(params, "simulate(params=...)"), mapping(inputs, "simulate(inputs=...)")
    start, guess = mapping(start, "simulate(start=...)"), mapping(guess, "simulate(guess=...)")
    max_steps = whole_number(max_steps, "max_steps", 1)
    progress = flag(progress, "progress", allow_none=True)
    steady_state = flag(steady_state, "steady_state")
    given_start = None if t_start is None else _check_time(t_start, "t_start")
    t_start, t_end = given_start or 0.0, _check_time(t_end, "t_end")
    rtol, atol = _check_tolerance(rtol, "rtol"), _check_tolerance(atol, "atol")
    if not RTOL_RANGE[0] <= rtol < RTOL_RANGE[1]:
        why = "each step could be wrong by its whole size" if rtol >= 1 else "double precision cannot meet it"
        raise MechnetError(f"rtol = {rtol!r} must lie in [{RTOL_RANGE[0]:g}, {RTOL_RANGE[1]:g}): it is the relative "
                           f"error each step may make, and at {rtol:g} {why}")
    if continue_from is not None:
        if not isinstance(continue_from, Result):
            raise MechnetError(f"continue_from takes a Result, got {type(continue_from).__name__}")
        # every column, not the states only: another model with states of the same names is still another
        foreign = [n for n in continue_from.names if n not in dae.observed_names]
        if foreign:
            raise MechnetError(f"continue_from holds a result of another model: model {cm.name!r} has no "
                               f"{', '.join(foreign[:3])}")
        t_start = continue_from.final_time
        _check_continuation(continue_from, given_start, start)
        guess = {**continue_from.final_values, **(guess or {})}
        dae = _selection_with_states(cm, continue_from.state_names) or dae
    choice = choose_method(dae, method)
    if t_out is not None:
        if n_out is not None:
            raise MechnetError("give either n_out or t_out, not both")
        try:
            grid = number_array(t_out)
        except (TypeError, ValueError):
            raise MechnetError(f"t_out = {t_out!r:.60} must be an increasing sequence of times (s)") from None
        if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0) or not np.all(np.isfinite(grid)):
            raise MechnetError("t_out must be an increasing sequence of at least two finite times")
        if abs(t_end - grid[-1]) > 1e-12 * max(1.0, abs(t_end)):
            raise MechnetError(f"t_end = {t_end:g} but t_out ends at {grid[-1]:g}; pass t_end = t_out[-1]")
        if continue_from is not None and grid[0] != t_start:
            raise MechnetError(f"continue_from=res goes on from res's final time {t_start:.17g} s, but t_out starts "
                               f"at {grid[0]:.17g} s; start t_out at res.final_time (or simulate anew, without "
                               f"continue_from)")
        t_start, t_end = float(grid[0]), float(grid[-1])
    else:
        if not (np.isfinite(t_end) and np.isfinite(t_start) and t_end > t_start):
            raise MechnetError(f"t_end = {t_end} must be finite and greater than t_start = {t_start}")
        n_out = 501 if n_out is None else whole_number(n_out, "n_out (output points)", 2)
        _check_result_size(n_out, len(dae.observed_names))
        grid = np.arange(n_out) * ((t_end - t_start) / (n_out - 1)) + t_start    # np.linspace's numbers,
        grid[-1] = t_end                                                          # without its 10 µs
    plan = plan_inputs(dae, inputs, t_start, t_end, max(grid.size, 2001))
    p = _resolve_params(dae, params)
    d, starts = start_values(dae, start, guess, continue_from)

    wall = _time.perf_counter()
    init = initialize(dae, t_start, plan.constant, p, starts, guess or {}, steady_state, d)
    init = ready_to_integrate(dae, t_start, init, plan.constant, p, d)
    _check_requirements(dae, t_start, init, plan, p, d, rtol, atol)
    events = breakpoints((*dae.time_events, *plan.time_events), t_start, t_end)
    grid = output_grid(grid, events)
    run = Run(cm, dae, choice, rtol, atol, max_steps, plan, p, d, init)
    with captured() as messages:             # SUNDIALS's text stays with this run (solver_output.py)
        try:
            run.integrate(grid, events, progress)
        except BaseException:                # a KeyboardInterrupt, or a failure CasADi made of one
            if not interrupted():
                raise
    if interrupted():
        run.failure = interruption(run)
        raise Interrupted("simulate", assemble(cm, dae, run, wall, messages, init, plan, p)
                          if len(run.rows) else None) from None
    sink = TEMPLATE.get()
    if sink is not None:                       # `prepared.py` asked what this run was
        sink.update(dae=dae, grid=grid, plan=plan, d=d, init=init, choice=choice, events=events, run=run,
                    settings=(t_start, rtol, atol, max_steps, steady_state))
    return assemble(cm, dae, run, wall, messages, init, plan, p)


def interruption(run) -> IntegrationError:
    """The failure of a run stopped by Ctrl-C where its rows end (`mechnet.interrupts`)."""
    run.rows.count = sum(len(b.t) for b in run.rows.blocks)      # (the interrupt may have hit `Rows.add`)
    t = run.rows.last.t if len(run.rows) else float("nan")
    run.stats["interrupted_at"] = t
    return IntegrationError(f"interrupted (Ctrl-C) at t = {t:.6g} s; the result holds the solution up to there",
                            t=t, step=run.stats.get("hlast", float("nan")), worst="-",
                            solver_message="interrupted", reason="interrupted")


def _check_continuation(res, t_start, start):
    """A continued run starts where `res` ended, in time and state: a different t_start or start values
    would silently jump one of them (issue 31), so either is refused, naming the conflict."""
    if t_start is not None and t_start != res.final_time:
        raise MechnetError(f"continue_from=res goes on from res's final time {res.final_time:.17g} s, and t_start = "
                           f"{t_start:.17g} s conflicts with it; leave t_start out (or simulate anew, without "
                           f"continue_from)")
    if start:
        names = ", ".join(sorted(start)[:3]) + (", ..." if len(start) > 3 else "")
        raise MechnetError(f"continue_from=res starts from res's final state, and start values ({names}) would jump "
                           f"it; leave start out to continue, or simulate anew (without continue_from) from start "
                           f"values; a guess= is fine")


def start_values(dae, start: dict | None, guess: dict | None, continue_from=None) -> tuple[np.ndarray, dict]:
    """(modes, start values) of a run: the components' starts (or a continued run's final state and
    modes) with `start` over them; every name of `start` and `guess` checked."""
    d = np.array(dae.d_value, dtype=float)
    if continue_from is not None:              # a continued run goes on in the modes it ended in
        d = np.array([continue_from.final_values.get(n, v) for n, v in zip(dae.d_names, d)], dtype=float)
    starts = dict(continue_from.final_state) if continue_from is not None else dict(dae.starts)
    for name, value in (start or {}).items():
        if name not in dae.observed_names:
            raise unknown_name(name, dae.observed_names, "start value for")
        if name in dae.d_names:                # a mode's start is its value, not an equation
            d[dae.d_names.index(name)] = _mode_value(dae, name, value)
            continue
        starts[name] = _check_value(value, f"simulate(start=...): start value {name}")
    for name, value in (guess or {}).items():
        if name not in dae.observed_names:
            raise unknown_name(name, dae.observed_names, "guess for")
        _check_value(value, f"simulate(guess=...): guess {name}")
    return d, starts


def _mode_value(dae, name, value) -> float:
    """A mode's start value: a number among the values its component declares it can take."""
    value = _check_value(value, f"simulate(start=...): start value {name}")
    allowed = dae.info.get("mode_values", {}).get(name)
    if allowed is not None and value not in allowed:
        raise MechnetError(f"simulate(start=...): start value {name} = {value:g} is no mode of it; it takes "
                           f"{', '.join(f'{v:g}' for v in allowed)}")
    return value


def assemble(cm, dae, run, wall, messages, init, plan, p) -> Result:
    """The Result of a finished run (`run`: its rows, events, failure and statistics)."""
    stats = run.stats
    if run.failure is not None and getattr(run.failure, "reason", "") != "interrupted":
        _end_at_last_finite_row(run, plan, p)
    stats["wall_time"] = _time.perf_counter() - wall
    stats["plugin"] = run.choice.plugin
    stats["solver_messages"] = messages
    T = run.rows.times()
    stretches = list(run.rows.by_selection())

    def observe_all() -> np.ndarray:
        values = np.empty((T.size, len(dae.observed_names)))
        k = 0
        for sel, t, X, Z, D, given in stretches:     # rows integrated with one selection, observed together
            values[k: k + t.size] = observe(sel, t, X, Z, plan, p, D) if given is None else given
            k += t.size
        return values

    final = run.rows.last if T.size else None
    final_dae = final.dae if T.size else dae
    solved = run.rows.last_solved if T.size else None    # (a row given next to a change point is off them)
    if solved is not None and solved.dae.invariant_names:
        # how far the constraints (and |Q| = 1) drifted by the end, in the selection that ended the run
        c = solved.dae.invariants(solved.t, *(ca.DM(np.asarray(v, dtype=float).ravel()) for v in
                                              (solved.x, solved.z, run._u_at(solved.t), p, solved.d))).full().ravel()
        stats["invariants_at_end"] = float(np.max(np.abs(c))) if c.size else 0.0
    known = {}
    if len(stretches) == 1 and stretches[0][5] is None:
        # one selection throughout: its states and algebraics are the run's own; every other name is
        # computed when first asked for (most callers read a few names of hundreds)
        _, _, X, Z, _, _ = stretches[0]
        known = {**{n: X[:, k] for k, n in enumerate(final_dae.x_names)},
                 **{n: Z[:, k] for k, n in enumerate(final_dae.z_names)}}
        observed = observe_all
    else:
        observed = observe_all()
        column = {n: c for c, n in enumerate(dae.observed_names)}
        X = observed[:, [column[n] for n in final_dae.x_names]]     # (every selection's states are observed)
    result = Result(T, observed, dae.observed_names, dae.units, stats, X, np.zeros((T.size, 0)), final_dae.x_names,
                    events=run.events, failure=run.failure, known=known, title=cm.name,
                    initial={"fixed": list(init.fixed), "free_states": list(init.free_states),
                             "residual": init.residual})
    if run.failure is not None:
        run.failure.result = result
        if getattr(run.failure, "reason", "") == "interrupted":
            return result                     # (raised with it: no warning)
        said = f"; SUNDIALS said {messages[-1]!r} (all {len(messages)} messages in res.stats['solver_messages'])" \
            if messages else ""
        warnings.warn(str(run.failure) + said, IntegrationWarning, stacklevel=_callers_level())
    return result


def _callers_level() -> int:
    """The `stacklevel` of a warning issued by this function's caller that names the first line outside
    mechnet: the user's call, whichever entry (cm.simulate, a prepared run) and wrappers led there."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
    frame, level = sys._getframe(1), 1
    while frame.f_back is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    return level


def _end_at_last_finite_row(run, plan, p):
    """A failed run's rows end before the first one holding a value that is not finite (values not finite
    from the first row on, a sensor undefined at rest, aside): past it the rows are the failure, not a
    solution, and `continue_from` or a plot would take them for one. The failure then says so."""
    stretches = [(X, Z, observe(sel, t, X, Z, plan, p, D) if given is None else given)
                 for sel, t, X, Z, D, given in run.rows.by_selection()]
    if not stretches:
        return
    watched = np.isfinite(stretches[0][2][0])
    finite = np.concatenate([np.isfinite(X).all(axis=1) & np.isfinite(Z).all(axis=1)
                             & np.isfinite(Y[:, watched]).all(axis=1) for X, Z, Y in stretches])
    if finite.all():
        return
    keep = max(1, int(np.argmin(finite)))
    run.rows.keep_first(keep)
    old, t_good = run.failure, run.rows.last.t
    run.failure = IntegrationError(f"{old}; the rows after t = {t_good:.6g} s held values that are not finite and "
                                   f"were dropped: the result ends there", t=t_good, step=old.step,
                                   worst=old.worst, solver_message=old.solver_message)
    run.stats["failed_at"] = float(t_good)


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


def _nothing_moves(dae) -> bool:
    """No state, no algebraic variable, and no observed value that time or an input could change (an empty
    model, or one holding only a Fixed): a run would return the same numbers at every time."""
    if dae.x.numel() or dae.z.numel():
        return False
    with BUILD_LOCK:
        y = dae.observed(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d)
        return not ca.depends_on(y, ca.vertcat(dae.t, dae.u)) if y.numel() else True


RESULT_BYTES_MAX = 4 * 2 ** 30     # a result larger than this is refused before anything is allocated


def _check_result_size(n_out: int, n_names: int):
    need = 8.0 * n_out * (n_names + 1) * 3            # observed values, states and algebraics, times
    if need > RESULT_BYTES_MAX:
        raise MechnetError(f"n_out = {n_out} would need about {need / 2 ** 30:.1f} GiB for the result "
                           f"({n_names} names); ask for fewer points (the solver's steps do not depend on n_out)")


def _check_time(value, what: str) -> float:
    return finite_number(value, f"{what} (s)", MechnetError)


def _check_tolerance(value, what: str) -> float:
    number = finite_number(value, what, MechnetError)
    if not number > 0:
        raise MechnetError(f"{what} = {value!r} must be a positive number")
    return number


def _check_value(value, what: str) -> float:
    return finite_number(value, what, InitializationError)


def _resolve_params(dae, given: dict | None, entry: str = "simulate") -> np.ndarray:
    """The parameter vector of a run: the compiled values with `given` over them, each new value checked
    as at construction (its Param's check, then the requirements between parameters, which a new value
    could break: `core/requirements.py`); a value no check is known for must still be finite. `entry`
    names the call the values came through (simulate, linearize, trim, Problem)."""
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
                raise ParameterError(f"{entry}(params={{{name!r}: ...}}): {exc}") from None
        else:
            values[dae.p_names.index(name)] = finite_number(value, f"{entry}(params={{{name!r}: ...}}): {owner}",
                                                            ParameterError)
    if given:
        check_values(dae.info.get("parameter_requirements", ()), dict(zip(dae.p_names, values)),
                     f"{entry}(params=...)")
    return values


def _check_requirements(dae, t, init, plan, p, d, rtol, atol):
    """A start that breaks a component's start requirement (a body outside its stops, which no event
    would ever catch) is refused, naming the requirement and by how much it is broken."""
    required = dae.info.get("start_requirements")
    if not required:
        return
    fn, texts = required
    values = fn(t, init.x, init.z, plan.constant, p, d).full().ravel()
    for value, text in zip(values, texts):
        if value < -10 * (rtol + atol):
            raise InitializationError(f"{text} (it starts {-value:.6g} beyond it); start it inside")
