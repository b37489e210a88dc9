"""Building a scene wrongly: name clashes, shared instances, edits after compile()."""
import pytest

import mechnet as mn
from mechnet.components import rotational as rot


# ---- names and ownership ------------------------------------------------------------------------

def test_duplicate_component_name():
    m = mn.Model("rig")
    m.add(rot.Inertia(name="j1", J=1.0))
    with pytest.raises(mn.NameConflictError, match=r"model 'rig'.*'j1'.*Inertia"):
        m.add(rot.Spring(name="j1", c=1.0))


def test_subsystem_named_like_a_component():
    m = mn.Model("rig")
    m.add(rot.Inertia(name="drive", J=1.0))
    with pytest.raises(mn.NameConflictError, match=r"model 'rig'.*'drive'"):
        m.add(mn.Model("drive"))


def test_same_component_instance_in_two_models():
    j = rot.Inertia(name="j1", J=1.0)
    mn.Model("first").add(j)
    with pytest.raises(mn.NameConflictError, match=r"'j1'.*already part of a model"):
        mn.Model("second").add(j)


def test_same_subsystem_in_two_models():
    sub = mn.Model("drive")
    sub.add(rot.Inertia(name="j", J=1.0))
    mn.Model("first").add(sub)
    with pytest.raises(mn.NameConflictError, match=r"'drive'.*already part of a model"):
        mn.Model("second").add(sub)


def test_model_added_to_itself():
    m = mn.Model("rig")
    with pytest.raises(mn.ConnectError, match=r"model 'rig'.*'rig'.*itself"):
        m.add(m)


def test_subsystems_added_in_a_cycle():
    outer, inner = mn.Model("outer"), mn.Model("inner")
    outer.add(inner)
    with pytest.raises(mn.ConnectError, match=r"model 'inner'.*'outer'.*itself"):
        inner.add(outer)


@pytest.mark.parametrize("item", ["j1", 3.0, rot.Inertia], ids=["string", "number", "class"])
def test_add_takes_components_or_models(item):
    m = mn.Model("rig")
    with pytest.raises(mn.ConnectError, match=r"model 'rig'.*add\(\)"):
        m.add(item)


# ---- components are immutable after construction ------------------------------------------------

@pytest.mark.parametrize("attribute, value", [
    ("J", 2.0),                # a parameter
    ("phi", 0.0),              # a variable
    ("flange_a", None),        # a connector
])
def test_declared_attribute_set_after_construction(attribute, value):
    j = rot.Inertia(name="j1", J=1.0)
    with pytest.raises(mn.ParameterError, match=rf"j1 \(Inertia\).*\b{attribute}\b.*construction"):
        setattr(j, attribute, value)
    assert j.J == 1.0


# ---- a compiled model is frozen -------------------------------------------------------------------

@pytest.fixture
def compiled_rig():
    m = mn.Model("rig")
    j = m.add(rot.Inertia(name="j1", J=1.0))
    f = m.add(rot.Fixed(name="f"))
    m.connect(f.flange, j.flange_a)
    m.compile()
    return m, j, f


def test_add_after_compile(compiled_rig):
    m, _, _ = compiled_rig
    with pytest.raises(mn.FrozenModelError, match=r"model 'rig'.*frozen.*add 'j2'"):
        m.add(rot.Inertia(name="j2", J=1.0))
    assert "j2" not in [c.name for c in m.components()]


def test_connect_after_compile(compiled_rig):
    m, j, f = compiled_rig
    with pytest.raises(mn.FrozenModelError, match=r"model 'rig'.*frozen.*connect"):
        m.connect(j.flange_b, f.flange)


def test_expose_after_compile(compiled_rig):
    m, j, _ = compiled_rig
    with pytest.raises(mn.FrozenModelError, match=r"model 'rig'.*frozen.*expose"):
        m.expose("out", j.flange_b)


def test_subsystem_is_frozen_with_its_parent():
    sub = mn.Model("drive")
    j = sub.add(rot.Inertia(name="j", J=1.0))
    sub.expose("flange", j.flange_b)
    top = mn.Model("top")
    top.add(sub)
    top.compile()
    with pytest.raises(mn.FrozenModelError, match=r"model 'drive'.*frozen.*add 'k'"):
        sub.add(rot.Inertia(name="k", J=1.0))
