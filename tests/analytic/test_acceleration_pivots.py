"""Dividing a joint's acceleration row by its articulated inertia (compile/tearing.py, pivots) only where
that cannot vanish. Two scenes where it could, from a review of the change, against closed-form
accelerations from Lagrange's equations: the compiled right-hand side must stay finite and exact at the
configurations where the inertia of the row alone vanishes or mixes, while the mechanism is regular."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot

L, R, M, J, TAU = 1.0, 0.25, 2.0, 0.1, 1.0


def _rates(cm, values):
    dae = cm.dae
    x = np.array([values.get(n, 0.0) for n in dae.x_names])
    return dict(zip(dae.x_names, np.asarray(dae.ode(0.0, x, np.zeros(dae.z.numel()), [], dae.p_value, [])).ravel()))


def _motor_on_a_massless_link(phi2):
    """A motor (inertia J, torque TAU) turns a massless rod L; at its end a free joint carries a massless
    rod R with a point mass M. The rod's articulated inertia is M·L²·sin²(φ2): zero when the two rods
    line up, where only the motor's inertia determines the acceleration."""
    m = mn.Model("motor_on_massless_link")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    rev1 = m.add(mb.Revolute(name="rev1", n=[0, 0, 1], use_flange=True, phi_start=0.0, w_start=0.0))
    rod1 = m.add(mb.FixedTranslation(name="rod1", r=[L, 0, 0]))
    rev2 = m.add(mb.Revolute(name="rev2", n=[0, 0, 1], phi_start=phi2, w_start=0.0))
    rod2 = m.add(mb.FixedTranslation(name="rod2", r=[R, 0, 0]))
    mass = m.add(mb.Particle(name="mass", m=M))
    fixed = m.add(rot.Fixed(name="fixed"))
    motor = m.add(rot.Inertia(name="motor", J=J))
    torque = m.add(rot.ConstantTorque(name="torque", tau_constant=TAU))
    for a, b in [(world.frame_b, rev1.frame_a), (rev1.frame_b, rod1.frame_a), (rod1.frame_b, rev2.frame_a),
                 (rev2.frame_b, rod2.frame_a), (rod2.frame_b, mass.frame_a), (rev1.support, fixed.flange),
                 (rev1.axis, motor.flange_b), (motor.flange_a, torque.flange)]:
        m.connect(a, b)
    return m.compile()


@pytest.mark.parametrize("phi2", [0.3, 1e-8, 0.0])
def test_a_motor_on_a_massless_link_accelerates_through_the_aligned_position(phi2):
    # At rest, the mass at p = L e(q1) + R e(q1 + q2): M(q) = [J + M(L² + R² + 2LR c), M(R² + LR c);
    # M(R² + LR c), M R²] with c = cos q2, generalised force (TAU, 0). Static evaluation of the compiled
    # right-hand side, scale TAU/J = 10 rad/s²: rtol 1e-12, atol 1e-12 (at q2 = 0: 1/J and −(L+R)/R/J).
    cm = _motor_on_a_massless_link(phi2)
    rates = _rates(cm, {"rev1.phi": 0.0, "rev1.w": 0.0, "rev2.phi": phi2, "rev2.w": 0.0})
    c = np.cos(phi2)
    mass_matrix = np.array([[J + M * (L**2 + R**2 + 2 * L * R * c), M * (R**2 + L * R * c)],
                            [M * (R**2 + L * R * c), M * R**2]])
    qdd = np.linalg.solve(mass_matrix, [TAU, 0.0])
    np.testing.assert_allclose([rates["rev1.w"], rates["rev2.w"]], qdd, rtol=1e-12, atol=1e-12)
    res = cm.simulate(0.2, n_out=3)
    assert res.success, res.failure


def test_two_joints_geared_one_to_one_keep_their_combined_inertia(monkeypatch):
    # rev1 carries a particle m1 = 1 kg at L; rev2 (at that particle) carries M at R; their axis flanges
    # are connected, so q2 = q1 = q (simplification makes both accelerations one variable) and a torque
    # TAU acts on that one degree of freedom: q̈ = TAU / (m1 L² + M(L² + 4R² + 4LR cos q)) at rest. The
    # child's row then holds the variable twice, and its coefficient on it vanishes at q = 2π/3.
    # Static evaluation, scale TAU/(m1 L²): rtol 1e-12, atol 1e-12.
    m = mn.Model("coupled")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    rev1 = m.add(mb.Revolute(name="rev1", n=[0, 0, 1], use_flange=True, phi_start=0.0, w_start=0.0))
    rod1 = m.add(mb.FixedTranslation(name="rod1", r=[L, 0, 0]))
    b1 = m.add(mb.Particle(name="b1", m=1.0))
    rev2 = m.add(mb.Revolute(name="rev2", n=[0, 0, 1], use_flange=True))
    rod2 = m.add(mb.FixedTranslation(name="rod2", r=[R, 0, 0]))
    mass = m.add(mb.Particle(name="mass", m=M))
    f1, f2 = m.add(rot.Fixed(name="f1")), m.add(rot.Fixed(name="f2"))
    torque = m.add(rot.ConstantTorque(name="torque", tau_constant=TAU))
    for a, b in [(world.frame_b, rev1.frame_a), (rev1.frame_b, rod1.frame_a), (rod1.frame_b, b1.frame_a),
                 (rod1.frame_b, rev2.frame_a), (rev2.frame_b, rod2.frame_a), (rod2.frame_b, mass.frame_a),
                 (rev1.support, f1.flange), (rev2.support, f2.flange), (rev1.axis, rev2.axis),
                 (rev1.axis, torque.flange)]:
        m.connect(a, b)
    from mechnet.compile import casadi_dae

    seen = []
    solve_block = casadi_dae.solve_block

    def spy(residuals, variables, symbols, parameter_hashes, guarded=False, pivots=None):
        seen.append({k: symbols[v].name() for k, v in (pivots or {}).items()})
        return solve_block(residuals, variables, symbols, parameter_hashes, guarded, pivots)

    monkeypatch.setattr(casadi_dae, "solve_block", spy)
    cm = m.compile()
    # whether the mixed row would be divided depends on the order tearing meets the rows (a review found
    # 153 of 576 orders dividing by a coefficient that vanishes at 2π/3); the pivot must not be offered
    for pivots in seen:
        assert len(set(pivots.values())) == len(pivots), pivots
    assert sum(len(p) for p in seen) == 1                      # rev1's row only: rev2's holds rev1's too
    for q in (2.0, 2 * np.pi / 3, 2.2):
        rates = _rates(cm, {"rev1.phi": q})
        expected = TAU / (1.0 * L**2 + M * (L**2 + 4 * R**2 + 4 * L * R * np.cos(q)))
        assert rates["rev1.w"] == pytest.approx(expected, rel=1e-12, abs=1e-12)
