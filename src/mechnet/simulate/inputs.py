"""External inputs: constants, tables, signals and Python callables, handed to the integrator as interpolants.

A callable is never called inside the integrator: it is sampled once on a
fine grid over the run, checked (shape, finiteness — naming the input and the
time of a bad value), and handed to the integrator as a linear interpolant.
Tables are exact: a (times, values) pair may jump (a time given twice), a
`Table` may also hold each value (mode="hold"), and their jumps (a Table's
every knot) are time events of the run, so the integrator never steps across one.
"""
from __future__ import annotations

import numbers
from collections.abc import Mapping
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..components.signals import Signal, Table, table_knots
from ..core.declarations import finite_number, not_a_number, number_array
from ..core.errors import InputError
from .result import unknown_name


@dataclass(frozen=True)
class InputPlan:
    constant: np.ndarray            # value of every input (time-varying ones: their value at t_start)
    varying: dict                   # input index -> knots (times, left, right values): `signals.table_knots`
    time_events: tuple = ()         # (time, cause): where an input table jumps (a Table: every knot)

    def key(self) -> tuple:
        """What an integrator built for this plan depends on: which inputs vary and their tables' times.
        The values are integrator parameters (`table_data`), so a new table on the same times (a sweep,
        an optimiser's checks, any callable over the same run) reuses the integrator. Times stay
        constants: as parameters they doubled the cost of every right-hand side (a 2001-knot lookup),
        values cost 15 % (benchmarks in the issue note)."""
        return tuple((k, knots[0].tobytes()) for k, knots in sorted(self.varying.items()))

    def table_data(self, t0: float = -np.inf) -> np.ndarray:
        """Every varying input's knot values for an integrator call starting at t0, in input order: the tail
        of the integrator's parameter vector. Knots at or before t0 give their right value, later ones
        their left value. No call crosses a jump (each is a time event), so the linear interpolant
        between the two is exact within a call, and a zero-order hold is a table of jumps."""
        return np.concatenate([np.where(t <= t0, right, left) for t, left, right in
                               (self.varying[k] for k in sorted(self.varying))] or [np.zeros(0)])

    def at(self, ts) -> np.ndarray:
        """Every input at each of the times ts, one column per time (right-continuous at jumps, as the
        integrator takes them after a restart)."""
        ts = np.asarray(ts, dtype=float).ravel()
        U = np.tile(self.constant.reshape(-1, 1), ts.size)
        for k, knots in self.varying.items():
            U[k] = _right_continuous(ts, *knots)
        return U

    def interpolated(self, t, tables) -> dict:
        """input index -> its value at the symbolic time t, read from the symbolic `tables` laid out as
        `table_data`: linear interpolants on the tables' times whose values are arguments."""
        out, at = {}, 0
        for k in sorted(self.varying):
            times = self.varying[k][0]
            lookup = ca.interpolant(f"input_{k}", "linear", [times], 1)
            out[k] = lookup(t, tables[at: at + times.size])
            at += times.size
        return out


def _right_continuous(ts, times, left, right) -> np.ndarray:
    """Linear from each knot's right value to the next knot's left value; left[0] before, right[-1] after."""
    i = np.clip(np.searchsorted(times, ts, side="right") - 1, 0, times.size - 2)
    share = (ts - times[i]) / (times[i + 1] - times[i])
    out = right[i] + share * (left[i + 1] - right[i])
    return np.where(ts < times[0], left[0], np.where(ts >= times[-1], right[-1], out))


def plan_inputs(dae, given: dict | None, t_start: float, t_end: float, n_samples: int) -> InputPlan:
    names = dae.u_names
    constant = np.array(dae.u_default, dtype=float)
    varying, events = {}, []
    for name, value in (given or {}).items():
        if name not in names:
            if name in dae.observed_names:
                raise InputError(f"{name!r} is a variable of the model, not an input; the inputs are "
                                 f"{', '.join(names) or 'none (add a Torque/Force input component)'}")
            raise unknown_name(name, names, "input")
        k, cause = names.index(name), f"input {name} knot"
        if isinstance(value, Table):
            knots, at = value.knots, value.events()
        elif isinstance(value, Signal):
            knots, at = _signal_knots(value, t_start, t_end, n_samples)
            cause = f"input {name}: {value!r}"
        elif callable(value):
            times = np.linspace(t_start, t_end, max(n_samples, 2))
            values = np.array([_sample_number(name, value, float(t)) for t in times])
            knots, at = (times, values, values), ()
        elif value is None or not_a_number(value) or isinstance(value, Mapping):
            raise InputError(f"input {name!r} = {value!r:.60}: give a number, a callable f(t), a (times, values) "
                             f"pair, an N×2 array or a Table")
        elif isinstance(value, numbers.Real) or (isinstance(value, np.ndarray) and value.ndim == 0):
            constant[k] = finite_number(value, f"input {name!r}", InputError)
            continue
        else:
            # jumps only: restarting at every sample of measured data would cost a solver ramp-up each,
            # and a kink is within the step control's reach
            knots = _table(name, value)
            at = knots[0][knots[1] != knots[2]]
        varying[k] = _held(*knots, t_start, t_end)
        events += [(float(t), cause) for t in at]
    for k, knots in varying.items():
        constant[k] = float(_right_continuous(np.array([t_start]), *knots)[0])
    return InputPlan(constant, varying, tuple(events))


def _held(times, left, right, t_start, t_end):
    """Knots reaching over [t_start, t_end], held constant outside the table for the integrator as for the
    results (CasADi's interpolant would extrapolate linearly)."""
    if times[0] > t_start:
        times, left, right = np.r_[t_start, times], np.r_[left[0], left], np.r_[left[0], right]
    if times[-1] < t_end:
        times, left, right = np.r_[times, t_end], np.r_[left, right[-1]], np.r_[right, right[-1]]
    return times, left, right


def _signal_knots(signal, t_start, t_end, n_samples):
    """A Signal other than a Table (Step, Ramp, Sine): sampled like a callable, with a knot at each of its
    events (value just before, value from it on), so its steps and corners are exact and are time events."""
    inside = np.array([t for t in signal.events() if t_start < t < t_end])
    times = np.union1d(np.linspace(t_start, t_end, max(n_samples, 2)), inside)
    right = signal(times)
    left = right.copy()
    if inside.size:
        left[np.searchsorted(times, inside)] = signal(np.nextafter(inside, -np.inf))
    return (times, left, right), inside


def _sample_number(name, f, t) -> float:
    out = _sample(name, f, t)
    if out.size != 1:
        raise InputError(f"input {name!r}: the callable returned shape {out.shape} at t = {t:g} s; "
                         f"it must return one number")
    if not np.isfinite(out.reshape(())):
        raise InputError(f"input {name!r}: the callable returned {float(out.reshape(()))} at "
                         f"t = {t:g} s; values must be finite")
    return float(out.reshape(()))


def _sample(name, f, t) -> np.ndarray:
    """f(t) as an array; a callable that fails or takes no time argument is named with the time."""
    try:
        out = f(t)
    except Exception as exc:                        # noqa: BLE001 - any user error, named and chained
        raise InputError(f"input {name!r}: the callable raised {type(exc).__name__} at t = {t:g} s: {exc} "
                         f"(it is called as f(t) with the time in seconds)") from exc
    if out is None or not_a_number(out):
        raise InputError(f"input {name!r}: the callable returned {out!r:.40} at t = {t:g} s; it must return "
                         f"one number")
    try:
        return np.asarray(out, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"input {name!r}: the callable returned {out!r:.40} at t = {t:g} s; it must return "
                         f"one number") from None


def _table(name, value):
    """A (times, values) pair or N×2 array as knots (`signals.table_knots`: a time given twice is a jump)."""
    try:
        return _table_arrays(name, value)
    except InputError:
        raise
    except (TypeError, ValueError):
        raise InputError(f"input {name!r}: a table must hold numbers: give (times, values) or an N×2 array "
                         f"of [time, value] rows") from None


def _table_arrays(name, value):
    if isinstance(value, tuple) and len(value) == 2:
        times, values = (number_array(v).ravel() for v in value)
    else:
        arr = number_array(value)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise InputError(f"input {name!r}: give a number, a callable f(t), a (times, values) pair or an "
                             f"N×2 array of [time, value] rows (got shape {arr.shape})")
        times, values = arr[:, 0], arr[:, 1]
    if times.size < 2 or times.size != values.size:
        raise InputError(f"input {name!r}: needs at least two samples and as many values as times "
                         f"(got {times.size} times, {values.size} values)")
    nonfinite = np.flatnonzero(~np.isfinite(times))
    if nonfinite.size:
        k = int(nonfinite[0])
        raise InputError(f"input {name!r}: time[{k}] = {times[k]} is not finite")
    try:
        knots = table_knots(times, values)
    except ValueError as exc:
        raise InputError(f"input {name!r}: {exc}") from None
    nonfinite = np.flatnonzero(~np.isfinite(values))
    if nonfinite.size:
        k = int(nonfinite[0])
        raise InputError(f"input {name!r}: value {values[k]} at t = {times[k]:g} s is not finite")
    return knots
