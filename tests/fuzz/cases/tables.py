"""Tables, signals and inputs: Table(times, values, mode), Step/Ramp/Sine/Constant, and the forms
simulate(inputs=...) takes ((times, values) pairs, N×2 arrays, callables)."""
from __future__ import annotations

import math

import numpy as np

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.signals import Constant, Ramp, Sine, Step, Table
from fuzz import fixtures
from fuzz.framework import Collector, close, expect


def _driven_by(signal):
    """j1 (J = 0.1) on a spring (c = 100), driven by a torque signal."""
    m = mn.Model("m")
    f = m.add(rot.Fixed(name="f"))
    s = m.add(rot.Spring(name="s", c=100.0))
    j1 = m.add(rot.Inertia(name="j1", J=0.1, phi_start=0.0, w_start=0.0))
    tq = m.add(rot.Torque(name="tq", tau=signal))
    m.connect(f.flange, s.flange_a)
    m.connect(s.flange_b, j1.flange_a)
    m.connect(tq.flange, j1.flange_b)
    return m.compile().simulate(1.0, n_out=11)


def _input(value):
    return lambda: fixtures.driven().simulate(1.0, n_out=11, inputs={"drive.tau": value})


def collector() -> Collector:
    col = Collector("tables")
    bad_tables = {
        "one_knot": ([0.0], [1.0]), "lengths": ([0.0, 1.0, 2.0], [1.0, 2.0]),
        "decreasing": ([0.0, 2.0, 1.0], [0, 1, 2]),
        "nan_time": ([0.0, math.nan], [0, 1]), "inf_value": ([0.0, 1.0], [0, math.inf]), "text": ("abc", [0, 1]),
        "none": (None, [0, 1]), "text_value": ([0, 1], ["a", "b"]), "three_equal": ([0, 1, 1, 1], [0, 1, 2, 3]),
        "values_2d": ([0.0, 1.0, 2.0], [[1, 2], [3, 4], [5, 6]]), "values_2x2": ([0, 1, 2, 3], [[1, 2], [3, 4]]),
        "times_2d": ([[0.0, 1.0], [2.0, 3.0]], [0, 1, 2, 3]),
        "empty": ([], []), "scalar": (1.0, 2.0), "bool": ([0, 1], [True, False]), "complex": ([0, 1], [1j, 2]),
        "dict": ({0: 1}, [1]),
    }
    culprits = {"values_2d": "values", "values_2x2": "values", "times_2d": "times", "text_value": "values",
                "inf_value": "values",
                "bool": "values", "complex": "values", "lengths": ("times", "values"), "one_knot": "knots"}
    for what, (t, y) in bad_tables.items():
        col.bad(f"table.{what}", lambda t=t, y=y: Table(t, y), culprits.get(what, "times"),
                known="Table flattening 2-D values" if what == "values_2x2" else "")
    col.bad("table.hold_repeat", lambda: Table([0, 1, 1, 2], [0, 1, 2, 3], mode="hold"), ("time",))
    for what, mode in (("unknown", "cubic"), ("none", None), ("number", 1), ("case", "Linear")):
        col.bad(f"table.mode.{what}", lambda m=mode: Table([0, 1], [0, 1], mode=m), ("mode",))
    col.good("table.jump", lambda: Table([0, 1, 1, 2], [0.0, 0.5, -0.5, 0.0]),
             "a time given twice in linear mode is a jump (Modelica)",
             lambda tab: expect(close(tab([0.5, 0.999999, 1.0, 1.5]), [0.25, 0.4999995, -0.5, -0.25]), "jump at 1"))
    col.good("table.column", lambda: Table(np.array([[0.0], [1.0]]), np.array([[1.0], [3.0]])),
             "a column of times and a column of values is one sequence each",
             lambda tab: expect(close(tab(0.5), 2.0), "midpoint 2"))
    for what, make, culprit in (
            ("step.nan", lambda: Step(math.nan), "height"), ("step.start_text", lambda: Step(1.0, start_time="1"),
            "start_time"),
            ("ramp.zero_duration", lambda: Ramp(1.0, 0.0), "duration"), ("ramp.negative", lambda: Ramp(1.0, -1.0),
            "duration"),
            ("ramp.inf", lambda: Ramp(math.inf), "height"), ("sine.f_nan", lambda: Sine(1.0, math.nan), "f"),
            ("sine.phase_text", lambda: Sine(phase="x"), "phase"), ("constant.none", lambda: Constant(None), "k"),
            ("constant.list", lambda: Constant([1, 2]), "k"), ("step.offset_inf", lambda: Step(offset=math.inf),
            "offset")):
        col.bad(f"signal.{what}", make, (culprit,))
    col.good("signal.sine_negative_f", lambda: Sine(1.0, -1.0)(0.25), "a negative frequency is a sine run backwards",
             lambda v: expect(close(v, -1.0), "sin(-pi/2)"))
    col.good("signal.step_drives", lambda: _driven_by(Step(1.0, start_time=0.5)),
             "a step is a time event", lambda r: expect(close(r["j1.phi"][:6], 0.0), "rests until 0.5 s"))
    col.good("signal.table_drives", lambda: _driven_by(Table([0, 0.5, 0.5, 1], [0, 0, 1, 1])),
             "a table with a jump as a component's signal", lambda r: expect(close(r["j1.phi"][:6], 0.0), "rests"))

    # simulate(inputs=...)
    bad_inputs = {
        "pair_lengths": ([0.0, 1.0], [0.0, 1.0, 2.0]), "pair_decreasing": ([1.0, 0.0], [0.0, 1.0]),
        "array_3col": np.zeros((3, 3)), "array_nan": np.array([[0.0, 0.0], [1.0, math.nan]]),
        "pair_text": (["a", "b"], [0, 1]), "pair_none": (None, None), "empty_array": np.zeros((0, 2)),
        "three_tuple": ([0, 1], [0, 1], [0, 1]), "row_2x3": np.zeros((2, 3)) + [[0, 1, 2], [0, 1, 2]],
        "set": {1.0, 2.0}, "pair_2d_values": ([0, 1, 2], [[1, 2], [3, 4], [5, 6]]),
    }
    for what, value in bad_inputs.items():
        col.bad(f"input.{what}", _input(value), ("drive.tau",), needs=("driven",))
    col.bad("input.callable_nan_late", _input(lambda t: math.nan if t > 0.5 else 0.0), ("drive.tau",),
            needs=("driven",))
    col.bad("input.callable_array", _input(lambda t: np.array([t, t])), ("drive.tau",), needs=("driven",))
    col.bad("input.signal_for_unknown", lambda: fixtures.driven().simulate(1.0, inputs={"drive.f": Step(1.0)}),
            ("drive.f",), needs=("driven",))
    exact = lambda r: expect(close(r["j1.phi"][-1], 0.01 * (1 - math.cos(math.sqrt(1000.0) * 1.0)), 1e-4),
                             "a constant 1 N·m: phi = (1 - cos w t)/c")  # noqa: E731
    col.good("input.number", _input(1.0), "a number is a constant input", exact, needs=("driven",))
    col.good("input.int", _input(1), "an int is a number", exact, needs=("driven",))
    col.good("input.numpy_scalar", _input(np.float64(1.0)), "a numpy scalar is a number", exact, needs=("driven",))
    col.good("input.pair_constant", _input(([0.0, 1.0], [1.0, 1.0])), "a (times, values) pair", exact,
             needs=("driven",))
    col.good("input.array_nx2", _input(np.array([[0.0, 1.0], [1.0, 1.0]])), "an N×2 array", exact, needs=("driven",))
    col.good("input.table", _input(Table([0, 1], [1, 1])), "a Table", exact, needs=("driven",))
    col.good("input.callable", _input(lambda t: 1.0), "a callable f(t)", exact, needs=("driven",))
    col.good("input.pair_jump", _input(([0.0, 0.5, 0.5, 1.0], [0.0, 0.0, 1.0, 1.0])),
             "a time given twice in a pair is a jump",
             lambda r: expect(close(r["j1.phi"][:6], 0.0) and r["j1.phi"][-1] > 1e-3, "rests, then moves"),
             needs=("driven",))
    col.good("input.table_short", _input(([0.0, 0.2], [1.0, 1.0])), "a table holds its end value past its end",
             exact, needs=("driven",))
    return col
