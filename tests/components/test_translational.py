"""One closed-form scenario per translational component."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components import translational as tr

TIGHT = dict(rtol=1e-10, atol=1e-10)


def test_mass_under_constant_force_is_a_parabola():
    # s = s0 + v0 t + F t^2 / (2 m); rtol = atol = 1e-10, horizon 2 s, scale 1 m: < 1e-8.
    m = mn.Model("free")
    mass = m.add(tr.Mass(name="mass", m=0.5, s_start=0.1, v_start=-0.3))
    src = m.add(tr.ConstantForce(name="src", f_constant=2.0))
    m.connect(src.flange, mass.flange_a)
    res = m.compile().simulate(2.0, **TIGHT)
    t = res.t
    assert np.max(np.abs(res["mass.s"] - (0.1 - 0.3 * t + 2.0 * t**2 / (2 * 0.5)))) < 1e-8
    # v = v0 + F t / m; rtol = atol = 1e-10, 2 s, scale 8 m/s: < 1e-8
    assert np.max(np.abs(res["mass.v"] - (-0.3 + 4.0 * t))) < 1e-8
    # a = F / m is an observed expression of constants: round-off only (atol 1e-12 at scale 4 m/s^2)
    assert np.max(np.abs(res["mass.a"] - 4.0)) < 1e-12
    # the source drives with +f: the cut force into the source is -f (a folded constant; np.allclose defaults)
    assert np.allclose(res["src.flange.f"], -2.0)


def test_force_input_value_comes_from_simulate():
    # Same parabola with the input set at simulation time; rtol = atol = 1e-10, horizon 1 s, scale 1 m: < 1e-8.
    m = mn.Model("driven")
    mass = m.add(tr.Mass(name="mass", m=2.0, s_start=0.0, v_start=0.0))
    force = m.add(tr.Force(name="force", f=1.0))
    m.connect(force.flange, mass.flange_b)
    cm = m.compile()
    assert cm.input_names == ("force.f",)
    # the input and the flange force are the constant passed in: np.allclose defaults (rtol 1e-5, atol 1e-8)
    for value in (1.0, -3.0):
        res = cm.simulate(1.0, inputs={"force.f": value}, **TIGHT)
        assert np.max(np.abs(res["mass.s"] - value * res.t**2 / 4.0)) < 1e-8
        assert np.allclose(res["force.f"], value)
        assert np.allclose(res["force.flange.f"], -value)
    # default value f=1.0 used when no input is given: s(1) = 1/4 m, same tolerance
    res = cm.simulate(1.0, **TIGHT)
    assert abs(res["mass.s"][-1] - 0.25) < 1e-8


def test_damper_decays_exponentially():
    # v = v0 exp(-d t / m), s = v0 m/d (1 - exp(-d t/m)); rtol = atol = 1e-10, horizon 3 s, scale v0 = 2 m/s: < 1e-8.
    mm, d, v0 = 0.2, 0.3, 2.0
    m = mn.Model("decay")
    fixed = m.add(tr.Fixed(name="fixed"))
    damper = m.add(tr.Damper(name="damper", d=d))
    mass = m.add(tr.Mass(name="mass", m=mm, s_start=0.0, v_start=v0))
    m.connect(fixed.flange, damper.flange_a)
    m.connect(damper.flange_b, mass.flange_a)
    cm = m.compile()
    assert cm.n_states == 2
    res = cm.simulate(3.0, **TIGHT)
    t = res.t
    assert np.max(np.abs(res["mass.v"] - v0 * np.exp(-d * t / mm))) < 1e-8
    assert np.max(np.abs(res["mass.s"] - v0 * mm / d * (1 - np.exp(-d * t / mm)))) < 1e-8
    # damper force = d * v_rel, an observed expression of the same state: round-off (atol 1e-10 at scale 0.6 N)
    assert np.max(np.abs(res["damper.f"] - d * res["mass.v"])) < 1e-10
    # the damper brakes the mass: the force on the mass at flange_b of the damper is -f, so m a = -f;
    # both are observed expressions of the same state: round-off (atol 1e-9 over 3 s at scale 3 m/s^2)
    assert np.max(np.abs(res["mass.a"] + res["damper.f"] / mm)) < 1e-9


def test_fixed_with_offset_and_spring_rest_length():
    # Equilibrium at s0 + s_rel0; oscillation about it: s = s_eq + A cos(w t).
    # rtol = atol = 1e-10, horizon 1 s (3.2 periods), scale 1 m: global error < 1e-7.
    mm, c = 0.1, 40.0
    m = mn.Model("offset")
    fixed = m.add(tr.Fixed(name="fixed", s0=0.3))
    spring = m.add(tr.Spring(name="spring", c=c, s_rel0=0.2))
    mass = m.add(tr.Mass(name="mass", m=mm, s_start=0.9, v_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, mass.flange_a)
    res = m.compile().simulate(1.0, **TIGHT)
    omega = np.sqrt(c / mm)
    assert np.max(np.abs(res["mass.s"] - (0.5 + 0.4 * np.cos(omega * res.t)))) < 1e-7
    assert np.all(res["fixed.flange.s"] == 0.3)
    # spring force c (s_rel - s_rel0) = c (s - 0.5), observed from the state: round-off, atol 1e-9 over 1 s at
    # scale 16 N; its reaction on the housing, fixed.flange.f = f (flange_a.f = -f, and the flows at the
    # connection sum to zero), is an alias: atol 1e-12
    assert np.max(np.abs(res["spring.f"] - c * (res["mass.s"] - 0.5))) < 1e-9
    assert np.max(np.abs(res["fixed.flange.f"] - res["spring.f"])) < 1e-12


def test_mass_spring_damper_underdamped_closed_form():
    # m x'' + d x' + c x = 0 from x0, v0 (zeta = 0.1): x = e^{-zeta wn t}(x0 cos wd t + (v0 + zeta wn x0)/wd sin wd t).
    # Acceptance criterion: rtol = atol = 1e-10, horizon 5 s (about 5 periods), scale x0 = 0.5 m: max error < 1e-7.
    mm, c = 1.0, 39.47841760435743          # wn = 2 pi rad/s
    wn = np.sqrt(c / mm)
    zeta = 0.1
    d = 2 * zeta * wn * mm
    x0, v0 = 0.5, -1.0
    m = mn.Model("msd")
    fixed = m.add(tr.Fixed(name="fixed"))
    sd = m.add(tr.SpringDamper(name="sd", c=c, d=d))
    mass = m.add(tr.Mass(name="mass", m=mm, s_start=x0, v_start=v0))
    m.connect(fixed.flange, sd.flange_a)
    m.connect(sd.flange_b, mass.flange_a)
    cm = m.compile()
    assert cm.n_states == 2
    res = cm.simulate(5.0, rtol=1e-10, atol=1e-10)
    t = res.t
    wd = wn * np.sqrt(1 - zeta**2)
    x = np.exp(-zeta * wn * t) * (x0 * np.cos(wd * t) + (v0 + zeta * wn * x0) / wd * np.sin(wd * t))
    assert np.max(np.abs(res["mass.s"] - x)) < 1e-7


def _sensed_oscillator():
    m = mn.Model("sensed")
    fixed = m.add(tr.Fixed(name="fixed"))
    spring = m.add(tr.Spring(name="spring", c=100.0))
    force = m.add(tr.ForceSensor(name="force"))
    power = m.add(tr.PowerSensor(name="power"))
    mass = m.add(tr.Mass(name="mass", m=0.1, s_start=0.5, v_start=0.0))
    position = m.add(tr.PositionSensor(name="position"))
    speed = m.add(tr.SpeedSensor(name="speed"))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, force.flange_a)
    m.connect(force.flange_b, power.flange_a)
    m.connect(power.flange_b, mass.flange_a)
    m.connect(position.flange, mass.flange_b)
    m.connect(speed.flange, mass.flange_b)
    return m


def test_sensors_measure_without_loading():
    # Sensors add no dynamics: still 2 states, same closed form; sensor outputs equal the quantities they
    # measure to round-off (atol 1e-12 at scale 1) since they are observed expressions of the same states.
    cm = _sensed_oscillator().compile()
    assert cm.n_states == 2
    res = cm.simulate(1.0, **TIGHT)
    omega = np.sqrt(1000.0)
    # rtol = atol = 1e-10, horizon 1 s (5 periods), scale 0.5 m: global error < 1e-7
    assert np.max(np.abs(res["position.s"] - 0.5 * np.cos(omega * res.t))) < 1e-7
    assert np.max(np.abs(res["position.s"] - res["mass.s"])) < 1e-12
    assert np.max(np.abs(res["speed.v"] - res["mass.v"])) < 1e-12
    # force sensor measures the cut force flowing from the spring to the mass: flange_a.f = -spring.f;
    # rtol = atol = 1e-10 over 1 s, scale 50 N: < 1e-9
    assert np.max(np.abs(res["force.f"] + res["spring.f"])) < 1e-9
    # power into the mass through the sensor = d/dt kinetic energy: f_on_mass * v; same tolerance
    assert np.max(np.abs(res["power.power"] - res["force.f"] * res["mass.v"])) < 1e-9


def test_power_sensor_integrates_to_kinetic_energy_change():
    # ∫ P dt over a quarter period = change of kinetic energy (spring energy fully converted).
    # rtol = atol = 1e-10; trapezoid on 20001 points over 0.0497 s: relative error < 1e-6 of c s0^2/2.
    cm = _sensed_oscillator().compile()
    quarter = 0.25 * 2 * np.pi / np.sqrt(1000.0)
    res = cm.simulate(quarter, n_out=20001, **TIGHT)
    work = np.trapezoid(res["power.power"], res.t)
    dKE = 0.5 * 0.1 * res["mass.v"][-1] ** 2
    assert abs(work - dKE) / (0.5 * 100.0 * 0.25) < 1e-6


@pytest.mark.parametrize("make, parameter", [
    (lambda: tr.Mass(name="bad", m=0.0), "m"),
    (lambda: tr.Mass(name="bad", m=-1.0), "m"),
    (lambda: tr.Mass(name="bad", m=float("nan")), "m"),
    (lambda: tr.Spring(name="bad", c=-1.0), "c"),
    (lambda: tr.Spring(name="bad", c=float("nan")), "c"),
    (lambda: tr.Damper(name="bad", d=-0.5), "d"),
    (lambda: tr.Damper(name="bad", d=float("nan")), "d"),
    (lambda: tr.SpringDamper(name="bad", c=-1.0, d=1.0), "c"),
    (lambda: tr.SpringDamper(name="bad", c=1.0, d=-1.0), "d"),
    (lambda: tr.Fixed(name="bad", s0=float("nan")), "s0"),
    (lambda: tr.ConstantForce(name="bad", f_constant=float("nan")), "f_constant"),
])
def test_bad_parameters_raise_parameter_error(make, parameter):
    with pytest.raises(mn.ParameterError) as info:
        make()
    message = str(info.value)
    assert "bad (" in message
    assert f"parameter {parameter} " in message


def test_translational_flange_does_not_connect_to_rotational():
    m = mn.Model("mixed")
    mass = m.add(tr.Mass(name="mass", m=1.0))
    inertia = m.add(rot.Inertia(name="inertia", J=1.0))
    with pytest.raises(mn.ConnectError) as info:
        m.connect(mass.flange_a, inertia.flange_a)
    message = str(info.value)
    assert "mass.flange_a" in message and "inertia.flange_a" in message
    assert "translational.Flange" in message and "rotational.Flange" in message
