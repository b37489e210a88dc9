"""Many runs of one compiled model: a grid or a list of cases, in worker processes or on a Dask cluster.

`sweep(cm, params={"spring.c": [100, 200]}, starts={"j1.phi": [0.1, 0.5]}, t_end=2.0)` runs every
combination (`combine="grid"`) or the i-th value of each list together (`combine="zip"`: a sample),
or the explicit `cases=[{"params": {...}, "start": {...}, "inputs": {...}}, ...]`. Each case is one
`cm.simulate`. The compiled model crosses to each worker once — pickled by CasADi's serialisation,
sent with each worker's initialiser, or `client.scatter(..., broadcast=True)` on Dask — so a user
who outgrows one machine passes `client=dask.distributed.Client("tcp://scheduler:8786")` and nothing
else changes. Every case comes back: a failed run with its partial result and reason, one refused
before it ran (start values that cannot be met) with its message, in one table.
"""
from __future__ import annotations

import contextlib
import csv
import itertools
import os
import pickle
import signal
import threading
import time
import warnings
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from multiprocessing import get_context

import numpy as np

from .core.arguments import mapping, name_list, whole_number
from .core.declarations import finite_number
from .core.errors import MechnetError
from .interrupts import Interrupted
from .simulate import IntegrationWarning

POLL_SECONDS = 0.1      # how often the parent looks at its workers' runs (Ctrl-C is noticed at once regardless)


@dataclass(frozen=True)
class Case:
    """One run's settings: tunable parameters, start values and inputs, by dotted name."""

    index: int
    params: dict = field(default_factory=dict)
    start: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)    # simulate() keywords of this case (method, rtol, ...)


@dataclass
class Run:
    """One case's outcome: status "ok", "failed" (the result holds the solution up to the failure) or
    "error" (refused before it ran: no result); its reason; its wall time on the worker."""

    case: Case
    status: str
    reason: str = ""
    result: object = None
    wall: float = 0.0


def cases_of(params=None, starts=None, inputs=None, combine: str = "grid") -> list[Case]:
    """The cases a sweep runs: every combination of the values (grid) or the i-th of each (zip)."""
    groups = [(kind, mapping(values, f"sweep({kind}=...)")) for kind, values in
              (("params", params), ("start", starts), ("inputs", inputs))]
    axes = []
    for kind, values in groups:
        for name, options in values.items():
            if isinstance(options, (str, bytes)) or not hasattr(options, "__len__"):
                raise MechnetError(f"sweep({'starts' if kind == 'start' else kind}=...): {name!r} takes a list "
                                   f"of values to run, got {options!r:.60}")
            if len(options) == 0:
                raise MechnetError(f"sweep({'starts' if kind == 'start' else kind}=...): {name!r} has no values, "
                                   f"so the sweep would run nothing; give it at least one")
            axes.append((kind, name, list(options)))
    if combine not in ("grid", "zip"):
        raise MechnetError(f"sweep(combine={combine!r}): 'grid' (every combination) or 'zip' (the i-th values "
                           f"together)")
    if not axes:
        return [Case(0)]
    if combine == "zip":
        lengths = {len(values) for _, _, values in axes}
        if len(lengths) != 1:
            raise MechnetError(f"sweep(combine='zip') needs lists of one length, got "
                               f"{', '.join(f'{n}: {len(v)}' for _, n, v in axes)}")
        rows = list(zip(*[values for _, _, values in axes]))
    else:
        rows = list(itertools.product(*[values for _, _, values in axes]))
    out = []
    for k, row in enumerate(rows):
        parts = {"params": {}, "start": {}, "inputs": {}}
        for (kind, name, _), value in zip(axes, row):
            parts[kind][name] = value
        out.append(Case(k, **parts))
    return out


def _explicit(cases) -> list[Case]:
    if isinstance(cases, (str, bytes, dict)) or not hasattr(cases, "__iter__"):
        raise MechnetError(f"sweep(cases={cases!r:.60}) takes a list of cases, each a mapping such as "
                           f"{{'params': {{...}}, 'start': {{...}}}}")
    cases = list(cases)
    if not cases:
        raise MechnetError("sweep(cases=[]): no cases, so the sweep would run nothing; give at least one")
    out = []
    for k, case in enumerate(cases):
        case = mapping(case, f"sweep(cases=[...])[{k}]")
        unknown = set(case) - {"params", "start", "inputs", "settings"}
        if unknown:
            raise MechnetError(f"sweep(cases=[...])[{k}]: keys are 'params', 'start', 'inputs' and 'settings', "
                               f"got {sorted(unknown)}")
        made = Case(k, **{key: mapping(case.get(key), f"sweep(cases=[...])[{k}][{key!r}]")
                          for key in ("params", "start", "inputs", "settings")})
        _check_settings(made.settings, f"sweep(cases=[...])[{k}]['settings']")
        out.append(made)
    return out


_OWN = {"t_end", "params", "start", "inputs"}     # set by the sweep itself, per case


def _check_settings(settings: dict, what: str) -> None:
    """Keywords the sweep passes on to cm.simulate: simulate's own, and not those the sweep sets."""
    import inspect

    from .simulate.integrator import simulate as simulate_function
    allowed = set(inspect.signature(simulate_function).parameters) - {"cm"} - _OWN
    for key in settings:
        if key == "start":
            raise MechnetError(f"{what}: start values of a sweep are `starts={{name: [values]}}`")
        if key in _OWN:
            raise MechnetError(f"{what}: {key!r} is set by the sweep itself, not a simulate() setting")
        if key not in allowed:
            raise MechnetError(f"{what}: {key!r} is not a setting of cm.simulate ({', '.join(sorted(allowed))})")


def run_case(cm, case: Case, settings: dict) -> Run:
    """One case, as every worker runs it (the simulator's own failures and refusals are kept)."""
    best = np.inf
    for _ in range(settings.get("repeat", 1)):        # the best of repeats: the first builds integrators
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", IntegrationWarning)     # the failure is in the table
                res = cm.simulate(settings["t_end"], params=case.params, start=case.start, inputs=case.inputs,
                                  **{**settings["simulate"], **case.settings})
        except MechnetError as exc:
            return Run(case, "error", f"{type(exc).__name__}: {exc}", None, time.perf_counter() - t0)
        best = min(best, time.perf_counter() - t0)
    status, reason = ("ok", "") if res.failure is None else ("failed", str(res.failure))
    return Run(case, status, reason, res, best)


_WORKER_MODEL = None


def _worker_start(packed: bytes):
    """A worker process: the model, and Ctrl-C left to the parent (a terminal sends it to the whole
    process group; the parent stops the workers itself: `_in_workers`)."""
    global _WORKER_MODEL
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _WORKER_MODEL = pickle.loads(packed)


def _worker_run(case: Case, settings: dict) -> Run:
    return run_case(_WORKER_MODEL, case, settings)


def _dask_run(case: Case, settings: dict, cm) -> Run:
    return run_case(cm, case, settings)


class Sweep:
    """The runs of a sweep, in case order, and their table (`rows()`, `to_pandas()`, `to_csv()`,
    `to_markdown()`). `outputs` are read at `at` (default: each run's end)."""

    def __init__(self, runs: list[Run], outputs: list[str], at: float | None):
        self.runs, self.outputs, self.at = runs, outputs, at

    def __len__(self):
        return len(self.runs)

    def __getitem__(self, k) -> Run:
        return self.runs[k]

    @property
    def failed(self) -> list[Run]:
        return [r for r in self.runs if r.status != "ok"]

    def rows(self) -> list[dict]:
        out = []
        for run in self.runs:
            row = {"case": run.case.index}
            for kind in ("params", "start", "inputs", "settings"):
                for name, value in getattr(run.case, kind).items():
                    row[name if kind in ("params", "settings") else f"{kind}:{name}"] = \
                        value if np.isscalar(value) else repr(value)
            res = run.result
            row.update(status=run.status, reason=run.reason, wall_s=run.wall,
                       t_end=float(res.t[-1]) if res is not None else np.nan,
                       steps=int(res.stats.get("nsteps", 0)) if res is not None else 0,
                       events=sum(1 for e in res.events if e.kind == "state") if res is not None else 0)
            for name in self.outputs:
                row[name] = _value_at(res, name, self.at)
            out.append(row)
        return out

    def to_pandas(self):
        try:
            import pandas as pd
        except ImportError:
            raise MechnetError("Sweep.to_pandas() needs pandas: pip install 'mechnet[pandas]'") from None
        return pd.DataFrame(self.rows())

    def to_csv(self, path) -> None:
        """The table as CSV (RFC 4180 quoting, the csv module's: a text holding a comma, a quote or a line
        break is quoted, its quotes doubled); floats with every digit (repr)."""
        rows = self.rows()
        keys = list(dict.fromkeys(k for row in rows for k in row))
        with open(path, "w", encoding="utf-8", newline="") as f:
            writer = csv.writer(f, lineterminator="\n")
            writer.writerow(keys)
            for row in rows:
                writer.writerow([_csv_cell(row.get(k, "")) for k in keys])

    def to_markdown(self) -> str:
        rows = self.rows()
        keys = list(dict.fromkeys(k for row in rows for k in row))
        lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
        lines += ["| " + " | ".join(_text(row.get(k, "")) for k in keys) + " |" for row in rows]
        return "\n".join(lines)

    def __repr__(self):
        return f"<Sweep: {len(self.runs)} runs, {len(self.failed)} not ok>"


def _value_at(res, name, at):
    if res is None:
        return np.nan
    values = np.asarray(res[name], dtype=float)
    if at is None:
        return float(values[-1])
    if at > res.t[-1] or at < res.t[0]:
        return np.nan                                   # a failed run that did not get there
    return float(np.interp(at, res.t, values))


def _text(value):
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _csv_cell(value):
    return repr(float(value)) if isinstance(value, float) else str(value)      # (np.float64's repr names its type)


def sweep(cm, *, t_end: float, params=None, starts=None, inputs=None, cases=None, combine: str = "grid",
          workers: int | None = None, client=None, outputs=(), at: float | None = None, repeat: int = 1,
          **simulate) -> Sweep:
    """Run `cm.simulate(t_end, params=..., start=..., inputs=..., **simulate)` for every case.

    `workers`: local worker processes (default: one per core, at most one per case; 0 or 1 runs them
    here, one after the other). `client`: a `dask.distributed.Client` to run them on instead. `outputs`:
    names whose values (at `at`, default each run's end) join the table; `repeat`: runs per case, the
    best wall time kept (the first run of a setting builds its integrators). Parameters must be tunable
    (`mn.tunable(...)` or `mn.every_parameter_tunable()`): a folded one is refused by its run."""
    if not hasattr(cm, "simulate") or not hasattr(cm, "dae"):
        raise MechnetError(f"sweep takes a compiled model (Model.compile()), got {type(cm).__name__}")
    t_end = finite_number(t_end, "sweep(t_end=...)", MechnetError)
    if t_end <= 0:
        raise MechnetError(f"sweep(t_end={t_end:g}) must be > 0")
    if at is not None:
        at = finite_number(at, "sweep(at=...)", MechnetError)
        t_start = finite_number(simulate.get("t_start") or 0.0, "sweep(t_start=...)", MechnetError)
        if not t_start <= at <= t_end:
            raise MechnetError(f"sweep(at={at:g}) lies outside the runs, from t_start = {t_start:g} to t_end = "
                               f"{t_end:g} s: the outputs would be read where no run has values")
    if combine not in ("grid", "zip"):
        raise MechnetError(f"sweep(combine={combine!r}): 'grid' (every combination) or 'zip' (the i-th values "
                           f"together)")
    _check_settings(simulate, "sweep(...)")
    if cases is not None:
        if params or starts or inputs:
            raise MechnetError("sweep: give cases=[...] or params/starts/inputs, not both")
        todo = _explicit(cases)
    else:
        todo = cases_of(params, starts, inputs, combine)
    names = name_list(outputs, "sweep(outputs=...)")
    unknown = [n for n in names if n not in cm.names]
    if unknown:
        raise MechnetError(f"sweep(outputs=...): {unknown[0]!r} is not a name of model {cm.name!r}")
    settings = {"t_end": t_end, "simulate": dict(simulate), "repeat": whole_number(repeat, "sweep(repeat=...)", 1)}
    if client is not None:
        _check_client(client)
        runs = _on_dask(cm, todo, settings, client, names, at)
    else:
        n = min(os.cpu_count() or 1, len(todo)) if workers is None else whole_number(workers, "sweep(workers=...)", 0)
        if n <= 1:
            runs = _here(cm, todo, settings, names, at)
        else:
            _check_picklable(todo, settings)
            runs = _in_workers(cm, todo, settings, n, names, at)
    return Sweep(list(runs), names, at)


def _here(cm, todo, settings, names, at) -> list[Run]:
    """The cases one after the other in this process; Ctrl-C raises `Interrupted` with the finished ones."""
    runs = []
    try:
        for case in todo:
            runs.append(run_case(cm, case, settings))
    except KeyboardInterrupt:
        raise Interrupted("sweep", Sweep(runs, names, at)) from None
    return runs


def _in_workers(cm, todo, settings, n, names, at) -> list[Run]:
    """The cases in n worker processes (spawned: no state of this process is copied). The parent waits
    POLL_SECONDS at a time and, on Ctrl-C, cancels the cases not started, ends the workers and raises
    `Interrupted` with a Sweep of the finished runs (the pool's own exit waited for the running cases:
    Ctrl-C took 12-19 s and lost every finished run). The workers ignore SIGINT (`_worker_start`)."""
    pool = ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn"), initializer=_worker_start,
                               initargs=(pickle.dumps(cm),))
    futures = []
    try:
        with _workers_ignore_sigint():
            futures = [pool.submit(_worker_run, case, settings) for case in todo]
        pending = set(futures)
        while pending:
            _, pending = wait(pending, timeout=POLL_SECONDS, return_when=FIRST_COMPLETED)
        runs = [f.result() for f in futures]
    except KeyboardInterrupt:
        finished = [f.result() for f in futures if f.done() and not f.cancelled() and f.exception() is None]
        _stop(pool)
        raise Interrupted("sweep", Sweep(finished, names, at)) from None
    except BaseException:
        _stop(pool)
        raise
    pool.shutdown()
    return runs


@contextlib.contextmanager
def _workers_ignore_sigint():
    """While the pool spawns its workers (at the first submit), SIGINT is ignored in this process, so they
    start with it ignored (a disposition kept across exec, and Python keeps it): a terminal's Ctrl-C, sent
    to the whole process group, found a worker still importing and printed its traceback. (In another
    thread than the main one the disposition cannot be changed: the workers ignore it once started.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel the cases not started and end the worker processes now (not after their runs), then let the
    pool release its queues (left open, their semaphores were reported leaked at exit)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=5.0)
    pool.shutdown(wait=True)


def _on_dask(cm, todo, settings, client, names, at) -> list[Run]:
    """The cases on a Dask cluster; Ctrl-C cancels those not finished and raises `Interrupted` with a
    Sweep of the finished ones."""
    shared = client.scatter(cm, broadcast=True)
    futures = client.map(_dask_run, todo, settings=settings, cm=shared, pure=False)
    try:
        while not all(f.done() for f in futures):
            time.sleep(POLL_SECONDS)
        return client.gather(futures)
    except KeyboardInterrupt:
        done = [f for f in futures if f.done() and f.status == "finished"]
        client.cancel([f for f in futures if not f.done()])
        finished = client.gather(done) if done else []
        raise Interrupted("sweep", Sweep(list(finished), names, at)) from None


def _check_client(client) -> None:
    """A Dask client that can take the runs: anything else, or a closed one, named."""
    if not all(hasattr(client, a) for a in ("scatter", "map", "gather", "cancel")):
        raise MechnetError(f"sweep(client={client!r:.60}) takes a dask.distributed.Client (or workers=n for "
                           f"local processes)")
    status = getattr(client, "status", "running")
    if status in ("closing", "closed", "failed"):
        raise MechnetError(f"sweep(client=...): the Dask client is {status}; pass an open one "
                           f"(dask.distributed.Client(...)) or workers=n for local processes")


def _check_picklable(todo, settings) -> None:
    """Worker processes receive each case pickled: a value that cannot be (a lambda, a local function) is
    refused by name before any worker starts."""
    for name, value in settings["simulate"].items():
        _picklable(value, f"sweep({name}=...)")
    for case in todo:
        for kind in ("params", "start", "inputs", "settings"):
            for name, value in getattr(case, kind).items():
                _picklable(value, f"sweep(cases=[...])[{case.index}]['settings'][{name!r}]" if kind == "settings"
                           else f"sweep({'starts' if kind == 'start' else kind}=...): {name!r} (case {case.index})")


def _picklable(value, what: str) -> None:
    try:
        pickle.dumps(value)
    except Exception as exc:                   # noqa: BLE001 - whatever pickle refuses
        raise MechnetError(f"{what}: {value!r:.60} cannot be sent to worker processes (pickle: {exc}); define "
                           f"it at module level (not a lambda or a local function), give a Table or (times, "
                           f"values), or run the sweep here with workers=0") from None
