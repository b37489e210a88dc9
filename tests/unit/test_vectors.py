"""mechnet.vectors: force systems against hand computations (Tenenbaum ch. 2).

Hand-worked numbers are exact binary fractions or short decimals, so the
comparisons use rtol 1e-12, atol 1e-12 N or N·m (forces and moments are O(10)).
"""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechnet.core.errors import InputError
from mechnet.vectors import ForceSystem

TOL = dict(rtol=1e-12, atol=1e-12)


def two_forces():
    """F1 = (0, 10, 0) N at A1 = (1, 0, 0) m and F2 = (0, 0, 5) N at A2 = (0, 2, 0) m."""
    return ForceSystem(forces=[([0, 10, 0], [1, 0, 0]), ([0, 0, 5], [0, 2, 0])])


def test_reduction_to_origin_and_to_a_point():
    """By hand:
    R   = (0, 10, 5)
    M_O = A1 × F1 + A2 × F2 = (0, 0, 10) + (10, 0, 0) = (10, 0, 10)
    M_B about B = (1, 1, 1): (A1 − B) × F1 = (0, −1, −1) × (0, 10, 0) = (10, 0, 0)
                             (A2 − B) × F2 = (−1, 1, −1) × (0, 0, 5) = (5, 5, 0)
                             M_B = (15, 5, 0)
    """
    system = two_forces()
    R, M_O = system.reduce_to([0, 0, 0])
    np.testing.assert_allclose(R, [0, 10, 5], **TOL)
    np.testing.assert_allclose(M_O, [10, 0, 10], **TOL)
    np.testing.assert_allclose(system.moment_about([1, 1, 1]), [15, 5, 0], **TOL)


def test_central_axis_by_hand():
    """By hand, from R = (0, 10, 5), M_O = (10, 0, 10), |R|² = 125:
    pitch p = R·M_O / |R|² = 50 / 125 = 0.4 m
    point   = R × M_O / |R|² = (100, 50, −100) / 125 = (0.8, 0.4, −0.8) m   (and point·R = 0)
    direction = (0, 2, 1) / √5;  smallest moment p R = (0, 4, 2) N·m
    and M about the point: M_O − point × R = (10, 0, 10) − (10, −4, 8) = (0, 4, 2), along R.
    """
    system = two_forces()
    axis = system.central_axis()
    assert axis.pitch == pytest.approx(0.4, rel=1e-12)
    np.testing.assert_allclose(axis.point, [0.8, 0.4, -0.8], **TOL)
    np.testing.assert_allclose(axis.direction, np.array([0, 2, 1]) / np.sqrt(5), **TOL)
    np.testing.assert_allclose(axis.moment, [0, 4, 2], **TOL)
    np.testing.assert_allclose(system.moment_about(axis.point), [0, 4, 2], **TOL)
    # every point of the axis sees the same (smallest) moment
    np.testing.assert_allclose(system.moment_about(axis.point + 3.0 * axis.direction), [0, 4, 2], **TOL)


def test_single_force_has_zero_pitch_through_its_point():
    """A lone force (1, 0, 0) N at (0, 2, 0) m: axis along x through (0, 2, 0), pitch 0."""
    axis = ForceSystem(forces=[([1, 0, 0], [0, 2, 0])]).central_axis()
    assert axis.pitch == 0.0
    np.testing.assert_allclose(axis.point, [0, 2, 0], **TOL)


def test_couple_is_equivalent_to_a_pure_torque_and_has_no_axis():
    """±(0, 3, 0) N at (2, 0, 0) m and at the origin: moment (2, 0, 0) × (0, 3, 0) = (0, 0, 6) N·m
    about every point, the same as a free torque (0, 0, 6)."""
    couple = ForceSystem(forces=[([0, 3, 0], [2, 0, 0]), ([0, -3, 0], [0, 0, 0])])
    torque = ForceSystem(torques=[[0, 0, 6]])
    assert couple.equivalent_to(torque)
    np.testing.assert_allclose(couple.moment_about([5, -7, 1]), [0, 0, 6], **TOL)
    assert couple.central_axis() is None
    assert ForceSystem(forces=[([1e-9, 0, 0], [0, 1, 0])]).central_axis(atol=1e-6) is None


def test_moment_transfer_between_points():
    """M_B = M_A + (A − B) × R for arbitrary A, B: rtol 1e-12, atol 1e-10 N·m (moments ~100 N·m)."""
    system = two_forces() + ForceSystem(torques=[[1, -2, 3]])
    A, B = np.array([0.3, -1.2, 2.0]), np.array([-4.0, 0.5, 1.5])
    R = system.resultant
    np.testing.assert_allclose(system.moment_about(B), system.moment_about(A) + np.cross(A - B, R),
                               rtol=1e-12, atol=1e-10)


def test_wrench_and_addition():
    """A cut force (1, 2, 3) N and torque (0, 0, 1) N·m at (1, 0, 0) m reduce, at the origin, to
    R = (1, 2, 3), M_O = (1, 0, 0) × (1, 2, 3) + (0, 0, 1) = (0, −3, 2) + (0, 0, 1) = (0, −3, 3).
    Adding the opposite wrench leaves nothing."""
    cut = ForceSystem.wrench([1, 2, 3], [0, 0, 1], point=[1, 0, 0])
    R, M = cut.reduce_to()
    np.testing.assert_allclose(R, [1, 2, 3], **TOL)
    np.testing.assert_allclose(M, [0, -3, 3], **TOL)
    nothing = cut + ForceSystem.wrench([-1, -2, -3], [0, 0, -1], point=[1, 0, 0])
    assert nothing.equivalent_to(ForceSystem())
    assert len((cut + two_forces()).forces) == 3


def test_not_equivalent_when_moment_differs():
    """Same resultant, shifted line of action: moments differ by 10 N·m, far above atol 1e-12."""
    assert not two_forces().equivalent_to(ForceSystem.wrench([0, 10, 5], [0, 0, 0]))


@pytest.mark.parametrize("build, culprit", [
    (lambda: ForceSystem(forces=[([1, 0], [0, 0, 0])]), "forces[0] force"),
    (lambda: ForceSystem(forces=[([1, 0, 0], [0, float("inf"), 0])]), "forces[0] point"),
    (lambda: ForceSystem(torques=[[0, 0, 1], "x"]), "torques[1]"),
])
def test_bad_vectors_name_the_culprit(build, culprit):
    with pytest.raises(InputError, match=culprit.replace("[", r"\[").replace("]", r"\]")):
        build()


coordinate = st.floats(-100, 100, allow_nan=False)
vector = st.lists(coordinate, min_size=3, max_size=3)


@settings(max_examples=60, deadline=None)
@given(forces=st.lists(st.tuples(vector, vector), max_size=4), torques=st.lists(vector, max_size=2),
       point=vector, probe=vector)
def test_reduction_at_any_point_is_equivalent(forces, torques, point, probe):
    """The wrench (R, M_P) at P acts like the original system about any other point Q.

    Entries ≤ 100 N and m, so moments are ≤ ~1e5 N·m and rounding of the cross products is
    ≲ 1e5 · 1e-16 per term: atol 1e-8 N·m, rtol 1e-9.
    """
    system = ForceSystem(forces, torques)
    R, M = system.reduce_to(point)
    reduced = ForceSystem.wrench(R, M, point)
    assert reduced.equivalent_to(system, rtol=1e-9, atol=1e-8)
    np.testing.assert_allclose(reduced.moment_about(probe), system.moment_about(probe), rtol=1e-9, atol=1e-8)
