"""External inputs: constants, arrays and Python callables, sampled into CasADi interpolants.

A callable is never called inside the integrator: it is sampled once on a
fine grid over the run, checked (shape, finiteness — naming the input and the
time of a bad value), and handed to the integrator as a linear interpolant.
"""
from __future__ import annotations

import numbers
from collections.abc import Mapping
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..core.declarations import finite_number, not_a_number
from ..core.errors import InputError
from .result import unknown_name


@dataclass(frozen=True)
class InputPlan:
    constant: np.ndarray            # value of every input (time-varying ones: their value at t_start)
    varying: dict                   # input index -> (times, values) arrays

    def key(self) -> tuple:
        """What an integrator built for this plan depends on: which inputs vary and their tables' times.
        The values are integrator parameters (`table_data`), so a new table on the same times (a sweep,
        an optimiser's checks, any callable over the same run) reuses the integrator. Times stay
        constants: as parameters they doubled the cost of every right-hand side (a 2001-knot lookup),
        values cost 15 % (benchmarks in the issue note)."""
        return tuple((k, t.tobytes()) for k, (t, v) in sorted(self.varying.items()))

    def table_data(self) -> np.ndarray:
        """Every varying input's values, in input order: the tail of the integrator's parameter vector."""
        return np.concatenate([self.varying[k][1] for k in sorted(self.varying)] or [np.zeros(0)])

    def at(self, ts) -> np.ndarray:
        """Every input at each of the times ts, one column per time (linear between samples)."""
        ts = np.asarray(ts, dtype=float).ravel()
        U = np.tile(self.constant.reshape(-1, 1), ts.size)
        for k, (times, values) in self.varying.items():
            U[k] = np.interp(ts, times, values)
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


def plan_inputs(dae, given: dict | None, t_start: float, t_end: float, n_samples: int) -> InputPlan:
    names = dae.u_names
    constant = np.array(dae.u_default, dtype=float)
    varying = {}
    for name, value in (given or {}).items():
        if name not in names:
            if name in dae.observed_names:
                raise InputError(f"{name!r} is a variable of the model, not an input; the inputs are "
                                 f"{', '.join(names) or 'none (add a Torque/Force input component)'}")
            raise unknown_name(name, names, "input")
        k = names.index(name)
        if callable(value):
            times = np.linspace(t_start, t_end, max(n_samples, 2))
            values = np.empty_like(times)
            for i, t in enumerate(times):
                out = _sample(name, value, float(t))
                if out.size != 1:
                    raise InputError(f"input {name!r}: the callable returned shape {out.shape} at t = {t:g} s; "
                                     f"it must return one number")
                if not np.isfinite(out.reshape(())):
                    raise InputError(f"input {name!r}: the callable returned {float(out.reshape(()))} at "
                                     f"t = {t:g} s; values must be finite")
                values[i] = float(out.reshape(()))
            varying[k] = (times, values)
        elif value is None or not_a_number(value) or isinstance(value, Mapping):
            raise InputError(f"input {name!r} = {value!r:.60}: give a number, a callable f(t), a (times, values) "
                             f"pair or an N×2 array")
        elif isinstance(value, numbers.Real) or (isinstance(value, np.ndarray) and value.ndim == 0):
            constant[k] = finite_number(value, f"input {name!r}", InputError)
        else:
            times, values = _table(name, value)
            # held constant outside the table, for the integrator as for the results (CasADi's
            # interpolant would extrapolate linearly)
            if times[0] > t_start:
                times, values = np.concatenate([[t_start], times]), np.concatenate([[values[0]], values])
            if times[-1] < t_end:
                times, values = np.concatenate([times, [t_end]]), np.concatenate([values, [values[-1]]])
            varying[k] = (times, values)
    for k, (times, values) in varying.items():
        constant[k] = float(np.interp(t_start, times, values))
    return InputPlan(constant, varying)


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
    try:
        return _table_arrays(name, value)
    except InputError:
        raise
    except (TypeError, ValueError):
        raise InputError(f"input {name!r}: a table must hold numbers: give (times, values) or an N×2 array "
                         f"of [time, value] rows") from None


def _table_arrays(name, value):
    if isinstance(value, tuple) and len(value) == 2:
        if any(not_a_number(v) for part in value for v in np.ravel(np.array(part, dtype=object))):
            raise TypeError
        times, values = (np.asarray(v, dtype=float).ravel() for v in value)
    else:
        if any(not_a_number(v) for v in np.ravel(np.array(value, dtype=object))):
            raise TypeError
        arr = np.asarray(value, dtype=float)
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
    bad = np.flatnonzero(np.diff(times) <= 0)
    if bad.size:
        k = int(bad[0])
        raise InputError(f"input {name!r}: times must be strictly increasing (time[{k}] = {times[k]:g}, "
                         f"time[{k + 1}] = {times[k + 1]:g})")
    nonfinite = np.flatnonzero(~np.isfinite(values))
    if nonfinite.size or not np.all(np.isfinite(times)):
        k = int(nonfinite[0]) if nonfinite.size else 0
        raise InputError(f"input {name!r}: value {values[k]} at t = {times[k]:g} s is not finite")
    return times, values
