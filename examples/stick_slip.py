"""Stick-slip: a block on a moving belt, held back by a spring — true stiction, no chattering.

wall ── spring (c) ── block (m) ── Friction (μs, μk) ── belt (v_belt)

The block rides on the belt (stuck: it moves at the belt's speed) until the spring pulls harder than
static friction holds (μs·m·g); it slips back, sliding against kinetic friction (μk·m·g) on a harmonic
arc, and sticks again when its speed reaches the belt's. The cycle repeats exactly: stick for
2(F_s − F_k)/(c·v_belt), slip for (π + 2α)/ω. Stuck is a mode, not a tiny velocity, so the block moves
with the belt exactly. Until the first breakaway `reference(t)` is the belt's motion.
"""
import numpy as np

import mechnet as mn
from mechnet.components import translational as tr
from mechnet.components.signals import Constant

M, C, G = 1.0, 20.0, 9.81          # kg, N/m, m/s^2
MU_S, MU_K, V_BELT = 0.4, 0.25, 0.2   # 1, 1, m/s

t_end = 8.0
plot = ["block.s", "block.v", "friction.mode"]
description = "Stick-slip oscillator on a belt: friction with true stiction (modes, no chattering)."


def build() -> mn.Model:
    m = mn.Model("stick_slip")
    wall = m.add(tr.Fixed(name="wall"))
    spring = m.add(tr.Spring(name="spring", c=C))
    block = m.add(tr.Mass(name="block", m=M, s_start=0.0, v_start=V_BELT))
    friction = m.add(tr.Friction(name="friction", fn=M * G, mu_k=MU_K, mu_s=MU_S))
    belt = m.add(tr.Speed(name="belt", v_ref=Constant(V_BELT), s_start=0.0))   # a signal: differentiable
    m.connect(wall.flange, spring.flange_a)
    m.connect(spring.flange_b, block.flange_a)
    m.connect(belt.flange, friction.flange_a)
    m.connect(friction.flange_b, block.flange_b)
    return m


def reference(t):
    """Stuck on the belt until the spring force reaches μs·m·g (NaN after: not compared)."""
    t = np.asarray(t, dtype=float)
    t_break = MU_S * M * G / C / V_BELT
    return {"block.s": np.where(t < t_break * 0.999, V_BELT * t, np.nan)}


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    res = build().compile().simulate(t_end, n_out=801, rtol=1e-10, atol=1e-12)
    res.plot(plot).savefig("stick_slip.png")
    print([e for e in res.events if e.kind == "state"][:6])
