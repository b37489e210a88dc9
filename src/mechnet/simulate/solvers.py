"""SUNDIALS through `casadi.integrator`: the method's plugin, the integrators a compiled model keeps, the
Newton matrix's AD mode, and one guarded call.

States are integrated in scaled form (x = nominal · xs) so that one absolute tolerance means
`atol · nominal` for each variable. Plain segments run on their own real-time grid (cached, so
simulating the same grid again reuses it); monitored pieces and failure recovery use a time normalised
over the piece (t = t0 + τ·h, τ ∈ [0, 1], t0 and h parameters), so one integrator serves every piece with
the same output pattern.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..caches import BUILD_LOCK
from ..core.errors import MechnetError
from ..interrupts import interrupted

METHODS = ("auto", "idas", "cvodes-bdf", "cvodes-adams")
FIRST_TIME_SHARE = 0.01          # of the first output interval: IDAS's initial-value search scale
PLUGINS = {"idas": ("idas", {}),
           "cvodes-bdf": ("cvodes", {"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton"}),
           "cvodes-adams": ("cvodes", {"linear_multistep_method": "adams",
                                       "nonlinear_solver_iteration": "functional"})}


@dataclass(frozen=True)
class MethodChoice:
    """The method a run starts with, why, and the one it falls back to when that one meets stiffness
    (`method="auto"` on an explicit ODE: Adams, then BDF, as LSODA does)."""

    method: str
    reason: str
    fallback: str | None = None

    @property
    def plugin(self) -> str:
        return PLUGINS[self.method][0]

    @property
    def options(self) -> dict:
        return dict(PLUGINS[self.method][1])


def choose_method(dae, method: str) -> MethodChoice:
    """`auto`: IDAS for a DAE; for an explicit ODE, Adams with functional iteration, which reaches the
    same error as BDF 2.8-4.5x faster on a 10-link chain (8x at the default settings on 40 links; a
    single pendulum 0.9-1.9x) and does not damp an oscillation: over 10^4 periods BDF lost 10.8 % of a
    pendulum's swing energy, Adams 0.8 % (docs/benchmarks.md, methods). BDF takes over from the first
    sign of stiffness on (`Run._call`)."""
    if method not in METHODS:
        raise MechnetError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    if method == "auto":
        if not dae.is_ode:
            n = dae.z.numel()
            return MethodChoice("idas", f"auto: IDAS (BDF), the model keeps {n} algebraic variable{'s' * (n > 1)}")
        return MethodChoice("cvodes-adams", "auto: CVODES Adams, an explicit ODE taken as non-stiff until its "
                                            "functional iteration fails; then BDF", fallback="cvodes-bdf")
    if method.startswith("cvodes") and not dae.is_ode:
        raise MechnetError(f"method {method!r} needs an explicit ODE, but this model keeps "
                           f"{dae.z.numel()} algebraic variables ({', '.join(dae.z_names[:5])}); use 'idas' or 'auto'")
    return MethodChoice(method, f"{method}, as asked")


def plugin_for(dae, method: str) -> tuple[str, str, dict]:
    """(method, plugin, options) the run starts with (benchmarks use the same mapping)."""
    choice = choose_method(dae, method)
    return choice.method, choice.plugin, choice.options


class Integrators:
    """Builds and caches one integrator per output pattern (normalised grid), in this thread's cache of the
    compiled model (`caches.py`: an integrator cannot serve two threads at once)."""

    def __init__(self, cm, dae, plugin, extra, rtol, atol, max_steps, inputs):
        self.cm, self.dae, self.plugin, self.extra = cm, dae, plugin, extra
        self.rtol, self.atol, self.max_steps = rtol, atol, max_steps
        self.inputs = inputs
        self.base_key = (id(dae), plugin, tuple(sorted(extra.items())), rtol, atol, max_steps, inputs.key())

    def get(self, tau: tuple, max_steps: int | None = None):
        """Integrator over a normalised grid (t = t0 + τ·h): reusable for every segment of that pattern.
        `max_steps` lowers the step limit of this call (a power of two, so few variants are built)."""
        max_steps = max_steps if max_steps and max_steps < self.max_steps else None   # one key per budget in force
        return self._cached(self.base_key + (tau, max_steps), lambda: self._build(tau, max_steps=max_steps))

    def get_real(self, points: tuple):
        """Integrator over a fixed grid in real time: no time scaling in the right-hand side.

        Used for plain segments (reused when the same grid is simulated again);
        the parameters keep the [u; p; d; t0; h; tables] layout, t0 and h unused.
        """
        return self._cached(self.base_key + ("real", points),
                            lambda: self._build(tuple(points[1:]), t0_real=points[0]))

    def _cached(self, key, build):
        cache = self.cm.integrators()
        if key not in cache:
            with BUILD_LOCK:
                cache[key] = build()
        return cache[key]

    def _build(self, tau: tuple, t0_real=None, max_steps=None):
        """Parameters of the integrator: [u; p; d; t0; h; tables] (tables: `InputPlan.table_data`)."""
        dae = self.dae
        sym = ca.MX if self.inputs.varying else ca.SX
        xs, zs = sym.sym("xs", dae.x.numel()), sym.sym("zs", dae.z.numel())
        s, t0, h = sym.sym("tau"), sym.sym("t0"), sym.sym("h")
        u, p, d = sym.sym("u", dae.u.numel()), sym.sym("p", dae.p.numel()), sym.sym("d", dae.d.numel())
        tables = sym.sym("tables", self.inputs.table_data().size)
        xn = ca.DM(list(dae.x_nominal)) if dae.x_nominal else ca.DM(0, 1)
        zn = ca.DM(list(dae.z_nominal)) if dae.z_nominal else ca.DM(0, 1)
        t = t0 + s * h if t0_real is None else s
        if self.inputs.varying:
            interp = self.inputs.interpolated(t, tables)
            u_t = ca.vertcat(*[interp[k] if k in interp else u[k] for k in range(dae.u.numel())])
        else:
            u_t = u
        args = (t, xn * xs, zn * zs, u_t, p, d)
        rate = dae.ode(*args) / xn
        spec = {"x": xs, "t": s, "p": ca.vertcat(u, p, d, t0, h, tables),
                "ode": h * rate if t0_real is None else rate}
        if dae.z.numel():
            spec["z"] = zs
            spec["alg"] = dae.alg(*args)
            if sym is ca.SX:              # ode and alg share the loop's trigonometry: one elimination for both
                spec["ode"], spec["alg"] = ca.cse([spec["ode"], spec["alg"]])
        if self.plugin == "cvodes" and self.extra.get("nonlinear_solver_iteration") == "functional" \
                and dae.ode.n_instructions() * dae.x.numel() > JACOBIAN_CHOICE_MAX:
            spec = _without_jacobian(spec)
        opts = dict(self.extra, reltol=self.rtol, abstol=self.atol, max_num_steps=max_steps or self.max_steps,
                    disable_internal_warnings=True, show_eval_warnings=False)
        opts["common_options"] = jacobian_options(dae, self.plugin, self.extra)
        if self.plugin == "idas":
            # IDAS's consistent-initial-value search takes its time scale from the "first requested time"
            # (its trial step is a thousandth of the distance), and CasADi passes the *last* output time. A
            # long call on a fast machine (a crank at 3000 rpm, 0.8 s, 40 turns) searched on a step of 0.8
            # ms and its line search failed (IDA_LINESEARCH_FAIL) at restarts consistent to Newton
            # accuracy, 14 times in a 20 s run; at the first output time, 1 in 3 restarts of a 2 s run
            # still did. A hundredth of the first output interval passed every restart tried.
            start = 0.0 if t0_real is None else float(t0_real)
            opts["first_time"] = start + FIRST_TIME_SHARE * (float(tau[0]) - start)
        return ca.integrator("F", self.plugin, spec, 0.0 if t0_real is None else float(t0_real), list(tau), opts)


def _without_jacobian(spec: dict) -> dict:
    """The ODE behind a function declared not differentiable, whose Jacobian is never built.

    CasADi's SUNDIALS interface builds the Jacobian of the right-hand side when it creates the
    integrator, whatever the Newton scheme; Adams with functional iteration never evaluates it (no linear
    solver is set up). For a 100-link chain (200 states, 10 783 instructions) that symbolic Jacobian (1.7
    million instructions) took 1.0 of the 1.2 s of the first simulation. A custom Jacobian declared
    structurally zero still left CasADi colouring the chain's dense Jacobian *pattern*, found by sparsity
    propagation through the function: 2.2 s for 600 links, 11 s for 1000. With its inputs and output
    marked not differentiable (`is_diff_in`, `is_diff_out`), nothing is propagated and the integrator is
    built in milliseconds (3.5 ms for 600 links). Only functional-iteration integrators get it: BDF, IDAS
    and everything that differentiates see the model itself. And only large ones (instructions × states
    above JACOBIAN_CHOICE_MAX): the MX call around the function costs about 0.35 µs per evaluation, 130 of
    the 470 µs of a 2-state oscillator's 95-step call, whose Jacobian costs nothing to build."""
    inputs = [spec["t"], spec["x"], spec["p"]]
    rate = ca.Function("rate", inputs, [spec["ode"]], {"is_diff_in": [False] * 3, "is_diff_out": [False],
                                                       "cse": True})
    t, x, p = (ca.MX.sym(n, v.shape) for n, v in zip(("t", "x", "p"), inputs))
    return {"t": t, "x": x, "p": p, "ode": rate(t, x, p)}


JACOBIAN_CHOICE_MAX = 50_000     # residual instructions × unknowns: above it (a 10-link chain's ODE) comparing costs
                                 # more than it can save in one run, and forward and reverse cost the same there


def jacobian_options(dae, plugin: str, extra: dict) -> dict:
    """How the integrator differentiates the residual for its Newton matrix: the cheaper of forward and
    reverse mode, counted once per selection. CasADi's default picks forward mode for a loop's residual,
    whose few state rows hold most of the work: reverse mode halves that Jacobian (slider-crank 3161 ->
    1713 instructions, four-bar 4445 -> 2204; docs/benchmarks.md). Functional iteration (Adams) needs
    no Jacobian."""
    if plugin == "cvodes" and extra.get("nonlinear_solver_iteration") == "functional":
        return {}
    if "_jacobian_options" not in dae.info:            # per compiled selection, across runs
        size = (dae.ode.n_instructions() + dae.alg.n_instructions()) * (dae.x.numel() + dae.z.numel())
        choice = {}
        if size <= JACOBIAN_CHOICE_MAX:
            args = [dae.t, dae.x, dae.z, dae.u, dae.p, dae.d]
            res, unknowns = ca.vertcat(dae.ode(*args), dae.alg(*args)), ca.vertcat(dae.x, dae.z)

            def cost(opts):
                return ca.Function("newton_matrix", args, [ca.jacobian(res, unknowns, opts)]).n_instructions()
            if cost({"allow_forward": False}) < cost({}):
                choice = {"allow_forward": False}
        dae.info["_jacobian_options"] = choice
    return dae.info["_jacobian_options"]


class SolverFailure(RuntimeError):
    """An integrator call failed: CasADi's text (with the solver's code), the call's statistics up to
    the failure (`tcur`: where the solver stopped) and its outputs ({"xf", "zf"} as `call` returns them:
    the output times it reached filled in, NaN after)."""

    def __init__(self, text: str, stats: dict, outputs: dict | None = None):
        super().__init__(text)
        self.stats, self.outputs = stats, outputs


def call(F, xs, zs, p) -> tuple[dict, dict]:
    """One integrator call: (its statistics, {"xf": states (n_x × outputs), "zf": algebraics (n_z ×
    outputs)}, scaled); raises SolverFailure.
    IDAS's consistent-initial-condition search can fail on a point that is
    already consistent (its line search cannot shrink a residual that is round-off): retried once from
    algebraic values nudged by 1e-6 relative, which it then corrects in a genuine Newton step (without
    this, tests/analytic/test_loops.py's kinematic four-bar fails at t = 3.09 s)."""
    try:
        return _on_numpy(F, xs, zs, p)
    except RuntimeError as exc:
        if "LINESEARCH" not in str(exc).upper() or not np.size(zs) or interrupted():
            raise
        return _on_numpy(F, xs, np.asarray(zs) * (1 + 1e-6) + 1e-9, p)


def _on_numpy(F, xs, zs, p) -> tuple[dict, dict]:
    """F(x0=xs, z0=zs, p=p) through a buffer on numpy memory: a keyword call converts three inputs and
    seven outputs through DM, 90 µs of a small model's 400 µs call (`numeric.NumpyCall`). The
    statistics are the buffer's (F.stats() holds only those of calls through F's own memory). The
    integrator writes each output time's column as it reaches it, so a failed call keeps the solution
    up to where it stopped (the columns after stay NaN)."""
    slot = _slot(F)
    buffer, trigger = slot.buffer
    inputs = [np.ascontiguousarray(v, dtype=float).ravel() for v in (xs, zs, p)]
    for i, n, v, name in zip(slot.inputs, slot.sizes, inputs, ("x0", "z0", "p")):
        if v.size != n:                           # (a buffer takes any longer memory without a word)
            raise ValueError(f"integrator input {name}: {v.size} values, expected {n}")
        buffer.set_arg(i, memoryview(v))
    outputs = {}
    for i, shape, name in zip(slot.outputs, slot.shapes, ("xf", "zf")):
        out = np.full(shape, np.nan)              # column-major storage: the transpose in C order
        buffer.set_res(i, memoryview(out))
        outputs[name] = out.T
    try:
        trigger()
    except RuntimeError as exc:
        del F._mechnet_slot                       # a failed evaluation's buffer is not used again
        try:
            stats = buffer.stats()
        except RuntimeError:                       # it failed before the solver started: no statistics
            stats = {}
        raise SolverFailure(str(exc), stats, outputs) from None
    return buffer.stats(), outputs


class _Slot:
    """An integrator's buffer and where its inputs and outputs lie, found once (a dozen SWIG calls and a
    new buffer cost 40 µs of a 2-state model's 350 µs call). Kept on the integrator itself: integrators
    are per thread (`caches.py`), so each buffer serves one thread."""

    def __init__(self, F):
        self.buffer = F.buffer()
        self.inputs = [F.index_in(name) for name in ("x0", "z0", "p")]
        self.sizes = [F.nnz_in(i) for i in self.inputs]
        self.outputs = [F.index_out(name) for name in ("xf", "zf")]
        self.shapes = [F.size_out(i)[::-1] for i in self.outputs]


def _slot(F) -> _Slot:
    try:
        return F._mechnet_slot
    except AttributeError:
        F._mechnet_slot = _Slot(F)
        return F._mechnet_slot


def solver_message(text: str) -> str:
    """The SUNDIALS return code out of CasADi's error text (e.g. CV_TOO_MUCH_WORK)."""
    found = re.search(r'returned "?([A-Z_]+)"?', text)
    if found:
        return found.group(1)
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else "unknown solver error"
