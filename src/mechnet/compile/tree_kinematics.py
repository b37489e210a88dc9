"""Kinematics along the spanning tree: every frame's position, orientation and velocities as expressions
of the joint coordinates and speeds, and the bookkeeping of where nodes sit relative to each other.

Nodes joined by rigid edges form one *link*; a joint starts a new one. Orientations of a planar chain
come from angle sums (`tree_turns`). Steps between nodes are kept per edge (`step`, `from_link`) so that
relative positions are sums of steps, never differences of absolute positions (`between`).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..core.errors import StructureError
from .tree_spatial import cross, skew
from .tree_turns import Turn, next_turn


@dataclass
class FrameKinematics:
    """Position, orientation, angular velocity and velocity of a frame origin (world components)."""

    r: ca.SX
    R: ca.SX
    w: ca.SX
    v: ca.SX


def kinematics(t):
    """Positions, orientations and velocities along the tree `t` (a `spanning_tree._Tree`, spanned);
    links are nodes joined by rigid edges."""
    root = t.order[0]
    zero3 = ca.densify(ca.SX.zeros(3))
    t.kin = {root: FrameKinematics(zero3, ca.densify(ca.SX.eye(3)), zero3, zero3)}
    t.link_of = {root: None}              # None: the world link (fixed)
    t.link_nodes = {None: [root]}
    t.joint = {}                          # link -> (joint, S (angular, linear; world axes), forward, parent node)
    t.coordinates = []
    t.turn = turn = {root: Turn(np.eye(3), ca.SX(0.0), np.eye(3))}   # node -> its Turn, or None
    t.step = {root: zero3}                # node -> its position from its parent node, world axes
    t.step_norm2 = {root: 0.0}            # node -> |step|² when a constant, else None
    t.from_link = {root: None}            # node -> its position from its link's first node (None: it is that)
    for n in t.order[1:]:
        e, forward, p = t.parent[n]
        kp = t.kin[p]
        r_rel, R_rel = e.relative_motion()
        same_axes = e.dof == 0 and ca.SX(R_rel).is_eye()      # a pure translation keeps the orientation
        turn[n] = turn[p] if same_axes else next_turn(e, R_rel, turn[p], forward)
        R, step, Ra = _placement(kp, r_rel, R_rel, forward, same_axes, turn[n], turn[p])
        t.step[n] = step
        t.from_link[n] = None if e.dof else (step if t.from_link[p] is None else t.from_link[p] + step)
        # |step|² is |r_rel|² when the step is a rotated constant (a rigid link): a body's inertia
        # about the joint then holds m·L², not m·(L² cos² + L² sin²)
        t.step_norm2[n] = float(ca.sumsqr(ca.DM(r_rel))) if ca.SX(r_rel).is_constant() else None
        r = kp.r + step
        w, v = kp.w, kp.v + cross(kp.w, step)
        if e.dof > 1:                                 # spherical, free: S from both frames' orientations
            if not forward:
                raise StructureError(
                    f"{e.path} ({type(e).__name__}) is walked from frame_b towards the world: connect its "
                    f"frame_a on the world's side (frame_b moves relative to frame_a)")
            R = t.let(R, f"{t.members[n][0].label}.R")
            S = t.let(e.motion_subspace(kp.R, R), f"{e.path}.S")
            qd = e.speed()
            Sv = ca.mtimes(S, qd)
            w, v = w + Sv[:3], v + Sv[3:]
        elif e.dof:
            S = joint_axes(e, Ra, forward)
            qd = e.speed()
            w, v = w + S[:3] * qd, v + S[3:] * qd
        if e.dof:
            t.link_of[n] = e.path
            t.link_nodes[e.path] = [n]
            t.joint[e.path] = (e, S, forward, p)
            t.coordinates.append((e.path, e.coordinate(), qd))
        else:
            t.link_of[n] = t.link_of[p]
            t.link_nodes[t.link_of[p]].append(n)
        name = t.members[n][0].label
        t.kin[n] = FrameKinematics(t.let(r, f"{name}.r_0"), R if same_axes else t.let(R, f"{name}.R"),
                                   w if not e.dof else t.let(w, f"{name}.w_0"), t.let(v, f"{name}.v_0"))
    lengths = [v for v in t.step_norm2.values() if v]
    t.length2 = max(lengths) if lengths else 1.0       # the mechanism's size², m²: scales the pivot check
    _place_bodies_and_loads(t)


def _placement(kp, r_rel, R_rel, forward, same_axes, turn, parent_turn):
    """(R, step, Ra) across one edge: the child node's orientation, its position from the parent node
    (world axes), and the orientation of the edge's frame_a, in which its motion axes are given."""
    if turn is not None and not same_axes:
        # a planar chain: the angles add, and R is built from their sum (Turn)
        R = kp.R if turn is parent_turn else turn.rotation()
        step = ca.mtimes(kp.R, r_rel) if forward else -ca.mtimes(R, r_rel)
        Ra = kp.R if forward else R
    elif same_axes:
        R = kp.R
        step = ca.mtimes(kp.R, r_rel) if forward else -ca.mtimes(kp.R, r_rel)
        Ra = kp.R
    elif forward:
        R = ca.mtimes(kp.R, R_rel)
        step = ca.mtimes(kp.R, r_rel)
        Ra = kp.R
    else:
        R = ca.mtimes(kp.R, R_rel.T)
        step = -ca.mtimes(R, r_rel)
        Ra = R
    return R, step, Ra


def joint_axes(e, Ra, forward):
    """S = (angular, linear): the joint's motion per unit speed in world axes, from the orientation Ra of
    its frame_a; reversed when the tree walks the joint from frame_b to frame_a."""
    s_ang, s_lin = e.motion_axes()
    sign = 1.0 if forward else -1.0
    return sign * ca.vertcat(ca.mtimes(Ra, s_ang), ca.mtimes(Ra, s_lin))


def _place_bodies_and_loads(t):
    """Which bodies and which loading frames (force elements, sensors, cut edges) sit at each node."""
    t.bodies_at = {k: [] for k in range(len(t.members))}
    t.loads_at = {k: [] for k in range(len(t.members))}
    for c in t.frames:
        if isinstance(c.owner, t.PartialBody) and id(c.owner) in t.cut_ids:
            raise StructureError(f"{c.owner.path} ({type(c.owner).__name__}) closes a kinematic loop: a body with "
                                 f"two frames cannot be a loop's cut; close the loop at a joint")
        if isinstance(c.owner, t.PartialBody):
            if c is c.owner.frame_a:                 # a body with two frames (BodyShape) sits at frame_a
                t.bodies_at[t.node_of[c]].append(c.owner)
        elif id(c.owner) in t.cut_ids or not isinstance(c.owner, (t.PartialTreeEdge, t.World)):
            t.loads_at[t.node_of[c]].append(c)        # force elements, sensors, cut edges


# ---- where nodes sit relative to each other ----------------------------------------------------------

def reference(t, link):
    """The kinematics of a link's reference point: its first node."""
    return t.kin[t.link_nodes[link][0]]


def between_norm2(t, n, a):
    """|between(n, a)|² when n is one constant step from a (a rigid link), else None."""
    if n == a:
        return 0.0
    return t.step_norm2.get(n) if t.parent.get(n, (None, None, None))[2] == a else None


def between(t, n, a) -> ca.SX:
    """Position of node n from node a (world axes) built from the edges' steps, not as the difference
    of their absolute positions: r_n − r_a keeps r_a in both terms, which the expression graph does
    not cancel ((x − (−0.5 sin φ)) − x in a cart-pole's ODE). a is n's link's first node (the sum
    kept per node in `from_link`, so a long rigid link costs O(length)) or, for n a link's first node,
    the first node of the link before; anything else falls back on the difference."""
    first = t.link_nodes[t.link_of[n]][0]
    if a == first:
        return t.from_link[n] if t.from_link[n] is not None else ca.densify(ca.SX.zeros(3))
    if n == first and n != t.order[0]:
        p = t.parent[n][2]
        if t.link_nodes[t.link_of[p]][0] == a:
            return t.step[n] if t.from_link[p] is None else t.from_link[p] + t.step[n]
    return t.kin[n].r - t.kin[a].r


def offset(t, link):
    """From the parent link's reference point to this link's, and the parent link."""
    parent_link = t.link_of[t.joint[link][3]]
    return between(t, t.link_nodes[link][0], t.link_nodes[parent_link][0]), parent_link


# ---- what leaves the equation system -------------------------------------------------------------------

def frame_values(t, tree):
    """r_0 and R of every frame become expressions (and their derivatives, where `der` was taken)."""
    from ..components.multibody.frames import to_row_major
    per_node = {}
    for c in t.frames:
        n = t.node_of[c]
        if n not in per_node:
            k = t.kin[n]
            per_node[n] = [(key, ca.vertsplit(value), ca.vertsplit(rate), unit) for key, value, rate, unit in (
                ("r_0", k.r, k.v, "m"),
                ("R", to_row_major(k.R), to_row_major(ca.mtimes(skew(k.w), k.R)), "1"))]
        label = c.label
        for key, values, rates, unit in per_node[n]:
            for i, (sym, val, dot) in enumerate(zip(ca.vertsplit(c._values[key]), values, rates)):
                tree.replaced[sym.element_hash()] = val
                tree.observed.append((f"{label}.{key}[{i}]", sym, unit, val))
                tree.rates[sym.element_hash()] = dot
