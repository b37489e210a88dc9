"""Drive line with a torque step: energy balance and the time event (Core I b acceptance)."""
from __future__ import annotations

import numpy as np

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.signals import Step
from mechnet.components.rotational.interfaces import PartialTwoFlanges


class WorkMeter(PartialTwoFlanges):
    """Rigid pass-through that integrates the power flowing from flange_a to flange_b (exact work)."""

    W = mn.State(unit="J", doc="work passed through", priority="prefer")

    def equations(self):
        return [mn.Eq(self.flange_a.phi, self.flange_b.phi), mn.Eq(self.flange_a.tau + self.flange_b.tau, 0.0),
                mn.Eq(mn.der(self.W), self.flange_a.tau * mn.der(self.flange_a.phi))]


J_M, J_L, C, D_S, D_B, TAU, T_STEP = 0.05, 0.5, 2000.0, 0.5, 2.0, 10.0, 0.5


def _metered_drive_line():
    m = mn.Model("metered")
    torque = m.add(rot.Torque(name="torque", tau=Step(TAU, start_time=T_STEP)))
    w_in = m.add(WorkMeter(name="w_in", W_start=0.0))
    motor = m.add(rot.Inertia(name="motor", J=J_M, phi_start=0.0, w_start=0.0))
    shaft = m.add(rot.SpringDamper(name="shaft", c=C, d=D_S))
    load = m.add(rot.Inertia(name="load", J=J_L, phi_start=0.0, w_start=0.0))
    w_bearing = m.add(WorkMeter(name="w_bearing", W_start=0.0))
    bearing = m.add(rot.Damper(name="bearing", d=D_B))
    housing = m.add(rot.Fixed(name="housing"))
    m.connect(torque.flange, w_in.flange_b)      # the meter's flange_a faces the motor
    m.connect(w_in.flange_a, motor.flange_a)
    m.connect(motor.flange_b, shaft.flange_a)
    m.connect(shaft.flange_b, load.flange_a)
    m.connect(load.flange_b, w_bearing.flange_a)
    m.connect(w_bearing.flange_b, bearing.flange_b)
    m.connect(bearing.flange_a, housing.flange)
    return m


def test_input_work_equals_stored_plus_dissipated_energy():
    # Input work W_in = ΔE_stored + W_dissipated(shaft damper + bearing); the works are integrated as
    # states (exact to the solver tolerance), the shaft damper's dissipation is ∫ d_s w_rel² dt, also
    # integrated by the solver via a second meter-free route: W_shaft = W_in - ΔE - W_bearing must be ≥ 0
    # and equal ∫ d_s w_rel² dt (trapezoid on 40001 points, relative error ~1e-7 of W_in).
    # rtol = 1e-10, atol = 1e-10, horizon 4 s, scale W_in (≈ 60 J): |balance| < 1e-6 · W_in.
    cm = _metered_drive_line().compile()
    res = cm.simulate(4.0, rtol=1e-10, atol=1e-10, n_out=40001)
    assert res.success
    E = (0.5 * J_M * res["motor.w"] ** 2 + 0.5 * J_L * res["load.w"] ** 2
         + 0.5 * C * res["shaft.phi_rel"] ** 2)
    W_in = -res["w_in.W"]            # the meter measures power flowing toward the source side; sign flips
    W_bearing = res["w_bearing.W"]
    w_rel = res["shaft.w_rel"]
    after = res.t >= T_STEP
    W_shaft = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(res.t) * D_S * (w_rel[1:] ** 2 + w_rel[:-1] ** 2))])
    balance = W_in[-1] - (E[-1] - E[0]) - W_bearing[-1] - W_shaft[-1]
    assert W_in[-1] > 10.0
    assert abs(balance) < 1e-6 * W_in[-1], balance / W_in[-1]
    # before the step nothing moves
    assert np.all(np.abs(res["motor.w"][~after]) < 1e-12)


def test_step_time_is_an_event_and_a_grid_point():
    cm = _metered_drive_line().compile()
    res = cm.simulate(1.0, n_out=7)            # grid 0, 1/6, ... does not contain 0.5 by itself
    assert [e.t for e in res.events] == [T_STEP]
    assert res.events[0].kind == "time" and "torque.tau" in res.events[0].cause
    assert np.count_nonzero(res.t == T_STEP) == 1
    k = int(np.flatnonzero(res.t == T_STEP)[0])
    # the input is 0 before and TAU from the step on
    assert res["torque.tau"][k - 1] == 0.0 and res["torque.tau"][k] == TAU


def test_steady_speed_of_the_drive_line_example():
    # After the transients decay the load turns at tau / d_bearing. Slowest time constant of the
    # rigid drive line: (J_m + J_l)/d_b = 0.275 s; at t = 4 s (12.7 time constants) the error is
    # e^-12.7·5 = 1.5e-5 rad/s. rtol 1e-8, atol 1e-8: |w - 5| < 1e-4 (scale 5 rad/s).
    from mechnet.scene import load_scene
    from pathlib import Path

    scene = load_scene(Path(__file__).resolve().parents[2] / "examples" / "drive_line.py")
    res = scene.model().compile().simulate(scene.t_end, rtol=1e-8, atol=1e-8)
    assert abs(res["load.w"][-1] - TAU / D_B) < 1e-4
    assert abs(res["motor.w"][-1] - TAU / D_B) < 1e-4
