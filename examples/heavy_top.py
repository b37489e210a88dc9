"""Heavy symmetric top on a spherical pivot at its tip, started in steady precession.

The top (1 kg, mass centre l = 0.1 m up its symmetry axis = body z, inertias A_cm = 0.002 and
C = 0.004 kg·m²) stands on a `Spherical` joint at the world origin, gravity −z, tilted by θ0 = 0.5 rad
about world x and spinning at ω3 = 100 rad/s about its axis. Its start angular velocity is that of
steady precession at Ω, the slow root of A·Ω²·cos θ0 − C·ω3·Ω + m·g·l = 0 (A = A_cm + m·l², about
the pivot; Ω ≈ 2.63 rad/s): the axis then circles the vertical at the fixed tilt θ0, without
nutation. The plot shows the symmetry axis in world coordinates, the third column of the top's
orientation R (row-major: R[2], R[5], R[8] = cos θ); `reference(t)` is the closed form of that
steady precession, (sin θ0 sin Ωt, −sin θ0 cos Ωt, cos θ0).
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb

MASS, L, A_CM, C, G = 1.0, 0.1, 0.002, 0.004, 9.81   # kg, m, kg·m² (transverse, about the axis), m/s²
THETA0, SPIN = 0.5, 100.0                             # rad tilt from the vertical, rad/s about the axis
A = A_CM + MASS * L ** 2                              # transverse inertia about the pivot
OMEGA = (C * SPIN - np.sqrt((C * SPIN) ** 2 - 4 * A * np.cos(THETA0) * MASS * G * L)) / (2 * A * np.cos(THETA0))

t_end = 5.0
plot = ["top.frame_a.R[2]", "top.frame_a.R[5]", "top.frame_a.R[8]"]
description = f"Heavy symmetric top in steady precession at Ω = {OMEGA:.4f} rad/s (tilt 0.5 rad, spin 100 rad/s)."


def build() -> mn.Model:
    R0 = mb.frames.matrix_of_quaternion(mb.frames.quaternion_of_axis_angle([1, 0, 0], THETA0))
    # body rates: precession Ω about world z seen in body axes, plus the spin relative to the precessing plane
    w_body = R0.T @ np.array([0.0, 0.0, OMEGA]) + np.array([0.0, 0.0, SPIN - OMEGA * np.cos(THETA0)])
    m = mn.Model("heavy_top")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    pivot = m.add(mb.Spherical(name="pivot", R_rel_start=R0, w_rel_start=list(w_body)))
    top = m.add(mb.Body(name="top", m=MASS, r_cm=[0.0, 0.0, L], I=np.diag([A_CM, A_CM, C])))
    m.connect(world.frame_b, pivot.frame_a)
    m.connect(pivot.frame_b, top.frame_a)
    return m


def reference(t):
    """The symmetry axis in steady precession: tilt θ0 from +z, azimuth −π/2 + Ω·t."""
    t = np.asarray(t, dtype=float)
    s = np.sin(THETA0)
    return {"top.frame_a.R[2]": s * np.sin(OMEGA * t), "top.frame_a.R[5]": -s * np.cos(OMEGA * t),
            "top.frame_a.R[8]": np.full_like(t, np.cos(THETA0))}
