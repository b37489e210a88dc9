"""Conservation and turning points of 3D rotation (Spherical joint, quaternion orientation).

1. a spherical pendulum from a general start (tilted 0.8 rad, an azimuthal rate well below the conical
   one: a precessing rosette, not a circle): energy and the vertical angular momentum about the pivot
   conserved at most 3× as badly as by a hand-written CasADi model of the same rigid body integrated
   with the same CVODES settings (the project's rule for conservation bounds), and the bob's path on the
   hand model's early on;
2. a heavy symmetric top released with no precession rate: the nutation's turning angle against the
   root of the cubic f(u) = 0 in u = cos θ (Goldstein, *Classical Mechanics*, 3rd ed., §5.7).

Conventions as in test_rotation_3d.py: frame orientations are observed as `<frame>.R[k]`, row-major,
columns = the frame's axes in world; a Spherical joint's w_rel is frame_b's angular velocity in frame_b
axes (the body's, when frame_a is the world).
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet import inertia
from mechnet.components import multibody as mb

G = 9.81

# mechnet's methods as CVODES options (src/mechnet/simulate/solvers.py, PLUGINS), for the hand model
CVODES_OPTIONS = {"cvodes-adams": dict(linear_multistep_method="adams", nonlinear_solver_iteration="functional"),
                  "cvodes-bdf": dict(linear_multistep_method="bdf", nonlinear_solver_iteration="newton")}


def _connect(m, pairs):
    for a, b in pairs:
        m.connect(a, b)


def _rotation(Q):
    """R(Q/|Q|) for a quaternion (w, x, y, z), written out (CasADi or numpy entries)."""
    w, x, y, z = Q[0], Q[1], Q[2], Q[3]
    n = w * w + x * x + y * y + z * z
    return [[1 - 2 * (y * y + z * z) / n, 2 * (x * y - w * z) / n, 2 * (x * z + w * y) / n],
            [2 * (x * y + w * z) / n, 1 - 2 * (x * x + z * z) / n, 2 * (y * z - w * x) / n],
            [2 * (x * z - w * y) / n, 2 * (y * z + w * x) / n, 1 - 2 * (x * x + y * y) / n]]


# ---- 1. spherical pendulum ------------------------------------------------------------------------

SP_MASS, SP_L, SP_RADIUS = 1.0, 1.0, 0.05
SP_TILT, SP_RATE = 0.8, 2.0          # rad about world x; rad/s about the world vertical (conical: 3.75)
SP_TOL = dict(rtol=1e-10, atol=1e-10)
SP_GRID = np.linspace(0.0, 20.0, 2001)


def _spherical_pendulum():
    """A small solid sphere (1 kg, radius 5 cm) on a 1 m rod from a spherical joint at the world origin,
    gravity −z; tilted by SP_TILT about x and started turning about the world vertical at SP_RATE (the
    whole rigid body: ω = SP_RATE·e_z, so the bob moves at SP_RATE·L·sin(SP_TILT) horizontally)."""
    m = mn.Model("spherical_pendulum")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    m.add(mb.SystemEnergy(name="energy"))
    m.add(mb.SystemMomentum(name="mom", point=[0.0, 0.0, 0.0]))
    ball = m.add(mb.Spherical(name="ball", axis_start=[1, 0, 0], angle_start=SP_TILT, w_rel_a_start=[0, 0, SP_RATE]))
    rod = m.add(mb.FixedTranslation(name="rod", r=[0.0, 0.0, -SP_L]))
    bob = m.add(mb.Body(name="bob", m=SP_MASS, I=inertia.sphere(SP_MASS, SP_RADIUS)))
    _connect(m, [(world.frame_b, ball.frame_a), (ball.frame_b, rod.frame_a), (rod.frame_b, bob.frame_a)])
    return m.compile()


def _sp_pivot_inertia():
    """Inertia about the pivot in body axes: I_sphere + m(|r|²·1 − r rᵀ), r = (0, 0, −L) the bob's offset."""
    r = np.array([0.0, 0.0, -SP_L])
    return (2 / 5) * SP_MASS * SP_RADIUS ** 2 * np.eye(3) + SP_MASS * (r @ r * np.eye(3) - np.outer(r, r)), r


def _sp_invariants(Q, w):
    """Energy (J) and vertical angular momentum about the pivot (kg·m²/s) of the pendulum at body-axes
    states Q (4, n) and ω (3, n), and the bob's world position (3, n)."""
    I, r = _sp_pivot_inertia()
    R = np.array(_rotation(Q))                           # (3, 3, n)
    bob = np.einsum("ijn,j->in", R, r)
    T = 0.5 * np.einsum("in,ij,jn->n", w, I, w)
    V = SP_MASS * G * bob[2]
    Lz = np.einsum("jn,jk,kn->n", R[2], I, w)            # (R I ω)_z
    return T + V, Lz, bob


def _hand_written_spherical_pendulum(method, grid, calls=1):
    """The pendulum as one rigid body about a fixed point, in mechnet's coordinates (Q, ω in body axes):
    dQ/dt = ½·Q ⊗ (0, ω), I·dω/dt = r × Rᵀ(m g) − ω × I ω (Euler's equations about the pivot), with
    R = R(Q/|Q|). CVODES with mechnet's options for `method`, at SP_TOL, over the grid in `calls` calls
    of equally many output intervals, restarted from Q/|Q| (as mechnet restarts)."""
    I, r = _sp_pivot_inertia()
    Q, w = ca.SX.sym("Q", 4), ca.SX.sym("w", 3)
    R = ca.SX(3, 3)
    for i, row in enumerate(_rotation(Q)):
        for j, entry in enumerate(row):
            R[i, j] = entry
    torque = ca.cross(ca.DM(r), ca.mtimes(R.T, ca.DM([0.0, 0.0, -SP_MASS * G])))
    dw = ca.solve(ca.DM(I), torque - ca.cross(w, ca.mtimes(ca.DM(I), w)))
    dQ = 0.5 * ca.vertcat(-ca.dot(Q[1:], w), Q[0] * w + ca.cross(Q[1:], w))
    x = ca.vertcat(Q, w)
    opts = dict(CVODES_OPTIONS[method], reltol=SP_TOL["rtol"], abstol=SP_TOL["atol"], max_num_steps=100_000)
    Q0 = np.r_[np.cos(SP_TILT / 2), np.sin(SP_TILT / 2), 0.0, 0.0]
    R0 = np.array(_rotation(Q0))
    X = [np.r_[Q0, R0.T @ np.array([0.0, 0.0, SP_RATE])][:, None]]
    bounds = [round(k * (grid.size - 1) / calls) for k in range(calls + 1)]
    for a, b in zip(bounds[:-1], bounds[1:]):
        x0 = X[-1][:, -1].copy()
        x0[:4] /= np.linalg.norm(x0[:4])
        F = ca.integrator("hand", "cvodes", {"x": x, "ode": ca.vertcat(dQ, dw)}, grid[a], list(grid[a + 1: b + 1]),
                          opts)
        X.append(F(x0=x0)["xf"].full())
    X = np.hstack(X)
    return X[:4], X[4:]


def test_spherical_pendulum_conserves_energy_and_vertical_momentum_like_a_hand_written_model():
    """Energy and L_z about the pivot, mechnet against the same rigid body written by hand in CasADi.

    Settings: rtol 1e-10, atol 1e-10, horizon 20 s, 2001 output points (both models), CVODES with the
    method mechnet ran (`res.stats["method"]`: Adams with functional iteration under "auto"). Scales:
    energy m·g·L = 9.81 J, momentum m·√(g·L³) = 3.13 kg·m²/s, position L = 1 m. Drift: max over the
    grid of |X − X(0)|/scale.

    Restarts: a grid of ≥ 1000 points runs in 20 integrator calls (progress chunks, 1 s each here),
    each restarting CVODES from order 1 with Q renormalised; the restarts are part of mechnet's
    settings, so the reference for the 3× rule is the hand model restarted at the same times (it then
    reproduces mechnet's trajectory within 2e-12 m: the two right-hand sides agree to round-off).
    Measured: energy drift 9.18e-9 (mechnet) vs 9.18e-9 (hand, 20 calls); L_z 1.99e-9 vs 1.99e-9.
    Against the hand model in ONE call (5.72e-9 and 4.23e-10) mechnet's drift is 1.6× and 4.7×: the
    20 restarts, not the model, cost that (mechnet on a 999-point grid, one call, drifts 5.72e-9 and
    4.23e-10). This is reported, not asserted: the rule's reference is the same settings.

    Also: SystemEnergy and SystemMomentum against the formulas at mechnet's own states (algebraic,
    round-off only: 1e-12 of the scales), the observed bob position against R·r (1e-14 m); the bob's
    position against the ONE-call hand model for t ≤ 2 s within 1e-7 m (an independent integration;
    measured 3.3e-9 m; 7e-8 m by 20 s as the two runs' errors separate along the orbit) and against
    the restarted one over all 20 s within 1e-7 m (measured 1.9e-12 m; the bound leaves room for a
    round-off difference flipping one step decision).
    """
    cm = _spherical_pendulum()
    assert cm.n_states == 7 and cm.dae.z.numel() == 0
    res = cm.simulate(SP_GRID[-1], t_out=SP_GRID, **SP_TOL)
    assert res.success
    method = res.stats["method"]
    assert method in CVODES_OPTIONS, method
    assert res.stats["segments"] == 20, res.stats        # the progress chunks, restarted every 1 s
    Q = np.vstack([res[f"ball.Q[{i}]"] for i in range(4)])
    w = np.vstack([res[f"ball.w_rel[{i}]"] for i in range(3)])
    E, Lz, bob = _sp_invariants(Q, w)
    e_scale, l_scale = SP_MASS * G * SP_L, SP_MASS * np.sqrt(G * SP_L ** 3)
    # the sensors against the formulas (and the observed position against R·r) at mechnet's states
    E_mn, Lz_mn = res["energy.total"], res["mom.L[2]"]
    assert np.max(np.abs(E_mn - E)) <= 1e-12 * e_scale
    assert np.max(np.abs(Lz_mn - Lz)) <= 1e-12 * l_scale
    r = np.vstack([res[f"bob.frame_a.r_0[{i}]"] for i in range(3)])
    assert np.max(np.abs(r - bob)) <= 1e-14
    # a general start, neither planar nor conical: the bob's height varies by 0.215 m, and successive
    # lowest points lie 3.57 rad apart in azimuth, not π (a closed ellipse's): the orbit precesses by
    # 0.42 rad a swing (sampled at 0.01 s: ±0.06 rad)
    assert np.ptp(r[2]) > 0.2
    low = np.flatnonzero((r[2, 1:-1] < r[2, :-2]) & (r[2, 1:-1] < r[2, 2:])) + 1
    azimuth = np.unwrap(np.arctan2(r[1], r[0]))
    assert len(low) >= 15 and np.min(np.diff(azimuth[low])) - np.pi > 0.3

    drift_E, drift_L = np.max(np.abs(E_mn - E_mn[0])) / e_scale, np.max(np.abs(Lz_mn - Lz_mn[0])) / l_scale
    hand = {}
    for calls in (20, 1):
        Eh, Lzh, bobh = _sp_invariants(*_hand_written_spherical_pendulum(method, SP_GRID, calls))
        assert E_mn[0] == pytest.approx(Eh[0], abs=1e-14) and Lz_mn[0] == pytest.approx(Lzh[0], abs=1e-14)
        hand[calls] = (np.max(np.abs(Eh - Eh[0])) / e_scale, np.max(np.abs(Lzh - Lzh[0])) / l_scale,
                       np.linalg.norm(r - bobh, axis=0))
    print(f"\nmethod {method}: drift mechnet E {drift_E:.3g}, L_z {drift_L:.3g}; hand (20 calls) E {hand[20][0]:.3g}, "
          f"L_z {hand[20][1]:.3g}; hand (1 call) E {hand[1][0]:.3g}, L_z {hand[1][1]:.3g}; bob gap to hand (20 "
          f"calls) {np.max(hand[20][2]):.3g} m, to hand (1 call) {np.max(hand[1][2][SP_GRID <= 2.0]):.3g} m "
          f"(t ≤ 2 s), {np.max(hand[1][2]):.3g} m (20 s)")
    assert drift_E <= 3 * hand[20][0]
    assert drift_L <= 3 * hand[20][1]
    assert np.max(hand[1][2][SP_GRID <= 2.0]) <= 1e-7
    assert np.max(hand[20][2]) <= 1e-7


# ---- 2. heavy symmetric top released without precession --------------------------------------------

TOP_MASS, TOP_L, TOP_A_CM, TOP_C = 1.0, 0.1, 0.002, 0.004     # kg, m (pivot to mass centre), kg·m² (cm)
TOP_THETA0, TOP_SPIN = 0.5, 50.0                              # rad from the vertical, rad/s about the axis
TOP_TOL = dict(rtol=1e-12, atol=1e-12)
TOP_GRID = np.linspace(0.0, 2.8, 28001)                       # 1e-4 s apart: 4.7 nutation periods of 0.6 s


def _released_top():
    """The top of test_rotation_3d.py (`_top`: pivot at the tip, the world origin; symmetry axis body z,
    mass centre at l on it) tilted by θ0 about world x and released spinning at ω3 about its axis with
    no precession and no nutation rate: ω = (0, 0, ω3) in body axes (φ̇ = θ̇ = 0, ψ̇ = ω3)."""
    R0 = mb.frames.matrix_of_quaternion(mb.frames.quaternion_of_axis_angle([1, 0, 0], TOP_THETA0))
    m = mn.Model("released_top")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    pivot = m.add(mb.Spherical(name="pivot", R_rel_start=R0, w_rel_start=[0.0, 0.0, TOP_SPIN]))
    body = m.add(mb.Body(name="top", m=TOP_MASS, r_cm=[0.0, 0.0, TOP_L], I=np.diag([TOP_A_CM, TOP_A_CM, TOP_C])))
    _connect(m, [(world.frame_b, pivot.frame_a), (pivot.frame_b, body.frame_a)])
    return m.compile()


def _turning_cosines():
    """The roots in [−1, 1] of Goldstein's cubic f(u) = (β − α·u)(1 − u²) − (b − a·u)², ascending.

    A = A_cm + m·l² (about the pivot), C about the axis. Euler angles φ, θ, ψ; u = cos θ. The Lagrangian
    ½A(θ̇² + φ̇² sin²θ) + ½C(ψ̇ + φ̇ cos θ)² − m·g·l·cos θ has the cyclic momenta p_ψ = C·ω3 = A·a and
    p_φ = A·φ̇·sin²θ + C·ω3·cos θ = A·b, and the energy E = ½A(θ̇² + φ̇² sin²θ) + ½C·ω3² + m·g·l·cos θ;
    with E' = E − ½C·ω3², β = 2E'/A, α = 2m·g·l/A, eliminating φ̇ = (b − a·u)/(1 − u²) gives
    u̇² = f(u): θ turns where f(u) = 0. Released at θ0 with φ̇ = θ̇ = 0: b = a·u0, β = α·u0, so
    f(u) = (u0 − u)·[α(1 − u²) − a²(u0 − u)]: u0 is a root and the other turning point is
    u1 = (a² − √(a⁴ − 4α·a²·u0 + 4α²))/(2α) (the third root lies above 1). The cubic is solved here as
    written (numpy.roots on its coefficients), u1's closed form checks it."""
    A = TOP_A_CM + TOP_MASS * TOP_L ** 2
    a, alpha, u0 = TOP_C * TOP_SPIN / A, 2 * TOP_MASS * G * TOP_L / A, np.cos(TOP_THETA0)
    b, beta = a * u0, alpha * u0
    # (β − αu)(1 − u²) − (b − au)² = αu³ − (β + a²)u² + (2ab − α)u + β − b²
    roots = np.roots([alpha, -(beta + a * a), 2 * a * b - alpha, beta - b * b])
    inside = np.sort(roots.real[(np.abs(roots.imag) < 1e-12) & (np.abs(roots.real) <= 1)])
    u1 = (a * a - np.sqrt(a ** 4 - 4 * alpha * a * a * u0 + 4 * alpha ** 2)) / (2 * alpha)
    assert len(inside) == 2 and abs(inside[0] - u1) < 1e-14 and abs(inside[1] - u0) < 1e-14, (inside, u1, u0)
    return inside


def _refined_extrema(t, u, kind):
    """Each interior sampled extremum of u (kind "min" or "max") refined by the parabola through it and its
    two neighbours (spacing h): (times, values, error bound). The parabola interpolates u within
    |u'''|·h³·max|s(s² − 1)|/6 = |u'''|·h³/(9√3) over the three samples (s ∈ [−1, 1]), and both extrema
    lie among them, so its vertex value is within that of u's extremum; |u'''|·h³ is bounded by the
    largest third difference |Δ³u| over the run (plus its own round-off, 8·1e-16)."""
    mid = u[1:-1]
    if kind == "min":
        k = np.flatnonzero((mid < u[:-2]) & (mid <= u[2:])) + 1
    else:
        k = np.flatnonzero((mid > u[:-2]) & (mid >= u[2:])) + 1
    h = t[1] - t[0]
    um, u0, up = u[k - 1], u[k], u[k + 1]
    curvature = (up - 2 * u0 + um) / 2
    slope = (up - um) / 2
    s = -slope / (2 * curvature)                  # vertex, in units of h from the sample
    bound = (np.max(np.abs(np.diff(u, 3))) + 8e-16) / (9 * np.sqrt(3))
    return t[k] + s * h, u0 - slope ** 2 / (4 * curvature), bound


def test_a_released_top_nutates_to_the_root_of_goldsteins_cubic():
    """The symmetry axis' tilt θ(t) = arccos(top.frame_a.R[8]) swings between θ0 and θ1 = arccos(u1), the
    roots of Goldstein's cubic (`_turning_cosines`), within 1e-8 rad at every turning point.

    Settings: rtol 1e-12, atol 1e-12, horizon 2.8 s (4.7 nutation periods of 0.6 s), outputs 1e-4 s
    apart; scale: θ1 − θ0 = 0.69 rad (θ0 = 0.5, θ1 = 1.193; ω3 = 50 rad/s, m = 1 kg, l = 0.1 m,
    A = 0.012, C = 0.004 kg·m²: a slow top, so the nutation is large and far from the gyroscopic limit).
    Each turning point is read off the three samples around the sampled extremum of u = cos θ by the
    vertex of their parabola (`_refined_extrema`; measurement error bound |Δ³u|max/(9√3), asserted
    below 1e-10 in u, i.e. 1.1e-10 rad at θ1, leaving the rest of 1e-8 to the integrator).
    The run's first point is itself a turning point (θ̇ = 0 at release), so the minima of θ are
    measured from the second on.
    """
    u_low, u_high = _turning_cosines()
    theta1, theta0 = np.arccos(u_low), np.arccos(u_high)
    assert theta0 == pytest.approx(TOP_THETA0, abs=1e-12)
    cm = _released_top()
    res = cm.simulate(TOP_GRID[-1], t_out=TOP_GRID, **TOP_TOL)
    assert res.success
    u = res["top.frame_a.R[8]"]
    t_max, u_max_theta, bound_max = _refined_extrema(res.t, u, "min")      # θ largest where u is smallest
    t_min, u_min_theta, bound_min = _refined_extrema(res.t, u, "max")
    assert len(t_max) == 5 and len(t_min) == 4, (t_max, t_min)
    assert max(bound_max, bound_min) <= 1e-10
    err_1 = np.abs(np.arccos(u_max_theta) - theta1)
    err_0 = np.abs(np.arccos(u_min_theta) - theta0)
    print(f"\nθ1 = {theta1:.12f}: turning points at {np.round(t_max, 5)} s, |error| {err_1.max():.3g} rad; "
          f"θ0 returns at {np.round(t_min, 5)} s, |error| {err_0.max():.3g} rad; measurement bound "
          f"{max(bound_max, bound_min):.3g} in u")
    assert np.max(err_1) <= 1e-8
    assert np.max(err_0) <= 1e-8
    # the nutation is periodic: the turning times are evenly spaced (1e-6 s: sampled vertex times)
    assert np.ptp(np.diff(t_max)) <= 1e-6 and np.ptp(np.diff(t_min)) <= 1e-6
