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

import itertools
import os
import pickle
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from multiprocessing import get_context

import numpy as np

from .core.arguments import mapping, name_list, whole_number
from .core.declarations import finite_number
from .core.errors import MechnetError
from .simulate import IntegrationWarning


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
    global _WORKER_MODEL
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
        rows = self.rows()
        keys = list(dict.fromkeys(k for row in rows for k in row))
        with open(path, "w", encoding="utf-8") as f:
            f.write(",".join(keys) + "\n")
            for row in rows:
                f.write(",".join(_csv_cell(row.get(k, "")) for k in keys) + "\n")

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
    text = repr(value) if isinstance(value, float) else str(value)
    return f'"{text}"' if ("," in text or '"' in text or "\n" in text) else text


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
        shared = client.scatter(cm, broadcast=True)
        futures = client.map(_dask_run, todo, settings=settings, cm=shared, pure=False)
        runs = client.gather(futures)
    else:
        n = min(os.cpu_count() or 1, len(todo)) if workers is None else whole_number(workers, "sweep(workers=...)", 0)
        if n <= 1:
            runs = [run_case(cm, case, settings) for case in todo]
        else:
            packed = pickle.dumps(cm)
            with ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn"), initializer=_worker_start,
                                     initargs=(packed,)) as pool:
                runs = list(pool.map(_worker_run, todo, [settings] * len(todo)))
    return Sweep(list(runs), names, at)
