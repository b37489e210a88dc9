"""Core I acceptance: rotational scenes against closed-form solutions."""
from __future__ import annotations

import numpy as np
import pytest

from models import inertia_chain, oscillator


def test_undamped_oscillator_100_periods():
    # phi(t) = phi0 cos(omega t), omega = sqrt(c/J).
    # rtol = atol = 1e-10, horizon 100 periods (19.9 s), scale phi0 = 0.5 rad: |error| < 1e-6 rad.
    J, c, phi0 = 0.1, 100.0, 0.5
    omega = np.sqrt(c / J)
    period = 2 * np.pi / omega
    cm = oscillator(J=J, c=c, phi0=phi0).compile()
    res = cm.simulate(100 * period, rtol=1e-10, atol=1e-10, n_out=20001)
    assert res.success
    err = np.max(np.abs(res["j1.phi"] - phi0 * np.cos(omega * res.t)))
    assert err < 1e-6, err
    # the spring torque c·phi_rel = c·phi is observed, not a state; same bound scaled by c
    assert np.max(np.abs(res["spring.tau"] - c * phi0 * np.cos(omega * res.t))) < 1e-6 * c


def test_damped_oscillator_underdamped_closed_form():
    # Underdamped: phi = e^{-zeta w0 t} (phi0 cos wd t + zeta w0 phi0 / wd sin wd t), w(0) = 0.
    # rtol = atol = 1e-10, horizon 5 s (about 25 periods, amplitude decays to 8 %), scale phi0 = 0.5: < 1e-7.
    J, c, d, phi0 = 0.1, 100.0, 0.1, 0.5
    w0 = np.sqrt(c / J)
    zeta = d / (2 * np.sqrt(c * J))
    wd = w0 * np.sqrt(1 - zeta**2)
    cm = oscillator(J=J, c=c, d=d, phi0=phi0).compile()
    res = cm.simulate(5.0, rtol=1e-10, atol=1e-10, n_out=5001)
    t = res.t
    exact = np.exp(-zeta * w0 * t) * (phi0 * np.cos(wd * t) + zeta * w0 * phi0 / wd * np.sin(wd * t))
    assert np.max(np.abs(res["j1.phi"] - exact)) < 1e-7
    # energy balance: kinetic + potential + dissipated = initial, scale c phi0^2 / 2, same tolerance regime
    E = 0.5 * J * res["j1.w"] ** 2 + 0.5 * c * res["j1.phi"] ** 2
    dissipated = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (d * res["j1.w"][1:] ** 2 + d * res["j1.w"][:-1] ** 2))])
    E0 = 0.5 * c * phi0**2
    # trapezoidal quadrature of the dissipation on dt = 1 ms: error O(dt^2 w0^2) ~ 1e-4 relative
    assert np.max(np.abs(E + dissipated - E0)) / E0 < 1e-3


def test_chain_of_20_compiles_to_explicit_ode_and_auto_uses_cvodes():
    cm = inertia_chain(n=20, d=0.1).compile()
    assert cm.dae.is_ode
    assert cm.algebraic_names == ()
    assert cm.n_states == 40
    res = cm.simulate(0.1)
    assert res.stats["method"] == "cvodes-adams" and res.stats["plugin"] == "cvodes"   # non-stiff: Adams


@pytest.fixture(scope="module")
def chain_runs():
    cm = inertia_chain(n=20, d=0.1).compile()
    rtol = atol = 1e-8
    return {m: cm.simulate(0.5, rtol=rtol, atol=atol, method=m, n_out=101)
            for m in ("auto", "idas", "cvodes-bdf", "cvodes-adams")}, rtol, atol


@pytest.mark.parametrize("method", ["idas", "cvodes-bdf", "cvodes-adams"])
def test_chain_methods_agree(chain_runs, method):
    # All four methods against a tight reference (scipy expm of the linear system below).
    # rtol = atol = 1e-8, horizon 0.5 s, scale 1 rad (initial displacement): each within 10·(rtol·1 + atol),
    # and within 10x that of each other.
    runs, rtol, atol = chain_runs
    ref = _chain_reference(runs["auto"].t)
    for m in ("auto", method):
        err = max(np.max(np.abs(runs[m][f"j{k}.phi"] - ref[:, k])) for k in range(20))
        assert err < 10 * (rtol * 1.0 + atol) * 10, (m, err)
    diff = max(np.max(np.abs(runs[method][f"j{k}.phi"] - runs["auto"][f"j{k}.phi"])) for k in range(20))
    assert diff < 10 * 10 * (rtol + atol)


def _chain_reference(t, n=20, J=0.01, c=1e3, d=0.1):
    """Exact solution of the linear chain via the matrix exponential."""
    from scipy.linalg import expm

    K = np.zeros((n, n))
    D = np.zeros((n, n))
    for k in range(n):
        # element k joins inertia k-1 (or the fixed end) to inertia k
        K[k, k] += c
        D[k, k] += d
        if k > 0:
            K[k - 1, k - 1] += c
            K[k, k - 1] -= c
            K[k - 1, k] -= c
            D[k - 1, k - 1] += d
            D[k, k - 1] -= d
            D[k - 1, k] -= d
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K / J, -D / J]])
    x0 = np.zeros(2 * n)
    x0[n - 1] = 1.0
    return np.array([expm(A * tk) @ x0 for tk in t])[:, :n]


def test_every_dotted_name_is_readable():
    m = oscillator(d=0.1)
    cm = m.compile()
    res = cm.simulate(0.2)
    flat = cm.stages["flat"]
    for v in flat.variables:
        values = res[v.name]
        assert values.shape == res.t.shape and np.all(np.isfinite(values)), v.name
    # aliases carry the right values and signs (Modelica conventions)
    assert np.allclose(res["spring.flange_b.phi"], res["j1.phi"], rtol=0, atol=1e-14)
    assert np.allclose(res["spring.flange_a.tau"], -res["spring.tau"], rtol=0, atol=1e-12)
    assert np.allclose(res["fixed.flange.tau"], res["spring.tau"], rtol=0, atol=1e-12)
    assert np.all(res["fixed.flange.phi"] == 0.0)
