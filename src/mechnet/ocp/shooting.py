"""Multiple shooting: one integrator call per interval, continuity at the nodes.

The states at the N + 1 nodes (and a DAE's algebraic variables there) are decision variables; each
interval is integrated by SUNDIALS (CVODES for an ODE, IDAS for a DAE) or a fixed-step Runge-Kutta,
with CasADi's forward and adjoint sensitivities for exact first derivatives. Integrals ride along as
quadratures. Path constraints and bounds on named quantities are enforced at the nodes (and, with
`constraint_points=m`, at m - 1 more points inside each interval); state and input bounds bind the
decision variables (at the nodes). The Hessian is limited-memory by default: an exact one
needs second-order sensitivities of every interval.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .problem import MAX_VARIABLES, OcpError
from .transcription import Transcription

INTEGRATORS = ("cvodes", "idas", "rk")


class MultipleShooting(Transcription):
    """`MultipleShooting(N=50, integrator="cvodes" | "idas" | "rk", rtol=1e-8, atol=1e-10, steps=4,
    controls="constant" | "linear", constraint_points=1)`; `steps`: Runge-Kutta steps per interval for
    "rk"; `constraint_points`: path constraints hold at this many evenly spaced points of each interval
    (its end included), not only at the nodes."""

    default_hessian = "limited-memory"

    def __init__(self, N: int, integrator: str = "cvodes", controls: str = "constant", hessian: str | None = None,
                 rtol: float = 1e-8, atol: float = 1e-10, steps: int = 4, constraint_points: int = 1):
        super().__init__(N, controls, hessian)
        from ..core.arguments import whole_number
        from ..core.declarations import finite_number
        if not isinstance(integrator, str) or integrator not in INTEGRATORS:
            raise OcpError(f"integrator = {integrator!r}: choose one of {', '.join(INTEGRATORS)}")
        self.integrator = integrator
        self.rtol = finite_number(rtol, "rtol", OcpError)
        self.atol = finite_number(atol, "atol", OcpError)
        if not (self.rtol > 0 and self.atol > 0):
            raise OcpError(f"rtol = {rtol!r}, atol = {atol!r}: the integrator's tolerances must be > 0")
        self.steps = whole_number(steps, "steps (Runge-Kutta steps per interval)", 1)
        self.constraint_points = whole_number(constraint_points, "constraint_points (per interval)", 1)
        # at least one variable a node and one row a constraint point, whatever the model; the
        # Runge-Kutta steps are unrolled and their states kept for the adjoint sensitivities
        for what, count in (("N", self.N), ("constraint_points", self.N * self.constraint_points),
                            ("steps", self.N * self.steps if integrator == "rk" else 0)):
            if count > MAX_VARIABLES:
                raise OcpError(f"{what} = {getattr(self, what)}: {count:.3g} points over N = {self.N} intervals "
                               f"exceed the {MAX_VARIABLES:.0e} a transcription may have")

    def __getstate__(self):
        """The settings only: what `prepare` and `transcribe` build (the last problem's CasADi functions)
        every solve builds again."""
        return {k: self.__dict__[k] for k in ("N", "controls", "hessian", "integrator", "rtol", "atol", "steps",
                                              "constraint_points")}

    def variables(self, prob) -> int:
        """The size of the transcription (before it is made): states, algebraics and inputs at every node,
        and the states at every constraint point or Runge-Kutta step inside the intervals."""
        dae = prob.dae
        inner = max(self.constraint_points, self.steps if self.integrator == "rk" else 1)
        return (self.N + 1) * (dae.x.numel() + dae.z.numel() + dae.u.numel()) + self.N * inner * dae.x.numel()

    def _interval(self, prob):
        """F(x0, z0, p = [u_a; u_b; p; d; t0; h; T]) -> xf, zf, qf over one interval (time normalised).
        The quadratures are under error control: without it CVODES's sensitivities of an integral were
        wrong (d/du_a of ∫u² over an interval with linear controls: 0.424 where 0.333 is right), and
        IPOPT stalled on the inconsistent gradient."""
        dae = prob.dae
        if dae.z.numel() and self.integrator == "cvodes":
            raise OcpError(f"integrator 'cvodes' needs an explicit ODE, but model {prob.cm.name!r} keeps algebraic "
                           f"variables ({', '.join(dae.z_names[:3])}); use integrator='idas'")
        if dae.z.numel() and self.integrator == "rk":
            raise OcpError("integrator 'rk' takes an explicit ODE; use integrator='idas' for this DAE")
        x, z = ca.SX.sym("x", dae.x.numel()), ca.SX.sym("z", dae.z.numel())
        nu = dae.u.numel()
        ua, ub = ca.SX.sym("ua", nu), ca.SX.sym("ub", nu)
        p, d = ca.SX.sym("p", dae.p.numel()), ca.SX.sym("d", dae.d.numel())
        t0, h, s = ca.SX.sym("t0"), ca.SX.sym("h"), ca.SX.sym("s")
        T = ca.SX.sym("T")
        u = ua if self.controls == "constant" else ua + s * (ub - ua)
        t = t0 + s * h
        spec = {"x": x, "t": s, "p": ca.vertcat(ua, ub, p, d, t0, h, T), "ode": h * dae.ode(t, x, z, u, p, d)}
        integrand = self.integrand_fn(t, x, z, u, p, d, T)
        if integrand.numel():
            spec["quad"] = h * integrand
        if dae.z.numel():
            spec["z"], spec["alg"] = z, dae.alg(t, x, z, u, p, d)
        plugin = {"cvodes": "cvodes", "idas": "idas", "rk": "rk"}[self.integrator]
        opts = {"number_of_finite_elements": self.steps} if plugin == "rk" else \
            {"reltol": self.rtol, "abstol": self.atol, "quad_err_con": True, "disable_internal_warnings": True,
             "show_eval_warnings": False}
        grid = [j / self.constraint_points for j in range(1, self.constraint_points + 1)]
        return ca.integrator("interval", plugin, spec, 0.0, grid, opts)

    def transcribe(self, prob, guess):
        dae = prob.dae
        size = self.variables(prob)
        if size > MAX_VARIABLES:
            raise OcpError(f"N = {self.N}: multiple shooting of model {prob.cm.name!r} would hold {size:.3g} "
                           f"variables and points, more than {MAX_VARIABLES:.0e}; lower N (or steps, "
                           f"constraint_points)")
        N = self.N
        nx_, nz = dae.x.numel(), dae.z.numel()
        F = self._interval(prob)
        setup = self.start(prob, guess, np.linspace(0.0, 1.0, N + 1), list(range(N + 1)))
        nlp, T, p, d_values, h, U = setup.nlp, setup.T, setup.p, setup.d, setup.h, setup.U
        Xg, Zg, xn, zn = setup.X0, setup.Z0, setup.xn, setup.zn
        xlo, xhi = self.state_bounds(prob)
        n_nodes = len(U)
        X = [nlp.variable(f"X_{k}", nx_, Xg[k], xlo, xhi, xn) for k in range(N + 1)]
        Z = [nlp.variable(f"Z_{k}", nz, Zg[k], -np.inf, np.inf, zn) for k in range(N + 1)]

        def u_at(k):                 # the input at node k (from the left at the end)
            return U[min(k, n_nodes - 1)]
        starts = self.start_value_fn(0.0, X[0], Z[0], u_at(0), p, d_values)
        nlp.constrain(starts - ca.DM(self.start_values), 0.0, 0.0, [f"start value {n}" for n in self.start_names], 0.0)
        integrals = 0
        for k in range(N + 1):
            t_k = k * h
            if nz:
                nlp.constrain(dae.alg(t_k, X[k], Z[k], u_at(k), p, d_values), 0.0, 0.0,
                              [f"algebraic equation for {n}" for n in dae.z_names], k / N)
            values = self.path_fn(t_k, X[k], Z[k], u_at(k), p, d_values, T)
            if values.numel():
                nlp.constrain(values, self.path_lower, self.path_upper, self.path_labels, k / N)
            if k == N:
                break
            ub = U[k + 1] if self.controls == "linear" else U[k]
            out = F(x0=X[k], z0=Z[k], p=ca.vertcat(U[k], ub, p, d_values, t_k, h, T))
            m = self.constraint_points
            for j in range(1, m):                  # path constraints between the nodes, on request
                s = j / m
                values = self.path_fn(t_k + s * h, out["xf"][:, j - 1], out["zf"][:, j - 1] if nz else ca.MX(0, 1),
                                      U[k] + s * (ub - U[k]), p, d_values, T)
                if values.numel():
                    nlp.constrain(values, self.path_lower, self.path_upper, self.path_labels, (k + s) / N)
            nlp.constrain((out["xf"][:, -1] - X[k + 1]) / ca.DM(xn), 0.0, 0.0,
                          [f"continuity of {n}" for n in dae.x_names], (k + 1) / N)
            if "qf" in F.name_out():
                integrals = integrals + out["qf"][:, -1]
        start_values = self.start_fn(0.0, X[0], Z[0], u_at(0), p, d_values, T)
        end_values = self.end_fn(T, X[N], Z[N], u_at(N), p, d_values, T)
        boundary = self.boundary_function(prob)(start_values, end_values,
                                                integrals if isinstance(integrals, ca.MX) else ca.MX(0, 1),
                                                T, self.parameter_values(prob, p))
        nlp.constrain(boundary[1:], [c.lower for c in prob.point], [c.upper for c in prob.point],
                      [c.label for c in prob.point], 1.0)
        times = ca.vertcat(*[k * h for k in range(N + 1)]).T
        layout = {"objective": boundary[0], "read": ["t", "x", "z", "u", "U", "T", "p"], "t": times,
                  "x": ca.horzcat(*X), "z": ca.horzcat(*Z), "u": ca.horzcat(*[u_at(k) for k in range(N + 1)]),
                  "U": ca.horzcat(*U), "T": T, "p": p}
        return nlp, layout
