"""Monitored integration: long pieces with dense monitor points, cut where the state selection degrades,
a change point lies ahead or a zero crossing is found (a mixin of the simulation loop, `run.Run`)."""
from __future__ import annotations

import numpy as np

from .winding import WINDING_POINTS

SOLVER_STEPS_PER_CHECK = 16.0   # the state-selection monitor checks its quality about this often
HORIZON_REACH = 2.0             # a piece aimed at a predicted switch reaches this many times as far,
PIECE_GROWTH = 4                # and one that needed no cut makes the next this many times longer (both
                                # while the run has had no switch, change point or state event)
MAX_PIECE_POINTS = 20_000       # monitor points in one piece at most
MONITOR_STEPS = 2.0             # with zero functions: monitor points about this many solver steps apart,
MONITOR_REDO = 3.0              # and a piece whose points lie more steps apart than this is integrated again
                                # finer before "no crossing" is accepted (`state_events.py`: why that makes
                                # detection a guarantee)


class MonitoredPieces:
    """Mixin of the simulation loop (`run.Run`): the monitored piece loop and its integrator calls."""

    def _integrate_monitored(self, grid, event_at):
        """Integrate long pieces with dense monitor points, switching states where a block degrades.

        The integrator reports the solution at extra monitor points inside each
        piece (interpolated, no restart). After the piece, the conditioning of
        the running selection is evaluated at every monitor point; at the
        first point where a better selection wins by the hysteresis factor, the
        piece is cut, the states are re-chosen and the integrator restarts —
        re-initialised — there (a "reselection" event). Monitor density adapts
        so the running selection's quality moves by at most ~0.05 between points. While
        nothing has happened, a piece that needed no cut makes the next PIECE_GROWTH times
        longer, up to the rest of the run: each restart costs IDAS ~30 ramp-up steps, so the
        benchmark's loops run in 5 calls (were 11–14). A failed piece is retried at half its
        length, and at most half-way to the last point it reached. A piece holds at most MAX_PIECE_POINTS
        monitor points (memory: the monitor batches them all).

        With zero functions the monitor spacing also follows the solver: at most MONITOR_STEPS mean
        solver steps (of the last piece) apart, and a piece found afterwards to have its points more
        than MONITOR_REDO of its own mean steps apart is integrated again at that spacing before its
        crossings are searched (the first piece, or one where the solution quickens). Where that needs
        more than MAX_PIECE_POINTS points the piece ends earlier, inside an output interval if need be.
        """
        n_int = grid.size - 1
        # pieces ending at a time event, or at the end of the run (a step exactly there takes effect after
        # the run), are judged at the left limits of the inputs and signals
        self._time_event_times = frozenset(event_at) | {float(grid[-1])}
        self._run_span = float(grid[-1] - grid[0])
        longest = n_int
        per_piece = 1
        density = 4                                   # monitor points per output interval
        fraction = 1.0                                # of the first interval, when pieces must be short
        grid_set = set(grid.tolist())
        spacing = np.inf                              # the longest monitor interval zero functions allow
        reach = np.inf                                # how far a piece reaches (after state events)
        redone = 0                                    # times the current piece was integrated again finer
        t_cur, k = grid[0], 0                         # current time; next output index is k + 1
        if not self._arm(t_cur):                      # a condition crossing at the start fired at once
            return
        while k < n_int:
            per_piece = max(1, min(per_piece, MAX_PIECE_POINTS // density))
            k_end = min(k + per_piece, n_int)
            for j in range(k + 1, k_end + 1):
                if grid[j] in event_at:
                    k_end = j
                    break
            first_end = t_cur + fraction * (grid[k + 1] - t_cur)
            starts = np.concatenate([[t_cur], grid[k + 1: k_end]])
            ends = np.concatenate([[first_end], grid[k + 2: k_end + 1]])
            # a periodic state winds at most TURN_LIMIT per piece, with points at most 1/WINDING_POINTS of
            # that apart (`Run._segment`: the round-off of large angles, IDAS's initial-value search)
            wind = self._winding_reach(t_cur)
            pts, is_output, span_at = _monitor_points(t_cur, starts, ends, density,
                                                      min(spacing, wind / WINDING_POINTS), grid[k + 1], grid_set,
                                                      t_cur + min(reach, wind))
            ok, message, xs, zs = self._dense(pts, budgeted=per_piece > 1 or fraction < 1)
            if ok and self.dae.zero_labels and redone < 3:
                # coarser than the solver's own steps, or than the zero functions' own rates allow:
                # integrate again finer before searching crossings
                h_solver, widest = self._mean_step, np.max(np.diff(pts))
                allowed = self._zero_spacing(pts, xs, zs)
                if h_solver > 0 and widest > MONITOR_REDO * h_solver:
                    spacing, redone = min(MONITOR_STEPS * h_solver, allowed), redone + 1
                    continue
                if widest > 1.5 * allowed:
                    spacing, redone = allowed, redone + 1
                    continue
            redone = 0
            t_next = self._step_over_from(t_cur, grid) if not ok else None
            if t_next is not None:                    # failed at a change point: shorter pieces cannot help
                t_cur, per_piece, fraction = t_next, 1, 1.0
                k = int(np.searchsorted(grid, t_cur, side="right")) - 1
                continue
            if not ok and per_piece > 1:
                # maybe a switch was due inside: look closer. Halve, and end at most half-way to the
                # last point the failed call reached (from its statistics): a piece ending just before
                # it failed again on the triple rocker (the solver crawls for a while before it gives up)
                reached = int(np.searchsorted(grid, self._failed_at, side="left")) - 1 - k \
                    if self._failed_at is not None else 0
                per_piece = max(1, min(per_piece // 2, reached // 2)) if reached > 0 else per_piece // 2
                continue
            if not ok and (self.monitor is not None or self.dae.zero_labels) and fraction > 1e-3:
                # a switch due within this interval, or monitor points too far apart for the solver's step
                # limit (zero functions: `_recover` would integrate on without looking for crossings):
                # take part of it
                fraction /= 4
                density = min(256, density * 2)
                continue
            if not ok:
                if self._recover(np.concatenate([[t_cur], grid[k + 1: k_end + 1]]), message):
                    t_next = self.rows.last.t          # integrated after all (one output interval at a time)
                else:
                    t_next = self._pass_change_point(grid)
                if t_next is None:
                    return
                t_cur, per_piece, fraction = t_next, 1, 1.0
                k = int(np.searchsorted(grid, t_cur, side="right")) - 1
                continue
            self.refine_at = None
            ratios, switch_at = self._ratios(pts, xs, zs)
            self._last_conditioning = None
            found = self._first_fold(pts, xs, zs) if self.refine_at is None else None
            fold, conds = found if found is not None else (None, None)
            before = [j for j in range(fold) if pts[j] < pts[fold]] if fold is not None else []
            crossing = None
            if before and pts[fold] > t_cur and (switch_at is None or fold <= switch_at):
                # a zero crossing before the change point comes first (and the functions are armed at it)
                crossing = self._first_crossing(pts, xs, zs, fold)
            if crossing is None and self.failure is None and before and pts[fold] > t_cur \
                    and (switch_at is None or fold <= switch_at):
                # a change point ahead: keep the piece up to it, then step over it (change_points.py)
                for m in range(1, fold + 1):
                    if is_output[m]:
                        self.x, self.z = xs[m], zs[m]
                        self._record(pts[m])
                self.x, self.z = xs[fold].copy(), zs[fold].copy()
                ts, xh, zh = self._history(pts[: fold + 1], xs[: fold + 1], zs[: fold + 1])
                t_b = self._step_over(grid, grid[-1], ts, xh, zh, self._conditioning(ts, xh, zh))
                if t_b is None:                       # not passed from here: look again only much closer
                    self._fold_floor = conds[fold] / 10
                t_cur, per_piece, fraction = (t_b if t_b is not None else pts[fold]), 1, 1.0
                k = int(np.searchsorted(grid, t_cur, side="right")) - 1
                continue
            limit = switch_at if self.refine_at is None else self.refine_at
            if crossing is None and self.failure is None:
                crossing = self._first_crossing(pts, xs, zs, limit)
            if crossing is not None:
                switch_at = None
            if self.failure is not None:              # the crossing search failed: keep up to its start
                for m in range(1, crossing + 1):
                    if is_output[m]:
                        self.x, self.z = xs[m], zs[m]
                        self._record(pts[m])
                return
            if self.refine_at is not None and crossing is None:
                # the monitor was too coarse for this stretch: keep what is safe, look closer from there
                stop = self.refine_at
                density = min(1024, density * 4)
                per_piece = 1
                if stop == 0:
                    fraction = max(fraction / 4, 1e-6)
                    continue
            else:
                stop = crossing if crossing is not None else (switch_at if switch_at is not None else len(pts) - 1)
            fraction = 1.0
            for m in range(1, stop + 1):
                if is_output[m]:
                    self.x, self.z = xs[m], zs[m]
                    self._record(pts[m])
            self.x, self.z = xs[stop].copy(), zs[stop].copy()
            t_cur = pts[stop]
            if crossing is not None:
                t_cur = self._handle_event(pts[stop], xs[stop].copy(), zs[stop].copy(), pts[stop + 1])
                if self.failure is not None:
                    return
                self._check_accumulation()
                if self.failure is not None:
                    return
                if self._resting is not None:
                    t_cur = self._rest_at_accumulation(t_cur, grid, event_at)
                per_piece = 1
                # the next piece reaches twice as far as the last gap between state events (not to the end
                # of a long output interval, integrated again after every event), growing while quiet
                times = [e.t for e in self.events if e.kind == "state" and e.t < t_cur]
                reach = 2.0 * (t_cur - (times[-1] if times else grid[0]))
                reach = reach if reach > 0 else np.inf
            else:
                reach *= PIECE_GROWTH
            k = int(np.searchsorted(grid, t_cur, side="right")) - 1
            if t_cur == grid[k] and k > 0 and grid[k] in event_at:
                self._restart_at(grid[k], event_at[grid[k]])
                if self.failure is not None:
                    return
            if switch_at is not None:
                self._reselect(t_cur)
                # a switch cut the piece: what came after it was wasted, so aim shorter next time
                per_piece = max(1, min(per_piece, int(np.ceil(span_at[stop] * 1.5))))
            else:
                # while nothing but time events has happened, pieces grow fast and far (a mechanism that
                # never switches pays few restarts); once the run has switched, stepped over a change
                # point or stopped at a state event, more will likely come: pieces grow by 2 up to a fifth
                # of the run and aim at the straight-line horizon, so little is integrated past each
                # (the Cartesian pendulum's 40 switches took 78 % more steps with fast growth)
                quiet = all(e.kind == "time" for e in self.events)
                factor = HORIZON_REACH if quiet else 1.0        # of the straight-line horizon (below)
                per_piece = min(longest, PIECE_GROWTH * per_piece) if quiet else \
                    min(max(1, n_int // 5), 2 * per_piece)
                if self.monitor is not None and stop >= 2:
                    # aim the next piece to end near the predicted switch: the quality falling to 0.9× the
                    # hysteresis share of the best choice's quality at the last full check (~0.45 when
                    # the best is ideal; a loop's choices all sit lower). The straight line through the
                    # last slope runs out early when the quality oscillates with the crank (a switch then
                    # rarely comes): the piece reaches HORIZON_REACH times as far, so a wrong guess costs
                    # at most that much integration past a switch, a too-short one a restart
                    slope = (ratios[stop] - ratios[stop - 1]) / max(pts[stop] - pts[stop - 1], 1e-300)
                    switch_level = 0.9 * self.monitor.HYSTERESIS * self.monitor.last_best
                    if slope < 0 and ratios[stop] > switch_level:
                        horizon = factor * (ratios[stop] - switch_level) / -slope
                        per_piece = int(min(per_piece, max(1, horizon // (grid[1] - grid[0]))))
                ahead = self._fold_ahead(pts[: stop + 1])
                if ahead is not None and ahead > t_cur:
                    # a change point ahead: end the next piece half-way to it (an integrator running
                    # into the rank loss crawls to its step limit before it fails)
                    halfway = 0.5 * (ahead - t_cur)
                    per_piece = int(min(per_piece, max(1, halfway // (grid[1] - grid[0]))))
                    if k + 1 < grid.size and halfway < grid[k + 1] - t_cur:
                        fraction = max(halfway / (grid[k + 1] - t_cur), 1e-3)
            steps = np.abs(np.diff(ratios[: stop + 1])) if stop > 0 else np.zeros(1)
            worst = float(np.max(steps)) if steps.size else 0.0
            if worst > 0.05 and density < 256:
                density *= 2
            elif worst < 0.01 and density > 1 and self.monitor is not None:
                density //= 2
            # never coarser than about MONITOR_STEPS solver steps with zero crossings to find (what the
            # solver resolves, the crossing search sees: `spacing`, in seconds, capped per piece not per
            # output interval), or SOLVER_STEPS_PER_CHECK for the quality alone
            h_solver = getattr(self, "_mean_step", 0.0)
            if np.isfinite(h_solver) and h_solver > 0:
                if self.dae.zero_labels:
                    spacing = MONITOR_STEPS * h_solver
                if self.monitor is not None:
                    density = int(min(1024, max(density, np.ceil((grid[1] - grid[0]) /
                                                                  (SOLVER_STEPS_PER_CHECK * h_solver)))))

    def _dense(self, pts, budgeted=False):
        """One integrator call over pts (unrecorded); returns the states at every point. `budgeted`:
        with the step limit of `_step_budget`."""
        t0, h = pts[0], pts[-1] - pts[0]
        tau = tuple(float(v) for v in np.round((pts[1:] - t0) / h, 12))   # 12 digits: grid round-off shares keys
        budget = self._step_budget(float(np.max(np.diff(pts)))) if budgeted else None
        self._failed_at = None
        try:
            self._renormalise()
            ox, oz = self._turns(self.x, self.z)
            s, out = self._call(t0, h, lambda: self.integrators.get(tau, budget), (self.x - ox) / self.xn,
                                (self.z - oz) / self.zn if self.zn.size else np.zeros(0), self.pvec(t0, h),
                                budgeted=budget is not None and budget < self.integrators.max_steps)
        except RuntimeError as exc:
            # after a failure CasADi's `tcur` is the last output time the solver reached (normalised; 0
            # when it failed before the first): the failure lies after it
            reached = getattr(exc, "stats", {}).get("tcur", float("nan"))
            self._failed_at = t0 + reached * h if np.isfinite(reached) and 0 < reached < 1 else None
            return False, str(exc), None, None
        self._count(s, h)
        # the mean step of this piece (the last step alone can be tiny: a restart, an output time)
        self._mean_step = h / max(int(s.get("nsteps", 0)), 1)
        xf = np.asarray(out["xf"]).reshape(self.xn.size, -1).T * self.xn + ox
        zf = (np.asarray(out["zf"]).reshape(self.zn.size, -1).T * self.zn + oz) if self.zn.size \
            else np.zeros((xf.shape[0], 0))
        return True, "", np.vstack([self.x, xf]), np.vstack([self.z.reshape(1, -1), zf])

    def _step_budget(self, gap):
        """Step limit of a monitored piece whose monitor points lie at most `gap` apart (SUNDIALS counts
        steps per output time): 8× the steps the run has needed per second so far over that gap (at
        least 1024, a power of two, below max_steps). A long piece that runs into a change point the
        monitor did not foresee then fails after about a thousand steps per monitor interval instead
        of crawling to max_steps (0.7 s each on the parallelogram); it is retried shorter, and a piece
        of one output interval runs without the limit."""
        steps, t_done = self.stats["nsteps"], (self.rows.last.t - self.rows.first_time) \
            if len(self.rows) > 1 else 0.0
        if steps < 100 or t_done <= 0:
            return None
        budget = 2 ** int(np.ceil(np.log2(max(1024.0, 8.0 * steps / t_done * gap))))
        return budget if budget < self.settings[4] else None


def _monitor_points(t_cur, starts, ends, density, spacing, next_output, grid_set, t_reach=np.inf):
    """The monitor points of a piece over the spans [starts, ends] (output intervals; the first may start
    or end inside one), up to t_reach at most: at least `density` per span, and at most `spacing` s apart
    (per span a power of two, so integrators are reused). Over MAX_PIECE_POINTS the piece ends earlier:
    after fewer spans, or inside its first span. Returns the points (t_cur first), which of them are
    output times, and where each lies in spans (2.5: half-way through the third)."""
    if t_reach < ends[-1]:
        keep = max(1, int(np.searchsorted(starts, t_reach, side="left")))
        starts, ends = starts[:keep].copy(), ends[:keep].copy()
        ends[-1] = min(ends[-1], max(t_reach, starts[-1] + 1e-3 * (ends[-1] - starts[-1])))
    counts = np.full(starts.size, density, dtype=np.int64)
    if np.isfinite(spacing) and spacing > 0:
        need = np.ceil((ends - starts) / spacing)
        counts = np.maximum(counts, 2 ** np.ceil(np.log2(np.maximum(need, 1.0))).astype(np.int64))
    total = np.cumsum(counts)
    keep = max(1, int(np.searchsorted(total, MAX_PIECE_POINTS, side="right")))
    starts, ends, counts = starts[:keep].copy(), ends[:keep].copy(), counts[:keep]
    if counts[0] > MAX_PIECE_POINTS:              # one span is too much: the piece ends inside it
        n = 2 ** int(np.floor(np.log2(MAX_PIECE_POINTS)))
        ends[0] = starts[0] + (ends[0] - starts[0]) * n / counts[0]
        counts[0] = n
    parts, is_output, span_at = [np.array([t_cur])], [False], [np.zeros(1)]
    for j, (a, b, c) in enumerate(zip(starts, ends, counts)):
        inner = a + (b - a) * np.arange(1, c + 1) / c
        inner[-1] = b                             # ends exactly on the output times
        parts.append(inner)
        is_output.extend([False] * (c - 1) + [bool(b == next_output or b in grid_set)])
        span_at.append(j + np.arange(1, c + 1) / c)
    return np.concatenate(parts), is_output, np.concatenate(span_at)
