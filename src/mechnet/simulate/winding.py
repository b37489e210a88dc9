"""Whole turns: the coordinates the equations see only through sine and cosine, and how far one
integrator call may wind them.

Why: a double holds an angle of 6000 rad (1000 turns) to 1e-12 rad only, and the forces computed from
it to ~1e-9 N (slider-crank at 3000 rpm); at a dead centre, where a pin force is only the weight, that
noise exceeds the error test of rtol = 1e-10 and IDAS fails. The simulator integrates such coordinates
without their whole turns (`turns_of`), which the equations cannot tell apart, adds them back to the
outputs, and ends each call before a coordinate winds more than TURN_LIMIT (`winding_reach`).

Which coordinates qualify is decided on the structure of `ode` and `alg`, once per compiled selection
(`whole_turns`), not on sampled values: a sample misses an end stop `c·fmax(φ − 10, 0)` near [−π, π]
and a spring whose stiffness is a tunable parameter set to 0 on the first run. A forward pass over
the SX algorithm tags every work value, for every candidate coordinate v at once (one numpy row per
value, a column per candidate):

- *clean*: independent of v;
- *angle*: clean + k·v, k ≠ 0, formed by +, −, negation and products with constants;
- *periodic*: depends on v only through sin, cos or tan of angles with integer k (anything may follow);
- *bad*: any other dependence.

v repeats after a whole turn iff no output is an angle or bad in its column. Only coordinates in "rad"
are candidates (a translational position never is); time, inputs and parameters are clean, so a
prescribed angle φ − w·t reaches the output as an angle and is not periodic, while sin(φ − w·t) is.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..caches import built

TURN = 2 * np.pi
TURN_LIMIT = 256.0    # rad: how far a periodic coordinate may wind within one integrator call
WINDING_POINTS = 8    # points at most that far apart within such a call (`Run._segment`, pieces.py)

CLEAN, PERIODIC, ANGLE, BAD = 0, 1, 2, 3
_TRIG = (ca.OP_SIN, ca.OP_COS, ca.OP_TAN)
_LINEAR = (ca.OP_ADD, ca.OP_SUB)


def whole_turns(dae) -> tuple[np.ndarray, np.ndarray]:
    """2π for each state and algebraic variable in which `ode` and `alg` repeat after a whole turn, else
    0 (`periodic_inputs`); cached on the DAE (one per compiled selection), built under the build lock."""
    return built(dae.info, "_whole_turns", lambda: _whole_turns(dae))


def _whole_turns(dae) -> tuple[np.ndarray, np.ndarray]:
    nx = len(dae.x_names)
    names = list(dae.x_names) + list(dae.z_names)
    candidates = [k for k, n in enumerate(names) if dae.units.get(n) == "rad"]
    slots = [(1, k) if k < nx else (2, k - nx) for k in candidates]      # (input: x or z, element)
    functions = [dae.ode] + ([dae.alg] if len(dae.z_names) else [])
    ok = periodic_inputs(functions, slots)
    period = np.zeros(len(names))
    period[np.array(candidates, dtype=int)] = np.where(ok, TURN, 0.0)
    return period[:nx], period[nx:]


def winding_reach(dae, t, x, z, u_at, p, d) -> float:
    """How long (s) an integrator call from (t, x, z) may last: until a periodic state winds TURN_LIMIT
    at its present rate (inf when none winds). Within a call the angle grows again from its
    turn-reduced start, and with it the round-off in everything computed from it. `u_at(t)`: the
    inputs at t."""
    px, _ = whole_turns(dae)
    if not px.any():
        return float("inf")
    rate = np.asarray(dae.ode(t, x, z, u_at(t), p, d), dtype=float).ravel()
    wind = float(np.max(np.abs(rate[px > 0])))
    return TURN_LIMIT / wind if np.isfinite(wind) and wind > 0 else float("inf")


def turns_of(values, period) -> np.ndarray:
    """The whole turns in `values` (0 where the period is 0): what the integrator leaves out."""
    values = np.asarray(values, dtype=float)
    if not period.any():                 # (most scenes: no periodic coordinate, and a call per integration)
        return np.zeros_like(values)
    return np.where(period > 0, np.round(values / np.where(period > 0, period, 1.0)), 0.0) * period


def periodic_inputs(functions, slots) -> np.ndarray:
    """For each (input index, element) in `slots`: True when every output of every function (SX, same
    inputs) is unchanged by adding 2π to that input element alone (see the module docstring)."""
    ok = np.ones(len(slots), dtype=bool)
    for f in functions:
        if not slots:
            break
        ok &= _periodic_in(f, slots)
    return ok


def _periodic_in(f, slots) -> np.ndarray:
    """One pass over f's algorithm; False for every slot when f is not an SX function or holds a call."""
    n = len(slots)
    if not f.is_a("SXFunction"):
        return np.zeros(n, dtype=bool)
    column = {slot: c for c, slot in enumerate(slots)}
    kind: list = [None] * f.sz_w()       # per work value: None (clean for every candidate) or int8 row
    coef: list = [None] * f.sz_w()       # its k·v coefficients where kind is ANGLE (None: no angle)
    const: list = [None] * f.sz_w()      # its value when it is a constant
    ok = np.ones(n, dtype=bool)
    for i in range(f.n_instructions()):
        op = f.instruction_id(i)
        if op == ca.OP_CONST:
            o = f.instruction_output(i)[0]
            kind[o], coef[o], const[o] = None, None, f.instruction_constant(i)
            continue
        if op == ca.OP_INPUT:
            o = f.instruction_output(i)[0]
            c = column.get(tuple(f.instruction_input(i)))
            kind[o] = coef[o] = const[o] = None
            if c is not None:
                kind[o], coef[o] = np.zeros(n, dtype=np.int8), np.zeros(n)
                kind[o][c], coef[o][c] = ANGLE, 1.0
            continue
        if op == ca.OP_OUTPUT:
            w = f.instruction_input(i)[0]
            if kind[w] is not None:
                ok &= ~((kind[w] == ANGLE) | (kind[w] == BAD))
            continue
        if op == ca.OP_PARAMETER:
            o = f.instruction_output(i)[0]
            kind[o] = coef[o] = const[o] = None
            continue
        if op == ca.OP_CALL:
            return np.zeros(n, dtype=bool)       # an embedded call: not looked into
        args = f.instruction_input(i)
        o = f.instruction_output(i)[0]
        kinds = [kind[a] for a in args]
        consts = [const[a] for a in args]
        coefs = [coef[a] for a in args]
        const[o] = None
        if all(k is None for k in kinds):
            kind[o] = coef[o] = None              # clean in, clean out
            continue
        if op == ca.OP_ASSIGN:
            kind[o], coef[o], const[o] = kinds[0], coefs[0], consts[0]
        elif op in _LINEAR:
            kind[o], coef[o] = _add(kinds[0], coefs[0], kinds[1], coefs[1], -1.0 if op == ca.OP_SUB else 1.0)
        elif op == ca.OP_NEG:
            kind[o], coef[o] = _scaled(kinds[0], coefs[0], -1.0)
        elif op == ca.OP_TWICE:
            kind[o], coef[o] = _scaled(kinds[0], coefs[0], 2.0)
        elif op == ca.OP_MUL and (consts[0] is not None or consts[1] is not None):
            j = 1 if consts[0] is not None else 0             # the tagged factor; the other is a constant
            kind[o], coef[o] = _scaled(kinds[j], coefs[j], consts[1 - j])
        elif op == ca.OP_DIV and consts[1] is not None and consts[1] != 0:
            kind[o], coef[o] = _scaled(kinds[0], coefs[0], 1.0 / consts[1])
        elif op in _TRIG:
            k, a = kinds[0], coefs[0]
            if a is None:
                kind[o] = k
            else:
                whole = np.abs(a - np.round(a)) <= 4 * np.finfo(float).eps * np.abs(a)
                kind[o] = np.where(k == ANGLE, np.where(whole, PERIODIC, BAD), k).astype(np.int8)
            coef[o] = None
        else:
            # any other operation: periodic stays periodic, an angle or worse turns bad
            worst = None
            for k, a in zip(kinds, coefs):
                if k is not None:
                    k = k if a is None else np.where(k == ANGLE, BAD, k).astype(np.int8)
                    worst = k if worst is None else np.maximum(worst, k)
            kind[o], coef[o] = worst, None
        if kind[o] is not None and not kind[o].any():
            kind[o] = coef[o] = None
    return ok


def _add(ka, ca_, kb, cb, sign):
    """Tags of a ± b: angles add (cancelling to clean), an angle next to a periodic value is bad."""
    if kb is None:
        return ka, ca_
    if ka is None:
        return _scaled(kb, cb, sign)
    if ca_ is None and cb is None:                 # no angle on either side: the worse tag wins
        return np.maximum(ka, kb), None
    ca_ = np.zeros(ka.size) if ca_ is None else ca_
    cb = np.zeros(kb.size) if cb is None else cb
    angle = (ka == ANGLE) | (kb == ANGLE)
    periodic = (ka == PERIODIC) | (kb == PERIODIC)
    bad = (ka == BAD) | (kb == BAD) | (angle & periodic)
    a = np.where(angle, np.where(ka == ANGLE, ca_, 0.0) + sign * np.where(kb == ANGLE, cb, 0.0), 0.0)
    kind = np.where(bad, BAD, np.where(periodic, PERIODIC, np.where(angle & (a != 0), ANGLE, CLEAN)))
    return kind.astype(np.int8), (np.where(kind == ANGLE, a, 0.0) if (kind == ANGLE).any() else None)


def _scaled(k, a, factor):
    """Tags of a tagged value times a constant: an angle's coefficient scales (by 0: clean)."""
    if k is None or factor == 0:
        return None, None
    return k, (None if a is None else a * factor)
