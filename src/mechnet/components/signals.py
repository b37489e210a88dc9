"""Signals: functions of time, symbolic in `time`, that know their discontinuities.

A signal drives an input of a component (`rot.Torque(name="tq", tau=Step(2.0, start_time=1.0))`).
Because the value is a CasADi expression of time, prescribed motion built on
it can be differentiated, and the times where the signal or its slope jumps
are handed to the simulator as time events: the integrator stops and
restarts exactly there instead of stepping across a kink.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ..core.declarations import finite_number, not_a_number
from ..core.errors import ParameterError


def _number(owner: str, name: str, value) -> float:
    return finite_number(value, f"{owner}: {name}")


def _clamp(value, lo, hi):
    """lo <= value <= hi, differentiated as the right-hand limit at the corners.

    Time events restart the integrator exactly at a corner, and from there on
    the right-hand slope is the one that holds (fmin/fmax would give the mean).
    """
    return ca.if_else(value < lo, lo, ca.if_else(value >= hi, hi, value))


class Signal:
    """Base class: `expr(time)` gives the value, `events()` the times of jumps and kinks.

    `smoothness` is how many times the signal may be differentiated with a
    bounded result (a step: 0, a ramp or table: 1, a sine: unlimited); index
    reduction refuses to differentiate a prescribed motion more often.
    """

    smoothness = float("inf")

    def expr(self, time: ca.SX) -> ca.SX:
        raise NotImplementedError

    def events(self) -> tuple:
        return ()

    def __call__(self, t):
        """Numeric value at time(s) t (for plots and tests)."""
        s = ca.SX.sym("t")
        f = ca.Function("signal", [s], [self.expr(s)])
        return np.array([float(f(v)) for v in np.atleast_1d(t)]).reshape(np.shape(t))


class Constant(Signal):
    """y = k."""

    def __init__(self, k: float):
        self.k = _number("Constant", "k", k)

    def expr(self, time):
        return ca.SX(self.k)

    def __repr__(self):
        return f"Constant({self.k:g})"


class Step(Signal):
    """y = offset before start_time, offset + height from start_time on."""

    smoothness = 0

    def __init__(self, height: float = 1.0, *, offset: float = 0.0, start_time: float = 0.0):
        self.height = _number("Step", "height", height)
        self.offset = _number("Step", "offset", offset)
        self.start_time = _number("Step", "start_time", start_time)

    def expr(self, time):
        return self.offset + ca.if_else(time >= self.start_time, self.height, 0.0)

    def events(self):
        return (self.start_time,)

    def __repr__(self):
        return f"Step(height={self.height:g}, start_time={self.start_time:g})"


class Ramp(Signal):
    """Rises linearly by `height` over `duration` from start_time, then holds."""

    smoothness = 1

    def __init__(self, height: float = 1.0, duration: float = 1.0, *, offset: float = 0.0,
                 start_time: float = 0.0):
        self.height = _number("Ramp", "height", height)
        self.duration = _number("Ramp", "duration", duration)
        if self.duration <= 0:
            raise ParameterError(f"Ramp: duration = {self.duration:g} must be > 0")
        self.offset = _number("Ramp", "offset", offset)
        self.start_time = _number("Ramp", "start_time", start_time)

    def expr(self, time):
        """Time is compared with the corners themselves, not time − start_time with the duration:
        0.7 − 0.2 < 0.5 in floating point, so a restart at the upper corner took the rising slope."""
        start, end = self.start_time, self.start_time + self.duration
        rising = self.offset + self.height * (time - start) / self.duration
        return ca.if_else(time < start, self.offset, ca.if_else(time >= end, self.offset + self.height, rising))

    def events(self):
        return (self.start_time, self.start_time + self.duration)

    def __repr__(self):
        return f"Ramp(height={self.height:g}, duration={self.duration:g}, start_time={self.start_time:g})"


class Sine(Signal):
    """y = offset + amplitude·sin(2π·f·(t − start_time) + phase) from start_time on (offset before)."""

    @property
    def smoothness(self):
        return float("inf") if self.start_time <= 0.0 else 0

    def __init__(self, amplitude: float = 1.0, f: float = 1.0, *, phase: float = 0.0, offset: float = 0.0,
                 start_time: float = 0.0):
        self.amplitude = _number("Sine", "amplitude", amplitude)
        self.f = _number("Sine", "f", f)
        self.phase = _number("Sine", "phase", phase)
        self.offset = _number("Sine", "offset", offset)
        self.start_time = _number("Sine", "start_time", start_time)

    def expr(self, time):
        wave = self.amplitude * ca.sin(2 * math.pi * self.f * (time - self.start_time) + self.phase)
        if self.start_time <= 0.0:
            return self.offset + wave
        return self.offset + ca.if_else(time >= self.start_time, wave, 0.0)

    def events(self):
        return (self.start_time,) if self.start_time > 0.0 else ()

    def __repr__(self):
        return f"Sine(amplitude={self.amplitude:g}, f={self.f:g} Hz)"


MODES = ("linear", "hold")


def table_knots(times, values, mode: str = "linear"):
    """Knots (t, left, right): strictly increasing times, the value just before each and the value from it on.

    Modelica's table modes: "linear" interpolates, and two equal consecutive
    times make a jump (left value, then right value); "hold" keeps value k on
    [t_k, t_k+1) (a zero-order hold: replayed optimal controls). Raises ValueError
    naming the index; the caller says whose table it is.
    """
    if mode not in MODES:
        raise ValueError(f"mode = {mode!r} is not one of {', '.join(map(repr, MODES))}")
    t = np.asarray(times, dtype=float).ravel()
    y = np.asarray(values, dtype=float).ravel()
    step = np.diff(t)
    for k in range(step.size):
        if step[k] < 0 or (step[k] == 0 and mode == "hold"):
            rule = "strictly increasing" + (" except at a jump (two equal times)" if mode == "linear" else "")
            raise ValueError(f"times must be {rule}, but time[{k}] = {t[k]:g} and time[{k + 1}] = {t[k + 1]:g}")
        if k + 1 < step.size and step[k] == 0 == step[k + 1]:
            raise ValueError(f"time[{k}] = time[{k + 1}] = time[{k + 2}] = {t[k]:g}: a jump takes exactly two "
                             f"equal times (the value before it and the value from it on)")
    if mode == "hold":
        return t, np.concatenate([y[:1], y[:-1]]), y
    first = np.concatenate([[True], step > 0])         # a knot's first time: its left value
    last = np.concatenate([step > 0, [True]])          # its last time: its right value
    return t[first], y[first], y[last]


def _sequence(given, what: str) -> np.ndarray:
    """A table's times or values as one sequence: a list, a row or a column. A matrix is refused, not
    flattened ([[1, 2], [3, 4]] became four values, issue 32)."""
    try:
        arr = np.asarray(given, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"Table: {what} must be a sequence of numbers, got {given!r:.60}") from None
    if arr.ndim > 2 or (arr.ndim == 2 and min(arr.shape) > 1):
        raise ParameterError(f"Table: {what} must be one sequence (a list, a row or a column), got an array of "
                             f"shape {arr.shape}; a table is one signal")
    return arr.ravel()


class Table(Signal):
    """A table of (time, value) knots in one of Modelica's modes; held constant outside it.

    `mode="linear"` interpolates linearly, and a time given twice is a jump
    (the first value before it, the second from it on); `mode="hold"` keeps
    each value until the next time (a zero-order hold, e.g. an optimal
    control's). Written as a sum of slope changes and steps, so the expression
    stays symbolic, differentiable between knots and right-continuous at them;
    every knot is a time event.

    >>> float(Table([0.0, 1.0, 2.0], [1.0, -1.0, 0.5], mode="hold")(1.5))
    -1.0
    """

    def __init__(self, times, values, mode: str = "linear"):
        for what, given in (("times", times), ("values", values)):
            entries = np.ravel(np.array(given, dtype=object))
            if not_a_number(given) or any(not_a_number(v) or v is None for v in entries):
                raise ParameterError(f"Table: {what} must be numbers, got {given!r:.60}")
        t, y = (_sequence(given, what) for what, given in (("times", times), ("values", values)))
        if t.size < 2 or t.size != y.size:
            raise ParameterError(f"Table: needs at least two knots and as many values as times "
                                 f"(got {t.size} times, {y.size} values)")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
            raise ParameterError("Table: times and values must be finite")
        try:
            self.knots = table_knots(t, y, mode)
        except ValueError as exc:
            raise ParameterError(f"Table: {exc}") from None
        self.times, self.values, self.mode = t, y, mode

    @property
    def smoothness(self):
        """0 where the table jumps (a step of torque cannot prescribe a motion), else 1 (kinks)."""
        _, left, right = self.knots
        return 0 if np.any(left != right) else 1

    def expr(self, time):
        t, left, right = self.knots
        clamped = _clamp(time, t[0], t[-1])
        slopes = (left[1:] - right[:-1]) / np.diff(t)
        changes = np.diff(np.concatenate([[0.0], slopes]))
        out = ca.SX(left[0])
        for tk, jump in zip(t, right - left):
            if jump != 0.0:
                out = out + ca.if_else(time >= tk, jump, 0.0)
        for tk, dk in zip(t[:-1], changes):
            if dk != 0.0:
                out = out + dk * ca.if_else(clamped >= tk, clamped - tk, 0.0)
        return out

    def events(self):
        return tuple(float(v) for v in self.knots[0])

    def __repr__(self):
        hold = ", hold" if self.mode == "hold" else ""
        return f"Table({self.times.size} knots{hold}, t = {self.times[0]:g}..{self.times[-1]:g} s)"
