"""Change points: where the whole constraint Jacobian loses rank, step over with the motion.

A parallelogram four-bar folds flat twice per revolution: there the loop's
constraint Jacobian loses rank for every choice of states, two branches of
solutions cross (parallelogram and anti-parallelogram), and the integrator's
Newton iteration fails. Re-selecting states cannot help (DESIGN.md). The
branch rule steps over the point instead: from the last accepted points the
conditioning's fall locates the point, one Gauss–Legendre step (whose stages
all lie away from the point, where the equations are regular) carries the
states past it, the algebraic variables are re-solved there from a
prediction, and the landing is kept only if Newton stayed near the
prediction at every stage and at the landing. Near the crossing the other
branch lies O(Δt) away and the continuing one O(Δt²), so the motion keeps
its branch, as a physical mechanism with inertia does.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
from scipy.interpolate import BarycentricInterpolator, CubicHermiteSpline

from ..caches import built
from ..core.errors import MechnetError
from ..numeric import mapped_in
from .events import Event
from .initialize import _newton, _residual_pair, solve_algebraic
from .reselection import dae_arguments
from .rows import observe

RANK_LOSS = 1e-4          # conditioning of the algebraic block below this: the constraints are losing rank
CLOSURE_RANK_LOSS = 0.05  # the same for the closures measured alone (`_kinematic_block`), relative to their
                          # best in the run: about the distance from the fold in radians (A02, N = 10 and 40)
                          # (a regular four-bar position measures ~0.03, 0.04 rad before a fold ~5e-6)
MAX_GROWTH = 64           # a jump spans at most this many times the last step before it,
MAX_OUTPUT_INTERVALS = 2  # or two output intervals when that is longer
GAUSS_C = 0.5 + 0.5 * np.array([-1, -1, 1, 1]) * np.sqrt(3 / 7 + np.array([1, -1, -1, 1]) * 2 / 7 * np.sqrt(6 / 5))
GAUSS_B = (18 + np.array([-1, 1, 1, -1]) * np.sqrt(30.0)) / 72    # 4-stage Gauss–Legendre: nodes, weights
HISTORY = 4               # recorded points used to estimate where the rank is lost


class ChangePoints:
    """Mixin of the simulation loop (`run.Run`): pass a change point after a failure."""

    def _conditioning(self, ts, xs, zs, unit_rows=True):
        """σ_min/σ_max of the algebraic block ∂alg/∂z at each point, columns per unit of each variable's
        largest size over the points (its nominal at least; angles: their nominal) and rows scaled to
        unit norm. The selection quality cannot see a change point: it scales each constraint row by its
        norm, and at a fold a whole row vanishes. The row-scaled ratio can miss the same thing (a
        parallelogram's closure along its flat line when the rocker-coupler angle is the state):
        `unit_rows=False` keeps the rows as they are, for the check after a failure.

        When the block also holds a large acceleration block (`_kinematic_block`), only its kinematic
        part is measured, with its rows as they are: they are all closures in one unit, and a fold then
        shows as a conditioning proportional to the distance from it."""
        n = len(ts)
        rows, cols, kinematic = self._kinematic_block()
        f = self._alg_jacobian_function(n)
        U = self._inputs_at(ts)
        J = f(np.reshape(ts, (1, -1)), np.asarray(xs).T, np.asarray(zs).T, U,
              np.tile(self.p.reshape(-1, 1), n), np.tile(self.d.reshape(-1, 1), n))[0]
        nz = self.dae.z.numel()
        J = J.reshape(nz, n, nz).transpose(1, 0, 2)[:, rows][:, :, cols]
        # per unit of each variable's size over these points (its nominal at least): a pin force of 6000 N
        # at 3000 rpm measured per newton made a regular slider-crank look singular four times a turn, and
        # its size at each point alone did where a force component crosses zero. Angles keep their
        # nominal: an angle's value says nothing of its scale (a parallelogram wound 10⁴ turns missed its fold)
        zn = self.zn[cols]
        size = np.maximum(np.max(np.abs(np.asarray(zs, dtype=float).reshape(n, nz)[:, cols]), axis=0), zn)
        J = J * np.where(_angles(self.dae)[cols], zn, size)
        if unit_rows and not kinematic:
            J = J / np.maximum(np.linalg.norm(J, axis=2, keepdims=True), 1e-300)
        s = np.linalg.svd(J, compute_uv=False)
        ratio = s[:, -1] / np.maximum(s[:, 0], 1e-300)
        if not kinematic:
            return ratio
        # unscaled, the ratio shrinks with the number of loops (2e-3 for ten parallelograms upright, 8e-5
        # for forty): relative to the best this selection has shown in the run, it reads the same for both
        best = self.__dict__.setdefault("_closure_best", {})
        seen, top = best.get(id(self.dae), (None, 0.0))
        top = max(top if seen is self.dae else 0.0, float(np.max(ratio)))   # (an id freed and reused: anew)
        best[id(self.dae)] = (self.dae, top)
        return ratio / max(top, 1e-300)

    def _rank_loss(self):
        """The conditioning below which the algebraic block counts as losing rank (see _conditioning)."""
        return CLOSURE_RANK_LOSS if self._kinematic_block()[2] else RANK_LOSS

    def _kinematic_block(self):
        """(rows, columns, proper) of ∂alg/∂z without a large linear block the compiler kept algebraic
        (`tearing.SYMBOLIC_TEARS_MAX`: accelerations and forces): the other variables and the equations
        in them alone — the loops' closures; `proper` when such a block was left out. Measured with
        its forces in newtons next to accelerations, ten parallelograms looked folded 0.2 rad before
        their fold. The whole block otherwise (cached per selection)."""
        dae = self.dae

        def build():
            kept = set(dae.info.get("linear_tears", ()))
            cols = np.array([name not in kept for name in dae.z_names], dtype=bool)
            args = dae_arguments(dae)
            pattern = np.array(ca.DM(ca.jacobian(dae.alg(*args), args[2]).sparsity(), 1).full(), dtype=bool)
            rows = ~np.any(pattern[:, ~cols], axis=1)
            proper = bool(kept and cols.any() and rows.sum() >= cols.sum())
            if not proper:
                rows, cols = np.ones(pattern.shape[0], dtype=bool), np.ones(pattern.shape[1], dtype=bool)
            return (np.nonzero(rows)[0], np.nonzero(cols)[0], proper), {}
        return built(dae.info, "_kinematic_block", build)[0]

    def _alg_jacobian_function(self, n):
        """∂alg/∂z of the running compiled selection, mapped over n points (cached per selection, across
        runs)."""
        dae = self.dae

        def build():
            args = dae_arguments(dae)
            return ca.Function("alg_z", args, [ca.jacobian(dae.alg(*args), args[2])]), {}
        single, maps = built(dae.info, "_alg_jacobians", build)
        return mapped_in(maps, single, n)

    def _pass_change_point(self, grid, limit=None):
        """After a failure: step over a change point and return the new time, or None (a real failure).
        The step stays before `limit` (the end of the running segment)."""
        limit = grid[-1] if limit is None else limit
        if self.failure is None or not self.dae.z.numel():
            return None
        last = self.rows.last
        ts, xs, zs = self._history(np.array([last.t]), last.x.reshape(1, -1), last.z.reshape(1, -1))
        if last.dae is not self.dae or len(ts) < 2:
            return None
        t_b = self._step_over_losing_rank(grid, limit, ts, xs, zs)
        if t_b is not None:
            self.failure = None
            self.stats.pop("failed_at", None)
        return t_b

    def _step_over_from(self, t, grid):
        """After a failed piece from (t, self.x, self.z): when the algebraic block is already losing
        rank there, and still falling, step over the change point at once; the new time or None."""
        if self.cm.selection_factory is None or not self.dae.z.numel():
            return None
        ts, xs, zs = self._history(np.array([t]), self.x.reshape(1, -1), self.z.reshape(1, -1))
        if len(ts) < 2:
            return None
        return self._step_over_losing_rank(grid, grid[-1], ts, xs, zs)

    def _step_over_losing_rank(self, grid, limit, ts, xs, zs):
        """After a failure: step over when the algebraic block is losing rank at the end of the history
        (ts, xs, zs) and still falling — row-scaled below RANK_LOSS, or with rows as they are, down
        tenfold over the history (a vanishing row), or (closures measured alone) below ten times
        CLOSURE_RANK_LOSS with the point estimated ahead; the new time or None."""
        conds, loss = self._conditioning(ts, xs, zs), self._rank_loss()
        if conds[-1] < loss and conds[-1] < conds[-2]:
            return self._step_over(grid, limit, ts, xs, zs, conds)
        if self._kinematic_block()[2] and conds[-1] < 10 * loss and _fold_time(ts, conds) is not None:
            # closures measured alone fall linearly to the point: at tight tolerances IDAS fails already
            # 0.06 rad before a fold of ten parallelograms (rtol 1e-10)
            return self._step_over(grid, limit, ts, xs, zs, conds)
        plain = self._conditioning(ts, xs, zs, unit_rows=False)
        if len(ts) >= 3 and plain[-1] < 0.1 * plain[0] and np.all(np.diff(plain) < 0):
            return self._step_over(grid, limit, ts, xs, zs, plain, unit_rows=False)
        return None

    def _first_fold(self, pts, xs, zs):
        """(index, conditioning at every point) of the first monitor point after the start where the
        algebraic block's conditioning falls below `_rank_loss`: the simulator steps over the change point
        before the integrator fails there."""
        self._last_conditioning = None
        if self.cm.selection_factory is None or not self.dae.z.numel() or pts.size < 2:
            return None
        cond, loss = self._conditioning(pts, xs, zs), self._rank_loss()
        if np.any(cond > loss):
            self._fold_floor = loss                           # a failed step over is forgotten once regular
        threshold = min(loss, self.__dict__.get("_fold_floor") or loss)
        # approaching the point (the conditioning still falling), not leaving it after a step over
        low = np.nonzero((cond[1:] < threshold) & (cond[1:] < cond[:-1]))[0]
        self._last_conditioning = cond
        return (int(low[0]) + 1, cond) if low.size else None

    def _fold_ahead(self, pts):
        """The time of a change point the conditioning at the monitor points `pts` (the start of the
        last piece checked by `_first_fold`) is heading for, or None when it is far (above 100·RANK_LOSS;
        the closures alone: whenever they fall) or not falling."""
        cond = getattr(self, "_last_conditioning", None)
        near = np.inf if self._kinematic_block()[2] else 100 * RANK_LOSS
        if cond is None or len(pts) < 3 or len(cond) < len(pts) or cond[len(pts) - 1] > near:
            return None
        keep = [j for j in range(len(pts)) if j == 0 or pts[j] > pts[j - 1]]
        return _fold_time(np.asarray(pts)[keep], cond[: len(pts)][keep])

    def _step_over(self, grid, limit, ts, xs, zs, conds, unit_rows=True):
        """Jump from the last of the points (ts, xs, zs) (increasing times, conditioning `conds`) past
        the change point ahead; the new time or None.

        The first try goes as far past the estimated point as the start was before it (with the
        closures measured alone: four times as far first, then that); then tries double from the last
        step before the start, up to MAX_GROWTH steps or two output intervals, leaving out (closures
        alone) those that put a stage of the step next to the point. The states take one
        Gauss–Legendre step (`_gauss_step`), its stages' algebraic variables started from the quadratic
        through the last three points. A landing is kept when Newton stayed on that branch at every
        stage and at the landing (the other branch lies O(Δt) away, the prediction O(Δt²)) and the
        conditioning rises there: the point lies behind."""
        t1, x1, z1 = ts[-1], xs[-1], zs[-1]
        h = t1 - ts[-2]
        if h <= 0:
            return None
        t_star = _fold_time(ts, conds)
        spacing = float(np.max(np.diff(grid))) if grid.size > 1 else h
        longest = min(max(MAX_GROWTH * h, MAX_OUTPUT_INTERVALS * spacing), limit - t1)
        # with the closures measured alone the estimate is sharp (the conditioning falls linearly): no
        # stage of the step next to the point (ten parallelograms lost 3e-3 J on a stage 0.4 ms from it);
        # after the mirror point, a landing four times as far past it as the start is before it (the point
        # then lies between the first two stages, 0.13 of the step from each)
        sharp = t_star is not None and self._kinematic_block()[2]
        ahead = [5.0, 2.0] if sharp else [2.0]
        tries = [k * (t_star - t1) for k in ahead if t_star is not None and 0 < k * (t_star - t1) <= longest]
        dt = h
        while dt <= longest:
            if not sharp or np.min(np.abs(t1 + GAUSS_C * dt - t_star)) > 0.1 * dt:
                tries.append(dt)
            dt *= 2
        watched = self._branch_variables()
        rates = [np.asarray(self.dae.ode(t, x, z, self._u_at(t), self.p, self.d)).ravel()
                 for t, x, z in zip(ts[-2:], xs[-2:], zs[-2:])]
        path = CubicHermiteSpline(ts[-2:], xs[-2:], np.array(rates), axis=0)
        predicted = BarycentricInterpolator(ts[-3:], zs[-3:], axis=0)

        def landing(t_b):
            """(x_b, z prediction, z_b) one Gauss–Legendre step past the point, or None when its stages
            left the branch."""
            dt = t_b - t1
            stage_t = t1 + GAUSS_C * dt
            x_b, stage_z, K = self._gauss_step(t1, x1, dt, path.derivative()(stage_t), predicted(stage_t))
            line = z1 + np.outer(stage_t - t1, (z1 - zs[-2]) / h)
            gap = np.abs(stage_z - predicted(stage_t))[:, watched]
            if np.any(gap > 0.5 * np.abs(line - z1)[:, watched] + 1e-8 * (1 + np.abs(stage_z[:, watched]))):
                return None                                        # a stage went to the other branch
            stages = BarycentricInterpolator(GAUSS_C, stage_z, axis=0)
            z_pred = stages(1.0)

            def along(t):
                """(x, z guess) at t inside the step: the collocation polynomial, the stages' z."""
                tau = (t - t1) / dt
                return x1 + dt * _integrated(tau) @ K, stages(tau)
            self._along = along
            try:
                return x_b, z_pred, solve_algebraic(self.dae, t_b, x_b, z_pred, self._u_at(t_b), self.p, self.d)
            except MechnetError:              # stages next to the point carry its noise: the history's quadratic
                z_pred = predicted(t_b)
                return x_b, z_pred, solve_algebraic(self.dae, t_b, x_b, z_pred, self._u_at(t_b), self.p, self.d)

        for dt in tries:
            t_b = t1 + dt
            following = grid[np.searchsorted(grid, t_b)] if t_b <= grid[-1] else t_b
            if following - t_b < 0.01 * dt and following <= limit:
                t_b, dt = following, following - t1      # no sliver of an interval left before an output
            try:
                landed = landing(t_b)
                if landed is None:
                    continue
                x_b, z_pred, z_b = landed
                z_line = z1 + (z1 - zs[-2]) / h * dt
                gap = np.abs(z_b - z_pred)[watched]
                if np.any(gap > 0.5 * np.abs(z_line - z1)[watched] + 1e-8 * (1 + np.abs(z_pred[watched]))):
                    continue                                       # Newton went to the other branch
                t_c = t_b + 0.05 * dt                              # a little further on the step's polynomial
                x_c, z_guess = self._along(t_c)
                z_c = solve_algebraic(self.dae, t_c, x_c, z_guess, self._u_at(t_c), self.p, self.d)
                c_b, c_c = self._conditioning([t_b, t_c], [x_b, x_c], [z_b, z_c], unit_rows)
            except MechnetError:
                continue
            kinematic = self._kinematic_block()[2]
            if c_c <= c_b or c_b < (0.5 * conds[-1] if kinematic else
                                    0.1 * max(conds[-1], RANK_LOSS) if unit_rows else 0.1 * conds[-1]):
                continue                    # not past the point yet, or too near it for the integrator
            j = int(np.argmin(np.abs(ts[:-1] - (t1 - dt))))     # a history point about a step before
            regular = (np.array([ts[j], t1, t_b, t_c]), np.array([xs[j], x1, x_b, x_c]),
                       np.array([zs[j], z1, z_b, z_c]))
            self._bridge(grid, t1, x1, z1, t_b, x_b, z_b, self._along, regular)
            where = f"estimated at t = {t_star:.9g} s; " if t_star is not None else ""
            self.events.append(Event(float(t_b), "change point",
                                     f"constraint Jacobian lost rank (algebraic block conditioning "
                                     f"{conds[-1]:.2g}, {where}passed from t = {t1:.9g} s in one Gauss–Legendre step)"))
            return t_b
        return None

    def _gauss_step(self, t1, x1, dt, rates_guess, z_guess):
        """One step of the 4-stage Gauss–Legendre method (order 8) from (t1, x1) over dt: (x at t1 + dt,
        the stages' algebraic variables, the stages' rates). Its stages lie at 0.07, 0.33, 0.67 and 0.93 of
        the step: a step placed around a change point has none at the point, where the algebraic block
        is singular; the states' error over the step is O(dt⁹), where extrapolating along the rates
        left 0.17 J of 159 at each fold of ten parallelograms. Raises MechnetError when the stage
        equations do not converge."""
        dae, n_s = self.dae, len(GAUSS_C)
        nx, nz = dae.x.numel(), dae.z.numel()
        residual, jacobian = built(dae.info, "_gauss_stages", lambda: _gauss_stage_equations(dae))
        stage_t = t1 + GAUSS_C * dt
        U = np.concatenate([np.ravel(self._u_at(t)) for t in stage_t]) if dae.u.numel() else np.zeros(0)
        w0 = np.concatenate([np.asarray(rates_guess, dtype=float).ravel(), np.asarray(z_guess, dtype=float).ravel()])
        w, r = _newton(residual, jacobian, w0, (t1, dt, x1, U, self.p, self.d))
        if not np.all(np.isfinite(r)) or np.max(np.abs(r)) > 1e-8 * (1.0 + np.max(np.abs(w))):
            raise MechnetError(f"the Gauss step over the change point at t = {t1:g} s did not converge")
        K = w[: n_s * nx].reshape(n_s, nx)
        return x1 + dt * GAUSS_B @ K, w[n_s * nx:].reshape(n_s, nz), K

    def _history(self, pts, xs, zs):
        """The monitor points (pts, xs, zs) preceded by recorded points of the running selection, up to
        HISTORY points with increasing times."""
        keep = [j for j in range(len(pts)) if j == 0 or pts[j] > pts[j - 1]]
        ts, X, Z = list(pts[keep]), list(xs[keep]), list(zs[keep])
        since = self.events[-1].t if self.events else -np.inf   # not across a jump, reset or switch
        for row in self.rows.backwards():
            if len(ts) >= HISTORY or row.dae is not self.dae or row.t < since:
                break
            if row.t < ts[0]:
                ts.insert(0, row.t), X.insert(0, row.x), Z.insert(0, row.z)
        return np.array(ts[-HISTORY:]), np.array(X[-HISTORY:]), np.array(Z[-HISTORY:])

    def _branch_names(self) -> set:
        """Names of the variables that decide the branch: coordinates and speeds (variables with a
        derivative), not forces and accelerations, which change fast near the point."""
        factory = self.cm.selection_factory
        return {factory.names[v] for v in factory.graph.der} if factory is not None else set()

    def _branch_variables(self):
        """Which algebraic variables decide the branch (`_branch_names`); all when none is known."""
        moving = self._branch_names()
        mask = np.array([name in moving for name in self.dae.z_names], dtype=bool)
        return mask if mask.any() else np.ones(len(self.dae.z_names), dtype=bool)

    def _bridge(self, grid, t1, x1, z1, t_b, x_b, z_b, along, regular):
        """Output points inside the step over the change point: the states on the step's collocation
        polynomial (`along`), the algebraic variables solved there when Newton stays on the branch
        (within half the step's change of each coordinate and speed of the guess, as for the landing)
        and the observed coordinates and speeds stay near the cubic through the `regular` points around
        the step (`_CurveAround`). Next to the point this selection's speed formulas divide zero by zero:
        an output 0.2 ms from a fold of ten parallelograms, where Newton failed, carried 4e7 J. An
        output that fails either test records the cubic's values (`Rows.add`, observed given)."""
        inside = grid[(grid > t1) & (grid < t_b)]
        if inside.size:
            watched = self._branch_variables()
            allowed = 0.5 * np.abs(z_b - z1)[watched]
            around = _CurveAround(self, regular)
        for t in inside:
            x, z_guess = along(t)
            try:
                z = solve_algebraic(self.dae, t, x, z_guess, self._u_at(t), self.p, self.d)
                if np.all(np.abs(z - z_guess)[watched] <= allowed + 1e-8 * (1 + np.abs(z_guess[watched]))) \
                        and around.near(t, observe(self.dae, np.array([t]), x.reshape(1, -1), z.reshape(1, -1),
                                                   self.plan, self.p, self.d.reshape(1, -1))[0]):
                    self.x, self.z = x, z
                    self._record(t)
                    continue
            except MechnetError:
                pass
            values = around.at(t, x)
            self.x, self.z = x, values[around.z_cols]
            self.rows.add_row(t, self.x, self.z, self.dae, self.d, observed=values)
        self.x, self.z = x_b.copy(), z_b.copy()
        if np.any(grid == t_b):
            self._record(t_b)                  # a landing on an output time: nothing after records it


class _CurveAround:
    """The observed values of a run's selection on the cubic through regular points (ts, X, Z) around a
    step over a change point: the history point nearest a step before it, the step's start, the landing
    and a point just after it."""

    def __init__(self, run, regular):
        ts, X, Z = regular
        dae, self.run = run.dae, run
        names = dae.observed_names
        around = observe(dae, ts, X, Z, run.plan, run.p, np.tile(run.d, (ts.size, 1)))
        self.curve = BarycentricInterpolator(ts, around, axis=0)
        self.constant = np.all(around == around[1], axis=0)       # kept exactly (a cubic rounds them)
        self.values = around[1]
        column = {n: k for k, n in enumerate(names)}
        self.x_cols = [column[n] for n in dae.x_names]
        self.z_cols = [column[n] for n in dae.z_names]
        self.given = {kind: [(k, column[n]) for k, n in enumerate(group) if n in column]
                      for kind, group in (("u", dae.u_names), ("p", dae.p_names), ("d", dae.d_names))}
        branch = run._branch_names() or set(dae.z_names)
        states = set(dae.x_names)
        # coordinates and speeds, not the states (the collocation polynomial gives those), each within a
        # tenth of its range over the four points: a speed at its turning point changes little across
        # the step and would reject a correct solution against its net change alone
        self.moving = np.array([n in branch and n not in states for n in names], dtype=bool)
        self.tolerance = 0.1 * np.ptp(around, axis=0)[self.moving]

    def near(self, t, y) -> bool:
        """Whether the observed values y at t keep their coordinates and speeds near the cubic."""
        expected = self.curve(t)[self.moving]
        return bool(np.all(np.abs(y[self.moving] - expected) <= self.tolerance + 1e-8 * (1 + np.abs(expected))))

    def at(self, t, x) -> np.ndarray:
        """Every observed value at t: the states x, the inputs, parameters and modes as they are, what stays
        constant around the step as it is, the rest on the cubic."""
        y = np.where(self.constant, self.values, self.curve(t))
        y[self.x_cols] = x
        for kind, values in (("u", self.run._u_at(t)), ("p", self.run.p), ("d", self.run.d)):
            for k, col in self.given[kind]:
                y[col] = values[k]
        return y


def _angles(dae) -> np.ndarray:
    """Which algebraic variables are angles (unit rad)."""
    return np.array([dae.units.get(n) == "rad" for n in dae.z_names], dtype=bool)


def _fold_time(ts, conds):
    """Where the conditioning reaches zero, from its last three values: near a change point it falls
    like c ∝ (t* − t)^k, so w = −dt/d(log c) = (t* − t)/k is linear in t and its root is t*. None
    when the conditioning is not falling."""
    if len(ts) < 3 or not np.all(np.diff(conds[-3:]) < 0) or conds[-1] <= 0:
        return None
    t, logc = np.asarray(ts[-3:], dtype=float), np.log(conds[-3:])
    mid = 0.5 * (t[1:] + t[:-1])
    w = -np.diff(t) / np.diff(logc)
    if w[1] < w[0]:
        return float(mid[1] + w[1] * (mid[1] - mid[0]) / (w[0] - w[1]))
    return float(mid[1] + w[1])            # not yet in the power law: k = 1, a short step


def _integrated_basis(c):
    """P_j(τ) = ∫₀^τ ℓ_j for the Lagrange basis ℓ_j on the nodes c, as polynomial coefficients (rows)."""
    from numpy.polynomial import polynomial as P
    rows = []
    for j in range(len(c)):
        basis = np.array([1.0])
        for m in range(len(c)):
            if m != j:
                basis = P.polymul(basis, np.array([-c[m], 1.0]) / (c[j] - c[m]))
        rows.append(P.polyint(basis))
    return np.array(rows)


def _integrated(tau):
    """[P_j(τ)] for the Gauss nodes: the collocation polynomial x(t1 + τ·dt) = x1 + dt Σ_j P_j(τ) K_j."""
    return np.array([np.polynomial.polynomial.polyval(tau, row) for row in GAUSS_P])


GAUSS_P = _integrated_basis(GAUSS_C)
GAUSS_A = np.array([_integrated(c) for c in GAUSS_C])   # a_ij = P_j(c_i)


def _gauss_stage_equations(dae):
    """Residual and Jacobian of the Gauss–Legendre stage equations in w = (K₁..K₄, Z₁..Z₄), arguments
    (t1, dt, x1, U, p, d): K_i = ode(t_i, X_i, Z_i), alg(t_i, X_i, Z_i) = 0, X_i = x1 + dt Σ a_ij K_j."""
    t, x, z, u, p, d = dae_arguments(dae)
    n_s, nx, nz, nu = len(GAUSS_C), x.numel(), z.numel(), u.numel()
    K, Z = ca.SX.sym("K", nx, n_s), ca.SX.sym("Z", nz, n_s)
    t1, dt, x1, U = ca.SX.sym("t1"), ca.SX.sym("dt"), ca.SX.sym("x1", nx), ca.SX.sym("U", nu * n_s)
    f = ca.Function("f", [t, x, z, u, p, d], [dae.ode(t, x, z, u, p, d), dae.alg(t, x, z, u, p, d)])
    rows_k, rows_z = [], []
    for i in range(n_s):
        X = x1 + dt * ca.mtimes(K, ca.DM(GAUSS_A[i]))
        rate, alg = f(t1 + GAUSS_C[i] * dt, X, Z[:, i], U[i * nu:(i + 1) * nu], p, d)
        rows_k.append(K[:, i] - rate)
        rows_z.append(alg)
    w = ca.vertcat(ca.vec(K), ca.vec(Z))
    return _residual_pair("gauss_stages", w, [t1, dt, x1, U, p, d], ca.vertcat(*rows_k, *rows_z))
