"""The multibody tree pass (part of flatten): frames become expressions, dynamics become a recursion.

DESIGN.md, "A multibody formulation that fits this pipeline". The frame
connection sets are the nodes of a graph whose edges are the tree-edge
components (joints, fixed translations and rotations). A breadth-first
spanning tree rooted at the World gives every frame's position `r_0` and
orientation `R` as expressions of the joint coordinates, so orientation is
never an unknown. Nodes joined by rigid edges form one *link* (rigid body).

Dynamics follow the articulated-body recursion, written as residual equations
with per-link intermediate unknowns so that every equation is local and emit
solves them one by one (O(N) in the number of links):

- inward (leaves → root): the articulated inertia I^A_k (an expression of the
  joint coordinates) and the bias wrench p_k (an unknown: it collects the
  external loads and the axis torques of the subtree);
- outward (root → leaves): the joint acceleration from
  D_k q̈_k = τ_k − Sᵀ(I^A_k (X A_parent + c_k) + p_k), and the link
  acceleration A_k = X A_parent + c_k + S q̈_k.

Everything is resolved in world axes; wrenches are (moment about the link's
reference point, force); accelerations are classical (α, a of the reference
point). Other components with frames (force elements, sensors) load the tree
through their cut forces, which stay ordinary unknowns of their own equations.

Frame positions and orientations, and the cut forces of the tree components
(bodies, edges, the World), leave the equation system: they are expressions
(`observed`), the latter built leaves → root from the link accelerations as
the wrench each subtree needs. So the compiled model carries about 16 unknowns
per link instead of 18 per frame, and no equation holds a whole-tree expression
that a later stage would have to rewrite.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import casadi as ca
import networkx as nx
import numpy as np

from ..core.equation import der
from ..core.errors import StructureError
from ..components.multibody.frames import axis_rotation, exact
from .artifacts import FlatEquation, FlatVariable
from .loops import Loop, closure, closure_equations, direction, loop_edges, loop_root, reduce_redundancy
from .tree_mass import check_loop_mass, sensor_equations


def _rotation_about_z(angle):
    c, s = ca.cos(angle), ca.sin(angle)
    R = ca.SX(3, 3)
    R[0, 0], R[0, 1], R[1, 0], R[1, 1], R[2, 2] = c, -s, s, c, 1.0
    return R


def _constant_rotation(n, angle):
    """axis_rotation as numbers, round-off made exact."""
    return exact(np.asarray(ca.evalf(ca.SX(axis_rotation(ca.DM(n), angle))).full(), dtype=float), 1e-14)


def _onto_z(n):
    """A constant rotation B with B·n = z to 1e-14 (n a unit vector), or None. The angle comes from
    atan2(|n × z|, n·z): arccos(n·z) loses an axis 1e-8 off z entirely (n·z rounds to 1)."""
    if not (n[0] or n[1]):
        return np.eye(3) if n[2] > 0 else np.diag([1.0, -1.0, -1.0])
    k = np.cross(n, [0.0, 0.0, 1.0])
    sin = np.linalg.norm(k)
    B = _constant_rotation(k / sin, np.arctan2(sin, n[2]))
    return B if np.max(np.abs(B @ n - [0.0, 0.0, 1.0])) <= 1e-14 else None


@dataclass(frozen=True)
class _Turn:
    """A frame's orientation R = A·Rz(angle)·B with A, B constant: reached from the world by rotations
    about one fixed axis (A·z) only. Its angle is then a sum of joint angles, and R is built from that
    sum: the product of the joints' rotations grows with every link and every time derivative."""

    A: np.ndarray
    angle: ca.SX
    B: np.ndarray

    def rotation(self):
        Rz = _rotation_about_z(self.angle)
        return ca.mtimes(ca.DM(self.A), ca.mtimes(Rz, ca.DM(self.B)))

    def fixed(self):
        """R as numbers when the angle is a number, else None."""
        a = ca.SX(self.angle)
        return exact(self.A @ _constant_rotation([0, 0, 1], float(ca.evalf(a))) @ self.B, 1e-14) \
            if a.is_constant() else None


def _motion_axes(e):
    """A joint's (angular, linear) unit axes as numbers."""
    return tuple(np.asarray(ca.DM(a).full(), dtype=float).ravel() for a in e.motion_axes())


def _next_turn(e, R_rel, turn, forward):
    """The child's _Turn across edge e (R_child = R_parent·R_rel, or ·R_relᵀ when the edge is walked
    backwards), or None when the edge turns about another axis. R_rel itself is checked, not only the
    joint's motion axes (a joint class of the user's may turn by more than its coordinate)."""
    if turn is None:
        return None
    R = ca.SX(R_rel)
    fixed = turn.fixed()
    if e.dof == 0:
        if not R.is_constant():
            return None
        M = np.asarray(ca.evalf(R).full(), dtype=float)
        M = M if forward else M.T
        if fixed is not None:
            return _Turn(exact(fixed @ M, 1e-14), ca.SX(0.0), np.eye(3))
        C = exact(turn.B @ M @ turn.B.T)           # B·M = C·B: C must turn about z
        if C[2, 2] != 1.0 or np.any(C[2, :2]) or np.any(C[:2, 2]):
            return None
        return _Turn(turn.A, turn.angle + float(np.arctan2(C[1, 0], C[0, 0])), turn.B)
    if e.dof != 1:
        return None
    q = e.coordinate()
    n, s_lin = _motion_axes(e)
    if any(not ca.is_equal(v, q) for v in ca.symvar(R)):
        return None
    if not np.any(n):
        return turn if R.is_constant() and R.is_eye() else None          # a prismatic: the same turn
    if np.any(s_lin):
        return None
    gap = ca.Function("gap", [q], [R - axis_rotation(ca.DM(n), q)])
    if not all(np.max(np.abs(np.asarray(gap(v)))) <= 1e-12 for v in (0.3, -1.7)):
        return None
    sign = 1.0 if forward else -1.0
    if fixed is not None:                                    # a new axis: Rot_n(x) = Bᵀ·Rz(x)·B with B·n = z
        B = _onto_z(n)
        return None if B is None else _Turn(exact(fixed @ B.T, 1e-14), sign * q, B)
    m = turn.B @ n                                           # B·Rot_n(x) = Rot_{B·n}(x)·B: B·n must be ±z,
    if abs(m[0]) > 1e-14 or abs(m[1]) > 1e-14:               # measured by the tilt (not by 1 − cos(tilt))
        return None
    return _Turn(turn.A, turn.angle + sign * float(np.sign(m[2])) * q, turn.B)


@dataclass
class FrameKinematics:
    """Position, orientation, angular velocity and velocity of a frame origin (world components)."""

    r: ca.SX
    R: ca.SX
    w: ca.SX
    v: ca.SX


@dataclass
class MultibodyTree:
    """What the pass found and made; flatten takes the variables, equations and substitutions."""

    frames: dict                     # frame label -> FrameKinematics (expressions of q, q̇)
    coordinates: list                # [(joint path, q symbol, q̇ symbol)] in tree order
    links: int
    bodies: int
    world: str
    variables: list = field(default_factory=list)      # new unknowns (link accelerations, bias wrenches)
    equations: list = field(default_factory=list)      # the recursion, local equations
    replaced: dict = field(default_factory=dict)       # element hash of a frame symbol -> expression
    rates: dict = field(default_factory=dict)          # element hash of a frame symbol -> its time derivative
    observed: list = field(default_factory=list)       # (name, symbol, unit, expression) leaving the system
    intermediates: tuple = ((), ())                    # (symbols, definitions): state-only quantities, in order
    zeros: list = field(default_factory=list)          # (name, unit) of accelerations/wrenches that are exactly 0
    loops: list = field(default_factory=list)          # Loop: one per cut edge (kinematic loops)

    def summary(self) -> str:
        return (f"multibody tree: {self.links} moving link(s), {self.bodies} body(ies), "
                f"{len(self.coordinates)} joint coordinate(s), rooted at {self.world}"
                + (f", {len(self.loops)} kinematic loop(s)" if self.loops else ""))


# ---- small spatial algebra (world axes; wrench = (moment, force), motion = (angular, linear)) ----------

def _blocks(a, b, c, d):
    return ca.vertcat(ca.horzcat(a, b), ca.horzcat(c, d))


def _cross(a, b):
    a = a if isinstance(a, ca.SX) else ca.SX(a)
    b = b if isinstance(b, ca.SX) else ca.SX(b)
    return ca.cross(a, b)


def _skew(v):
    return ca.skew(ca.SX(v))


def _transport_wrench(w, d):
    """A wrench acting at a point d from the reference, expressed about the reference: the moment gains d × f."""
    return ca.vertcat(w[:3] + _cross(d, w[3:]), w[3:])


def _transport_inertia(I6, d):
    """Xᵀ I X for X = [[1, 0], [−[d]×, 1]] (the acceleration of a point at d from the reference)."""
    D = _skew(d)
    eye, zero = ca.SX.eye(3), ca.SX(3, 3)
    X = _blocks(eye, zero, -D, eye)
    return ca.mtimes(X.T, ca.mtimes(I6, X))


def _roles():
    from ..components.multibody.interfaces import Frame, PartialBody, PartialTreeEdge
    from ..components.multibody.parts import World
    return Frame, PartialBody, PartialTreeEdge, World


# ---- the pass -------------------------------------------------------------------------------------------

class _Tree:
    """Working state of the pass for one scene."""

    def __init__(self, components, graph):
        Frame, self.PartialBody, self.PartialTreeEdge, self.World = _roles()
        self.frames = [c for c in graph.nodes if isinstance(c, Frame)]
        self.members = sorted((sorted(m, key=lambda c: c.label)
                               for m in nx.connected_components(graph.subgraph(self.frames))),
                              key=lambda m: m[0].label)
        self.node_of = {c: k for k, members in enumerate(self.members) for c in members}
        self.world = self._the_world(components) if self.frames else None
        self.components = components
        self.let_symbols, self.let_values = [], []
        self._body_cache, self._velocity_cache = {}, {}
        self._pivots = []                     # (joint, D, scale): checked numerically once the tree is built
        self._pivot_rows = []                 # (equation index, link's own inertia along the joint, its M)
        self._unmoved = []                    # joints on a loop that move no mass themselves: check_loop_mass

    def let(self, expr, name):
        """Hide a state-only expression behind named symbols, entry by entry (numbers stay numbers, so
        structural zeros survive). Later stages see only short local equations; emit expands the
        chain once at the end, so the compiled expressions keep their sharing and stay O(N)."""
        expr = ca.densify(ca.SX(expr))
        out = []
        for k, e in enumerate(ca.vertsplit(ca.vec(expr))):
            if e.is_constant() or e.is_symbolic():
                out.append(e)
                continue
            sym = ca.SX.sym(f"{name}_{k}")
            self.let_symbols.append(sym)
            self.let_values.append(e)
            out.append(sym)
        return ca.reshape(ca.vertcat(*out), expr.shape[0], expr.shape[1])

    def _the_world(self, components):
        worlds = [c for c in components if isinstance(c, self.World)]
        if not worlds:
            shown = ", ".join(f.label for f in self.frames[:3]) + (", …" if len(self.frames) > 3 else "")
            raise StructureError(f"the scene has multibody frames ({shown}) but no World; add "
                                 f"mechnet.components.multibody.World(name='world') and connect its frame_b")
        if len(worlds) > 1:
            raise StructureError(f"the scene has {len(worlds)} Worlds ({', '.join(w.path for w in worlds)}); "
                                 f"a scene has exactly one World: connect everything to one of them")
        return worlds[0]

    def span(self):
        """Spanning tree from the World's node; the edges it leaves out close kinematic loops.

        Rigid edges are taken into the tree first, then joints driven through a flange, then plain
        joints: a loop is cut at a plain joint where it has one (its drive is then simply zero).
        Within each class, edges are taken in name order, so the choice is reproducible."""
        g = nx.MultiGraph()
        g.add_nodes_from(range(len(self.members)))
        for e in self.components:
            if isinstance(e, self.PartialTreeEdge):
                weight = 0 if not e.dof else (1 if getattr(e, "use_flange", False) else 2)
                g.add_edge(self.node_of[e.frame_a], self.node_of[e.frame_b], key=e.path, comp=e, weight=weight)
        kept = {key for _, _, key in nx.minimum_spanning_edges(g, algorithm="kruskal", keys=True, data=False)}
        root = self.node_of[self.world.frame_b]
        self.parent = {root: None}          # node -> (edge, forward: parent is frame_a's side, parent node)
        self.order = [root]
        for u in self.order:
            for _, v, key, data in sorted(g.edges(u, keys=True, data=True), key=lambda item: item[2]):
                if key in kept and v not in self.parent:
                    e = data["comp"]
                    self.parent[v] = (e, self.node_of[e.frame_a] == u, u)
                    self.order.append(v)
        self.cuts = sorted((data["comp"] for _, _, key, data in g.edges(keys=True, data=True) if key not in kept),
                           key=lambda e: e.path)
        self.cut_ids = {id(e) for e in self.cuts}
        unreached = [k for k in range(len(self.members)) if k not in self.parent]
        if unreached:
            owners = sorted({c.owner for k in unreached for c in self.members[k]},
                            key=lambda c: (not isinstance(c, self.PartialBody), c.path))
            raise StructureError(
                f"no path to the World ({self.world.path}) from "
                + ", ".join(f"{c.path} ({type(c).__name__})" for c in owners[:6]) + (" …" if len(owners) > 6 else "")
                + "; connect them to the world through joints or fixed translations")
        self.children = {n: [] for n in self.order}
        for n in self.order[1:]:
            self.children[self.parent[n][2]].append(n)

    def kinematics(self):
        """Positions, orientations and velocities along the tree; links are nodes joined by rigid edges."""
        root = self.order[0]
        zero3 = ca.densify(ca.SX.zeros(3))
        self.kin = {root: FrameKinematics(zero3, ca.densify(ca.SX.eye(3)), zero3, zero3)}
        self.link_of = {root: None}           # None: the world link (fixed)
        self.link_nodes = {None: [root]}
        self.joint = {}                       # link -> (joint, S = (angular, linear) axis, world axes)
        self.coordinates = []
        self.turn = turn = {root: _Turn(np.eye(3), ca.SX(0.0), np.eye(3))}   # node -> its _Turn, or None
        self.step = {root: zero3}             # node -> its position from its parent node, world axes
        self.step_norm2 = {root: 0.0}         # node -> |step|² when a constant, else None
        self.from_link = {root: None}         # node -> its position from its link's first node (None: it is that)
        for n in self.order[1:]:
            e, forward, p = self.parent[n]
            kp = self.kin[p]
            r_rel, R_rel = e.relative_motion()
            same_axes = e.dof == 0 and ca.SX(R_rel).is_eye()      # a pure translation keeps the orientation
            turn[n] = turn[p] if same_axes else _next_turn(e, R_rel, turn[p], forward)
            if turn[n] is not None and not same_axes:
                # a planar chain: the angles add, and R is built from their sum (_Turn)
                R = kp.R if turn[n] is turn[p] else turn[n].rotation()
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
            self.step[n] = step
            self.from_link[n] = None if e.dof else (step if self.from_link[p] is None else self.from_link[p] + step)
            # |step|² is |r_rel|² when the step is a rotated constant (a rigid link): a body's inertia
            # about the joint then holds m·L², not m·(L² cos² + L² sin²)
            self.step_norm2[n] = float(ca.sumsqr(ca.DM(r_rel))) if ca.SX(r_rel).is_constant() else None
            r = kp.r + step
            w, v = kp.w, kp.v + _cross(kp.w, step)
            if e.dof:
                s_ang, s_lin = e.motion_axes()
                sign = 1.0 if forward else -1.0
                S = sign * ca.vertcat(ca.mtimes(Ra, s_ang), ca.mtimes(Ra, s_lin))
                qd = e.speed()
                w, v = w + S[:3] * qd, v + S[3:] * qd
                self.link_of[n] = e.path
                self.link_nodes[e.path] = [n]
                self.joint[e.path] = (e, S, forward, p)
                self.coordinates.append((e.path, e.coordinate(), qd))
            else:
                self.link_of[n] = self.link_of[p]
                self.link_nodes[self.link_of[p]].append(n)
            name = self.members[n][0].label
            self.kin[n] = FrameKinematics(self.let(r, f"{name}.r_0"), R if same_axes else self.let(R, f"{name}.R"),
                                          w if not e.dof else self.let(w, f"{name}.w_0"), self.let(v, f"{name}.v_0"))
        self.bodies_at = {k: [] for k in range(len(self.members))}
        self.loads_at = {k: [] for k in range(len(self.members))}
        for c in self.frames:
            if isinstance(c.owner, self.PartialBody):
                self.bodies_at[self.node_of[c]].append(c.owner)
            elif id(c.owner) in self.cut_ids or not isinstance(c.owner, (self.PartialTreeEdge, self.World)):
                self.loads_at[self.node_of[c]].append(c)        # force elements, sensors, cut edges

    # -- loads ------------------------------------------------------------------------------------------

    def load(self, fr, n):
        """The wrench a component's frame puts on node n (moment about n, force), world axes."""
        R = self.kin[n].R
        return ca.vertcat(-ca.mtimes(R, fr.t), -ca.mtimes(R, fr.f))

    def body_terms(self, body, n, d, d_norm2=None):
        """Spatial inertia about a point at −d from node n, velocity-product wrench, gravity wrench.
        `d_norm2`: |d|² when it is a constant (`between_norm2`)."""
        key = (id(body), d is None)
        if d is None and key in self._body_cache:
            return self._body_cache[key]
        m, r_cm, I = body.mass_properties()
        k = self.kin[n]
        offset = ca.mtimes(k.R, r_cm) if not ca.DM(r_cm).is_zero() else None
        if d is None:
            c = offset if offset is not None else ca.SX.zeros(3)
            norm2 = float(ca.sumsqr(ca.DM(r_cm))) if ca.SX(r_cm).is_constant() else None
        else:
            c = d + offset if offset is not None else d
            norm2 = d_norm2 if offset is None else None
        C = _skew(c)
        # -m·C² = m·(|c|² 1 − c cᵀ): with |c|² a known constant the rotation's cos² + sin² never appears
        I_O = m * (norm2 * ca.SX.eye(3) - ca.mtimes(c, c.T)) if norm2 is not None else -m * ca.mtimes(C, C)
        if not ca.DM(I).is_zero():
            I_O = I_O + ca.mtimes(k.R, ca.mtimes(I, k.R.T))
        gravity = m * self.world.gravity_at(k.r + offset if offset is not None else k.r)
        out = (_blocks(I_O, m * C, -m * C, m * ca.SX.eye(3)),
               ca.vertcat(_cross(k.w, ca.mtimes(I_O, k.w)), m * _cross(k.w, _cross(k.w, c))),
               ca.vertcat(_cross(c, gravity), gravity))
        if d is None:
            self._body_cache[key] = out
        return out

    def ref(self, link):
        return self.kin[self.link_nodes[link][0]]

    def between_norm2(self, n, a):
        """|between(n, a)|² when n is one constant step from a (a rigid link), else None."""
        if n == a:
            return 0.0
        return self.step_norm2.get(n) if self.parent.get(n, (None, None, None))[2] == a else None

    def between(self, n, a) -> ca.SX:
        """Position of node n from node a (world axes) built from the edges' steps, not as the difference
        of their absolute positions: r_n − r_a keeps r_a in both terms, which the expression graph does
        not cancel ((x − (−0.5 sin φ)) − x in a cart-pole's ODE). a is n's link's first node (the sum
        kept per node in `from_link`, so a long rigid link costs O(length)) or, for n a link's first node,
        the first node of the link before; anything else falls back on the difference."""
        first = self.link_nodes[self.link_of[n]][0]
        if a == first:
            return self.from_link[n] if self.from_link[n] is not None else ca.densify(ca.SX.zeros(3))
        if n == first and n != self.order[0]:
            p = self.parent[n][2]
            if self.link_nodes[self.link_of[p]][0] == a:
                return self.step[n] if self.from_link[p] is None else self.from_link[p] + self.step[n]
        return self.kin[n].r - self.kin[a].r

    def offset(self, link):
        """From the parent link's reference point to this link's, and the parent link."""
        parent_link = self.link_of[self.joint[link][3]]
        return self.between(self.link_nodes[link][0], self.link_nodes[parent_link][0]), parent_link

    def velocity_terms(self, link):
        """c_k: the acceleration of the link that the joint's motion adds at zero q̈ (Coriolis, centripetal)."""
        if link not in self._velocity_cache:
            e, S, _, _ = self.joint[link]
            d, parent_link = self.offset(link)
            wp = self.ref(parent_link).w
            qd = e.speed()
            self._velocity_cache[link] = ca.vertcat(_cross(wp, S[:3] * qd),
                                                    _cross(wp, _cross(wp, d)) + 2 * _cross(wp, S[3:] * qd))
        return self._velocity_cache[link]

    # -- dynamics ---------------------------------------------------------------------------------------

    def dynamics(self, tree):
        moving = [self.link_of[n] for n in self.order[1:] if self.link_nodes.get(self.link_of[n], [None])[0] == n]
        M, bias = {}, {}
        for link in moving:
            Mk, bk = ca.SX.zeros(6, 6), ca.SX.zeros(6)
            for n in self.link_nodes[link]:
                d = self.between(n, self.link_nodes[link][0])
                d_norm2 = self.between_norm2(n, self.link_nodes[link][0])
                for body in self.bodies_at[n]:
                    Mb, bb, gb = self.body_terms(body, n, d, d_norm2)
                    Mk, bk = Mk + Mb, bk + bb - gb
                for fr in self.loads_at[n]:
                    bk -= _transport_wrench(self.load(fr, n), d)
            M[link], bias[link] = Mk, bk
        self.A, P = {None: ca.densify(ca.SX.zeros(6))}, {}
        child_links = {link: [] for link in self.link_nodes}
        for link in moving:
            child_links[self.link_of[self.joint[link][3]]].append(link)
        IA, Ia, U, D = {}, {}, {}, {}
        massless, inert, reaches_cut = set(), set(), {}
        on_loop = {j.path for e in self.cuts
                   for j in loop_edges(self.parent, self.node_of[e.frame_a], self.node_of[e.frame_b])}
        for link in reversed(moving):                      # inward: articulated inertia and bias
            e, S, _, _ = self.joint[link]
            IA_k, p_k = M[link], bias[link]
            reaches_cut[link] = any(id(fr.owner) in self.cut_ids for n in self.link_nodes[link]
                                    for fr in self.loads_at[n]) or any(reaches_cut[j] for j in child_links[link])
            for j in child_links[link]:
                dj, _ = self.offset(j)
                if j in massless:                          # passes its loads on: the wrench through its joint
                    through = P[j]
                    if j in inert:                         # and its inertia, rigidly (its joint moves none)
                        IA_k = IA_k + _transport_inertia(Ia[j], dj)
                        through = through + ca.mtimes(Ia[j], self.velocity_terms(j))
                    p_k = p_k + _transport_wrench(through, dj)
                    continue
                ej, Sj, _, _ = self.joint[j]
                u_j = ej.axis_load() - ca.dot(Sj, P[j])
                IA_k = IA_k + _transport_inertia(Ia[j], dj)
                p_k = p_k + _transport_wrench(ca.mtimes(Ia[j], self.velocity_terms(j)) + P[j] + U[j] * u_j / D[j], dj)
            empty = all(ca.SX(x).is_zero() for x in ca.vertsplit(ca.vec(IA_k)))
            unmoved = not empty and link in on_loop and not getattr(e, "use_flange", False) and \
                ca.SX(ca.dot(S, ca.mtimes(IA_k, S))).is_zero()
            if reaches_cut[link] and (empty or unmoved):
                # a link inside a loop whose joint moves no mass (none beyond it, or none along its axis):
                # its joint equation S·P = axis load constrains the loop's wrench, its acceleration comes
                # from the differentiated closure, and whatever mass it has rides rigidly on the parent's
                # side (IA·S = 0). Whether the loop gives that freedom mass is check_loop_mass's question
                massless.add(link)
                IA[link] = IA_k = IA_k if empty else self.let(IA_k, f"{e.path}.articulated_inertia")
                Ia[link], U[link], D[link] = IA_k if unmoved else ca.SX.zeros(6, 6), ca.SX.zeros(6), ca.SX(0)
                if unmoved:
                    inert.add(link)
                if not getattr(e, "use_flange", False):
                    self._unmoved.append(e)
                P[link] = _defined(tree, e, [f"{e.path}.bias_wrench[{i}]" for i in range(6)], ["N*m"] * 3 + ["N"] * 3,
                                   p_k, "loads through a massless link of a loop")
                continue
            if ca.SX(ca.dot(S, ca.mtimes(IA_k, S))).is_zero() and not getattr(e, "use_flange", False):
                raise StructureError(
                    f"joint {e.path} ({type(e).__name__}) moves no mass: nothing beyond it has mass (or inertia "
                    f"about its axis), so its acceleration is undetermined; attach a Body beyond the "
                    f"joint, or drive it through its flange (use_flange=True)")
            IA[link] = IA_k = self.let(IA_k, f"{e.path}.articulated_inertia")
            U[link] = ca.mtimes(IA_k, S)
            D[link] = ca.dot(S, U[link])
            if not getattr(e, "use_flange", False):
                rotates = ca.DM(e.motion_axes()[1]).is_zero()       # revolute: kg·m²; prismatic: kg
                scale = ca.trace(IA_k[:3, :3]) if rotates else ca.trace(IA_k[3:, 3:]) / 3
                self._pivots.append((e, D[link], scale))
            Ia[link] = self.let(IA_k - ca.mtimes(U[link], U[link].T) / D[link], f"{e.path}.reduced_inertia")
            P[link] = _defined(tree, e, [f"{e.path}.bias_wrench[{i}]" for i in range(6)], ["N*m"] * 3 + ["N"] * 3,
                               p_k, "bias wrench of the subtree (articulated-body inward pass)")
        for link in moving:                                # outward: joint and link accelerations
            e, S, _, _ = self.joint[link]
            d, parent_link = self.offset(link)
            Ap = self.A[parent_link]
            pre = ca.vertcat(Ap[:3], Ap[3:] + _cross(Ap[:3], d)) + self.velocity_terms(link)
            qdd = der(e.speed())
            if link not in massless and qdd.is_symbolic():
                # D may be divided by when the link's own inertia about its freedom is positive (D is at
                # least that); mark_pivots checks it once the tree is built. Not when simplification
                # makes the acceleration one of the parent's, which this row also holds
                self._pivot_rows.append((len(tree.equations), ca.dot(S, ca.mtimes(M[link], S)), M[link]))
                unless = tuple(a.name() for a in ca.vertsplit(Ap) if a.is_symbolic())
            _eq(tree, e, D[link] * qdd - (e.axis_load() - ca.dot(S, ca.mtimes(IA[link], pre) + P[link])),
                "joint acceleration (articulated-body outward pass)", regular=link not in massless,
                pivot=qdd.name() if link not in massless and qdd.is_symbolic() else "",
                pivot_unless=unless if link not in massless and qdd.is_symbolic() else ())
            side = "frame_b" if self.joint[link][2] else "frame_a"
            self.A[link] = _defined(tree, e, [f"{e.path}.{side}.z_0[{i}]" for i in range(3)] +
                                    [f"{e.path}.{side}.a_0[{i}]" for i in range(3)], ["rad/s2"] * 3 + ["m/s2"] * 3,
                                    pre + S * qdd, "link acceleration (articulated-body outward pass)")

    # -- what leaves the equation system ------------------------------------------------------------------

    def frame_values(self, tree):
        """r_0 and R of every frame become expressions (and their derivatives, where `der` was taken)."""
        from ..components.multibody.frames import to_row_major
        per_node = {}
        for c in self.frames:
            n = self.node_of[c]
            if n not in per_node:
                k = self.kin[n]
                per_node[n] = [(key, ca.vertsplit(value), ca.vertsplit(rate), unit) for key, value, rate, unit in (
                    ("r_0", k.r, k.v, "m"),
                    ("R", to_row_major(k.R), to_row_major(ca.mtimes(_skew(k.w), k.R)), "1"))]
            label = c.label
            for key, values, rates, unit in per_node[n]:
                for i, (sym, val, dot) in enumerate(zip(ca.vertsplit(c._values[key]), values, rates)):
                    tree.replaced[sym.element_hash()] = val
                    tree.observed.append((f"{label}.{key}[{i}]", sym, unit, val))
                    tree.rates[sym.element_hash()] = dot

    def cut_forces(self, tree):
        """Cut forces of bodies, edges and the World: the wrench each subtree needs, built leaves → root."""
        sub, flows = {}, {}              # flows: frame -> wrench into the component (moment, force), world axes
        for n in reversed(self.order):
            link = self.link_of[n]
            ref = self.ref(link)
            d = self.between(n, self.link_nodes[link][0])
            alpha, a_ref = self.A[link][:3], self.A[link][3:]
            a_n = a_ref + _cross(alpha, d) + _cross(ref.w, _cross(ref.w, d))
            W = ca.SX.zeros(6)
            for body in self.bodies_at[n]:
                Mb, bb, gb = self.body_terms(body, n, None)
                flows[body.frame_a] = ca.mtimes(Mb, ca.vertcat(alpha, a_n)) + bb - gb
                W += flows[body.frame_a]
            for fr in self.loads_at[n]:
                W -= self.load(fr, n)
            for c in self.children[n]:
                e, forward, _ = self.parent[c]
                child_frame, parent_frame = (e.frame_b, e.frame_a) if forward else (e.frame_a, e.frame_b)
                moved = _transport_wrench(sub[c], self.step[c])
                flows[child_frame] = -sub[c]
                flows[parent_frame] = moved
                W += moved
            sub[n] = W
        root = self.order[0]
        others = [c for c in self.members[root] if c is not self.world.frame_b]
        total = sum((flows[c] if c in flows else -self.load(c, root) for c in others), ca.SX.zeros(6))
        flows[self.world.frame_b] = -total
        for fr, wrench in flows.items():
            R = self.kin[self.node_of[fr]].R
            for key, value, unit in (("f", ca.mtimes(R.T, wrench[3:]), "N"), ("t", ca.mtimes(R.T, wrench[:3]), "N*m")):
                for i, (sym, val) in enumerate(zip(ca.vertsplit(fr._values[key]), ca.vertsplit(value))):
                    tree.replaced[sym.element_hash()] = val
                    tree.observed.append((f"{fr.label}.{key}[{i}]", sym, unit, val))

    def check_pivots(self):
        """A joint whose moving side has no mass or inertia along its freedom has D = 0 everywhere: its
        acceleration is undetermined. Exact zeros are caught while building; this catches the numerical
        ones (a mass on a tilted axis), at two random configurations, relative to the subtree's inertia."""
        if not self._pivots:
            return
        _, values, _ = self._at_random_configurations(
            ca.vertcat(*[ca.vertcat(D, scale) for _, D, scale in self._pivots]), 12345)
        for k, (e, _, _) in enumerate(self._pivots):
            if all(abs(v[2 * k]) <= 1e-12 * max(abs(v[2 * k + 1]), 1e-300) for v in values):
                raise StructureError(
                    f"joint {e.path} ({type(e).__name__}) moves no mass: what lies beyond it has no mass "
                    f"(or inertia) along its axis, so its acceleration is undetermined; attach a Body off "
                    f"the axis, or drive it through its flange (use_flange=True)")

    def _at_random_configurations(self, exprs, seed):
        """exprs in the joint coordinates (intermediates expanded), their values at rest at two random
        configurations with the tunable parameters at their values, and those parameters' symbols."""
        q = ca.vertcat(*[qs for _, qs, _ in self.coordinates])
        tunables = [(sym, value) for c in self.components for sym, value in c.tunable.values()]
        p = ca.vertcat(*[sym for sym, _ in tunables]) if tunables else ca.SX(0, 1)
        _, (exprs,) = ca.substitute_inplace(self.let_symbols, self.let_values, [exprs], False)
        speeds = ca.vertcat(*[qds for _, _, qds in self.coordinates])
        exprs = ca.substitute(exprs, speeds, ca.DM.zeros(speeds.numel()))
        fn = ca.Function("at_random", [q, p], [exprs])
        rng = np.random.default_rng(seed)
        return exprs, [np.asarray(fn(rng.uniform(-np.pi, np.pi, q.numel()), [v for _, v in tunables])).ravel()
                       for _ in range(2)], p

    def mark_pivots(self, tree):
        """Keep a joint-acceleration row's pivot only where the link's own inertia along the joint's
        freedom, Sᵀ·M·S, is positive: the articulated inertia D is at least that, at every configuration
        (the children only add positive semi-definite terms), so dividing by D is safe. For a revolute
        joint it is the link's moment of inertia about its axis, for a prismatic one its mass; both are
        constants, checked numerically at two random configurations. Not when it depends on a tunable
        parameter (it could be set to zero per run): D may vanish where the link itself has no mass
        (a massless rod driven through its flange), and the block is then solved whole."""
        if not self._pivot_rows:
            return
        own, values, p = self._at_random_configurations(ca.vertcat(*[
            ca.vertcat(o, ca.trace(Mk[:3, :3]) + ca.trace(Mk[3:, 3:])) for _, o, Mk in self._pivot_rows]), 54321)
        for k, (index, _, _) in enumerate(self._pivot_rows):
            tuned = p.numel() > 0 and ca.depends_on(own[2 * k], p)
            if tuned or not all(v[2 * k] > 1e-9 * max(v[2 * k + 1], 1e-300) for v in values):
                tree.equations[index] = replace(tree.equations[index], pivot="", pivot_unless=())

    def _loop_axes(self, e):
        """(R, name) of the axes that resolve the closure position of cut edge e; R None for the world's.
        - a root (`loop_root`) that does not turn: the world's, or the root's own if it is tilted (a
          constant rotation; the dropped directions then read 'position z');
        - a turning root, every rotation down to the cut's frames about one fixed axis (_Turn): the
          constant axes A of that turn, whose z is the plane's normal (the world's when A = 1);
        - else the root's own: it turns with the whole loop.
        Constant axes keep the root's rotation out of the residual's two time derivatives."""
        na, nb = self.node_of[e.frame_a], self.node_of[e.frame_b]
        root = loop_root(self.parent, na, nb)
        label = self.members[root][0].label
        R = ca.SX(self.kin[root].R)
        if R.is_constant():
            fixed = np.asarray(ca.evalf(R).full())
            return (None, "world axes") if np.array_equal(fixed, np.eye(3)) else (R, f"axes of {label}")
        ta, tb = self.turn.get(na), self.turn.get(nb)
        if ta is not None and tb is not None and np.array_equal(ta.A, tb.A):
            return (None, "world axes") if np.array_equal(ta.A, np.eye(3)) else \
                (ca.DM(ta.A), f"axes of the plane {label} turns in")
        return R, f"axes of {label}"

    @staticmethod
    def _loop_turn(e):
        """A constant B taking a revolute cut's axis (in its frame_a) onto z, when that axis is not ±z:
        the closure's angles are then taken about B's axes (`closure`), where a turn about the axis is
        exactly (0, 0, θ); None otherwise. Any constant B leaves the residual zero only at closure."""
        if e.dof != 1:
            return None
        n, s_lin = _motion_axes(e)
        if np.any(s_lin) or not np.any(n) or not (n[0] or n[1]):
            return None
        return _onto_z(n / np.linalg.norm(n))

    def close_loops(self, tree):
        """Each cut edge: closure residuals (redundant planar directions dropped), balance, drive."""
        if not self.cuts:
            return
        frames = [self._loop_axes(e) for e in self.cuts]
        turns = [self._loop_turn(e) for e in self.cuts]
        parts = [closure(e, self.kin[self.node_of[e.frame_a]], self.kin[self.node_of[e.frame_b]], R, B)
                 for e, (R, _), B in zip(self.cuts, frames, turns)]
        axes = [(name, "frame_a axes" if B is None else "frame_a axes turned onto the pins' axis")
                for (_, name), B in zip(frames, turns)]
        # residuals are written in the joint coordinates themselves (an expression along the loop's
        # tree path): index reduction must see which coordinates they constrain
        _, expanded = ca.substitute_inplace(self.let_symbols, self.let_values, [p[0] for p in parts], False)
        parts = [(r,) + p[1:] for r, p in zip(expanded, parts)]
        loops = []
        for k, e in enumerate(self.cuts):
            around = loop_edges(self.parent, self.node_of[e.frame_a], self.node_of[e.frame_b])
            loops.append(Loop(k + 1, e.path, tuple(j.path for j in around if j.dof) + (e.path,), 0, ()))
        coordinates = [q for _, q, _ in self.coordinates] + [e.coordinate() for e in self.cuts if e.dof]
        tunables = [(sym, value) for c in self.components for sym, value in c.tunable.values()]
        bases = reduce_redundancy(self.cuts, [r for r, _, _, _ in parts], coordinates,
                                  (self.let_symbols, self.let_values), tunables, lambda k: loops[k].describe(), axes)
        check_loop_mass(self, [ca.mtimes(ca.DM(K.T), r) for (r, _, _, _), (K, _) in zip(parts, bases) if K.shape[1]],
                             coordinates)
        for k, (e, (res, wrench, balance, drive), (K, N)) in enumerate(zip(self.cuts, parts, bases)):
            loop = replace(loops[k], kept=K.shape[1],
                           dropped=tuple(direction(N[:, j], *axes[k]) for j in range(N.shape[1])))
            tree.loops.append(loop)
            tree.equations.extend(closure_equations(e, loop, res, wrench, balance, drive, K, N, axes[k]))

    def scene_sensors(self, tree):
        """SystemEnergy and SystemMomentum: sums over the bodies (`tree_mass.sensor_equations`)."""
        for sensor, residual, doc in sensor_equations(self):
            _eq(tree, sensor, residual, doc)


def build_tree(components, graph: nx.Graph):
    """The tree's variables, equations, substitutions and observed expressions; None without frames."""
    t = _Tree(components, graph)
    if not t.frames:
        return None
    t.span()
    t.kinematics()
    tree = MultibodyTree({c.label: t.kin[t.node_of[c]] for c in t.frames}, t.coordinates, len(t.joint),
                         sum(isinstance(c, t.PartialBody) for c in components), t.world.path)
    t.dynamics(tree)
    t.check_pivots()
    t.mark_pivots(tree)
    t.frame_values(tree)
    t.cut_forces(tree)
    t.close_loops(tree)
    t.scene_sensors(tree)
    tree.observed.extend((name, None, unit, ca.SX(0)) for name, unit in tree.zeros)
    tree.intermediates = (tuple(t.let_symbols), tuple(t.let_values))
    return tree


def _defined(tree, comp, names, units, rhs, doc):
    """Unknowns equal to `rhs`, entry by entry; an entry that is exactly zero (a planar scene's
    out-of-plane accelerations and moments) stays the number 0 instead of becoming an unknown."""
    out = []
    for name, unit, value in zip(names, units, ca.vertsplit(ca.densify(ca.SX(rhs)))):
        if value.is_zero():
            out.append(ca.SX(0))
            tree.zeros.append((name, unit))
            continue
        sym = _new(tree, comp, [name], [unit])
        _eq(tree, comp, sym - value, doc)
        out.append(sym)
    return ca.vertcat(*out)


def _new(tree, comp, names, units):
    syms = []
    for name, unit in zip(names, units):
        s = ca.SX.sym(name)
        syms.append(s)
        tree.variables.append(FlatVariable(name=name, symbol=s, kind="algebraic", unit=unit, origin=comp.path,
                                           component_type=type(comp).__name__))
    return ca.vertcat(*syms)


def _eq(tree, comp, residual, doc, regular=False, pivot="", pivot_unless=()):
    residual = ca.reshape(ca.SX(residual), -1, 1)
    label = f"{comp.path} ({type(comp).__name__}), tree equation"
    for i in range(residual.numel()):
        tree.equations.append(FlatEquation(residual[i], comp.path, label + (f"[{i}]" if residual.numel() > 1 else ""),
                                           doc, regular=regular, pivot=pivot, pivot_unless=pivot_unless))
