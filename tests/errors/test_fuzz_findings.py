"""Regressions for what the fuzz suite (tests/fuzz, issue 32) found: each input now raises a MechnetError
naming its culprit."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

import mechnet as mn
import mechnet.inertia  # noqa: F401 - mn.inertia
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from models import oscillator


@pytest.mark.parametrize("make", [lambda: rot.Inertia(J=1.0), lambda: mb.Spherical(), lambda: rot.Speed(w_ref=1.0),
                                  lambda: mb.WorldForce(force=[0, 0, 1])])
def test_a_component_without_a_name_says_so(make):
    with pytest.raises(mn.ParameterError, match="name is required"):
        make()


@pytest.mark.parametrize("kwargs, culprit", [
    ({"Q_start": [1, 0, 0, 0], "w_rel_a_start": [1, 2]}, "w_rel_a_start"),
    ({"Q_start": [1, 0, 0, 0], "w_rel_a_start": "abc"}, "w_rel_a_start"),
    ({"Q_start": [1, 0, 0, 0], "w_rel_a_start": [math.nan, 0, 0]}, "w_rel_a_start"),
    ({"Q_start": [1, 0, 0], "w_rel_a_start": [1, 2, 3]}, "Q_start"),
    ({"axis_start": [0, 0, 1], "angle_start": "x"}, "angle_start"),
])
def test_spherical_start_values_of_the_wrong_size_are_named(kwargs, culprit):
    with pytest.raises(mn.ParameterError, match=f"ball \\(Spherical\\): {culprit}"):
        mb.Spherical(name="ball", **kwargs)


def test_w_rel_a_start_is_still_turned_into_frame_b():
    """A half turn about z: frame_a's (1, 2, 3) is frame_b's (-1, -2, 3)."""
    joint = mb.Spherical(name="ball", Q_start=[0, 0, 0, 1], w_rel_a_start=[1, 2, 3])
    start = next(v.start for v in joint.variables() if v.local_name == "w_rel")
    assert start == pytest.approx([-1, -2, 3])


@pytest.mark.parametrize("times, values, culprit", [
    ([0, 1, 2, 3], [[1, 2], [3, 4]], "values"), ([[0, 1], [2, 3]], [0, 1, 2, 3], "times"), ({0: 1}, [1], "times")])
def test_a_table_takes_one_sequence_not_a_matrix(times, values, culprit):
    from mechnet.components.signals import Table
    with pytest.raises(mn.ParameterError, match=f"Table: {culprit}"):
        Table(times, values)


def test_a_table_given_as_columns_is_still_one_sequence():
    from mechnet.components.signals import Table
    assert float(Table([[0.0], [1.0]], [[1.0], [3.0]])(0.5)) == pytest.approx(2.0)


def test_an_empty_model_is_refused_at_compile():
    with pytest.raises(mn.StructureError, match="model 'm' has no components"):
        mn.Model("m").compile()


def test_an_unknown_member_of_a_model_is_named_and_still_an_attribute_error():
    m = mn.Model("m")
    with pytest.raises(mn.UnknownNameError, match="'nothing'"):
        m.nothing
    assert not hasattr(m, "nothing") and getattr(m, "nothing", 1) == 1


def test_a_misspelled_simulate_setting_is_named_with_the_closest_one():
    from models import oscillator
    with pytest.raises(mn.MechnetError, match=r"rtoll \(did you mean rtol\?\)"):
        oscillator().compile().simulate(1.0, rtoll=1e-6)


def test_steady_state_over_fixed_starts_says_where_the_rates_come_from():
    from models import oscillator
    with pytest.raises(mn.InitializationError, match="steady_state=True"):
        oscillator().compile().simulate(1.0, steady_state=True)


def test_kinematics_names_a_list_or_a_non_model():
    from models import oscillator
    m = mn.Model("p")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", phi_start=0.0, w_start=0.0))
    bob = m.add(mb.Body(name="bob", m=1.0, r_cm=[1, 0, 0]))
    m.connect(world.frame_b, rev.frame_a)
    m.connect(rev.frame_b, bob.frame_a)
    cm = m.compile()
    with pytest.raises(mn.InputError, match=r"kinematics\(q=...\) takes a mapping"):
        mn.kinematics(cm, q=[1, 2, 3])
    with pytest.raises(mn.MechnetError, match="takes a compiled model"):
        mn.kinematics(oscillator())


def test_linearize_and_trim_name_their_wrong_settings():
    from models import oscillator
    cm = oscillator().compile()
    with pytest.raises(mn.MechnetError, match="x0"):
        cm.linearize(x0={"j1.phi": 0.0})
    with pytest.raises(mn.InputError, match="max_iter"):
        cm.trim(max_iter=0)
    with pytest.raises(mn.UnknownNameError, match="did you mean ode"):
        cm.functions()["odee"]


@pytest.mark.parametrize("call, culprit", [
    (lambda: mn.inertia.transfer(np.eye(3), 1.0, [1, 0]), "d"),
    (lambda: mn.inertia.principal_axes(np.full((3, 3), math.nan)), "I"),
    (lambda: mn.inertia.composite("ab"), r"parts\[0\]"),
    (lambda: mn.inertia.composite([(1.0, [0, 0], np.eye(3))]), "r_cm"),
])
def test_inertia_helpers_name_the_wrong_array(call, culprit):
    with pytest.raises(mn.ParameterError, match=culprit):
        call()


def test_a_mode_start_outside_its_values_is_refused_naming_it():
    """A friction element's mode is −1, 0 or +1: a start of 7 names the mode and its values (it ran)."""
    from models import stick_slip_block
    cm = stick_slip_block().compile()
    mode = next(n for n in cm.dae.d_names if n.endswith(".mode"))
    with pytest.raises(mn.MechnetError, match=re.escape(f"{mode} = 7 is no mode of it; it takes -1, 0, 1")):
        cm.simulate(0.1, start={mode: 7.0})
    assert cm.simulate(0.1, n_out=3, start={mode: 0.0}).failure is None


def test_settings_by_position_and_per_call_settings_are_named():
    """`simulate(1.0, 1e-6)` and a prepared run called with `inputs=` say what to do, not Python's TypeError."""
    cm = oscillator().compile()
    with pytest.raises(mn.MechnetError, match=r"simulate\(\) takes t_end as its only positional argument; 1e-06"):
        cm.simulate(1.0, 1e-6)
    with pytest.raises(mn.MechnetError, match=r"prepare\(\) takes t_end"):
        cm.prepare(1.0, 1e-6)
    with pytest.raises(mn.MechnetError, match=r"inputs is fixed when it is prepared"):
        cm.prepare(1.0)(inputs={"x": 1.0})


def test_continuing_another_models_result_is_refused_naming_continue_from():
    """A result of a model with the same state names and more variables is another model's."""
    plain = oscillator().compile()
    other = mn.Model("driven")
    fixed = other.add(rot.Fixed(name="fixed"))
    spring = other.add(rot.Spring(name="spring", c=100.0))
    j1 = other.add(rot.Inertia(name="j1", J=0.1, phi_start=0.5, w_start=0.0))
    drive = other.add(rot.Torque(name="drive"))
    other.connect(fixed.flange, spring.flange_a)
    other.connect(spring.flange_b, j1.flange_a)
    other.connect(drive.flange, j1.flange_b)
    res = other.compile().simulate(0.1, n_out=3)
    assert set(plain.state_names) <= set(res.state_names)
    with pytest.raises(mn.MechnetError, match="continue_from holds a result of another model"):
        plain.simulate(0.2, continue_from=res)
