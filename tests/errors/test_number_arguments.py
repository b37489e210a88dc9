"""One rule for numbers (`declarations.not_a_number`): text, truth values and complex numbers are refused
wherever a number is expected, with a ParameterError/MechnetError naming the argument — float() would
have taken '2.5' and True (issue 16: J='2.5' and J=True were accepted, Torque(tau='3.0') refused)."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from models import oscillator


@pytest.mark.parametrize("bad", ["2.5", True, np.bool_(True), 1 + 0j])
def test_a_scalar_parameter_must_be_a_number(bad):
    with pytest.raises(mn.ParameterError, match=r"j1 .*J = .* is not a number"):
        rot.Inertia(name="j1", J=bad)


@pytest.mark.parametrize("bad", ["1", False])
def test_a_particle_mass_must_be_a_number(bad):
    with pytest.raises(mn.ParameterError, match=r"bob .*m = .* is not a number"):
        mb.Particle(name="bob", m=bad)


@pytest.mark.parametrize("bad", ["123", (True, 0.0, 0.0), ["1", 0, 0]])
def test_a_vector_parameter_must_hold_numbers(bad):
    with pytest.raises(mn.ParameterError, match=r"load"):
        mb.WorldForce(name="load", force=bad)


@pytest.mark.parametrize("bad", ["50", True])
def test_a_tunable_parameter_given_per_run_must_be_a_number(bad):
    cm = oscillator(c=mn.tunable(100.0)).compile()
    with pytest.raises(mn.ParameterError, match=r"spring\.c.*is not a number"):
        cm.simulate(1.0, params={"spring.c": bad})


@pytest.mark.parametrize("kwargs, name", [(dict(t_end=True), "t_end"), (dict(t_end=1.0, rtol=True), "rtol"),
                                          (dict(t_end=1.0, start={"j1.phi": True}), r"j1\.phi")])
def test_simulate_numbers_must_be_numbers(kwargs, name):
    with pytest.raises(mn.MechnetError, match=name):
        oscillator().compile().simulate(**kwargs)


def test_a_real_number_still_passes():
    # the same arguments as numbers: the oscillator's closed form phi = 0.5 cos(sqrt(c/J) t)
    # (rtol 1e-8, 1 s, amplitude 0.5: within 1e-6)
    j1 = rot.Inertia(name="j1", J=np.float64(0.1), phi_start=0.5, w_start=0)
    assert j1 is not None
    res = oscillator().compile().simulate(1.0, rtol=1e-8, atol=1e-10)
    assert abs(res["j1.phi"][-1] - 0.5 * np.cos(np.sqrt(1000.0))) < 1e-6
