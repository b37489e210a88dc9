"""Start values that cannot all hold: InitializationError naming the start values involved."""
import re

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot


@pytest.fixture(scope="module")
def cm():
    """f (housing) -- s (spring c = 10) -- j1 (J = 1, phi_start = 0.5)."""
    m = mn.Model("osc")
    j = m.add(rot.Inertia(name="j1", J=1.0, phi_start=0.5, w_start=0.0))
    s = m.add(rot.Spring(name="s", c=10.0))
    f = m.add(rot.Fixed(name="f"))
    m.connect(f.flange, s.flange_a)
    m.connect(s.flange_b, j.flange_a)
    return m.compile()


@pytest.mark.parametrize("alias", ["j1.flange_a.phi", "j1.flange_b.phi", "s.flange_b.phi"])
def test_aliases_of_one_state_with_different_start_values(cm, alias):
    """phi_start = 0.5 on j1 and 0.7 on a flange rigidly attached to it."""
    with pytest.raises(mn.InitializationError) as info:
        cm.simulate(0.1, n_out=3, start={alias: 0.7})
    text = str(info.value)
    assert re.search(r"\bj1\.phi\b", text) and alias in text, text
    assert "0.5" in text and "0.7" in text, "both values are shown"


def test_aliases_with_equal_start_values_are_accepted(cm):
    """Guard for the test above: agreeing start values on aliases are not a conflict."""
    res = cm.simulate(0.1, n_out=3, start={"j1.flange_a.phi": 0.5})
    assert res["j1.phi"][0] == pytest.approx(0.5)


def test_start_values_related_through_an_equation(cm):
    """s.tau = c·j1.phi, so s.tau = 3 asks for j1.phi = 0.3 while j1.phi = 0.1 is also fixed."""
    with pytest.raises(mn.InitializationError) as info:
        cm.simulate(0.1, n_out=3, start={"j1.phi": 0.1, "s.tau": 3.0})
    text = str(info.value)
    assert "j1.phi" in text and "s.tau" in text, text


@pytest.mark.parametrize("name", ["f.flange.phi", "s.flange_a.phi"])
def test_start_value_on_a_quantity_the_model_fixes(cm, name):
    """f.flange.phi = 0 always (Fixed); so is everything rigidly attached to it."""
    quoted = re.escape(name)
    with pytest.raises(mn.InitializationError, match=rf"{quoted} = 0\.2 cannot hold.*fixes {quoted} = 0\b"):
        cm.simulate(0.1, n_out=3, start={name: 0.2})


def test_start_value_on_a_fixed_quantity_that_agrees_is_accepted(cm):
    res = cm.simulate(0.1, n_out=3, start={"f.flange.phi": 0.0})
    assert res["f.flange.phi"][0] == 0.0


def test_start_value_that_is_nan(cm):
    with pytest.raises(mn.InitializationError, match=r"j1\.phi = nan"):
        cm.simulate(0.1, n_out=3, start={"j1.phi": float("nan")})


# ---- models with algebraic variables ---------------------------------------------------------

class Loop(mn.Component):
    """z + z³ = x (stays an algebraic loop), der(x) = -z: one state, one algebraic."""

    x = mn.State(start=1.0)
    z = mn.Var(doc="loop variable")

    def equations(self):
        return [mn.Eq(self.z + self.z ** 3, self.x, "nonlinear loop"),
                mn.Eq(mn.der(self.x), -self.z, "decay")]


class NoRealRoot(mn.Component):
    """z² = x − 2 has no real solution while x < 2."""

    x = mn.State(start=1.0)
    z = mn.Var(start=1.0)

    def equations(self):
        return [mn.Eq(self.z ** 2, self.x - 2.0, "no real root for x < 2"),
                mn.Eq(mn.der(self.x), -self.z, "decay")]


def test_start_values_for_a_state_and_its_algebraic():
    """One state, two fixed start values that z + z³ = x ties together (2 ≠ 5 + 125): name both."""
    m = mn.Model("loop")
    m.add(Loop(name="l"))
    cm = m.compile()
    assert cm.algebraic_names == ("l.z",)
    with pytest.raises(mn.InitializationError) as info:
        cm.simulate(0.1, n_out=3, start={"l.x": 2.0, "l.z": 5.0})
    text = str(info.value)
    assert re.search(r"\bl\.x = 2\b", text) and re.search(r"\bl\.z = 5\b", text), text


def test_no_consistent_algebraic_values():
    """x_start = 1 leaves z² = −1: name the start value and the equation it contradicts."""
    m = mn.Model("noroot")
    m.add(NoRealRoot(name="c", x_start=1.0))
    cm = m.compile()
    with pytest.raises(mn.InitializationError) as info:
        cm.simulate(0.1, n_out=3)
    text = str(info.value)
    assert "c.x = 1" in text, text
    assert "c (NoRealRoot), equation 1" in text, text


class _Scaled(mn.Component):
    """x'' = −x with an output y = k·x, k tunable: at k = 0 a start value on y fixes nothing."""
    k = mn.Param(2.0)
    x = mn.State(priority="default")
    v = mn.State(priority="default")
    y = mn.Var()

    def equations(self):
        return [mn.Eq(mn.der(self.x), self.v), mn.Eq(mn.der(self.v), -self.x), mn.Eq(self.y, self.k * self.x)]


@pytest.fixture(scope="module")
def scaled():
    m = mn.Model("scaled")
    m.add(_Scaled(name="s", k=mn.tunable(2.0)))
    return m.compile()


def test_start_value_whose_coefficient_a_parameter_makes_zero(scaled):
    """Regression (review): the initial system's structure is cached symbolically, with k a symbol; at
    k = 0, y = 0 whatever x, so y = 1 cannot hold and is reported as such (not as a failed Newton)."""
    with pytest.raises(mn.InitializationError, match=r"start value s\.y = 1 cannot hold"):
        scaled.simulate(0.1, n_out=3, start={"s.y": 1.0, "s.v": 0.0}, params={"s.k": 0.0})
    # y = 0 agrees with k = 0; x then comes from its own start value (was "too many fixed start values")
    res = scaled.simulate(0.1, n_out=3, start={"s.y": 0.0, "s.x": 0.4, "s.v": 0.0}, params={"s.k": 0.0})
    assert res["s.x"][0] == pytest.approx(0.4, rel=1e-12, abs=0)
    # and the cached structure still serves k ≠ 0: y = 1 → x = 1/k (static, rtol 1e-12)
    res = scaled.simulate(0.1, n_out=3, start={"s.y": 1.0, "s.v": 0.0}, params={"s.k": 4.0})
    assert res["s.x"][0] == pytest.approx(0.25, rel=1e-12, abs=0)


# ---- too few fixed values, whatever the matching of the initial system picks ----------------------

class _LoopUndeclared(Loop):
    """Loop whose x declares no default start."""

    x = mn.State()


def _loop_model(declared=True, **kw):
    """Loop (z + z³ = x, der(x) = −z; x declares start=1.0, a guess, never enforced) or _LoopUndeclared."""
    m = mn.Model("loop")
    m.add((Loop if declared else _LoopUndeclared)(name="l", **kw))
    return m.compile()


@pytest.mark.parametrize("declared, kw", [(True, {}), (False, {}), (True, {"x_guess": 0.8})],
                         ids=["declared-start", "no-declared-start", "guess"])
def test_a_state_fixed_by_nothing_is_named_even_when_an_algebraic_equation_could_take_it(declared, kw):
    """Regression (issue 15, item 4): the algebraic row z + z³ = x could be matched to x, leaving z
    unmatched and x reported as neither fixed nor free; x then started anywhere (0.532, 0, 0.420).
    Declared starts and guesses only seed Newton, so x is free and must be named."""
    cm = _loop_model(declared, **kw)
    with pytest.raises(mn.InitializationError, match=r"too few fixed start values: nothing fixes the states l\.x\b"):
        cm.simulate(0.1, n_out=3)


def _real_root(x):
    """The one real root of z + z³ = x (Cardano; z + z³ is increasing)."""
    s = np.sqrt(x ** 2 / 4 + 1 / 27)
    return np.cbrt(x / 2 + s) + np.cbrt(x / 2 - s)


def test_the_loop_with_one_fixed_value_starts_there_and_keeps_its_invariant():
    """Guard for the test above. x_start = 0.8: z(0) is the real root of z + z³ = 0.8. Along the motion
    dz/dt·(1 + 3z²) = −z, so ln z + 3z²/2 + t is constant (z > 0 throughout): checked at every output
    point against its start value, atol 1e-5 (run rtol 1e-8, atol 1e-10; horizon 2 s; z from 0.59 to ~0.1)."""
    cm = _loop_model(x_start=0.8)
    res = cm.simulate(2.0, n_out=41, rtol=1e-8, atol=1e-10)
    assert res["l.x"][0] == 0.8 and res["l.z"][0] == pytest.approx(_real_root(0.8), rel=1e-10, abs=0)
    z = res["l.z"]
    invariant = np.log(z) + 1.5 * z ** 2 + res.t
    assert np.max(np.abs(invariant - invariant[0])) < 1e-5


def test_a_fixed_algebraic_value_fixes_the_state_through_the_equation():
    """z is fixed instead of x: the initial system is square all the same; x = z + z³ exactly (rtol 1e-12)."""
    cm = _loop_model()
    res = cm.simulate(0.1, n_out=3, start={"l.z": 0.5})
    assert res["l.z"][0] == pytest.approx(0.5, rel=1e-12, abs=0)
    assert res["l.x"][0] == pytest.approx(0.5 + 0.125, rel=1e-12, abs=0)


def test_the_loop_at_steady_state_starts_at_its_equilibrium():
    """der(x) = −z = 0 gives z = 0 and then x = 0: steady state fixes the one degree of freedom (atol 1e-12)."""
    cm = _loop_model()
    res = cm.simulate(0.1, n_out=3, steady_state=True, guess={"l.x": 0.3, "l.z": 0.2})
    assert abs(res["l.x"][0]) < 1e-12 and abs(res["l.z"][0]) < 1e-12


def test_steady_state_where_none_exists_names_the_derivative():
    # issue 16: a free inertia under a constant torque accelerates at tau/J forever; the message listed an
    # empty group. der(j1.w) = 2 N·m / 1 kg·m² whatever the state: no steady state
    from mechnet.components import rotational as rot
    m = mn.Model("spin")
    j1 = m.add(rot.Inertia(name="j1", J=1.0))
    tq = m.add(rot.ConstantTorque(name="tq", tau_constant=2.0))
    m.connect(tq.flange, j1.flange_a)
    with pytest.raises(mn.InitializationError, match=r"no steady state exists: der\(j1\.w\) is a constant"):
        m.compile().simulate(1.0, steady_state=True)
