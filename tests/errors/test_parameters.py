"""Non-physical or malformed component arguments: ParameterError naming the component and the argument.

Every message must say which component (`name (Type)`) and which keyword is
wrong; where the library knows it, the message also says what was expected.
"""
import math
import re

import pytest

import mechnet as mn
from mechnet.components import rotational as rot

NAN, INF = float("nan"), float("inf")

# (component class, parameter, the other arguments it needs)
POSITIVE_OR_NONNEGATIVE = [
    (rot.Inertia, "J", {}),
    (rot.Spring, "c", {}),
    (rot.Damper, "d", {}),
    (rot.SpringDamper, "c", {"d": 1.0}),
    (rot.SpringDamper, "d", {"c": 1.0}),
]


def case_id(value):
    """Readable test ids: class names, and the names of the other arguments given."""
    if isinstance(value, type):
        return value.__name__
    if isinstance(value, dict):
        return "with_" + "_".join(value) if value else "alone"
    return None


def culprit(component: str, cls, what: str) -> str:
    """Regex: the message names `component (Class)` and then the argument."""
    return rf"{re.escape(component)} \({cls.__name__}\).*\b{re.escape(what)}\b"


@pytest.mark.parametrize("cls, param, others, value, expected", [
    (rot.Inertia, "J", {}, 0.0, "must be > 0"),
    (rot.Inertia, "J", {}, -1.0, "must be > 0"),
    (rot.Spring, "c", {}, -1.0, "must be >= 0"),
    (rot.Damper, "d", {}, -1.0, "must be >= 0"),
    (rot.SpringDamper, "c", {"d": 1.0}, -2.0, "must be >= 0"),
    (rot.SpringDamper, "d", {"c": 1.0}, -0.5, "must be >= 0"),
], ids=case_id)
def test_out_of_range_parameter(cls, param, others, value, expected):
    with pytest.raises(mn.ParameterError, match=culprit("x1", cls, param)) as info:
        cls(name="x1", **{**others, param: value})
    assert expected in str(info.value)
    assert f"{value:g}" in str(info.value), "the message repeats the offending value"


@pytest.mark.parametrize("value", [NAN, INF, -INF], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("cls, param, others", POSITIVE_OR_NONNEGATIVE + [
    (rot.Spring, "phi_rel0", {"c": 1.0}),
    (rot.Fixed, "phi0", {}),
    (rot.ConstantTorque, "tau_constant", {}),
], ids=case_id)
def test_non_finite_parameter(cls, param, others, value):
    with pytest.raises(mn.ParameterError, match=culprit("x1", cls, param)) as info:
        cls(name="x1", **{**others, param: value})
    assert "not finite" in str(info.value)


@pytest.mark.parametrize("cls, param, others", POSITIVE_OR_NONNEGATIVE,
                         ids=case_id)
@pytest.mark.parametrize("value", ["heavy", "1,5", [1.0, 2.0]])
def test_parameter_that_is_not_a_number(cls, param, others, value):
    with pytest.raises(mn.ParameterError, match=culprit("x1", cls, param)) as info:
        cls(name="x1", **{**others, param: value})
    assert "not a number" in str(info.value)


def test_parameter_message_gives_unit_and_meaning():
    with pytest.raises(mn.ParameterError) as info:
        rot.Inertia(name="j1", J=-1.0)
    text = str(info.value)
    assert "kg*m^2" in text and "moment of inertia" in text


@pytest.mark.parametrize("cls, param, others", POSITIVE_OR_NONNEGATIVE + [
    (rot.ConstantTorque, "tau_constant", {}),
], ids=case_id)
def test_missing_required_parameter(cls, param, others):
    others = {k: v for k, v in others.items() if k != param}
    with pytest.raises(mn.ParameterError, match=culprit("x1", cls, param)) as info:
        cls(name="x1", **others)
    assert "required" in str(info.value)


def test_unknown_keyword_argument_is_named_and_parameters_listed():
    with pytest.raises(mn.ParameterError, match=culprit("j1", rot.Inertia, "K")) as info:
        rot.Inertia(name="j1", J=1.0, K=2.0)
    assert "unknown argument" in str(info.value)
    assert re.search(r"(parameters|arguments) are .*\bJ\b", str(info.value))


def test_misspelled_start_keyword_suggests_the_right_one():
    """`phi_strat=` is a typo of `phi_start=`: the message should point at the keyword that exists."""
    with pytest.raises(mn.ParameterError, match=culprit("j1", rot.Inertia, "phi_strat")) as info:
        rot.Inertia(name="j1", J=1.0, phi_strat=0.1)
    assert "phi_start" in str(info.value)


@pytest.mark.parametrize("keyword, value", [
    ("phi_start", NAN),
    ("phi_start", INF),
    ("w_start", -INF),
    ("phi_guess", NAN),
    ("phi_start", "abc"),          # a non-number start value
    ("w_guess", "fast"),
])
def test_bad_start_or_guess_value(keyword, value):
    with pytest.raises(mn.ParameterError, match=culprit("j1", rot.Inertia, keyword)):
        rot.Inertia(name="j1", J=1.0, **{keyword: value})


@pytest.mark.parametrize("value", [0.0, -1.0, NAN])
def test_nominal_value_must_be_positive(value):
    """States are integrated as x / nominal: a zero or negative nominal value breaks the scaling."""
    with pytest.raises(mn.ParameterError, match=culprit("j1", rot.Inertia, "phi_nominal")):
        rot.Inertia(name="j1", J=1.0, phi_nominal=value)


@pytest.mark.parametrize("value", [NAN, INF, "strong"])
def test_bad_input_default(value):
    """`Torque(tau=...)` sets the default of input tq.tau: it must be a finite number."""
    with pytest.raises(mn.ParameterError, match=culprit("tq", rot.Torque, "tau")):
        rot.Torque(name="tq", tau=value)


@pytest.mark.parametrize("value", [NAN, INF, -1.0])
def test_bad_tunable_value_at_construction(value):
    with pytest.raises(mn.ParameterError, match=culprit("s", rot.Spring, "c")):
        rot.Spring(name="s", c=mn.tunable(value))


@pytest.mark.parametrize("name", ["1j", "j.1", "a b", "class", ""])
def test_component_name_must_be_an_identifier(name):
    with pytest.raises(mn.ParameterError, match=rf"Inertia: name {re.escape(repr(name))}"):
        rot.Inertia(name=name, J=1.0)


# ---- tunable parameters changed at simulate time go through the same checks ---------------------

@pytest.fixture(scope="module")
def tunable_oscillator():
    m = mn.Model("osc")
    j = m.add(rot.Inertia(name="j1", J=1.0, phi_start=0.5, w_start=0.0))
    s = m.add(rot.Spring(name="s", c=mn.tunable(10.0)))
    f = m.add(rot.Fixed(name="f"))
    m.connect(f.flange, s.flange_a)
    m.connect(s.flange_b, j.flange_a)
    return m.compile()


@pytest.mark.parametrize("value", [-5.0, NAN, INF], ids=["negative", "nan", "inf"])
def test_simulate_params_checked_like_construction(tunable_oscillator, value):
    """A spring constant that `Spring(c=-5)` rejects must not slip in through simulate(params=)."""
    assert tunable_oscillator.parameter_names == ("s.c",)
    with pytest.raises(mn.ParameterError, match=r"s\.c"):
        tunable_oscillator.simulate(0.1, n_out=3, params={"s.c": value})


def test_simulate_params_accepts_a_valid_value(tunable_oscillator):
    """Guard for the test above: the same call with a physical value works (w = sqrt(c/J))."""
    res = tunable_oscillator.simulate(0.1, n_out=3, params={"s.c": 4.0})
    assert res["j1.phi"][-1] == pytest.approx(0.5 * math.cos(2.0 * 0.1), rel=1e-5)


@pytest.mark.parametrize("kwargs, typo, meant", [
    ({"phimin": -1.0, "phi_max": 1.0}, "phimin", "phi_min"),                  # a required keyword misspelled
    ({"phi_min": NAN, "phi_max": 1.0, "v_rets": 0.1}, "v_rets", "v_rest"),    # before a bad value is checked
    ({"phi_min": -1.0, "phi_max": 1.0, "phi_rel_strat": 0.0}, "phi_rel_strat", "phi_rel_start"),
])
def test_a_misspelled_keyword_is_reported_as_unknown_first(kwargs, typo, meant):
    """Issue 32, item 7: `phimin=` was reported as the missing `phi_min`, not as the unknown `phimin`."""
    with pytest.raises(mn.ParameterError) as info:
        rot.HardStop(name="stop", **kwargs)
    message = str(info.value)
    assert isinstance(info.value, mn.MechnetError)
    assert message.startswith(f"stop (HardStop): unknown argument(s) {typo} (did you mean {meant}?)"), message
    assert "is required" not in message
