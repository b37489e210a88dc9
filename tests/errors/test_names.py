"""Dotted names that the model does not contain: UnknownNameError naming it, with a suggestion."""
import pytest

import mechnet as mn
from mechnet.components import rotational as rot


@pytest.fixture(scope="module")
def cm():
    """j1 on a tunable spring to the housing, driven by an input torque."""
    m = mn.Model("osc")
    j = m.add(rot.Inertia(name="j1", J=1.0, phi_start=0.5, w_start=0.0))
    s = m.add(rot.Spring(name="s", c=mn.tunable(10.0)))
    f = m.add(rot.Fixed(name="f"))
    tq = m.add(rot.Torque(name="tq"))
    m.connect(f.flange, s.flange_a)
    m.connect(s.flange_b, j.flange_a)
    m.connect(tq.flange, j.flange_b)
    cm = m.compile()
    assert cm.parameter_names == ("s.c",) and cm.input_names == ("tq.tau",)
    return cm


@pytest.fixture(scope="module")
def res(cm):
    return cm.simulate(0.1, n_out=5)


@pytest.mark.parametrize("keyword, name, suggestion", [
    ("start", "j1.phii", "j1.phi"),
    ("start", "j2.phi", "j1.phi"),
    ("guess", "j1.ww", "j1.w"),
    ("params", "s.cc", "s.c"),
    ("inputs", "tq.tauu", "tq.tau"),
])
def test_unknown_name_in_simulate(cm, keyword, name, suggestion):
    with pytest.raises(mn.UnknownNameError, match=rf"'{name}' does not exist") as info:
        cm.simulate(0.1, n_out=3, **{keyword: {name: 1.0}})
    assert f"did you mean {suggestion}" in str(info.value)


@pytest.mark.parametrize("keyword", ["start", "guess", "params", "inputs"])
def test_unknown_name_without_a_close_match(cm, keyword):
    with pytest.raises(mn.UnknownNameError, match=r"'nope' does not exist") as info:
        cm.simulate(0.1, n_out=3, **{keyword: {"nope": 1.0}})
    assert "did you mean" not in str(info.value)


def test_parameter_that_is_not_tunable(cm):
    """j1.J exists but was folded into the equations: say so, and how to make it tunable."""
    with pytest.raises(mn.UnknownNameError, match=r"'j1\.J'") as info:
        cm.simulate(0.1, n_out=3, params={"j1.J": 2.0})
    assert "tunable(" in str(info.value), "suggest declaring it as J=mn.tunable(...)"


@pytest.mark.parametrize("name, suggestion", [("nope", None), ("j1.phii", "j1.phi"), ("s.tua", "s.tau")])
def test_unknown_name_in_result(res, name, suggestion):
    with pytest.raises(mn.UnknownNameError, match=rf"'{name}' does not exist") as info:
        res[name]
    if suggestion:
        assert f"did you mean {suggestion}" in str(info.value)
    assert name not in res


def test_unknown_name_in_plot(res):
    with pytest.raises(mn.UnknownNameError, match=r"'j1\.phii'.*did you mean j1\.phi"):
        res.plot(["j1.phi", "j1.phii"])


def test_unknown_name_is_also_a_key_error(res):
    """`except KeyError` keeps working for code that treats the result like a mapping."""
    with pytest.raises(KeyError):
        res["nope"]
    with pytest.raises(mn.UnknownNameError) as info:
        res["nope"]
    assert str(info.value).startswith("variable 'nope'"), "no extra quoting from KeyError"
