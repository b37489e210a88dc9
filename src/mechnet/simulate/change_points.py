"""Change points: where the whole constraint Jacobian loses rank, continue with the velocity.

A parallelogram four-bar folds flat twice per revolution: there the loop's
constraint Jacobian loses rank for every choice of states, two branches of
solutions cross (parallelogram and anti-parallelogram), and the integrator's
Newton iteration fails. Re-selecting states cannot help (DESIGN.md). The
branch rule steps over the point instead. From the last accepted point, every
variable moves on with its velocity (the secant of the last two accepted
points, a least-squares step through the rank drop). The algebraic variables
are re-solved at the new time from that prediction, and the solution is kept
only if Newton stayed near the prediction. Near the crossing the other branch
lies O(Δt) away and the continuing one O(Δt²), so the motion keeps its
branch, as a physical mechanism with inertia does.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..core.errors import MechnetError
from .events import Event
from .initialize import solve_algebraic
from .reselection import dae_arguments

RANK_LOSS = 1e-4          # conditioning of the algebraic block below this: the constraints are losing rank
                          # (a regular four-bar position measures ~0.03, 0.04 rad before a fold ~5e-6)
MAX_GROWTH = 64           # repeated steps over one point grow at most this much
MAX_OUTPUT_INTERVALS = 2  # and never beyond two output intervals


class ChangePoints:
    """Mixin of the simulation loop (`integrator._Run`): pass a change point after a failure."""

    def _algebraic_conditioning(self):
        """σ_min/σ_max of the algebraic block ∂alg/∂z (rows scaled to unit norm) at the last accepted
        point. The selection quality cannot see a change point: it scales each constraint row by its
        norm, and at a fold a whole row vanishes."""
        dae = self.dae
        if not dae.z.numel():
            return None
        t = self.T[-1]
        J = np.asarray(self._alg_jacobian_function()(t, self.X[-1], self.Z[-1], self._u_at(t), self.p, self.d),
                       dtype=float)
        J = J / np.maximum(np.linalg.norm(J, axis=1, keepdims=True), 1e-300)
        s = np.linalg.svd(J, compute_uv=False)
        return float(s[-1] / s[0]) if s.size and s[0] > 0 else 0.0

    def _alg_jacobian_function(self):
        """∂alg/∂z of the running compiled selection (cached per selection)."""
        dae = self.dae
        cache = self.__dict__.setdefault("_alg_jacobians", {})
        if id(dae) not in cache:
            args = dae_arguments(dae)
            cache[id(dae)] = ca.Function("alg_z", args, [ca.jacobian(dae.alg(*args), args[2])])
        return cache[id(dae)]

    def _pass_change_point(self, grid, limit=None):
        """After a failure: step over a change point and return the new time, or None (a real failure).
        The step stays before `limit` (the end of the running segment)."""
        limit = grid[-1] if limit is None else limit
        if self.failure is None or len(self.T) < 2 or self.D[-1] is not self.D[-2]:
            return None
        quality = self._algebraic_conditioning()
        if quality is None or quality >= RANK_LOSS:
            return None
        if self.T[-1] - self.T[-2] <= 0:
            return None
        dt = self.failure.t - self.T[-1] if self.failure.t > self.T[-1] else 0.0
        t_b = self._step_over(grid, limit, self.T[-2], self.X[-2], self.Z[-2], self.T[-1], self.X[-1],
                              self.Z[-1], dt, quality)
        if t_b is not None:
            self.failure = None
            self.stats.pop("failed_at", None)
        return t_b

    def _first_fold(self, pts, xs, zs):
        """(index, conditioning) of the first monitor point after the start where the algebraic block's
        conditioning falls below RANK_LOSS: the simulator steps over the change point before the
        integrator fails there."""
        if self.cm.selection_factory is None or not self.dae.z.numel() or pts.size < 2:
            return None
        n, nz = pts.size, self.dae.z.numel()
        f = self._alg_jacobian_function().map(n)
        U = np.column_stack([self._u_at(t) for t in pts])
        J = np.asarray(f(pts.reshape(1, -1), xs.T, zs.T, U, np.tile(self.p.reshape(-1, 1), n),
                         np.tile(self.d.reshape(-1, 1), n)), dtype=float)
        J = J.reshape(nz, n, nz).transpose(1, 0, 2)
        J = J / np.maximum(np.linalg.norm(J, axis=2, keepdims=True), 1e-300)
        s = np.linalg.svd(J, compute_uv=False)
        cond = s[:, -1] / np.maximum(s[:, 0], 1e-300)
        # approaching the point (the conditioning still falling), not leaving it after a step over
        low = np.nonzero((cond[1:] < RANK_LOSS) & (cond[1:] < cond[:-1]))[0]
        return (int(low[0]) + 1, float(cond[low[0] + 1])) if low.size else None

    def _step_over(self, grid, limit, t0, x0, z0, t1, x1, z1, dt_min, quality):
        """Move from (t1, x1, z1) past the change point along the secant from (t0, x0, z0); the new time
        or None. Repeated steps near one point grow (the point was not passed yet)."""
        h = t1 - t0
        if h <= 0:
            return None
        watched = self._branch_variables()
        xdot, zdot = (x1 - x0) / h, (z1 - z0) / h
        last = getattr(self, "_last_change_point", None)
        growth = 1.0
        if last is not None and t1 <= last[0] + 4 * last[1]:
            growth = last[2] * 4
            if growth > MAX_GROWTH:
                return None
        dt = growth * max(h, dt_min)
        spacing = float(np.max(np.diff(grid))) if grid.size > 1 else h
        longest = max(MAX_GROWTH * h, MAX_OUTPUT_INTERVALS * spacing)
        while dt <= longest and t1 + dt < limit:
            t_b = t1 + dt
            x_b, z_pred = x1 + xdot * dt, z1 + zdot * dt
            try:
                z_b = solve_algebraic(self.dae, t_b, x_b, z_pred, self._u_at(t_b), self.p, self.d)
            except MechnetError:
                dt *= 2
                continue
            # kept only if Newton stayed on the predicted branch: within half the predicted motion
            gap = np.abs(z_b - z_pred)[watched]
            if np.all(gap <= 0.5 * np.abs(zdot * dt)[watched] + 1e-8 * (1 + np.abs(z_pred[watched]))):
                self._bridge(grid, t1, x1, z1, t_b, x_b, z_b)
                self._last_change_point = (t_b, dt, dt / max(h, 1e-300))
                self.events.append(Event(float(t_b), "change point",
                                         f"constraint Jacobian lost rank (algebraic block conditioning "
                                         f"{quality:.2g}); passed from t = {t1:.9g} s with the velocity"))
                return t_b
            dt *= 2
        return None

    def _branch_variables(self):
        """Algebraic variables that decide the branch: coordinates and speeds (variables with a
        derivative), not forces and accelerations, which change fast near the point."""
        factory = self.cm.selection_factory
        moving = {factory.names[v] for v in factory.graph.der} if factory is not None else set()
        mask = np.array([name in moving for name in self.dae.z_names], dtype=bool)
        return mask if mask.any() else np.ones(len(self.dae.z_names), dtype=bool)

    def _bridge(self, grid, t1, x1, z1, t_b, x_b, z_b):
        """Output points inside the step over the change point: linear between its two ends."""
        for t in grid[(grid > t1) & (grid < t_b)]:
            s = (t - t1) / (t_b - t1)
            self.x, self.z = x1 + s * (x_b - x1), z1 + s * (z_b - z1)
            self._record(t)
        self.x, self.z = x_b.copy(), z_b.copy()
