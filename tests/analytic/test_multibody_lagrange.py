"""Spatial trees against an independently derived reference: Lagrange's equations.

The reference builds the kinetic and potential energy from its own forward
kinematics (rotation matrices composed with SciPy-free Rodrigues formulas in
CasADi) and gets q̈ = M⁻¹(∂L/∂q − ∂²T/∂q̇∂q · q̇ + Q) by automatic
differentiation; mechnet's compiled right-hand side must agree at random
states. rtol/atol do not enter (no integration): the bound is round-off,
1e-9 relative to the largest acceleration.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb

G = np.array([0.0, -9.81, 0.0])


def rot(n, angle):
    n = np.asarray(n, dtype=float) / np.linalg.norm(n)
    K = ca.DM([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return ca.SX.eye(3) + ca.sin(angle) * K + (1 - ca.cos(angle)) * ca.mtimes(K, K)


def random_inertia(rng):
    A = rng.normal(size=(3, 3))
    Q, _ = np.linalg.qr(A)
    moments = np.sort(rng.uniform(0.2, 1.0, size=3))
    moments[2] = min(moments[2], moments[0] + moments[1] - 0.05)     # triangle inequality
    return Q @ np.diag(moments) @ Q.T


def build(rng, reversed_middle: bool, spring: bool):
    """World → Revolute(n1) → FixedRotation → Body1 ... → Prismatic(n2) → Body2 → Revolute(n3) → Body3."""
    axes = [rng.normal(size=3) for _ in range(3)]
    offsets = [rng.normal(size=3) for _ in range(3)]
    cms = [rng.normal(size=3) * 0.3 for _ in range(3)]
    inertias = [random_inertia(rng) for _ in range(3)]
    masses = rng.uniform(0.5, 2.0, size=3)
    rot_axis, rot_angle = rng.normal(size=3), rng.uniform(-1, 1)

    m = mn.Model("tree")
    world = m.add(mb.World(name="world"))
    j1 = m.add(mb.Revolute(name="j1", n=axes[0], phi_start=0, w_start=0))
    fr = m.add(mb.FixedRotation(name="fr", r=offsets[0], n=rot_axis, angle=rot_angle))
    b1 = m.add(mb.Body(name="b1", m=masses[0], r_cm=cms[0], I=inertias[0]))
    j2 = m.add(mb.Prismatic(name="j2", n=axes[1], s_start=0, v_start=0))
    t2 = m.add(mb.FixedTranslation(name="t2", r=offsets[1]))
    b2 = m.add(mb.Body(name="b2", m=masses[1], r_cm=cms[1], I=inertias[1]))
    j3 = m.add(mb.Revolute(name="j3", n=axes[2], phi_start=0, w_start=0))
    t3 = m.add(mb.FixedTranslation(name="t3", r=offsets[2]))
    b3 = m.add(mb.Body(name="b3", m=masses[2], r_cm=cms[2], I=inertias[2]))
    m.connect(world.frame_b, j1.frame_a)
    m.connect(j1.frame_b, fr.frame_a)
    m.connect(fr.frame_b, b1.frame_a)
    if reversed_middle:                      # the prismatic joint is wired backwards: frame_b towards the world
        m.connect(fr.frame_b, j2.frame_b)
        m.connect(j2.frame_a, t2.frame_a)
    else:
        m.connect(fr.frame_b, j2.frame_a)
        m.connect(j2.frame_b, t2.frame_a)
    m.connect(t2.frame_b, b2.frame_a)
    m.connect(t2.frame_b, j3.frame_a)
    m.connect(j3.frame_b, t3.frame_a)
    m.connect(t3.frame_b, b3.frame_a)
    anchor = np.array([0.3, 0.2, -0.4])
    c_s, d_s, s0 = 7.0, 0.8, 0.5
    if spring:
        fix = m.add(mb.FixedTranslation(name="anchor", r=anchor))
        sd = m.add(mb.SpringDamper(name="sd", c=c_s, d=d_s, s_unstretched=s0))
        m.connect(world.frame_b, fix.frame_a)
        m.connect(fix.frame_b, sd.frame_a)
        m.connect(t3.frame_b, sd.frame_b)
    cm = m.compile()

    # --- independent reference -----------------------------------------------------------------------
    q = ca.SX.sym("q", 3)
    qd = ca.SX.sym("qd", 3)
    sign = -1.0 if reversed_middle else 1.0
    R1 = rot(axes[0], q[0])
    p1 = ca.DM.zeros(3)
    R1b = ca.mtimes(R1, rot(rot_axis, rot_angle))
    o1 = p1 + ca.mtimes(R1, ca.DM(offsets[0]))
    n2 = np.asarray(axes[1]) / np.linalg.norm(axes[1])
    o2j = o1 + sign * ca.mtimes(R1b, ca.DM(n2)) * q[1]
    o2 = o2j + ca.mtimes(R1b, ca.DM(offsets[1]))
    R3 = ca.mtimes(R1b, rot(axes[2], q[2]))
    o3 = o2 + ca.mtimes(R3, ca.DM(offsets[2]))
    frames = [(R1b, o1), (R1b, o2), (R3, o3)]
    T, V = 0, 0
    for (R, o), mass, r_cm, I in zip(frames, masses, cms, inertias):
        rc = o + ca.mtimes(R, ca.DM(r_cm))
        vc = ca.jtimes(rc, q, qd)
        Rdot = ca.reshape(ca.jtimes(ca.reshape(R, 9, 1), q, qd), 3, 3)
        W = ca.mtimes(Rdot, R.T)
        w = ca.vertcat(W[2, 1], W[0, 2], W[1, 0])
        T += 0.5 * mass * ca.dot(vc, vc) + 0.5 * ca.dot(w, ca.mtimes(ca.mtimes(R, ca.DM(I)), ca.mtimes(R.T, w)))
        V -= mass * ca.dot(ca.DM(G), rc)
    Q = ca.SX.zeros(3)
    if spring:
        d = o3 - ca.DM(anchor)
        s = ca.norm_2(d)
        V += 0.5 * c_s * (s - s0) ** 2
        sdot = ca.jtimes(s, q, qd)
        Q -= d_s * sdot * ca.gradient(s, q)
    L = T - V
    M = ca.hessian(T, qd)[0]
    rhs = ca.gradient(L, q) - ca.mtimes(ca.jacobian(ca.gradient(T, qd), q), qd) + Q
    qdd = ca.solve(M, rhs)
    ref = ca.Function("ref", [q, qd], [qdd])
    return cm, ref


@pytest.mark.parametrize("reversed_middle", [False, True])
@pytest.mark.parametrize("spring", [False, True])
def test_spatial_tree_matches_lagrange(reversed_middle, spring):
    rng = np.random.default_rng(7 + 2 * reversed_middle + spring)
    cm, ref = build(rng, reversed_middle, spring)
    assert cm.dae.z.numel() == 0, "a tree compiles to an explicit ODE"
    names = list(cm.state_names)
    coords = ["j1.phi", "j2.s", "j3.phi"]
    speeds = ["j1.w", "j2.v", "j3.w"]
    assert sorted(names) == sorted(coords + speeds)
    for _ in range(5):
        qv, qdv = rng.uniform(-1.5, 1.5, 3), rng.uniform(-2, 2, 3)
        x = np.zeros(len(names))
        for k, name in enumerate(coords):
            x[names.index(name)] = qv[k]
        for k, name in enumerate(speeds):
            x[names.index(name)] = qdv[k]
        xdot = np.asarray(cm.dae.ode(0.0, x, [], [], cm.dae.p_value, []), dtype=float).ravel()
        got = np.array([xdot[names.index(n)] for n in speeds])
        want = np.asarray(ref(qv, qdv), dtype=float).ravel()
        assert np.allclose(got, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
        for k, name in enumerate(coords):       # der(q) = q̇
            assert xdot[names.index(name)] == pytest.approx(qdv[k], abs=1e-14)
