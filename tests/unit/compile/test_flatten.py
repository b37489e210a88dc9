"""flatten: dotted names, connection sets, derivative variables, equation labels."""
import re

import casadi as ca
import pytest

import mechnet as mn
from mechnet.compile.flatten import flatten
from mechnet.components import rotational as rot


class Pair(mn.Component):
    """A vector variable q (shape 2) fixed by one vector equation."""

    q = mn.Var(shape=2)

    def equations(self):
        return [mn.Eq(self.q, ca.vertcat(1.0, 2.0), "two values")]


def scene():
    """Subsystem `drive` (inertia j, flange_b exposed) + j1 + spring s: three connectors in one set.

    Sets: {drive.j.flange_b, j1.flange_a, s.flange_a}; the rest are unconnected
    singletons {drive.j.flange_a}, {j1.flange_b}, {s.flange_b}.
    """
    m = mn.Model("top")
    drive = mn.Model("drive")
    j = drive.add(rot.Inertia("j", J=1.0))
    drive.expose("flange", j.flange_b)
    m.add(drive)
    j1 = m.add(rot.Inertia("j1", J=2.0))
    s = m.add(rot.Spring("s", c=3.0))
    m.connect(drive.flange, j1.flange_a)
    m.connect(j1.flange_a, s.flange_a)
    m.add(Pair("v"))
    return m


@pytest.fixture(scope="module")
def flat():
    return flatten(scene())


def symbols_of(expr, flat):
    """Dotted names of the flat variables a residual contains."""
    name = {v.symbol.element_hash(): v.name for v in flat.variables}
    return {name[s.element_hash()] for s in ca.symvar(expr)}


def equations_labelled(flat, prefix):
    return [e for e in flat.equations if e.label.startswith(prefix)]


def test_dotted_names_carry_the_subsystem_path(flat):
    names = [v.name for v in flat.variables]
    assert len(names) == len(set(names))
    for expected in ("drive.j.phi", "drive.j.w", "drive.j.flange_b.phi", "drive.j.flange_b.tau",
                     "j1.phi", "j1.flange_a.tau", "s.phi_rel", "s.tau", "s.flange_b.phi"):
        assert expected in names
    # the subsystem's component is addressed through it, never by its bare name
    assert not any(n.startswith("j.") for n in names)
    origin = {v.name: v.origin for v in flat.variables}
    assert origin["drive.j.phi"] == "drive.j"
    assert origin["drive.j.flange_b.tau"] == "drive.j"


def test_scalars_have_no_index_and_vectors_are_indexed_from_zero(flat):
    names = [v.name for v in flat.variables]
    indexed = [n for n in names if "[" in n]
    assert indexed == ["v.q[0]", "v.q[1]"]
    # one residual per element, each with its own label
    labels = [e.label for e in flat.equations if e.origin == "v"]
    assert len(labels) == 2 and len(set(labels)) == 2
    assert labels[1] == "v (Pair), equation 1[1]"


def test_kinds_follow_the_declarations(flat):
    kind = {v.name: v.kind for v in flat.variables}
    assert kind["j1.phi"] == kind["j1.w"] == "state"
    assert kind["j1.a"] == kind["s.tau"] == "algebraic"
    assert kind["j1.flange_a.phi"] == "across"
    assert kind["j1.flange_a.tau"] == "through"
    assert kind["der(j1.phi)"] == "derivative"


def test_three_connectors_give_two_across_equalities_and_one_flow_sum(flat):
    members = ["drive.j.flange_b", "j1.flange_a", "s.flange_a"]
    prefix = "connection {" + ", ".join(members) + "}"
    eqs = equations_labelled(flat, prefix)
    across = [e for e in eqs if "phi of" in e.label]
    through = [e for e in eqs if "tau" in e.label and "phi of" not in e.label]
    assert len(eqs) == 3 and len(across) == 2 and len(through) == 1
    phis = {f"{c}.phi" for c in members}
    # each equality ties two of the three angles, with coefficients +1 and -1
    tied = set()
    for e in across:
        used = symbols_of(e.residual, flat)
        assert len(used) == 2 and used <= phis
        tied |= used
        grad = ca.evalf(ca.jacobian(e.residual, ca.vertcat(*ca.symvar(e.residual)))).full().ravel()
        assert sorted(grad) == [-1.0, 1.0]
    assert tied == phis
    # the flow equation is the plain sum of the three cut torques
    (flow,) = through
    assert "sum to zero" in flow.label
    assert symbols_of(flow.residual, flat) == {f"{c}.tau" for c in members}
    grad = ca.evalf(ca.jacobian(flow.residual, ca.vertcat(*ca.symvar(flow.residual)))).full().ravel()
    assert list(grad) == [1.0, 1.0, 1.0]
    assert float(ca.evalf(ca.substitute(flow.residual, ca.vertcat(*ca.symvar(flow.residual)),
                                         ca.DM.zeros(3)))) == 0.0


@pytest.mark.parametrize("connector", ["drive.j.flange_a", "j1.flange_b", "s.flange_b"])
def test_an_unconnected_flange_gets_zero_torque(flat, connector):
    eqs = equations_labelled(flat, "connection {" + connector + "}")
    assert len(eqs) == 1                  # no angle equation for a set of one
    (eq,) = eqs
    assert "unconnected" in eq.label
    tau = next(v.symbol for v in flat.variables if v.name == f"{connector}.tau")
    assert ca.is_equal(ca.simplify(eq.residual), tau)      # residual is tau itself: tau = 0


def test_connection_equations_are_counted_per_set(flat):
    # 4 sets over 6 flanges: (3 - 1) angle equalities, one flow equation per set
    connection = [e for e in flat.equations if e.origin == "connection"]
    assert len(connection) == 2 + 4


def test_the_flat_system_is_balanced(flat):
    # every component is balanced and each connection set adds (n - 1) + 1 equations
    assert len(flat.equations) == len(flat.unknowns())


def test_derivatives_become_variables_named_der(flat):
    index = flat.index_of()
    for state in ("j1.phi", "j1.w", "drive.j.phi", "drive.j.w"):
        d = f"der({state})"
        assert d in index
        assert flat.der_of[index[state]] == (index[d], 1.0)
        assert flat.variables[index[d]].unit == f"({flat.variables[index[state]].unit})/s"
    assert {flat.variables[i].name for i in flat.states()} == {"j1.phi", "j1.w", "drive.j.phi", "drive.j.w"}
    # nothing else has a derivative: no der() of a connector or algebraic variable was written
    assert len(flat.der_of) == 4


LABEL = re.compile(r"^(?P<path>[\w.]+) \((?P<type>\w+)\), equation (?P<number>\d+)(\[\d+\])?$")


def test_every_equation_names_its_component_and_number_or_its_connection(flat):
    labels = [e.label for e in flat.equations]
    assert len(labels) == len(set(labels))          # a message can always point at one equation
    for eq in flat.equations:
        if eq.origin == "connection":
            assert eq.label.startswith("connection {")
        else:
            match = LABEL.match(eq.label)
            assert match, eq.label
            assert match["path"] == eq.origin
    by_label = {e.label: e for e in flat.equations}
    euler = by_label["j1 (Inertia), equation 5"]
    assert symbols_of(euler.residual, flat) == {"j1.a", "j1.flange_a.tau", "j1.flange_b.tau"}
    assert "Euler" in euler.describe()
    assert symbols_of(by_label["drive.j (Inertia), equation 3"].residual, flat) == {"drive.j.w", "der(drive.j.phi)"}
    assert symbols_of(by_label["s (Spring), equation 4"].residual, flat) == {"s.tau", "s.phi_rel"}


class Stray(mn.Component):
    x = mn.Var()

    def equations(self):
        return [mn.Eq(self.x, ca.SX.sym("undeclared"), "uses a symbol nobody declared")]


def test_an_undeclared_symbol_is_reported_with_its_equation():
    m = mn.Model("stray")
    m.add(Stray("st"))
    with pytest.raises(mn.StructureError, match=r"st \(Stray\), equation 1.*undeclared"):
        flatten(m)
