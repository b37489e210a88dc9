"""The hard-case suite (issue 22): five scenes that are hard for a simulator, each against physics
derived independently of mechnet — a modal solution, a closed-form period, hand-written CasADi models,
a piecewise closed form — at the default settings (rtol 1e-6, atol 1e-8) and at rtol 1e-4 (atol 1e-6,
the default ratio), unless the physics puts a criterion out of reach there (then the test says why and
asserts the honest bound).

1. A stiff spring chain (stiffness ratio 1e6) against its modal solution.
2. A pendulum for 10^4 periods: energy drift and phase at the accuracy study's recommended setting.
3. A planar chain with nearly massless links (1e-6 of the others) against a hand-written chain.
4. A belt-driven stick-slip oscillator: event count and event-time drift over 50 (1000) cycles.
5. A free crank-rocker four-bar through 200 toggle positions of its rocker (100 turns): loop closure
   and energy against a hand-written one-coordinate model.

`benchmarks/hard_cases.py` runs the same scenes (the slow versions too) and prints the table.
"""
from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np
import pytest
import scipy.linalg
from scipy.special import ellipk

import mechnet as mn
from mechnet import accuracy
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.components.signals import Constant

from models import four_bar

SETTINGS = [pytest.param(1e-6, 1e-8, id="rtol1e-6"), pytest.param(1e-4, 1e-6, id="rtol1e-4")]
CVODES = {"cvodes-adams": {"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"},
          "cvodes-bdf": {"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton"}}


def integrate_by_hand(x, rate, x0, grid, method, rtol, atol):
    """A hand-written explicit ODE integrated by CasADi's CVODES (Adams or BDF, as mechnet runs them) or
    IDAS, on `grid`; returns the states at every grid time, one row per state."""
    plugin, opts = ("idas", {}) if method == "idas" else ("cvodes", CVODES[method])
    F = ca.integrator("by_hand", plugin, {"x": x, "ode": rate}, float(grid[0]), [float(t) for t in grid[1:]],
                      dict(opts, reltol=rtol, abstol=atol, max_num_steps=10 ** 7))
    x0 = np.asarray(x0, dtype=float)
    return np.hstack([x0[:, None], np.array(F(x0=x0)["xf"])])


# ----------------------------------------------------------------------------- 1. stiff spring chain
STIFF_J = np.array([1.0, 1.0, 1.0, 1.0])                 # kg·m²
STIFF_C = np.array([1.0, 1e6, 10.0, 1e3])               # N·m/rad: housing–j0, j0–j1, j1–j2, j2–j3
STIFF_PHI0 = np.array([1e-3, 0.0, 0.0, 1.0])            # rad: the stiff spring pre-twisted by 1 mrad
STIFF_T_END = 10.0


def stiff_chain() -> mn.Model:
    """Housing, then four × (spring + inertia), released at rest from STIFF_PHI0."""
    m = mn.Model("stiff_chain")
    previous = m.add(rot.Fixed(name="fixed")).flange
    for k, (J, c, phi0) in enumerate(zip(STIFF_J, STIFF_C, STIFF_PHI0)):
        spring = m.add(rot.Spring(name=f"s{k}", c=float(c)))
        inertia = m.add(rot.Inertia(name=f"j{k}", J=float(J), phi_start=float(phi0), w_start=0.0))
        m.connect(previous, spring.flange_a)
        m.connect(spring.flange_b, inertia.flange_a)
        previous = inertia.flange_b
    return m


def stiff_matrices():
    n = len(STIFF_J)
    K = np.zeros((n, n))
    for k, c in enumerate(STIFF_C):          # spring k joins inertia k−1 (the housing for k = 0) and k
        K[k, k] += c
        if k > 0:
            K[k - 1, k - 1] += c
            K[k - 1, k] -= c
            K[k, k - 1] -= c
    return np.diag(STIFF_J), K


def stiff_modal(t):
    """φ(t) = Φ cos(Ω t) Φᵀ M φ0 (released at rest), Φ, Ω² from eigh(K, M): angles, one row per inertia."""
    M, K = stiff_matrices()
    lam, Phi = scipy.linalg.eigh(K, M)
    q0 = Phi.T @ M @ STIFF_PHI0
    return Phi @ (q0[:, None] * np.cos(np.outer(np.sqrt(lam), np.atleast_1d(t))))


def stiff_by_hand(grid, method, rtol, atol):
    M, K = stiff_matrices()
    n = len(STIFF_J)
    x = ca.SX.sym("x", 2 * n)
    rate = ca.vertcat(x[n:], ca.mtimes(ca.DM(-np.linalg.solve(M, K)), x[:n]))
    return integrate_by_hand(x, rate, np.r_[STIFF_PHI0, np.zeros(n)], grid, method, rtol, atol)[:n]


def run_stiff_chain(method, rtol, atol):
    cm = stiff_chain().compile()
    grid = np.linspace(0.0, STIFF_T_END, 11)
    res = cm.simulate(STIFF_T_END, n_out=11, rtol=rtol, atol=atol, method=method, progress=False)
    assert res.success, res.failure
    phi = np.array([res[f"j{k}.phi"] for k in range(len(STIFF_J))])
    exact = stiff_modal(grid)
    error = float(np.max(np.abs(phi - exact)))
    hand = float(np.max(np.abs(stiff_by_hand(grid, res.stats["method"], rtol, atol) - exact)))
    return res, error, hand


@pytest.mark.parametrize("method", ["auto", "cvodes-bdf"])
@pytest.mark.parametrize("rtol, atol", SETTINGS)
def test_stiff_spring_chain_follows_its_modal_solution(method, rtol, atol):
    # Housing –1– j0 –1e6– j1 –10– j2 –1e3– j3 (springs in N·m/rad, J = 1 kg·m² each): stiffness ratio
    # 1e6, natural frequencies 0.49, 3.2, 44.8 and 1414 rad/s. Released at rest with j3 at 1 rad and the
    # stiff spring pre-twisted by 1 mrad, so every mode moves (the 1414 rad/s one with 0.7 mrad: 2250 of
    # its periods in the horizon). Reference: the modal solution φ(t) = Φ cos(Ωt) Φᵀ M φ0 from
    # scipy.linalg.eigh(K, M), at t = 0, 1, ..., 10 s. Horizon 10 s, scale 1 rad (the largest amplitude).
    # Pass criteria: (a) max |φ − modal| over the 11 times and 4 inertias ≤ 3× the error of a hand-written
    # CasADi model of the same linear ODE (φ'' = −M⁻¹Kφ) integrated by the same CVODES method at the same
    # rtol/atol — the integrator's own phase error, which grows with the periods elapsed, is the floor
    # (measured: auto 6.9e-6 vs hand 6.2e-6 rad at rtol 1e-6, 5.8e-4 vs 5.8e-4 at 1e-4; BDF 4.8e-5 vs
    # 4.7e-5, 4.8e-4 vs 5.1e-4); (b) the error ≤ 100·rtol·scale (the 44.8 rad/s mode turns 71 times in the
    # horizon and its phase error grows with each turn: rtol per period and then some).
    res, error, hand = run_stiff_chain(method, rtol, atol)
    assert error <= 3 * hand, (error, hand)
    assert error <= 100 * rtol * 1.0, error


# ----------------------------------------------------------------------------- 2. pendulum, 10^4 periods
PEND_L, PEND_G, PEND_M, PEND_THETA0 = 1.0, 9.81, 1.0, 1.0        # m, m/s², kg, rad from the bottom
PEND_T = 4 * math.sqrt(PEND_L / PEND_G) * float(ellipk(math.sin(PEND_THETA0 / 2) ** 2))   # 2.1391 s
PEND_SWING = PEND_M * PEND_G * PEND_L * (1 - math.cos(PEND_THETA0))                       # J above the bottom
PEND_ACCEL = PEND_G / PEND_L * math.sin(PEND_THETA0)             # |θ''| at the turning point, rad/s²
PEND_PERIODS, PEND_SHORT = 10_000, 100
PEND_ENERGY, PEND_PHASE = 1e-4, 1e-3                             # the 10^4-period bounds (relative; rad)
PEND_TOLERANCES = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
# Per-period budget of the study's 1-period error e1 = max(|Δφ|, |Δw|) at t = T (a turning point): an
# angle error e1 there changes the energy by m g L sin θ0 · e1, and the relative energy drift may grow by
# PEND_ENERGY / PEND_PERIODS a period (errors adding up each period); a speed error e1 there is a time
# offset e1 / |θ''|, a phase of 2π e1 / (|θ''| T) = 0.36 e1 a period against PEND_PHASE / PEND_PERIODS.
PEND_BUDGET = min(PEND_ENERGY / PEND_PERIODS * PEND_SWING / (PEND_M * PEND_G * PEND_L * math.sin(PEND_THETA0)),
                  PEND_PHASE / PEND_PERIODS * PEND_ACCEL * PEND_T / (2 * math.pi))   # 5.5e-9 (the energy's)


def pendulum() -> mn.Model:
    """A 1 kg point mass on a massless 1 m link (Revolute about z + FixedTranslation + Particle), released
    at rest θ0 = 1 rad from the bottom (rev.phi = θ0 − π/2: the link hangs at −π/2), with an energy sensor."""
    m = mn.Model("pendulum")
    world = m.add(mb.World(name="world", g=[0.0, -PEND_G, 0.0]))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=PEND_THETA0 - math.pi / 2, w_start=0.0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[PEND_L, 0, 0]))
    bob = m.add(mb.Particle(name="bob", m=PEND_M))
    m.connect(world.frame_b, rev.frame_a)
    m.connect(rev.frame_b, rod.frame_a)
    m.connect(rod.frame_b, bob.frame_a)
    m.add(mb.SystemEnergy(name="energy"))
    return m


@pytest.fixture(scope="module")
def pendulum_cm():
    return pendulum().compile()


def pendulum_study(cm):
    """The work-precision study of one period against the closed form (back at rest at θ0 at t = T),
    `auto` (what simulate runs) at PEND_TOLERANCES; the recommended trial for PEND_BUDGET."""
    def reference(t):
        return {"rev.phi": np.full_like(t, PEND_THETA0 - math.pi / 2), "rev.w": np.zeros_like(t)}
    study = accuracy.study(cm, PEND_T, methods=["auto"], tolerances=PEND_TOLERANCES, reference=reference, repeat=1)
    return study, study.recommend(PEND_BUDGET, simulate_only=True)


def pendulum_figures(res):
    """(max |E − E0| / E_swing over the outputs, phase error in rad at the last output, a whole number of
    periods: the speed there is θ''·δt at the turning point, δt the time offset, 2π δt / T the phase)."""
    E = np.asarray(res["energy.total"])
    return (float(np.max(np.abs(E - E[0]))) / PEND_SWING,
            abs(2 * math.pi * float(res["rev.w"][-1]) / PEND_ACCEL / PEND_T))


def pendulum_by_hand(periods, method, rtol, atol):
    """θ'' = −(g/L) sin θ by CVODES in mechnet's coordinate φ = θ − π/2 (the Revolute's angle, the link
    hanging at −π/2): φ'' = −(g/L) cos φ. The coordinate matters: the error test weighs rtol·|φ|, and in θ
    (about 0 instead of −π/2) Adams drifts 0.2e-2 instead of 0.9e-2 over 10^4 periods at rtol 1e-6, and
    runs away (20× E_swing) at rtol 1e-4. Returns (energy drift / E_swing, phase) as pendulum_figures."""
    phi, w = ca.SX.sym("phi"), ca.SX.sym("w")
    grid = np.linspace(0.0, periods * PEND_T, 2001)
    X = integrate_by_hand(ca.vertcat(phi, w), ca.vertcat(w, -PEND_G / PEND_L * ca.cos(phi)),
                          [PEND_THETA0 - math.pi / 2, 0.0], grid, method, rtol, atol)
    E = PEND_M * (0.5 * PEND_L ** 2 * X[1] ** 2 + PEND_G * PEND_L * np.sin(X[0]))
    return float(np.max(np.abs(E - E[0]))) / PEND_SWING, abs(2 * math.pi * X[1, -1] / PEND_ACCEL / PEND_T)


def run_pendulum(cm, periods, method, rtol, atol):
    res = cm.simulate(periods * PEND_T, n_out=2001, rtol=rtol, atol=atol, method=method, progress=False)
    assert res.success, res.failure
    return res, *pendulum_figures(res)


def test_pendulum_study_recommends_a_setting_within_the_per_period_budget(pendulum_cm):
    # The study of one period (error at t = T against the closed form: at rest at θ0, T = 4 √(L/g) K(sin²(θ0/2))
    # = 2.1391 s) must find a setting within PEND_BUDGET = 5.5e-9 (rad and rad/s), and rtol 1e-4 must be out
    # of the budget by far (why the 10^4-period bounds are out of reach at rtol 1e-4: they ask for a phase of
    # 1e-3 rad in 6.3e4 rad, 1.6e-8 relative). Measured: auto rtol 1e-10, error 4.0e-9; rtol 1e-4 errs 1e-4.
    study, best = pendulum_study(pendulum_cm)
    assert best is not None and best.error <= PEND_BUDGET
    assert best.setting <= 1e-9
    loose = [t for t in study.trials if t.setting == 1e-4][0]
    assert loose.error > 1e3 * PEND_BUDGET, loose.error


def test_pendulum_hundred_periods_at_the_recommended_setting(pendulum_cm):
    # 100 periods (214 s) at the study's recommended setting (atol = rtol/100), n_out 2001, scale E_swing =
    # m g L (1 − cos θ0) = 4.51 J and 1 rad of phase. Bounds in proportion to the run (1/100 of the 10^4-period
    # ones): relative energy drift ≤ 1e-6, phase at t = 100 T ≤ 1e-5 rad (measured 2.9e-8 and 6.9e-7 at 1e-10).
    _, best = pendulum_study(pendulum_cm)
    _, drift, phase = run_pendulum(pendulum_cm, PEND_SHORT, best.method, best.setting, best.setting / 100)
    assert drift <= PEND_ENERGY * PEND_SHORT / PEND_PERIODS, drift
    assert phase <= PEND_PHASE * PEND_SHORT / PEND_PERIODS, phase


@pytest.mark.slow
def test_pendulum_ten_thousand_periods_at_the_recommended_setting(pendulum_cm):
    # 10^4 periods (21 391 s) at the recommended setting, n_out 2001: relative energy drift ≤ 1e-4 and phase
    # at t = 10^4 T ≤ 1e-3 rad (measured at auto rtol 1e-10: 2.7e-7 and 5.1e-4 rad, about 6 s; rtol 1e-9 —
    # within the phase budget a period, not the energy's — ends 3.4e-3 rad off: the energy drift changes
    # the period, and the phase then grows faster than linearly).
    _, best = pendulum_study(pendulum_cm)
    _, drift, phase = run_pendulum(pendulum_cm, PEND_PERIODS, best.method, best.setting, best.setting / 100)
    assert drift <= PEND_ENERGY, drift
    assert phase <= PEND_PHASE, phase


@pytest.mark.parametrize("periods", [PEND_SHORT, pytest.param(PEND_PERIODS, marks=pytest.mark.slow)])
@pytest.mark.parametrize("rtol, atol", SETTINGS)
def test_pendulum_at_fixed_settings_drifts_no_more_than_a_hand_written_model(pendulum_cm, periods, rtol, atol):
    # At the default settings and at rtol 1e-4 the 10^4-period bounds are out of reach (see the study test);
    # the honest bound is the integrator's own: the relative energy drift (n_out 2001) within 3× that of
    # the pendulum written by hand in the same coordinate and integrated by CVODES Adams (what auto runs
    # here) at the same rtol/atol. Horizon 100 T (10^4 T slow), scale E_swing. Measured: 100 T, 8.9e-5 vs
    # 5.4e-5 (rtol 1e-6), 3.3e-3 vs 7.3e-3 (1e-4); 10^4 T, 7.8e-3 vs 7.3e-3, 0.29 vs 0.32. The phase is
    # not compared here: at these settings it is 1e-3 to 0.6 rad and varies by 3× between equally good
    # integrations (the hand model written with sin(φ + π/2) instead of cos φ: 8.6e-5 vs 7.7e-4 rad at
    # 100 T, rtol 1e-6; mechnet 2.7e-3) — no bound tighter than "less than a radian" would hold.
    res, drift, _ = run_pendulum(pendulum_cm, periods, "auto", rtol, atol)
    hand_drift, _ = pendulum_by_hand(periods, res.stats["method"], rtol, atol)
    assert drift <= 3 * hand_drift, (drift, hand_drift)


# ----------------------------------------------------------------------------- 3. nearly massless links
LIGHT_SCENES = {"light joint": (1.0, 1e-6, 1.0, 1e-6),      # a 1e-6 kg pin between two heavy links, light tip
                "light tip": (1.0, 1.0, 1e-6, 1e-6)}        # a double pendulum with a two-link 1e-6 kg whip
LIGHT_L, LIGHT_G, LIGHT_PHI0, LIGHT_T_END = 1.0, 9.81, 0.3, 1.0


def light_chain(masses, length=LIGHT_L, first=LIGHT_PHI0, bend=LIGHT_PHI0, name="light_chain") -> mn.Model:
    """World, then n × (Revolute about z + FixedTranslation [length, 0, 0] + Particle m_k): point masses at
    the link ends; the first link `first` rad from hanging down, every further joint bent `bend` rad, at
    rest (here 0.3 and 0.3; the 50-link chain of test_hard_mechanisms.py uses it too)."""
    m = mn.Model(name)
    previous = m.add(mb.World(name="world", g=[0.0, -LIGHT_G, 0.0])).frame_b
    for k, mass in enumerate(masses):
        rev = m.add(mb.Revolute(name=f"rev{k}", n=[0, 0, 1], w_start=0.0,
                                phi_start=first - math.pi / 2 if k == 0 else bend))
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[length, 0, 0]))
        particle = m.add(mb.Particle(name=f"mass{k}", m=mass))
        m.connect(previous, rev.frame_a)
        m.connect(rev.frame_b, rod.frame_a)
        m.connect(rod.frame_b, particle.frame_a)
        previous = rod.frame_b
    m.add(mb.SystemEnergy(name="energy"))
    return m


def light_chain_by_hand(masses, grid, method, rtol, atol):
    """The chain in its relative joint angles φ and speeds, derived by hand: absolute angles θ = cumsum(φ),
    the mass k at Σ_{j≤k} L (cos θ_j, sin θ_j); with μ_jk = Σ_{i ≥ max(j,k)} m_i (the masses outboard of
    both links), M_jk = L² μ_jk cos(θ_j − θ_k), f_j = −g L μ_jj cos θ_j − L² Σ_k μ_jk sin(θ_j − θ_k) θ̇_k²,
    M θ̈ = f (solved by CasADi's symbolic QR). Returns (φ, energy) on the grid."""
    n = len(masses)
    phi, w = ca.SX.sym("phi", n), ca.SX.sym("w", n)
    th, thd = ca.cumsum(phi), ca.cumsum(w)
    c, s = ca.cos(th), ca.sin(th)
    mu = ca.DM([[sum(masses[max(j, k):]) for k in range(n)] for j in range(n)])
    M = LIGHT_L ** 2 * mu * (c @ c.T + s @ s.T)
    f = -LIGHT_G * LIGHT_L * ca.diag(mu) * c - LIGHT_L ** 2 * (mu * (s @ c.T - c @ s.T)) @ (thd * thd)
    thdd = ca.solve(M, f)
    x0 = np.r_[LIGHT_PHI0 - math.pi / 2, [LIGHT_PHI0] * (n - 1), np.zeros(n)]
    X = integrate_by_hand(ca.vertcat(phi, w), ca.vertcat(w, thdd - ca.vertcat(0, thdd[:-1])), x0, grid, method,
                          rtol, atol)
    th, thd = np.cumsum(X[:n], axis=0), np.cumsum(X[n:], axis=0)
    y = np.cumsum(LIGHT_L * np.sin(th), axis=0)
    vx, vy = np.cumsum(-LIGHT_L * np.sin(th) * thd, axis=0), np.cumsum(LIGHT_L * np.cos(th) * thd, axis=0)
    energy = sum(mk * (0.5 * (vx[k] ** 2 + vy[k] ** 2) + LIGHT_G * y[k]) for k, mk in enumerate(masses))
    return X[:n], energy


@functools.lru_cache(maxsize=None)
def light_chain_reference(scene):
    """The hand model at rtol 1e-11, atol 1e-13 by Adams, and its distance from BDF at the same settings
    (1e-12 costs 5 s here: the nearly singular mass matrix leaves round-off in the accelerations)."""
    grid = np.linspace(0.0, LIGHT_T_END, 21)
    reference, _ = light_chain_by_hand(LIGHT_SCENES[scene], grid, "cvodes-adams", 1e-11, 1e-13)
    check, _ = light_chain_by_hand(LIGHT_SCENES[scene], grid, "cvodes-bdf", 1e-11, 1e-13)
    return reference, float(np.max(np.abs(check - reference)))


def run_light_chain(scene, method, rtol, atol):
    masses = LIGHT_SCENES[scene]
    grid = np.linspace(0.0, LIGHT_T_END, 21)
    reference, reference_error = light_chain_reference(scene)
    res = light_chain(masses).compile().simulate(LIGHT_T_END, n_out=21, rtol=rtol, atol=atol, method=method,
                                                 progress=False)
    assert res.success, res.failure
    phi = np.array([res[f"rev{k}.phi"] for k in range(len(masses))])
    E = np.asarray(res["energy.total"])
    hand, hand_E = light_chain_by_hand(masses, grid, res.stats["method"], rtol, atol)
    return {"error": float(np.max(np.abs(phi - reference))), "hand_error": float(np.max(np.abs(hand - reference))),
            "reference_error": reference_error,
            "drift": float(np.max(np.abs(E - E[0]))), "hand_drift": float(np.max(np.abs(hand_E - hand_E[0])))}


@pytest.mark.parametrize("method", ["auto", "cvodes-bdf"])
@pytest.mark.parametrize("rtol, atol", SETTINGS)
@pytest.mark.parametrize("scene", list(LIGHT_SCENES))
def test_nearly_massless_links_follow_a_hand_written_chain(scene, rtol, atol, method):
    # A planar four-link chain of 1 m links with point masses (1, 1e-6, 1, 1e-6) kg ("light joint": the pin
    # between the two heavy links and the tip carry 1e-6 kg; the light pin makes a fast, nearly massless
    # mode) or (1, 1, 1e-6, 1e-6) kg ("light tip"), released at rest bent 0.3 rad at every joint, 1 s,
    # 21 outputs. The multibody model (not a 1D stand-in) against the chain's dynamics derived by hand in
    # joint coordinates (light_chain_by_hand). Reference: the hand model at rtol 1e-11, atol 1e-13 (Adams;
    # BDF at the same settings must agree within 1e-6 rad: measured 1e-8). Pass criteria: the relative angles' error against
    # the reference ≤ 3× the hand model's error at the same method and rtol/atol; the energy drift ≤ 3×
    # the hand model's. Scale 1 rad, horizon 1 s. Measured (auto, rtol 1e-6 / 1e-4): light joint 6.1e-3 vs
    # 6.2e-3 rad, 0.20 vs 0.21 rad — the nearly massless pin makes the angles that sensitive for any
    # integrator; light tip 1.3e-6 vs 9.6e-7, 9.8e-5 vs 9.8e-5 rad.
    out = run_light_chain(scene, method, rtol, atol)
    assert out["reference_error"] <= 1e-6, out
    assert out["error"] <= 3 * out["hand_error"], out
    assert out["drift"] <= 3 * out["hand_drift"], out


# ----------------------------------------------------------------------------- 4. stick-slip, 1000 cycles
SS_M, SS_C, SS_G, SS_MU_S, SS_MU_K, SS_V = 1.0, 20.0, 9.81, 0.4, 0.25, 0.2   # kg, N/m, m/s², 1, 1, m/s
SS_FS, SS_FK = SS_MU_S * SS_M * SS_G, SS_MU_K * SS_M * SS_G                 # static, kinetic limit (N)
SS_OMEGA = math.sqrt(SS_C / SS_M)
SS_D = (SS_FS - SS_FK) / SS_C                       # breakaway point from the sliding equilibrium F_k/c (m)
SS_ALPHA = math.atan2(SS_V / SS_OMEGA, SS_D)
SS_STICK = 2 * SS_D / SS_V                           # stuck on the belt from x_k − d to x_k + d: 0.736 s
SS_SLIP = (math.pi + 2 * SS_ALPHA) / SS_OMEGA        # slipping on the harmonic arc: 0.947 s
SS_CYCLE = SS_STICK + SS_SLIP                        # 1.683 s
SS_FIRST = SS_FS / SS_C / SS_V                       # first breakaway, stuck from s = 0: 0.981 s


def stick_slip() -> mn.Model:
    """examples/stick_slip.py's scene: wall –spring c– block m –Friction(μs, μk)– belt at V, the block
    starting at s = 0 with the belt's speed (stuck)."""
    m = mn.Model("stick_slip")
    wall = m.add(tr.Fixed(name="wall"))
    spring = m.add(tr.Spring(name="spring", c=SS_C))
    block = m.add(tr.Mass(name="block", m=SS_M, s_start=0.0, v_start=SS_V))
    friction = m.add(tr.Friction(name="friction", fn=SS_M * SS_G, mu_k=SS_MU_K, mu_s=SS_MU_S))
    belt = m.add(tr.Speed(name="belt", v_ref=Constant(SS_V), s_start=0.0))
    m.connect(wall.flange, spring.flange_a)
    m.connect(spring.flange_b, block.flange_a)
    m.connect(belt.flange, friction.flange_a)
    m.connect(friction.flange_b, block.flange_b)
    return m


def stick_slip_times(cycles):
    """Piecewise closed form: stuck, the block rides the belt until c·s = F_s (t = F_s/(c V)); slipping,
    m s'' = −c s + F_k, from x_k + d with speed V (x_k = F_k/c, d = (F_s − F_k)/c), the arc
    s − x_k = d cos ωτ + (V/ω) sin ωτ, until the speed is V again at τ = (π + 2α)/ω, α = atan(V/(ω d)),
    at x_k − d, where it sticks (the spring needs c·|x_k − d| < F_s); then stuck again for 2d/V. Every
    breakaway restarts from the same state, so the cycle repeats exactly: breakaway k (k = 0, 1, ...) at
    SS_FIRST + k·SS_CYCLE, stick k at that + SS_SLIP."""
    breaks = SS_FIRST + SS_CYCLE * np.arange(cycles)
    return breaks, breaks + SS_SLIP


def run_stick_slip(cycles, rtol, atol):
    t_end = SS_FIRST + (cycles - 1) * SS_CYCLE + SS_SLIP + SS_STICK / 2        # halfway through the last stick
    res = stick_slip().compile().simulate(t_end, n_out=201, rtol=rtol, atol=atol, progress=False)
    assert res.success, res.failure
    state = [e for e in res.events if e.kind == "state"]
    breaks = np.array([e.t for e in state if "breaks away" in e.cause])
    sticks = np.array([e.t for e in state if "sticks" in e.cause])
    return res, state, breaks, sticks


@pytest.mark.parametrize("cycles", [50, pytest.param(1000, marks=pytest.mark.slow)])
@pytest.mark.parametrize("rtol, atol", SETTINGS)
def test_stick_slip_cycles_count_and_drift(cycles, rtol, atol):
    # The belt-driven oscillator (c = 20 N/m, m = 1 kg, μs = 0.4, μk = 0.25, belt 0.2 m/s) for 50 cycles
    # (1000 slow), ending halfway through a stick phase. Pass criteria: exactly `cycles` breakaways and
    # `cycles` sticks, alternating, and nothing else; the k-th (k = 1, 2, ...) breakaway and stick each
    # within 10·k·rtol·T_cycle of the closed form (T_cycle = 1.683 s, the scale; the time errors of the
    # slip arcs add up cycle by cycle, since every breakaway restarts from the same state). Measured per
    # cycle: 2.7e-6 s at rtol 1e-6 (bound 1.7e-5), 9.7e-5 s at rtol 1e-4 (bound 1.7e-3).
    res, state, breaks, sticks = run_stick_slip(cycles, rtol, atol)
    assert len(state) == 2 * cycles
    assert breaks.size == cycles and sticks.size == cycles
    assert np.all(breaks < sticks) and np.all(sticks[:-1] < breaks[1:])
    exact_breaks, exact_sticks = stick_slip_times(cycles)
    k = np.arange(1, cycles + 1)
    assert np.all(np.abs(breaks - exact_breaks) <= 10 * k * rtol * SS_CYCLE), np.max(np.abs(breaks - exact_breaks))
    assert np.all(np.abs(sticks - exact_sticks) <= 10 * k * rtol * SS_CYCLE), np.max(np.abs(sticks - exact_sticks))


# ----------------------------------------------------------------------------- 5. four-bar through toggles
FB_A, FB_B, FB_C, FB_D = 0.2, 0.6, 0.5, 0.6          # crank, coupler, rocker, ground (m): a crank-rocker
FB_MASSES, FB_G, FB_THETA0, FB_W0 = (1.0, 2.0, 1.5), 9.81, 0.3, 20.0
FB_TURNS, FB_T_END, FB_N_OUT = 100, 36.0, 7201


def four_bar_by_hand():
    """The four-bar in its crank angle θ, independent of mechnet: B = a(cos θ, sin θ), C the upper
    intersection of |C − B| = b and |C − D| = c (D = (d, 0)); slender rods (m L²/12 about the middle);
    M(θ) θ'' + ½ M'(θ) θ'² + V'(θ) = 0. Returns (x = [θ, θ'], ẋ, E(θ, θ'))."""
    th, w = ca.SX.sym("theta"), ca.SX.sym("w")
    A, D = ca.DM([0.0, 0.0]), ca.DM([FB_D, 0.0])
    B = FB_A * ca.vertcat(ca.cos(th), ca.sin(th))
    dist = ca.norm_2(D - B)
    along = (FB_B ** 2 - FB_C ** 2 + dist ** 2) / (2 * dist)
    e = (D - B) / dist
    C = B + along * e + ca.sqrt(FB_B ** 2 - along ** 2) * ca.vertcat(-e[1], e[0])
    M, V = 0, 0
    for (p, q, L), m in zip(((A, B, FB_A), (B, C, FB_B), (D, C, FB_C)), FB_MASSES):
        centre, angle = (p + q) / 2, ca.atan2(q[1] - p[1], q[0] - p[0])
        M += m * ca.sumsqr(ca.jacobian(centre, th)) + m * L ** 2 / 12 * ca.jacobian(angle, th) ** 2
        V += m * FB_G * centre[1]
    accel = -(0.5 * ca.jacobian(M, th) * w ** 2 + ca.jacobian(V, th)) / M
    return ca.vertcat(th, w), ca.vertcat(w, accel), ca.Function("E", [th, w], [0.5 * M * w ** 2 + V])


def rocker_limits():
    """The rocker's toggle angles (from +x): crank and coupler in line, |AC| = b + a and b − a; the angle
    at D of the triangle A D C by the law of cosines, θ4 = π − ∠ADC."""
    return tuple(math.pi - math.acos((FB_D ** 2 + FB_C ** 2 - r ** 2) / (2 * FB_D * FB_C))
                 for r in (FB_B + FB_A, FB_B - FB_A))


def run_four_bar(rtol, atol):
    m = four_bar(FB_A, FB_B, FB_C, FB_D, theta2=FB_THETA0, masses=FB_MASSES, g=FB_G)
    m.add(mb.SystemEnergy(name="energy"))
    res = m.compile().simulate(FB_T_END, n_out=FB_N_OUT, rtol=rtol, atol=atol, start={"joint_a.w": FB_W0},
                               progress=False)
    assert res.success, res.failure
    gap = max(float(np.max(np.abs(res[f"{p}.frame_a.r_0[{i}]"] - res[f"{p}.frame_b.r_0[{i}]"])))
              for p in ("joint_a", "joint_b", "joint_c", "joint_d") for i in range(3))
    E = np.asarray(res["energy.total"])
    x, rate, energy = four_bar_by_hand()
    X = integrate_by_hand(x, rate, [FB_THETA0, FB_W0], res.t, "idas", rtol, atol)
    E_hand = np.array(energy(X[0], X[1])).ravel()
    return {"res": res, "gap": gap, "drift": float(np.max(np.abs(E - E[0]))),
            "hand_drift": float(np.max(np.abs(E_hand - E_hand[0]))), "E0": float(E[0]), "hand_E0": float(E_hand[0]),
            "turns": float(res["joint_a.phi"][-1] - FB_THETA0) / (2 * math.pi)}


@pytest.mark.parametrize("rtol, atol", SETTINGS)
def test_free_four_bar_through_two_hundred_toggles(rtol, atol):
    # The crank-rocker of tests/models.py (a = 0.2, b = 0.6, c = 0.5, d = 0.6 m; 1, 2, 1.5 kg slender rods;
    # gravity), free and undamped, launched at θ2 = 0.3 rad with 20 rad/s: it turns over 100 times in 36 s
    # (7201 outputs), the rocker passing its two toggle positions (crank and coupler in line) every turn.
    # tests/hard/test_loop_singularities.py covers toggles of a triple rocker swinging for 3 s and the
    # parallelogram's change points; this is the long run of a crank-rocker. Pass criteria:
    # - at least 100 turns; the rocker swings between its closed-form toggle angles 1.5208 and 2.4189 rad:
    #   never beyond them by more than the loop tolerance 10·(rtol·d + atol)/c rad, and within 1e-3 rad of
    #   both (the outputs are 0.1 rad of crank apart: measured 3e-7 rad off at rtol 1e-6, 1.1e-4 at 1e-4);
    # - every pin closes within 10·(rtol·d + atol), scale d = 0.6 m (measured 4.7e-6 m at rtol 1e-6, 3.6e-4
    #   at 1e-4: the closest margin of the suite, 1.3×);
    # - the energy (mb.SystemEnergy, E0 = 21.37 J) drifts at most 3× as much as a hand-written CasADi model
    #   in the crank angle (four_bar_by_hand, IDAS at the same rtol/atol on the same grid), which starts at the
    #   same energy within 1e-9 J. Measured: 1.05e-2 vs 1.48e-2 J at rtol 1e-6; 0.49 vs 0.80 J at 1e-4.
    out = run_four_bar(rtol, atol)
    res = out["res"]
    assert out["turns"] >= FB_TURNS, out["turns"]
    low, high = rocker_limits()
    th4 = np.asarray(res["joint_d.phi"])
    loop = 10 * (rtol * FB_D + atol)
    assert low - loop / FB_C <= th4.min() <= low + 1e-3, (th4.min(), low)
    assert high - 1e-3 <= th4.max() <= high + loop / FB_C, (th4.max(), high)
    assert out["gap"] <= loop, out["gap"]
    assert abs(out["E0"] - out["hand_E0"]) <= 1e-9
    assert out["drift"] <= 3 * out["hand_drift"], (out["drift"], out["hand_drift"])
