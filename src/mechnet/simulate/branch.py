"""Whole-branch check of the state selection: a one-DOF loop that never needs the monitor.

Why: the selection monitor (`reselection.py`) checks the running selection
after every integrator piece and restarts IDAS at each cut; on a four-bar that
was a third of the run. When the constraints are holonomic and do not depend
on time, every quality the monitor compares is a function of the coordinates
alone, and a one-DOF mechanism's coordinates stay on one closed curve, its
assembly branch, whatever the forces and speeds. Tracing that curve once
(pseudo-arclength continuation: tangent predictor, Newton corrector) shows
whether some selection stays regular all round (|quality| ≥ FLOOR, one sign)
and never loses to another by the hysteresis factor (with MARGIN for the
spacing of the points), and whether the constraints keep their rank (no
branch crossing). Such a selection — the running one when it qualifies — is
one the monitor would never leave: the run switches to it at the start and
integrates in one piece, as a hand-written model would.

Anything else (several degrees of freedom, time in the constraints, Jacobians
that depend on speeds, a curve that does not land on its start, a state event
that sets a coordinate) is not certified, and the monitor runs as before.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..numeric import NumpyCall, dense

FLOOR = 1e-2          # the running selection's |quality| all round the branch (1 ideal, 0 singular)
MARGIN = 1.02         # on the hysteresis factor, plus the ratio's largest change between two points
STEP = 0.1            # largest continuation step (coordinates over their nominal values: radians)
MIN_STEP = 1e-5
TURN = 0.1            # largest turn of the tangent in one step (rad): the curve is resolved between points
RANK_FLOOR = 1e-3     # |regularity| of the constraints all round the branch (`_continuation_step`)
MAX_POINTS = 4000     # points on the curve before giving up
MAX_SELECTIONS = 64   # selections compared at each point, at most
CHUNK = 32            # points per mapped quality evaluation (one map reused)
WATCH = 16            # points traced between two checks of the running selection
MAX_VERDICTS = 256    # verdicts cached per selection factory (start points, parameters)


@dataclass(frozen=True)
class Verdict:
    """What the whole-branch check found; `holds`: the monitor can stay off."""

    holds: bool
    reason: str
    points: int = 0
    worst_quality: float = float("nan")     # min |quality| of the running selection on the branch
    worst_ratio: float = float("nan")       # min |running quality| / best other quality
    at: tuple = ()                          # where it failed on the branch (the coordinates, `coordinates`)
    coordinates: tuple = ()                 # names of the loop's coordinates
    dummies: frozenset | None = None        # the selection that holds (the running one if it does)
    states: tuple = ()                      # its states

    def describe(self) -> str:
        if not self.holds:
            where = ", ".join(f"{n} = {v:.4g}" for n, v in zip(self.coordinates, self.at))
            return f"monitor on: {self.reason}" + (f" at {where}" if where else "")
        states = f"states {', '.join(self.states)}" if self.states else "the selection (no states: motion prescribed)"
        return (f"monitor off: {states} hold{'s' if not self.states else ''} on the whole branch ({self.points} points, "
                f"quality >= {self.worst_quality:.2g}, >= {self.worst_ratio:.2g} x any other selection)")


class BranchCheck:
    """The loop's position constraints and the selection Jacobians as functions of its coordinates
    (built once per selection factory), and the curve traced from a start point."""

    def __init__(self, factory):
        self.factory = factory
        self._period_cache = None
        self.reason = self._analyse()

    # ------------------------------------------------------------------ structure (once)
    def _analyse(self) -> str | None:
        f = self.factory
        graph = f.graph
        top, top_candidates = f._top_level()
        levels, h, cand = [], list(top), list(top_candidates)
        while h:                       # every selection's levels lie within these rows and columns
            levels.append((tuple(h), tuple(cand)))
            h = [graph.parent[e] for e in h if graph.parent[e] in graph.parent]
            cand = [graph.antider[v] for v in cand if graph.antider[v] in graph.antider]
        roots = set()
        for rows, _ in levels:
            for e in rows:
                while e in graph.parent:
                    e = graph.parent[e]
                roots.add(e)
        roots = sorted(roots)
        index = {s.element_hash(): k for k, s in enumerate(f.symbols)}
        params = f._args[2]
        param_hashes = {s.element_hash() for s in ca.symvar(params)} if params.numel() else set()
        residuals = ca.vertcat(*f.flat.expand([f.equations[e].residual for e in roots]))
        if ca.depends_on(residuals, f.flat.time):
            return "the constraints depend on time"
        coords = set()
        for s in ca.symvar(residuals):
            h_ = s.element_hash()
            if h_ in param_hashes:
                continue
            k = index.get(h_)
            moves = k is not None and (k in graph.der or k in graph.known_rate)   # known rate: a Speed drive
            if not moves or k in graph.antider or f.variables[k].kind == "input":
                return f"the constraints hold {s.name()}, which is not a position coordinate with a rate " \
                       f"(an input, a speed, or a position given as a function of time)"
            coords.add(index[h_])
        coords = sorted(coords)
        if len(coords) - len(roots) != 1:
            return f"{len(coords) - len(roots)} degrees of freedom in the constraints (checked: one)"
        q = ca.vertcat(*[f.symbols[v] for v in coords])
        blocks = []
        for rows, cols in levels:
            exprs = f.flat.expand([f.equations[e].residual for e in rows])
            jac = ca.jacobian(ca.vertcat(*exprs), ca.vertcat(*[f.symbols[v] for v in cols]))
            if ca.depends_on(jac, f.flat.time):
                return "a selection Jacobian depends on time"
            for s in ca.symvar(jac):
                if s.element_hash() not in param_hashes and index.get(s.element_hash()) not in coords:
                    return f"a selection Jacobian depends on {s.name()}, not only on the coordinates"
            blocks.append(ca.vec(jac))
        phi_q = ca.jacobian(residuals, q)
        shape = ca.vertcat(ca.vec(phi_q), *blocks)
        self.coords, self.n_roots = coords, len(roots)
        closure = ca.Function("branch_residual", [q, params], [residuals, phi_q])
        self.residual = NumpyCall(dense(closure))
        self.shape = NumpyCall(dense(ca.Function("branch_shape", [q, params], [shape])))
        # the coordinates the curve's shape depends on: the rest enter linearly with constant coefficients
        self.shaping = np.array([ca.depends_on(shape, f.symbols[v]) for v in coords])
        self.driven = np.array([v in graph.known_rate for v in coords])     # turned at a prescribed rate
        self.nominal = np.array([abs(f.variables[v].nominal) or 1.0 for v in coords])
        self.step = NumpyCall(dense(_continuation_step(closure, self.nominal, params)))
        return None

    def _periods(self, p) -> np.ndarray:
        """2π for a coordinate the constraint and selection Jacobians are periodic in (an angle), else 0.
        The curve is the integral curve of the null space of Φ_q, so Jacobians that repeat make it
        repeat (a gear's constraint, linear in a crank angle, does not spoil the crank's period)."""
        rng = np.random.default_rng(7)
        period = np.full(len(self.coords), 2 * np.pi)
        for _ in range(2):
            y = rng.uniform(-np.pi, np.pi, len(self.coords)) * self.nominal
            base = self.shape(y, p)[0].ravel()
            for k in range(len(self.coords)):
                shifted = y.copy()
                shifted[k] += 2 * np.pi
                if not np.allclose(self.shape(shifted, p)[0].ravel(), base, rtol=1e-9,
                                   atol=1e-9 * (1 + np.abs(base).max())):
                    period[k] = 0.0
        return period

    # ------------------------------------------------------------------ the curve (per start)
    def _wrap(self, p) -> np.ndarray:
        """Period of each shaping coordinate over its nominal value (0: not an angle), per parameters."""
        if self._period_cache is None or not np.array_equal(self._period_cache[0], p):
            self._period_cache = (p.copy(), (self._periods(p) / self.nominal)[self.shaping])
        return self._period_cache[1]

    def trace(self, q0, p, watch=None) -> tuple[np.ndarray | None, str, tuple]:
        """The points of the closed curve through q0 (rows), or None, why not and where. Every WATCH
        points the new stretch must keep the constraints regular, and pass `watch(points) -> reason`
        (None: it does)."""
        scale, shaping, wrap = self.nominal, self.shaping, self._wrap(p)
        y0 = np.asarray(q0, dtype=float) / scale
        r0, J0 = self.residual(y0 * scale, p)
        if np.abs(r0).max() > 1e-8 * (1 + np.abs(y0 * scale).max()):
            return None, "the start point does not close the constraints", tuple(q0)

        def passes_start(a, b) -> bool:
            """Whether the chord a -> b passes the start point (shaping coordinates, angles modulo 2π)
            within a quarter step: the curve has closed."""
            da = (a - y0)[shaping]
            da = da - _turns(da, wrap) * wrap
            chord = (b - a)[shaping]
            s_ = float(np.clip(-(da @ chord) / max(chord @ chord, 1e-300), 0.0, 1.0))
            return float(np.linalg.norm(da + s_ * chord)) < 0.25 * STEP

        t = np.linalg.svd(J0 * scale)[2][-1]
        points, augmented = [y0], [np.vstack([J0 * scale, t])]
        sign, heading, checked = None, None, 0
        y, h, travelled, closed = y0, STEP, 0.0, False
        while not closed:
            if len(points) >= MAX_POINTS:
                return None, f"the curve did not close within {MAX_POINTS} points", tuple(y * scale)
            # h is measured in the coordinates that shape the curve (a geared motor's angle does not)
            along = max(float(np.linalg.norm(t[shaping])), 1e-3)
            y_new, last, t_new, A = (a.ravel() if a.shape[1] == 1 else a for a in self.step(y, t, h / along, p))
            moved = float(np.linalg.norm((y_new - y)[shaping]))
            if not (last[0] < 1e-10 and moved < 1.5 * h and _turn(t, t_new, shaping) < TURN):
                h /= 2                  # Newton failed, left the curve, or the curve turns sharply here
                if h < MIN_STEP:
                    return None, "the continuation stalled", tuple(y * scale)
                continue
            travelled += moved
            if travelled > 2 * STEP and passes_start(y, y_new):
                # closed only if it lands on the start (angles shifted by whole turns) to Newton accuracy:
                # a phase that drifts by less than the step per turn would otherwise pass after one turn
                gap = self._gap_to_start(y, t, y0, wrap, p)
                if not gap < 1e-8:
                    return None, f"the branch does not close: one turn ends {gap:.1e} from its start " \
                                 f"(a drifting phase)", tuple(y_new * scale)
                closed = True
            y, t = y_new, t_new
            points.append(y)
            augmented.append(A)
            h = min(2 * h, STEP)
            if closed or len(points) - checked > WATCH:
                stretch = np.array(points[checked:]) * scale
                A = np.array(augmented[checked:])
                regular = np.linalg.det(A) / np.maximum(np.prod(np.linalg.norm(A[:, :-1], axis=2), axis=1), 1e-300)
                sign = np.sign(regular[0]) if sign is None else sign
                if np.any(np.sign(regular) != sign):
                    k = int(np.argmax(np.sign(regular) != sign))
                    return None, "the branch crosses another (a change point)", tuple(stretch[k])
                k = int(np.argmin(np.abs(regular)))
                if abs(regular[k]) < RANK_FLOOR:
                    return None, f"the constraints nearly lose rank ({abs(regular[k]):.1e})", tuple(stretch[k])
                tangents = A[:, -1, :]
                if self.driven.any():
                    # a coordinate turned at a constant rate must move one way all round: where its
                    # tangent component vanishes (a dead point for that drive) the motion cannot go on
                    along = tangents[:, self.driven]
                    heading = np.sign(along[0]) if heading is None else heading
                    stuck = np.any((np.sign(along) != heading) | (np.abs(along) < FLOOR * np.linalg.norm(
                        tangents[:, shaping], axis=1, keepdims=True)), axis=1)
                    if stuck.any():
                        k = int(np.argmax(stuck))
                        names = ", ".join(self.factory.names[v] for v, d in zip(self.coords, self.driven) if d)
                        return None, f"{names}, turned at a prescribed rate, would have to turn back on the " \
                                     f"branch (a dead point)", tuple(stretch[k])
                why = watch(stretch) if watch is not None else None
                if why:
                    return None, why[0], tuple(why[1])
                checked = len(points) - 1
        return np.array(points) * scale, "", ()


    def on_curve(self, q0, Q, p) -> bool:
        """Whether the start q0 lies on the closed curve traced as Q (rows): the nearest point's landing
        in the plane through q0 normal to the curve is q0 itself, to Newton accuracy."""
        scale, shaping, wrap = self.nominal, self.shaping, self._wrap(p)
        y0, Y = np.asarray(q0, dtype=float) / scale, Q / scale
        d = (Y - y0)[:, shaping]
        d = d - _turns(d, wrap) * wrap
        k = int(np.argmin(np.linalg.norm(d, axis=1)))
        if np.linalg.norm(d[k]) > STEP:
            return False
        _, J = self.residual(Y[k] * scale, p)
        tangent = np.linalg.svd(J * scale)[2][-1]
        return self._gap_to_start(Y[k], tangent, y0, wrap, p) < 1e-8

    def _gap_to_start(self, y, t, y0, wrap, p) -> float:
        """Distance (shaping coordinates, relative) between the start, shifted by the whole turns the
        curve has made, and the curve's point in the plane through it normal to the tangent (shaping
        part): 0 when the curve closes."""
        shaping = self.shaping
        target = y0.copy()
        target[shaping] += _turns((y - y0)[shaping], wrap) * wrap
        normal = np.zeros_like(t)
        normal[shaping] = t[shaping] / max(float(np.linalg.norm(t[shaping])), 1e-300)
        landed, last, _, _ = (a.ravel() for a in self.step(y, normal, float(normal @ (target - y)), p))
        if not last[0] < 1e-10:
            return float("inf")
        return float(np.linalg.norm((landed - target)[shaping]) / (1.0 + np.linalg.norm(target[shaping])))


def _turns(d, wrap) -> np.ndarray:
    """Whole periods in the differences d (0 where a coordinate has no period)."""
    return np.where(wrap > 0, np.round(d / np.where(wrap > 0, wrap, 1.0)), 0.0)


def _turn(t, t_new, shaping) -> float:
    """Angle between two tangents' parts in the coordinates that shape the curve (a geared motor's angle
    dominates the whole tangent and would hide the turn)."""
    a, b = t[shaping], t_new[shaping]
    cos = float(a @ b) / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-300)
    return float(np.arccos(np.clip(cos, -1.0, 1.0)))


def _continuation_step(closure, scale, params, newton=4) -> ca.Function:
    """One pseudo-arclength step in coordinates over their nominal values, y -> y + h·t corrected
    onto Φ = 0 in the plane normal to t (`newton` iterations, unrolled), as one CasADi function.
    Returns the point, its last Newton correction, the unit tangent there (oriented along t) and
    the augmented matrix [Φ_y; tᵀ]. Its determinant over the row norms of Φ_y is the signed
    regularity: ±1 for orthogonal rows, 0 where the constraints lose rank; at a branch point (two
    branches crossing: a parallelogram folding flat) it changes sign, the tangent does not."""
    n = scale.size
    y, t, h = ca.SX.sym("y", n), ca.SX.sym("t", n), ca.SX.sym("h")
    S = ca.diag(ca.DM(scale))

    def at(point):
        r, J = closure(S @ point, params)
        return r, J @ S

    predicted = y + h * t
    point, correction = predicted, ca.SX(0)
    for _ in range(newton):
        r, J = at(point)
        dy = -ca.solve(ca.vertcat(J, t.T), ca.vertcat(r, t.T @ (point - predicted)))
        point, correction = point + dy, ca.norm_inf(dy)
    r, J = at(point)
    tangent = ca.solve(ca.vertcat(J, t.T), ca.vertcat(ca.SX.zeros(r.numel()), 1))
    tangent = tangent / ca.norm_2(tangent)
    last = ca.fmax(correction, ca.norm_inf(r))
    return ca.Function("branch_step", [y, t, h, params], [point, last, tangent, ca.vertcat(J, tangent.T)])


def selections(factory) -> list:
    """Every valid dummy set (walking the levels like `choose`), at most MAX_SELECTIONS, or None."""
    graph = factory.graph
    found = []

    def walk(h, candidates, dummies):
        if len(found) > MAX_SELECTIONS:
            return
        if not h:
            found.append(frozenset(dummies))
            return
        cand = [v for v in candidates if any(v in graph.inc[e] for e in h)]
        below = [graph.parent[e] for e in h if graph.parent[e] in graph.parent]
        for chosen in itertools.combinations(cand, len(h)):
            walk(below, [graph.antider[v] for v in chosen if graph.antider[v] in graph.antider], dummies | set(chosen))

    walk(*factory._top_level(), set())
    return found if len(found) <= MAX_SELECTIONS else None


def _qualities(factory, dummies, Q, coords, p) -> np.ndarray:
    """Signed quality of one selection at the curve points (rows of Q)."""
    levels = factory.levels_for(dummies)
    out = np.empty(len(Q))
    for start in range(0, len(Q), CHUNK):
        part = Q[start: start + CHUNK]
        values = np.zeros((CHUNK, len(factory.names)))
        values[: len(part)][:, coords] = part
        values[len(part):, coords] = part[-1]            # padding: one map size for every chunk
        out[start: start + len(part)] = factory.quality_batch(levels, values, p)[: len(part)]
    return out


def check_branch(factory, preferred, values, p, hysteresis, reset=()) -> Verdict:
    """A selection that holds on the whole branch through the point `values` (all of
    `factory.names`) at parameters p — the monitor would never switch away from it nor see a change
    point — `preferred` if it does. `reset`: names of the states a state event can set (a coordinate
    among them could move the run to another branch). Cached on the factory per start point,
    parameters and preference (at most MAX_VERDICTS, the oldest dropped first)."""
    check = factory.__dict__.get("_branch_check")
    if check is None:
        check = factory.__dict__["_branch_check"] = BranchCheck(factory)
    if check.reason is not None:
        return Verdict(False, check.reason)
    jumped = [factory.names[v] for v in check.coords if factory.names[v] in set(reset)]
    if jumped:
        return Verdict(False, f"a state event resets {', '.join(jumped)}: the run may jump to another branch")
    p = np.asarray(p, dtype=float).ravel()
    q0 = np.asarray(values, dtype=float)[check.coords]
    key = (preferred, tuple(np.round(p, 12)), tuple(np.round(q0, 10)), hysteresis)
    cache = factory.__dict__.setdefault("_branch_verdicts", {})
    if key not in cache:
        if len(cache) >= MAX_VERDICTS:
            del cache[next(iter(cache))]
        # a start on a curve traced before (another start point of the same branch) shares its verdict
        by_key = factory.__dict__.setdefault("_branch_curves", {})
        if key[:2] + key[3:] not in by_key and len(by_key) >= MAX_VERDICTS:
            del by_key[next(iter(by_key))]
        curves = by_key.setdefault(key[:2] + key[3:], [])
        known = next((verdict for Q, verdict in curves if check.on_curve(q0, Q, p)), None)
        if known is None:
            known, Q = _verdict(factory, check, preferred, q0, p, hysteresis)
            if known.holds and len(curves) < MAX_VERDICTS:
                curves.append((Q, known))
        cache[key] = known
    return cache[key]


def _verdict(factory, check, preferred, q0, p, hysteresis) -> tuple[Verdict, np.ndarray | None]:
    """The verdict, and the traced curve when it closed."""
    names = tuple(factory.names[v] for v in check.coords)
    alternatives = selections(factory)
    if alternatives is None:
        return Verdict(False, f"more than {MAX_SELECTIONS} selections to compare"), None
    if preferred not in alternatives:
        alternatives.insert(0, preferred)
    viable = {d: 0.0 for d in alternatives}      # selections regular so far, with their sign
    failed = {}

    def watch(stretch):
        """Drop the selections that turn singular on this stretch; stop when none is left."""
        for d in list(viable):
            q = _qualities(factory, d, stretch, check.coords, p)
            sign = viable[d] or np.sign(q[0])
            bad = (np.sign(q) != sign) | (np.abs(q) < FLOOR)
            if np.any(bad):
                k = int(np.argmax(bad))
                failed[d] = (f"the running selection's quality falls to {abs(q[k]):.2g}", stretch[k])
                del viable[d]
            else:
                viable[d] = sign
        return None if viable else failed[preferred]

    Q, why, at = check.trace(q0, p, watch)
    if Q is None:
        return Verdict(False, why, at=at, coordinates=names), None
    quality = {d: np.abs(_qualities(factory, d, Q, check.coords, p)) for d in alternatives}
    found = {}
    for d in viable:
        best_other = np.max([quality[o] for o in alternatives if o != d] or [np.zeros(len(Q))], axis=0)
        ratios = np.minimum(quality[d] / np.maximum(best_other, 1e-300), 10.0)     # 10: far from switching
        # between two points the ratio may dip below both: allow for as much as it moves between neighbours
        margin = MARGIN + float(np.max(np.abs(np.diff(ratios)) / ratios[1:]))
        k = int(np.argmin(ratios))
        found[d] = (ratios[k] >= margin * hysteresis, float(ratios[k]), k)
    holding = [d for d in found if found[d][0]]
    if not holding:
        if preferred in failed:
            reason, point = failed[preferred]
            return Verdict(False, reason, points=len(Q), at=tuple(point), coordinates=names), Q
        _, ratio, k = found[preferred]
        return Verdict(False, f"another selection is {1 / ratio:.2g} x better", points=len(Q), at=tuple(Q[k]),
                       worst_ratio=ratio, coordinates=names), Q
    chosen = preferred if preferred in holding else max(holding, key=lambda d: found[d][1])
    return Verdict(True, "", len(Q), float(quality[chosen].min()), found[chosen][1], coordinates=names,
                   dummies=chosen, states=tuple(state_names(factory, chosen))), Q


def state_names(factory, dummies) -> list:
    """The states of a selection: the derivatives that are not dummies, by their antiderivatives."""
    return sorted(factory.names[i] for i, j in factory.graph.der.items() if j not in dummies)
