"""What collocation and multiple shooting share: the problem's placeholders as functions of the model's
(t, x, z, u, p, d), the NLP's variables with their bounds and scales, and the IPOPT call.

Each transcription fills an `Nlp` (decision variables, constraints with a label and a time each) and
says how to read the trajectories from its solution; solving, reporting the worst constraint by name
and time, and building the `Solution` are common.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..caches import BUILD_LOCK
from ..core.errors import InitializationError
from ..interrupts import Interrupted, interrupted, watched
from ..solver_output import captured
from .problem import OcpError, Problem
from .progress import IterationBar


NLPSOL_OPTIONS = ("print_time", "expand", "record_time", "error_on_fail", "calc_lam_p", "calc_lam_x")


@dataclass
class Nlp:
    """Decision variables (scaled) and constraints, each constraint row labelled (what, time)."""

    w: list = field(default_factory=list)
    w0: list = field(default_factory=list)
    lbw: list = field(default_factory=list)
    ubw: list = field(default_factory=list)
    g: list = field(default_factory=list)
    lbg: list = field(default_factory=list)
    ubg: list = field(default_factory=list)
    labels: list = field(default_factory=list)

    def variable(self, name, n, guess, lower, upper, scale) -> ca.MX:
        """A block of n decision variables in scaled form; returns them unscaled (scale · w)."""
        w = ca.MX.sym(name, n)
        self.w.append(w)
        scale = np.broadcast_to(np.asarray(scale, dtype=float), (n,))
        self.w0.extend(np.broadcast_to(np.asarray(guess, dtype=float), (n,)) / scale)
        self.lbw.extend(np.broadcast_to(np.asarray(lower, dtype=float), (n,)) / scale)
        self.ubw.extend(np.broadcast_to(np.asarray(upper, dtype=float), (n,)) / scale)
        return w * ca.DM(scale)

    def constrain(self, expr, lower, upper, what, t):
        """Rows lower <= expr <= upper, labelled `what` (one label, or one per row) at the time t given as
        a share of the horizon (the final time may be a decision variable)."""
        n = expr.numel()
        self.g.append(ca.vec(expr))
        self.lbg.extend(np.broadcast_to(np.asarray(lower, dtype=float), (n,)))
        self.ubg.extend(np.broadcast_to(np.asarray(upper, dtype=float), (n,)))
        whats = what if isinstance(what, (list, tuple)) else [what] * n
        self.labels.extend((w, t) for w in whats)


@dataclass
class Layout:
    """What both transcriptions start from (`Transcription.start`): the NLP with the final time, the
    parameters and the controls declared, the guess on the transcription's points, and the scales."""

    nlp: Nlp
    T: object                   # final time (MX: a number or a decision variable)
    p: object                   # parameter vector (MX)
    d: object                   # discrete values (DM)
    h: object                   # T / N
    U: list                     # controls at their nodes (MX)
    X0: np.ndarray              # guess of states, algebraics and inputs at the points
    Z0: np.ndarray
    U0: np.ndarray
    xn: np.ndarray
    zn: np.ndarray


class Transcription:
    """Base of Collocation and MultipleShooting. `controls`: "constant" or "linear" between nodes;
    `hessian`: "exact" or "limited-memory"."""

    default_hessian = "exact"
    expand = False           # the NLP's MX graph expanded to SX (`Collocation.expand`); read in `solve`

    def __init__(self, N: int, controls: str = "constant", hessian: str | None = None):
        from ..core.arguments import whole_number
        self.N = whole_number(N, "N (intervals)", 2)
        if controls not in ("constant", "linear"):
            raise OcpError(f"controls = {controls!r}: choose 'constant' (zero-order hold) or 'linear'")
        self.controls = controls
        hessian = hessian or self.default_hessian
        if hessian not in ("exact", "limited-memory"):
            raise OcpError(f"hessian = {hessian!r}: choose 'exact' or 'limited-memory'")
        self.hessian = hessian

    # ---- the problem as functions -----------------------------------------------------------

    def prepare(self, prob: Problem):
        """Functions of (t, x, z, u, p, d) for the path quantities, constraints and integrands."""
        dae = prob.dae
        t, x, z, u, p, d = dae.t, dae.x, dae.z, dae.u, dae.p, dae.d
        names = list(prob._vars)
        observed = dae.observed(t, x, z, u, p, d)
        column = {n: k for k, n in enumerate(dae.observed_names)}
        values = ca.vertcat(*[observed[column[n]] for n in names]) if names else ca.SX(0, 1)
        path_syms = ca.vertcat(prob.time, *prob._vars.values())
        T = prob.t_final

        def of_point(exprs):
            exprs = ca.vertcat(*exprs) if exprs else ca.SX(0, 1)
            f = ca.Function("f", [path_syms, T], [exprs])
            return ca.Function("at_point", [t, x, z, u, p, d, T], [f(ca.vertcat(t, values), T)])

        self.path_names = [c.label for c in prob.path]
        bounded = [(n, lo, hi) for n, (lo, hi) in prob.bounds_of.items()
                   if n not in dae.x_names and n not in dae.u_names and n not in dae.p_names]
        self.path_fn = of_point([c.expr for c in prob.path] + [prob.var(n) for n, _, _ in bounded])
        self.path_lower = [c.lower for c in prob.path] + [lo for _, lo, _ in bounded]
        self.path_upper = [c.upper for c in prob.path] + [hi for _, _, hi in bounded]
        self.path_labels = self.path_names + [f"bounds on {n}" for n, _, _ in bounded]
        kinds = {"start": [], "end": [], "integral": []}
        for sym_name, (kind, expr) in prob._boundary.items():
            kinds[kind].append((sym_name, expr))
        self.boundary_order = kinds
        self.start_fn = of_point([e for _, e in kinds["start"]])
        self.end_fn = of_point([e for _, e in kinds["end"]])
        self.integrand_fn = of_point([e for _, e in kinds["integral"]])
        start_names = list(prob.start)
        self.start_names = start_names
        self.start_values = [prob.start[n] for n in start_names]
        self.start_value_fn = ca.Function("start_values", [t, x, z, u, p, d],
                                          [ca.vertcat(*[observed[column[n]] for n in start_names])
                                           if start_names else ca.SX(0, 1)])

    def boundary_function(self, prob: Problem) -> ca.Function:
        """(start values, end values, integrals, T, p) -> [objective; boundary constraints]."""
        syms = prob._boundary_syms
        kinds = self.boundary_order
        sv = ca.vertcat(*[syms[n] for n, _ in kinds["start"]]) if kinds["start"] else ca.SX(0, 1)
        ev = ca.vertcat(*[syms[n] for n, _ in kinds["end"]]) if kinds["end"] else ca.SX(0, 1)
        iv = ca.vertcat(*[syms[n] for n, _ in kinds["integral"]]) if kinds["integral"] else ca.SX(0, 1)
        names = prob.parameter_vars()
        pvars = ca.vertcat(*[prob._vars[n] for n in names]) if names else ca.SX(0, 1)
        exprs = [prob.objective] + [c.expr for c in prob.point]
        return ca.Function("boundary", [sv, ev, iv, prob.t_final, pvars], [ca.vertcat(*exprs)])

    @staticmethod
    def parameter_values(prob: Problem, p):
        """The parameters the boundary function takes (`Problem.parameter_vars`) out of the vector p."""
        names = prob.parameter_vars()
        return ca.vertcat(*[p[prob.dae.p_names.index(n)] for n in names]) if names else ca.MX(0, 1)

    def parameters(self, prob: Problem, nlp: Nlp):
        """The model's parameter vector, the freed ones decision variables within their bounds (those of
        free_parameter and of bounds(...), both)."""
        values = [ca.MX(v) for v in prob.p_value]
        checks = prob.dae.info.get("parameter_checks", {})
        for name, (lo, hi) in prob.free_params.items():
            k = prob.dae.p_names.index(name)
            more = prob.bounds_of.get(name, (lo, hi))
            lo, hi = max(lo, more[0]), min(hi, more[1])
            # the parameter's own check as bounds (a mass > 0, a friction coefficient >= 0); a strict one
            # 1e-12 inside, since IPOPT ends on a bound it is held to
            value_range = getattr(getattr(checks.get(name, (None,))[0], "check", None), "value_range", None)
            if value_range is not None:
                lower, strict, upper = value_range
                lo, hi = max(lo, lower + (1e-12 * max(1.0, abs(lower)) if strict else 0.0)), min(hi, upper)
            if lo > hi:
                raise OcpError(f"parameter {name}: free_parameter and bounds leave no value ({lo:g} > {hi:g})")
            values[k] = nlp.variable(f"p_{name}", 1, min(max(prob.p_value[k], lo), hi), lo, hi,
                                     max(abs(prob.p_value[k]), 1.0))
        self._requirements(prob, nlp, values)
        return ca.vertcat(*values) if values else ca.MX(0, 1)

    @staticmethod
    def _requirements(prob: Problem, nlp: Nlp, values: list) -> None:
        """The requirements between parameters (mu_s >= mu_k, a stop's limits in order) that hold a freed
        one, as constraints lhs − rhs >= 0 (a strict one as well: IPOPT cannot keep a strict inequality,
        and the boundary value is one the model runs with)."""
        names = prob.dae.p_names
        for entry in prob.dae.info.get("parameter_requirements", ()):
            sides = [entry[f"{s}_value"] if entry[f"{s}_value"] is not None else entry[s] for s in ("lhs", "rhs")]
            if not any(isinstance(v, str) and v in prob.free_params for v in sides):
                continue
            lhs, rhs = (values[names.index(v)] if isinstance(v, str) else ca.MX(v) for v in sides)
            nlp.constrain(lhs - rhs, 0.0, np.inf,
                          f"{entry['owner']}: {entry['lhs'].rsplit('.', 1)[-1]} {entry['op']} "
                          f"{entry['rhs'].rsplit('.', 1)[-1]}", 0.0)

    def start(self, prob: Problem, guess, shares, node_points) -> Layout:
        """The NLP both transcriptions build on: final time, parameters, and the controls (bounded, rate
        bounded) with their guess; `shares`: the transcription's points as shares of the horizon, where
        the guess is laid out; `node_points[k]`: the point of control node k."""
        dae = prob.dae
        nlp = Nlp()
        T = self.final_time(prob, nlp, guess)
        p = self.parameters(prob, nlp)
        x0, z0, u0 = self.start_point(prob)
        X0, Z0, U0 = guess_trajectory(prob, guess, np.asarray(shares) * final_time_guess(prob, guess), x0, z0, u0)
        ulo, uhi = self.input_bounds(prob)
        n_nodes = self.N + 1 if self.controls == "linear" else self.N
        U = [nlp.variable(f"U_{k}", dae.u.numel(), U0[node_points[k]], ulo, uhi, 1.0) for k in range(n_nodes)]
        h = T / self.N
        self.control_rates(prob, nlp, U, h)
        return Layout(nlp, T, p, ca.DM(list(dae.d_value)) if dae.d.numel() else ca.DM(0, 1), h, U, X0, Z0, U0,
                      np.array(dae.x_nominal, dtype=float), np.array(dae.z_nominal, dtype=float))

    def final_time(self, prob: Problem, nlp: Nlp, guess=None):
        lo, hi = prob.t_bounds
        if lo == hi:
            return ca.MX(lo)
        return nlp.variable("t_final", 1, final_time_guess(prob, guess), lo, hi, hi)

    def control_rates(self, prob: Problem, nlp: Nlp, U: list, h) -> None:
        """Rate bounds between successive control nodes: (U[k+1] - U[k]) / h."""
        for name, (lo, hi) in prob.rate_bounds_of.items():
            j = prob.dae.u_names.index(name)
            for k in range(len(U) - 1):
                nlp.constrain((U[k + 1][j] - U[k][j]) / h, lo, hi, f"rate bounds on {name}", (k + 1) / self.N)

    def input_bounds(self, prob: Problem):
        dae = prob.dae
        lo = np.array([prob.bounds_of.get(n, (-math.inf, math.inf))[0] for n in dae.u_names])
        hi = np.array([prob.bounds_of.get(n, (-math.inf, math.inf))[1] for n in dae.u_names])
        return lo, hi

    def state_bounds(self, prob: Problem):
        dae = prob.dae
        lo = np.array([prob.bounds_of.get(n, (-math.inf, math.inf))[0] for n in dae.x_names])
        hi = np.array([prob.bounds_of.get(n, (-math.inf, math.inf))[1] for n in dae.x_names])
        return lo, hi

    def start_point(self, prob: Problem):
        """The consistent initial point simulate() would start from (a guess where the start values do
        not fix one: an optimised start)."""
        from ..simulate.initialize import initialize
        dae = prob.dae
        u0 = np.clip(np.array(dae.u_default, dtype=float), *self.input_bounds(prob))
        try:
            init = initialize(dae, 0.0, u0, prob.p_value, prob.start, {}, False)
            return init.x, init.z, u0
        except InitializationError:
            x = np.array([dae.guesses.get(n, 0.0) for n in dae.x_names], dtype=float)
            z = np.array([dae.guesses.get(n, 0.0) for n in dae.z_names], dtype=float)
            return x, z, u0

    # ---- solving --------------------------------------------------------------------------------

    @watched("optimal control solve")
    def solve(self, prob: Problem, guess, ipopt: dict, progress, verbose):
        """Solve with IPOPT. Ctrl-C stops IPOPT at its next iteration (`IterationBar`) and raises
        `mechnet.Interrupted` carrying a Solution at the last iterate (`stats["status"] == "interrupted"`,
        not a success; None when IPOPT had not finished an iteration)."""
        from ..core.arguments import mapping
        ipopt = mapping(ipopt, "solve(ipopt=...)")
        setup = _time.perf_counter()
        with BUILD_LOCK:
            self.prepare(prob)
            nlp, layout = self.transcribe(prob, guess)
            w, g = ca.vertcat(*nlp.w), ca.vertcat(*nlp.g)
            opts = {"ipopt.print_level": 5 if verbose else 0, "ipopt.sb": "yes", "print_time": False,
                    "ipopt.hessian_approximation": self.hessian, "expand": self.expand}
            opts.update({k if "." in k or k in NLPSOL_OPTIONS else f"ipopt.{k}": v for k, v in ipopt.items()})
            try:
                max_iter = int(opts.get("ipopt.max_iter", 3000))
                bar = IterationBar(w.numel(), g.numel(), 0, max_iter, progress)
                opts["iteration_callback"] = bar
                solver = ca.nlpsol("ocp", "ipopt", {"x": w, "f": layout["objective"], "g": g}, opts)
            except (RuntimeError, TypeError, ValueError) as exc:
                if interrupted():
                    raise Interrupted("optimal control solve") from None
                raise OcpError(f"solve(ipopt={ipopt!r:.120}): IPOPT refused the options: "
                               f"{str(exc).strip().splitlines()[-1]}") from None
            read = ca.Function("trajectories", [w], [layout[k] for k in layout["read"]])
            final_time = ca.Function("t_final", [w], [layout["T"]])
        started = _time.perf_counter()
        setup = started - setup
        out, messages = None, []
        try:
            with captured() as messages:
                out = solver(x0=nlp.w0, lbx=nlp.lbw, ubx=nlp.ubw, lbg=nlp.lbg, ubg=nlp.ubg)
        except BaseException:                 # a KeyboardInterrupt, or a failure CasADi made of one
            if not interrupted():
                raise
        finally:
            bar.close()
        if interrupted():
            solution = None
            if bar.last is not None:          # the iterate of the last iteration IPOPT finished
                with BUILD_LOCK:
                    f_g = ca.Function("f_g", [w], [layout["objective"], g])
                f, g_last = f_g(bar.last)
                stats = {"success": False, "return_status": "interrupted", "iter_count": bar.iterations}
                iterate = {"x": bar.last, "g": g_last, "f": f}
                solution = self._solution(prob, nlp, layout, opts, read, final_time, iterate, stats, messages,
                                          _time.perf_counter() - started, setup)
            raise Interrupted("optimal control solve", solution) from None
        return self._solution(prob, nlp, layout, opts, read, final_time, out, solver.stats(), messages,
                              _time.perf_counter() - started, setup)

    def _solution(self, prob, nlp, layout, opts, read, final_time, out, stats, messages, wall, setup):
        """The Solution at IPOPT's answer `out` (nlpsol's outputs x, g, f; `stats` its statistics)."""
        from .solution import Solution
        w_opt = np.asarray(out["x"]).ravel()
        g_opt = np.asarray(out["g"]).ravel()
        violation = np.maximum(np.asarray(nlp.lbg) - g_opt, g_opt - np.asarray(nlp.ubg))
        violation = np.where(np.isfinite(violation), violation, 0.0)
        worst = int(np.argmax(violation)) if violation.size and violation.max() > 0 else None
        t_final = float(final_time(w_opt))
        info = {"success": bool(stats.get("success")), "status": stats.get("return_status"),
                "iterations": int(stats.get("iter_count", 0)), "wall_time": wall, "setup_time": setup,
                "expanded": bool(opts["expand"]),
                "function_time": sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_")),
                "function_times": {k[len("t_wall_"):]: v for k, v in stats.items() if k.startswith("t_wall_nlp_")},
                "objective": float(out["f"]), "method": type(self).__name__, "N": self.N,
                "max_violation": float(violation[worst]) if worst is not None else 0.0,
                "worst_constraint": (nlp.labels[worst][0], float(nlp.labels[worst][1]) * t_final)
                if worst is not None else None,
                "solver_messages": messages}
        with BUILD_LOCK:
            trajectories = read(w_opt)
            return Solution(prob, self, dict(zip(layout["read"], (np.asarray(v) for v in trajectories))), info)

    def transcribe(self, prob: Problem, guess):            # pragma: no cover - abstract
        raise NotImplementedError


def final_time_guess(prob: Problem, guess=None) -> float:
    """A free final time starts where the guess ends (a previous Solution or a Result, within the bounds),
    else at the geometric mean of its bounds; the guess's time grid spans it."""
    lo, hi = prob.t_bounds
    if guess is not None and hasattr(guess, "t") and len(guess.t):
        return float(min(max(float(np.asarray(guess.t)[-1]), lo), hi))
    return math.sqrt(lo * hi)


def guess_trajectory(prob: Problem, guess, times: np.ndarray, x0, z0, u0):
    """States, algebraics and inputs at `times` from a Result or Solution (interpolated), else the
    start point held (a trivial guess)."""
    dae = prob.dae
    if guess is None or (isinstance(guess, str) and guess == "interpolate"):
        X = np.tile(x0, (times.size, 1))
        if guess is not None:
            share = times / times[-1] if times[-1] > 0 else np.zeros_like(times)
            for name, target in prob.end_targets().items():
                k = dae.x_names.index(name)
                X[:, k] = x0[k] + share * (target - x0[k])
        return X, np.tile(z0, (times.size, 1)), np.tile(u0, (times.size, 1))
    if not hasattr(guess, "t") or not all(n in guess for n in dae.x_names):
        raise OcpError("guess takes a Result of cm.simulate, a previous Solution of this model, \"interpolate\" "
                       "or None")
    t_src = np.asarray(guess.t, dtype=float)
    scale = times[-1] / t_src[-1] if t_src[-1] > 0 else 1.0
    at = times / scale

    def column(name, default):
        return np.interp(at, t_src, np.asarray(guess[name], dtype=float)) if name in guess else \
            np.full(times.size, default)
    X = np.column_stack([column(n, v) for n, v in zip(dae.x_names, x0)]) if dae.x_names else np.zeros((times.size, 0))
    Z = np.column_stack([column(n, v) for n, v in zip(dae.z_names, z0)]) if dae.z_names else np.zeros((times.size, 0))
    U = np.column_stack([column(n, v) for n, v in zip(dae.u_names, u0)])
    return X, Z, U

