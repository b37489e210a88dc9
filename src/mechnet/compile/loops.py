"""Kinematic loops (part of the tree pass): cut edges, their closure residuals, and redundancy.

The spanning tree leaves some tree edges (joints, rigid connections) out; each
of them closes a kinematic loop. Such a *cut edge* takes no part in the
articulated-body recursion. It acts like a force element whose cut forces
load the tree, and it adds equations of its own:

- six closure residuals: the relative position in the axes of the loop's
  root (`loop_root`, where the tree paths to the cut's two frames meet),
  R_cᵀ(r_b − r_a − R_a r_rel(q)), or in constant axes (the world's, a plane's)
  when the root does not turn or every rotation down to the cut is about one
  fixed axis; and the relative rotation M = R_rel(q)ᵀ R_aᵀ R_b as three angles
  atan2(skew part, trace part), about frame_a's axes turned so that a revolute
  cut's pin is their z (B, `closure`'s `turn`). The angles are exact for a
  rotation about one of those axes and vanish only at M = 1, so there is no
  second branch at π. The
  root's axes move with the whole loop, so a planar loop's normal stays a
  constant direction there even on a turning base, and on the ground they are
  the world's. Index reduction differentiates the position twice: resolved in
  frame_a it carried frame_a's rotation through both derivatives (a
  slider-crank's acceleration rows took 118 instructions each, its ODE 478; in
  world axes 347, and the piston position is solved explicitly);
- the balance of the massless edge: forces in world axes, R_a f_a + R_b f_b = 0
  (R_a f_a pairs with the world-axes position residual), torques in frame_a's,
  t_a + R_aᵀ(R_b t_b + (r_b − r_a) × R_b f_b) = 0. There frame_a's cut torque has
  coefficient 1 and is solved explicitly; in world axes its coefficient was R_a,
  and a slider-crank's two zero out-of-plane torques were torn into the
  integrator's unknowns;
- for a joint, its drive: s_linᵀ f_a − s_angᵀ t_b = axis load (Modelica's
  tau = −n·frame_b.t, f = −n·frame_b.f).

The constraint wrench λ = (R_cᵀR_a f_a, −B t_b) pairs with the residuals by virtual work
(on the constraint manifold, λᵀ d(res)/dt is the power of the constraint
forces). A planar loop of parallel revolutes has three residual directions
that stay constant whatever the coordinates. They are found as the common
left null space of the residual Jacobian at random coordinates (the start
point may be singular) and dropped, and the matching wrench components are set
to zero. A non-zero constant means the loop cannot close. Any other rank loss
means genuinely redundant spatial constraints. Both are errors naming the
joints.

The loop's cost is this small system on top of the O(N) tree: Pantelides
differentiates the kept residuals, dummy derivatives pick the states, and the
dependent coordinates are solved from the residuals themselves (no drift).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..components.multibody.frames import exact
from ..core.errors import StructureError
from .artifacts import FlatEquation

_AXES = ("x", "y", "z")
_DIRECTIONS = tuple(f"position {a}" for a in _AXES) + tuple(f"rotation about {a}" for a in _AXES)


@dataclass(frozen=True)
class Loop:
    """One closed loop: the edge that closes it, the joints around it, and what was dropped."""

    number: int
    cut: str                 # path of the cut edge
    joints: tuple            # paths of the edges with freedoms around the loop (the cut last)
    kept: int                # closure residuals kept
    dropped: tuple           # names of the constant residual directions that were dropped

    def describe(self) -> str:
        return f"loop {self.number} (closed by {self.cut}; joints {', '.join(self.joints)})"

    def summary(self) -> str:
        note = (f"; {len(self.dropped)} redundant constraint(s) dropped ({', '.join(self.dropped)}, "
                f"constant: a planar loop)" if self.dropped else "")
        return f"{self.describe()}: {self.kept} closure constraint(s){note}"


def tree_path(parent, n):
    """[(node, edge)] from node n up to the root."""
    out = []
    while parent[n] is not None:
        e, _, p = parent[n]
        out.append((n, e))
        n = p
    return out


def loop_root(parent, na, nb):
    """The node where the tree paths from na and nb meet: the loop's part that carries the rest."""
    above_a = {na} | {parent[n][2] for n, _ in tree_path(parent, na)}
    n = nb
    while n not in above_a:
        n = parent[n][2]
    return n


def loop_edges(parent, na, nb):
    """The tree edges between nodes na and nb (through their nearest common ancestor)."""
    pa, pb = tree_path(parent, na), tree_path(parent, nb)
    common = {n for n, _ in pa} & {n for n, _ in pb}
    return [e for n, e in pa if n not in common] + [e for n, e in reversed(pb) if n not in common]


def _angles(M):
    """Three rotation angles of M ≈ 1 (about x, y, z of its own axes): exact for a rotation about one axis."""
    return ca.vertcat(ca.atan2(M[2, 1] - M[1, 2], M[1, 1] + M[2, 2]),
                      ca.atan2(M[0, 2] - M[2, 0], M[0, 0] + M[2, 2]),
                      ca.atan2(M[1, 0] - M[0, 1], M[0, 0] + M[1, 1]))


def closure(e, ka, kb, axes=None, turn=None):
    """(residuals, wrench λ, balance, drive or None) of the cut edge e between frames with kinematics ka,
    kb; the position resolved in the axes with orientation `axes` (the loop's root, `loop_root`, or a
    constant frame), or the world's (None). `turn`: a constant rotation B taking the loop's common joint
    axis, in frame_a's axes, onto z (a planar loop about an oblique axis): the three angles are taken
    about B's axes, where a turn about that axis is exactly (0, 0, θ) and the out-of-plane angles stay
    constant; about frame_a's own axes they do not, and the loop was refused as over-constrained."""
    r_rel, R_rel = e.relative_motion()
    r_rel, R_rel = ca.SX(r_rel), ca.SX(R_rel)
    d = kb.r - ka.r
    B = ca.DM(np.eye(3) if turn is None else turn)

    def to_root(v):
        return v if axes is None else ca.mtimes(axes.T, v)
    a_axes = to_root(ka.R)                     # frame_a's axes in the residual's
    residuals = ca.vertcat(to_root(d) - ca.mtimes(a_axes, r_rel),
                           _angles(ca.mtimes(B, ca.mtimes(ca.mtimes(R_rel.T, ca.mtimes(ka.R.T, kb.R)), B.T))))
    f_a, t_a = e.frame_a._values["f"], e.frame_a._values["t"]
    f_b, t_b = e.frame_b._values["f"], e.frame_b._values["t"]
    fb_0 = ca.mtimes(kb.R, f_b)
    balance = ca.vertcat(ca.mtimes(ka.R, f_a) + fb_0,
                         t_a + ca.mtimes(ka.R.T, ca.mtimes(kb.R, t_b) + ca.cross(d, fb_0)))
    drive = None
    if e.dof:
        s_ang, s_lin = e.motion_axes()
        drive = ca.dot(ca.SX(s_lin), f_a) - ca.dot(ca.SX(s_ang), t_b) - e.axis_load()
    return residuals, ca.vertcat(ca.mtimes(a_axes, f_a), -ca.mtimes(B, t_b)), balance, drive


def _split(P):
    """Orthonormal bases of the range of a projector P (6×6) and of its complement, axis-aligned when P is."""
    from scipy.linalg import qr

    def basis(A):
        k = int(round(np.trace(A)))
        if k == 0:
            return np.zeros((6, 0))
        q, _, _ = qr(exact(A), pivoting=True)
        q = exact(q[:, :k])
        return q * np.where(q[np.argmax(np.abs(q), axis=0), range(k)] < 0, -1.0, 1.0)

    P = exact(P)
    return basis(np.eye(6) - P), basis(P)


def reduce_redundancy(cuts, residuals, coordinates, let, tunables, parent_describe, position_axes):
    """For each cut edge, the bases (kept K, dropped N) of its residual directions, decided from the
    Jacobian at random coordinates; errors for loops that cannot close or are redundant in 3D."""
    q = ca.vertcat(*coordinates)
    p = ca.vertcat(*[sym for sym, _ in tunables]) if tunables else ca.SX(0, 1)
    stacked = ca.vertcat(*residuals)
    _, (stacked,) = ca.substitute_inplace(let[0], let[1], [stacked], False)
    fn = ca.Function("closure", [q, p], [stacked, ca.jacobian(stacked, q)])
    rng = np.random.default_rng(20261123)
    pvals = [v for _, v in tunables]
    points = [fn(rng.uniform(-np.pi, np.pi, q.numel()), pvals) for _ in range(3)]
    values = [np.asarray(v, dtype=float).ravel() for v, _ in points]
    jacs = [np.asarray(J, dtype=float) for _, J in points]
    bases, kept_rows = [], []
    for k, e in enumerate(cuts):
        rows = slice(6 * k, 6 * k + 6)
        Js = np.hstack([J[rows] for J in jacs])
        L = max(np.max(np.abs([v[rows][:3] for v in values])), np.max(np.abs(Js[:3])), 1e-300)
        scale = np.diag([1 / L] * 3 + [1.0] * 3)
        U, s, _ = np.linalg.svd(scale @ Js)
        s = np.concatenate([s, np.zeros(6 - len(s))])
        null = U[:, s <= 1e-9 * max(s[0], 1e-300)]
        N = scale @ null                                   # left null space of Js itself
        P = N @ np.linalg.pinv(N) if N.shape[1] else np.zeros((6, 6))
        K, N = _split(P)
        for j in range(N.shape[1]):
            c = [float(N[:, j] @ v[rows]) for v in values]
            tol = 1e-9 * (L * np.linalg.norm(N[:3, j]) + np.linalg.norm(N[3:, j]))
            if max(abs(x - c[0]) for x in c) > tol:
                continue          # not constant: a coincidence of the samples, left to the rank check
            if abs(c[0]) > tol:
                raise StructureError(
                    f"{parent_describe(k)} cannot close: the closure residual of {e.path} "
                    f"({type(e).__name__}) along {direction(N[:, j], *position_axes[k])} is the constant {c[0]:.6g} "
                    f"whatever the joint coordinates (axes not parallel, or link offsets along the "
                    f"common axis that do not add up); fix the geometry of the joints around the loop")
        bases.append((K, N))
        kept_rows.append(np.vstack([K.T @ J[rows] for J in jacs[:1]]))
    if kept_rows:
        A = np.vstack(kept_rows)
        norms = np.maximum(np.linalg.norm(A, axis=1, keepdims=True), 1e-300)
        rank = np.linalg.matrix_rank(A / norms, tol=1e-9)
        if rank < A.shape[0]:
            names = ", ".join(parent_describe(k) for k in range(len(cuts)))
            raise StructureError(
                f"over-constrained kinematic loop(s): {names} impose {A.shape[0]} closure constraints of "
                f"which only {rank} are independent, and the redundant ones are not a planar loop's constant "
                f"out-of-plane directions; replace one joint of the loop by a joint with fewer constraints "
                f"(e.g. a weld by a joint, or a revolute by a revolute and a prismatic along its axis), or open the loop")
    return bases


def direction(n, position_axes="world axes", rotation_axes="frame_a axes"):
    """A residual direction in words: 'position z (world axes)', or a combination with its axes named once
    (positions are resolved in the loop root's axes, `position_axes`; rotations in frame_a's)."""
    n = exact(np.asarray(n, dtype=float))
    hits = [k for k in range(6) if n[k] != 0]
    kinds = [(kind, where) for kind, where, present in
             (("position", position_axes, any(k < 3 for k in hits)), ("rotation", rotation_axes, any(k >= 3 for k in hits)))
             if present]
    axes = kinds[0][1] if len(kinds) == 1 else ", ".join(f"{kind}: {where}" for kind, where in kinds)
    if len(hits) == 1:
        return f"{_DIRECTIONS[hits[0]]} ({axes})"
    terms = []
    for i, k in enumerate(hits):
        sign = (" − " if n[k] < 0 else " + ") if i else ("-" if n[k] < 0 else "")
        terms.append(f"{sign}{abs(n[k]):.3g}·{_DIRECTIONS[k]}")
    return f"the combination {''.join(terms)} ({axes})"


def closure_equations(e, loop, residuals, wrench, balance, drive, K, N, position_axes):
    """The cut edge's equations: kept residual combinations, balance, drive, dropped wrench components = 0."""
    label = f"{e.path} ({type(e).__name__}), {loop.describe()}"
    eqs = []
    kept = ca.mtimes(ca.sparsify(ca.DM(K.T)), residuals) if K.shape[1] else ca.SX(0, 1)
    for i in range(kept.numel()):
        eqs.append(FlatEquation(kept[i], e.path, f"{label}, closure residual {direction(K[:, i], *position_axes)}",
                                "loop closure (position level)"))
    for i in range(6):
        eqs.append(FlatEquation(balance[i], e.path, f"{label}, balance[{i}]",
                                "massless cut edge: the wrenches at frame_a and frame_b balance"))
    if drive is not None:
        eqs.append(FlatEquation(drive, e.path, f"{label}, drive", "axis load from the cut wrench"))
    gauge = ca.mtimes(ca.sparsify(ca.DM(N.T)), wrench) if N.shape[1] else ca.SX(0, 1)
    for i in range(gauge.numel()):
        eqs.append(FlatEquation(gauge[i], e.path, f"{label}, dropped constraint {direction(N[:, i], *position_axes)}",
                                "no wrench along a redundant constraint direction"))
    return eqs
