"""What accuracy costs in time, for any compiled model: a work-precision study.

`study(cm, t_end)` runs the scene with every applicable method over a range of tolerances (or, for
fixed-step methods, step counts), measures each run's error at a time `at` against a reference and
its wall time, and says which method is cheapest for a given accuracy:

- mechnet's own methods (`cm.simulate`): CVODES Adams and BDF (explicit ODEs), IDAS, "auto";
- fixed steps, the MuJoCo-style choice: CasADi's `rk` (explicit Runge–Kutta 4) and `collocation`
  (implicit, for a DAE too) plugins at several step counts, on the compiled model's own functions;
- the Baumgarte formulation of a constrained scene (`CompileOptions(reduce=...(method="baumgarte"))`);
- SciPy's Radau, BDF and DOP853 on the ODE form, as references from outside.

The reference is the scene's `reference(t)` when given; otherwise two runs much tighter than the
tightest setting (Adams and BDF, or IDAS at two tolerances), whose difference estimates the
reference's own error: errors within 10× of it are marked unreliable, and a difference far beyond the
tolerance (methods disagreeing: a chaotic scene, or one past a bifurcation) is reported as such.
Runs go through `mn.sweep` (worker processes, or a Dask client).

Timing: every row runs once for its result (which also builds its integrators), then `repeat` more times
round-robin over the rows (not `repeat` in a row per row, which lets a burst of load on a shared machine
favour one row); the best and the median are kept. Rows whose best-to-median ranges overlap are a tie,
decided on counted work (right-hand-side evaluations) rather than on timing noise.

What the solvers print (a diverging fixed step makes CasADi print "NaN detected" and its `Function step`
input dumps, from C++ or through Python's streams) is captured while the study's own runs work and summed up
in the row's note, never printed.
"""
from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
import threading
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .core.arguments import name_list, whole_number
from .core.declarations import finite_number
from .core.errors import MechnetError
from .numeric import NumpyCall
from . import solver_output
from .simulate import IntegrationWarning
from .sweep import run_case, sweep

TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
STEPS = (10, 30, 100, 300, 1000, 3000)
SIMULATE = ("auto", "cvodes-adams", "cvodes-bdf", "idas")
METHODS = ("auto", "cvodes-adams", "cvodes-bdf", "idas", "rk", "collocation", "baumgarte", "scipy-radau",
           "scipy-bdf", "scipy-dop853")
ATOL_RATIO = 1e-2          # atol = rtol · ATOL_RATIO (scaled by each state's nominal value, as in simulate)
UNRELIABLE = 10.0          # errors within this factor of the reference's own error are not trusted
DISAGREE = 1e3             # reference runs differing by more than this × their tolerance: chaotic
TIE = 0.2                  # one timing per row: runs within 20 % of the fastest count as equally fast
DIVERGED = 1e6             # a fixed-step error beyond this × the largest reference value: diverged
REPEAT = 5                 # timed repeats per row, round-robin over the rows
REFERENCE_STEPS = 10 ** 7  # the reference runs' step limit (one output interval over the whole run)


@dataclass
class Trial:
    """One run of the study: `setting` is rtol (tolerance methods) or the number of steps."""

    method: str
    setting: float
    error: float = np.nan
    time: float = np.nan
    steps: int = 0
    evaluations: int = 0
    events: int = 0
    reselections: int = 0
    drift: float = np.nan          # largest |invariant| (constraint residuals, |Q| − 1) at `at`
    status: str = "ok"
    reason: str = ""
    reliable: bool = True
    timer: object = field(default=None, repr=False, compare=False)   # () -> seconds of one more run, while timing
    times: list = field(default_factory=list)   # the timed repeats (s); `time` is the best of them
    output: str = ""               # a summary of what the solver printed during the run (captured)

    @property
    def median(self) -> float:
        """The median timed repeat (the best when there is one timing)."""
        return float(np.median(self.times)) if self.times else self.time

    @property
    def slowest_tied(self) -> float:
        """The upper end of this row's timing range: its median over three or more repeats, else its best
        plus TIE (one run says nothing of the noise)."""
        return self.median if len(self.times) >= 3 else self.time * (1 + TIE)

    @property
    def work(self) -> int:
        """Counted work: right-hand-side (or residual) evaluations; 0 when the method does not count them."""
        return self.evaluations

    @property
    def call(self) -> str:
        """How to run this setting (what a user pastes)."""
        if self.method in ("rk", "collocation"):
            return f"fixed steps: CasADi '{self.method}' plugin, {int(self.setting)} steps"
        if self.method.startswith("scipy-"):
            return f"scipy.integrate.solve_ivp(method='{self.method[6:]}', rtol={self.setting:g})"
        if self.method == "baumgarte":
            return f"CompileOptions(reduce=IndexReductionOptions(method='baumgarte')); rtol={self.setting:g}"
        return f"cm.simulate(..., method={self.method!r}, rtol={self.setting:g}, atol={self.setting * ATOL_RATIO:g})"


@dataclass
class AccuracyStudy:
    name: str
    at: float
    names: tuple
    trials: list
    reference: str                   # what the errors are measured against
    reference_error: float           # its own error estimate (0 for reference(t))
    warnings: list = field(default_factory=list)

    def rows(self) -> list[dict]:
        return [{"method": t.method, "setting": t.setting, "error": t.error, "time_s": t.time,
                 "time_median_s": t.median, "repeats": len(t.times), "steps": t.steps,
                 "evaluations": t.evaluations, "events": t.events, "reselections": t.reselections,
                 "drift": t.drift, "reliable": t.reliable, "status": t.status, "reason": t.reason,
                 "solver_output": t.output}
                for t in self.trials]

    def to_pandas(self):
        try:
            import pandas as pd
        except ImportError:
            raise MechnetError("AccuracyStudy.to_pandas() needs pandas: pip install 'mechnet[pandas]'") from None
        return pd.DataFrame(self.rows())

    def to_csv(self, path) -> None:
        rows = self.rows()
        if not rows:
            raise MechnetError("AccuracyStudy.to_csv(): the study has no runs")
        with open(path, "w", encoding="utf-8") as f:
            f.write(",".join(rows[0]) + "\n")
            for row in rows:
                f.write(",".join(repr(v) if isinstance(v, float) else f'"{v}"' if "," in str(v) else str(v)
                                 for v in row.values()) + "\n")

    def to_markdown(self, target: float = 1e-6) -> str:
        lines = [f"Work-precision study of {self.name!r}: error at t = {self.at:g} s in {', '.join(self.names[:6])}"
                 f"{' ...' if len(self.names) > 6 else ''} against {self.reference}", "",
                 "| method | rtol / steps | error | time (ms): best / median | steps | f evals | events | reselections "
                 "| drift | note |", "|---|---|---|---|---|---|---|---|---|---|"]
        for t in self.trials:
            note = t.reason if t.status != "ok" else ("" if t.reliable else "within 10x of the reference's error")
            note = "; ".join(n for n in (note, t.output) if n)
            if t.status == "skipped":
                lines.append(f"| {t.method} | - | - | - | - | - | - | - | - | skipped: {note} |")
                continue
            timing = f"{1e3 * t.time:.3g}" + (f" / {1e3 * t.median:.3g}" if len(t.times) > 1 else "")
            lines.append(f"| {t.method} | {t.setting:g} | {t.error:.2e} | {timing} | {t.steps} | "
                         f"{t.evaluations} | {t.events} | {t.reselections} | {t.drift:.1e} | {note} |")
        repeats = max((len(t.times) for t in self.trials), default=0)
        if repeats > 1:
            lines += ["", f"Times: the best and the median of {repeats} repeats taken round-robin over the rows, after "
                          f"a first run that builds the integrators."]
        lines += [""] + [f"- {w}" for w in self.warnings]
        lines.append(f"- for error <= {target:g}: " + self.recommendation(target).replace("\n", "; "))
        return "\n".join(lines)

    def recommend(self, error: float, simulate_only: bool = False):
        """The cheapest trial whose error is at most `error` (among cm.simulate's methods only, when
        asked), or None. An unreliable trial (within 10× of the reference's own error) counts when even
        its measured error plus the reference's stays within `error`: its true error cannot be larger
        (a chaotic chain at 10 s: no reliable run fell between 10× the reference's error and 1e-3).

        Cheapest: the best time, unless other rows' timing ranges (best to median) overlap the fastest's —
        a tie timing cannot decide — then the least counted work among them (right-hand-side evaluations,
        when every tied row counts them), then the best time. Choosing the most accurate of a 20 % band
        once picked a setting 1.7× slower than another row of the same table."""
        error = finite_number(error, "recommend(error)", MechnetError)
        if error <= 0:
            raise MechnetError(f"recommend(error={error:g}): give the error to reach, a number > 0")
        fits = [t for t in self.trials if t.status == "ok" and t.error <= error
                and (t.reliable or t.error + self.reference_error <= error)
                and (not simulate_only or t.method in SIMULATE)]
        if not fits:
            return None
        fastest = min(fits, key=lambda t: t.time)
        tied = [t for t in fits if t.time <= fastest.slowest_tied and fastest.time <= t.slowest_tied]
        counted = all(t.work > 0 for t in tied)
        return min(tied, key=lambda t: (t.work if counted else 0, t.time))

    def recommendation(self, error: float) -> str:
        """What to paste: the cheapest cm.simulate setting reaching `error`, and the cheapest run of any
        kind when that is another (a fixed-step or SciPy run the user would write themselves)."""
        best, overall = self.recommend(error, simulate_only=True), self.recommend(error)
        if overall is not None and overall.method in SIMULATE:    # (a tie is decided within its own group)
            best = overall
        if overall is None:
            return f"no method reached an error of {error:g} at t = {self.at:g} s"
        text = "" if best is None else (f"{best.call}  # error {best.error:.2g} at t = {self.at:g} s in "
                                        f"{_cost(best)}, the cheapest cm.simulate setting for error <= {error:g}")
        if overall is not best:
            text += ("\n" if text else "") + (f"# cheapest of all: {overall.call} (error {overall.error:.2g}, "
                                               f"{_cost(overall)})")
        return text

    def plot(self, path=None):
        """Error against time, log–log, one line per method; the cheapest run at each accuracy (the
        front no other run beats in both) ringed; the reference's own error shaded."""
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(7, 5))
        for method in dict.fromkeys(t.method for t in self.trials):
            pts = sorted((t.time, t.error) for t in self.trials if t.method == method and t.status == "ok"
                         and t.error > 0 and np.isfinite(t.error))
            if pts:
                ax.loglog(*zip(*pts), "o-", label=method, ms=4)
        front = _front([t for t in self.trials if t.status == "ok" and t.reliable and t.error > 0])
        if front:
            ax.loglog([t.time for t in front], [t.error for t in front], "o", mfc="none", mec="k", ms=10,
                      label="cheapest at its accuracy")
        if self.reference_error > 0:
            ax.axhspan(1e-300, UNRELIABLE * self.reference_error, color="0.9", label="within 10x of the reference")
            # the band reaches down to 1e-300: the axis ends a little below the lowest error or the reference's
            shown = [t.error for t in self.trials if t.status == "ok" and t.error > 0 and np.isfinite(t.error)]
            ax.set_ylim(bottom=0.3 * min(shown + [self.reference_error]))
        ax.set_xlabel("wall time of a run [s]")
        ax.set_ylabel(f"error at t = {self.at:g} s")
        ax.set_title(f"{self.name}: work-precision ({self.reference})", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:   # (no labelled line: no legend, and no warning)
            ax.legend(fontsize=8)
        if path is not None:
            fig.savefig(path, dpi=110, bbox_inches="tight")
        return fig


def _cost(t) -> str:
    """A row's time as the recommendation quotes it: best (and median) ms, and its counted work."""
    timing = f"{1e3 * t.time:.3g} ms" + (f" (median {1e3 * t.median:.3g} ms)" if len(t.times) > 1 else "")
    return timing + (f", {t.work} f evals" if t.work else "")


def _front(trials):
    """The trials no other trial beats in both time and error, by time."""
    out = []
    for t in sorted(trials, key=lambda t: (t.time, t.error)):
        if not out or t.error < out[-1].error:
            out.append(t)
    return out


def study(cm, t_end: float, *, at: float | None = None, names=None, methods=None, tolerances=TOLERANCES,
          steps=STEPS, reference=None, repeat: int = REPEAT, workers: int | None = 0, client=None) -> AccuracyStudy:
    """The work-precision study of `cm` over [0, t_end], errors at `at` (default t_end) in `names`
    (default: the reference's names, else the states). `reference(t)` -> {name: value} when the scene
    has a closed form (a scene file's `reference`). `repeat`: timed runs per setting after the first,
    round-robin over the settings, the best kept and the median shown (1: the first run's time alone)."""
    if not hasattr(cm, "dae") or not hasattr(cm, "simulate"):
        raise MechnetError(f"accuracy: study takes a compiled model (Model.compile()), got {type(cm).__name__}")
    t_end = finite_number(t_end, "accuracy: t_end (s)", MechnetError)
    at = t_end if at is None else finite_number(at, "accuracy: at (s)", MechnetError)
    tolerances = _numbers(tolerances, "tolerances", lambda v: 0 < v < 1, "each in (0, 1)")
    steps = tuple(whole_number(v, "accuracy(steps=...)", 1) for v in _numbers(steps, "steps", lambda v: v >= 1, ">= 1"))
    if not 0 < at <= t_end:
        raise MechnetError(f"accuracy: at = {at:g} s must lie in (0, t_end = {t_end:g} s]")
    dae = cm.dae
    methods = list(name_list(methods, "accuracy(methods=...)")) if methods is not None else list(METHODS)
    unknown = [m for m in methods if m not in METHODS]
    if not methods:
        raise MechnetError("accuracy(methods=[]): name at least one method: " + ", ".join(METHODS))
    if unknown:
        raise MechnetError(f"accuracy: unknown method {unknown[0]!r}; choose from {', '.join(METHODS)}")
    repeat = whole_number(repeat, "accuracy(repeat=...)", 1)
    notes = []
    ref_values, ref_error, ref_text, ref_run = _reference(cm, at, reference, tolerances, notes)
    names = tuple(name_list(names, "accuracy(names=...)")) if names is not None else tuple(ref_values)
    missing = [n for n in names if n not in ref_values]
    if missing:
        raise MechnetError(f"accuracy: no reference value for {missing[0]!r}")
    truth = np.array([ref_values[n] for n in names])

    def error_of(values: dict) -> float:
        return float(np.max(np.abs(np.array([values[n] for n in names]) - truth)))

    trials = []
    native = [m for m in methods if m in ("auto", "cvodes-adams", "cvodes-bdf", "idas")]
    if not dae.is_ode:
        skipped = [m for m in native if m.startswith("cvodes")]
        native = [m for m in native if m not in skipped]
        trials += [Trial(m, np.nan, status="skipped", reason="needs an explicit ODE (the model keeps algebraic "
                                                            "variables)") for m in skipped]
    cases = [{"settings": {"method": m, "rtol": tol, "atol": tol * ATOL_RATIO}} for m in native for tol in tolerances]
    parallel = client is not None or workers is None or workers > 1
    if cases:
        runs = sweep(cm, t_end=at, cases=cases, workers=workers, client=client, t_out=[0.0, at])
        native_trials = []
        for run in runs:
            s = run.case.settings
            trial = Trial(s["method"], s["rtol"], time=run.wall, status=run.status, reason=run.reason)
            if run.result is not None and run.status == "ok":
                _fill(trial, run.result, cm, names, error_of)
                trial.timer = None if parallel else _case_timer(cm, run.case, at)
                native_trials.append((trial, run.case))
            trials.append(trial)
        if parallel and repeat > 1:         # round-robin over the native rows, each round one sweep
            again = [{"params": c.params, "start": c.start, "inputs": c.inputs, "settings": c.settings}
                     for _, c in native_trials]
            rounds = [sweep(cm, t_end=at, cases=again, workers=workers, client=client, t_out=[0.0, at])
                      for _ in range(repeat)]
            for k, (trial, _) in enumerate(native_trials):
                trial.times = [r.runs[k].wall for r in rounds]
    for method in ("rk", "collocation"):
        if method in methods:
            trials += _fixed_steps(cm, method, steps, at, ref_run, names, error_of)
    if "baumgarte" in methods:
        trials += _baumgarte(cm, at, tolerances, names, error_of)
    for method in [m for m in methods if m.startswith("scipy-")]:
        trials += _scipy(cm, method, at, tolerances, ref_run, names, error_of)
    _time_rounds(trials, repeat)
    for t in trials:
        t.reliable = t.status == "ok" and t.error > UNRELIABLE * ref_error
    return AccuracyStudy(cm.name, at, names, trials, ref_text, ref_error, notes)


def _case_timer(cm, case, at):
    """A timer of one native run (as the sweep runs it, here)."""
    settings = {"t_end": at, "simulate": {"t_out": [0.0, at]}, "repeat": 1}
    return lambda: run_case(cm, case, settings).wall


def _time_rounds(trials, repeat):
    """`repeat` timed runs of every row that has a timer, round-robin over the rows; each row's time the
    best of them. With one repeat, the first run's time stands (it includes building the integrators)."""
    timed = [t for t in trials if getattr(t, "timer", None) is not None]
    if repeat > 1 and timed:
        for t in timed:
            t.times = []
        with _quiet():                       # said once, in the row's note, by its first run
            for _ in range(repeat):
                for t in timed:
                    t.times.append(t.timer())
    for t in trials:
        if t.status == "ok" and not t.times:
            t.times = [t.time]
        if t.times:
            t.time = min(t.times)
        t.timer = None                       # (a closure over integrators: not part of the result)


_QUIET_LOCK = threading.RLock()   # the descriptors are the process's: one quiet block at a time


@contextlib.contextmanager
def _quiet():
    """Within the block, what anything prints — CasADi's C++ through the process's file descriptors 1 and 2,
    or through Python's sys.stdout and sys.stderr — goes to the yielded list (its lines, on leaving), not to
    the terminal. Python-level redirection alone misses the C++ writes; descriptor-level alone misses what
    CasADi hands to Python's streams. For the study's own runs only: the descriptors are the process's, so
    blocks in two threads take turns (overlapping, they restored each other's copies in the wrong order and
    left the process silent), and what another thread prints meanwhile lands in the note too."""
    with _QUIET_LOCK:
        with _quiet_unlocked() as lines:
            yield lines


@contextlib.contextmanager
def _quiet_unlocked():
    lines: list[str] = []
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    with tempfile.TemporaryFile() as sink:
        saved = []
        try:
            for fd in (1, 2):
                copy = os.dup(fd)
                saved.append((fd, copy))
                os.dup2(sink.fileno(), fd)
        except OSError:                      # no such descriptor (a windowed program): Python's streams only
            pass
        try:
            with solver_output.captured() as errors, contextlib.redirect_stdout(io.StringIO()) as out:
                yield lines
        finally:
            _flush_c_streams()
            for fd, copy in saved:
                os.dup2(copy, fd)
                os.close(copy)
            sink.seek(0)
            text = sink.read().decode("utf-8", errors="replace") + out.getvalue()
            lines += [line.strip() for line in text.splitlines() if line.strip()] + errors


def _flush_c_streams():
    """fflush(NULL): C stdio buffers (std::cout shares them) reach the captured descriptors before they return."""
    import ctypes
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


def _summary(lines) -> str:
    """What a run printed, in a few words for the table's note."""
    if not lines:
        return ""
    kinds = [k for k in ("NaN detected", "Inf detected", "rootfinder process failed") if any(k in s for s in lines)]
    if any(s.startswith("Input 0") for s in lines):
        kinds.append("input dumps of CasADi's step function")
    what = ", ".join(kinds) if kinds else f"{lines[0][:80]!r}"
    return f"solver printed {what} ({len(lines)} line{'s' * (len(lines) != 1)} of output suppressed)"


def _numbers(values, what, ok, rule):
    """A non-empty sequence of numbers obeying `rule`, or a MechnetError naming the argument."""
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise MechnetError(f"accuracy({what}=...) takes a list of numbers, got {values!r:.40}")
    out = tuple(finite_number(v, f"accuracy({what}=...)", MechnetError) for v in values)
    if not out or not all(ok(v) for v in out):
        raise MechnetError(f"accuracy({what}={list(values)!r:.60}): give at least one number, {rule}")
    return out


def _reference(cm, at, reference, tolerances, notes):
    """(values at `at`, their error estimate, what they are, the run giving the start point)."""
    tight = min(tolerances) * 1e-2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        first = cm.simulate(at, t_out=[0.0, at], rtol=tight, atol=tight * ATOL_RATIO, max_steps=REFERENCE_STEPS)
    if first.failure is not None:
        raise MechnetError(f"accuracy: the reference run at rtol {tight:g} failed: {first.failure}")
    if reference is not None:
        values = _reference_values(reference, at)
        if values:
            return values, 0.0, "the scene's reference(t)", first
        notes.append(f"reference(t) gives no value at t = {at:g} s (the scene's closed form ends earlier): "
                     f"errors against tight runs instead")
    other_method = "cvodes-bdf" if cm.dae.is_ode else "idas"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        second = cm.simulate(at, t_out=[0.0, at], rtol=tight * 0.1, atol=tight * 0.1 * ATOL_RATIO, method=other_method,
                             max_steps=REFERENCE_STEPS)
    names = list(cm.state_names)
    a = np.array([first[n][-1] for n in names])
    if second.failure is not None:      # below what double precision resolves (the squeezer at 1e-14): a
        with warnings.catch_warnings():  # decade looser checks the run at `tight` instead
            warnings.simplefilter("ignore", IntegrationWarning)
            looser = cm.simulate(at, t_out=[0.0, at], rtol=tight * 10, atol=tight * 10 * ATOL_RATIO,
                                 method=other_method, max_steps=REFERENCE_STEPS)
        if looser.failure is None:
            error = float(np.max(np.abs(np.array([looser[n][-1] for n in names]) - a)))
            notes.append(f"the check of the reference ({other_method} at rtol {tight * 0.1:g}) failed: "
                         f"{second.failure}; checked at rtol {tight * 10:g} instead")
            return ({n: float(a[k]) for k, n in enumerate(names)}, error,
                    f"a run at rtol {tight:g} (checked by {other_method} at {tight * 10:g}: {error:.1e} apart)", first)
        notes.append(f"the check of the reference ({other_method} at rtol {tight * 0.1:g}) failed: {second.failure}; "
                     f"no error is marked reliable")
        return {n: float(a[k]) for k, n in enumerate(names)}, np.inf, f"a run at rtol {tight:g} (unchecked)", first
    b = np.array([second[n][-1] for n in names])
    scale = max(1.0, float(np.max(np.abs(a))))
    ref_error = float(np.max(np.abs(a - b)))
    text = (f"a {other_method} run at rtol {tight * 0.1:g} (checked by a run at {tight:g}: {ref_error:.1e} "
            f"apart)")
    if ref_error > DISAGREE * tight * scale:
        notes.append(f"the reference runs disagree by {ref_error:.2g} at t = {at:g} s, far beyond their tolerance "
                     f"{tight:g}: the scene is chaotic or ill-conditioned there; compare at an earlier time (at=...)")
    return {n: float(b[k]) for k, n in enumerate(names)}, ref_error, text, second


def _reference_values(reference, at) -> dict:
    """reference(t) at `at`, as {name: number} (non-finite values dropped), or a MechnetError naming it: a
    scene's own code failing is the scene's mistake, said as such rather than as a traceback of the study."""
    try:
        given = reference(np.array([at]))
        values = {}
        for n, v in dict(given).items():
            v = np.asarray(v, dtype=float).ravel()
            if v.size and np.isfinite(v).all():
                values[n] = float(v[0])
    except Exception as exc:   # the scene's code: any error it raises is reported, named
        raise MechnetError(f"accuracy: the scene's reference(t) failed at t = [{at:g}]: "
                           f"{type(exc).__name__}: {exc}"[:400]) from exc
    bad = [n for n in values if not isinstance(n, str)]
    if bad:
        raise MechnetError(f"accuracy: reference(t) must return {{name: values}} with dotted names, got key {bad[0]!r}")
    return values


def _fill(trial, res, cm, names, error_of):
    values = {n: float(np.asarray(res[n], dtype=float)[-1]) for n in names}
    trial.error = error_of(values)
    trial.steps, trial.evaluations = int(res.stats.get("nsteps", 0)), int(res.stats.get("nfevals", 0))
    trial.events = sum(1 for e in res.events if e.kind == "state")
    trial.reselections = sum(1 for e in res.events if e.kind == "reselection")
    trial.drift = float(res.stats.get("invariants_at_end", np.nan))


def _start_point(ref_run, dae):
    """x0, z0 of the model's own selection, from the reference run (None when it started in another)."""
    if any(e.kind == "reselection" and e.t == 0.0 for e in ref_run.events) or ref_run.x.shape[1] != dae.x.numel():
        return None
    return np.asarray(ref_run.x[0], dtype=float), np.asarray(ref_run.z[0], dtype=float)


def _plain(dae):
    """Why fixed steps or SciPy cannot run this model, or ''."""
    if dae.zero_labels:
        return "state events need mechnet's event loop"
    if dae.time_events:
        return "time events (steps, tables) need restarts"
    if dae.u.numel():
        return "external inputs are not replayed here"
    return ""


def _fixed_steps(cm, method, steps, at, ref_run, names, error_of):
    import casadi as ca
    dae = cm.dae
    why = _plain(dae) or ("explicit Runge-Kutta needs an explicit ODE" if method == "rk" and not dae.is_ode else "")
    start = _start_point(ref_run, dae)
    if not why and start is None:
        why = "the scene starts in another choice of states"
    if why:
        return [Trial(method, np.nan, status="skipped", reason=why)]
    x0, z0 = start
    u, p, d = ca.DM(list(dae.u_default)), ca.DM(list(dae.p_value)), ca.DM(list(dae.d_value))
    t = ca.SX.sym("t")
    spec = {"x": dae.x, "t": t, "ode": dae.ode(t, dae.x, dae.z, u, p, d)}
    if dae.z.numel():
        spec.update(z=dae.z, alg=dae.alg(t, dae.x, dae.z, u, p, d))
    observed = NumpyCall(dae.observed)
    index = {n: k for k, n in enumerate(dae.observed_names)}
    scale = max(1.0, float(np.max(np.abs(error_of({nm: 0.0 for nm in names})))))    # max |reference value|
    out = []
    for n in steps:
        trial = Trial(method, float(n))
        try:
            with _quiet() as printed:        # a diverging step prints "NaN detected" and input dumps
                F = ca.integrator("F", method, spec, 0.0, [at], {"number_of_finite_elements": int(n)})
                t0 = time.perf_counter()
                r = F(x0=x0, z0=z0)
                trial.time = time.perf_counter() - t0
        except RuntimeError as exc:
            trial.status, trial.reason = "failed", _casadi_reason(exc)
        trial.output = _summary(printed)
        if trial.status == "failed":
            out.append(trial)
            continue
        x, z = np.asarray(r["xf"]).ravel(), np.asarray(r["zf"]).ravel()
        y = observed(np.array([at]), x, z, *(np.asarray(v).ravel() for v in (u, p, d)))[0].ravel()
        trial.steps = int(n)
        trial.evaluations = 4 * int(n) if method == "rk" else 0    # RK4: four stages; collocation: Newton's, uncounted
        trial.error = error_of({nm: float(y[index[nm]]) for nm in names}) if np.all(np.isfinite(y)) else np.inf
        if not trial.error <= DIVERGED * scale:
            trial.status, trial.reason = "failed", f"diverged (error {trial.error:.2g}: the step is too long)"
        else:
            trial.timer = _call_timer(F, x0, z0)
        out.append(trial)
    return out


def _casadi_reason(exc) -> str:
    """CasADi's last line, without its source path and its advice to set options the study does not own."""
    line = str(exc).strip().splitlines()[-1]
    line = line.split(": ", 1)[1] if line.startswith(".../") and ": " in line else line
    return line.split(" Set '")[0][:200]


def _call_timer(F, x0, z0):
    def run():
        t0 = time.perf_counter()
        F(x0=x0, z0=z0)
        return time.perf_counter() - t0
    return run


def _baumgarte(cm, at, tolerances, names, error_of):
    from .compile.index_reduction import IndexReductionOptions
    from .compile.pipeline import CompileOptions, compile_model
    source = getattr(cm, "_source", None)
    if source is None or not cm.dae.invariant_names or cm.dae.d_names:
        why = ("no constraints to stabilise" if source is not None and not cm.dae.invariant_names else
               "modes are not supported by the Baumgarte formulation" if source is not None else
               "the compiled model has no scene to compile again")
        return [Trial("baumgarte", np.nan, status="skipped", reason=why)]
    try:
        other = compile_model(source, CompileOptions(reduce=IndexReductionOptions(method="baumgarte")))
    except MechnetError as exc:
        return [Trial("baumgarte", np.nan, status="skipped", reason=str(exc)[:200])]
    missing = [n for n in names if n not in other.names]
    if missing:
        return [Trial("baumgarte", np.nan, status="skipped", reason=f"{missing[0]} is not a name there")]
    runs = sweep(other, t_end=at, cases=[{"settings": {"rtol": tol, "atol": tol * ATOL_RATIO}} for tol in tolerances],
                 workers=0, t_out=[0.0, at])
    out = []
    for run in runs:
        trial = Trial("baumgarte", run.case.settings["rtol"], time=run.wall, status=run.status, reason=run.reason)
        if run.status == "ok":
            _fill(trial, run.result, other, names, error_of)
            trial.timer = _case_timer(other, run.case, at)
        out.append(trial)
    return out


def _scipy(cm, method, at, tolerances, ref_run, names, error_of):
    from scipy.integrate import solve_ivp
    import casadi as ca
    dae = cm.dae
    why = _plain(dae) or ("" if dae.is_ode else "SciPy integrates the explicit ODE form only")
    start = _start_point(ref_run, dae)
    if not why and start is None:
        why = "the scene starts in another choice of states"
    if why:
        return [Trial(method, np.nan, status="skipped", reason=why)]
    x0 = start[0]
    u, p, d = (np.array(v, dtype=float) for v in (dae.u_default, dae.p_value, dae.d_value))
    none = np.zeros(0)
    rhs = NumpyCall(dae.ode)
    jac = NumpyCall(ca.Function("ode_jacobian", [dae.t, dae.x, dae.z, dae.u, dae.p, dae.d],
                                [ca.densify(ca.jacobian(dae.ode(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d), dae.x))]))
    observed = NumpyCall(dae.observed)
    index = {n: k for k, n in enumerate(dae.observed_names)}
    name = {"radau": "Radau", "bdf": "BDF", "dop853": "DOP853"}[method[6:]]
    implicit = {} if name == "DOP853" else {"jac": lambda t, x: jac(np.array([t]), x, none, u, p, d)[0]}

    def solve(tol):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)       # overflow on the way to a failure: in the table
            return solve_ivp(lambda t, x: rhs(np.array([t]), x, none, u, p, d)[0].ravel(), (0.0, at), x0,
                             method=name, rtol=tol, atol=tol * ATOL_RATIO * np.array(dae.x_nominal), **implicit)

    def timer(tol):
        def run():
            t0 = time.perf_counter()
            solve(tol)
            return time.perf_counter() - t0
        return run

    out = []
    for tol in tolerances:
        trial = Trial(method, tol)
        with _quiet() as printed:
            t0 = time.perf_counter()
            sol = solve(tol)
            trial.time = time.perf_counter() - t0
        trial.output = _summary(printed)
        if not sol.success:
            trial.status, trial.reason = "failed", sol.message
        else:
            y = observed(np.array([at]), sol.y[:, -1], none, u, p, d)[0].ravel()
            trial.error = error_of({nm: float(y[index[nm]]) for nm in names})
            trial.steps, trial.evaluations = sol.t.size - 1, int(sol.nfev)
            trial.timer = timer(tol)
        out.append(trial)
    return out
