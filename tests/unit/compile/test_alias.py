"""simplify: alias and constant elimination, derivative merging, inconsistent constants."""
import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.compile.alias import simplify
from mechnet.compile.flatten import flatten
from mechnet.components import rotational as rot
from stage_scenes import evaluate, oscillator, rigid_pair


@pytest.fixture(scope="module")
def osc():
    flat = flatten(oscillator())
    simplified, aliases = simplify(flat)
    return flat, simplified, aliases


def survivor_symbols(simplified):
    return [v.symbol for v in simplified.variables]


def value_of(name, simplified, aliases, values):
    """A flat variable's value given values of the surviving variables."""
    survivors = {v.name: v.symbol for v in simplified.variables}
    expr = survivors[name] if name in survivors else aliases.expressions[name]
    return float(evaluate([expr], survivor_symbols(simplified), values)[0])


def test_oscillator_keeps_exactly_two_states(osc):
    _, simplified, _ = osc
    assert [simplified.variables[i].name for i in simplified.states()] == ["j1.phi", "j1.w"]
    # the unknowns left at each instant: the acceleration and the spring torque, one equation each
    assert len(simplified.equations) == len(simplified.unknowns())


def test_every_flat_name_survives_or_has_an_alias_expression(osc):
    flat, simplified, aliases = osc
    survivors = {v.name for v in simplified.variables}
    eliminated = set(aliases.expressions)
    assert survivors.isdisjoint(eliminated)
    assert survivors | eliminated == {v.name for v in flat.variables}
    assert aliases.n_alias + aliases.n_constant == len(eliminated)


def test_angles_alias_the_inertia_or_the_fixed_housing(osc):
    _, simplified, aliases = osc
    phi = next(v.symbol for v in simplified.variables if v.name == "j1.phi")
    for name in ("spring.flange_b.phi", "j1.flange_a.phi", "j1.flange_b.phi", "spring.phi_rel"):
        assert ca.is_equal(aliases.expressions[name], phi), name            # + j1.phi, no sign
    for name in ("fixed.flange.phi", "spring.flange_a.phi"):
        expr = aliases.expressions[name]
        assert expr.is_constant() and float(ca.evalf(expr)) == 0.0, name     # the housing at phi0 = 0


@pytest.mark.parametrize("name, sign", [
    ("spring.flange_b.tau", +1.0),      # flange_b.tau = tau
    ("spring.flange_a.tau", -1.0),      # flange_a.tau = -tau              (a + b = 0)
    ("j1.flange_a.tau", -1.0),          # connection: j1.flange_a.tau + spring.flange_b.tau = 0
    ("fixed.flange.tau", +1.0),         # connection: fixed.flange.tau + spring.flange_a.tau = 0
])
def test_sign_aliases_come_out_with_the_right_sign(osc, name, sign):
    _, simplified, aliases = osc
    rng = np.random.default_rng(1)
    values = rng.uniform(0.5, 2.0, len(simplified.variables))     # every survivor non-zero
    tau = value_of("spring.tau", simplified, aliases, values)
    assert tau != 0.0
    # exact: a sign alias is a multiplication by ±1
    assert value_of(name, simplified, aliases, values) == sign * tau


@pytest.mark.parametrize("factory", [oscillator, rigid_pair])
def test_alias_expressions_satisfy_every_eliminated_equation(factory):
    """Substituting the AliasMap into the flat residuals: the removed ones vanish identically,
    the others are exactly the simplified system."""
    flat = flatten(factory())
    simplified, aliases = simplify(flat)
    eliminated = [v for v in flat.variables if v.name in aliases.expressions]
    substituted = ca.substitute(ca.vertcat(*[e.residual for e in flat.equations]),
                                ca.vertcat(*[v.symbol for v in eliminated]),
                                ca.vertcat(*[aliases.expressions[v.name] for v in eliminated]))
    survivors = survivor_symbols(simplified)
    points = np.random.default_rng(2).uniform(-2.0, 2.0, (3, len(survivors)))
    flat_values = np.array([evaluate([substituted], survivors, p) for p in points])
    kept_values = np.array([evaluate([e.residual for e in simplified.equations], survivors, p) for p in points])
    # static check (no horizon): the same arithmetic on values of scale 2, so equal up to
    # rounding: rtol 0, atol 1e-14
    labels = [e.label for e in flat.equations]
    nonzero = {labels[k] for k in np.flatnonzero(np.any(np.abs(flat_values) > 1e-14, axis=0))}
    assert nonzero == {e.label for e in simplified.equations}
    for k, eq in enumerate(simplified.equations):
        np.testing.assert_allclose(flat_values[:, labels.index(eq.label)], kept_values[:, k], rtol=0, atol=1e-14)


def test_directly_connected_inertias_share_one_set_of_states():
    flat = flatten(rigid_pair())
    simplified, aliases = simplify(flat)
    assert len(flat.der_of) == 4                        # j1.phi, j1.w, j2.phi, j2.w before simplify
    assert len(simplified.der_of) == 2
    assert len(simplified.equations) == len(simplified.unknowns())
    # j2's angle and speed are j1's (rigid connection), and so are their derivatives (merged)
    rng = np.random.default_rng(3)
    values = rng.uniform(0.5, 2.0, len(simplified.variables))
    for j2_name, j1_name in (("j2.phi", "j1.phi"), ("j2.w", "j1.w"),
                             ("der(j2.phi)", "der(j1.phi)"), ("der(j2.w)", "der(j1.w)")):
        assert (value_of(j2_name, simplified, aliases, values)
                == value_of(j1_name, simplified, aliases, values)), j2_name


def test_directly_connected_inertias_move_as_their_combined_inertia():
    J1, J2, tau = 2.0, 3.0, 5.0
    cm = rigid_pair(J1, J2, tau).compile()
    assert cm.n_states == 2
    res = cm.simulate(1.0, rtol=1e-12, atol=1e-12, n_out=11)
    assert res.success
    t = res.t
    phi = tau * t ** 2 / (2 * (J1 + J2))
    w = tau * t / (J1 + J2)
    # simulated at rtol = atol = 1e-12 over 1 s; phi <= 0.5 rad, w <= 1 rad/s; checked at rtol 0,
    # atol 1e-9: three decades of margin over the expected global error
    for name in ("j1.phi", "j2.phi"):
        np.testing.assert_allclose(res[name], phi, rtol=0, atol=1e-9)
    for name in ("j1.w", "j2.w"):
        np.testing.assert_allclose(res[name], w, rtol=0, atol=1e-9)
    # the cut torque into j2 accelerates j2 alone: J2 * tau / (J1 + J2) = 3 N m. It is an algebraic
    # function of no state, so it is exact to rounding over the whole 1 s horizon: rtol 0,
    # atol 1e-12 on a 3 N m scale (the integrator's rtol = atol = 1e-12 do not enter)
    np.testing.assert_allclose(res["j2.flange_a.tau"], J2 * tau / (J1 + J2), rtol=0, atol=1e-12)
    np.testing.assert_allclose(res["j1.flange_b.tau"], -J2 * tau / (J1 + J2), rtol=0, atol=1e-12)


def test_inconsistent_constant_equation_is_a_structure_error_naming_the_equation():
    """Two housings at 0 rad and 1 rad on the same connection: 0 = 1 after eliminating constants."""
    m = mn.Model("clash")
    f0 = m.add(rot.Fixed("f0", phi0=0.0))
    f1 = m.add(rot.Fixed("f1", phi0=1.0))
    j = m.add(rot.Inertia("j", J=1.0))
    m.connect(f0.flange, j.flange_a)
    m.connect(f1.flange, j.flange_a)
    flat = flatten(m)
    with pytest.raises(mn.StructureError) as info:
        simplify(flat)
    message = str(info.value)
    labels = [e.label for e in flat.equations]
    assert any(label in message for label in labels), message
    assert "f0" in message or "f1" in message
