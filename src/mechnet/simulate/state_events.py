"""State events for the simulation loop: detection on dense output, Illinois location, resets.

A component's `When(condition, reset, direction)` becomes a zero function and a
transition. After each integrated piece the zero functions are evaluated at
every reported point; at the first sign change (in the declared direction)
the crossing is located by re-integrating from the last point before it
(Illinois variant of regula falsi, to 1e-12 relative in time), both limits are
recorded, the reset is applied and the algebraic variables re-solved. Events
closer together than the monitor can resolve stop the run with the partial
result (chattering, a Zeno point).
"""
from __future__ import annotations

import numpy as np

from ..core.errors import IntegrationError
from ..numeric import mapped_in
from .events import Event
from .initialize import solve_algebraic


class StateEvents:
    """Mixin of the simulation loop (`integrator._Run`): everything about zero crossings."""

    def _g(self, t, x, z):
        return np.asarray(self.dae.zero(t, x, z, self._u_at(t), self.p, self.d)).ravel()

    def _crossed(self, g_a, g_b):
        """Which zero functions changed sign between two points, in their direction."""
        dirs = np.array(self.dae.zero_directions)
        falling = (g_a > 0) & (g_b <= 0)
        rising = (g_a < 0) & (g_b >= 0)
        return np.flatnonzero((falling & (dirs <= 0)) | (rising & (dirs >= 0)))

    def _state_event(self, points, n_before):
        """After a segment: find the first zero crossing between recorded points, locate and apply it.

        Returns the event time (the segment must continue from there) or None.
        """
        if not self.dae.zero_labels:
            return None
        rows = range(n_before - 1, len(self.T))
        G = [self._g(self.T[k], self.X[k], self.Z[k]) for k in rows]
        for j in range(1, len(G)):
            hit = self._crossed(G[j - 1], G[j])
            if hit.size:
                k = n_before - 1 + j - 1              # last recorded point before the crossing
                t_a, x_a, z_a = self.T[k], self.X[k].copy(), self.Z[k].copy()
                t_b = self.T[k + 1]
                del self.T[k + 1:], self.X[k + 1:], self.Z[k + 1:], self.D[k + 1:]
                return self._handle_event(t_a, x_a, z_a, t_b)
        return None

    def _advance_to(self, t_a, x_a, z_a, t):
        F1 = self.integrators.get((1.0,))
        out = F1(x0=x_a / self.xn, z0=z_a / self.zn if self.zn.size else np.zeros(0), p=self.pvec(t_a, t - t_a))
        x = np.asarray(out["xf"]).ravel() * self.xn
        z = np.asarray(out["zf"]).ravel() * self.zn if self.zn.size else np.zeros(0)
        return x, z

    def _handle_event(self, t_a, x_a, z_a, t_b):
        """Illinois iteration on the earliest crossing, then the transition and re-initialisation."""
        x_b, z_b = self._advance_to(t_a, x_a, z_a, t_b)
        g_a, g_b = self._g(t_a, x_a, z_a), self._g(t_b, x_b, z_b)
        hit = self._crossed(g_a, g_b)
        if not hit.size:
            # a grazing crossing that the re-integration does not reproduce: no event, carry on from t_b
            self.x, self.z = x_b, z_b
            return t_b
        i = int(hit[0])
        if hit.size > 1:                              # earliest by the secant estimate
            est = [t_a - g_a[h] * (t_b - t_a) / (g_b[h] - g_a[h]) for h in hit]
            i = int(hit[int(np.argmin(est))])
        lo, hi, f_lo, f_hi = t_a, t_b, g_a[i], g_b[i]
        x_hi, z_hi = x_b, z_b
        side = 0
        tol = 1e-12 * max(1.0, abs(t_b))
        for _ in range(200):
            if hi - lo <= tol:
                break
            t = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
            if not (lo < t < hi):
                t = 0.5 * (lo + hi)
            x_t, z_t = self._advance_to(t_a, x_a, z_a, t)
            g_t = self._g(t, x_t, z_t)
            crossed = self._crossed(g_a, g_t)
            early = [h for h in crossed if h != i]
            if early:                                 # another function crosses before t: it comes first
                i = int(early[0])
                lo, f_lo, hi, f_hi, x_hi, z_hi, side = t_a, g_a[i], t, g_t[i], x_t, z_t, 0
                continue
            if i in crossed:                          # the crossing lies in (lo, t]
                hi, f_hi, x_hi, z_hi = t, g_t[i], x_t, z_t
                if side == -1:
                    f_lo *= 0.5                       # Illinois: the same end kept twice
                side = -1
            else:
                lo, f_lo = t, g_t[i]
                if side == 1:
                    f_hi *= 0.5
                side = 1
        t_e = hi
        self._record_at(t_e, x_hi, z_hi)
        # every function that crossed by t_e fires, in index order (two balls landing at once)
        fired = [int(h) for h in self._crossed(g_a, self._g(t_e, x_hi, z_hi))] or [i]
        x_now, u_e = np.asarray(x_hi, dtype=float), self._u_at(t_e)
        for h in fired:
            x_plus, _ = self.dae.transition[h](t_e, x_now, z_hi, u_e, self.p, self.d)
            x_now = np.asarray(x_plus).ravel()
        self.x = x_now
        self.z = solve_algebraic(self.dae, t_e, self.x, z_hi, u_e, self.p, self.d)
        self._record_at(t_e, self.x, self.z)
        for h in fired:
            self.events.append(Event(float(t_e), "state", self.dae.zero_labels[h]))
        return t_e

    def _record_at(self, t, x, z):
        self.x, self.z = np.asarray(x, dtype=float).copy(), np.asarray(z, dtype=float).copy()
        self._record(t)

    def _first_crossing(self, pts, xs, zs, limit):
        """Index of the last point before the first zero crossing among pts (up to `limit`), or None."""
        if not self.dae.zero_labels:
            return None
        n = pts.size if limit is None else limit + 1
        U = self._inputs_at(pts[:n])
        zero = mapped_in(self.dae.info.setdefault("_zero_maps", {}), self.dae.zero, n)
        G = zero(pts[:n].reshape(1, -1), xs[:n].T, zs[:n].T, U, np.tile(self.p.reshape(-1, 1), n),
                 np.tile(self.d.reshape(-1, 1), n))[0].T
        dirs = np.array(self.dae.zero_directions)
        falling = (G[:-1] > 0) & (G[1:] <= 0) & (dirs <= 0)
        rising = (G[:-1] < 0) & (G[1:] >= 0) & (dirs >= 0)
        hits = np.flatnonzero(np.any(falling | rising, axis=1))
        return int(hits[0]) if hits.size else None

    def _event_density(self, density, out_interval):
        """Monitor points close enough to resolve the spacing of recent state events (or stop at a Zeno point)."""
        times = sorted({e.t for e in self.events if e.kind == "state"})   # simultaneous events count once
        if len(times) < 2:
            return density
        gap = times[-1] - times[-2]
        needed = 8.0 * out_interval / max(gap, 1e-300)
        if needed > 4096:
            self.failure = IntegrationError(
                f"event accumulation at t = {times[-1]:.9g} s: state events {gap:.3g} s apart, too close to "
                f"resolve (chattering or a Zeno point such as a bouncing ball coming to rest); the result "
                f"holds the solution up to there", t=float(times[-1]), step=float("nan"),
                worst=self.events[-1].cause, solver_message="event accumulation")
            return density
        return int(min(4096, max(density, 2 ** int(np.ceil(np.log2(max(needed, 1.0)))))))
