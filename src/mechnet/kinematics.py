"""Kinematic analysis: every frame's position, orientation and velocity for given joint coordinates.

No dynamics are evaluated: the tree pass already holds each frame as an
expression of the joint coordinates and speeds, and this evaluates them.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .caches import builds_symbols
from .core.declarations import finite_number
from .core.arguments import mapping
from .core.errors import InputError, MechnetError, SceneError, UnknownNameError


@builds_symbols
def kinematics(cm, q: dict | None = None, qd: dict | None = None, params: dict | None = None) -> dict:
    """{frame label: {"r_0", "R", "v_0", "w_0"}} (world components) at joint coordinates `q` and speeds `qd`.

    `q` and `qd` map joint paths (e.g. "arm.rev1") to a value, or to an array for a joint with several
    freedoms in its coordinate order (Spherical: q = Q (w, x, y, z), qd = w_rel; FreeMotion: q = (r_rel,
    Q), qd = (v_rel, w_rel); Universal: (phi_a, phi_b) ...); unspecified joints take their start values
    (or 0; a quaternion without one is the identity). `params` sets tunable parameters.
    """
    if not hasattr(cm, "stages") or "flat" not in getattr(cm, "stages", {}):
        raise MechnetError(f"kinematics() takes a compiled model (model.compile()), got {type(cm).__name__} "
                           f"{cm!r:.40}")
    q, qd, params = (mapping(v, f"kinematics({w}=...)", InputError) for v, w in ((q, "q"), (qd, "qd"),
                                                                                 (params, "params")))
    flat = cm.stages["flat"]
    tree = flat.multibody
    if tree is None:
        raise SceneError(f"model {cm.name!r} has no multibody frames: nothing for kinematics() to evaluate")
    joints = {path: (qs, qds) for path, qs, qds in tree.coordinates}
    for given, what in ((q or {}, "q"), (qd or {}, "qd")):
        unknown = sorted(set(given) - set(joints))
        if unknown:
            raise UnknownNameError(f"kinematics({what}=...): {', '.join(unknown)} is not a joint of the tree; "
                                   f"joints: {', '.join(joints) or 'none'}")
    starts = cm.dae.starts
    by_symbol = {v.symbol.element_hash(): v.name for v in flat.variables}
    q_syms = [qs for qs, _ in joints.values()] + [qds for _, qds in joints.values()]
    q_vals = []
    for given, what, k in ((q or {}, "q", 0), (qd or {}, "qd", 1)):
        for path, syms in joints.items():
            scalars = ca.vertsplit(ca.SX(syms[k]))     # a spherical joint: its quaternion, its angular velocity
            if path in given:
                values = np.ravel(np.asarray(given[path], dtype=object))
                if values.size != len(scalars):
                    raise InputError(f"kinematics({what}=...): {what}[{path!r}] needs {len(scalars)} number(s), "
                                     f"got {values.size}")
            else:
                values = [starts.get(by_symbol.get(s.element_hash()), 0.0) or 0.0 for s in scalars]
            values = [finite_number(v, f"kinematics({what}=...): {what}[{path!r}]", InputError) for v in values]
            if k == 0:
                values = _quaternions(flat, path, scalars, values, path in given, by_symbol)
            q_vals.extend(values)
    labels = sorted(tree.frames)
    outs = []
    for label in labels:
        k = tree.frames[label]
        outs.extend([k.r, ca.reshape(k.R, 9, 1), k.v, k.w])
    stacked = flat.expand([ca.vertcat(*outs)])[0]
    p_syms = [p.symbol for p in flat.parameters]
    unknown = sorted(set(params or {}) - {p.name for p in flat.parameters})
    if unknown:
        raise UnknownNameError(f"kinematics(params=...): {', '.join(unknown)} is not a tunable parameter; "
                               f"tunable parameters: {', '.join(p.name for p in flat.parameters) or 'none'}")
    p_vals = [finite_number((params or {}).get(p.name, p.value), f"kinematics(params=...): params[{p.name!r}]",
                            InputError) for p in flat.parameters]
    fn = ca.Function("kinematics", [ca.vertcat(*q_syms) if q_syms else ca.SX(0, 1),
                                    ca.vertcat(*p_syms) if p_syms else ca.SX(0, 1)], [stacked])
    values = np.asarray(fn(q_vals, p_vals), dtype=float).ravel()
    out, i = {}, 0
    for label in labels:
        r, R, v, w = values[i:i + 3], values[i + 3:i + 12].reshape(3, 3, order="F"), values[i + 12:i + 15], \
            values[i + 15:i + 18]
        out[label] = {"r_0": r, "R": R, "v_0": v, "w_0": w}
        i += 18
    return out


def _quaternions(flat, path, scalars, values, given, by_symbol):
    """A joint's coordinates with its quaternion (if any) checked: a zero quaternion given is refused by
    name, one left without a start is the identity."""
    groups = {n for _, names in flat.unit_quaternions for n in names}
    index = [i for i, s in enumerate(scalars) if by_symbol.get(s.element_hash()) in groups]
    if index and not any(values[i] for i in index):
        if given:
            raise InputError(f"kinematics(q=...): the quaternion in q[{path!r}] is zero, which is no "
                             f"orientation; the identity is [1, 0, 0, 0]")
        values = list(values)
        values[index[0]] = 1.0
    return values
