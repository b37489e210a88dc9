"""Models whose equations do not determine their variables: StructureError and its subclasses.

Each message must name the equations (as `component (Type), equation k`) and
variables (dotted names with their component) involved.
"""
import casadi as ca

from mechnet.compile.index_reduction import IndexReductionOptions
import pytest

import mechnet as mn
from mechnet.components import rotational as rot


class Clamp(mn.Component):
    """Holds its flange twice: one equation too many for the one torque it adds."""

    flange = mn.Port(rot.Flange)
    k = mn.Param(3.0, doc="stiffness")

    def equations(self):
        return [mn.Eq(self.flange.tau, -self.k * self.flange.phi, "holds the flange"),
                mn.Eq(self.flange.tau ** 3, -self.flange.phi, "holds it again")]


class Pusher(mn.Component):
    """Prescribes both the torque and (through phi·tau = 2) the angle of its flange."""

    flange = mn.Port(rot.Flange)

    def equations(self):
        return [mn.Eq(self.flange.tau, 1.0, "pushes"),
                mn.Eq(self.flange.phi * self.flange.tau, 2.0, "and positions")]


class Loose(mn.Component):
    """Declares y but no equation fixes it."""

    x = mn.State(start=1.0)
    y = mn.Var(doc="forgotten")

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.x, "decay")]


class Constrained(mn.Component):
    """Two states tied by x = 2y + 1 (not an alias): an index-2 DAE with multiplier F."""

    x = mn.State(start=1.0)
    y = mn.State(start=0.0)
    F = mn.Var(doc="constraint force")

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.x + self.F, "x dynamics"),
                mn.Eq(mn.der(self.y), self.y - 2 * self.F, "y dynamics"),
                mn.Eq(self.x, 2 * self.y + 1, "coupling")]


class Gear(mn.Component):
    """Ideal gear of ratio 2 between two flanges: couples the angles of two inertias rigidly."""

    flange_a = mn.Port(rot.Flange)
    flange_b = mn.Port(rot.Flange)

    def equations(self):
        return [mn.Eq(self.flange_b.phi, 2 * self.flange_a.phi, "kinematics"),
                mn.Eq(2 * self.flange_b.tau, -self.flange_a.tau, "power balance")]


# ---- over-determined --------------------------------------------------------------------------

def test_over_determined_lists_the_competing_equations():
    m = mn.Model("over")
    j = m.add(rot.Inertia(name="j1", J=1.0))
    c = m.add(Clamp(name="clamp"))
    m.connect(j.flange_a, c.flange)
    with pytest.raises(mn.UnbalancedModelError, match=r"model 'over'.*equations for .*unknowns") as info:
        m.compile()
    err = info.value
    text = str(err)
    assert "Over-determined" in text
    for label in ("clamp (Clamp), equation 1", "clamp (Clamp), equation 2"):
        assert label in text
        assert any(label in e for e in err.equations)
    assert any("holds it again" in e for e in err.equations), "the equation's doc is shown"
    assert err.variables == []


def test_two_fixed_at_different_angles_on_one_flange():
    """f1 holds the flange at 0, f2 at 0.5: after constants are eliminated, 0.5 = 0 remains."""
    m = mn.Model("twofixed")
    j = m.add(rot.Inertia(name="j1", J=1.0))
    f1 = m.add(rot.Fixed(name="f1"))
    f2 = m.add(rot.Fixed(name="f2", phi0=0.5))
    m.connect(j.flange_a, f1.flange)
    m.connect(j.flange_a, f2.flange)
    with pytest.raises(mn.StructureError, match=r"cannot hold") as info:
        m.compile()
    text = str(info.value)
    assert "f1.flange" in text and "f2.flange" in text, text
    assert "0.5" in text


def test_two_fixed_at_the_same_angle_leave_the_reaction_undetermined():
    """Consistent but redundant: how the reaction torque splits between f1 and f2 is undetermined."""
    m = mn.Model("twofixed")
    j = m.add(rot.Inertia(name="j1", J=1.0))
    f1 = m.add(rot.Fixed(name="f1"))
    f2 = m.add(rot.Fixed(name="f2"))
    m.connect(j.flange_a, f1.flange)
    m.connect(j.flange_a, f2.flange)
    with pytest.raises(mn.UnbalancedModelError, match=r"f[12]\.flange\.tau \(f[12], Fixed\)") as info:
        m.compile()
    assert any("flange.tau" in v for v in info.value.variables)


def test_over_determined_through_constants_is_not_swallowed():
    """Pusher fixes tau = 1 and phi·tau = 2 on a flange that also carries an inertia.

    That is one equation more than unknowns; alias and constant elimination
    must not consume the surplus silently (and then report wrong values).
    """
    m = mn.Model("pushed")
    j = m.add(rot.Inertia(name="j1", J=1.0))
    p = m.add(Pusher(name="p"))
    m.connect(j.flange_a, p.flange)
    with pytest.raises(mn.StructureError, match=r"\((Inertia|Pusher)\), equation \d"):
        m.compile()


# ---- under-determined -------------------------------------------------------------------------

def test_under_determined_lists_the_free_variables():
    m = mn.Model("under")
    m.add(Loose(name="l"))
    with pytest.raises(mn.UnbalancedModelError,
                       match=r"model 'under'.*\n.*Under-determined.*\n\s+l\.y \(l, Loose\)") as info:
        m.compile()
    assert info.value.variables == ["l.y (l, Loose)"]
    assert info.value.equations == []


def test_unbalanced_is_a_structure_error():
    assert issubclass(mn.UnbalancedModelError, mn.StructureError)
    assert issubclass(mn.HigherIndexError, mn.StructureError)


# ---- higher index ------------------------------------------------------------------------------

NO_REDUCTION = mn.CompileOptions(reduce=IndexReductionOptions(method="none"))


def test_constraint_between_states_is_higher_index():
    """With index reduction switched off, a constraint among states is named as a higher-index problem."""
    m = mn.Model("hi")
    m.add(Constrained(name="b"))
    with pytest.raises(mn.HigherIndexError, match=r"model 'hi'") as info:
        m.compile(NO_REDUCTION)
    text = str(info.value)
    assert "b (Constrained), equation 3" in text and "coupling" in text
    assert "b.x" in text and "b.y" in text
    assert "b (Constrained), equation 1" not in text, "only the constraint is blamed"


def test_rigid_gear_between_two_inertias_is_higher_index():
    m = mn.Model("gearbox")
    j1 = m.add(rot.Inertia(name="j1", J=1.0))
    g = m.add(Gear(name="gear"))
    j2 = m.add(rot.Inertia(name="j2", J=2.0))
    m.connect(j1.flange_b, g.flange_a)
    m.connect(g.flange_b, j2.flange_a)
    with pytest.raises(mn.HigherIndexError, match=r"gear \(Gear\), equation 1") as info:
        m.compile(NO_REDUCTION)
    assert "j1.phi" in str(info.value) and "j2.phi" in str(info.value)


# ---- symbols the model does not declare ------------------------------------------------------

class Stray(mn.Component):
    x = mn.State(start=1.0)

    def equations(self):
        k = ca.SX.sym("k")          # meant to be a Param
        return [mn.Eq(mn.der(self.x), -k * self.x, "decay")]


_GHOST = rot.Inertia(name="ghost", J=1.0)


class Peeker(mn.Component):
    """Reads a variable of a component that was never added to the model."""

    x = mn.State(start=1.0)

    def equations(self):
        return [mn.Eq(mn.der(self.x), -_GHOST.phi, "follows the ghost")]


@pytest.mark.parametrize("cls, symbol", [(Stray, "k"), (Peeker, "ghost.phi")])
def test_undeclared_symbol_in_an_equation(cls, symbol):
    m = mn.Model("m")
    m.add(cls(name="c"))
    with pytest.raises(mn.StructureError,
                       match=rf"c \({cls.__name__}\), equation 1 uses the symbol '{symbol}'"):
        m.compile()


# ---- malformed equations ---------------------------------------------------------------------

class ComparisonInsteadOfEq(mn.Component):
    x = mn.State(start=1.0)

    def equations(self):
        return [mn.der(self.x) == -self.x]          # a CasADi comparison, not an equation


class ForgotReturn(mn.Component):
    x = mn.State(start=1.0)

    def equations(self):
        [mn.Eq(mn.der(self.x), -self.x)]            # noqa: B018 - the mistake under test


class StringOperand(mn.Component):
    x = mn.State(start=1.0)

    def equations(self):
        return [mn.Eq("der(x)", -self.x)]


class ConstantEquation(mn.Component):
    x = mn.State(start=1.0)

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.x), mn.Eq(1.0, 2.0, "nonsense")]


@pytest.mark.parametrize("cls", [ComparisonInsteadOfEq, ForgotReturn, StringOperand, ConstantEquation])
def test_malformed_equation_names_the_component(cls):
    m = mn.Model("m")
    m.add(cls(name="c"))
    with pytest.raises(mn.StructureError, match=rf"c \({cls.__name__}\)"):
        m.compile()
