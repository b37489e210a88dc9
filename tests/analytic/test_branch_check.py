"""Whole-branch check of the state selection (`mechnet/simulate/branch.py`).

A one-DOF loop moves on one closed curve of its coordinates, its assembly
branch, whatever the forces. The check traces that curve once; a selection
that stays regular and never loses to another by the monitor's hysteresis
factor on it needs no monitor, and the run is one integrator call. The traced
curves are compared with the closed-form loop closures; the scenes the monitor
must watch (toggle positions, a parallelogram's change points) must be refused.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from mechnet.components import rotational as rot
from mechnet.components.signals import Constant, Sine
from mechnet.simulate import branch

from models import four_bar, four_bar_angles, slider_crank, slider_crank_x

A, B, C, D = 0.2, 0.6, 0.5, 0.6          # Grashof crank-rocker (m)
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _wrap(x):
    return np.angle(np.exp(1j * x))


def _traced(cm, res):
    """(coordinate names, curve points) of the compiled model's branch through the run's start."""
    factory = cm.selection_factory
    check = factory._branch_check
    names = [factory.names[v] for v in check.coords]
    Q, why, _ = check.trace(np.array([res[n][0] for n in names]), np.array(cm.dae.p_value, dtype=float))
    assert Q is not None, why
    return names, Q


def _example(name):
    spec = importlib.util.spec_from_file_location(f"{name}_scene", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build()


def test_crank_rocker_runs_in_one_piece_on_the_freudenstein_curve():
    # Released at rest under gravity: no toggle position on a crank-rocker's branch, so the running
    # selection holds all round and the run is one IDAS call. The traced branch is checked point by
    # point against Freudenstein's closure (rocker and coupler angles of the crank angle): within 1e-9 rad
    # (Newton to 1e-12 in coordinates of scale 1 rad). It closes after one crank turn (2π within a step).
    cm = four_bar().compile()
    res = cm.simulate(2.0, rtol=1e-8, atol=1e-10)
    assert res.success
    assert res.stats["selection"].startswith("monitor off"), res.stats["selection"]
    assert res.stats["segments"] == 1 and not res.events
    names, Q = _traced(cm, res)
    th2 = Q[:, names.index("joint_a.phi")]
    th3, th4 = four_bar_angles(A, B, C, D, th2)
    assert np.max(np.abs(_wrap(Q[:, names.index("joint_d.phi")] - th4))) < 1e-9
    assert np.max(np.abs(_wrap(Q[:, names.index("joint_b.phi")] - (th3 - th2)))) < 1e-9
    assert abs(abs(th2[-1] - th2[0]) - 2 * np.pi) < branch.STEP
    assert np.max(np.abs(np.diff(th2))) <= 1.5 * branch.STEP          # no gap along the turn


def test_slider_crank_branch_is_the_closed_form_piston_curve():
    # Piston position x = r cos θ + √(l² − r² sin² θ) at every traced point, within 1e-10 m (scale
    # r = 0.1 m); the slider coordinate is not an angle, so the curve closes by returning to its start.
    r, l = 0.1, 0.35
    cm = slider_crank(r, l).compile()
    res = cm.simulate(1.0, rtol=1e-8, atol=1e-10)
    assert res.success and res.stats["segments"] == 1
    assert res.stats["selection"].startswith("monitor off"), res.stats["selection"]
    names, Q = _traced(cm, res)
    theta = Q[:, names.index("joint_a.phi")]
    assert np.max(np.abs(Q[:, names.index("slider.s")] - slider_crank_x(r, l, theta))) < 1e-10
    assert abs(abs(theta[-1] - theta[0]) - 2 * np.pi) < branch.STEP


def test_one_piece_run_matches_the_monitored_run(monkeypatch):
    # The four-bar of benchmarks/loops.py (5 N·m on the crank, 0.2 N·m·s crank damper, 6 turns in 2 s),
    # run once with the check and once with the monitor forced on: the crank angles agree within 1e-6 rad
    # over the run (38 rad of travel; each run's own error at rtol 1e-10, atol 1e-12 is ~1e-7 rad).
    def scene():
        m = four_bar(drive=rot.ConstantTorque(name="motor", tau_constant=5.0))
        damper = m.add(rot.Damper(name="damper", d=0.2))
        m.connect(m.fixed.flange, damper.flange_a)
        m.connect(damper.flange_b, m.joint_a.axis)
        return m.compile()

    settings = dict(rtol=1e-10, atol=1e-12, n_out=201)
    one = scene().simulate(2.0, **settings)
    assert one.stats["selection"].startswith("monitor off") and one.stats["segments"] == 1
    from mechnet.simulate.reselection import SelectionMonitor
    monkeypatch.setattr(SelectionMonitor, "whole_branch",
                        lambda self, values, params: branch.Verdict(False, "forced on by the test"))
    watched = scene().simulate(2.0, **settings)
    assert watched.stats["selection"] == "monitor on: forced on by the test" and watched.stats["segments"] > 1
    assert one.success and watched.success
    assert np.max(np.abs(one["joint_a.phi"] - watched["joint_a.phi"])) < 1e-6


def test_triple_rocker_is_left_to_the_monitor():
    # A non-Grashof four-bar reaches toggle positions, where every selection turns singular in turn:
    # nothing holds all round, the monitor runs and re-selects (tests/hard/test_loop_singularities.py).
    cm = four_bar(0.5, 0.4, 0.45, 0.6, theta2=1.5).compile()
    res = cm.simulate(1.0, rtol=1e-8, atol=1e-10)
    assert res.success
    assert res.stats["selection"].startswith("monitor on: the running selection's quality falls"), \
        res.stats["selection"]


def test_parallelogram_change_point_is_found_where_it_folds_flat():
    # A parallelogram (a = c, b = d) folds flat at crank angles 0 and π, where it meets the
    # anti-parallelogram branch: the constraint Jacobian loses rank for every selection, so no
    # selection can hold. The check reports the crossing within a step (0.1 rad) of a fold.
    cm = four_bar(0.3, 0.6, 0.3, 0.6, theta2=0.5).compile()
    res = cm.simulate(0.5, rtol=1e-8, atol=1e-10, start={"joint_a.w": 8.0})
    text = res.stats["selection"]
    assert text.startswith("monitor on: the branch crosses another (a change point) at joint_a.phi = "), text
    crank = float(text.split("joint_a.phi = ")[1].split(",")[0])
    assert min(abs(_wrap(crank)), abs(_wrap(crank - np.pi))) < branch.STEP


def test_geared_four_bar_switches_to_a_selection_that_holds():
    # examples/four_bar.py: a motor drives the crank through a gear. The running selection (coupler
    # angle) is poor at the start; the motor angle holds all round, so the run switches to it at t = 0
    # (one event naming both) and integrates in one piece. Energy: tests/examples/test_loop_examples.py.
    cm = _example("four_bar").compile()
    res = cm.simulate(1.0, rtol=1e-8, atol=1e-10)
    assert res.success and res.stats["segments"] == 1
    assert [e.kind for e in res.events] == ["reselection"] and res.events[0].t == 0.0
    assert "whole-branch selection" in res.events[0].cause and "-> motor.phi, motor.w" in res.events[0].cause
    assert res.stats["selection"].startswith("monitor off: states motor.phi, motor.w hold")


def test_crank_turned_at_constant_speed_runs_in_one_piece():
    # A Speed source at a constant 2 rad/s leaves no degree of freedom; the crank angle still moves on
    # the same closed curve, and the dependent block holds all round it: one piece, no monitor. The rocker
    # against Freudenstein's closure over 3 s (a turn), rtol 1e-10, atol 1e-11: within 1e-8 rad.
    cm = four_bar(drive=rot.Speed(name="motor", w_ref=Constant(2.0), phi_start=0.3)).compile()
    t = np.linspace(0.0, 3.0, 301)
    res = cm.simulate(3.0, rtol=1e-10, atol=1e-11, t_out=t)
    assert res.success
    assert res.stats["selection"].startswith("monitor off: the selection (no states: motion prescribed) holds")
    assert not res.events
    _, th4 = four_bar_angles(A, B, C, D, 0.3 + 2.0 * t)
    assert np.max(np.abs(_wrap(res["joint_d.phi"] - th4))) < 1e-8


def test_crank_given_as_a_function_of_time_is_not_checked():
    # A Position source makes the crank angle a function of time inside the constraints: the check does
    # not apply, says so, and the monitor watches the run.
    cm = four_bar(drive=rot.Position(name="motor", phi_ref=Sine(amplitude=3.0, f=0.5, offset=0.3))).compile()
    res = cm.simulate(0.5, rtol=1e-8, atol=1e-10)
    assert res.success
    assert res.stats["selection"] == "monitor on: the constraints depend on time"


@pytest.mark.parametrize("start", [0.3, 2.0])
def test_a_branch_is_traced_once_for_all_its_start_points(start):
    # Rerunning from the same start reuses the verdict. Another start on the same branch (the crank
    # 0.5 rad further) is recognised on the traced curve (its landing there is itself, to 1e-8) and
    # traced no more; a start on the crossed assembly (Freudenstein's other root) is traced anew.
    cm = four_bar().compile()

    def run(theta, branch_sign=+1):
        th3, th4 = four_bar_angles(A, B, C, D, theta, branch_sign)
        return cm.simulate(0.2, rtol=1e-6, atol=1e-8, start={"joint_a.phi": theta},
                           guess={"joint_b.phi": th3 - theta, "joint_d.phi": th4, "joint_c.phi": th4 - th3})

    first = run(start)
    factory = cm.selection_factory
    curves = lambda: sum(len(c) for c in factory._branch_curves.values())       # noqa: E731
    assert curves() == 1 and first.stats["selection"].startswith("monitor off")
    assert run(start).stats["selection"] == first.stats["selection"]
    moved = run(start + 0.5)
    assert curves() == 1 and moved.stats["selection"] == first.stats["selection"]
    crossed = run(start, -1)
    assert abs(_wrap(crossed["joint_d.phi"][0] - four_bar_angles(A, B, C, D, start, -1)[1])) < 1e-9
    assert curves() == 2 and crossed.stats["selection"].startswith("monitor off")


def test_five_bar_with_two_degrees_of_freedom_is_left_to_the_monitor():
    # A planar five-bar (two cranks from ground pivots 0.5 m apart, two couplers) has two degrees of
    # freedom: its coordinates fill a surface, not a curve, and the check says so. The run closes every
    # pin within 10·(rtol·L + atol), L = 0.5 m, rtol 1e-8, atol 1e-10, over 0.5 s under gravity.
    import mechnet as mn
    from mechnet.components import multibody as mb

    a1, b1, b2, a2, e = 0.2, 0.4, 0.4, 0.2, 0.5
    th1, th5 = 1.2, 1.8
    B = a1 * np.array([np.cos(th1), np.sin(th1)])
    Dp = np.array([e, 0.0]) + a2 * np.array([np.cos(th5), np.sin(th5)])
    # C on both circles |C - B| = b1, |C - D| = b2, above the line B-D
    dist = np.linalg.norm(Dp - B)
    along = (b1 ** 2 - b2 ** 2 + dist ** 2) / (2 * dist)
    u = (Dp - B) / dist
    Cp = B + along * u + np.sqrt(b1 ** 2 - along ** 2) * np.array([-u[1], u[0]])
    abs_angles = [th1, np.arctan2(*(Cp - B)[::-1]), np.arctan2(*(Dp - Cp)[::-1]), th5 + np.pi]
    rel = [abs_angles[0]] + [abs_angles[k] - abs_angles[k - 1] for k in range(1, 4)] + [-abs_angles[3]]

    m = mn.Model("five_bar")
    world = m.add(mb.World(name="world", g=[0.0, -9.81, 0.0]))
    ground = m.add(mb.FixedTranslation(name="ground", r=[e, 0, 0]))
    m.connect(world.frame_b, ground.frame_a)
    joints = []
    for k, name in enumerate("abcde"):
        fixed = {"phi_start": rel[k], "w_start": 0.0} if name in "ae" else {"phi_guess": rel[k]}
        joints.append(m.add(mb.Revolute(name=f"joint_{name}", n=[0, 0, 1], **fixed)))
    m.connect(world.frame_b, joints[0].frame_a)
    previous = joints[0].frame_b
    for k, L in enumerate((a1, b1, b2, a2)):
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[L, 0, 0]))
        body = m.add(mb.Body(name=f"body{k}", m=1.0, r_cm=[L / 2, 0, 0],
                             I=np.diag([0.0, L ** 2 / 12, L ** 2 / 12])))
        m.connect(previous, rod.frame_a)
        m.connect(rod.frame_a, body.frame_a)
        m.connect(rod.frame_b, joints[k + 1].frame_a)
        previous = joints[k + 1].frame_b
    m.connect(previous, ground.frame_b)

    cm = m.compile()
    assert cm.n_states == 4
    res = cm.simulate(0.5, rtol=1e-8, atol=1e-10)
    assert res.success, res.failure
    assert res.stats["selection"] == "monitor on: 2 degrees of freedom in the constraints (checked: one)"
    gap = max(np.max(np.abs(res[f"joint_{j}.frame_a.r_0[{i}]"] - res[f"joint_{j}.frame_b.r_0[{i}]"]))
              for j in "abcde" for i in range(3))
    assert gap <= 10 * (1e-8 * 0.5 + 1e-10)


def _phase_loop(r, reset=False):
    """A one-DOF loop of two angles (a, b) with the closure b − r·a + 2 sin(b − a) + 0.5 sin a = c0, driven
    by a torque on a (masses 0.01, light damping). Its Jacobians are 2π-periodic in both angles; the
    closure itself only for r = 1: otherwise the phase b − a drifts by about 2π(r − 1)/(1 + 2 cos(b − a))
    per turn, towards 2π/3, where ∂Φ/∂b vanishes. `reset`: a state event takes a back by one turn."""
    import casadi as ca
    import mechnet as mn

    phase = 1.3
    c0 = phase + 2.0 * np.sin(phase)

    class PhaseLoop(mn.Component):
        a = mn.State(priority="default")
        b = mn.State(priority="default")
        wa = mn.State(priority="default")
        wb = mn.State(priority="default")
        lam = mn.Var()

        def equations(self):
            s = self.b - self.a
            return [mn.Eq(mn.der(self.a), self.wa), mn.Eq(mn.der(self.b), self.wb),
                    mn.Eq(0.01 * mn.der(self.wa), 2.0 - 0.02 * self.wa
                          - self.lam * (-r - 2.0 * ca.cos(s) + 0.5 * ca.cos(self.a))),
                    mn.Eq(0.01 * mn.der(self.wb), -0.02 * self.wb - self.lam * (1.0 + 2.0 * ca.cos(s))),
                    mn.Eq(self.b - r * self.a + 2.0 * ca.sin(s) + 0.5 * ca.sin(self.a) - c0, 0.0, "closure")]

        def events(self):
            return (mn.When(self.a - 4.0, reset={self.a: self.a - 2 * np.pi}, direction="rising"),) if reset else ()

    m = mn.Model("phase_loop")
    m.add(PhaseLoop(name="d", a_start=0.0, b_guess=phase, wa_start=0.0))
    return m


def test_a_branch_that_does_not_close_is_left_to_the_monitor():
    # r = 1.004: each turn of a moves the phase by ~1e-2 rad, so after one turn the curve passes within a
    # step of its start without closing. Only landing on the start (to 1e-8) counts as closed: refused, and
    # the monitor re-selects as the phase nears 2π/3. Closure within 10·(rtol·scale + atol), scale 10 rad
    # (a turns ~3 times), rtol 1e-8, atol 1e-10, over 2 s.
    res = _phase_loop(1.004).compile().simulate(2.0, rtol=1e-8, atol=1e-10, n_out=401)
    assert res.stats["selection"].startswith("monitor on: the branch does not close"), res.stats["selection"]
    assert res.success, res.failure
    a, b = res["d.a"], res["d.b"]
    closure = b - 1.004 * a + 2.0 * np.sin(b - a) + 0.5 * np.sin(a) - (1.3 + 2.0 * np.sin(1.3))
    assert np.max(np.abs(closure)) < 10 * (1e-8 * 10.0 + 1e-10)


def test_the_same_loop_closing_exactly_runs_in_one_piece():
    # r = 1: the closure is periodic too, the curve lands on its start after one turn, and it holds.
    res = _phase_loop(1.0).compile().simulate(2.0, rtol=1e-8, atol=1e-10, n_out=401)
    assert res.stats["selection"].startswith("monitor off"), res.stats["selection"]
    assert res.success and res.stats["segments"] == 1


def test_a_state_event_that_sets_a_coordinate_keeps_the_monitor():
    # An event that writes a loop coordinate could put the run on another branch than the one checked.
    res = _phase_loop(1.0, reset=True).compile().simulate(2.0, rtol=1e-8, atol=1e-10, n_out=401)
    assert res.stats["selection"] == "monitor on: a state event resets d.a: the run may jump to another branch"
    assert res.success and sum(e.kind == "state" for e in res.events) >= 3        # a passes 4 rad, is set back
    assert np.max(res["d.a"]) < 4.0 + 1e-6


def test_piston_pushed_at_constant_speed_cannot_pass_its_dead_centre():
    # A Speed source moving the piston at 0.2 m/s: the piston would have to turn back at the dead centres
    # (x = l + r = 0.45 m), so the check refuses the branch (the crank would need an infinite speed there),
    # naming the prescribed coordinate; until then the run follows the closed form within 1e-8 m.
    from mechnet.components import translational as tr
    r, l = 0.1, 0.35
    cm = slider_crank(r, l, piston_drive=tr.Speed(name="pusher", v_ref=Constant(0.2))).compile()
    res = cm.simulate(0.015, rtol=1e-8, atol=1e-10)
    assert res.stats["selection"].startswith("monitor on: slider.s, turned at a prescribed rate, would have to "
                                             "turn back on the branch (a dead point) at "), res.stats["selection"]
    assert res.success
    x = res["slider.s"]
    assert np.max(np.abs(x - slider_crank_x(r, l, res["joint_a.phi"]))) < 1e-8
