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
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .core.arguments import name_list, whole_number
from .core.declarations import finite_number
from .core.errors import MechnetError
from .numeric import NumpyCall
from .simulate import IntegrationWarning
from .sweep import sweep

TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
STEPS = (10, 30, 100, 300, 1000, 3000)
SIMULATE = ("auto", "cvodes-adams", "cvodes-bdf", "idas")
METHODS = ("auto", "cvodes-adams", "cvodes-bdf", "idas", "rk", "collocation", "baumgarte", "scipy-radau",
           "scipy-bdf", "scipy-dop853")
ATOL_RATIO = 1e-2          # atol = rtol · ATOL_RATIO (scaled by each state's nominal value, as in simulate)
UNRELIABLE = 10.0          # errors within this factor of the reference's own error are not trusted
DISAGREE = 1e3             # reference runs differing by more than this × their tolerance: chaotic
TIE = 0.2                  # runs within 20 % of the fastest time count as equally fast (timing noise)
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
        return [{"method": t.method, "setting": t.setting, "error": t.error, "time_s": t.time, "steps": t.steps,
                 "evaluations": t.evaluations, "events": t.events, "reselections": t.reselections,
                 "drift": t.drift, "reliable": t.reliable, "status": t.status, "reason": t.reason}
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
                 "| method | rtol / steps | error | time (ms) | steps | f evals | events | reselections | drift "
                 "| note |", "|---|---|---|---|---|---|---|---|---|---|"]
        for t in self.trials:
            note = t.reason if t.status != "ok" else ("" if t.reliable else "within 10x of the reference's error")
            if t.status == "skipped":
                lines.append(f"| {t.method} | - | - | - | - | - | - | - | - | skipped: {note} |")
                continue
            lines.append(f"| {t.method} | {t.setting:g} | {t.error:.2e} | {1e3 * t.time:.3g} | {t.steps} | "
                         f"{t.evaluations} | {t.events} | {t.reselections} | {t.drift:.1e} | {note} |")
        lines += [""] + [f"- {w}" for w in self.warnings]
        lines.append(f"- for error <= {target:g}: " + self.recommendation(target).replace("\n", "; "))
        return "\n".join(lines)

    def recommend(self, error: float, simulate_only: bool = False):
        """The cheapest trial whose error is at most `error` (among cm.simulate's methods only, when
        asked), or None. An unreliable trial (within 10× of the reference's own error) counts when even
        its measured error plus the reference's stays within `error`: its true error cannot be larger
        (a chaotic chain at 10 s: no reliable run fell between 10× the reference's error and 1e-3)."""
        fits = [t for t in self.trials if t.status == "ok" and t.error <= error
                and (t.reliable or t.error + self.reference_error <= error)
                and (not simulate_only or t.method in SIMULATE)]
        if not fits:
            return None
        # times within TIE of the fastest are a tie on millisecond runs: the most accurate of those wins
        fastest = min(t.time for t in fits)
        return min((t for t in fits if t.time <= (1 + TIE) * fastest), key=lambda t: (t.error, t.time))

    def recommendation(self, error: float) -> str:
        """What to paste: the cheapest cm.simulate setting reaching `error`, and the cheapest run of any
        kind when that is another (a fixed-step or SciPy run the user would write themselves)."""
        best, overall = self.recommend(error, simulate_only=True), self.recommend(error)
        if overall is None:
            return f"no method reached an error of {error:g} at t = {self.at:g} s"
        text = "" if best is None else (f"{best.call}  # error {best.error:.2g} at t = {self.at:g} s in "
                                        f"{1e3 * best.time:.3g} ms, the cheapest cm.simulate setting for error "
                                        f"<= {error:g}")
        if overall is not best:
            text += ("\n" if text else "") + (f"# cheapest of all: {overall.call} (error {overall.error:.2g}, "
                                               f"{1e3 * overall.time:.3g} ms)")
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


def _front(trials):
    """The trials no other trial beats in both time and error, by time."""
    out = []
    for t in sorted(trials, key=lambda t: (t.time, t.error)):
        if not out or t.error < out[-1].error:
            out.append(t)
    return out


def study(cm, t_end: float, *, at: float | None = None, names=None, methods=None, tolerances=TOLERANCES,
          steps=STEPS, reference=None, repeat: int = 2, workers: int | None = 0, client=None) -> AccuracyStudy:
    """The work-precision study of `cm` over [0, t_end], errors at `at` (default t_end) in `names`
    (default: the reference's names, else the states). `reference(t)` -> {name: value} when the scene
    has a closed form (a scene file's `reference`). `repeat`: runs per setting, the fastest kept."""
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
    if cases:
        runs = sweep(cm, t_end=at, cases=cases, workers=workers, client=client, repeat=repeat, t_out=[0.0, at])
        for run in runs:
            s = run.case.settings
            trial = Trial(s["method"], s["rtol"], time=run.wall, status=run.status, reason=run.reason)
            if run.result is not None and run.status == "ok":
                _fill(trial, run.result, cm, names, error_of)
            trials.append(trial)
    for method in ("rk", "collocation"):
        if method in methods:
            trials += _fixed_steps(cm, method, steps, at, ref_run, names, error_of, repeat)
    if "baumgarte" in methods:
        trials += _baumgarte(cm, at, tolerances, names, error_of, repeat)
    for method in [m for m in methods if m.startswith("scipy-")]:
        trials += _scipy(cm, method, at, tolerances, ref_run, names, error_of, repeat)
    for t in trials:
        t.reliable = t.status == "ok" and t.error > UNRELIABLE * ref_error
    return AccuracyStudy(cm.name, at, names, trials, ref_text, ref_error, notes)


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
        values = {n: float(np.asarray(v, dtype=float).ravel()[0])
                  for n, v in dict(reference(np.array([at]))).items() if np.isfinite(np.asarray(v, dtype=float)).all()}
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
    if second.failure is not None:
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


def _fixed_steps(cm, method, steps, at, ref_run, names, error_of, repeat):
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
    out = []
    for n in steps:
        trial = Trial(method, float(n))
        try:
            F = ca.integrator("F", method, spec, 0.0, [at], {"number_of_finite_elements": int(n)})
            best = np.inf
            for _ in range(repeat):
                t0 = time.perf_counter()
                r = F(x0=x0, z0=z0)
                best = min(best, time.perf_counter() - t0)
        except RuntimeError as exc:
            trial.status, trial.reason = "failed", str(exc).strip().splitlines()[-1][:200]
            out.append(trial)
            continue
        x, z = np.asarray(r["xf"]).ravel(), np.asarray(r["zf"]).ravel()
        y = observed(np.array([at]), x, z, np.asarray(u).ravel(), np.asarray(p).ravel(), np.asarray(d).ravel())[0].ravel()
        trial.time, trial.steps = best, int(n)
        trial.error = error_of({nm: float(y[index[nm]]) for nm in names}) if np.all(np.isfinite(y)) else np.inf
        if not np.isfinite(trial.error):
            trial.status, trial.reason = "failed", "diverged"
        out.append(trial)
    return out


def _baumgarte(cm, at, tolerances, names, error_of, repeat):
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
                 workers=0, repeat=repeat, t_out=[0.0, at])
    out = []
    for run in runs:
        trial = Trial("baumgarte", run.case.settings["rtol"], time=run.wall, status=run.status, reason=run.reason)
        if run.status == "ok":
            _fill(trial, run.result, other, names, error_of)
        out.append(trial)
    return out


def _scipy(cm, method, at, tolerances, ref_run, names, error_of, repeat):
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
    u, p, d = np.array(dae.u_default, dtype=float), np.array(dae.p_value, dtype=float), np.array(dae.d_value, dtype=float)
    none = np.zeros(0)
    rhs = NumpyCall(dae.ode)
    jac = NumpyCall(ca.Function("ode_jacobian", [dae.t, dae.x, dae.z, dae.u, dae.p, dae.d],
                                [ca.densify(ca.jacobian(dae.ode(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d), dae.x))]))
    observed = NumpyCall(dae.observed)
    index = {n: k for k, n in enumerate(dae.observed_names)}
    name = {"radau": "Radau", "bdf": "BDF", "dop853": "DOP853"}[method[6:]]
    out = []
    for tol in tolerances:
        trial = Trial(method, tol)
        best, sol = np.inf, None
        for _ in range(repeat):
            t0 = time.perf_counter()
            implicit = {} if name == "DOP853" else {"jac": lambda t, x: jac(np.array([t]), x, none, u, p, d)[0]}
            sol = solve_ivp(lambda t, x: rhs(np.array([t]), x, none, u, p, d)[0].ravel(), (0.0, at), x0,
                            method=name, rtol=tol, atol=tol * ATOL_RATIO * np.array(dae.x_nominal), **implicit)
            best = min(best, time.perf_counter() - t0)
        if not sol.success:
            trial.status, trial.reason = "failed", sol.message
        else:
            y = observed(np.array([at]), sol.y[:, -1], none, u, p, d)[0].ravel()
            trial.error = error_of({nm: float(y[index[nm]]) for nm in names})
            trial.time, trial.steps, trial.evaluations = best, sol.t.size - 1, int(sol.nfev)
        out.append(trial)
    return out
