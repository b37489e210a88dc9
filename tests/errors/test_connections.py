"""Bad connections: ConnectError naming the connectors (and the model) involved."""
import re

import pytest

import mechnet as mn
from mechnet.components import rotational as rot


class Pin(mn.Connector):
    """An electrical pin: a connector type that is not a rotational flange."""

    v = mn.Across(unit="V", doc="potential")
    i = mn.Through(unit="A", doc="current into the component")


class Ground(mn.Component):
    """Zero potential at its pin."""

    p = mn.Port(Pin)

    def equations(self):
        return [mn.Eq(self.p.v, 0.0, "ground potential")]


@pytest.fixture
def scene():
    m = mn.Model("m")
    j = m.add(rot.Inertia(name="j1", J=1.0))
    g = m.add(Ground(name="g"))
    return m, j, g


@pytest.mark.parametrize("order", ["flange_first", "pin_first"])
def test_incompatible_connector_types(scene, order):
    m, j, g = scene
    a, b = (j.flange_a, g.p) if order == "flange_first" else (g.p, j.flange_a)
    with pytest.raises(mn.ConnectError) as info:
        m.connect(a, b)
    text = str(info.value)
    assert re.search(rf"{re.escape(a.label)}\b.*\b{re.escape(b.label)}\b", text), text
    assert "Flange" in text and "Pin" in text, "the message says which connector types clash"


def test_connector_connected_to_itself(scene):
    m, j, _ = scene
    with pytest.raises(mn.ConnectError, match=r"j1\.flange_a.*itself"):
        m.connect(j.flange_a, j.flange_a)


@pytest.mark.parametrize("side", ["first", "second"])
def test_connector_of_a_component_not_added(scene, side):
    m, j, _ = scene
    stray = rot.Inertia(name="j2", J=1.0)
    args = (stray.flange_a, j.flange_b) if side == "first" else (j.flange_b, stray.flange_a)
    with pytest.raises(mn.ConnectError, match=r"model 'm'.*j2\.flange_a.*add\(\)"):
        m.connect(*args)


@pytest.mark.parametrize("make_bad, shown", [
    (lambda j: j, r"<Inertia j1>"),                    # the component instead of one of its flanges
    (lambda j: "j1.flange_a", r"'j1\.flange_a'"),      # a dotted name instead of the connector
    (lambda j: j.phi, r"j1\.phi"),                     # a variable instead of a connector
    (lambda j: None, r"None"),
], ids=["component", "string", "variable", "none"])
def test_connect_takes_connectors_only(scene, make_bad, shown):
    m, j, _ = scene
    j2 = m.add(rot.Inertia(name="j2", J=1.0))
    with pytest.raises(mn.ConnectError, match=rf"model 'm'.*connect\(\).*{shown}"):
        m.connect(j2.flange_a, make_bad(j))


def test_expose_of_a_foreign_connector():
    sub = mn.Model("drive")
    outside = rot.Inertia(name="j", J=1.0)
    with pytest.raises(mn.ConnectError, match=r"model 'drive'.*j\.flange_b"):
        sub.expose("flange", outside.flange_b)


@pytest.mark.parametrize("make_bad, shown", [
    (lambda j: j, r"<Inertia j>"),
    (lambda j: j.phi, r"j\.phi"),
], ids=["component", "variable"])
def test_expose_takes_connectors_only(make_bad, shown):
    sub = mn.Model("drive")
    j = sub.add(rot.Inertia(name="j", J=1.0))
    with pytest.raises(mn.ConnectError, match=rf"model 'drive'.*{shown}"):
        sub.expose("flange", make_bad(j))


def test_expose_name_must_be_an_identifier():
    sub = mn.Model("drive")
    j = sub.add(rot.Inertia(name="j", J=1.0))
    with pytest.raises(mn.ParameterError, match=r"model 'drive'.*'1flange'"):
        sub.expose("1flange", j.flange_b)
