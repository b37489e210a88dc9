"""Rigid couplings and prescribed motion: IdealGear and the Position/Speed/Accelerate sources.

Each scenario has a closed form. The rigid ones need index reduction: the
gear's angle relation and a prescribed position or speed attached to an
inertia or mass are constraints among states, and the signal behind the
source is differentiated through `time`.
"""
from __future__ import annotations

import re

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.components.signals import Constant, Sine, Table

TIGHT = dict(rtol=1e-10, atol=1e-10)


# ---- IdealGear ------------------------------------------------------------------------------------

J1, J2, RATIO, TAU = 0.2, 0.5, 3.0, 1.5


def _geared_pair():
    # torque tau on J1 at flange_a; J2 behind the gear at flange_b: phi_a = ratio·phi_b
    m = mn.Model("gear")
    tq = m.add(rot.ConstantTorque(name="tq", tau_constant=TAU))
    j1 = m.add(rot.Inertia(name="j1", J=J1, phi_start=0.1, w_start=-0.4))
    gear = m.add(rot.IdealGear(name="gear", ratio=RATIO))
    j2 = m.add(rot.Inertia(name="j2", J=J2))
    m.connect(tq.flange, j1.flange_a)
    m.connect(j1.flange_b, gear.flange_a)
    m.connect(gear.flange_b, j2.flange_a)
    return m.compile()


def test_ideal_gear_reflects_inertia_by_ratio_squared():
    # phi_a'' = tau / (J1 + J2/ratio^2): the reflected inertia of a lossless gear.
    cm = _geared_pair()
    # one rotational degree of freedom: angle and speed of one side, the other side dependent
    assert cm.n_states == 2
    assert "gear (IdealGear), equation 1" in cm.stages["index"].summary()
    res = cm.simulate(2.0, **TIGHT)
    assert res.success
    a = TAU / (J1 + J2 / RATIO**2)
    # j1.a is solved from the linear acceleration system (constants only): the closed form to
    # 1e-9 relative (rtol 1e-9, atol 0; any horizon, scale a = 5.87 rad/s^2); observed round-off ~1e-15.
    assert np.max(np.abs(res["j1.a"] - a)) <= 1e-9 * abs(a)
    # phi_a = ratio·phi_b is kept exactly (the dependent angle is solved from the original
    # constraint, no drift): atol 1e-9 over 2 s at scale |phi_a| <= 11 rad (relative 1e-10).
    assert np.max(np.abs(res["j1.phi"] - RATIO * res["j2.phi"])) < 1e-9
    # speeds likewise (observed, round-off: atol 1e-9 at scale 11 rad/s)
    assert np.max(np.abs(res["j1.w"] - RATIO * res["j2.w"])) < 1e-9
    # torque balance of the gear: 0 = ratio·flange_a.tau + flange_b.tau (observed linear
    # combination of constants: atol 1e-12 at scale tau = 1.5 N·m)
    assert np.max(np.abs(RATIO * res["gear.flange_a.tau"] + res["gear.flange_b.tau"])) < 1e-12


def test_ideal_gear_parabola_accuracy():
    # phi_a = phi0 + w0 t + a t^2/2 with a = tau / (J1 + J2/ratio^2); rtol = atol = 1e-10,
    # horizon 2 s, scale 11 rad: < 1e-8 (the same bound test_rotational holds a single inertia to).
    res = _geared_pair().simulate(2.0, **TIGHT)
    t = res.t
    a = TAU / (J1 + J2 / RATIO**2)
    assert np.max(np.abs(res["j1.phi"] - (0.1 - 0.4 * t + a * t**2 / 2))) < 1e-8


@pytest.mark.parametrize("ratio", [0.0, float("inf"), float("nan")])
def test_ideal_gear_ratio_must_be_nonzero_and_finite(ratio):
    with pytest.raises(mn.ParameterError, match=r"gear \(IdealGear\).*ratio"):
        rot.IdealGear(name="gear", ratio=ratio)


# ---- Position ------------------------------------------------------------------------------------

def _position_on_mass_with_spring(A, f, mass_m, c, **mass_kw):
    # source -- mass -- spring -- fixed (at s = 0)
    m = mn.Model("shaker")
    src = m.add(tr.Position(name="src", s_ref=Sine(A, f)))
    mass = m.add(tr.Mass(name="mass", m=mass_m, **mass_kw))
    spring = m.add(tr.Spring(name="spring", c=c))
    fixed = m.add(tr.Fixed(name="fixed"))
    m.connect(src.flange, mass.flange_a)
    m.connect(mass.flange_b, spring.flange_a)
    m.connect(spring.flange_b, fixed.flange)
    return m


def test_rigid_position_source_reaction_force():
    A, f, mass_m, c = 0.3, 1.5, 2.0, 40.0
    cm = _position_on_mass_with_spring(A, f, mass_m, c).compile()
    summary = cm.stages["index"].summary()
    # the source equation (s_ref driven by the Sine) is differentiated twice: velocity and acceleration
    assert re.search(r"differentiated src \(Position\), equation \d+ — s_ref driven by Sine\(.*\) ×2", summary)
    # the prescribed position leaves no degree of freedom
    assert cm.n_states == 0
    res = cm.simulate(2.0, **TIGHT)
    assert res.success
    t = res.t
    w = 2 * np.pi * f
    s_ref = A * np.sin(w * t)
    s_dd = -A * w**2 * np.sin(w * t)
    # The mass follows s_ref: algebraic, no integration error (atol 1e-12 at scale A = 0.3 m).
    assert np.max(np.abs(res["mass.s"] - s_ref)) < 1e-12
    # Newton on the mass: m·s'' = flange_a.f + flange_b.f with flange_b.f = -c·(s - 0) from the
    # spring and flange_a.f = -src.flange.f at the connection. src.flange.f is the cut force into
    # the source, so src.flange.f = -(m·s_ref'' + c·s_ref): the source pushes the mass with +(...).
    expected = -(mass_m * s_dd + c * s_ref)
    amplitude = mass_m * A * w**2 + c * A        # 65.3 N
    # closed form to 1e-8 relative to the amplitude (rtol 1e-8, atol 0); every value is an
    # observed expression of time, so horizon (2 s) and integrator tolerance play no part.
    assert np.max(np.abs(res["src.flange.f"] - expected)) <= 1e-8 * amplitude


def test_rigid_position_source_start_values_must_agree():
    # Initialisation: the prescribed position fixes the mass's position and velocity at t = 0
    # (s_ref(0) = 0, s_ref'(0) = 2·pi·f·A). Consistent fixed start values are accepted ...
    A, f = 0.3, 1.5
    v0 = 2 * np.pi * f * A
    res = _position_on_mass_with_spring(A, f, 2.0, 40.0, s_start=0.0, v_start=v0).compile().simulate(0.5, **TIGHT)
    assert res.success
    # start values enforced by the prescribed motion: atol 1e-12 at scales 0.3 m and 2.8 m/s
    assert abs(res["mass.s"][0]) < 1e-12 and abs(res["mass.v"][0] - v0) < 1e-12
    # ... a conflicting one is refused by name
    cm = _position_on_mass_with_spring(A, f, 2.0, 40.0, s_start=0.1).compile()
    with pytest.raises(mn.InitializationError, match=r"mass\.s"):
        cm.simulate(0.5, **TIGHT)


def test_table_signal_cannot_drive_a_rigid_position_source():
    # A Table is piecewise linear: its first derivative exists (piecewise), its second does not,
    # but a rigidly attached mass needs the position differentiated twice.
    m = mn.Model("table")
    src = m.add(tr.Position(name="src", s_ref=Table([0.0, 1.0, 2.0], [0.0, 0.5, 0.2])))
    mass = m.add(tr.Mass(name="mass", m=1.0))
    m.connect(src.flange, mass.flange_a)
    with pytest.raises(mn.StructureError, match=r"src \(Position\).*Table.*2 time\(s\)"):
        m.compile()


def test_external_input_cannot_drive_a_rigid_position_source():
    # An external input has no known derivative, so the constraint cannot be differentiated.
    m = mn.Model("external")
    src = m.add(rot.Position(name="src"))
    j = m.add(rot.Inertia(name="j", J=1.0))
    m.connect(src.flange, j.flange_a)
    with pytest.raises(mn.StructureError, match=r"external input src\.phi_ref"):
        m.compile()


def test_position_through_a_spring_needs_no_index_reduction():
    # Through a compliant element the prescribed angle is an ordinary equation: a Table serves.
    m = mn.Model("soft")
    src = m.add(rot.Position(name="src", phi_ref=Table([0.0, 1.0], [0.0, 1.0])))
    spring = m.add(rot.Spring(name="spring", c=10.0))
    j = m.add(rot.Inertia(name="j", J=1.0, phi_start=0.0, w_start=0.0))
    m.connect(src.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    cm = m.compile()
    assert cm.n_states == 2
    assert "nothing differentiated" in cm.stages["index"].summary()
    res = cm.simulate(1.0, t_out=np.linspace(0.0, 1.0, 11), **TIGHT)
    # the source angle is the table value: observed, exact up to round-off (atol 1e-12, scale 1 rad)
    assert np.max(np.abs(res["src.flange.phi"] - res.t)) < 1e-12


# ---- Speed ---------------------------------------------------------------------------------------

def test_rigid_speed_source_torque():
    # w_ref = w0 + W sin(2 pi f t) drives an inertia rigidly, with a damper to ground:
    # the source delivers J·w_ref' + d·w_ref.
    W, w0, f, J, d = 2.0, 0.5, 0.8, 0.3, 0.7
    m = mn.Model("spin")
    src = m.add(rot.Speed(name="src", w_ref=Sine(W, f, offset=w0), phi_start=0.2))
    j = m.add(rot.Inertia(name="j", J=J))
    damper = m.add(rot.Damper(name="damper", d=d))
    fixed = m.add(rot.Fixed(name="fixed"))
    m.connect(src.flange, j.flange_a)
    m.connect(j.flange_b, damper.flange_a)
    m.connect(damper.flange_b, fixed.flange)
    cm = m.compile()
    assert "src (Speed)" in cm.stages["index"].summary()
    assert cm.state_names == ("j.phi",)         # the angle is free, the speed prescribed
    res = cm.simulate(3.0, **TIGHT)
    assert res.success
    t = res.t
    om = 2 * np.pi * f
    w_ref = w0 + W * np.sin(om * t)
    w_ref_dot = W * om * np.cos(om * t)
    # speed is prescribed: observed expression of time, round-off only (atol 1e-12, scale 2.5 rad/s)
    assert np.max(np.abs(res["j.w"] - w_ref)) < 1e-12
    # torque delivered = -(cut torque into the source); closed form to 1e-8 relative to its
    # amplitude J·W·om + d·(W + w0) = 4.77 N·m (rtol 1e-8, atol 0; observed, horizon 3 s irrelevant)
    amplitude = J * W * om + d * (W + w0)
    assert np.max(np.abs(-res["src.flange.tau"] - (J * w_ref_dot + d * w_ref))) <= 1e-8 * amplitude
    # the angle integrates w_ref from phi_start = 0.2: rtol = atol = 1e-10, horizon 3 s,
    # scale 6 rad: < 1e-7 (observed 1.6e-8)
    phi = 0.2 + w0 * t + W / om * (1 - np.cos(om * t))
    assert np.max(np.abs(res["j.phi"] - phi)) < 1e-7


def test_rigid_translational_speed_source_with_table():
    # A Table is differentiable once, which is all a rigid Speed source needs: m·v_ref' per segment.
    mass_m = 3.0
    m = mn.Model("conveyor")
    src = m.add(tr.Speed(name="src", v_ref=Table([0.0, 1.0, 2.0], [0.0, 2.0, 1.0]), s_start=0.5))
    mass = m.add(tr.Mass(name="mass", m=mass_m))
    m.connect(src.flange, mass.flange_a)
    cm = m.compile()
    assert "src (Speed)" in cm.stages["index"].summary()
    res = cm.simulate(2.5, t_out=np.linspace(0.0, 2.5, 11), **TIGHT)
    assert res.success
    # the table knots (time events) join the output grid; v_ref' is defined only between them
    t = res.t
    between = np.min(np.abs(t[:, None] - np.array([0.0, 1.0, 2.0])[None, :]), axis=1) > 1e-9
    assert between.sum() == 8
    slope = np.where(t < 1.0, 2.0, np.where(t < 2.0, -1.0, 0.0))
    # the force the source exerts is -src.flange.f = m·v_ref' (constants per segment: atol 1e-12 at 6 N)
    assert np.max(np.abs(-res["src.flange.f"] - mass_m * slope)[between]) < 1e-12
    # velocity prescribed (observed, round-off: atol 1e-12 at 2 m/s); position integrates the table
    # from s_start = 0.5: rtol = atol = 1e-10, horizon 2.5 s, scale 3.5 m: < 1e-8
    v = np.where(t < 1.0, 2.0 * t, np.where(t < 2.0, 2.0 - (t - 1.0), 1.0))
    assert np.max(np.abs(res["mass.v"] - v)) < 1e-12
    s = np.where(t < 1.0, 0.5 + t**2,
                 np.where(t < 2.0, 1.5 + 2.0 * (t - 1) - 0.5 * (t - 1) ** 2, 3.0 + (t - 2.0)))
    assert np.max(np.abs(res["mass.s"] - s)) < 1e-8


# ---- Accelerate ----------------------------------------------------------------------------------

def test_accelerate_with_constant_acceleration_is_a_parabola():
    # phi = phi0 + w0 t + a t^2 / 2
    phi0, w0, a = 0.2, -0.4, 1.7
    m = mn.Model("accelerate")
    acc = m.add(rot.Accelerate(name="acc", a_ref=Constant(a), phi_start=phi0, w_start=w0))
    cm = m.compile()
    assert cm.state_names == ("acc.phi", "acc.w")
    # rtol = atol = 1e-12 (at 1e-10 BDF leaves 3.5e-10 here), horizon 2 s, scale 3 rad: < 1e-9
    res = cm.simulate(2.0, rtol=1e-12, atol=1e-12)
    assert res.success
    t = res.t
    assert np.max(np.abs(res["acc.phi"] - (phi0 + w0 * t + a * t**2 / 2))) < 1e-9
    assert np.max(np.abs(res["acc.w"] - (w0 + a * t))) < 1e-9


@pytest.mark.parametrize("domain", ["rotational", "translational"])
def test_accelerate_drives_a_rigid_inertia_with_an_external_input(domain):
    # a_ref is never differentiated, so an external input serves; the source delivers J·a (m·a).
    x0, v0, a, inertia = 0.2, -0.4, 1.7, 0.5
    m = mn.Model("accelerate")
    if domain == "rotational":
        acc = m.add(rot.Accelerate(name="acc", a_ref=0.0, phi_start=x0, w_start=v0))
        body = m.add(rot.Inertia(name="body", J=inertia))
        pos, cut, inp = "body.phi", "acc.flange.tau", "acc.a_ref"
    else:
        acc = m.add(tr.Accelerate(name="acc", a_ref=0.0, s_start=x0, v_start=v0))
        body = m.add(tr.Mass(name="body", m=inertia))
        pos, cut, inp = "body.s", "acc.flange.f", "acc.a_ref"
    m.connect(acc.flange, body.flange_a)
    cm = m.compile()
    assert cm.n_states == 2
    assert cm.input_names == (inp,)
    res = cm.simulate(2.0, inputs={inp: a}, rtol=1e-12, atol=1e-12)
    assert res.success
    t = res.t
    # rtol = atol = 1e-12, horizon 2 s, scale 3 (rad or m): < 1e-9
    assert np.max(np.abs(res[pos] - (x0 + v0 * t + a * t**2 / 2))) < 1e-9
    # cut effort into the source = -J·a (observed product of constants: atol 1e-12 at scale 0.85)
    assert np.max(np.abs(res[cut] + inertia * a)) < 1e-12


def test_rigid_speed_source_force_at_start_is_the_right_hand_limit():
    # The run starts at the first knot: the force the source exerts is m·(right-hand slope) = 3·2 = 6 N.
    m = mn.Model("conveyor")
    src = m.add(tr.Speed(name="src", v_ref=Table([0.0, 1.0, 2.0], [0.0, 2.0, 1.0]), s_start=0.5))
    mass = m.add(tr.Mass(name="mass", m=3.0))
    m.connect(src.flange, mass.flange_a)
    res = m.compile().simulate(0.5, **TIGHT)
    # an observed product of constants: atol 1e-12 at scale 6 N
    assert abs(-res["src.flange.f"][0] - 6.0) < 1e-12
