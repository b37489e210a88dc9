"""Spherical pendulum on a conical orbit: a small ball on a 1 m rod from a spherical joint.

A solid sphere (1 kg, radius 5 cm — it needs inertia about the rod: a point mass would leave the
spin about the rod undetermined) hangs on a massless rod of length L = 1 m from a `Spherical` joint at
the world origin, gravity −z. Tilted by α = 0.6 rad about world x and started circling the vertical
at the conical rate √(g/(L cos α)) (`w_rel_a_start`, resolved in the world), it stays on its cone:
the bob runs round the horizontal circle of radius L sin α at height −L cos α. `reference(t)` is
that circle, (−L sin α sin ωt, L sin α cos ωt, −L cos α); the sphere's isotropic inertia adds no
gyroscopic moment, so the rate is the point-mass pendulum's.
"""
import numpy as np

import mechnet as mn
from mechnet import inertia
from mechnet.components import multibody as mb

L, ALPHA, G = 1.0, 0.6, 9.81           # m rod, rad cone half-angle, m/s²
MASS, RADIUS = 1.0, 0.05               # kg, m: the ball
RATE = np.sqrt(G / (L * np.cos(ALPHA)))

t_end = 5.0
plot = ["bob.frame_a.r_0[0]", "bob.frame_a.r_0[1]", "bob.frame_a.r_0[2]"]
description = f"Conical pendulum on a spherical joint: the bob circles at √(g/(L cos α)) = {RATE:.4f} rad/s."


def build() -> mn.Model:
    m = mn.Model("spherical_pendulum")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    ball = m.add(mb.Spherical(name="ball", axis_start=[1, 0, 0], angle_start=ALPHA, w_rel_a_start=[0, 0, RATE]))
    rod = m.add(mb.FixedTranslation(name="rod", r=[0.0, 0.0, -L]))
    bob = m.add(mb.Body(name="bob", m=MASS, I=inertia.sphere(MASS, RADIUS)))
    m.connect(world.frame_b, ball.frame_a)
    m.connect(ball.frame_b, rod.frame_a)
    m.connect(rod.frame_b, bob.frame_a)
    return m


def reference(t):
    """The bob on its circle: tilted by α about x (start at azimuth +π/2), turning at RATE about +z."""
    t = np.asarray(t, dtype=float)
    r = L * np.sin(ALPHA)
    return {"bob.frame_a.r_0[0]": -r * np.sin(RATE * t), "bob.frame_a.r_0[1]": r * np.cos(RATE * t),
            "bob.frame_a.r_0[2]": np.full_like(t, -L * np.cos(ALPHA))}
