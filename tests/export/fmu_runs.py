"""Running an exported FMU (Model Exchange) as importers run it, in FMPy and in the Modelica Association's
`fmusim`, and reading its events from the output: the harness of tests/export/test_event_fmus.py.

What the importers do, read from their sources (FMPy 0.3.32 `fmpy/simulation.py`, `fmpy/sundials`;
Reference-FMUs `fmusim/FMICVode.c`, `FMIEuler.c`):

- CVode: BDF, relative tolerance rtol and absolute tolerance rtol·nominal per state (FMPy's
  `CVodeSolver` multiplies `getNominalsOfContinuousStates` by rtol; fmusim does the same), so with the
  nominals mechnet declares (1.0 for every state of these scenes) atol = rtol. FMPy also limits the
  step to (stop − start)/50.
- Euler: both take one explicit step per output interval (FMPy's `simulateME` steps from communication
  point to communication point; its `step_size` is only checked to divide the interval; fmusim's
  `FMIEulerStep` steps to the next output time), so a step h is run as output interval h.
- Both record a row before and one after every event (FMPy's `record_events=True`, the default;
  fmusim always), whatever the output interval, so event times are read from repeated time rows.
"""
from __future__ import annotations

import csv
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
FMUSIM = ROOT.parent / "shared" / "tools" / "fmusim"
NO_FMUSIM = f"no second importer at {FMUSIM}"


@dataclass(frozen=True)
class Setting:
    """An importer setting: CVode at rtol with an output interval, or Euler at step h (= the interval)."""
    solver: str                  # "CVode" or "Euler"
    interval: float              # s: output interval (Euler: the step)
    rtol: float | None = None    # CVode's relative tolerance (atol = rtol·nominal)

    @property
    def atol(self) -> float | None:
        return None if self.rtol is None else self.rtol * 1.0   # the states' nominals are 1.0

    def __str__(self):
        if self.solver == "Euler":
            return f"Euler h={self.interval:g}"
        return f"CVode rtol={self.rtol:g} dt_out={self.interval:g}"


CVODE_SETTINGS = [Setting("CVode", interval, rtol) for rtol in (1e-4, 1e-6) for interval in (0.01, 0.1)]
EULER_FAST, EULER_FINE = Setting("Euler", 1e-3), Setting("Euler", 1e-4)


@dataclass
class Run:
    """One importer's output: time and the recorded variables (mechnet names), rows repeated at events."""
    label: str
    t: np.ndarray
    values: dict = field(repr=False)

    def __getitem__(self, name):
        return self.values[name]

    def transitions(self, names=None, tol=1e-9):
        """Times of the events that changed something: a time repeated in the output (the rows before
        and after an event) with some of `names` (default: every recorded variable) differing by more
        than tol between its first and last row. Events that change nothing (an indicator crossing
        without a transition, a stop fired at round-off speed) are left out; times within 1e-12 s merge."""
        names = list(self.values) if names is None else names
        t = self.t
        out = []
        i = 0
        while i < len(t) - 1:
            j = i
            while j + 1 < len(t) and t[j + 1] == t[i]:
                j += 1
            if j > i and any(abs(self.values[n][j] - self.values[n][i]) > tol for n in names):
                if not out or t[i] - out[-1] > 1e-12:
                    out.append(float(t[i]))
            i = j + 1
        return np.array(out)

    def mode_changes(self, name):
        """Times at which the discrete variable `name` takes a new value (between any two rows)."""
        d = self.values[name]
        return self.t[1:][np.diff(d) != 0]


def fmpy_run(path, stop_time, names, setting: Setting, start_values=None) -> Run:
    from fmpy import simulate_fmu
    from mechnet.export.model_description import fmi_name

    kw = dict(relative_tolerance=setting.rtol) if setting.solver == "CVode" else dict(step_size=setting.interval)
    res = simulate_fmu(str(path), stop_time=stop_time, solver=setting.solver, output_interval=setting.interval,
                       output=[fmi_name(n) for n in names], fmi_type="ModelExchange",
                       start_values={fmi_name(k): v for k, v in (start_values or {}).items()}, **kw)
    return Run(f"FMPy {setting}", np.asarray(res["time"]), {n: np.asarray(res[fmi_name(n)]) for n in names})


def fmusim_run(path, stop_time, names, setting: Setting, workdir, start_values=None) -> Run:
    from mechnet.export.model_description import fmi_name

    out = Path(workdir) / f"{Path(path).stem}.csv"
    args = [str(FMUSIM), "--interface-type", "me", "--solver", setting.solver.lower(),
            "--output-interval", repr(setting.interval), "--stop-time", repr(float(stop_time)),
            "--output-file", str(out)]
    if setting.rtol is not None:
        args += ["--tolerance", repr(setting.rtol)]
    for k, v in (start_values or {}).items():
        args += ["--start-value", fmi_name(k), repr(float(v))]
    for n in names:
        args += ["--output-variable", fmi_name(n)]
    done = subprocess.run([*args, str(path)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"fmusim {setting} failed ({done.returncode}): {done.stdout[-2000:]}{done.stderr[-2000:]}"
    rows = list(csv.reader(out.open()))
    data = np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))
    return Run(f"fmusim {setting}", data[:, 0], {n: data[:, rows[0].index(fmi_name(n))] for n in names})


def run(importer, path, stop_time, names, setting: Setting, workdir, start_values=None) -> Run:
    """`importer` is "fmpy" or "fmusim"."""
    if importer == "fmpy":
        return fmpy_run(path, stop_time, names, setting, start_values)
    return fmusim_run(path, stop_time, names, setting, workdir, start_values)


def first_disagreement(expected, measured, tol):
    """None when every expected time has a measured one within tol and vice versa (in order, same count);
    else a message naming the first disagreeing event and both lists' lengths."""
    expected, measured = np.asarray(expected, float), np.asarray(measured, float)
    for k in range(max(len(expected), len(measured))):
        if k >= len(expected):
            return (f"{len(measured)} events measured, {len(expected)} expected: extra event #{k + 1} at "
                    f"{measured[k]:.9g} s")
        if k >= len(measured):
            return (f"{len(measured)} events measured, {len(expected)} expected: event #{k + 1} at "
                    f"{expected[k]:.9g} s missing (last measured {measured[-1] if len(measured) else None})")
        if abs(expected[k] - measured[k]) > tol:
            return (f"event #{k + 1}: measured {measured[k]:.9g} s, expected {expected[k]:.9g} s "
                    f"(off by {measured[k] - expected[k]:.3g} s > {tol:g}); {len(measured)} measured, "
                    f"{len(expected)} expected")
    return None
