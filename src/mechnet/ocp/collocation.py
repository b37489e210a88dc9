"""Direct collocation on the index-reduced DAE, algebraic equations included.

On each of N intervals the states are a polynomial of degree `degree` through the interval's start and
its collocation points (Radau or Legendre); the ODE holds at the collocation points, the algebraic
equations (a loop's dependent coordinates) at the collocation points, at t = 0 and at the end. Path
constraints and bounds on named quantities are enforced at t = 0 and at every collocation point (with
Legendre points also at the end; the interval boundaries between are not collocation points);
bounds on states and inputs are bounds of the decision variables themselves. Integrals use the
collocation quadrature. The states are the start point's selection (`cm.dae`); `Solution.verify`
checks it held.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .problem import MAX_VARIABLES, OcpError
from .transcription import Transcription

MAX_DEGREE = 9              # CasADi's Radau and Legendre points stop at order 9


def coefficients(degree: int, scheme: str):
    """(tau, C, D, W): collocation times in [0, 1] with 0 first; C[r, j] the derivative at tau_j of the
    Lagrange polynomial through all the tau with 1 at tau_r; D[r] its value at 1; W[j - 1] the
    quadrature weight of collocation point j (the integral of the polynomial through tau_1..tau_d alone
    that is 1 at tau_j: the integrand is known at the collocation points only; Radau with one point
    would otherwise weigh it by 1/2)."""
    tau = np.array([0.0] + list(ca.collocation_points(degree, scheme)))
    n = tau.size
    C, D = np.zeros((n, n)), np.zeros(n)
    for r in range(n):
        poly = _lagrange(tau, r)
        D[r] = poly(1.0)
        C[r] = np.polyder(poly)(tau)
    W = np.array([np.polyint(_lagrange(tau[1:], j))(1.0) for j in range(degree)])
    return tau, C, D, W


def _lagrange(points, r) -> np.poly1d:
    poly = np.poly1d([1.0])
    for k, point in enumerate(points):
        if k != r:
            poly *= np.poly1d([1.0, -point]) / (points[r] - point)
    return poly


class Collocation(Transcription):
    """`Collocation(N=50, degree=3, scheme="radau" | "legendre", controls="constant" | "linear")`."""

    # the NLP expanded to one SX graph when it stays small (`expand`): a cart-pole's function evaluations
    # 7-10x faster and its solve 2x; but building the expanded Hessian of a robot arm (1000 ODE
    # instructions, N = 40) took 3 s more than the whole solve saved, and 3x the memory
    EXPAND_MAX = 50_000            # collocation points x model instructions

    @property
    def expand(self) -> bool:
        return self._size <= self.EXPAND_MAX

    def __init__(self, N: int, degree: int = 3, scheme: str = "radau", controls: str = "constant",
                 hessian: str | None = None):
        super().__init__(N, controls, hessian)
        from ..core.arguments import whole_number
        self.degree = whole_number(degree, "degree", 1)
        if self.degree > MAX_DEGREE:
            raise OcpError(f"degree = {self.degree}: collocation points go up to degree {MAX_DEGREE}; for more "
                           f"accuracy raise N")
        if self.N * (self.degree + 1) > MAX_VARIABLES:     # at least one variable a point, whatever the model
            raise OcpError(f"N = {self.N}: {self.N} intervals of {self.degree + 1} points exceed the "
                           f"{MAX_VARIABLES:.0e} decision variables a transcription may have")
        if not isinstance(scheme, str) or scheme not in ("radau", "legendre"):
            raise OcpError(f"scheme = {scheme!r}: choose 'radau' or 'legendre'")
        if controls == "linear" and self.degree < 2:
            raise OcpError("controls='linear' needs degree >= 2: with one collocation point per interval the "
                           "control is seen at one time only, and its slope is left free")
        self.scheme = scheme

    def __getstate__(self):
        """The settings only: what `prepare` and `transcribe` build (the last problem's CasADi functions)
        every solve builds again."""
        return {k: self.__dict__[k] for k in ("N", "controls", "hessian", "degree", "scheme")}

    def variables(self, prob) -> int:
        """The number of decision variables (before they are made): states and algebraics at every point
        and at the end, an input at every node."""
        dae = prob.dae
        return (self.N * (self.degree + 1) + 1) * (dae.x.numel() + dae.z.numel()) + (self.N + 1) * dae.u.numel()

    def transcribe(self, prob, guess):
        dae = prob.dae
        size = self.variables(prob)
        if size > MAX_VARIABLES:
            raise OcpError(f"N = {self.N}: collocation of model {prob.cm.name!r} at degree {self.degree} would have "
                           f"{size:.3g} decision variables, more than {MAX_VARIABLES:.0e} (about 3 kB each while "
                           f"the NLP is built); lower N")
        self._size = self.N * self.degree * dae.n_instructions()
        N, d = self.N, self.degree
        tau, C, D, W = coefficients(d, self.scheme)
        nx_, nz = dae.x.numel(), dae.z.numel()
        shares = [(k + tj) / N for k in range(N) for tj in tau] + [1.0]
        setup = self.start(prob, guess, shares, [min(k * (d + 1), len(shares) - 1) for k in range(N + 1)])
        nlp, T, p, d_values, h, U = setup.nlp, setup.T, setup.p, setup.d, setup.h, setup.U
        Xg, Zg, xn, zn = setup.X0, setup.Z0, setup.xn, setup.zn
        xlo, xhi = self.state_bounds(prob)

        def control(k, s):
            return U[k] if self.controls == "constant" else U[k] + s * (U[k + 1] - U[k])

        def at_point(fn, t, x, z, u):
            return fn(t, x, z, u, p, d_values, T)

        X = nlp.variable("X_0", nx_, Xg[0], xlo, xhi, xn)
        Zs = nlp.variable("Z_start", nz, Zg[0], -np.inf, np.inf, zn)
        starts = self.start_value_fn(0.0, X, Zs, control(0, 0.0), p, d_values)
        nlp.constrain(starts - ca.DM(self.start_values), 0.0, 0.0, [f"start value {n}" for n in self.start_names], 0.0)
        if nz:
            nlp.constrain(dae.alg(0.0, X, Zs, control(0, 0.0), p, d_values), 0.0, 0.0, _alg_labels(dae), 0.0)
        self._path(nlp, at_point(self.path_fn, 0.0, X, Zs, control(0, 0.0)), 0.0)
        start_values = at_point(self.start_fn, 0.0, X, Zs, control(0, 0.0))
        integrals = 0
        read = {"t": [ca.MX(0.0)], "x": [X], "z": [Zs], "u": [control(0, 0.0)]}
        for k in range(N):
            Xc, Zc = [], []
            for j in range(1, d + 1):
                i = k * (d + 1) + j
                Xc.append(nlp.variable(f"X_{k}_{j}", nx_, Xg[i], xlo, xhi, xn))
                Zc.append(nlp.variable(f"Z_{k}_{j}", nz, Zg[i], -np.inf, np.inf, zn))
            points = [X] + Xc
            for j in range(1, d + 1):
                t_j = (k + tau[j]) * h
                u_j = control(k, tau[j])
                slope = sum(C[r, j] * points[r] for r in range(d + 1))
                rate = dae.ode(t_j, Xc[j - 1], Zc[j - 1], u_j, p, d_values)
                nlp.constrain((h * rate - slope) / ca.DM(xn) if nx_ else ca.MX(0, 1), 0.0, 0.0,
                              [f"der({n})" for n in dae.x_names], (k + tau[j]) / N)
                if nz:
                    nlp.constrain(dae.alg(t_j, Xc[j - 1], Zc[j - 1], u_j, p, d_values), 0.0, 0.0,
                                  _alg_labels(dae), (k + tau[j]) / N)
                self._path(nlp, at_point(self.path_fn, t_j, Xc[j - 1], Zc[j - 1], u_j), (k + tau[j]) / N)
                integrals = integrals + h * W[j - 1] * at_point(self.integrand_fn, t_j, Xc[j - 1], Zc[j - 1], u_j)
                read["t"].append(t_j)
                read["x"].append(Xc[j - 1])
                read["z"].append(Zc[j - 1])
                read["u"].append(u_j)
            end = sum(D[r] * points[r] for r in range(d + 1))
            X = nlp.variable(f"X_{k + 1}", nx_, Xg[(k + 1) * (d + 1) if k + 1 < N else -1], xlo, xhi, xn)
            nlp.constrain((end - X) / ca.DM(xn) if nx_ else ca.MX(0, 1), 0.0, 0.0,
                          [f"continuity of {n}" for n in dae.x_names], (k + 1) / N)
        u_end = control(N - 1, 1.0)
        Ze = nlp.variable("Z_end", nz, Zg[-1], -np.inf, np.inf, zn)
        if nz:
            nlp.constrain(dae.alg(T, X, Ze, u_end, p, d_values), 0.0, 0.0, _alg_labels(dae), 1.0)
        end_values = at_point(self.end_fn, T, X, Ze, u_end)
        if self.scheme == "legendre":           # the end is not a collocation point: constrain it, output it
            self._path(nlp, at_point(self.path_fn, T, X, Ze, u_end), 1.0)
            read["t"].append(T)
            read["x"].append(X)
            read["z"].append(Ze)
            read["u"].append(u_end)
        boundary = self.boundary_function(prob)(start_values, end_values,
                                                integrals if isinstance(integrals, ca.MX) else ca.MX(0, 1),
                                                T, self.parameter_values(prob, p))
        nlp.constrain(boundary[1:], [c.lower for c in prob.point], [c.upper for c in prob.point],
                      [c.label for c in prob.point], 1.0)
        layout = {"objective": boundary[0], "read": ["t", "x", "z", "u", "U", "T", "p"],
                  "t": ca.horzcat(*read["t"]), "x": ca.horzcat(*read["x"]), "z": ca.horzcat(*read["z"]),
                  "u": ca.horzcat(*read["u"]), "U": ca.horzcat(*U), "T": T, "p": p}
        return nlp, layout

    def _path(self, nlp, values, t):
        if values.numel():
            nlp.constrain(values, self.path_lower, self.path_upper, self.path_labels, t)

    def node_times(self, T):
        return np.linspace(0.0, T, self.N + 1)


def _alg_labels(dae):
    return [f"algebraic equation for {n}" for n in dae.z_names]
