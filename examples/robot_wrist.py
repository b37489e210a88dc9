"""A robot arm with a spherical wrist: three revolutes (base, shoulder, elbow) and a ball-joint wrist.

The arm's links are steel boxes (`BodyBox`: geometry and density give mass and inertia); the wrist is a
`Spherical` joint carrying a gripper block, so the hand swings freely in every direction (no Euler
angles: its orientation is a quaternion, renormalised at every integrator restart). Released from a
bent pose with the base turning, the unpowered arm falls under gravity and the hand tumbles; the
scene shows the wrist's quaternion and the energy, constant up to the integration error (no damping,
no drives: about 5e-6 relative at the default tolerances).
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb

G = 9.81

t_end = 2.0
plot = ["energy.total", "wrist.Q[0]", "wrist.Q[1]", "wrist.Q[2]", "wrist.Q[3]"]
description = "Unpowered arm with a spherical wrist falling from a bent pose: energy constant to ~1e-5 (default rtol)."


def build() -> mn.Model:
    m = mn.Model("robot_wrist")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -G]))
    base = m.add(mb.Revolute(name="base", n=[0, 0, 1], phi_start=0.0, w_start=1.0))
    column = m.add(mb.BodyBox(name="column", r=[0, 0, 0.4], width=0.12, density=2700.0))
    shoulder = m.add(mb.Revolute(name="shoulder", n=[0, 1, 0], phi_start=-0.6, w_start=0.0))
    upper = m.add(mb.BodyBox(name="upper", r=[0.5, 0, 0], width=0.08, density=2700.0))
    elbow = m.add(mb.Revolute(name="elbow", n=[0, 1, 0], phi_start=1.2, w_start=0.0))
    fore = m.add(mb.BodyBox(name="fore", r=[0.4, 0, 0], width=0.06, density=2700.0))
    wrist = m.add(mb.Spherical(name="wrist", axis_start=[1, 1, 0], angle_start=0.5, w_rel_start=[0.0, 2.0, 0.0]))
    hand = m.add(mb.BodyBox(name="hand", r=[0.15, 0, 0], width=0.1, height=0.04, density=2700.0))
    m.add(mb.SystemEnergy(name="energy"))
    chain = [(world.frame_b, base.frame_a), (base.frame_b, column.frame_a), (column.frame_b, shoulder.frame_a),
             (shoulder.frame_b, upper.frame_a), (upper.frame_b, elbow.frame_a), (elbow.frame_b, fore.frame_a),
             (fore.frame_b, wrist.frame_a), (wrist.frame_b, hand.frame_a)]
    for a, b in chain:
        m.connect(a, b)
    return m
