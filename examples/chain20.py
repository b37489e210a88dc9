"""A 20-link planar chain from 3D components, released horizontal at rest.

Unit masses at the link ends, unit lengths, revolute joints about z. The tree
pass compiles it to 40 states and an explicit ODE whose size grows linearly
with the number of links (about 130 operations per link); see
`benchmarks/chain3d.py` for the comparison with PyDy and hand-written models.
"""
import mechnet as mn
from mechnet.components import multibody as mb

N = 20

t_end = 5.0
plot = ["rev0.phi", "rev9.phi", "rev19.phi", "energy.total"]
description = "20-link pendulum chain from 3D components (O(N) compiled model)."


def build(n: int = N) -> mn.Model:
    m = mn.Model("chain20")
    world = m.add(mb.World(name="world"))
    m.add(mb.SystemEnergy(name="energy"))
    previous = world.frame_b
    for k in range(n):
        rev = m.add(mb.Revolute(name=f"rev{k}", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[1.0, 0, 0]))
        mass = m.add(mb.Particle(name=f"mass{k}", m=1.0))
        m.connect(previous, rev.frame_a)
        m.connect(rev.frame_b, rod.frame_a)
        m.connect(rod.frame_b, mass.frame_a)
        previous = rod.frame_b
    return m
