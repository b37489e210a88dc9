"""The solution of an optimal control problem: trajectories by name, the controls as exact tables, and
a re-simulation with those controls that says how far the model departs from the transcription."""
from __future__ import annotations

import numpy as np

from ..components.signals import Table
from ..simulate.result import Result


class Solution:
    """`sol.t`, `sol[name]` for every dotted name, `sol.inputs` (tables `cm.simulate` replays exactly),
    `sol.t_final`, `sol.params` (the free parameters), `sol.stats`, `sol.plot()`, `sol.verify()`."""

    def __init__(self, prob, method, values: dict, stats: dict):
        dae = prob.dae
        self.problem, self.method, self.stats = prob, method, stats
        self.success = stats["success"]
        self.t = np.asarray(values["t"], dtype=float).ravel()
        self.t_final = float(np.asarray(values["T"]).ravel()[0])
        p = np.asarray(values["p"], dtype=float).ravel()
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
        return self.result.plot(names or list(self.problem.dae.u_names) + list(self.problem.dae.x_names[:4]), **kw)

    def verify(self, rtol: float = 1e-10, atol: float = 1e-12, **simulate_kw) -> dict:
        """Re-simulate from the solution's start with its controls (`sol.inputs`, exact piecewise tables)
        and free parameters: {"max_deviation": largest |state difference| at the solution's times,
        "worst": its state, "deviation": per state, "result": the simulation}."""
        prob = self.problem
        dae = prob.dae
        start = {n: float(v) for n, v in zip(dae.x_names, self._x[:, 0])}
        res = prob.cm.simulate(self.t_final, t_out=self.t, inputs=self.inputs, start=start,
                               params={**{n: float(self._p[k]) for k, n in enumerate(dae.p_names)}},
                               rtol=rtol, atol=atol, **simulate_kw)
        k = min(res.t.size, self.t.size)
        deviation = {n: float(np.max(np.abs(res[n][:k] - self._x[j, :k]))) for j, n in enumerate(dae.x_names)}
        worst = max(deviation, key=deviation.get) if deviation else None
        return {"max_deviation": deviation[worst] if worst else 0.0, "worst": worst, "deviation": deviation,
                "result": res, "complete": res.success and k == self.t.size}

    def __repr__(self):
        status = "ok" if self.success else f"FAILED ({self.stats['status']})"
        return (f"<Solution {status}: objective {self.stats['objective']:.6g}, t_final = {self.t_final:g} s, "
                f"{self.stats['iterations']} iterations>")

