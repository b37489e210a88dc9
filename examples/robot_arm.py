"""A three-link robot arm: revolute joints driven by motors through gears, with a torque profile.

Base joint about the vertical z axis (World gravity along −z), shoulder and
elbow about horizontal axes. Each joint is driven acausally through its 1D
flange: motor torque (a signal) → motor inertia → IdealGear → joint axis,
with a bearing damper on each motor. The reflected motor inertias J·ratio²
enter the joint dynamics through the connections. The demo plots the joint
angles and the tool-point height.
"""
import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import signals as sig
from mechnet.inertia import cylinder, rod

LINKS = [  # (axis, length of the link after the joint, mass of the link)
    ([0, 0, 1], 0.3, 4.0),
    ([0, 1, 0], 0.5, 3.0),
    ([0, 1, 0], 0.4, 1.5),
]
J_MOTOR, RATIO, D_MOTOR = 2e-4, 50.0, 2e-3

t_end = 2.0
plot = ["base.phi", "shoulder.phi", "elbow.phi", "tool.frame_a.r_0[2]"]
description = "Three-link robot arm driven by geared motors with torque profiles."


def build(driven: bool = True) -> mn.Model:
    """The arm; `driven=False` leaves the motor torques inputs ("base_torque.tau", ..., for `optimize`)."""
    m = mn.Model("robot_arm")
    world = m.add(mb.World(name="world", g=[0.0, 0.0, -9.81]))
    # motor torques (N·m, ×RATIO at the joint): turn the base, hold the shoulder against gravity
    # with a slow oscillation on top, and ramp the elbow's holding torque down
    profiles = [sig.Step(height=0.02, start_time=0.1),
                sig.Sine(amplitude=0.05, f=0.5, offset=-0.37),
                sig.Ramp(height=0.05, duration=1.0, offset=-0.08, start_time=0.5)]
    starts = [0.0, -0.6, 1.2]
    previous = world.frame_b
    for k, (name, (axis, length, mass)) in enumerate(zip(["base", "shoulder", "elbow"], LINKS)):
        joint = m.add(mb.Revolute(name=name, n=axis, use_flange=True, phi_start=starts[k], w_start=0.0))
        # link k: a rod along its local z (base) or x (others) with the motor housing's mass at its middle
        along = [0, 0, length] if k == 0 else [length, 0, 0]
        link = m.add(mb.FixedTranslation(name=f"{name}_link", r=along))
        shape = cylinder(mass, 0.04, length, axis=2) if k == 0 else rod(mass, length, axis=0)
        body = m.add(mb.Body(name=f"{name}_body", m=mass, r_cm=[x / 2 for x in along], I=shape))
        motor = m.add(rot.Inertia(name=f"{name}_motor", J=J_MOTOR, phi_start=starts[k] * RATIO, w_start=0.0))
        gear = m.add(rot.IdealGear(name=f"{name}_gear", ratio=RATIO))
        torque = m.add(rot.Torque(name=f"{name}_torque", **({"tau": profiles[k]} if driven else {})))
        bearing = m.add(rot.Damper(name=f"{name}_bearing", d=D_MOTOR))
        fixed = m.add(rot.Fixed(name=f"{name}_fixed"))
        m.connect(previous, joint.frame_a)
        m.connect(joint.frame_b, link.frame_a)
        m.connect(joint.frame_b, body.frame_a)
        m.connect(joint.support, fixed.flange)
        m.connect(torque.flange, motor.flange_a)
        m.connect(motor.flange_a, bearing.flange_b)
        m.connect(bearing.flange_a, fixed.flange)
        m.connect(motor.flange_b, gear.flange_a)
        m.connect(gear.flange_b, joint.axis)
        previous = link.frame_b
    tool = m.add(mb.Particle(name="tool", m=0.5))
    m.connect(previous, tool.frame_a)
    return m


def forward_kinematics(q):
    """Tool position for joint angles q = (base, shoulder, elbow), written out by hand."""
    def rz(a):
        return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])

    def ry(a):
        return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])

    R1 = rz(q[0])
    p1 = R1 @ np.array([0, 0, LINKS[0][1]])
    R2 = R1 @ ry(q[1])
    p2 = p1 + R2 @ np.array([LINKS[1][1], 0, 0])
    R3 = R2 @ ry(q[2])
    return p2 + R3 @ np.array([LINKS[2][1], 0, 0])


TARGET = [0.8, -0.2, 0.6]        # joint angles (rad) the arm moves to, rest to rest


def optimize(cm, N: int = 30, T: float = 1.5):
    """Point to point through the motors and gears: from the start pose to TARGET at rest in T seconds
    with the least ∫ Σ τ² dt (motor torques, |τ| <= 1 N·m). `cm` is the torque-profile scene; the problem
    compiles `build(driven=False)`, whose motor torques are inputs."""
    from mechnet import ocp

    free = build(driven=False).compile()
    prob = ocp.Problem(free, t_final=T)
    effort = 0
    for name, target in zip(["base", "shoulder", "elbow"], TARGET):
        prob.bounds(f"{name}_torque.tau", -1.0, 1.0)
        prob.subject_to(prob.at_end(prob.var(f"{name}.phi")) == target)
        prob.subject_to(prob.at_end(prob.var(f"{name}.w")) == 0.0)
        effort = effort + prob.var(f"{name}_torque.tau") ** 2
    prob.minimize(prob.integral(effort))
    return prob.solve(ocp.Collocation(N=N, degree=3))
