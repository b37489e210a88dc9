"""Baumgarte stabilisation (CasADi's dae_reduce_index) against mechnet's dummy derivatives.

The Cartesian pendulum (x, y, vx, vy, lam; index 3) compiled both ways and run
with IDAS at the same settings. With Baumgarte every coordinate stays a state
and the rod length is only kept by the damped correction, so it drifts; with
dummy derivatives y is algebraic and solved from the rod length itself.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

import mechnet as mn
from mechnet.compile.index_reduction import IndexReductionOptions
from models import CartesianPendulum, cartesian_pendulum

ROD = "p (CartesianPendulum), equation 5 — rod length"
BAUMGARTE = mn.CompileOptions(reduce=IndexReductionOptions(method="baumgarte", baumgarte_pole=-10.0))


def _drift(res, L=1.0):
    return float(np.max(np.abs(np.hypot(res["p.x"], res["p.y"]) - L)))


def test_baumgarte_pendulum_drift_against_dummy_derivatives(record_property):
    cm = cartesian_pendulum(0.5).compile(BAUMGARTE)
    index = cm.stages["index"]
    assert index.index == 3 and index.differentiated == ((ROD, 2),)
    assert index.dummies == () and index.levels == () and index.factory is None
    assert "Baumgarte pole -10" in index.summary()
    # no state selection: all four coordinates stay states, plus CasADi's first-order der(p.x), der(p.y)
    assert set(cm.state_names) == {"p.x", "p.y", "p.vx", "p.vy", "der(p.x)", "der(p.y)"}
    assert "index-1 DAE" in cm.summary()

    res_b = cm.simulate(10.0, rtol=1e-8)
    res_d = cartesian_pendulum(0.5).compile().simulate(10.0, rtol=1e-8)
    assert res_b.success and res_d.success
    drift_b, drift_d = _drift(res_b), _drift(res_d)
    record_property("drift_baumgarte", drift_b)
    record_property("drift_dummy_derivatives", drift_d)
    print(f"max |sqrt(x^2+y^2) - L| over 10 s, IDAS rtol 1e-8: Baumgarte (pole -10) {drift_b:.3g} "
          f"({res_b.stats['nsteps']} steps), dummy derivatives {drift_d:.3g} ({res_d.stats['nsteps']} steps)")
    # Measured (casadi 3.8.2, IDAS, rtol 1e-8, atol 1e-8, theta0 = 0.5, 10 s): Baumgarte pole -10:
    # 7.6e-9 (3064 steps); dummy derivatives: 2.0e-8 (2183 steps; y is solved from the rod length by
    # IDAS's Newton iteration, converged to within the tolerance, not to round-off). Without the
    # correction (pole 0) the Baumgarte route drifts to 4.3e-7; pole -1: 3.7e-8. Pole -100 needs
    # ~1e6 IDAS steps and -1000 fails: IDAS keeps the algebraic variables (which carry pole² times the
    # constraint residual) in its error test.
    assert np.isfinite(drift_b) and drift_b < 1e-2
    assert np.isfinite(drift_d) and drift_d < 1e-2
    # the same motion: over 10 s (about 5 periods) the two agree to the integration error
    # (measured: x 5.5e-7, vx 1.8e-6, lam 5.6e-6 at scales 0.5, 1.4, 12)
    for name, tol in (("p.x", 1e-5), ("p.y", 1e-5), ("p.vx", 3e-5), ("p.lam", 1e-4)):
        assert np.max(np.abs(res_b[name] - res_d[name])) < tol, name
    # the run starts on the constraint manifold: every invariant is fixed to 0 at t = 0
    for k in range(len(cm.dae.invariant_names)):
        assert abs(res_b[f"invariant[{k}]"][0]) < 1e-10


def test_baumgarte_start_point_follows_start_values_and_parameters():
    # the invariants are start conditions: another x start and rod length give a consistent start
    m = mn.Model("pendulum")
    m.add(CartesianPendulum(name="p", L=mn.tunable(1.0), x_start=0.48, y_guess=-0.88, vx_start=0.0))
    cm = m.compile(BAUMGARTE)
    res = cm.simulate(1.0, rtol=1e-8, start={"p.x": 0.3}, params={"p.L": 2.0}, guess={"p.y": -2.0})
    assert res.success
    assert res["p.x"][0] == 0.3
    # y from the rod length (Newton to 1e-10 relative), drift over 1 s measured 2.5e-9
    assert abs(res["p.y"][0] + np.sqrt(4.0 - 0.09)) < 1e-9
    assert _drift(res, L=2.0) < 1e-6


def test_invariants_are_casadis():
    # dae.invariants (labelled, computed here) and CasADi's own dropped constraints "I" are the same set
    cm = cartesian_pendulum(0.5).compile(BAUMGARTE)
    dae = cm.dae
    assert dae.invariant_names == (ROD, f"d/dt {ROD}", "der(p.x) = p.vx", "der(p.y) = p.vy")
    rng = np.random.default_rng(1)
    x, z = rng.normal(size=dae.x.numel()), rng.normal(size=dae.z.numel())
    ours = np.asarray(dae.invariants(0.3, x, z, [], [], [])).ravel()
    casadis = np.asarray(dae.info["casadi_invariants"](0.3, x, z, [], [], [])).ravel()
    assert np.allclose(np.sort(ours), np.sort(casadis), rtol=1e-14, atol=1e-14)
    assert isinstance(dae.invariants, ca.Function)
