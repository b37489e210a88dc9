"""Tumbling satellite: a torque-free rigid body spun near its intermediate axis (the Dzhanibekov effect).

No gravity (World g = 0); a Body with principal inertias I = diag(0.3, 0.35, 0.4) kg·m² hangs on a
FreeMotion joint from the world, so `free.w_rel` is the body's angular velocity in body axes. Spun
at w = (0.5, 6, 1) rad/s, close to the intermediate axis y, the rotation is unstable: ω_y flips sign
every 6.55 s (half period 2K(k)/λ of the Jacobi elliptic solution) while ω_x and ω_z pulse. The
kinetic energy ½ Σ I ω² and |I·ω| are conserved. `reference(t)` is an independent solution: Euler's
equations of the same body integrated by SciPy (DOP853, rtol = atol = 1e-12). 13 states (position,
velocity, quaternion, body rates); the quaternion's |Q| − 1 is watched as an invariant.
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb

I_BODY = np.array([0.3, 0.35, 0.4])     # kg·m²: principal moments, y the intermediate axis
MASS = 2.0                              # kg (plays no part without forces)
W0 = (0.5, 6.0, 1.0)                    # rad/s in body axes: near the intermediate axis

t_end = 20.0
plot = ["free.w_rel[0]", "free.w_rel[1]", "free.w_rel[2]"]
description = ("Torque-free body spun near its intermediate axis: ω_y flips sign every 6.55 s "
               "(reference: Euler's equations, SciPy DOP853).")


def build() -> mn.Model:
    m = mn.Model("tumbling_satellite")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, 0.0]))
    free = m.add(mb.FreeMotion(name="free", Q_start=[1.0, 0.0, 0.0, 0.0], w_rel_start=list(W0),
                               r_rel_start=[0.0, 0.0, 0.0], v_rel_start=[0.0, 0.0, 0.0]))
    body = m.add(mb.Body(name="body", m=MASS, I=np.diag(I_BODY)))
    m.connect(world.frame_b, free.frame_a)
    m.connect(free.frame_b, body.frame_a)
    return m


def reference(t):
    """Euler's equations I·dω/dt = (I·ω) × ω in body axes, integrated with SciPy."""
    from scipy.integrate import solve_ivp

    I1, I2, I3 = I_BODY

    def euler(_, w):
        return [(I2 - I3) / I1 * w[1] * w[2], (I3 - I1) / I2 * w[2] * w[0], (I1 - I2) / I3 * w[0] * w[1]]

    t = np.atleast_1d(t)
    sol = solve_ivp(euler, (0.0, float(t[-1])), W0, t_eval=t, method="DOP853", rtol=1e-12, atol=1e-12)
    return {f"free.w_rel[{i}]": sol.y[i] for i in range(3)}
