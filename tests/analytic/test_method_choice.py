"""method="auto": Adams for a non-stiff ODE, BDF once stiffness shows, IDAS for a DAE (issue 17, item 6).

The stiff scene is linear (a heavy mass on a soft spring, a 1 g mass on a 1e8 N/m spring-damper to
it), so its exact solution is the matrix exponential; the scene that becomes stiff mid-run is checked
against SciPy's Radau at rtol 1e-10, an independent implicit integrator.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import mechnet as mn
from mechnet.components import translational as tr
from mechnet.components.translational.interfaces import PartialCompliant
from mechnet.core.declarations import Param
from mechnet.core.equation import Eq, der, time
from models import cartesian_pendulum, oscillator

M, K1, S0 = 1.0, 100.0, 0.1              # heavy mass (kg), soft spring (N/m), start (m)
ML, K, D = 1e-3, 1e8, 2e3                 # light mass, stiff spring and damper: eigenvalues -5e4, -2e6 1/s
RTOL, ATOL = 1e-6, 1e-8                   # simulate()'s defaults


class EngagingDamper(PartialCompliant):
    """A damper whose constant rises smoothly from 0 to d around t_on (over ~0.1 s, no time event):
    stiffness that appears in the middle of a run."""

    d = Param(unit="N*s/m", doc="final damping constant")
    t_on = Param(unit="s", doc="engagement time")

    def equations(self):
        engaged = self.d * (1 + ca.tanh((time - self.t_on) / 0.05)) / 2
        return self.compliant_equations() + [
            Eq(self.f, engaged * der(self.flange_b.s - self.flange_a.s), "engaging damping")]


def two_masses(coupling) -> mn.Model:
    """Ground - soft spring - heavy mass - coupling - light mass, both masses at S0 and at rest."""
    m = mn.Model("two_masses")
    ground = m.add(tr.Fixed(name="ground"))
    soft = m.add(tr.Spring(name="soft", c=K1))
    heavy = m.add(tr.Mass(name="heavy", m=M, s_start=S0, v_start=0.0))
    light = m.add(tr.Mass(name="light", m=ML, s_start=S0, v_start=0.0))
    m.connect(ground.flange, soft.flange_a)
    m.connect(soft.flange_b, heavy.flange_a)
    for element in coupling:
        m.add(element)
        m.connect(heavy.flange_b, element.flange_a)
        m.connect(element.flange_b, light.flange_a)
    return m


def hand_bdf_error(rhs, t, exact):
    """The error of a hand-written CasADi model of the same ODE, CVODES BDF at simulate()'s default
    tolerances on the same grid: global error at rtol 1e-6 is well above rtol·scale (a 3 s run of the
    stiff pair: 4e-6 m on 0.1 m), so the bound is this model's error ×3."""
    y, tt = ca.SX.sym("y", 4), ca.SX.sym("t")
    F = ca.integrator("F", "cvodes", {"x": y, "t": tt, "ode": ca.vertcat(*rhs(tt, y))}, t[0], list(t[1:]),
                      {"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton",
                       "reltol": RTOL, "abstol": ATOL})
    heavy = np.concatenate([[S0], np.asarray(F(x0=[S0, 0, S0, 0])["xf"])[0]])
    return np.max(np.abs(heavy - exact))


def pair(t, y, d):
    """The two masses' rates: y = [heavy s, v, light s, v], coupling K1 + d(t) (EngagingDamper) or K, D."""
    sh, vh, sl, vl = y[0], y[1], y[2], y[3]
    k = K if d is None else K1
    f = k * (sl - sh) + (D if d is None else d(t)) * (vl - vh)
    return [vh, (-K1 * sh + f) / M, vl, -f / ML]


def method_events(res):
    return [e for e in res.events if e.kind == "method"]


def test_a_stiff_scene_falls_back_to_bdf_and_matches_the_matrix_exponential():
    cm = two_masses([tr.SpringDamper(name="stiff", c=K, d=D)]).compile()
    res = cm.simulate(3.0)
    bdf = cm.simulate(3.0, method="cvodes-bdf")
    assert res.success and res.stats["method"] == "cvodes-bdf"
    [event] = method_events(res)
    assert event.t == 0.0 and "cvodes-adams -> cvodes-bdf" in event.cause and "stiff" in event.cause
    assert "cvodes-bdf" in res.stats["method_reason"]
    # the failed Adams probe is not counted; what ran is BDF's own run, step for step
    assert res.stats["nsteps"] == bdf.stats["nsteps"] < 1000
    A = np.array([[0, 1, 0, 0], [-(K1 + K) / M, -D / M, K / M, D / M],
                  [0, 0, 0, 1], [K / ML, D / ML, -K / ML, -D / ML]])
    exact = np.array([expm(A * t) @ [S0, 0, S0, 0] for t in res.t])
    # 3 s (half a period of the slow mode) at rtol 1e-6, atol 1e-8: within 3x a hand-written BDF model's
    # error at the same settings (both ~4e-6 m on a 0.1 m scale)
    bound = 3 * hand_bdf_error(lambda t, y: pair(t, y, None), res.t, exact[:, 0])
    assert np.max(np.abs(res["heavy.s"] - exact[:, 0])) < bound
    assert np.max(np.abs(res["light.s"] - exact[:, 2])) < bound


def test_a_non_stiff_scene_stays_with_adams():
    J, c, phi0 = 0.1, 100.0, 0.5
    res = oscillator(J=J, c=c, phi0=phi0).compile().simulate(5.0)
    assert res.stats["method"] == "cvodes-adams" and res.stats["plugin"] == "cvodes"
    assert not method_events(res) and res.stats["method_reason"].startswith("auto: CVODES Adams")
    w = np.sqrt(c / J)
    # 5 s = 25 periods at rtol 1e-6, atol 1e-8, scale 0.5 rad: bound 10·(rtol·scale + atol)·25 periods
    assert np.max(np.abs(res["j1.phi"] - phi0 * np.cos(w * res.t))) < 10 * (RTOL * phi0 + ATOL) * 25


def test_stiffness_that_appears_mid_run_is_caught():
    cm = two_masses([EngagingDamper(name="clutch", d=D, t_on=1.0), tr.Spring(name="link", c=K1)]).compile()
    res = cm.simulate(3.0)
    assert res.success and res.stats["method"] == "cvodes-bdf"
    [event] = method_events(res)
    assert "cvodes-adams -> cvodes-bdf" in event.cause
    bdf = cm.simulate(3.0, method="cvodes-bdf")
    assert res.stats["nsteps"] == bdf.stats["nsteps"] < 10_000     # Adams alone: 5e6 steps, 20 s

    ref = solve_ivp(lambda t, y: pair(t, y, lambda t: D * (1 + np.tanh((t - 1.0) / 0.05)) / 2), (0, 3.0),
                    [S0, 0, S0, 0], method="Radau", t_eval=res.t, rtol=1e-10, atol=1e-12)
    # 3 s at rtol 1e-6, atol 1e-8: within 3x a hand-written BDF model's error at the same settings
    bound = 3 * hand_bdf_error(lambda t, y: pair(t, y, lambda t: D * (1 + ca.tanh((t - 1.0) / 0.05)) / 2),
                               res.t, ref.y[0])
    assert np.max(np.abs(res["heavy.s"] - ref.y[0])) < bound


def test_long_output_intervals_are_not_mistaken_for_stiffness():
    # 100 rad/s over 20 s in two output intervals: ~7500 Adams steps each, over the probe budget of
    # 4096. BDF, tried with an eighth of that, runs out too: not stiff, and Adams goes on without the
    # probe budget, at the cost of Adams alone (review: the whole run had been redone with BDF)
    J, c, phi0 = 0.01, 100.0, 0.5
    cm = oscillator(J=J, c=c, phi0=phi0).compile()
    res = cm.simulate(20.0, n_out=3)
    adams = cm.simulate(20.0, n_out=3, method="cvodes-adams")
    assert res.success and res.stats["method"] == "cvodes-adams"
    [event] = method_events(res)
    assert event.t == 0.0 and "not stiffness" in event.cause
    assert res.stats["nsteps"] == adams.stats["nsteps"]
    assert np.array_equal(res["j1.phi"], adams["j1.phi"])
    w = np.sqrt(c / J)
    # 320 periods at rtol 1e-6: the phase error grows linearly; bound 10·(rtol·scale + atol)·320
    assert np.max(np.abs(res["j1.phi"] - phi0 * np.cos(w * res.t))) < 10 * (RTOL * phi0 + ATOL) * 320


def test_method_events_are_stamped_in_time_order_in_a_monitored_run():
    # review: a switch decided at the end of a monitored piece was stamped there, after the state events
    # the piece was then cut at. A bouncing ball (state events) beside masses whose damper engages at
    # 1.3 s: every event list is sorted, and the switch lies within the run.
    from models import BouncingBall
    m = two_masses([EngagingDamper(name="clutch", d=D, t_on=1.3), tr.Spring(name="link", c=K1)])
    m.add(BouncingBall(name="ball", h_start=1.0, v_start=0.0))
    cm = m.compile()
    for n_out in (4, 101, 501):
        res = cm.simulate(3.0, n_out=n_out)
        times = [e.t for e in res.events]
        assert times == sorted(times), res.events
        assert res.stats["method"] == "cvodes-bdf" and len(method_events(res)) == 1


def test_a_dae_runs_with_idas_and_says_why():
    cm = cartesian_pendulum().compile()
    res = cm.simulate(0.5)
    assert res.stats["method"] == "idas" and "1 algebraic variable" in res.stats["method_reason"]
    assert "method (auto): auto: IDAS" in cm.summary()


def test_the_summary_names_the_method_auto_chooses():
    assert "method (auto): auto: CVODES Adams" in oscillator().compile().summary()


@pytest.mark.parametrize("method", ["cvodes-adams", "cvodes-bdf", "idas"])
def test_an_explicit_method_is_kept_on_a_stiff_scene(method):
    # asked for by name, a method is never switched (Adams crawls: keep the run short)
    cm = two_masses([tr.SpringDamper(name="stiff", c=K, d=D)]).compile()
    res = cm.simulate(1e-3 if method == "cvodes-adams" else 0.1, method=method)
    assert res.stats["method"] == method and not method_events(res)
