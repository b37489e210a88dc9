"""Core II bad input: structurally singular models, non-differentiable inputs, inconsistent constraints."""
from __future__ import annotations

import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.components.signals import Sine, Step, Table
from models import CartesianPendulum


def test_two_prescribed_motions_on_one_mass_fight():
    m = mn.Model("fight")
    a = m.add(tr.Position(name="a", s_ref=Sine(0.1, 1.0)))
    b = m.add(tr.Position(name="b", s_ref=Sine(0.2, 1.0)))
    mass = m.add(tr.Mass(name="mass", m=1.0))
    m.connect(a.flange, mass.flange_a)
    m.connect(b.flange, mass.flange_b)
    with pytest.raises(mn.StructureError, match=r"(?s)structurally singular.*a \(Position\).*b \(Position\)"):
        m.compile()


def test_prescribed_motion_on_a_fixed_flange_names_the_likely_cause():
    m = mn.Model("pinned")
    wall = m.add(tr.Fixed(name="wall"))
    src = m.add(tr.Position(name="src", s_ref=Sine(0.1, 1.0)))
    m.connect(wall.flange, src.flange)
    with pytest.raises(mn.StructureError, match=r"(?s)prescribed motion fighting.*src \(Position\)"):
        m.compile()


@pytest.mark.parametrize("signal, times", [(Step(1.0, start_time=0.5), 1), (Table([0, 1], [0, 1]), 2)])
def test_signal_differentiated_beyond_its_smoothness(signal, times):
    m = mn.Model("rough")
    src = m.add(tr.Position(name="src", s_ref=signal))
    mass = m.add(tr.Mass(name="mass", m=1.0))
    m.connect(src.flange, mass.flange_a)
    with pytest.raises(mn.StructureError, match=rf"src \(Position\).*differentiated {times} time"):
        m.compile()


def test_external_input_that_would_need_differentiating():
    m = mn.Model("driven")
    src = m.add(rot.Position(name="src"))
    j = m.add(rot.Inertia(name="j", J=1.0))
    m.connect(src.flange, j.flange_a)
    with pytest.raises(mn.StructureError, match=r"external input src\.phi_ref"):
        m.compile()


@pytest.mark.parametrize("lib, source, key, value, state, start", [
    (rot, rot.Speed, "w_ref", 2.0, "w", {"src.phi": 0.0}),
    (rot, rot.Position, "phi_ref", 3, "phi", {}),
    (tr, tr.Speed, "v_ref", 0.5, "v", {"src.s": 0.0}),
    (tr, tr.Position, "s_ref", 0.25, "s", {}),
], ids=["rot.Speed", "rot.Position", "tr.Speed", "tr.Position"])
def test_a_number_as_a_motion_reference_is_a_constant(lib, source, key, value, state, start):
    """Issue 32, item 7: `rot.Speed(w_ref=2.0)` rigidly on an inertia failed index reduction (the number
    was an external input's default); it is the constant signal, differentiable, and drives the body."""
    import numpy as np

    rotational = lib is rot
    m = mn.Model("constant_drive")
    src = m.add(source(name="src", **{key: value}))
    driven = m.add(rot.Inertia(name="b", J=1.0) if rotational else tr.Mass(name="b", m=1.0))
    spring = m.add(lib.Spring(name="k", c=1.0))
    free = m.add(rot.Inertia(name="f", J=1.0) if rotational else tr.Mass(name="f", m=1.0))
    m.connect(src.flange, driven.flange_a)
    m.connect(driven.flange_b, spring.flange_a)
    m.connect(spring.flange_b, free.flange_a)
    cm = m.compile()
    assert f"src.{key}" not in cm.input_names
    position = "phi" if rotational else "s"
    res = cm.simulate(1.0, start={**start, f"f.{position}": 0.0, f"f.{'w' if rotational else 'v'}": 0.0})
    assert np.max(np.abs(res[f"b.{state}"] - value)) < 1e-9


def test_a_motion_reference_that_is_not_a_number_is_still_refused():
    with pytest.raises(mn.ParameterError, match=r"src \(Speed\): w_ref.* = '2' is not a number"):
        rot.Speed(name="src", w_ref="2")


def test_inconsistent_fixed_values_name_the_constraint_and_residual():
    # x = 2 is impossible on a rod of length 1: initialisation names the rod equation and its residual
    m = mn.Model("pendulum")
    m.add(CartesianPendulum(name="p", x_start=2.0, vx_start=0.0))
    cm = m.compile()
    with pytest.raises(mn.InitializationError, match=r"(?s)rod length.*residual.*p\.x = 2"):
        cm.simulate(0.1)
