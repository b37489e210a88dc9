"""A drive train with a clutch that engages and a brake that stops it: friction torques with stiction.

motor (J_m, spinning) ── clutch ── load (J_l) ── brake ── housing

The clutch is pressed at 0.5 s: it slips (3 N·m) until both sides turn together at 0.75 s and then
sticks. The brake, open until then (no normal force: it holds nothing and carries no torque), is
pressed at 2 s and stops the whole line at 2.2 s, then holds it at rest exactly (stuck, not creeping).
The inputs are steps (time events); each element starting to slide when pressed (at the step) and
each sticking are state events.
"""
import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.signals import Step

J_MOTOR, J_LOAD, W0 = 0.1, 0.3, 10.0      # kg*m^2, kg*m^2, rad/s

t_end = 3.0
plot = ["motor.w", "load.w", "clutch.tau", "brake.tau"]
description = "Clutch engaging and a brake stopping a drive line: stick and slip with modes."


def build() -> mn.Model:
    m = mn.Model("clutch_brake")
    motor = m.add(rot.Inertia(name="motor", J=J_MOTOR, phi_start=0.0, w_start=W0))
    clutch = m.add(rot.Clutch(name="clutch", fn_max=100.0, cgeo=0.1, mu_k=0.3, mu_s=0.4,
                              f_normalized=Step(1.0, start_time=0.5)))
    load = m.add(rot.Inertia(name="load", J=J_LOAD, phi_start=0.0, w_start=0.0))
    brake = m.add(rot.Brake(name="brake", fn_max=100.0, cgeo=0.1, mu_k=0.5, mu_s=0.6,
                            f_normalized=Step(1.0, start_time=2.0)))
    housing = m.add(rot.Fixed(name="housing"))
    m.connect(motor.flange_b, clutch.flange_a)
    m.connect(clutch.flange_b, load.flange_a)
    m.connect(housing.flange, brake.flange_a)
    m.connect(brake.flange_b, load.flange_b)
    return m


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    res = build().compile().simulate(t_end, n_out=301, rtol=1e-10, atol=1e-12)
    res.plot(plot).savefig("clutch_brake.png")
    print(res.events)
