"""`cm.prepare`: one simulation's settings fixed, run again and again (an optimiser's or a study's calls
with new parameters or start values) without `cm.simulate`'s fixed cost.

`cm.simulate` spends about 0.3 ms per call beyond the integrator on a small model (docs/benchmarks.md,
"fixed cost"): checking arguments, planning inputs and output times, choosing the method, setting up the
run loop. A prepared run does that once, in its first call, which is `cm.simulate` itself. When that
run was one integrator call over the whole grid — no event of any kind, no selection monitor, no
quaternion, no angle winding further than one call may take it — later calls repeat just that call:
the start (kept while the parameters and start values stay the same), one integrator call from it,
and the Result. Wherever the run loop would act (the call fails, turns stiff, or any of the above),
the call is `cm.simulate` with the same arguments. Either way a call returns the numbers
`cm.simulate` returns.
"""
from __future__ import annotations

import copy
import inspect
import time as _time

import numpy as np

from ..core.arguments import mapping
from ..core.errors import MechnetError
from ..interrupts import Interrupted, interrupted, watched
from ..solver_output import captured
from .integrator import (TEMPLATE, _check_requirements, _resolve_params, assemble, interruption, simulate,
                         start_values)
from .initialize import initialize, ready_to_integrate
from .rows import Rows
from .run import STIFF_MIN_STEPS, STIFF_SHARE
from .solvers import SolverFailure, call
from .winding import turns_of, whole_turns, winding_reach


PER_CALL = ("params", "start", "guess", "continue_from")      # (continue_from: not at all)
SETTINGS = tuple(n for n in inspect.signature(simulate).parameters if n not in ("cm", "t_end"))


class PreparedRun:
    """`cm.simulate(t_end, **settings)` as a function of the parameters and start values (`cm.prepare`).
    The first call that succeeds decides the path for every later one: a first run the loop had to
    split or stop (a start spun past the winding reach, an event) keeps every call on `cm.simulate`."""

    def __init__(self, cm, t_end: float, settings: dict):
        for name in settings:
            if name == "continue_from":
                raise MechnetError("prepare(..., continue_from=...): a prepared run starts where its settings say; "
                                   "continue a run with cm.simulate(t_end, continue_from=res)")
            if name in PER_CALL:
                raise MechnetError(f"prepare(..., {name}=...): {name} changes per call; give it to the prepared "
                                   f"run: run = cm.prepare(t_end, ...); run({name}=...)")
            if name not in SETTINGS:
                settings_ = ", ".join(n for n in SETTINGS if n not in PER_CALL)
                raise MechnetError(f"prepare(..., {name}=...): no such setting of cm.simulate; "
                                   f"the settings are {settings_}")
        # the settings as they are now: a list or table changed later must not reach only some calls
        self.cm, self.t_end, self.settings = cm, t_end, {k: _copied(v) for k, v in settings.items()}
        self._plain = None                  # what a plain run repeats, once a first call has shown one
        self._decided = False

    def __getstate__(self):                 # in another process the first call decides again
        return {"cm": self.cm, "t_end": self.t_end, "settings": self.settings, "_plain": None, "_decided": False}

    @watched("prepared run")
    def __call__(self, params: dict | None = None, start: dict | None = None, guess: dict | None = None,
                 **other):
        """The Result of `cm.simulate(t_end, params=params, start=start, guess=guess, **settings)`. Ctrl-C
        raises `mechnet.Interrupted` with the partial result, as `cm.simulate` does. Every other setting
        (inputs, rtol, ...) is fixed when the run is prepared."""
        if other:
            names = ", ".join(other)
            raise MechnetError(f"a prepared run takes params, start and guess per call; {names} is fixed when "
                               f"it is prepared: cm.prepare(t_end, {next(iter(other))}=...)")
        if self._plain is not None:
            result = self._plain.run(params, start, guess)
            if result is not None:
                return result
        if self._decided:
            return simulate(self.cm, self.t_end, params=params, start=start, guess=guess, **self.settings)
        template = {}
        token = TEMPLATE.set(template)
        try:
            result = simulate(self.cm, self.t_end, params=params, start=start, guess=guess, **self.settings)
        finally:
            TEMPLATE.reset(token)
        if result.failure is None:             # (a failed first call says nothing of the others)
            self._plain = PlainRun.from_template(self.cm, template)
            self._decided = True
        return result

    @property
    def plain(self) -> bool:
        """Whether later calls repeat one integrator call (None until a first call succeeded)."""
        return None if not self._decided else self._plain is not None


def _copied(value):
    """A setting as it is now (a function or an object that cannot be copied: itself)."""
    try:
        return value if callable(value) else copy.deepcopy(value)
    except Exception:                          # noqa: BLE001 - whatever the object refuses, keep it
        return value


class PlainRun:
    """The one integrator call a plain run made, ready to repeat from other parameters and starts."""

    def __init__(self, cm, template):
        self.cm = cm
        self.dae, self.plan = template["dae"], template["plan"]
        self.grid = np.array(template["grid"], dtype=float)     # (a t_out array of the caller's, copied)
        self.d, self.choice = template["d"], template["choice"]
        self.t_start, self.rtol, self.atol, self.max_steps, self.steady_state = template["settings"]
        run = template["run"]
        self.integrators = run.integrators      # (its integrators live in each thread's cache: thread-safe)
        self.points = tuple(np.asarray(self.grid, dtype=float).tolist())
        self.xn, self.zn = run.xn, run.zn
        self.stats = {k: v for k, v in run.stats.items() if k in ("method", "method_reason", "selection")}
        # (parameters and starts, (the start found, the call's parameter vector, scaled start, whole turns)): one
        # reference, swapped whole (threads share a prepared run)
        self._start = (None, (None,) * 6)

    @classmethod
    def from_template(cls, cm, template) -> PlainRun | None:
        """The plain run the first call made, or None when its run loop did more than one call."""
        run = template.get("run")
        if run is None:
            return None
        dae = template["dae"]
        plain = (run.failure is None and not run.events and not template["events"] and run.monitor is None
                 and not dae.zero_labels and not run.quaternions and not run.plan.varying
                 and run.stats["segments"] == 1 and dae.x.numel() > 0
                 and len(run.rows.blocks) == 2 and run.choice == template["choice"]
                 and "selection" not in run.stats)     # (no branch verdict, which parameters could change)
        return cls(cm, template) if plain else None

    def _u_at(self, t):
        """The inputs at t (`Run._u_at`)."""
        return self.plan.at(t)[:, 0]

    def run(self, params, start, guess):
        """The Result, or None when the run loop is needed (the caller then simulates in full)."""
        dae, plan = self.dae, self.plan
        params, start = mapping(params, "simulate(params=...)"), mapping(start, "simulate(start=...)")
        guess = mapping(guess, "simulate(guess=...)")
        p = _resolve_params(dae, params)
        d, starts = start_values(dae, start, guess)
        if d.tobytes() != self.d.tobytes():
            return None                          # other modes: the run loop decides again
        wall = _time.perf_counter()
        key = (p.tobytes(), tuple(sorted(starts.items())), tuple(sorted((guess or {}).items())))
        known, (init, pvec, xs, zs, ox, oz) = self._start
        t0, h = self.grid[0], self.grid[-1] - self.grid[0]
        if key != known:
            init = initialize(dae, self.t_start, plan.constant, p, starts, guess or {}, self.steady_state, d)
            init = ready_to_integrate(dae, self.t_start, init, plan.constant, p, d)
            _check_requirements(dae, self.t_start, init, plan, p, d, self.rtol, self.atol)
            if t0 + winding_reach(dae, t0, init.x, init.z, self._u_at, p, d) < self.grid[-1]:
                return None                      # a coordinate winds too far for one call: the run loop splits it
            px, pz = whole_turns(dae)            # (the whole turns are left out of the call, as `Run._attempt` does)
            ox, oz = turns_of(init.x, px), turns_of(init.z, pz)
            pvec = np.concatenate([plan.constant, p, d, [t0, h], plan.table_data(t0)])
            xs = (init.x - ox) / self.xn
            zs = (init.z - oz) / self.zn if self.zn.size else np.zeros(0)
            self._start = (key, (init, pvec, xs, zs, ox, oz))
        with captured() as messages:
            try:
                stats, out = call(self.integrators.get_real(self.points), xs, zs, pvec)
            except SolverFailure as failure:
                if not interrupted():
                    return None
                stats, out = failure.stats, failure.outputs     # Ctrl-C: the output times reached
        stopped = interrupted()
        if self.choice.fallback is not None and not stopped:
            steps, failures = int(stats.get("nsteps", 0)), int(stats.get("nncfails", 0))
            if steps >= STIFF_MIN_STEPS and failures >= STIFF_SHARE * steps:
                return None                      # stiff under these parameters: the run loop switches
        xf = np.asarray(out["xf"]).reshape(self.xn.size, -1).T * self.xn + ox
        zf = (np.asarray(out["zf"]).reshape(self.zn.size, -1).T * self.zn + oz) if self.zn.size \
            else np.zeros((xf.shape[0], 0))
        reached = np.isfinite(xf).all(axis=1) & np.isfinite(zf).all(axis=1) if stopped else np.ones(1, dtype=bool)
        n = xf.shape[0] if reached.all() else int(np.argmin(reached))
        outcome = _Outcome(self, d, stats, h)
        outcome.rows.add_row(t0, init.x, init.z, dae, d)
        outcome.rows.add(self.grid[1:][:n], xf[:n], zf[:n], dae, d)
        if stopped:
            outcome.failure = interruption(outcome)
            raise Interrupted("prepared run", assemble(self.cm, dae, outcome, wall, messages, init, plan, p))
        return assemble(self.cm, dae, outcome, wall, messages, init, plan, p)


class _Outcome:
    """What `assemble` reads of a run, for the one call of a plain run."""

    def __init__(self, plain: PlainRun, d, stats, h):
        self.rows, self.events, self.failure, self.choice = Rows(), [], None, plain.choice
        self._u_at = plain._u_at
        self.stats = {"nsteps": int(stats.get("nsteps", 0)), "nfevals": int(stats.get("nfevals", 0)),
                      "netfails": int(stats.get("netfails", 0)), "nncfails": int(stats.get("nncfails", 0)),
                      "segments": 1, **plain.stats, "hlast": float(stats.get("hlast", float("nan"))) * h}
