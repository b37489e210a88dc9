"""State events for the simulation loop: armed sides, detection between monitor points, location, resets.

A component's `When(condition, reset, direction)` becomes a zero function g and
a transition. Each g is *armed* with the side it is on (+1 or −1); an event is
g reaching the other side in the declared direction. Two rules make detection
independent of the output grid and the tolerance:

- **Sides on the boundary.** Where g is on its boundary (g = 0 to within what
  the event location resolves, and always just after its own event) its side
  is the one it moves to: the sign of ġ, or of g̈ where ġ vanishes too (ġ and g̈
  are Lie derivatives along the DAE, inputs held). A directional condition that
  moves into its direction from the boundary crosses *now*: a ball placed on
  the floor at rest fires at once. After a reset the fired condition is armed
  with its new side (a bounce: h = 0, ḣ > 0, armed +, the next impact found;
  a sensor whose reset keeps ḣ < 0 has completed its crossing); one that the
  reset leaves on its boundary with ġ = 0 and g̈ pushing it across fires again at
  the same instant, which is an accumulation (a ball at rest) and stops the run.
- **Excursions between monitor points.** g and ġ at both ends of each monitor
  interval define a cubic Hermite interpolant; its extrema inside the interval
  are checked too, so a whole excursion (down through zero and back) between
  two points is found and bracketed by re-integration to the extremum. The
  cubic is exact when g is at most cubic in t along the solution (a ball's
  height in free flight); otherwise it deviates by at most Δ⁴·max|g⁗|/384 over
  an interval Δ, and monitor points are at most about two solver steps apart
  (`_integrate_monitored`), the resolution the solver itself has of the
  solution. A predicted crossing that re-integration does not confirm is
  searched again on the sub-intervals between the checked extrema.

The crossing is located by Illinois regula falsi (to 1e-12 relative in time)
on a bracket whose ends have the two signs; both limits are recorded, the reset
is applied and the algebraic variables re-solved. Events closer together than
the monitor can resolve stop the run with the partial result (a Zeno point).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..core.errors import IntegrationError
from ..numeric import mapped_in
from .events import Event
from .initialize import solve_algebraic

SPLIT_DEPTH = 3          # times a predicted but unconfirmed crossing is searched again on sub-intervals
SX_SOLVE_MAX = 8         # algebraic variables up to which ż is solved symbolically in SX


def zero_rates(dae) -> ca.Function:
    """(t, x, z, u, p, d) -> [g, ġ, g̈]: the Lie derivatives of the zero functions along the DAE.

    ż comes from differentiating alg = 0 (index 1: ∂alg/∂z is regular). Inputs are held constant
    (their rate is not known to the DAE). Built in SX (fast to evaluate) unless the DAE needs MX or
    holds many algebraic variables (a symbolic solve would swell); cached on the selection."""
    if "_zero_rates" not in dae.info:
        if dae.z.numel() <= SX_SOLVE_MAX:
            try:
                dae.info["_zero_rates"] = _zero_rates(dae, ca.SX)
            except (RuntimeError, NotImplementedError, TypeError):
                pass
        if "_zero_rates" not in dae.info:
            dae.info["_zero_rates"] = _zero_rates(dae, ca.MX)
    return dae.info["_zero_rates"]


def _zero_rates(dae, sym):
    args = [sym.sym(n, v.shape) for n, v in zip("txzupd", (dae.t, dae.x, dae.z, dae.u, dae.p, dae.d))]
    t, x, z = args[:3]
    f = dae.ode(*args)
    w, field = x, f
    if z.numel():
        a = dae.alg(*args)
        zdot = -ca.solve(ca.jacobian(a, z), ca.jacobian(a, x) @ f + ca.jacobian(a, t))
        w, field = ca.vertcat(x, z), ca.vertcat(f, zdot)

    def lie(e):
        return ca.jtimes(e, w, field) + ca.jacobian(e, t)

    g = dae.zero(*args)
    gd = lie(g)
    return ca.Function("zero_rates", args, [ca.vertcat(g, gd, lie(gd))])


def _cubic_extrema(g_a, d_a, g_b, d_b, h):
    """Times (in (0, h)) and values of the extrema of the cubic Hermite interpolant, per function.

    Returns arrays (n, 2) of times and values, NaN where there is none."""
    # p(s) = g_a + d_a s + c2 s² + c3 s³ on s ∈ [0, h]
    c2 = (3 * (g_b - g_a) / h - 2 * d_a - d_b) / h
    c3 = (2 * (g_a - g_b) / h + d_a + d_b) / h ** 2
    # p'(s) = d_a + 2 c2 s + 3 c3 s² = 0
    A, B, C = 3 * c3, 2 * c2, d_a
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = B * B - 4 * A * C
        root = np.sqrt(np.where(disc >= 0, disc, np.nan))
        q = -0.5 * (B + np.copysign(root, B))
        s1, s2 = q / A, C / q
        linear = np.abs(A) <= 1e-14 * (np.abs(B) + np.abs(C) / h)
        s1 = np.where(linear, -C / B, s1)
        s2 = np.where(linear, np.nan, s2)
    s = np.stack([s1, s2], axis=-1)
    s = np.where((s > 0) & (s < np.asarray(h)[..., None]), s, np.nan)
    val = g_a[..., None] + s * (d_a[..., None] + s * (c2[..., None] + s * c3[..., None]))
    return s, val


def _allowed(dirs, before, after):
    """Which functions go from side `before` (±1, 0 unknown) to a value `after` across zero, in their
    direction: falling from + to ≤ 0, rising from − to ≥ 0."""
    return (((before > 0) & (after <= 0) & (dirs <= 0)) | ((before < 0) & (after >= 0) & (dirs >= 0))
            | ((before == 0) & (after != 0) & ((dirs == 0) | (np.sign(after) == dirs))))


def _predicted(dirs, before, s, ext, g_b):
    """Which functions the Hermite cubic (extrema at times s, values ext, end value g_b) takes across
    zero in their direction, starting from side `before`: its knots walked in time order."""
    order = np.argsort(np.where(np.isnan(s), np.inf, s), axis=-1)
    ext = np.take_along_axis(ext, order, axis=-1)
    hit, prev = np.zeros(np.shape(g_b), dtype=bool), np.array(before, dtype=float)
    for v in (ext[..., 0], ext[..., 1], g_b):
        valid = ~np.isnan(v)
        hit |= valid & _allowed(dirs, prev, np.where(valid, v, 0.0))
        prev = np.where(valid & (np.nan_to_num(v) != 0), np.sign(np.nan_to_num(v)), prev)
    return hit


class StateEvents:
    """Mixin of the simulation loop (`run.Run`): everything about zero crossings."""

    _armed = None            # side of each zero function (±1; 0 on the boundary and not moving)
    _armed_at = None         # the time they were set at
    _pending = None          # the bracket found by _first_crossing, for _handle_event

    def _rates(self, t, x, z):
        out = np.asarray(zero_rates(self.dae)(t, x, z, self._u_at(t), self.p, self.d)).ravel()
        return out.reshape(3, -1)

    def _tol_t(self, t):
        return 1e-12 * max(1.0, abs(t))

    def _sides(self, t, rates, near=None):
        """The side each function is on just after t: the sign of g, or where g is on its boundary the
        sign of ġ, else of g̈. Returns (sides, on_boundary, moving_by_rate). `near`: after an event, how
        close to zero each function was found (a fired one is on its boundary unless its reset moved it
        away)."""
        g, gd, gdd = rates
        tol = self._tol_t(t)
        on = (g == 0) | (np.abs(g) <= np.abs(gd) * tol)
        if near is not None:
            on |= np.abs(g) <= near
        by_rate = np.abs(gd) > np.abs(gdd) * tol
        return np.where(on, np.where(by_rate, np.sign(gd), np.sign(gdd)), np.sign(g)), on, by_rate

    def _crossing_now(self, sides, on):
        """Directional functions on their boundary moving into their direction: they cross now."""
        dirs = np.array(self.dae.zero_directions)
        return [int(i) for i in np.flatnonzero(on & (dirs != 0) & (sides == dirs))]

    def _arm(self, t):
        """At the start of the run: arm every function; a directional one leaving its boundary in its
        direction fires at once. False when that stopped the run."""
        if not self.dae.zero_labels:
            return True
        sides, on, _ = self._sides(t, self._rates(t, self.x, self.z))
        self._armed, self._armed_at = sides, t
        now = self._crossing_now(sides, on)
        if now:
            self._fire(t, self.x, self.z, now)
        return self.failure is None

    def _first_crossing(self, pts, xs, zs, limit):
        """Index of the last monitor point before the first event among pts (up to `limit`), or None.

        Candidates: a sign change between points against the armed side, or an extremum of the
        Hermite cubic beyond zero; each is confirmed by re-integration (`_bracket`) and the bracket
        kept for `_handle_event`. On return without a crossing the functions are armed with their
        sides at the last point."""
        if not self.dae.zero_labels:
            return None
        n = pts.size if limit is None else limit + 1
        U = self._inputs_at(pts[:n])
        rates = mapped_in(self.dae.info.setdefault("_zero_rate_maps", {}), zero_rates(self.dae), n)
        R = rates(pts[:n].reshape(1, -1), xs[:n].T, zs[:n].T, U, np.tile(self.p.reshape(-1, 1), n),
                  np.tile(self.d.reshape(-1, 1), n))[0]
        m = len(self.dae.zero_labels)
        G, D = R[:m].T, R[m: 2 * m].T                   # (n, m)
        dirs = np.array(self.dae.zero_directions)
        # the side at each point: its sign; at the start the armed side where it was set at that very time
        # (just after an event g may be a round-off on either side) or where g is exactly 0
        side = np.sign(G)
        keep = (side[0] == 0) | (self._armed_at == pts[0])
        side[0] = np.where(keep, self._armed if self._armed is not None else 0.0, side[0])
        last = np.maximum.accumulate(np.where(side != 0, np.arange(n)[:, None], 0), axis=0)
        side = np.take_along_axis(side, last, axis=0)
        h = np.diff(pts[:n])[:, None]
        s, ext = _cubic_extrema(G[:-1], D[:-1], G[1:], D[1:], h)
        hit = _predicted(dirs, side[:-1], s, ext, G[1:])
        for j in np.flatnonzero(np.any(hit, axis=1)):
            found = self._bracket(pts[j], xs[j], zs[j], side[j], pts[j + 1], xs[j + 1], zs[j + 1])
            if found is not None:
                self._pending = found
                return int(j)
        self._armed, self._armed_at = side[n - 1], pts[n - 1]
        return None

    def _bracket(self, t_a, x_a, z_a, s_a, t_b, x_b, z_b, depth=0):
        """The earliest confirmed crossing in (t_a, t_b]: (functions, lo, x_lo, z_lo, s_lo, hi, x_hi, z_hi),
        where s_lo are the sides at lo; None when re-integration shows none (a grazing prediction)."""
        dirs = np.array(self.dae.zero_directions)
        ra, rb = self._rates(t_a, x_a, z_a), self._rates(t_b, x_b, z_b)
        s, ext = _cubic_extrema(ra[0], ra[1], rb[0], rb[1], t_b - t_a)
        cand = _predicted(dirs, s_a, s, ext, rb[0])
        knots = sorted({t_a + float(v) for v in s[cand].ravel() if np.isfinite(v)})
        ts, states = [t_a], [(x_a, z_a)]
        for t in knots:
            ts.append(t)
            states.append(self._advance_to(t_a, x_a, z_a, t))
        ts.append(t_b)
        states.append((x_b, z_b))
        G = [ra[0]] + [self._rates(t, *st)[0] for t, st in zip(ts[1:-1], states[1:-1])] + [rb[0]]
        side = s_a
        for k in range(1, len(ts)):
            crossed = np.flatnonzero(_allowed(dirs, side, G[k]))
            if crossed.size:
                x_lo, z_lo = states[k - 1]
                return (crossed, ts[k - 1], x_lo, z_lo, side, ts[k], *states[k])
            side = np.where(G[k] != 0, np.sign(G[k]), side)
        if depth < SPLIT_DEPTH and len(ts) > 2:        # the cubic was off: look again between the knots
            side = s_a
            for k in range(1, len(ts)):
                found = self._bracket(ts[k - 1], *states[k - 1], side, ts[k], *states[k], depth + 1)
                if found is not None:
                    return found
                side = np.where(G[k] != 0, np.sign(G[k]), side)
        return None

    def _advance_to(self, t_a, x_a, z_a, t):
        F1 = self.integrators.get((1.0,))
        out = F1(x0=x_a / self.xn, z0=z_a / self.zn if self.zn.size else np.zeros(0), p=self.pvec(t_a, t - t_a))
        x = np.asarray(out["xf"]).ravel() * self.xn
        z = np.asarray(out["zf"]).ravel() * self.zn if self.zn.size else np.zeros(0)
        return x, z

    def _locate(self, i, lo, f_lo, hi, f_hi, t_a, x_a, z_a, x_hi, z_hi):
        """Illinois regula falsi for function i on [lo, hi] (f_lo, f_hi of opposite sides), states
        re-integrated from (t_a, x_a, z_a). Returns (t, x, z) at the end past the crossing."""
        sign_lo = np.sign(f_lo)
        side = 0
        tol = self._tol_t(hi)
        for _ in range(200):
            if hi - lo <= tol:
                break
            t = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
            if not (lo < t < hi):
                t = 0.5 * (lo + hi)
            x_t, z_t = self._advance_to(t_a, x_a, z_a, t)
            g_t = self._rates(t, x_t, z_t)[0][i]
            if np.sign(g_t) != sign_lo:                   # the crossing lies in (lo, t]
                hi, f_hi, x_hi, z_hi = t, g_t, x_t, z_t
                if side == -1:
                    f_lo *= 0.5                           # Illinois: the same end kept twice
                side = -1
            else:
                lo, f_lo = t, g_t
                if side == 1:
                    f_hi *= 0.5
                side = 1
        return hi, x_hi, z_hi

    def _handle_event(self, t_a, x_a, z_a, t_b):
        """Locate the crossing bracketed by `_first_crossing` (the earliest of the functions crossing
        there), then apply the transition(s) and re-initialise."""
        crossed, lo, x_lo, z_lo, s_lo, hi, x_hi, z_hi = self._pending
        self._pending = None
        g_lo, g_hi = self._rates(lo, x_lo, z_lo)[0], self._rates(hi, x_hi, z_hi)[0]
        best = None
        for i in crossed:
            # a start on the boundary has no sign yet: the armed side stands in for it
            f_lo = g_lo[i] if np.sign(g_lo[i]) == s_lo[i] else s_lo[i] * 1e-300
            if s_lo[i] == 0:
                f_lo = -np.sign(g_hi[i]) * 1e-300
            found = self._locate(i, lo, f_lo, hi, g_hi[i], lo, x_lo, z_lo, x_hi, z_hi)
            if best is None or found[0] < best[0]:
                best = found
        t_e, x_e, z_e = best
        dirs = np.array(self.dae.zero_directions)
        # every function that crossed by t_e fires, in index order (two balls landing at once)
        fired = [int(h) for h in np.flatnonzero(_allowed(dirs, s_lo, self._rates(t_e, x_e, z_e)[0]))]
        self._record_at(t_e, x_e, z_e)
        self._fire(t_e, x_e, z_e, fired or [int(crossed[0])])
        return t_e

    def _fire(self, t_e, x_e, z_e, fired):
        """Apply the transitions of `fired` at t_e (the left limit is recorded already), record the
        right limit and re-arm. A function that fires again at the same instant
        is an accumulation: the run stops."""
        once = set()
        while fired:
            again = [h for h in fired if h in once]
            if again:
                self._accumulation(t_e, again[0], "its reset leaves the condition crossing, so it fires "
                                                  "again at the same instant")
                return
            once.update(fired)
            g_left, gd_left, _ = self._rates(t_e, x_e, z_e)
            near = np.zeros_like(g_left)
            near[fired] = 2 * np.maximum(np.abs(g_left[fired]), np.abs(gd_left[fired]) * self._tol_t(t_e))
            x_now, u_e = np.asarray(x_e, dtype=float), self._u_at(t_e)
            for h in fired:
                x_plus, _ = self.dae.transition[h](t_e, x_now, z_e, u_e, self.p, self.d)
                x_now = np.asarray(x_plus).ravel()
            self.x = x_now
            self.z = z_e = solve_algebraic(self.dae, t_e, self.x, z_e, u_e, self.p, self.d)
            x_e = self.x
            self._record_at(t_e, self.x, self.z)
            for h in fired:
                self.events.append(Event(float(t_e), "state", self.dae.zero_labels[h]))
            sides, on, by_rate = self._sides(t_e, self._rates(t_e, self.x, self.z), near)
            self._armed, self._armed_at = sides, t_e
            # one that fired and goes on across with speed has completed its crossing (a sensor);
            # one held on its boundary by g̈ alone cannot leave it (a ball at rest): it fires again
            fired = [h for h in self._crossing_now(sides, on) if not (h in once and by_rate[h])]

    def _accumulation(self, t, i, why):
        label = self.dae.zero_labels[i]
        self.failure = IntegrationError(
            f"event accumulation at t = {t:.9g} s: {label} — {why} (chattering or a Zeno point such as a "
            f"bouncing ball coming to rest); the result holds the solution up to there",
            t=float(t), step=float("nan"), worst=label, solver_message="event accumulation")

    def _record_at(self, t, x, z):
        self.x, self.z = np.asarray(x, dtype=float).copy(), np.asarray(z, dtype=float).copy()
        self._record(t)

    def _event_density(self, density, out_interval):
        """Monitor points close enough to resolve the spacing of recent state events (or stop at a Zeno point)."""
        times = sorted({e.t for e in self.events if e.kind == "state"})   # simultaneous events count once
        if len(times) < 2:
            return density
        gap = times[-1] - times[-2]
        needed = 8.0 * out_interval / max(gap, 1e-300)
        if needed > 4096:
            cause = self.events[-1].cause
            label = self.dae.zero_labels.index(cause) if cause in self.dae.zero_labels else 0
            self._accumulation(times[-1], label, f"state events {gap:.3g} s apart, too close to resolve")
            return density
        return int(min(4096, max(density, 2 ** int(np.ceil(np.log2(max(needed, 1.0)))))))
