"""Kinematic loops in the tree pass: the closure equations of every cut edge.

The spanning tree leaves one edge out per loop; its two frames must meet. Which axes the closure is
resolved in decides whether a planar loop's residual stays free of the loop's own rotation; the
residuals, the redundancy analysis and the equations themselves come from `loops.py`.
"""
from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np

from .loops import Loop, closure, closure_equations, direction, loop_edges, loop_root, reduce_redundancy
from .tree_mass import check_loop_mass
from .tree_turns import motion_axes, onto_z


def loop_axes(t, e):
    """(R, name) of the axes that resolve the closure position of cut edge e; R None for the world's.
    - a root (`loop_root`) that does not turn: the world's, or the root's own if it is tilted (a
      constant rotation; the dropped directions then read 'position z');
    - a turning root, every rotation down to the cut's frames about one fixed axis (Turn): the
      constant axes A of that turn, whose z is the plane's normal (the world's when A = 1);
    - else the root's own: it turns with the whole loop.
    Constant axes keep the root's rotation out of the residual's two time derivatives."""
    na, nb = t.node_of[e.frame_a], t.node_of[e.frame_b]
    root = loop_root(t.parent, na, nb)
    label = t.members[root][0].label
    R = ca.SX(t.kin[root].R)
    if R.is_constant():
        fixed = np.asarray(ca.evalf(R).full())
        return (None, "world axes") if np.array_equal(fixed, np.eye(3)) else (R, f"axes of {label}")
    ta, tb = t.turn.get(na), t.turn.get(nb)
    if ta is not None and tb is not None and np.array_equal(ta.A, tb.A):
        return (None, "world axes") if np.array_equal(ta.A, np.eye(3)) else \
            (ca.DM(ta.A), f"axes of the plane {label} turns in")
    return R, f"axes of {label}"


def loop_turn(e):
    """A constant B taking a revolute cut's axis (in its frame_a) onto z, when that axis is not ±z:
    the closure's angles are then taken about B's axes (`closure`), where a turn about the axis is
    exactly (0, 0, θ); None otherwise. Any constant B leaves the residual zero only at closure."""
    if e.dof != 1:
        return None
    n, s_lin = motion_axes(e)
    if np.any(s_lin) or not np.any(n) or not (n[0] or n[1]):
        return None
    return onto_z(n / np.linalg.norm(n))


def close_loops(t, tree):
    """Each cut edge: closure residuals (redundant planar directions dropped), balance, drive."""
    if not t.cuts:
        return
    frames = [loop_axes(t, e) for e in t.cuts]
    turns = [loop_turn(e) for e in t.cuts]
    parts = [closure(e, t.kin[t.node_of[e.frame_a]], t.kin[t.node_of[e.frame_b]], R, B)
             for e, (R, _), B in zip(t.cuts, frames, turns)]
    axes = [(name, "frame_a axes" if B is None else "frame_a axes turned onto the pins' axis")
            for (_, name), B in zip(frames, turns)]
    # residuals are written in the joint coordinates themselves (an expression along the loop's
    # tree path): index reduction must see which coordinates they constrain
    _, expanded = ca.substitute_inplace(t.let_symbols, t.let_values, [p[0] for p in parts], False)
    parts = [(r,) + p[1:] for r, p in zip(expanded, parts)]
    loops = []
    for k, e in enumerate(t.cuts):
        around = loop_edges(t.parent, t.node_of[e.frame_a], t.node_of[e.frame_b])
        loops.append(Loop(k + 1, e.path, tuple(j.path for j in around if j.dof) + (e.path,), 0, ()))
    coordinates = [q for _, q, _ in t.coordinates] + [e.coordinate() for e in t.cuts if e.dof]
    tunables = [(sym, value) for c in t.components for sym, value in c.tunable.values()]
    bases = reduce_redundancy(t.cuts, [r for r, _, _, _ in parts], coordinates,
                              (t.let_symbols, t.let_values), tunables, lambda k: loops[k].describe(), axes)
    check_loop_mass(t, [ca.mtimes(ca.DM(K.T), r) for (r, _, _, _), (K, _) in zip(parts, bases) if K.shape[1]],
                    coordinates)
    for k, (e, (res, wrench, balance, drive), (K, N)) in enumerate(zip(t.cuts, parts, bases)):
        loop = replace(loops[k], kept=K.shape[1],
                       dropped=tuple(direction(N[:, j], *axes[k]) for j in range(N.shape[1])))
        tree.loops.append(loop)
        tree.equations.extend(closure_equations(e, loop, res, wrench, balance, drive, K, N, axes[k]))
