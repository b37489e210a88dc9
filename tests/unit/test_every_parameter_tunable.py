"""`mn.every_parameter_tunable()`: every scalar parameter of the components built inside stays a symbol.

Scene: `models.oscillator` with a damper (inertia J on a spring-damper c, d to a fixed housing). At the
default values the result must equal the folded model's (1e-12 at rtol 1e-10, atol 1e-12: the same
arithmetic, in another order at most); a new stiffness changes the undamped period to 2 pi sqrt(J / c).
"""
import threading

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from models import oscillator

SCALARS = {"fixed.phi0", "j1.J", "spring.c", "spring.d", "spring.phi_rel0"}


def test_every_scalar_parameter_becomes_tunable_and_the_result_is_unchanged():
    folded = oscillator(d=0.3).compile()
    with mn.every_parameter_tunable():
        model = oscillator(d=0.3)
    cm = model.compile()
    assert set(cm.dae.p_names) == SCALARS
    assert folded.dae.p_names == ()
    kw = dict(rtol=1e-10, atol=1e-12, n_out=21)
    a, b = folded.simulate(2.0, **kw), cm.simulate(2.0, **kw)
    for name in ("j1.phi", "j1.w", "spring.tau"):
        np.testing.assert_allclose(b[name], a[name], rtol=1e-12, atol=1e-12)


def test_a_changed_stiffness_changes_the_period():
    J = 0.1
    with mn.every_parameter_tunable():
        model = oscillator(J=J, phi0=0.5, w0=0.0)
    cm = model.compile()
    for c in (100.0, 400.0):
        period = 2 * np.pi * np.sqrt(J / c)
        res = cm.simulate(period, params={"spring.c": c}, rtol=1e-10, atol=1e-12, n_out=5)
        np.testing.assert_allclose(res["j1.phi"], 0.5 * np.cos(2 * np.pi * res.t / period), atol=1e-8)


def test_vector_parameters_stay_folded_and_the_setting_ends_with_the_block():
    from mechnet.components import multibody as mb

    with mn.every_parameter_tunable():
        body = mb.Body(name="body", m=2.0, r_cm=[0.1, 0.0, 0.0])
    assert set(body.tunable) == {"m"}            # r_cm (a vector) and I (a matrix) stay numbers
    assert rot.Spring(name="s", c=10.0).tunable == {}


def test_another_thread_does_not_see_the_setting():
    seen = {}

    def build():
        seen["tunable"] = dict(rot.Spring(name="s", c=10.0).tunable)
    with mn.every_parameter_tunable():
        worker = threading.Thread(target=build)
        worker.start()
        worker.join()
        assert set(rot.Spring(name="s", c=10.0).tunable) == {"c", "phi_rel0"}
    assert seen["tunable"] == {}


def test_an_explicit_tunable_keeps_its_value():
    with mn.every_parameter_tunable():
        spring = rot.Spring(name="s", c=mn.tunable(7.0))
    assert spring.tunable["c"][1] == pytest.approx(7.0)
