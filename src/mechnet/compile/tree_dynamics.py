"""Dynamics along the spanning tree: the articulated-body recursion as local residual equations, and the
cut forces of the tree's components as expressions of the link accelerations.

Inward (leaves → root) the articulated inertia I^A_k (an expression of the joint coordinates) and the
bias wrench p_k (an unknown: the subtree's external loads and axis torques); outward (root → leaves)
the joint acceleration from D_k q̈_k = τ_k − Sᵀ(I^A_k (X A_parent + c_k) + p_k) and the link acceleration
A_k = X A_parent + c_k + S q̈_k. World axes throughout; wrenches are (moment about the link's reference
point, force), accelerations classical (α, a of the reference point). A joint enters only through its
motion axes S, its speed and its axis load.
"""
from __future__ import annotations

import casadi as ca

from ..core.equation import der
from ..core.errors import StructureError
from .loops import loop_edges
from .tree_equations import add_equations, defined
from .tree_kinematics import between, between_norm2, offset, reference
from .tree_spatial import blocks, cross, skew, transport_inertia, transport_wrench


def load(t, fr, n):
    """The wrench a component's frame puts on node n (moment about n, force), world axes."""
    R = t.kin[n].R
    return ca.vertcat(-ca.mtimes(R, fr.t), -ca.mtimes(R, fr.f))


def body_terms(t, body, n, d, d_norm2=None):
    """Spatial inertia about a point at −d from node n, velocity-product wrench, gravity wrench.
    `d_norm2`: |d|² when it is a constant (`between_norm2`)."""
    key = (id(body), d is None)
    if d is None and key in t._body_cache:
        return t._body_cache[key]
    m, r_cm, I = body.mass_properties()
    k = t.kin[n]
    offset_cm = ca.mtimes(k.R, r_cm) if not ca.SX(r_cm).is_zero() else None
    if d is None:
        c = offset_cm if offset_cm is not None else ca.SX.zeros(3)
        norm2 = float(ca.sumsqr(ca.DM(r_cm))) if ca.SX(r_cm).is_constant() else None
    else:
        c = d + offset_cm if offset_cm is not None else d
        norm2 = d_norm2 if offset_cm is None else None
    C = skew(c)
    # -m·C² = m·(|c|² 1 − c cᵀ): with |c|² a known constant the rotation's cos² + sin² never appears
    I_O = m * (norm2 * ca.SX.eye(3) - ca.mtimes(c, c.T)) if norm2 is not None else -m * ca.mtimes(C, C)
    if not ca.SX(I).is_zero():
        I_O = I_O + ca.mtimes(k.R, ca.mtimes(I, k.R.T))
    gravity = m * t.world.gravity_at(k.r + offset_cm if offset_cm is not None else k.r)
    out = (blocks(I_O, m * C, -m * C, m * ca.SX.eye(3)),
           ca.vertcat(cross(k.w, ca.mtimes(I_O, k.w)), m * cross(k.w, cross(k.w, c))),
           ca.vertcat(cross(c, gravity), gravity))
    if d is None:
        t._body_cache[key] = out
    return out


def velocity_terms(t, link):
    """c_k: the acceleration of the link that the joint's motion adds at zero q̈ (Coriolis, centripetal)."""
    if link not in t._velocity_cache:
        e, S, _, _ = t.joint[link]
        d, parent_link = offset(t, link)
        wp = reference(t, parent_link).w
        qd = e.speed()
        Sv = S * qd if e.dof == 1 else ca.mtimes(S, qd)
        c = ca.vertcat(cross(wp, Sv[:3]), cross(wp, cross(wp, d)) + 2 * cross(wp, Sv[3:]))
        # a column of S carried by a frame the joint itself turns (a universal joint's second axis)
        t._velocity_cache[link] = c + e.motion_bias(S, qd) if e.dof > 1 else c
    return t._velocity_cache[link]


def dynamics(t, tree):
    """The recursion's unknowns and equations into `tree`; the link accelerations into `t.A`."""
    moving = [t.link_of[n] for n in t.order[1:] if t.link_nodes.get(t.link_of[n], [None])[0] == n]
    M, bias = _link_terms(t, moving)
    t.A = {None: ca.densify(ca.SX.zeros(6))}
    IA, D, P, massless = _inward(t, tree, moving, M, bias)
    _outward(t, tree, moving, M, IA, D, P, massless)


def _link_terms(t, moving):
    """Each moving link's own spatial inertia and bias wrench (velocity products, gravity, loads) about
    its reference point."""
    M, bias = {}, {}
    for link in moving:
        Mk, bk = ca.SX.zeros(6, 6), ca.SX.zeros(6)
        for n in t.link_nodes[link]:
            d = between(t, n, t.link_nodes[link][0])
            d_norm2 = between_norm2(t, n, t.link_nodes[link][0])
            for body in t.bodies_at[n]:
                Mb, bb, gb = body_terms(t, body, n, d, d_norm2)
                Mk, bk = Mk + Mb, bk + bb - gb
            for fr in t.loads_at[n]:
                bk -= transport_wrench(load(t, fr, n), d)
        M[link], bias[link] = Mk, bk
    return M, bias


def _inward(t, tree, moving, M, bias):
    """Leaves → root: articulated inertia IA, D = SᵀIA·S and bias wrench P of every moving link, and the
    links inside a loop whose joint moves no mass (`massless`). Registers the joints whose D is checked
    numerically (`t._pivots`) and those left to check_loop_mass (`t._unmoved`)."""
    P = {}
    child_links = {link: [] for link in t.link_nodes}
    for link in moving:
        child_links[t.link_of[t.joint[link][3]]].append(link)
    IA, Ia, U, D, D_inv = {}, {}, {}, {}, {}
    massless, inert, reaches_cut = set(), set(), {}
    on_loop = {j.path for e in t.cuts
               for j in loop_edges(t.parent, t.node_of[e.frame_a], t.node_of[e.frame_b])}
    for link in reversed(moving):
        e, S, _, _ = t.joint[link]
        IA_k, p_k = M[link], bias[link]
        reaches_cut[link] = any(id(fr.owner) in t.cut_ids for n in t.link_nodes[link]
                                for fr in t.loads_at[n]) or any(reaches_cut[j] for j in child_links[link])
        for j in child_links[link]:
            dj, _ = offset(t, j)
            if j in massless:                          # passes its loads on: the wrench through its joint
                through = P[j]
                if j in inert:                         # and its inertia, rigidly (its joint moves none)
                    IA_k = IA_k + transport_inertia(Ia[j], dj)
                    through = through + ca.mtimes(Ia[j], velocity_terms(t, j))
                p_k = p_k + transport_wrench(through, dj)
                continue
            ej, Sj, _, _ = t.joint[j]
            if ej.dof == 6:                            # a free joint passes nothing on (S is invertible)
                continue
            if ej.dof > 1:
                u_j = ej.axis_load() - ca.mtimes(Sj.T, P[j])
                if _turns_freely(ej, Sj):            # a ball joint passes no moment, exactly
                    A_inv, B = U[j]
                    through = ca.mtimes(Ia[j], velocity_terms(t, j)) + ca.vertcat(
                        ca.SX.zeros(3), P[j][3:] - ca.mtimes(B.T, ca.mtimes(A_inv, P[j][:3])))
                else:
                    through = ca.mtimes(Ia[j], velocity_terms(t, j)) + P[j] + \
                        ca.mtimes(U[j], ca.mtimes(D_inv[j], u_j))
                IA_k = IA_k + transport_inertia(Ia[j], dj)
                p_k = p_k + transport_wrench(through, dj)
                continue
            u_j = ej.axis_load() - ca.dot(Sj, P[j])
            IA_k = IA_k + transport_inertia(Ia[j], dj)
            p_k = p_k + transport_wrench(ca.mtimes(Ia[j], velocity_terms(t, j)) + P[j] + U[j] * u_j / D[j], dj)
        if e.dof > 1:
            IA[link], U[link], D[link], D_inv[link], Ia[link] = _multi_freedom(t, e, S, IA_k)
            P[link] = defined(tree, e, [f"{e.path}.bias_wrench[{i}]" for i in range(6)], ["N*m"] * 3 + ["N"] * 3,
                              p_k, "bias wrench of the subtree (articulated-body inward pass)")
            continue
        empty = all(ca.SX(x).is_zero() for x in ca.vertsplit(ca.vec(IA_k)))
        unmoved = not empty and link in on_loop and not getattr(e, "use_flange", False) and \
            ca.SX(ca.dot(S, ca.mtimes(IA_k, S))).is_zero()
        if reaches_cut[link] and (empty or unmoved):
            # a link inside a loop whose joint moves no mass (none beyond it, or none along its axis):
            # its joint equation S·P = axis load constrains the loop's wrench, its acceleration comes
            # from the differentiated closure, and whatever mass it has rides rigidly on the parent's
            # side (IA·S = 0). Whether the loop gives that freedom mass is check_loop_mass's question
            massless.add(link)
            IA[link] = IA_k = IA_k if empty else t.let(IA_k, f"{e.path}.articulated_inertia")
            Ia[link], U[link], D[link] = IA_k if unmoved else ca.SX.zeros(6, 6), ca.SX.zeros(6), ca.SX(0)
            if unmoved:
                inert.add(link)
            if not getattr(e, "use_flange", False):
                t._unmoved.append(e)
            P[link] = defined(tree, e, [f"{e.path}.bias_wrench[{i}]" for i in range(6)], ["N*m"] * 3 + ["N"] * 3,
                              p_k, "loads through a massless link of a loop")
            continue
        if ca.SX(ca.dot(S, ca.mtimes(IA_k, S))).is_zero() and not getattr(e, "use_flange", False):
            raise StructureError(
                f"joint {e.path} ({type(e).__name__}) moves no mass: nothing beyond it has mass (or inertia "
                f"about its axis), or a joint beyond it at the same point already gives that freedom, so its "
                f"acceleration is undetermined; attach a Body beyond the joint, drive it through its flange "
                f"(use_flange=True), or remove the redundant joint")
        IA[link] = IA_k = t.let(IA_k, f"{e.path}.articulated_inertia")
        U[link] = ca.mtimes(IA_k, S)
        D[link] = ca.dot(S, U[link])
        if not getattr(e, "use_flange", False):
            rotates = ca.DM(e.motion_axes()[1]).is_zero()       # revolute: kg·m²; prismatic: kg
            # the scale must not vanish with D: the subtree's mass times the mechanism's length² counts
            # too (a revolute whose child is a spherical joint at the same point has neither D nor any
            # rotational articulated inertia, only the mass at the pivot)
            scale = ca.trace(IA_k[:3, :3]) + ca.trace(IA_k[3:, 3:]) / 3 * t.length2 if rotates \
                else ca.trace(IA_k[3:, 3:]) / 3
            t._pivots.append((e, D[link], scale))
        Ia[link] = t.let(IA_k - ca.mtimes(U[link], U[link].T) / D[link], f"{e.path}.reduced_inertia")
        P[link] = defined(tree, e, [f"{e.path}.bias_wrench[{i}]" for i in range(6)], ["N*m"] * 3 + ["N"] * 3,
                          p_k, "bias wrench of the subtree (articulated-body inward pass)")
    return IA, D, P, massless


def _multi_freedom(t, e, S, IA_k):
    """IA, U = IA·S, D⁻¹ (twice: the outward pass multiplies by it where a single freedom divides by D),
    D⁻¹ and the reduced inertia IA − U·D⁻¹·Uᵀ passed to the parent, for a joint with several freedoms
    (spherical: D = Sᵀ·IA·S is the subtree's inertia about the pivot in frame_b axes; free: nothing
    passes on). D⁻¹ is written out (3x3 or 6x6): the accelerations then stay explicit, an ODE."""
    if all(ca.SX(x).is_zero() for x in ca.vertsplit(ca.vec(ca.mtimes(S.T, ca.mtimes(IA_k, S))))):
        raise StructureError(
            f"joint {e.path} ({type(e).__name__}) moves no mass: nothing beyond it has mass or inertia, so "
            f"its accelerations are undetermined; attach a Body beyond the joint")
    IA_k = t.let(IA_k, f"{e.path}.articulated_inertia")
    U = t.let(ca.mtimes(IA_k, S), f"{e.path}.IA_S")
    D = t.let(ca.mtimes(S.T, U), f"{e.path}.D")
    scale = ca.trace(IA_k[:3, :3]) + (ca.trace(IA_k[3:, 3:]) if e.dof == 6 else 0)
    t._pivots.append((e, D, scale))
    if e.dof == 6:                                     # S is orthogonal: D⁻¹ = Sᵀ·IA⁻¹·S
        D_inv = t.let(ca.mtimes(S.T, ca.mtimes(_spatial_inverse(t, IA_k, e.path), S)), f"{e.path}.D_inv")
        return IA_k, U, D_inv, D_inv, ca.SX.zeros(6, 6)
    if _turns_freely(e, S):
        # S = [R_b; 0] spans every rotation about the pivot: with IA = [[A, B], [Bᵀ, M]], D⁻¹ = R_bᵀ·A⁻¹·R_b
        # and the reduced inertia is [[0, 0], [0, M − Bᵀ·A⁻¹·B]] — its zero blocks written as zeros, not
        # left to cancel (the round-off they left grew ~7x per link of a spherical chain)
        A, B, M = IA_k[:3, :3], IA_k[:3, 3:], IA_k[3:, 3:]
        A_inv = t.let(_spd_inverse(A), f"{e.path}.A_inv")
        D_inv = t.let(ca.mtimes(S[:3, :].T, ca.mtimes(A_inv, S[:3, :])), f"{e.path}.D_inv")
        reduced = t.let(M - ca.mtimes(B.T, ca.mtimes(A_inv, B)), f"{e.path}.reduced_mass")
        Z = ca.SX.zeros(3, 3)
        return IA_k, (A_inv, B), D_inv, D_inv, blocks(Z, Z, Z, reduced)
    D_inv = t.let(ca.inv(D), f"{e.path}.D_inv")       # explicit: the accelerations stay an ODE's
    return IA_k, U, D_inv, D_inv, t.let(IA_k - ca.mtimes(U, ca.mtimes(D_inv, U.T)), f"{e.path}.reduced_inertia")


def _spd_inverse(A):
    """The inverse of a symmetric positive definite 3x3 through its Cholesky factor L (A = L·Lᵀ,
    A⁻¹ = L⁻ᵀ·L⁻¹): square roots of pivots instead of a cofactor expansion's cancelling products."""
    l00 = ca.sqrt(A[0, 0])
    l10, l20 = A[1, 0] / l00, A[2, 0] / l00
    l11 = ca.sqrt(A[1, 1] - l10 * l10)
    l21 = (A[2, 1] - l20 * l10) / l11
    l22 = ca.sqrt(A[2, 2] - l20 * l20 - l21 * l21)
    # L⁻¹ (lower triangular) by forward substitution
    i00, i11, i22 = 1 / l00, 1 / l11, 1 / l22
    i10 = -l10 * i00 * i11
    i21 = -l21 * i11 * i22
    i20 = -(l20 * i00 + l21 * i10) * i22
    Linv = ca.vertcat(ca.horzcat(i00, 0, 0), ca.horzcat(i10, i11, 0), ca.horzcat(i20, i21, i22))
    return ca.mtimes(Linv.T, Linv)


def _turns_freely(e, S) -> bool:
    """A joint whose freedoms are every rotation about one point and nothing else (S = [R; 0], 3 columns):
    a spherical joint."""
    return e.dof == 3 and all(ca.SX(x).is_zero() for x in ca.vertsplit(ca.vec(S[3:, :])))


def _spatial_inverse(t, IA, name):
    """IA⁻¹ by blocks, IA = [[A, B], [Bᵀ, M]] (M the mass block): the Schur complement A − B·M⁻¹·Bᵀ is
    the rotational inertia about the mass centre, so the large m·|c|² terms cancel once, in a 3x3, not
    inside a 6x6 cofactor expansion (whose error grew as (m·|c|²/I)²: 1e-6 for 1000 kg at 0.6 m)."""
    A, B, M = IA[:3, :3], IA[:3, 3:], IA[3:, 3:]
    M_inv = t.let(ca.inv(M), f"{name}.mass_inverse")
    BM = t.let(ca.mtimes(B, M_inv), f"{name}.B_M_inv")
    S_inv = t.let(ca.inv(A - ca.mtimes(BM, B.T)), f"{name}.central_inverse")
    top = -ca.mtimes(S_inv, BM)
    return blocks(S_inv, top, top.T, M_inv + ca.mtimes(BM.T, ca.mtimes(S_inv, BM)))


def _outward(t, tree, moving, M, IA, D, P, massless):
    """Root → leaves: each joint's acceleration row and its link's acceleration (`t.A`). Rows whose pivot
    may be safe are registered for mark_pivots (`t._pivot_rows`)."""
    for link in moving:
        e, S, _, _ = t.joint[link]
        d, parent_link = offset(t, link)
        Ap = t.A[parent_link]
        pre = ca.vertcat(Ap[:3], Ap[3:] + cross(Ap[:3], d)) + velocity_terms(t, link)
        qdd = der(e.speed())
        if e.dof > 1:
            add_equations(tree, e, qdd - ca.mtimes(D[link], e.axis_load() - ca.mtimes(
                S.T, ca.mtimes(IA[link], pre) + P[link])), "joint accelerations: D⁻¹·(τ − Sᵀ(IA·a + p)) "
                "(articulated-body outward pass)")
            t.A[link] = defined(tree, e, [f"{e.path}.frame_b.z_0[{i}]" for i in range(3)] +
                                [f"{e.path}.frame_b.a_0[{i}]" for i in range(3)], ["rad/s2"] * 3 + ["m/s2"] * 3,
                                pre + ca.mtimes(S, qdd), "link acceleration (articulated-body outward pass)")
            continue
        if link not in massless and qdd.is_symbolic():
            # D may be divided by when the link's own inertia about its freedom is positive (D is at
            # least that); mark_pivots checks it once the tree is built. Not when simplification
            # makes the acceleration one of the parent's, which this row also holds
            t._pivot_rows.append((len(tree.equations), ca.dot(S, ca.mtimes(M[link], S)), M[link]))
            unless = tuple(a.name() for a in ca.vertsplit(Ap) if a.is_symbolic())
        add_equations(tree, e, D[link] * qdd - (e.axis_load() - ca.dot(S, ca.mtimes(IA[link], pre) + P[link])),
                      "joint acceleration (articulated-body outward pass)", regular=link not in massless,
                      pivot=qdd.name() if link not in massless and qdd.is_symbolic() else "",
                      pivot_unless=unless if link not in massless and qdd.is_symbolic() else ())
        side = "frame_b" if t.joint[link][2] else "frame_a"
        t.A[link] = defined(tree, e, [f"{e.path}.{side}.z_0[{i}]" for i in range(3)] +
                            [f"{e.path}.{side}.a_0[{i}]" for i in range(3)], ["rad/s2"] * 3 + ["m/s2"] * 3,
                            pre + S * qdd, "link acceleration (articulated-body outward pass)")


def cut_forces(t, tree):
    """Cut forces of bodies, edges and the World: the wrench each subtree needs, built leaves → root."""
    sub, flows = {}, {}              # flows: frame -> wrench into the component (moment, force), world axes
    for n in reversed(t.order):
        link = t.link_of[n]
        ref = reference(t, link)
        d = between(t, n, t.link_nodes[link][0])
        alpha, a_ref = t.A[link][:3], t.A[link][3:]
        a_n = a_ref + cross(alpha, d) + cross(ref.w, cross(ref.w, d))
        W = ca.SX.zeros(6)
        for body in t.bodies_at[n]:
            Mb, bb, gb = body_terms(t, body, n, None)
            wrench = ca.mtimes(Mb, ca.vertcat(alpha, a_n)) + bb - gb
            _add(flows, body.frame_a, wrench)       # a two-frame body (BodyShape) also passes a wrench on there
            W += wrench
        for fr in t.loads_at[n]:
            W -= load(t, fr, n)
        for c in t.children[n]:
            e, forward, _ = t.parent[c]
            child_frame, parent_frame = (e.frame_b, e.frame_a) if forward else (e.frame_a, e.frame_b)
            moved = transport_wrench(sub[c], t.step[c])
            _add(flows, child_frame, -sub[c])
            _add(flows, parent_frame, moved)
            W += moved
        sub[n] = W
    root = t.order[0]
    others = [c for c in t.members[root] if c is not t.world.frame_b]
    total = sum((flows[c] if c in flows else -load(t, c, root) for c in others), ca.SX.zeros(6))
    flows[t.world.frame_b] = -total
    for fr, wrench in flows.items():
        R = t.kin[t.node_of[fr]].R
        for key, value, unit in (("f", ca.mtimes(R.T, wrench[3:]), "N"), ("t", ca.mtimes(R.T, wrench[:3]), "N*m")):
            for i, (sym, val) in enumerate(zip(ca.vertsplit(fr._values[key]), ca.vertsplit(value))):
                tree.replaced[sym.element_hash()] = val
                tree.observed.append((f"{fr.label}.{key}[{i}]", sym, unit, val))


def _add(flows, frame, wrench):
    """flows[frame] += wrench (the first term as it is: a component with one role keeps its expression)."""
    flows[frame] = flows[frame] + wrench if frame in flows else wrench
