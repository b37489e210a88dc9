"""What a fuzz case is, and the helpers cases share (the CLI, FMUs through FMPy, finding NaN in a result).

A case is data: an id, the API area, a call that makes the bad input, and the word(s) the refusal must
name. A legitimate input instead carries `ok` (why it is legitimate) and `check` (asserts the result is
right), so "accepted" is proven, not assumed. The runner (runner.py) classes what happened.
"""
from __future__ import annotations

import contextlib
import io
import math
import numbers
from dataclasses import dataclass
from typing import Callable

import numpy as np

import mechnet as mn


@dataclass
class Case:
    """One input. `culprit`: words the message must contain (each a string, or a tuple of alternatives);
    `needs`: fixtures (fixtures.py) to build in the parent before forking; `slow`: left out of the sample."""

    id: str
    area: str
    run: Callable[[], object]
    culprit: tuple = ()
    ok: str | None = None
    check: Callable[[object], object] | None = None
    needs: tuple = ()
    slow: bool = False
    timeout: float = 60.0
    known: str = ""                  # a known defect this case reproduces (issue 32's list), for the report


class Collector:
    """A module's cases: `bad(...)` for a mistake, `good(...)` for a legitimate input with its check."""

    def __init__(self, area: str):
        self.area = area
        self.cases: list[Case] = []

    def bad(self, id: str, run, culprit=(), **kw) -> None:
        culprit = (culprit,) if isinstance(culprit, str) else tuple(culprit)
        self.cases.append(Case(f"{self.area}.{id}", self.area, run, culprit, **kw))

    def good(self, id: str, run, why: str, check, **kw) -> None:
        self.cases.append(Case(f"{self.area}.{id}", self.area, run, ok=why, check=check, **kw))


# ---- refusals that do not arrive as a MechnetError object ------------------------------------------

class CliRefusal(mn.MechnetError):
    """The CLI refused (exit status 2 with an `error: ...` line, or argparse's usage error)."""


class FmuRefusal(mn.MechnetError):
    """An FMU call returned fmi2Error/fmi3Error; the message is what the FMU logged."""


def cli(*args) -> str:
    """`mechnet ARGS` in this process: its stdout when it succeeds; CliRefusal (with its stderr) when it
    exits with status 2 and an error line. A traceback escapes as the exception itself."""
    from mechnet.cli import main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main([str(a) for a in args])
        except SystemExit as exc:          # argparse: "mechnet simulate: error: argument --t-end: ..."
            status = exc.code
    if status not in (0, None):
        text = err.getvalue().strip()
        if "error:" in text:
            raise CliRefusal(text)
        if "usage:" in out.getvalue():     # no command: the help, with status 2
            raise CliRefusal(out.getvalue().strip())
        raise RuntimeError(f"exit status {status} without an error line: {text!r:.300}")
    return out.getvalue()


class FmuSession:
    """An FMI 2.0 Model Exchange instance of an extracted FMU through FMPy's low-level class, with a
    logger that keeps what the FMU says; `call` turns a refused call into FmuRefusal with that text."""

    def __init__(self, fmu_path: str, instantiate: bool = True):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Model, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
        self.md = read_model_description(fmu_path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[str] = []

        def logger(env, name, status, category, message):
            self.log.append(message.decode(errors="replace") if isinstance(message, bytes) else str(message))
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        from ctypes import byref
        from fmpy.logging import addLoggerProxy
        addLoggerProxy(byref(self._callbacks))     # formats the FMU's "%s", args before `logger` sees them
        self.fmu = FMU2Model(guid=self.md.guid, unzipDirectory=extract(fmu_path),
                             modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName="fuzz")
        if instantiate:
            self.fmu.instantiate(callbacks=self._callbacks)
            self.fmu.setupExperiment(startTime=0.0)

    def call(self, name, *args):
        from fmpy.fmi1 import FMICallException
        try:
            return getattr(self.fmu, name)(*args)
        except FMICallException as exc:
            raise FmuRefusal(f"{name} refused ({exc}): " + " | ".join(self.log)) from None

    def start(self):
        """Initialisation done, continuous-time mode (what a master does before stepping)."""
        self.call("enterInitializationMode")
        self.call("exitInitializationMode")
        self.call("newDiscreteStates")
        self.call("enterContinuousTimeMode")

    def derivatives(self) -> np.ndarray:
        import ctypes
        n = self.md.numberOfContinuousStates
        buf = (ctypes.c_double * n)()
        self.call("getDerivatives", buf, n)
        return np.array(buf)


# ---- results --------------------------------------------------------------------------------------

def contains_nan(obj, depth: int = 0) -> bool:
    """Whether a returned value holds a NaN anywhere a user would read numbers (arrays, floats, a Result's
    columns, a sweep's or study's table, dicts and lists of them)."""
    if depth > 4 or obj is None or isinstance(obj, (str, bytes, bool)):
        return False
    if isinstance(obj, numbers.Real):
        return math.isnan(obj)
    if isinstance(obj, np.ndarray):
        return obj.dtype.kind in "fc" and bool(np.isnan(obj).any())
    if isinstance(obj, dict):
        return any(contains_nan(v, depth + 1) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return any(contains_nan(v, depth + 1) for v in obj[:10000])
    if isinstance(obj, mn.Result):
        return contains_nan(obj.t, depth + 1) or contains_nan(np.asarray(obj.values, dtype=float), depth + 1)
    rows = getattr(obj, "rows", None)             # Sweep, AccuracyStudy: a method giving the table
    if rows is not None:
        try:
            table = rows() if callable(rows) else rows
        except Exception:      # a table that cannot be read is judged by the object's fields below
            table = None
        if table is not None and contains_nan(list(table), depth + 1):
            return True
    if hasattr(obj, "__dict__") and type(obj).__module__.startswith("mechnet"):
        return any(contains_nan(v, depth + 1) for v in vars(obj).values() if not callable(v))
    return False


def close(a, b, tol=1e-6) -> bool:
    return bool(np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=tol, atol=tol))


def expect(condition: bool, what: str) -> None:
    """An OK case's check: AssertionError saying what is wrong (the runner classes it E)."""
    if not condition:
        raise AssertionError(what)
