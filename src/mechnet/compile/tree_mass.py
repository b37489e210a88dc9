"""What the tree's bodies weigh and how they move (part of the tree pass, `spanning_tree.py`): the scene
sensors' energy and momentum, and whether a kinematic loop gives every joint's motion mass. Both sum
over the bodies with their motion in world axes (`body_motions`)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ..core.errors import StructureError


def _cross(a, b):
    return ca.cross(ca.SX(a), ca.SX(b))


def body_motions(t) -> list:
    """(m, r_cm, v_cm, I_cm, ω) of every body of the tree `t` (a `spanning_tree._Tree`), world axes."""
    out = []
    for n, bodies in t.bodies_at.items():
        k = t.kin[n]
        for body in bodies:
            m, r_cm, I = body.mass_properties()
            c = ca.mtimes(k.R, r_cm)
            out.append((m, k.r + c, k.v + _cross(k.w, c), ca.mtimes(k.R, ca.mtimes(I, k.R.T)), k.w))
    return out


def kinetic_energy(motions) -> ca.SX:
    return sum((0.5 * m * ca.dot(vc, vc) + 0.5 * ca.dot(w, ca.mtimes(Iw, w)) for m, _, vc, Iw, w in motions),
               ca.SX(0))


def sensor_equations(t) -> list:
    """(sensor, residual, doc) of every SystemEnergy and SystemMomentum: sums over the bodies (and the
    force elements' stored energy)."""
    from ..components.multibody.sensors import PartialSceneSensor, SystemEnergy, SystemMomentum
    sensors = [c for c in t.components if isinstance(c, PartialSceneSensor)]
    if not sensors:
        return []
    motions = body_motions(t)
    kinetic, potential = kinetic_energy(motions), ca.SX(0)
    for m, rc, _, _, _ in motions:
        potential -= t.world.mue * m / ca.norm_2(rc) if t.world.point_gravity else m * ca.dot(t.world.g, rc)
    for comp in t.components:
        stored = getattr(comp, "potential_energy", None)
        if callable(stored) and stored() is not None:
            potential += stored()
    out = []
    for sensor in sensors:
        if isinstance(sensor, SystemEnergy):
            out += [(sensor, sensor.kinetic - kinetic, "kinetic energy of all bodies"),
                    (sensor, sensor.potential - potential, "potential energy: gravity and force elements"),
                    (sensor, sensor.total - kinetic - potential, "total mechanical energy")]
        elif isinstance(sensor, SystemMomentum):
            p = sum((m * vc for m, _, vc, _, _ in motions), ca.SX.zeros(3))
            L = sum((_cross(rc - sensor.point, m * vc) + ca.mtimes(Iw, w) for m, rc, vc, Iw, w in motions),
                    ca.SX.zeros(3))
            out += [(sensor, sensor.p - p, "linear momentum"),
                    (sensor, sensor.L - L, "angular momentum about the point")]
    return out


def check_loop_mass(t, kept, coordinates):
    """A joint on a loop that moves no mass itself (`tree_dynamics._inward`) is well posed when the mechanism gives
    its freedom mass: the kinetic energy's Hessian M in the speeds, restricted to the motions the kept
    closures allow (null space Z of their Jacobian G), must be nonsingular. Judged at two random
    configurations, assembled (Gauss-Newton on the closures) where they can be; flange-driven coordinates
    count as driven (unit mass), cut coordinates carry none. Why not the spanning tree alone: where the
    loop is cut decides what lies 'beyond' a joint, and a slider-crank cut at its slider left the wrist
    pin with nothing beyond it but a particle on its axis, though the loop fixes that angle."""
    if not t._unmoved:
        return
    speeds = [qd for _, _, qd in t.coordinates]
    kinetic = kinetic_energy(body_motions(t))
    _, (kinetic,) = ca.substitute_inplace(t.let_symbols, t.let_values, [kinetic], False)
    qd = ca.vertcat(*speeds)
    M = ca.SX.zeros(len(coordinates), len(coordinates))
    M[:len(speeds), :len(speeds)] = ca.hessian(kinetic, qd)[0]
    joints = [t.joint[path][0] for path, _, _ in t.coordinates] + [e for e in t.cuts if e.dof]
    driven = [i for i, e in enumerate(joints) if getattr(e, "use_flange", False)]
    q = ca.vertcat(*coordinates)
    G = ca.jacobian(ca.vertcat(*kept), q) if kept else ca.SX(0, len(coordinates))
    tunables = [(sym, value) for c in t.components for sym, value in c.tunable.values()]
    p = ca.vertcat(*[sym for sym, _ in tunables]) if tunables else ca.SX(0, 1)
    pv = [v for _, v in tunables]
    fn = ca.Function("loop_mass", [q, qd, p], [M, G, ca.vertcat(*kept) if kept else ca.SX(0, 1)])
    rng = np.random.default_rng(2468)
    weak, judged = set(), 0
    for _ in range(2):
        qv = rng.uniform(-np.pi, np.pi, q.numel())
        for _ in range(30):                        # assemble: min-norm Newton steps onto the closures
            Mv, Gv, rv = (np.asarray(x) for x in fn(qv, np.zeros(qd.numel()), pv))
            if not rv.size or not np.all(np.isfinite(rv)) or np.max(np.abs(rv)) <= 1e-12:
                break
            qv = qv - np.linalg.lstsq(Gv, rv.ravel(), rcond=None)[0]
        assembled = not rv.size or (np.all(np.isfinite(rv)) and np.max(np.abs(rv)) <= 1e-9)
        if not (assembled and np.all(np.isfinite(Mv)) and np.all(np.isfinite(Gv))):
            continue                                # judge only configurations the loop can take
        judged += 1
        scale = max(np.trace(Mv), 1e-300)
        Mv[driven, driven] += scale                # a flange drives these: count them as heavy
        _, sv, Vt = np.linalg.svd(Gv) if Gv.size else (None, np.zeros(0), np.eye(q.numel()))
        Z = Vt[int(np.sum(sv > 1e-9 * max(sv.max(initial=0.0), 1e-300))):].T
        lam, vec = np.linalg.eigh(Z.T @ Mv @ Z)
        bad = [Z @ vec[:, i] for i in range(len(lam)) if lam[i] <= 1e-12 * scale]
        if not bad:
            return
        weak |= {e.path for v in bad for i, e in enumerate(joints) if abs(v[i]) > 1e-6 * np.max(np.abs(v))}
    if not judged:
        return
    named = [e for e in t._unmoved if e.path in weak] or t._unmoved
    one = len(named) == 1
    raise StructureError(
        ", ".join(f"joint {e.path} ({type(e).__name__})" for e in named)
        + (" moves" if one else " move") + " no mass: neither what lies beyond in the tree nor the kinematic "
        f"loop gives {'its' if one else 'their'} motion mass (or inertia about the axis), so the acceleration "
        "is undetermined; attach a Body that the loop moves, or drive a joint through its flange "
        "(use_flange=True)")
