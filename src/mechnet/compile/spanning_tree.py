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

This module spans the tree and runs the stages in order; each stage is a function of the shared
state (`_Tree`) in its own module:

- `tree_kinematics`: positions, orientations, velocities; where nodes sit relative to each other;
- `tree_turns`: planar orientations as angle sums;
- `tree_dynamics`: the articulated-body recursion and the cut forces;
- `tree_pivots`: numerical checks on what the recursion divides by;
- `tree_loops`: closure equations of the cut edges (with `loops`, `tree_mass`);
- `tree_spatial`, `tree_equations`: spatial algebra; new unknowns and equations.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import networkx as nx

from ..core.errors import StructureError
from .tree_dynamics import cut_forces, dynamics
from .tree_equations import add_equations
from .tree_kinematics import FrameKinematics, frame_values, kinematics
from .loops import loop_edges
from .tree_loops import close_loops
from .tree_mass import sensor_equations
from .tree_pivots import check_pivots, mark_pivots

__all__ = ["FrameKinematics", "MultibodyTree", "build_tree", "span"]


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
                f"{sum(ca.SX(q).numel() for _, q, _ in self.coordinates)} joint coordinate(s), rooted at {self.world}"
                + (f", {len(self.loops)} kinematic loop(s)" if self.loops else ""))


def _roles():
    from ..components.multibody.interfaces import Frame, PartialBody, PartialTreeEdge
    from ..components.multibody.parts import World
    return Frame, PartialBody, PartialTreeEdge, World


class _Tree:
    """Working state of the pass for one scene, shared by its stages. Each stage adds what it finds:

    - here: `frames`, their connection sets `members` (the nodes) and `node_of`, the `world`, the
      state-only intermediates (`let`), and what the checks collect (`_pivots`, `_pivot_rows`,
      `_unmoved`);
    - `span`: `parent` (node -> (edge, forward, parent node)), `order` (breadth-first from the World),
      `children`, and the edges left out, `cuts` (`cut_ids`);
    - `tree_kinematics.kinematics`: `kin` (node -> FrameKinematics), links (`link_of`, `link_nodes`),
      `joint`, `coordinates`, the per-node `turn`, `step`, `step_norm2`, `from_link`, and which bodies
      and loads sit where (`bodies_at`, `loads_at`);
    - `tree_dynamics.dynamics`: the link accelerations `A`.
    """

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


def span(t):
    """Spanning tree from the World's node; the edges it leaves out close kinematic loops.

    Rigid edges are taken into the tree first, then joints driven through a flange, then plain
    joints: a loop is cut at a plain joint where it has one (its drive is then simply zero).
    Within each class, edges are taken in name order, so the choice is reproducible."""
    g = nx.MultiGraph()
    g.add_nodes_from(range(len(t.members)))
    for e in t.components:
        if isinstance(e, t.PartialTreeEdge):
            weight = 0 if not e.dof else (1 if getattr(e, "use_flange", False) else 2)
            g.add_edge(t.node_of[e.frame_a], t.node_of[e.frame_b], key=e.path, comp=e, weight=weight)
    kept = {key for _, _, key in nx.minimum_spanning_edges(g, algorithm="kruskal", keys=True, data=False)}
    root = t.node_of[t.world.frame_b]
    t.parent = {root: None}          # node -> (edge, forward: parent is frame_a's side, parent node)
    t.order = [root]
    for u in t.order:
        for _, v, key, data in sorted(g.edges(u, keys=True, data=True), key=lambda item: item[2]):
            if key in kept and v not in t.parent:
                e = data["comp"]
                t.parent[v] = (e, t.node_of[e.frame_a] == u, u)
                t.order.append(v)
    t.cuts = sorted((data["comp"] for _, _, key, data in g.edges(keys=True, data=True) if key not in kept),
                    key=lambda e: e.path)
    t.cut_ids = {id(e) for e in t.cuts}
    unreached = [k for k in range(len(t.members)) if k not in t.parent]
    if unreached:
        owners = sorted({c.owner for k in unreached for c in t.members[k]},
                        key=lambda c: (not isinstance(c, t.PartialBody), c.path))
        raise StructureError(
            f"no path to the World ({t.world.path}) from "
            + ", ".join(f"{c.path} ({type(c).__name__})" for c in owners[:6]) + (" …" if len(owners) > 6 else "")
            + "; connect them to the world through joints or fixed translations")
    t.children = {n: [] for n in t.order}
    for n in t.order[1:]:
        t.children[t.parent[n][2]].append(n)
    for e in t.cuts:
        around = loop_edges(t.parent, t.node_of[e.frame_a], t.node_of[e.frame_b]) + [e]
        several = [j for j in around if j.dof > 1]
        if several:
            raise StructureError(
                f"{several[0].path} ({type(several[0]).__name__}) lies on the kinematic loop closed at {e.path} "
                f"({type(e).__name__}): joints with several freedoms in a loop are not supported yet (spatial "
                f"loops come next); build the loop from revolute and prismatic joints")


def build_tree(components, graph: nx.Graph):
    """The tree's variables, equations, substitutions and observed expressions; None without frames."""
    t = _Tree(components, graph)
    if not t.frames:
        return None
    span(t)
    kinematics(t)
    tree = MultibodyTree({c.label: t.kin[t.node_of[c]] for c in t.frames}, t.coordinates, len(t.joint),
                         sum(isinstance(c, t.PartialBody) for c in components), t.world.path)
    dynamics(t, tree)
    check_pivots(t)
    mark_pivots(t, tree)
    frame_values(t, tree)
    cut_forces(t, tree)
    close_loops(t, tree)
    for sensor, residual, doc in sensor_equations(t):      # SystemEnergy, SystemMomentum: sums over the bodies
        add_equations(tree, sensor, residual, doc)
    tree.observed.extend((name, None, unit, ca.SX(0)) for name, unit in tree.zeros)
    tree.intermediates = (tuple(t.let_symbols), tuple(t.let_values))
    return tree
