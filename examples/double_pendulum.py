"""Double pendulum from 3D components: two revolute joints, two rods, two point masses.

World → Revolute → FixedTranslation → Particle → Revolute → FixedTranslation →
Particle, all joints about z, gravity along −y. The planar scene compiles to
the planar size: 4 states, an explicit ODE. `energy.total` (a SystemEnergy
sensor) is conserved; `reference(t)` is the same pendulum from Lagrange's
equations in absolute angles, integrated with SciPy, given for t ≤ 1 s only
(the motion is chaotic: later differences measure the chaos, not the model).
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb

M1, M2, L1, L2, G = 1.0, 1.0, 1.0, 1.0, 9.81
PHI1, PHI2 = 0.5, 0.8     # rad: link 1 from the +x axis, link 2 relative to link 1

t_end = 10.0
plot = ["link1.phi", "link2.phi", "energy.total"]
description = "Double pendulum from 3D multibody components (4 states, explicit ODE)."


def build() -> mn.Model:
    m = mn.Model("double_pendulum")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    link1 = m.add(mb.Revolute(name="link1", n=[0, 0, 1], phi_start=PHI1, w_start=0.0))
    rod1 = m.add(mb.FixedTranslation(name="rod1", r=[L1, 0, 0]))
    mass1 = m.add(mb.Particle(name="mass1", m=M1))
    link2 = m.add(mb.Revolute(name="link2", n=[0, 0, 1], phi_start=PHI2, w_start=0.0))
    rod2 = m.add(mb.FixedTranslation(name="rod2", r=[L2, 0, 0]))
    mass2 = m.add(mb.Particle(name="mass2", m=M2))
    m.add(mb.SystemEnergy(name="energy"))
    m.connect(world.frame_b, link1.frame_a)
    m.connect(link1.frame_b, rod1.frame_a)
    m.connect(rod1.frame_b, mass1.frame_a)
    m.connect(rod1.frame_b, link2.frame_a)
    m.connect(link2.frame_b, rod2.frame_a)
    m.connect(rod2.frame_b, mass2.frame_a)
    return m


def reference(t):
    """Lagrange's equations in the absolute angles a1 = phi1, a2 = phi1 + phi2 (from +x, gravity −y)."""
    from scipy.integrate import solve_ivp

    def rhs(_, s):
        a1, a2, w1, w2 = s
        c = np.cos(a1 - a2)
        sn = np.sin(a1 - a2)
        M = np.array([[(M1 + M2) * L1 ** 2, M2 * L1 * L2 * c], [M2 * L1 * L2 * c, M2 * L2 ** 2]])
        f = np.array([-M2 * L1 * L2 * sn * w2 ** 2 - (M1 + M2) * G * L1 * np.cos(a1),
                      M2 * L1 * L2 * sn * w1 ** 2 - M2 * G * L2 * np.cos(a2)])
        return [w1, w2, *np.linalg.solve(M, f)]

    t = np.atleast_1d(t)
    sol = solve_ivp(rhs, (0.0, float(t[-1])), [PHI1, PHI1 + PHI2, 0.0, 0.0], t_eval=t, rtol=1e-12,
                    atol=1e-12, method="DOP853")
    early = np.where(t <= 1.0, 1.0, np.nan)
    return {"link1.phi": sol.y[0] * early, "link2.phi": (sol.y[1] - sol.y[0]) * early}
