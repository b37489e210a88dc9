"""Crank-rocker four-bar driven by a geared motor: a closed kinematic loop of four revolute joints.

Planar mechanism in the x–y plane, every pin a plain `Revolute` about z, gravity
along −y. Ground pivots A = (0, 0) and D = (D, 0); crank A→B (length A), coupler
B→C (length B), rocker D→C (length C). Grashof: A + B < C + D with the crank the
shortest link, so the crank turns fully while the rocker swings. The pin at C
(`closing_joint`) is wired last, but which pin the spanning tree leaves out as
the cut joint is the compiler's choice (it reports it in `summary()`); it
drops the loop's three redundant out-of-plane closure constraints. Every link
is a slender rod with mass (m L²/12 about its middle).

The crank joint is driven through its 1D flange: a constant motor torque →
motor rotor (`rot.Inertia`, with a viscous bearing damper to the housing) →
`rot.IdealGear` (RATIO) → crank joint axis; the crank joint's support and the
damper's housing side are a `rot.Fixed`. The crank joint's phi_start/w_start
fix the start (THETA0, at rest); the rotor's angle is RATIO times the crank's
through the gear. The coupler and rocker guesses come from the circle
intersection at C (`assembly`, open branch: rocker above the ground line).
One degree of freedom: 2 states.
The bearing damper brings the crank to a mean speed near TAU·RATIO/(D_BEARING·RATIO²)
≈ 1 rev/s, with a speed ripple from gravity on the links. `energy` (SystemEnergy)
holds the links' kinetic and potential energy; the rotor's ½ J w² is not in it.
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import signals as sig
from mechnet.inertia import rod

A, B, C, D = 0.15, 0.5, 0.4, 0.45          # m: crank, coupler, rocker, ground (Grashof crank-rocker)
MASSES = {"crank": 0.5, "coupler": 1.0, "rocker": 0.8}    # kg, slender rods
G = 9.81
THETA0 = 0.3                               # rad: initial crank angle from +x
J_MOTOR, RATIO = 2e-4, 10.0                # kg·m², motor turns / crank turn
TAU = 0.4                                  # N·m at the motor (4 N·m at the crank)
D_BEARING = 6e-3                           # N·m·s/rad at the motor

t_end = 3.0
plot = ["crank_joint.phi", "crank_joint.w", "rocker_joint.phi", "energy.total"]
description = "Crank-rocker four-bar (one closed loop) driven by a geared motor with a constant torque."


def assembly(theta2, a=A, b=B, c=C, d=D):
    """Coupler and rocker angles (from +x) for the crank angle theta2, open branch.

    C is where the circle of radius b about the crank pin B meets the circle of
    radius c about the ground pivot D; of the two intersections, the one to the
    left of the line B→D (above the ground line) is the open assembly.
    """
    theta2 = np.asarray(theta2, dtype=float)
    bx, by = a * np.cos(theta2), a * np.sin(theta2)
    ex, ey = d - bx, -by
    L = np.hypot(ex, ey)
    p = (b ** 2 - c ** 2 + L ** 2) / (2 * L)          # along B→D from B
    h = np.sqrt(b ** 2 - p ** 2)                       # off the line, to its left
    cx = bx + (p * ex - h * ey) / L
    cy = by + (p * ey + h * ex) / L
    theta3 = np.arctan2(cy - by, cx - bx)
    theta4 = np.arctan2(cy, cx - d)
    return theta3, theta4


def build(d_bearing: float = D_BEARING, tau: float | None = TAU, theta0: float = THETA0) -> mn.Model:
    """The four-bar; `tau=None` leaves the motor torque an input ("motor_torque.tau", for `optimize`)."""
    th3, th4 = assembly(theta0)
    m = mn.Model("four_bar")
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    ground = m.add(mb.FixedTranslation(name="ground", r=[D, 0, 0]))
    crank_j = m.add(mb.Revolute(name="crank_joint", n=[0, 0, 1], use_flange=True, phi_start=theta0,
                                w_start=0.0))
    coupler_j = m.add(mb.Revolute(name="coupler_joint", n=[0, 0, 1], phi_guess=float(th3 - theta0)))
    rocker_j = m.add(mb.Revolute(name="rocker_joint", n=[0, 0, 1], phi_guess=float(th4)))
    closing_j = m.add(mb.Revolute(name="closing_joint", n=[0, 0, 1], phi_guess=float(th4 - th3)))
    links = {}
    for key, length in (("crank", A), ("coupler", B), ("rocker", C)):
        link = m.add(mb.FixedTranslation(name=key, r=[length, 0, 0]))
        body = m.add(mb.Body(name=f"{key}_body", m=MASSES[key], r_cm=[length / 2, 0, 0],
                             I=rod(MASSES[key], length, axis=0)))
        m.connect(link.frame_a, body.frame_a)
        links[key] = link
    m.connect(world.frame_b, ground.frame_a)
    m.connect(world.frame_b, crank_j.frame_a)
    m.connect(crank_j.frame_b, links["crank"].frame_a)
    m.connect(links["crank"].frame_b, coupler_j.frame_a)
    m.connect(coupler_j.frame_b, links["coupler"].frame_a)
    m.connect(ground.frame_b, rocker_j.frame_a)
    m.connect(rocker_j.frame_b, links["rocker"].frame_a)
    m.connect(links["coupler"].frame_b, closing_j.frame_a)     # closes the loop at C
    m.connect(closing_j.frame_b, links["rocker"].frame_b)

    # drive line: torque → rotor (with bearing loss) → gear → crank joint axis; housings fixed
    housing = m.add(rot.Fixed(name="housing"))
    torque = m.add(rot.Torque(name="motor_torque", **({} if tau is None else {"tau": sig.Constant(tau)})))
    motor = m.add(rot.Inertia(name="motor", J=J_MOTOR))      # its angle and speed follow the crank's
    bearing = m.add(rot.Damper(name="bearing", d=d_bearing))
    gear = m.add(rot.IdealGear(name="gear", ratio=RATIO))
    m.connect(torque.flange, motor.flange_a)
    m.connect(bearing.flange_a, housing.flange)
    m.connect(bearing.flange_b, motor.flange_a)
    m.connect(motor.flange_b, gear.flange_a)
    m.connect(gear.flange_b, crank_j.axis)
    m.connect(crank_j.support, housing.flange)

    m.add(mb.SystemEnergy(name="energy"))
    return m


def optimize(cm, N: int = 40, T: float = 1.0):
    """Minimal-effort move of the crank by 1 rad, rest to rest in T seconds, through the motor and gear:
    the loop's closure is part of the optimal control problem (collocation on the index-reduced DAE).
    `cm` is the constant-torque scene; the problem needs the torque as an input, so it compiles
    `build(tau=None)`. The states are the start's choice (the coupler joint's angle and speed); past
    about 1.3 rad of crank travel another choice is better and the solution is refused
    (`sol.stats["selection"]`)."""
    from mechnet import ocp

    driven = build(tau=None).compile()
    prob = ocp.Problem(driven, t_final=T)
    prob.bounds("motor_torque.tau", -1.0, 1.0)
    prob.subject_to(prob.at_end(prob.var("crank_joint.phi")) == THETA0 + 1.0)
    prob.subject_to(prob.at_end(prob.var("crank_joint.w")) == 0.0)
    prob.minimize(prob.integral(prob.var("motor_torque.tau") ** 2))
    return prob.solve(ocp.Collocation(N=N, degree=3))
