"""Regressions for what the fuzz suite (tests/fuzz, issue 32) found: each input now raises a MechnetError
naming its culprit."""
from __future__ import annotations

import math

import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot


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
