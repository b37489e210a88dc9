"""Cart-pole from multibody parts: a pole hanging from a cart pushed along a rail (swing-up OCP in __main__).

World → Prismatic (x, driven through its axis flange by a translational Force `push.f`) → cart
Particle, and on the cart a Revolute about z → FixedTranslation (L down) → pole-tip Particle;
gravity along −y. The pole hangs at hinge.phi = 0 and stands upright at π. As a scene the input
stays at its default 0 N, so simulating it just lets the pole hang at rest. `optimize(cm)` (run by
`mechnet demo`, and by running this file) solves the swing-up: minimal ∫ push.f² dt over T_SWING s with |push.f| <= F_MAX, from hanging at rest to
upright at rest with the cart back at 0 (mechnet.ocp, direct collocation, verified by
re-simulation), and save the plot as cart_pole_swing_up.png in the working directory.
"""
import math

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import translational as tr

M_CART, M_TIP, L = 1.0, 0.3, 0.5      # kg, kg, m
T_SWING, F_MAX = 2.5, 30.0            # s, N

t_end = 5.0
plot = ["rail.s", "hinge.phi", "push.f"]
description = "Cart-pole from multibody parts (4 states); run the file for the swing-up OCP."


def build() -> mn.Model:
    m = mn.Model("cart_pole")
    world = m.add(mb.World(name="world"))
    rail = m.add(mb.Prismatic(name="rail", n=[1, 0, 0], use_flange=True, s_start=0.0, v_start=0.0))
    cart = m.add(mb.Particle(name="cart", m=M_CART))
    hinge = m.add(mb.Revolute(name="hinge", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
    pole = m.add(mb.FixedTranslation(name="pole", r=[0, -L, 0]))
    tip = m.add(mb.Particle(name="tip", m=M_TIP))
    ground = m.add(tr.Fixed(name="ground"))
    push = m.add(tr.Force(name="push"))
    m.connect(world.frame_b, rail.frame_a)
    m.connect(rail.frame_b, cart.frame_a)
    m.connect(rail.frame_b, hinge.frame_a)
    m.connect(hinge.frame_b, pole.frame_a)
    m.connect(pole.frame_b, tip.frame_a)
    m.connect(rail.support, ground.flange)
    m.connect(rail.axis, push.flange)
    return m


def optimize(cm, N: int = 80):
    """The swing-up on the compiled scene, solved by Radau collocation from the hanging start."""
    from mechnet import ocp

    prob = ocp.Problem(cm, t_final=T_SWING)
    prob.bounds("push.f", -F_MAX, F_MAX)
    for name, value in (("rail.s", 0.0), ("rail.v", 0.0), ("hinge.phi", math.pi), ("hinge.w", 0.0)):
        prob.subject_to(prob.at_end(prob.var(name)) == value)
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    return prob.solve(ocp.Collocation(N=N, degree=3))


if __name__ == "__main__":
    from pathlib import Path

    sol = optimize(build().compile())
    check = sol.verify()
    print(sol)
    print(f"re-simulation deviation {check['max_deviation']:.2e} ({check['worst']})")
    out = Path.cwd() / "cart_pole_swing_up.png"
    sol.plot(["push.f", "rail.s", "hinge.phi"]).savefig(out)
    print(f"plot saved to {out}")
