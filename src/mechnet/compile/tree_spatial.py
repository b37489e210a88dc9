"""The small spatial algebra of the tree pass: 6-vectors and 6x6 blocks in world axes.

A wrench is (moment about a reference point, force), a motion (angular, linear); the recursion moves
both between a link's reference point and its nodes, so only these few operations are needed.
"""
from __future__ import annotations

import casadi as ca


def blocks(a, b, c, d):
    """[[a, b], [c, d]]."""
    return ca.vertcat(ca.horzcat(a, b), ca.horzcat(c, d))


def cross(a, b):
    """a × b for numbers or expressions alike."""
    a = a if isinstance(a, ca.SX) else ca.SX(a)
    b = b if isinstance(b, ca.SX) else ca.SX(b)
    return ca.cross(a, b)


def skew(v):
    """[v]×: skew(v)·x = v × x."""
    return ca.skew(ca.SX(v))


def transport_wrench(w, d):
    """A wrench acting at a point d from the reference, expressed about the reference: the moment gains d × f."""
    return ca.vertcat(w[:3] + cross(d, w[3:]), w[3:])


def transport_inertia(I6, d):
    """Xᵀ I X for X = [[1, 0], [−[d]×, 1]] (the acceleration of a point at d from the reference)."""
    D = skew(d)
    eye, zero = ca.SX.eye(3), ca.SX(3, 3)
    X = blocks(eye, zero, -D, eye)
    return ca.mtimes(X.T, ca.mtimes(I6, X))
