"""Numerical checks on the articulated inertias D that the outward pass divides by.

Exact zeros are caught while the recursion is built (`tree_dynamics`); what only numbers can tell —
a mass on a tilted axis, a link's own inertia along its joint — is judged here at random
configurations, once the whole tree is built.
"""
from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np

from ..core.errors import StructureError


def check_pivots(t):
    """A joint whose moving side has no mass or inertia along its freedom has D = 0 everywhere: its
    acceleration is undetermined. Exact zeros are caught while building; this catches the numerical
    ones (a mass on a tilted axis), at two random configurations, relative to the subtree's inertia."""
    if not t._pivots:
        return
    _, values, _ = at_random_configurations(
        t, ca.vertcat(*[ca.vertcat(ca.vec(D), scale) for _, D, scale in t._pivots]), 12345)
    start = 0
    for e, D, _ in t._pivots:
        n = D.shape[0]
        # the smallest eigenvalue of D (a joint with several freedoms: its least-moved direction)
        smallest = [np.min(np.abs(np.linalg.eigvalsh(v[start:start + n * n].reshape(n, n)))) for v in values]
        scales = [abs(v[start + n * n]) for v in values]
        start += n * n + 1
        if all(s <= 1e-12 * max(c, 1e-300) for s, c in zip(smallest, scales)) and n > 1:
            raise StructureError(
                f"joint {e.path} ({type(e).__name__}) moves no mass in some direction: what lies beyond it "
                f"has no inertia about some axis through the joint (a particle on a rod has none about the "
                f"rod), or a joint beyond it at the same point already gives that freedom, so that "
                f"acceleration is undetermined; give the body beyond it a rotational inertia (mb.Body with I, "
                f"e.g. mechnet.inertia.sphere), or remove the redundant joint")
        if all(s <= 1e-12 * max(c, 1e-300) for s, c in zip(smallest, scales)):
            raise StructureError(
                f"joint {e.path} ({type(e).__name__}) moves no mass: what lies beyond it has no mass "
                f"(or inertia) along its axis, or a joint beyond it at the same point already gives that "
                f"freedom, so its acceleration is undetermined; attach a Body off the axis, drive it "
                f"through its flange (use_flange=True), or remove the redundant joint")


def at_random_configurations(t, exprs, seed):
    """exprs in the joint coordinates (intermediates expanded), their values at rest at two random
    configurations with the tunable parameters at their values, and those parameters' symbols."""
    q = ca.vertcat(*[qs for _, qs, _ in t.coordinates])
    tunables = [(sym, value) for c in t.components for sym, value in c.tunable.values()]
    p = ca.vertcat(*[sym for sym, _ in tunables]) if tunables else ca.SX(0, 1)
    _, (exprs,) = ca.substitute_inplace(t.let_symbols, t.let_values, [exprs], False)
    speeds = ca.vertcat(*[qds for _, _, qds in t.coordinates])
    exprs = ca.substitute(exprs, speeds, ca.DM.zeros(speeds.numel()))
    fn = ca.Function("at_random", [q, p], [exprs])
    rng = np.random.default_rng(seed)
    return exprs, [np.asarray(fn(rng.uniform(-np.pi, np.pi, q.numel()), [v for _, v in tunables])).ravel()
                   for _ in range(2)], p


def mark_pivots(t, tree):
    """Keep a joint-acceleration row's pivot only where the link's own inertia along the joint's
    freedom, Sᵀ·M·S, is positive: the articulated inertia D is at least that, at every configuration
    (the children only add positive semi-definite terms), so dividing by D is safe. For a revolute
    joint it is the link's moment of inertia about its axis, for a prismatic one its mass; both are
    constants, checked numerically at two random configurations. Not when it depends on a tunable
    parameter (it could be set to zero per run): D may vanish where the link itself has no mass
    (a massless rod driven through its flange), and the block is then solved whole."""
    if not t._pivot_rows:
        return
    own, values, p = at_random_configurations(t, ca.vertcat(*[
        ca.vertcat(o, ca.trace(Mk[:3, :3]) + ca.trace(Mk[3:, 3:])) for _, o, Mk in t._pivot_rows]), 54321)
    for k, (index, _, _) in enumerate(t._pivot_rows):
        tuned = p.numel() > 0 and ca.depends_on(own[2 * k], p)
        if tuned or not all(v[2 * k] > 1e-9 * max(v[2 * k + 1], 1e-300) for v in values):
            tree.equations[index] = replace(tree.equations[index], pivot="", pivot_unless=())
