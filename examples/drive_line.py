"""A damped drive line started by a torque step: motor, elastic shaft, load on a damped bearing.

torque step ── motor (J_m) ── shaft (c, d) ── load (J_l) ── bearing damper ── housing

The motor torque jumps from 0 to 10 N·m at t = 0.5 s; the step is a time event,
so the integrator restarts exactly there. The shaft winds up, oscillates and
settles to the steady speed tau / d_bearing.
"""
import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.signals import Step

J_MOTOR, J_LOAD = 0.05, 0.5        # kg*m^2
C_SHAFT, D_SHAFT = 2000.0, 0.5     # N*m/rad, N*m*s/rad
D_BEARING = 2.0                    # N*m*s/rad
TAU, T_STEP = 10.0, 0.5            # N*m, s

t_end = 4.0
plot = ["motor.w", "load.w"]
description = "Drive line with a torque step (a time event) and damping."


def build() -> mn.Model:
    m = mn.Model("drive_line")
    torque = m.add(rot.Torque(name="torque", tau=Step(TAU, start_time=T_STEP)))
    motor = m.add(rot.Inertia(name="motor", J=J_MOTOR, phi_start=0.0, w_start=0.0))
    shaft = m.add(rot.SpringDamper(name="shaft", c=C_SHAFT, d=D_SHAFT))
    load = m.add(rot.Inertia(name="load", J=J_LOAD, phi_start=0.0, w_start=0.0))
    bearing = m.add(rot.Damper(name="bearing", d=D_BEARING))
    housing = m.add(rot.Fixed(name="housing"))
    m.connect(torque.flange, motor.flange_a)
    m.connect(motor.flange_b, shaft.flange_a)
    m.connect(shaft.flange_b, load.flange_a)
    m.connect(load.flange_b, bearing.flange_b)
    m.connect(bearing.flange_a, housing.flange)
    return m


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    res = build().compile().simulate(t_end)
    res.plot(plot).savefig("drive_line.png")
    print(res.events)
