"""The tree pass builds a planar chain's orientations from angle sums (tree_turns.Turn):
checked against forward kinematics written here with numpy, and against joints it must not trust."""
import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components.multibody.frames import axis_rotation
from mechnet.kinematics import kinematics


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _mixed_chain():
    """World — j1 (about z) — 1 m — fixed turn 0.7 rad about z — j2 (about −z) — (0.5, 0.2) — slider s
    along x — j3 (about z, mounted backwards: its frame_b towards the world) — 0.3 m — particle p; a
    particle on every other link too."""
    m = mn.Model("chain")
    parts = [m.add(mb.World(name="world")),
             m.add(mb.Revolute(name="j1", n=[0, 0, 1])),
             m.add(mb.FixedTranslation(name="t1", r=[1.0, 0.0, 0.0])),
             m.add(mb.FixedRotation(name="turn", n=[0, 0, 1], angle=0.7)),
             m.add(mb.Revolute(name="j2", n=[0, 0, -1])),
             m.add(mb.FixedTranslation(name="t2", r=[0.5, 0.2, 0.0])),
             m.add(mb.Prismatic(name="s", n=[1, 0, 0])),
             m.add(mb.Revolute(name="j3", n=[0, 0, 1])),
             m.add(mb.FixedTranslation(name="t3", r=[0.3, 0.0, 0.0])),
             m.add(mb.Particle(name="p", m=1.0))]
    world, j1, t1, turn, j2, t2, s, j3, t3, p = parts
    for a, b in [(world.frame_b, j1.frame_a), (j1.frame_b, t1.frame_a), (t1.frame_b, turn.frame_a),
                 (turn.frame_b, j2.frame_a), (j2.frame_b, t2.frame_a), (t2.frame_b, s.frame_a),
                 (s.frame_b, j3.frame_b), (j3.frame_a, t3.frame_a), (t3.frame_b, p.frame_a)]:
        m.connect(a, b)
    for k, frame in enumerate((t1.frame_b, t2.frame_b, s.frame_b)):      # a mass on every moving link
        m.connect(frame, m.add(mb.Particle(name=f"mass{k}", m=1.0)).frame_a)
    return m


def test_a_planar_chain_with_reversed_and_fixed_turns_matches_forward_kinematics():
    """Positions, orientations and angular velocity of the particle at 5 random (q, q̇), against the
    chain multiplied out with numpy: equal to 1e-13 (unit lengths, angles up to π)."""
    cm = _mixed_chain().compile()
    rng = np.random.default_rng(7)
    for _ in range(5):
        q1, q2, q3 = rng.uniform(-np.pi, np.pi, 3)
        s = rng.uniform(-1, 1)
        w1, w2, w3 = rng.uniform(-2, 2, 3)
        k = kinematics(cm, q={"j1": q1, "j2": q2, "s": s, "j3": q3},
                       qd={"j1": w1, "j2": w2, "s": 0.4, "j3": w3})["p.frame_a"]
        R = _rz(q1)
        r = R @ [1.0, 0.0, 0.0]
        R = R @ _rz(0.7) @ _rz(-q2)
        r = r + R @ [0.5, 0.2, 0.0] + R @ [s, 0.0, 0.0]
        R = R @ _rz(q3).T                    # j3 backwards: frame_a = frame_b turned back by q3
        r = r + R @ [0.3, 0.0, 0.0]
        np.testing.assert_allclose(k["r_0"], r, rtol=0, atol=1e-13)
        np.testing.assert_allclose(k["R"], R, rtol=0, atol=1e-13)
        np.testing.assert_allclose(k["w_0"], [0.0, 0.0, w1 - w2 - w3], rtol=0, atol=1e-13)


class _OffsetRevolute(mb.Revolute):
    """A revolute about z whose zero is turned by 0.5 rad: frame_b = Rz(phi + 0.5) in frame_a."""

    def relative_motion(self):
        return ca.SX.zeros(3), axis_rotation(ca.DM([0, 0, 1]), self.phi + 0.5)


def test_a_joint_that_turns_by_more_than_its_coordinate_keeps_its_own_rotation():
    """Its motion axes say 'about z by phi', its relative rotation says phi + 0.5: the pass must use the
    rotation (a sum phi alone put the link at (1, 0, 0) at phi = 0, instead of (cos 0.5, sin 0.5, 0))."""
    m = mn.Model("offset")
    world = m.add(mb.World(name="world"))
    j = m.add(_OffsetRevolute(name="j", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
    t = m.add(mb.FixedTranslation(name="t", r=[1.0, 0.0, 0.0]))
    p = m.add(mb.Particle(name="p", m=1.0))
    m.connect(world.frame_b, j.frame_a)
    m.connect(j.frame_b, t.frame_a)
    m.connect(t.frame_b, p.frame_a)
    for phi in (0.0, 1.2):
        r = kinematics(m.compile(), q={"j": phi})["p.frame_a"]["r_0"]
        np.testing.assert_allclose(r, [np.cos(phi + 0.5), np.sin(phi + 0.5), 0.0], rtol=0, atol=1e-14)


def _rot(n, a):
    n = np.asarray(n, dtype=float) / np.linalg.norm(n)
    K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def _plane_chain(mount, axis):
    """World — fixed rotation `mount` (axis, angle) — three revolutes about `axis` with links of
    (0.7, 0.2, 0) between them — particle. Returns the model and its numpy forward kinematics."""
    m = mn.Model("plane")
    world = m.add(mb.World(name="world"))
    tilt = m.add(mb.FixedRotation(name="tilt", n=list(mount[0]), angle=mount[1]))
    m.connect(world.frame_b, tilt.frame_a)
    last = tilt.frame_b
    for k in range(3):
        j = m.add(mb.Revolute(name=f"j{k}", n=list(axis)))
        link = m.add(mb.FixedTranslation(name=f"l{k}", r=[0.7, 0.2, 0.0]))
        m.connect(last, j.frame_a)
        m.connect(j.frame_b, link.frame_a)
        m.connect(link.frame_b, m.add(mb.Particle(name=f"p{k}", m=1.0)).frame_a)
        last = link.frame_b

    def forward(q):
        R, r = _rot(*mount), np.zeros(3)
        for qk in q:
            R = R @ _rot(axis, qk)
            r = r + R @ [0.7, 0.2, 0.0]
        return r, R
    return m, forward



@pytest.mark.parametrize("mount, axis", [(((1, 0, 0), 0.0), (0, 1, 0)),          # revolutes about world y
                                         (((1, 0, 0), np.pi / 2), (0, 0, 1)),    # a vertical plane by a mount
                                         (((1, 1, 1), 0.7), (0, 0, 1)),          # an oblique plane
                                         (((0, 0, 1), 0.4), (1, 2, 2)),          # an oblique axis, no mount
                                         (((1, 0, 0), 0.0), (1e-7, 0, 1)),       # 1e-7 off z (arccos loses it)
                                         (((1, 0, 0), 0.0), (3e-9, 0, -1))])     # 3e-9 off −z
def test_a_planar_chain_about_any_fixed_axis_matches_forward_kinematics(mount, axis):
    """The angle sums hold for rotations about any one fixed axis (tree_turns.Turn): positions and
    orientations of the last particle at 5 random q against numpy, to 1e-13 (lengths < 1 m)."""
    m, forward = _plane_chain(mount, axis)
    cm = m.compile()
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, 3)
        k = kinematics(cm, q={f"j{i}": q[i] for i in range(3)})["p2.frame_a"]
        r, R = forward(q)
        np.testing.assert_allclose(k["r_0"], r, rtol=0, atol=1e-13)
        np.testing.assert_allclose(k["R"], R, rtol=0, atol=1e-13)


def test_a_joint_axis_slightly_off_the_planes_axis_breaks_the_angle_sum():
    """A revolute about z, then one whose axis leans 1e-6 rad off z: no longer one fixed axis. The pass
    must multiply the rotations (a test on 1 − cos(tilt) took the lean for z and misplaced the last
    frame by 2e-6); numpy forward kinematics to 1e-13."""
    m = mn.Model("lean")
    world = m.add(mb.World(name="world"))
    j0 = m.add(mb.Revolute(name="j0", n=[0, 0, 1]))
    l0 = m.add(mb.FixedTranslation(name="l0", r=[0.7, 0.2, 0.0]))
    j1 = m.add(mb.Revolute(name="j1", n=[1e-6, 0, 1]))
    l1 = m.add(mb.FixedTranslation(name="l1", r=[0.7, 0.2, 0.0]))
    for a, b in [(world.frame_b, j0.frame_a), (j0.frame_b, l0.frame_a), (l0.frame_b, j1.frame_a),
                 (j1.frame_b, l1.frame_a)]:
        m.connect(a, b)
    for k, frame in enumerate((l0.frame_b, l1.frame_b)):
        m.connect(frame, m.add(mb.Particle(name=f"p{k}", m=1.0)).frame_a)
    cm = m.compile()
    for q0, q1 in [(0.4, 2.9), (-1.3, -2.2)]:
        k = kinematics(cm, q={"j0": q0, "j1": q1})["p1.frame_a"]
        R0 = _rot((0, 0, 1), q0)
        R1 = R0 @ _rot((1e-6, 0, 1), q1)
        np.testing.assert_allclose(k["R"], R1, rtol=0, atol=1e-13)
        np.testing.assert_allclose(k["r_0"], R0 @ [0.7, 0.2, 0.0] + R1 @ [0.7, 0.2, 0.0], rtol=0, atol=1e-13)
