"""Solver failures return the partial result (with an IntegrationError) instead of raising;
solver choices that cannot work raise MechnetError naming the method."""
import math

import casadi as ca
import numpy as np
import pytest

import mechnet as mn


class Blowup(mn.Component):
    """der(x) = x², x(0) = 1: x = 1/(1 − t), which blows up at t = 1."""

    x = mn.State(start=1.0)

    def equations(self):
        return [mn.Eq(mn.der(self.x), self.x ** 2, "finite-time blow-up")]


class Decay(mn.Component):
    x = mn.State(start=1.0)

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.x, "decay")]


class SqrtOfNegative(mn.Component):
    """der(x) = sqrt(x) at x = −1: the right-hand side is NaN at the very first evaluation."""

    x = mn.State(start=-1.0)
    y = mn.State(start=1.0)

    def equations(self):
        return [mn.Eq(mn.der(self.x), ca.sqrt(self.x), "undefined for x < 0"),
                mn.Eq(mn.der(self.y), -self.y, "harmless")]


class Loop(mn.Component):
    """z + z³ = x stays an algebraic loop (not solvable explicitly): the model is a DAE."""

    x = mn.State(start=1.0)
    z = mn.Var()

    def equations(self):
        return [mn.Eq(self.z + self.z ** 3, self.x, "nonlinear loop"),
                mn.Eq(mn.der(self.x), -self.z, "decay")]


def compiled(component):
    m = mn.Model("m")
    m.add(component)
    return m.compile()


@pytest.fixture(scope="module")
def blowup():
    """One failing run shared by the tests below (it takes a good fraction of a second)."""
    cm = compiled(Blowup(name="b", x_start=1.0))
    with pytest.warns(mn.IntegrationWarning) as records:
        res = cm.simulate(2.0)
    return res, records


def test_failure_warns_and_does_not_raise(blowup):
    res, records = blowup
    messages = [str(r.message) for r in records if issubclass(r.category, mn.IntegrationWarning)]
    assert len(messages) == 1
    assert "b.x" in messages[0] and "integration failed" in messages[0]


def test_failure_describes_time_step_and_worst_variable(blowup):
    res, _ = blowup
    assert res.success is False
    err = res.failure
    assert isinstance(err, mn.IntegrationError) and isinstance(err, mn.MechnetError)
    assert 0.9 <= err.t <= 1.0, err.t
    assert err.worst.split()[0] == "b.x", err.worst
    assert math.isfinite(err.step) and 0.0 < err.step < 1e-2
    assert err.solver_message.strip()
    assert err.result is res
    assert f"{err.t:.6g}" in str(err) and "b.x" in str(err)


def test_partial_result_ends_at_the_failure(blowup):
    res, _ = blowup
    assert res.t[-1] == res.failure.t
    assert np.all(np.diff(res.t) > 0)
    assert np.all(np.isfinite(res["b.x"]))
    assert res.final_state["b.x"] == res["b.x"][-1]


def test_partial_result_is_accurate(blowup):
    """x = 1/(1 − t) up to t = 0.8 within 1e-4 relative at the default rtol = 1e-6.

    The relative error of x is amplified like 1/(1 − t), so the bound is not
    taken up to t = 0.9: an uninterrupted CVODES run at rtol = 1e-6 is off by
    1.8e-4 there, but by 8e-5 at t = 0.8. The partial result must be as good
    as a run that did not fail.
    """
    res, _ = blowup
    keep = res.t <= 0.8
    assert keep.sum() > 100
    exact = 1.0 / (1.0 - res.t[keep])
    rel = np.abs(res["b.x"][keep] / exact - 1.0)
    assert rel.max() <= 1e-4, f"max relative error {rel.max():.3g} at t = {res.t[keep][rel.argmax()]:.3g}"


def test_a_start_where_a_derivative_is_nan_is_refused_before_integrating():
    """The integrator would fail at its first step and return one row holding der(b.x) = NaN (issue 31):
    the start is refused instead, naming the derivative and the states it was evaluated at."""
    cm = compiled(SqrtOfNegative(name="b", x_start=-1.0, y_start=1.0))
    with pytest.raises(mn.InitializationError, match=r"der\(b\.x\) = nan at the start, from b\.x = -1, b\.y = 1"):
        cm.simulate(1.0)


def test_no_failure_means_no_failure_object():
    cm = compiled(Decay(name="d", x_start=1.0))
    res = cm.simulate(1.0, n_out=11)
    assert res.success is True and res.failure is None
    assert res["d.x"][-1] == pytest.approx(math.exp(-1.0), rel=1e-5)


# ---- choosing a solver ------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["rk4", "IDAS", "cvodes", ""])
def test_unknown_method(method):
    cm = compiled(Decay(name="d"))
    with pytest.raises(mn.MechnetError, match=rf"unknown method '{method}'.*idas.*cvodes-bdf.*cvodes-adams"):
        cm.simulate(1.0, method=method)


@pytest.fixture(scope="module")
def dae():
    cm = compiled(Loop(name="l", x_start=1.0))     # a declared start only seeds Newton: x_start fixes x
    assert not cm.dae.is_ode and cm.algebraic_names == ("l.z",)
    return cm


@pytest.mark.parametrize("method", ["cvodes-adams", "cvodes-bdf"])
def test_ode_method_on_a_dae(dae, method):
    with pytest.raises(mn.MechnetError, match=rf"'{method}'.*explicit ODE.*l\.z.*'idas'"):
        dae.simulate(1.0, method=method)


def test_idas_handles_the_same_dae(dae):
    """Guard for the test above: the model itself is fine. The algebraic equation
    z + z³ = x holds along the solution to the integrator's tolerance (rtol = 1e-6)."""
    res = dae.simulate(1.0, method="idas", n_out=11)
    assert res.success
    np.testing.assert_allclose(res["l.z"] + res["l.z"] ** 3, res["l.x"], rtol=0, atol=1e-6)
    assert np.all(np.diff(res["l.x"]) < 0), "x decays while z > 0"
