"""The solution of an optimal control problem: trajectories by name, the controls as exact tables, and
a re-simulation with those controls that says how far the model departs from the transcription."""
from __future__ import annotations

import numpy as np

from ..components.signals import Table
from ..core.requirements import onto_requirements
from ..core.errors import InitializationError
from ..simulate.result import Result


class Solution:
    """`sol.t`, `sol[name]` for every dotted name, `sol.inputs` (tables `cm.simulate` replays exactly),
    `sol.t_final`, `sol.params` (the free parameters), `sol.stats`, `sol.plot()`, `sol.verify()`."""

    def __init__(self, prob, method, values: dict, stats: dict):
        dae = prob.dae
        self.problem, self.method, self.stats = prob, method, stats
        stats["smoothed"] = prob.smoothed          # friction elements posed in their smooth form
        self.success = stats["success"]
        self.t = np.asarray(values["t"], dtype=float).ravel()
        self.t_final = float(np.asarray(values["T"]).ravel()[0])
        p = _onto_requirements(prob, np.asarray(values["p"], dtype=float).ravel())
        self.params = {n: float(p[dae.p_names.index(n)]) for n in prob.free_params}
        self._p = p
        n = self.t.size
        X, Z, U = (np.asarray(values[k], dtype=float).reshape(size, n)
                   for k, size in (("x", dae.x.numel()), ("z", dae.z.numel()), ("u", dae.u.numel())))
        self._x, self._z, self._u = X, Z, U
        d = np.array(dae.d_value, dtype=float)
        observed = dae.observed.map(self.t.size)
        Y = np.asarray(observed(self.t.reshape(1, -1), X, Z, U, np.tile(p.reshape(-1, 1), self.t.size),
                                np.tile(d.reshape(-1, 1), self.t.size)))
        self.result = Result(self.t, Y.T, dae.observed_names, dae.units, dict(stats), X.T, Z.T, dae.x_names,
                             title=f"{prob.cm.name}: optimal control ({type(method).__name__}, N = {method.N})")
        held, self.stats["selection"] = _selection_held(prob, self.t, X, Z, U, p, d)
        if not held:
            self.success = self.stats["success"] = False
        nodes = np.asarray(values["U"], dtype=float).reshape(dae.u.numel(), -1)
        knots = np.linspace(0.0, self.t_final, method.N + 1)
        mode = "hold" if method.controls == "constant" else "linear"
        times = knots[:-1] if mode == "hold" else knots
        self.inputs = {n: Table(times, nodes[k], mode=mode) for k, n in enumerate(dae.u_names)}

    def __getitem__(self, name):
        return self.result[name]

    def __contains__(self, name):
        return name in self.result

    @property
    def names(self):
        return self.result.names

    def plot(self, names=None, **kw):
        """The named trajectories against time, one subplot per unit (`Result.plot`)."""
        return self.result.plot(names or list(self.problem.dae.u_names) + list(self.problem.dae.x_names[:6]), **kw)

    def verify(self, rtol: float = 1e-10, atol: float = 1e-12, **simulate_kw) -> dict:
        """Re-simulate from the solution's start with its controls (`sol.inputs`, exact piecewise tables)
        and free parameters: {"max_deviation": largest |state difference| at the solution's times,
        "worst": its state, "deviation": per state, "result": the simulation}."""
        prob = self.problem
        dae = prob.dae
        initial = {n: float(v) for n, v in zip(dae.x_names + dae.z_names,
                                                 np.concatenate([self._x[:, 0], self._z[:, 0]]))}
        run = {"t_out": self.t, "inputs": self.inputs, "rtol": rtol, "atol": atol,
               "params": {n: float(self._p[k]) for k, n in enumerate(dae.p_names)}, **simulate_kw}
        try:       # the problem's start values, its solution's start as the guess (the same branch)
            res = prob.cm.simulate(self.t_final, start=prob.start, guess=initial, **run)
        except InitializationError:      # the start was optimised: the solution's states fix it
            res = prob.cm.simulate(self.t_final, start={n: initial[n] for n in dae.x_names}, **run)
        # the run's times hold the solution's and the tables' knots (time events): compare at the former
        scale = max(1.0, abs(self.t_final))
        rows = np.searchsorted(res.t, self.t - 1e-12 * scale)
        found = (rows < res.t.size) & (np.abs(res.t[np.minimum(rows, res.t.size - 1)] - self.t) <= 1e-9 * scale)
        rows, cols = rows[found], np.flatnonzero(found)
        deviation = {n: float(np.max(np.abs(res[n][rows] - self._x[j, cols]), initial=0.0))
                     for j, n in enumerate(dae.x_names)}
        worst = max(deviation, key=deviation.get) if deviation else None
        return {"max_deviation": deviation[worst] if worst else 0.0, "worst": worst, "deviation": deviation,
                "result": res, "complete": res.success and bool(found.all())}

    def __repr__(self):
        status = "ok" if self.success else \
            f"FAILED ({self.stats['status'] if self.stats['status'] != 'Solve_Succeeded' else self.stats['selection']})"
        return (f"<Solution {status}: objective {self.stats['objective']:.6g}, t_final = {self.t_final:g} s, "
                f"{self.stats['iterations']} iterations>")


def _selection_held(prob, t, X, Z, U, p, d) -> tuple[bool, str]:
    """The transcription integrates the start point's choice of states (`cm.dae`); at every point of the
    solution the simulator's monitor must find no better choice by its hysteresis factor (a loop near a
    singular position: the dependent coordinates there are ill-conditioned functions of the states).
    (held, what was found)."""
    from ..simulate.reselection import SelectionMonitor
    monitor = SelectionMonitor.create(prob.cm, prob.dae)
    if monitor is None:
        return True, "no state selection to watch (a tree, or constant constraint Jacobians)"
    worst = (1.0, None)
    for k, tk in enumerate(t):
        values = monitor.values_at(prob.dae, tk, X[:, k], Z[:, k], U[:, k], p, d)
        quality, switch = monitor.better_at(values, probe=True, params=p)
        if quality is not None and abs(quality) < worst[0]:
            worst = (abs(quality), tk)
        if switch:
            return False, (f"degraded at t = {tk:.6g} s (conditioning {abs(quality):.2g}): another choice of "
                           f"states is better there; the solution cannot be trusted past it")
    return True, f"held (lowest conditioning {worst[0]:.2g}, at t = {worst[1]:.6g} s)" if worst[1] is not None \
        else "held"


def _onto_requirements(prob, p: np.ndarray) -> np.ndarray:
    """The parameter vector with the freed parameters moved onto their own check's range and the
    requirements between parameters where they leave them by no more than 1e-6 (relative, absolute
    below 1): IPOPT keeps bounds and constraints to its relaxation and tolerance (a freed mu_k ended at
    −7.5e-9 for a bound of 0), and cm.simulate checks them. A strict bound becomes the transcription's
    (1e-12 inside); a move that would leave another range is not made (the replay then names it)."""
    if not prob.free_params:
        return p
    names = prob.dae.p_names
    values = dict(zip(names, p.tolist()))
    ranges = {name: _value_range(prob, name) for name in prob.free_params}
    for name, value_range in ranges.items():
        if value_range is not None:
            values[name] = _into(values[name], *value_range)
    moved = onto_requirements(prob.dae.info.get("parameter_requirements", ()), values, set(prob.free_params))
    for name, value_range in ranges.items():
        if value_range is not None and _into(moved[name], *value_range) != moved[name]:
            moved[name] = values[name]
    return np.array([moved[n] for n in names], dtype=float)


def _value_range(prob, name):
    declaration = prob.dae.info.get("parameter_checks", {}).get(name, (None,))[0]
    return getattr(getattr(declaration, "check", None), "value_range", None)


def _into(value: float, lower: float, strict: bool, upper: float) -> float:
    """value moved into [lower, upper] when it is outside by at most 1e-6 (relative, absolute below 1); a
    strict lower bound 1e-12 inside, as the transcription bounds it."""
    slack = 1e-6 * max(1.0, abs(value))
    floor = lower + 1e-12 * max(1.0, abs(lower)) if strict else lower
    if floor - slack <= value < floor:
        return floor
    if upper < value <= upper + slack:
        return upper
    return value
