"""A ball bouncing on a rigid floor until it comes to rest: impacts with restitution, a Zeno point.

floor ── Contact (e) ── ball (m) ── gravity

Each impact reverses the ball's speed times e (an impulse through the whole scene: here just the
ball). The bounces come ever faster and accumulate at T∞ = √(2h/g)·(1 + e)/(1 − e) = 4.06 s; there the
contact enters its rest mode (a "rest" event) and the ball lies on the floor for the rest of the run,
held by the contact force m·g. Before the first impact the ball falls freely: `reference(t)`.
"""
import numpy as np

import mechnet as mn
from mechnet.components import translational as tr

M, G, H0, E = 0.1, 9.81, 1.0, 0.8      # kg, m/s^2, m, 1

t_end = 6.0
plot = ["ball.s", "ball.v", "contact.f"]
description = "Bouncing ball: impacts with restitution, coming to rest at the accumulation point."


def build() -> mn.Model:
    m = mn.Model("bouncing_ball")
    floor = m.add(tr.Fixed(name="floor"))
    contact = m.add(tr.Contact(name="contact", e=E))
    ball = m.add(tr.Mass(name="ball", m=M, s_start=H0, v_start=0.0))
    gravity = m.add(tr.ConstantForce(name="gravity", f_constant=-M * G))
    m.connect(floor.flange, contact.flange_a)
    m.connect(contact.flange_b, ball.flange_a)
    m.connect(gravity.flange, ball.flange_b)
    return m


def reference(t):
    """Free fall until the first impact at √(2h/g) (NaN after: not compared)."""
    t = np.asarray(t, dtype=float)
    free = t < np.sqrt(2 * H0 / G) * 0.999
    return {"ball.s": np.where(free, H0 - 0.5 * G * t ** 2, np.nan)}


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    res = build().compile().simulate(t_end, n_out=601, rtol=1e-10, atol=1e-12)
    res.plot(plot).savefig("bouncing_ball.png")
    print([e for e in res.events if e.kind == "rest"])
