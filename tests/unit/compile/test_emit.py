"""emit: ode / alg / observed functions, torn variables, pruned sensors."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import mechnet as mn
from mechnet.compile.alias import simplify
from mechnet.compile.casadi_dae import emit
from mechnet.compile.flatten import flatten
from mechnet.compile.structure import analyze_structure
from mechnet.components import rotational as rot
from stage_scenes import Cubic, evaluate, oscillator, single


def run_stages(model):
    flat = flatten(model)
    simplified, aliases = simplify(flat)
    structure = analyze_structure(simplified)
    return flat, emit(flat, simplified, aliases, structure)


def cubic_root(x: float) -> float:
    """The real root of z + z³ = x (the cubic is monotone, so the bracket [-|x|-1, |x|+1] holds it)."""
    bound = abs(x) + 1.0
    return brentq(lambda z: z + z ** 3 - x, -bound, bound, xtol=1e-15, rtol=4 * np.finfo(float).eps)


def flat_residuals(flat, dae, t, x, z, u=(), p=None):
    """Every flat equation evaluated at the values `observed` gives for every flat variable."""
    p = list(dae.p_value) if p is None else p
    y = np.asarray(dae.observed(t, x, z, list(u), p, [])).ravel()
    values = y[:len(flat.variables)]
    symbols = [v.symbol for v in flat.variables] + [q.symbol for q in flat.parameters]
    return evaluate([e.residual for e in flat.equations], symbols, np.concatenate([values, p]))


# ---- a model that stays a DAE ---------------------------------------------------------------

def test_a_nonlinear_constraint_stays_algebraic():
    flat, dae = run_stages(single(Cubic("c", x_start=1.0)))
    assert not dae.is_ode
    assert dae.x_names == ("c.x",)
    assert "c.z" in dae.z_names
    assert dae.alg.size_out(0) == (1, 1)                # alg non-empty: one residual for one tear
    assert dae.info["torn"] == 1
    # alg is the cubic itself: zero at the real root, non-zero elsewhere
    x0 = 1.0
    z0 = cubic_root(x0)
    # static: brentq to 4 eps on z ~ 0.68; the residual has slope 1 + 3 z^2 ~ 2.4, so it is
    # below 1e-14 absolute (rtol not used) at scale 1
    assert abs(float(dae.alg(0.0, x0, z0, [], [], []))) < 1e-14
    assert abs(float(dae.alg(0.0, x0, z0 + 0.1, [], [], []))) > 0.1
    # ode is -z exactly; the flat residuals are sums of O(1) terms: rtol 0, atol 1e-15 / 1e-14, static
    np.testing.assert_allclose(np.asarray(dae.ode(0.0, x0, z0, [], [], [])).ravel(), [-z0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(flat_residuals(flat, dae, 0.0, [x0], [z0]), 0.0, rtol=0, atol=1e-14)


def test_the_dae_simulates_with_idas_and_agrees_with_an_independent_solution():
    cm = single(Cubic("c", x_start=1.0)).compile()
    res = cm.simulate(1.0, rtol=1e-10, atol=1e-10, method="auto", n_out=11)
    assert res.success
    assert res.stats["plugin"] == "idas"

    reference = solve_ivp(lambda t, x: [-cubic_root(x[0])], (0.0, 1.0), [1.0], method="DOP853",
                          rtol=1e-12, atol=1e-12, t_eval=[1.0])
    assert reference.success
    x_ref = reference.y[0, -1]
    # mechnet: IDAS rtol = atol = 1e-10; reference: DOP853 rtol = atol = 1e-12; horizon 1 s,
    # x decays from 1 to ~0.46 (scale 1): global error ~1e-10 observed, atol 1e-7 allowed (rtol 0)
    assert res["c.x"][-1] == pytest.approx(x_ref, rel=0, abs=1e-7)
    assert res["c.z"][-1] == pytest.approx(cubic_root(x_ref), rel=0, abs=1e-7)


# ---- observed -------------------------------------------------------------------------------

def test_observed_returns_every_dotted_name():
    m = mn.Model("tuned")
    j1 = m.add(rot.Inertia("j1", J=2.0, phi_start=1.0))
    spring = m.add(rot.Spring("spring", c=mn.tunable(8.0)))
    fixed = m.add(rot.Fixed("fixed"))
    speed = m.add(rot.SpeedSensor("speed"))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j1.flange_a)
    m.connect(j1.flange_b, speed.flange)
    flat, dae = run_stages(m)
    names = tuple(v.name for v in flat.variables) + ("spring.c",)
    assert dae.observed_names == names
    assert dae.observed.size_out(0) == (len(names), 1)
    y = np.asarray(dae.observed(0.0, [0.3, -0.7], [], [], [8.0], [])).ravel()
    assert np.all(np.isfinite(y))
    at = dict(zip(names, y))
    assert at["spring.c"] == 8.0
    assert at["fixed.flange.phi"] == 0.0
    assert at["speed.w"] == at["j1.w"] == -0.7
    # every flat equation holds at the observed values (an ODE model: any state is consistent);
    # static, values of scale 1 (phi = 0.3 rad, w = -0.7 rad/s, c = 8): rtol 0, atol 1e-14
    np.testing.assert_allclose(flat_residuals(flat, dae, 0.0, [0.3, -0.7], [], p=[8.0]), 0.0, rtol=0, atol=1e-14)
    # and the derivative variables agree with ode
    xdot = np.asarray(dae.ode(0.0, [0.3, -0.7], [], [], [8.0], [])).ravel()
    assert [at["der(j1.phi)"], at["der(j1.w)"]] == list(xdot)
    # a = -c phi / J = -1.2 rad/s^2, two roundings: rtol 1e-15, static
    assert at["der(j1.w)"] == pytest.approx(-8.0 * 0.3 / 2.0, rel=1e-15, abs=0)


# ---- pruning --------------------------------------------------------------------------------

@pytest.mark.parametrize("sensor", [rot.SpeedSensor, rot.PowerSensor])
def test_an_unused_sensor_is_reported_as_pruned(sensor):
    cm = oscillator(sensor=sensor).compile()
    assert cm.dae.info["observed_only"] > 0
    assert f"{cm.dae.info['observed_only']} only observed" in cm.summary()


@pytest.mark.parametrize("sensor", [rot.SpeedSensor, rot.AngleSensor, rot.PowerSensor, rot.TorqueSensor])
def test_an_unused_sensor_costs_nothing_in_ode_and_alg(sensor):
    bare = oscillator().compile()
    probed = oscillator(sensor=sensor).compile()
    assert probed.state_names == bare.state_names
    assert probed.algebraic_names == bare.algebraic_names == ()
    assert probed.dae.n_instructions() == bare.dae.n_instructions()


def test_a_pruned_speed_sensor_is_still_readable():
    cm = oscillator(sensor=rot.SpeedSensor, sensor_name="speed").compile()
    res = cm.simulate(1.0, rtol=1e-10, atol=1e-10, n_out=51)
    assert res.success
    # the same quantity through an alias: equal to rounding whatever the integration error
    # (simulated at rtol = atol = 1e-10 over 1 s; |w| <= 2 rad/s): rtol 0, atol 1e-12
    np.testing.assert_allclose(res["speed.w"], res["j1.w"], rtol=0, atol=1e-12)
    assert np.max(np.abs(res["j1.w"])) > 1.0                 # it did move: phi0 = 1 rad, omega = 2 rad/s


def test_a_pruned_power_sensor_measures_the_kinetic_power():
    J = 2.0
    cm = oscillator(J=J, sensor=rot.PowerSensor).compile()
    res = cm.simulate(1.0, rtol=1e-10, atol=1e-10, n_out=51)
    assert res.success
    # power into j1 = J w a = d/dt (J w^2 / 2), an algebraic identity of the observed values, so it
    # holds to rounding whatever the integration error (rtol = atol = 1e-10, 1 s horizon):
    # rtol 0, atol 1e-12 on a power of scale J * |w| * |a| <= 2 * 2 * 4 = 16 W
    np.testing.assert_allclose(res["sensor.power"], J * res["j1.w"] * res["j1.a"], rtol=0, atol=1e-12)
    assert np.max(np.abs(res["sensor.power"])) > 1.0
