"""Cardan shaft: two shafts at an angle joined by a cross on two pins (Hooke's joint).

The input shaft (along x) turns at a constant 2 rad/s, driven by a `Speed` source through its
revolute's flange; the cross turns on two pins (z, then y) and drives the output shaft, tilted by
β = 0.4 rad in the x-y plane. The four revolutes form a spatial loop whose axes meet at one point (its
position closures are redundant and mechnet drops them). The output speed pulses twice per turn
between ω·cos β and ω/cos β: `reference(t)` is the textbook ratio cos β / (1 − sin²β cos²φ), φ the
input yoke's angle from the plane of the shafts (φ = input.phi + π/2 here: the yoke holds the first
pin, across that plane at the start).
"""
import numpy as np

import mechnet as mn
from mechnet import inertia
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import signals as sig

BETA, W_IN = 0.4, 2.0                  # rad between the shafts, rad/s input speed

t_end = 3.0
plot = ["input.w", "output.w"]
description = f"Cardan shaft at β = {BETA} rad: the output speed pulses between ω·cos β and ω/cos β."


def build() -> mn.Model:
    m = mn.Model("cardan_shaft")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    inp = m.add(mb.Revolute(name="input", n=[1, 0, 0], use_flange=True))
    motor = m.add(rot.Speed(name="motor", w_ref=sig.Constant(W_IN), phi_start=0.0))
    fixed = m.add(rot.Fixed(name="fixed"))
    yoke_in = m.add(mb.BodyCylinder(name="yoke_in", r=[0.2, 0, 0], diameter=0.04))
    pin_a = m.add(mb.Revolute(name="pin_a", n=[0, 0, 1]))
    pin_b = m.add(mb.Revolute(name="pin_b", n=[0, 1, 0]))
    cross = m.add(mb.Body(name="cross", m=0.2, I=inertia.sphere(0.2, 0.02)))
    tilt = m.add(mb.FixedRotation(name="tilt", n=[0, 0, 1], angle=BETA))
    out = m.add(mb.Revolute(name="output", n=[1, 0, 0]))
    yoke_out = m.add(mb.BodyCylinder(name="yoke_out", r=[0.2, 0, 0], diameter=0.04))
    for a, b in [(motor.flange, inp.axis), (fixed.flange, inp.support), (world.frame_b, inp.frame_a),
                 (inp.frame_b, yoke_in.frame_a), (inp.frame_b, pin_a.frame_a), (pin_a.frame_b, cross.frame_a),
                 (pin_a.frame_b, pin_b.frame_a), (world.frame_b, tilt.frame_a), (tilt.frame_b, out.frame_a),
                 (out.frame_b, yoke_out.frame_a), (out.frame_b, pin_b.frame_b)]:
        m.connect(a, b)
    return m


def reference(t):
    """Constant input speed and the textbook output speed at the input angle W_IN·t."""
    t = np.asarray(t, dtype=float)
    phi = W_IN * t + np.pi / 2
    ratio = np.cos(BETA) / (1 - np.sin(BETA) ** 2 * np.cos(phi) ** 2)
    return {"input.w": np.full_like(t, W_IN), "output.w": W_IN * ratio}
