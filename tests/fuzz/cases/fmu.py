"""An exported FMU (FMI 2.0, the driven model: tunable spring.c, input drive.tau) driven through FMPy's
low-level calls with values a master must not set: the FMU must refuse them (fmi2Error) and log the name."""
from __future__ import annotations

import ctypes
import math

import numpy as np

from fuzz import fixtures
from fuzz.framework import Collector, FmuSession, close, expect

NEEDS = ("driven", "fmu")


def _session(started=False):
    s = FmuSession(fixtures.fmu())
    if started:
        s.start()
    return s


def _set(name, value, started=False, then=None):
    def run():
        s = _session(started)
        if not started:
            s.call("enterInitializationMode")
        s.call("setReal", [s.vr[name]], [value])
        if not started:
            s.call("exitInitializationMode")
            s.call("newDiscreteStates")
            s.call("enterContinuousTimeMode")
        return s.derivatives() if then is None else then(s)
    return run


def collector() -> Collector:
    col = Collector("fmu")
    for name in ("spring.c", "drive.tau"):
        for what, value in (("nan", math.nan), ("inf", math.inf)):
            col.bad(f"setReal.{name}.{what}", _set(name, value), (name,), needs=NEEDS)
            col.bad(f"setReal.{name}.{what}_running", _set(name, value, started=True), (name,), needs=NEEDS)
    col.bad("setReal.spring.c.negative", _set("spring.c", -1.0), ("spring.c",), needs=NEEDS)
    col.bad("setReal.spring.c.negative_running", _set("spring.c", -1.0, started=True), ("spring.c",), needs=NEEDS)
    col.bad("setReal.start.nan", _set("j1.phi", math.nan), ("j1.phi",), needs=NEEDS)
    col.bad("setReal.output", _set("spring.tau", 1.0, started=True), ("spring.tau",), needs=NEEDS)

    def unknown_ref(call):
        def run():
            s = _session(True)
            if call == "set":
                return s.call("setReal", [99999], [1.0])
            return s.call("getReal", [99999])
        return run
    col.bad("setReal.unknown_ref", unknown_ref("set"), ("99999",), needs=NEEDS)
    col.bad("getReal.unknown_ref", unknown_ref("get"), ("99999",), needs=NEEDS)

    def states(values):
        def run():
            s = _session(True)
            n = s.md.numberOfContinuousStates
            s.call("setContinuousStates", (ctypes.c_double * n)(*values[:n]), n)
            return s.derivatives()
        return run
    col.bad("setContinuousStates.nan", states([math.nan, 0.0]), (("state", "j1.phi", "x[0]"),), needs=NEEDS)
    col.bad("setContinuousStates.count", lambda: (lambda s: s.call(
        "setContinuousStates", (ctypes.c_double * 5)(*[0.0] * 5), 5))(_session(True)), (("2", "states"),), needs=NEEDS)

    def set_time(t):
        def run():
            s = _session(True)
            s.call("setTime", t)
            return s.derivatives()
        return run
    col.bad("setTime.nan", set_time(math.nan), ("time",), needs=NEEDS)
    col.bad("setInteger.any", lambda: _session(True).call("setInteger", [0], [1]), ("Integer",), needs=NEEDS)
    col.bad("getFMUstate", lambda: _session(True).call("getFMUstate"), ("state",), needs=NEEDS)

    def wrong_guid():
        from fmpy.fmi2 import FMU2Model
        from fmpy import extract
        s = FmuSession(fixtures.fmu(), instantiate=False)
        fmu = FMU2Model(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=extract(fixtures.fmu()),
                        modelIdentifier=s.md.modelExchange.modelIdentifier, instanceName="x")
        try:
            fmu.instantiate(callbacks=s._callbacks)
        except Exception as exc:
            raise __import__("fuzz.framework", fromlist=["FmuRefusal"]).FmuRefusal(
                f"instantiate refused ({exc}): " + " | ".join(s.log)) from None
    col.bad("instantiate.guid", wrong_guid, ("GUID",), needs=NEEDS)

    col.good("setReal.spring.c.tuned", _set("spring.c", 400.0),
        "a tunable parameter within its range", lambda d: expect(np.all(np.isfinite(d)), "finite"), needs=NEEDS)

    def physics():
        s = _session(True)
        s.call("setReal", [s.vr["drive.tau"]], [1.0])
        return s.derivatives()
    col.good("setReal.input.derivatives", physics, "an input set in continuous-time mode drives the model",
             lambda d: expect(close(sorted(np.abs(d)), [0.0, 10.0]), "der(w) = tau/J = 10"), needs=NEEDS)
    return col
