"""External inputs: constants, callables and arrays become interpolants; bad ones are named."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.signals import Table


def _driven_inertia(**torque_kw):
    m = mn.Model("driven")
    j = m.add(rot.Inertia(name="j", J=1.0, phi_start=0.0, w_start=0.0))
    tq = m.add(rot.Torque(name="tq", **torque_kw))
    m.connect(tq.flange, j.flange_a)
    return m.compile()


TIGHT = dict(rtol=1e-10, atol=1e-10)


def test_callable_input_is_sampled_not_called_by_the_integrator():
    # tau = 2t on J = 1: w = t², phi = t³/3. The linear interpolant of 2t is exact.
    # rtol = atol = 1e-10, horizon 1 s, scale 1: < 1e-8.
    calls = []

    def tau(t):
        calls.append(t)
        return 2.0 * t

    cm = _driven_inertia()
    res = cm.simulate(1.0, inputs={"tq.tau": tau}, **TIGHT)
    assert np.max(np.abs(res["j.w"] - res.t**2)) < 1e-8
    assert np.max(np.abs(res["j.phi"] - res.t**3 / 3)) < 1e-8
    assert np.max(np.abs(res["tq.tau"] - 2 * res.t)) < 1e-12
    n_calls = len(calls)
    assert n_calls >= 501 and n_calls == len(set(calls))      # sampled once per grid time, then never again


@pytest.mark.parametrize("form", ["pair", "array"])
def test_array_input(form):
    # tau piecewise linear 0 -> 2 over [0, 1]: same closed form as above. rtol = atol = 1e-10, 1 s: < 1e-8.
    times, values = np.array([0.0, 1.0]), np.array([0.0, 2.0])
    given = (times, values) if form == "pair" else np.column_stack([times, values])
    res = _driven_inertia().simulate(1.0, inputs={"tq.tau": given}, **TIGHT)
    assert np.max(np.abs(res["j.w"] - res.t**2)) < 1e-8


def test_signal_driven_torque_has_no_input_left():
    cm = _driven_inertia(tau=Table([0.0, 1.0], [0.0, 2.0]))
    assert cm.input_names == ()
    res = cm.simulate(1.0, **TIGHT)
    assert np.max(np.abs(res["j.w"] - res.t**2)) < 1e-8


def test_callable_returning_the_wrong_shape_is_named():
    cm = _driven_inertia()
    with pytest.raises(mn.InputError, match=r"tq\.tau.*shape \(2,\).*t = 0"):
        cm.simulate(1.0, inputs={"tq.tau": lambda t: [t, t]})


def test_callable_returning_nan_names_input_and_time():
    cm = _driven_inertia()
    with pytest.raises(mn.InputError, match=r"tq\.tau.*nan.*t = 0\.5"):
        cm.simulate(1.0, n_out=11, inputs={"tq.tau": lambda t: float("nan") if t >= 0.5 else 0.0})


def test_array_input_with_non_increasing_times():
    cm = _driven_inertia()
    with pytest.raises(mn.InputError, match=r"tq\.tau.*strictly increasing"):
        cm.simulate(1.0, inputs={"tq.tau": ([0.0, 1.0, 0.5], [0.0, 1.0, 2.0])})


def test_a_name_that_is_not_an_input():
    cm = _driven_inertia()
    with pytest.raises(mn.InputError, match=r"'j\.phi' is a variable of the model, not an input.*tq\.tau"):
        cm.simulate(1.0, inputs={"j.phi": 1.0})
    with pytest.raises(mn.UnknownNameError, match=r"tq\.tauu.*did you mean tq\.tau"):
        cm.simulate(1.0, inputs={"tq.tauu": 1.0})
