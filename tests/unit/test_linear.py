"""Linearisation and trim (mechnet.linear) against closed forms."""
import math

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.linear import LinearModel, TrimPoint, linearize, trim

from models import cartesian_pendulum

M, C, D = 2.0, 40.0, 3.0


def msd(force_input=True, constant_force=None, s_start=0.1):
    """Fixed — spring ∥ damper — mass, optionally pushed by a Force input or a ConstantForce."""
    m = mn.Model("msd")
    fixed = m.add(tr.Fixed(name="fixed"))
    spring = m.add(tr.Spring(name="spring", c=C))
    damper = m.add(tr.Damper(name="damper", d=D))
    mass = m.add(tr.Mass(name="mass", m=M, s_start=s_start))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, mass.flange_a)
    m.connect(fixed.flange, damper.flange_a)
    m.connect(damper.flange_b, mass.flange_a)
    if force_input:
        force = m.add(tr.Force(name="force"))
        m.connect(force.flange, mass.flange_b)
    elif constant_force is not None:
        load = m.add(tr.ConstantForce(name="load", f_constant=constant_force))
        m.connect(load.flange, mass.flange_b)
    return m.compile()


def ordered(lm, names):
    """A, B with states in the given order (whatever order the compiler chose)."""
    k = [lm.state_names.index(n) for n in names]
    return lm.A[np.ix_(k, k)], lm.B[k, :]


def test_mass_spring_damper_A_and_B():
    cm = msd()
    lm = linearize(cm)
    assert isinstance(lm, LinearModel)
    assert set(lm.state_names) == {"mass.s", "mass.v"} and lm.input_names == ("force.f",)
    A, B = ordered(lm, ["mass.s", "mass.v"])
    # linear model: the Jacobians are exact up to rounding, 1e-12
    np.testing.assert_allclose(A, [[0.0, 1.0], [-C / M, -D / M]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(B, [[0.0], [1.0 / M]], rtol=0, atol=1e-12)
    # default outputs are the states: C = I, D = 0 (exact)
    np.testing.assert_array_equal(lm.C, np.eye(2))
    np.testing.assert_array_equal(lm.D, np.zeros((2, 1)))
    # eigenvalues of m s² + d s + c = 0, 1e-12 relative
    expected = np.roots([M, D, C])
    np.testing.assert_allclose(np.sort_complex(lm.eigenvalues()), np.sort_complex(expected), rtol=1e-12)


def test_mass_spring_damper_without_input_and_method_on_compiled_model():
    cm = msd(force_input=False)
    lm = cm.linearize({"mass.s": 0.0, "mass.v": 0.0})
    A, B = ordered(lm, ["mass.s", "mass.v"])
    np.testing.assert_allclose(A, [[0.0, 1.0], [-C / M, -D / M]], rtol=0, atol=1e-12)  # exact up to rounding
    assert B.shape == (2, 0) and lm.D.shape == (2, 0)


def test_rotational_oscillator_A():
    J, c, d = 0.1, 100.0, 0.4
    m = mn.Model("rot")
    fixed = m.add(rot.Fixed(name="fixed"))
    sd = m.add(rot.SpringDamper(name="sd", c=c, d=d))
    j1 = m.add(rot.Inertia(name="j1", J=J, phi_start=0.5))
    tq = m.add(rot.Torque(name="tq"))
    m.connect(fixed.flange, sd.flange_a)
    m.connect(sd.flange_b, j1.flange_a)
    m.connect(tq.flange, j1.flange_b)
    lm = m.compile().linearize()
    A, B = ordered(lm, ["j1.phi", "j1.w"])
    np.testing.assert_allclose(A, [[0.0, 1.0], [-c / J, -d / J]], rtol=0, atol=1e-12)   # exact up to rounding
    np.testing.assert_allclose(B, [[0.0], [1.0 / J]], rtol=0, atol=1e-12)


def test_outputs_rows_C_and_D():
    cm = msd()
    lm = linearize(cm, {"mass.s": 0.2, "mass.v": 0.0}, {"force.f": 1.0}, outputs=["spring.f", "mass.a"])
    k = [lm.state_names.index(n) for n in ("mass.s", "mass.v")]
    # spring.f = c·s; mass.a = (−c s − d v + F)/m: exact up to rounding, 1e-12
    np.testing.assert_allclose(lm.C[:, k], [[C, 0.0], [-C / M, -D / M]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(lm.D, [[0.0], [1.0 / M]], rtol=0, atol=1e-12)
    assert lm.y_op["spring.f"] == pytest.approx(C * 0.2, abs=1e-12)
    assert lm.u_op == {"force.f": 1.0}


@pytest.mark.parametrize("theta0", [0.5, 0.0])
def test_cartesian_pendulum_lower_equilibrium(theta0):
    """Index 3 → states (x, vx), algebraic y. At θ = 0 (x = 0, y = −L) ∂alg/∂y = 2y ≠ 0, so the
    selection compiled at θ0 = 0.5 is fine there: linearise the same compiled model at θ = 0."""
    g, L = 9.81, 1.0
    cm = cartesian_pendulum(theta0=theta0, L=L).compile()
    assert not cm.dae.is_ode and len(cm.state_names) == 2 and len(cm.algebraic_names) == 1
    lm = cm.linearize({n: 0.0 for n in cm.state_names})
    # the algebraic variable is on the lower branch: y = −L (Newton from the guess), 1e-12
    for name, value in lm.z_op.items():
        if name == "p.y":
            assert value == pytest.approx(-L, abs=1e-12)
    eig = np.sort_complex(lm.eigenvalues())
    # ±i√(g/L), 1e-8 absolute (the z elimination is exact; only rounding remains)
    np.testing.assert_allclose(eig, [-1j * math.sqrt(g / L), 1j * math.sqrt(g / L)], rtol=0, atol=1e-8)


def test_pendulum_singular_dependent_block_is_reported():
    cm = cartesian_pendulum(theta0=0.5).compile()
    if cm.state_names != ("p.x", "p.vx"):
        pytest.skip("another state selection")
    with pytest.raises(mn.InitializationError, match="not determined by the states"):
        cm.linearize({"p.x": 1.0, "p.vx": 0.0})     # y = 0: ∂alg/∂y = 2y singular


def test_linearize_from_result_and_trim_point():
    cm = cartesian_pendulum(theta0=0.3).compile()
    res = cm.simulate(0.5, n_out=11)
    lm = cm.linearize(res)
    assert lm.t == pytest.approx(0.5)
    for n in cm.state_names:
        assert lm.x_op[n] == res.final_state[n]
    tp = cm.trim()
    assert isinstance(tp, TrimPoint)
    lm0 = cm.linearize(tp)
    # trim found the lower equilibrium: ±i√g, 1e-8
    np.testing.assert_allclose(np.sort_complex(lm0.eigenvalues()), [-1j * math.sqrt(9.81), 1j * math.sqrt(9.81)],
                               rtol=0, atol=1e-8)


def test_trim_loaded_spring_static_deflection():
    F = 7.5
    cm = msd(force_input=False, constant_force=F)
    tp = trim(cm)
    # linear equations: Newton is exact in one step up to rounding, 1e-10
    assert tp.x["mass.s"] == pytest.approx(F / C, abs=1e-10)
    assert tp.x["mass.v"] == pytest.approx(0.0, abs=1e-10)
    assert tp.residual < 1e-10


def test_trim_with_input_value():
    cm = msd()
    tp = cm.trim(inputs={"force.f": 4.0})
    assert tp.x["mass.s"] == pytest.approx(4.0 / C, abs=1e-10)   # static deflection, 1e-10
    assert tp.u == {"force.f": 4.0}


def test_trim_free_input_holds_position():
    cm = msd()
    tp = cm.trim(fixed={"mass.s": 0.1}, free_inputs=["force.f"])
    # the force that holds the mass at s = 0.1 is c·0.1, 1e-10
    assert tp.u["force.f"] == pytest.approx(C * 0.1, abs=1e-10)
    assert tp.x["mass.s"] == pytest.approx(0.1, abs=1e-12)


def test_trim_counts_must_match():
    cm = msd()
    with pytest.raises(mn.InitializationError, match=r"1 fixed value.*0 free input"):
        cm.trim(fixed={"mass.s": 0.1})
    with pytest.raises(mn.InitializationError, match=r"0 fixed value.*1 free input"):
        cm.trim(free_inputs=["force.f"])


def test_trim_without_steady_state_names_the_residual():
    m = mn.Model("spin")
    fixed = m.add(rot.Fixed(name="fixed"))
    damper = m.add(rot.Damper(name="damper", d=0.5))
    j = m.add(rot.Inertia(name="j", J=2.0))
    torque = m.add(rot.ConstantTorque(name="torque", tau_constant=1.0))
    m.connect(fixed.flange, damper.flange_a)
    m.connect(damper.flange_b, j.flange_a)
    m.connect(torque.flange, j.flange_b)
    with pytest.raises(mn.InitializationError, match=r"largest residual .* in der\(j\.(w|phi)\)"):
        m.compile().trim()


def test_unknown_names():
    cm = msd()
    with pytest.raises(mn.UnknownNameError, match="mass.q"):
        linearize(cm, {"mass.q": 0.0})
    with pytest.raises(mn.UnknownNameError, match="not a state"):
        linearize(cm, {"spring.f": 0.0})
    with pytest.raises(mn.UnknownNameError):
        linearize(cm, u_op={"force.g": 1.0})
    with pytest.raises(mn.UnknownNameError):
        linearize(cm, outputs=["spring.nope"])
    with pytest.raises(mn.UnknownNameError):
        cm.trim(fixed={"mass.q": 0.1}, free_inputs=["force.f"])
    with pytest.raises(mn.UnknownNameError):
        cm.trim(inputs={"force.g": 1.0})
