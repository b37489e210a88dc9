"""Dynamic state selection: watch the dependent block, switch states before it turns singular.

Index reduction chooses dummy derivatives at the start point; as a mechanism
moves, that choice can degrade (a pendulum's dependent coordinate near its
turning point). The monitor evaluates, at dense output points, the quality of
the running choice (|det| of the chosen constraint columns over the Hadamard
bound: 1 ideal, 0 singular) against the best choice there; when the best wins
by the hysteresis factor the loop cuts the piece, compiles (or reuses) the
other selection and restarts from the consistent point — a "reselection"
event.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..caches import built
from ..core.errors import MechnetError
from ..numeric import NumpyCall, dense, mapped_in
from .branch import Verdict, check_branch, state_names
from .events import Event
from .initialize import solve_algebraic


class Reselection:
    """Mixin of the simulation loop (`run.Run`): quality along a piece and the switch."""

    def _ratios(self, pts, xs, zs):
        """Conditioning ratio (running / best selection) at each point, and the first point to switch at."""
        n = pts.size
        if self.monitor is None or not self.monitor.alternatives:
            return np.ones(n), None           # nothing to switch to (change points are watched apart)
        U = self._inputs_at(pts)
        # the running choice's quality at every point in one batch; the full comparison with the
        # best choice (a pivoted QR per point) only where a switch is possible (quality below 1/2)
        monitor = self.monitor
        values = np.zeros((n, len(monitor.names)))
        values[:, monitor.factory.watched_indices()] = monitor.watched(self.dae, n)(
            pts.reshape(1, -1), xs.T, zs.T, U, np.tile(self.p.reshape(-1, 1), n),
            np.tile(self.d.reshape(-1, 1), n))[0].T
        levels = monitor.factory.levels_for(monitor.current)
        signed = monitor.factory.quality_batch(levels, values, self.p)
        ratios, signs = np.abs(signed), np.sign(signed)
        signs[signs == 0] = 1.0
        for m in range(n):
            if m > 0 and signs[m] != signs[m - 1]:
                self.refine_at = m - 1        # passed through the singular point between two checks
                return ratios[: m], None
            if ratios[m] >= monitor.HYSTERESIS or m == 0:
                continue
            # a loop's dependent block rarely reaches quality 1/2 even at its best: after a full check
            # that kept the choice, check again only once the running quality has fallen by 10%, or
            # every 16 points (the best choice may have improved meanwhile)
            last = getattr(self, "_last_full_check", None)
            if last is not None and ratios[m] >= 0.9 * last[0] and last[1] < 16:
                self._last_full_check = (last[0], last[1] + 1)
                continue
            quality, switch = monitor.better_at(values[m], probe=True, params=self.p)
            self._last_full_check = (ratios[m], 0)
            if switch:
                if ratios[m - 1] - ratios[m] > 0.25:
                    self.refine_at = m - 1    # monitored too coarsely: look closer before switching
                    return ratios[: m], None
                return ratios[: m + 1], m
        return ratios, None

    def _reselect(self, t):
        """Switch to a better state selection when the running one degrades (hysteresis factor 2).

        Returns the quality ratio (running / best) after the check.
        """
        values = self._observed_at(t)
        quality, switch = self.monitor.better(values, params=self.p)
        if switch is None:
            return quality
        self._switch_selection(t, values, *switch)
        return 1.0

    def _switch_selection(self, t, values, dummies, new_dae, cause):
        """Continue from the point t (observed `values`) with the selection `dummies` (compiled: new_dae)."""
        named = dict(zip(self.dae.observed_names, values))
        x_new = np.array([named.get(n, 0.0) for n in new_dae.x_names])
        z_guess = np.array([named.get(n, 0.0) for n in new_dae.z_names])
        self._use(new_dae)
        self.x = x_new
        self.z = solve_algebraic(new_dae, t, x_new, z_guess, self._u_at(t), self.p, self.d)
        self.monitor.current = dummies
        self._last_full_check = None
        self.events.append(Event(float(t), "reselection", cause))
        if len(self.rows) and self.rows.last.t == t:
            self.rows.replace_last(self.x, self.z, new_dae)


def dae_arguments(dae) -> list:
    """Fresh symbols (t, x, z, u, p, d) shaped like the compiled model's function arguments."""
    return [ca.SX.sym(k, m) for k, m in (("t", 1), ("x", dae.x.numel()), ("z", dae.z.numel()),
                                         ("u", dae.u.numel()), ("p", dae.p.numel()), ("d", dae.d.numel()))]


def _observed_of(dae, names, label) -> ca.Function:
    """The observed values of `names` alone (0 for a name the selection does not observe), as a Function
    of the compiled model's arguments."""
    args = dae_arguments(dae)
    y = dae.observed(*args)
    position = {name: k for k, name in enumerate(dae.observed_names)}
    return ca.Function(label, args, [ca.vertcat(*[y[position[n]] if n in position else ca.SX(0) for n in names])])


class SelectionMonitor:
    """Watches the conditioning of the dependent block and proposes a better selection."""

    HYSTERESIS = 0.5

    def __init__(self, cm, factory, current):
        self.cm, self.factory, self.current = cm, factory, current
        self.names = factory.names
        self.alternatives = True          # False: a single possible choice (only change points to watch)
        self.last_best = 1.0              # the best choice's quality at the last full check

    @classmethod
    def create(cls, cm, dae):
        factory = cm.selection_factory
        if factory is None:
            return None
        index = cm.stages["index"]
        if not factory.can_degrade():
            return None       # constant constraint Jacobians (gears): nothing to watch
        # without an alternative choice of states the monitor still watches for change points
        alternatives = any(len(level.candidates) > len(level.chosen) for level in index.levels)
        current = frozenset(factory.names.index(n) for n in index.dummies)
        if dae is not cm.dae:
            current = next((k for k, v in cm._selections.items() if v is dae), current)
        monitor = cls(cm, factory, current)
        monitor.alternatives = alternatives
        return monitor

    def watched(self, dae, n):
        """The variables the selection depends on (`factory.watched_indices()`), at n points in one call.
        Only these are evaluated, not every observed name; cached per compiled selection and n."""
        single, maps = built(dae.info, "_watched", lambda: (   # per compiled selection, across runs
            _observed_of(dae, [self.names[k] for k in self.factory.watched_indices()], "watched"), {}))
        return mapped_in(maps, single, n)

    def values_at(self, dae, t, x, z, u, p, d) -> np.ndarray:
        """The values of `names` at one point of the running selection `dae` (0 for a name it does not
        observe), without evaluating every observed name; cached per compiled selection."""
        values = built(dae.info, "_selection_values",
                       lambda: NumpyCall(dense(_observed_of(dae, self.names, "selection_values"))))
        return values(t, x, z, u, p, d)[0].ravel()

    def whole_branch(self, values, params) -> Verdict:
        """A selection that holds on the whole branch through this point (`values` follow `names`,
        `values_at`; `branch.py`), the running one if it does: with it this monitor would never act,
        and the run can do without it."""
        resets = {name for dae in (self.cm.dae, *self.cm._selections.values()) for name in reset_states(dae)}
        return check_branch(self.factory, self.current, values, params, self.HYSTERESIS, resets)

    def better(self, observed_values, probe=False, params=None):
        """`better_at` from a vector of every observed value (the compiled model's `observed`)."""
        named = dict(zip(self.cm.dae.observed_names, observed_values))
        return self.better_at(np.array([named.get(n, 0.0) for n in self.names]), probe, params)

    def better_at(self, values, probe=False, params=None):
        """(quality, switch): the running selection's quality in [0, 1] (1: ideal, 0: singular) and
        None, or — when another selection is better by the hysteresis factor — (dummies, compiled
        selection, cause); when probing, just True. `values` follow `names`."""
        memo = {}                              # the Jacobians at this point, shared by the three steps
        try:
            best, levels = self.factory.choose(values, params, memo)
        except MechnetError:
            return None, None
        q_signed = self.factory.quality(self.factory.levels_for(self.current), values, signed=True, params=params,
                                        memo=memo)
        q_now = abs(q_signed)
        if best == self.current:
            self.last_best = q_now
            return q_signed, None
        q_best = self.last_best = self.factory.quality(levels, values, params=params, memo=memo)
        if q_now >= self.HYSTERESIS * q_best:
            return q_signed, None
        if probe:
            return q_signed, True
        try:
            other = self.cm.selection(best)
        except MechnetError:
            return q_signed, None              # that choice cannot hold the model's resets: keep going
        old = state_names(self.factory, self.current)
        new = state_names(self.factory, best)
        cause = (f"dependent block conditioning {q_now:.2g} vs {q_best:.2g}: states "
                 f"{', '.join(old)} -> {', '.join(new)}")
        return q_now, (best, other, cause)


def reset_states(dae) -> tuple:
    """Names of the states some state event of the compiled model sets (its transitions), found once."""
    def find():
        names = set()
        if dae.transition:
            args = dae_arguments(dae)
            for transition in dae.transition:
                x_plus = transition(*args)[0]
                names.update(n for k, n in enumerate(dae.x_names) if not ca.is_equal(x_plus[k], args[1][k], 2))
        return tuple(sorted(names))
    return built(dae.info, "_reset_states", find)
