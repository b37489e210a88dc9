"""simulate() and prepare() settings: each keyword with what it must not be, on the oscillator (j1 on a
spring, phi = 0.5 cos(sqrt(1000) t)) and the driven model (input drive.tau, tunable spring.c)."""
from __future__ import annotations

import math

import numpy as np

from fuzz import fixtures
from fuzz.framework import Collector, close, expect

W = math.sqrt(1000.0)


def _exact(res):
    expect(close(res["j1.phi"], 0.5 * np.cos(W * res.t), 1e-4), "phi = 0.5 cos(w t)")


BAD_SETTINGS = {
    "t_end": [("zero", 0.0), ("negative", -1.0), ("nan", math.nan), ("inf", math.inf), ("text", "1"),
              ("none", None), ("list", [1.0]), ("bool", True), ("complex", 1j)],
    "t_start": [("after_end", 2.0), ("equal_end", 1.0), ("nan", math.nan), ("text", "0"), ("inf", -math.inf)],
    "rtol": [("negative", -1e-6), ("zero", 0.0), ("one", 1.0), ("nan", math.nan), ("tiny", 1e-20), ("text", "1e-6"),
             ("list", [1e-6]), ("inf", math.inf)],
    "atol": [("negative", -1e-8), ("zero", 0.0), ("nan", math.nan), ("text", "x"), ("inf", math.inf)],
    "method": [("unknown", "rk45"), ("case", "IDAS"), ("number", 1), ("none_text", "none"), ("list", ["idas"]),
               ("accuracy_only", "collocation")],
    "n_out": [("zero", 0), ("one", 1), ("negative", -5), ("float", 2.5), ("text", "11"), ("nan", math.nan),
              ("bool", True), ("huge", 10**12)],
    "t_out": [("unsorted", [0.0, 0.5, 0.2, 1.0]), ("not_to_end", [0.0, 0.5]), ("past_end", [0.0, 0.5, 2.0]),
              ("nan", [0.0, math.nan, 1.0]), ("text", "0,1"), ("one", [1.0]), ("repeated", [0.0, 0.5, 0.5, 1.0]),
              ("matrix", [[0.0, 1.0]])],
    "max_steps": [("zero", 0), ("negative", -1), ("float", 10.5), ("text", "100"), ("nan", math.nan)],
    "progress": [("text", "yes"), ("number", 2)],
    "steady_state": [("text", "yes"), ("number", 1), ("none", None)],
    "params": [("list", [100.0]), ("unknown", {"spring.k": 1.0}), ("folded", {"j1.J": 1.0}),
    ("nan", {"spring.c": math.nan}),
               ("text", {"spring.c": "100"}), ("negative", {"spring.c": -1.0}), ("key", {1: 1.0}),
               ("state", {"j1.phi": 1.0}), ("array", {"spring.c": [1.0, 2.0]})],
    "start": [("unknown", {"j9.phi": 1.0}), ("nan", {"j1.phi": math.nan}), ("text", {"j1.phi": "a"}),
              ("list", [0.1]), ("param", {"spring.c": 1.0}), ("inf", {"j1.w": math.inf}),
              ("vector", {"j1.phi": [1.0, 2.0]})],
    "guess": [("unknown", {"j9.phi": 1.0}), ("nan", {"j1.phi": math.nan}), ("text", {"j1.w": "b"}), ("list", [0.1])],
    "inputs": [("unknown", {"drive.f": 1.0}), ("nan", {"drive.tau": math.nan}), ("text", {"drive.tau": "1"}),
               ("list", [1.0]), ("state", {"j1.phi": 1.0}), ("none_value", {"drive.tau": None}),
               ("raises", {"drive.tau": lambda t: 1 / 0}), ("returns_nan", {"drive.tau": lambda t: math.nan}),
               ("returns_text", {"drive.tau": lambda t: "x"}), ("returns_vector", {"drive.tau": lambda t: [1.0, 2.0]}),
               ("two_args", {"drive.tau": lambda t, u: 1.0}), ("inf", {"drive.tau": math.inf})],
    "continue_from": [("text", "res"), ("number", 1.0), ("dict", {"t": 1.0})],
}

# which model each setting is tried on
DRIVEN = {"params", "inputs"}


def _culprit(key, what):
    """The name the refusal must say: the keyword, or the dotted name at fault."""
    if key in ("params", "start", "guess", "inputs") and isinstance(dict(BAD_SETTINGS[key])[what], dict):
        value = dict(BAD_SETTINGS[key])[what]
        name = next(iter(value))
        return (name if isinstance(name, str) else key,)
    return (key,)


def _call(key, value, kind):
    def run():
        cm = fixtures.driven() if key in DRIVEN else fixtures.osc()
        if key == "t_end":
            args, kw = (value,), {}
        elif key == "t_start":
            args, kw = (1.0,), {"t_start": value}
        else:
            args, kw = (1.0,), {key: value}
        if kind == "prepare":
            run = cm.prepare(*args, **{k: v for k, v in kw.items() if k not in ("params", "start", "guess")})
            return run(**{k: v for k, v in kw.items() if k in ("params", "start", "guess")})
        return cm.simulate(*args, **kw)
    return run


def collector() -> Collector:
    col = Collector("simulate")
    for key, values in BAD_SETTINGS.items():
        for what, value in values:
            needs = ("driven",) if key in DRIVEN else ("osc",)
            col.bad(f"simulate.{key}.{what}", _call(key, value, "simulate"), _culprit(key, what), needs=needs)
            if key not in ("inputs", "continue_from", "progress"):
                col.bad(f"prepare.{key}.{what}", _call(key, value, "prepare"), _culprit(key, what), needs=needs)
    for key in ("tolerance", "t_final", "rtoll", "output", "x0"):
        col.bad(f"simulate.unknown_keyword.{key}", lambda k=key: fixtures.osc().simulate(1.0, **{k: 1}), (key,),
                needs=("osc",))
        col.bad(f"prepare.unknown_keyword.{key}", lambda k=key: fixtures.osc().prepare(1.0, **{k: 1}), (key,),
                needs=("osc",))
    col.bad("prepare.call.unknown", lambda: fixtures.osc().prepare(1.0)(inputs={"drive.tau": 1.0}), ("inputs",),
            needs=("osc",))
    col.bad("prepare.call.positional", lambda: fixtures.osc().prepare(1.0)({"j1.phi": 1.0}), ("j1.phi",),
            needs=("osc",))
    col.bad("simulate.positional_extra", lambda: fixtures.osc().simulate(1.0, 1e-6), ("simulate",), needs=("osc",))
    col.bad("simulate.start_and_continue", lambda: fixtures.osc().simulate(
        2.0, continue_from=fixtures.osc().simulate(1.0), start={"j1.phi": 0.1}), ("start", "continue_from"),
        needs=("osc",))
    col.bad("simulate.continue_other_model", lambda: fixtures.osc().simulate(
        2.0, continue_from=fixtures.driven().simulate(1.0)), ("continue_from",), needs=("osc", "driven"))
    col.bad("simulate.continue_before_end", lambda: fixtures.osc().simulate(
        0.5, continue_from=fixtures.osc().simulate(1.0)), ("t_end",), needs=("osc",))
    col.bad("simulate.steady_state_with_start", lambda: fixtures.osc().simulate(1.0, steady_state=True),
            ("steady_state", ("j1.phi", "j1.w")), needs=("osc",))

    # legitimate settings
    col.good("simulate.rtol_loose", lambda: fixtures.osc().simulate(0.1, rtol=0.5), "any rtol in [1e-14, 1)",
             lambda r: expect(abs(r["j1.phi"][0] - 0.5) < 1e-12, "starts at 0.5"), needs=("osc",))
    col.good("simulate.n_out_two", lambda: fixtures.osc().simulate(1.0, n_out=2), "two points: start and end",
             lambda r: expect(len(r.t) == 2 and close(r["j1.phi"][-1], 0.5 * math.cos(W), 1e-4), "exact end"),
             needs=("osc",))
    col.good("simulate.n_out_float_whole", lambda: fixtures.osc().simulate(1.0, n_out=11.0), "11.0 is a whole number",
             lambda r: expect(len(r.t) == 11, "11 points"), needs=("osc",))
    col.good("simulate.t_out_numpy", lambda: fixtures.osc().simulate(1.0, t_out=np.linspace(0, 1, 7)),
             "an increasing grid ending at t_end", lambda r: (expect(len(r.t) == 7, "7 points"), _exact(r)),
             needs=("osc",))
    col.good("simulate.t_out_from_before_zero", lambda: fixtures.osc().simulate(1.0, t_out=[-1.0, 0.5, 1.0]),
             "without t_start the run starts at t_out's first time",
             lambda r: expect(r.t[0] == -1.0 and close(r["j1.phi"], 0.5 * np.cos(W * (r.t + 1)), 1e-4), "from -1"),
             needs=("osc",))
    col.good("simulate.t_start_negative", lambda: fixtures.osc().simulate(0.5, t_start=-0.5),
             "time may start below 0", lambda r: expect(close(r["j1.phi"][-1], 0.5 * math.cos(W), 1e-4), "one second"),
             needs=("osc",))
    col.good("simulate.method_each", lambda: [fixtures.osc().simulate(0.5, method=m)["j1.phi"][-1]
                                              for m in ("auto", "idas", "cvodes-bdf", "cvodes-adams")],
             "every listed method", lambda v: expect(close(v, [0.5 * math.cos(W / 2)] * 4, 1e-4), "same end"),
             needs=("osc",))
    col.good("simulate.params_int", lambda: fixtures.driven().simulate(1.0, params={"spring.c": 400}),
             "an int is a number", lambda r: expect(abs(r["j1.phi"][-1]) < 1e-12, "undriven stays"), needs=("driven",))
    col.good("simulate.numpy_scalar", lambda: fixtures.osc().simulate(np.float32(1.0), rtol=np.float64(1e-8)),
             "numpy scalars are numbers", _exact, needs=("osc",))
    col.good("simulate.continue", lambda: fixtures.osc().simulate(2.0, continue_from=fixtures.osc().simulate(
        1.0, rtol=1e-10, atol=1e-12), rtol=1e-10, atol=1e-12), "a run goes on where the last ended", _exact,
        needs=("osc",))
    col.good("prepare.repeated", lambda: [fixtures.driven().prepare(1.0, n_out=3)(params={"spring.c": c})["j1.phi"][-1]
                                          for c in (100, 200)], "a prepared run called twice",
             lambda v: expect(close(v, [0, 0]), "undriven stays at 0"), needs=("driven",))
    return col
