"""One closed-form scenario per rotational component."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot

TIGHT = dict(rtol=1e-10, atol=1e-10)


def test_inertia_under_constant_torque_is_a_parabola():
    # phi = phi0 + w0 t + tau t^2 / (2 J); rtol = atol = 1e-10, horizon 2 s, scale 1 rad: < 1e-8.
    m = mn.Model("free")
    j = m.add(rot.Inertia(name="j", J=0.5, phi_start=0.1, w_start=-0.3))
    src = m.add(rot.ConstantTorque(name="src", tau_constant=2.0))
    m.connect(src.flange, j.flange_a)
    res = m.compile().simulate(2.0, **TIGHT)
    t = res.t
    assert np.max(np.abs(res["j.phi"] - (0.1 - 0.3 * t + 2.0 * t**2 / (2 * 0.5)))) < 1e-8
    assert np.max(np.abs(res["j.a"] - 4.0)) < 1e-12
    # the source drives with +tau: the cut torque into the source is -tau
    assert np.allclose(res["src.flange.tau"], -2.0)


def test_torque_input_value_comes_from_simulate():
    # Same parabola with the input set at simulation time; rtol = atol = 1e-10, 1 s, scale 1 rad: < 1e-8.
    m = mn.Model("driven")
    j = m.add(rot.Inertia(name="j", J=2.0, phi_start=0.0, w_start=0.0))
    tq = m.add(rot.Torque(name="tq", tau=1.0))
    m.connect(tq.flange, j.flange_b)
    cm = m.compile()
    assert cm.input_names == ("tq.tau",)
    for value in (1.0, -3.0):
        res = cm.simulate(1.0, inputs={"tq.tau": value}, **TIGHT)
        assert np.max(np.abs(res["j.phi"] - value * res.t**2 / 4.0)) < 1e-8
        assert np.allclose(res["tq.tau"], value)
    # default value used when no input is given
    res = cm.simulate(1.0, **TIGHT)
    assert abs(res["j.phi"][-1] - 0.25) < 1e-8


def test_damper_decays_exponentially():
    # w = w0 exp(-d t / J), phi = w0 J/d (1 - exp(-d t/J)); rtol = atol = 1e-10, 3 s, scale w0 = 2: < 1e-8.
    J, d, w0 = 0.2, 0.3, 2.0
    m = mn.Model("decay")
    fixed = m.add(rot.Fixed(name="fixed"))
    damper = m.add(rot.Damper(name="damper", d=d))
    j = m.add(rot.Inertia(name="j", J=J, phi_start=0.0, w_start=w0))
    m.connect(fixed.flange, damper.flange_a)
    m.connect(damper.flange_b, j.flange_a)
    res = m.compile().simulate(3.0, **TIGHT)
    t = res.t
    assert np.max(np.abs(res["j.w"] - w0 * np.exp(-d * t / J))) < 1e-8
    assert np.max(np.abs(res["j.phi"] - w0 * J / d * (1 - np.exp(-d * t / J)))) < 1e-8
    assert np.max(np.abs(res["damper.tau"] - d * res["j.w"])) < 1e-10


def test_fixed_with_offset_and_spring_rest_angle():
    # Equilibrium at phi0 + phi_rel0; oscillation about it: phi = phi_eq + A cos(w t).
    # rtol = atol = 1e-10, horizon 1 s (3.2 periods), scale 1 rad: global error < 1e-7.
    J, c = 0.1, 40.0
    m = mn.Model("offset")
    fixed = m.add(rot.Fixed(name="fixed", phi0=0.3))
    spring = m.add(rot.Spring(name="spring", c=c, phi_rel0=0.2))
    j = m.add(rot.Inertia(name="j", J=J, phi_start=0.9, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    res = m.compile().simulate(1.0, **TIGHT)
    omega = np.sqrt(c / J)
    assert np.max(np.abs(res["j.phi"] - (0.5 + 0.4 * np.cos(omega * res.t)))) < 1e-7
    assert np.all(res["fixed.flange.phi"] == 0.3)


def _sensed_oscillator():
    m = mn.Model("sensed")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=100.0))
    torque = m.add(rot.TorqueSensor(name="torque"))
    power = m.add(rot.PowerSensor(name="power"))
    j = m.add(rot.Inertia(name="j", J=0.1, phi_start=0.5, w_start=0.0))
    angle = m.add(rot.AngleSensor(name="angle"))
    speed = m.add(rot.SpeedSensor(name="speed"))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, torque.flange_a)
    m.connect(torque.flange_b, power.flange_a)
    m.connect(power.flange_b, j.flange_a)
    m.connect(angle.flange, j.flange_b)
    m.connect(speed.flange, j.flange_b)
    return m


def test_sensors_measure_without_loading():
    # Sensors add no dynamics: still 2 states, same closed form; sensor outputs equal the quantities they
    # measure to round-off (atol 1e-12 at scale 1) since they are observed expressions of the same states.
    cm = _sensed_oscillator().compile()
    assert cm.n_states == 2
    res = cm.simulate(1.0, **TIGHT)
    omega = np.sqrt(1000.0)
    # rtol = atol = 1e-10, horizon 1 s (5 periods), scale 0.5 rad: global error < 1e-7
    assert np.max(np.abs(res["angle.phi"] - 0.5 * np.cos(omega * res.t))) < 1e-7
    assert np.max(np.abs(res["angle.phi"] - res["j.phi"])) < 1e-12
    assert np.max(np.abs(res["speed.w"] - res["j.w"])) < 1e-12
    # torque sensor measures the cut torque flowing from the spring to the inertia: flange_a.tau = -spring.tau
    assert np.max(np.abs(res["torque.tau"] + res["spring.tau"])) < 1e-9
    # power into the inertia through the sensor = d/dt kinetic energy: tau_on_inertia * w
    assert np.max(np.abs(res["power.power"] - res["torque.tau"] * res["j.w"])) < 1e-9


def test_power_sensor_integrates_to_kinetic_energy_change():
    # ∫ P dt over a quarter period = change of kinetic energy (spring energy fully converted).
    # rtol = atol = 1e-10; trapezoid on 20001 points over 0.0497 s: relative error < 1e-6 of c phi0^2/2.
    cm = _sensed_oscillator().compile()
    quarter = 0.25 * 2 * np.pi / np.sqrt(1000.0)
    res = cm.simulate(quarter, n_out=20001, **TIGHT)
    # power = flange_a.tau * w: the power flowing through the sensor from flange_a into what hangs on flange_b
    work = np.trapezoid(res["power.power"], res.t)
    dKE = 0.5 * 0.1 * res["j.w"][-1] ** 2
    assert abs(work - dKE) / (0.5 * 100.0 * 0.25) < 1e-6


def test_tunable_parameter_is_kept_symbolic_and_can_be_changed():
    # A tunable spring constant: compile once, run with two values; each against phi0 cos(sqrt(c/J) t).
    # rtol = atol = 1e-10, horizon 1 s (up to 5 periods), scale 0.5 rad: global error < 1e-7.
    m = mn.Model("tuned")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=mn.tunable(100.0)))
    j = m.add(rot.Inertia(name="j", J=0.1, phi_start=0.5, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    cm = m.compile()
    assert cm.parameter_names == ("spring.c",)
    for c in (100.0, 25.0):
        res = cm.simulate(1.0, params={"spring.c": c}, **TIGHT)
        assert np.max(np.abs(res["j.phi"] - 0.5 * np.cos(np.sqrt(c / 0.1) * res.t))) < 1e-7
        assert np.allclose(res["spring.c"], c)


@pytest.mark.parametrize("folded", [True, False])
def test_zero_parameters_fold_away(folded):
    # A damper with d = 0 folds to nothing in the ODE when not tunable: fewer instructions than tunable d.
    m = mn.Model("fold")
    fixed = m.add(rot.Fixed(name="fixed"))
    sd = m.add(rot.SpringDamper(name="sd", c=10.0, d=0.0 if folded else mn.tunable(0.0)))
    j = m.add(rot.Inertia(name="j", J=1.0, phi_start=1.0))
    m.connect(fixed.flange, sd.flange_a)
    m.connect(sd.flange_b, j.flange_a)
    cm = m.compile()
    n = cm.dae.ode.n_instructions()
    assert ("sd.d" in cm.parameter_names) is (not folded)
    if folded:
        assert n <= 8, cm.summary()
