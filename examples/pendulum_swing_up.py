"""Pendulum minimum-time swing-up: a 1 kg bob on a 1 m rod, |motor torque| <= 4 N·m, from hanging to upright at rest.

The torque limit is below m·g·L = 9.81 N·m, so the pendulum cannot be lifted directly: it must swing
back and forth to gain energy. `build()` gives the pendulum with its motor (simulated unpowered it
just hangs); `optimize(cm)` finds the minimum-time swing-up by direct collocation and returns the
`mechnet.ocp.Solution` (the demo replays its controls with `cm.simulate` and plots it).
"""
from __future__ import annotations

import math

import mechnet as mn
from mechnet import ocp
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot

MASS, LENGTH, G = 1.0, 1.0, 9.81
TAU_MAX = 4.0                      # N·m, below m·g·L: a swing-up needs several swings
t_end = 2.0
plot = ["rev.phi", "rev.w"]


def build() -> mn.Model:
    m = mn.Model("pendulum_swing_up")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], use_flange=True, phi_start=-math.pi / 2, w_start=0.0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[LENGTH, 0, 0]))
    bob = m.add(mb.Particle(name="bob", m=MASS))
    motor = m.add(rot.Torque(name="motor"))          # the control "motor.tau", 0 unless given
    housing = m.add(rot.Fixed(name="housing"))
    m.connect(world.frame_b, rev.frame_a)
    m.connect(rev.frame_b, rod.frame_a)
    m.connect(rod.frame_b, bob.frame_a)
    m.connect(motor.flange, rev.axis)
    m.connect(housing.flange, rev.support)
    return m


def problem(cm) -> ocp.Problem:
    prob = ocp.Problem(cm, t_final=(1.0, 10.0))
    prob.bounds("motor.tau", -TAU_MAX, TAU_MAX)
    prob.subject_to(prob.at_end(prob.var("rev.phi")) == math.pi / 2)      # upright
    prob.subject_to(prob.at_end(prob.var("rev.w")) == 0.0)
    prob.minimize(prob.t_final)
    return prob


def optimize(cm, N: int = 60) -> ocp.Solution:
    return problem(cm).solve(ocp.Collocation(N=N, degree=3))


if __name__ == "__main__":
    sol = optimize(build().compile())
    print(sol, sol.verify()["max_deviation"])
    sol.plot().savefig("pendulum_swing_up.png")
