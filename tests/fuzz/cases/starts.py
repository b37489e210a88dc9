"""Start values: fixed and guessed, at construction and in simulate(start=...), that over- or
under-specify the start, contradict a constraint, or put a body outside its stops."""
from __future__ import annotations

import math

import numpy as np

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from fuzz import fixtures
from fuzz.framework import Collector, close, expect
from models import cartesian_pendulum


def _rigid_pair(**starts):
    """Two inertias rigidly joined: one state pair; fixing both angles over-specifies."""
    m = mn.Model("pair")
    j1 = m.add(rot.Inertia(name="j1", J=1.0, **starts.get("j1", {})))
    j2 = m.add(rot.Inertia(name="j2", J=1.0, **starts.get("j2", {})))
    m.connect(j1.flange_b, j2.flange_a)
    return m.compile()


def _stopped(s_start):
    m = mn.Model("stopped")
    f = m.add(tr.Fixed(name="f"))
    stop = m.add(tr.HardStop(name="stop", s_min=-0.1, s_max=0.1, e=0.5))
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=s_start, v_start=0.0))
    m.connect(f.flange, stop.flange_a)
    m.connect(stop.flange_b, mass.flange_a)
    return m.compile().simulate(0.1)


def collector() -> Collector:
    col = Collector("starts")
    col.bad("rigid.both_angles", lambda: _rigid_pair(j1={"phi_start": 0.0}, j2={"phi_start": 1.0}).simulate(1.0),
            ("j1.phi", "j2.phi"))
    col.good("rigid.start_on_the_other", lambda: _rigid_pair(j1={"phi_start": 0.2}).simulate(
        1.0, n_out=3, start={"j2.w": 0.0}), "one angle and one speed, given on either inertia, fix the pair",
        lambda r: expect(close(r["j2.phi"], 0.2), "rests at 0.2"))
    col.bad("rigid.speeds_conflict", lambda: _rigid_pair(j1={"phi_start": 0.0, "w_start": 1.0}).simulate(
        1.0, start={"j2.w": 2.0}), ("j1.w", "j2.w"))
    col.bad("rigid.missing_starts", lambda: _rigid_pair().simulate(1.0, n_out=3), ("j1.phi", "j1.w"))
    col.bad("cartesian.off_circle", lambda: _cartesian({"p.x": 2.0}), ("p.x",))
    col.bad("cartesian.both_coordinates", lambda: _cartesian({"p.y": -0.5}), (("p.x", "p.y"),))
    col.bad("cartesian.speed_off_circle", lambda: _cartesian({"p.vy": 1.0}), (("p.vx", "p.vy"),))
    col.bad("stop.outside", lambda: _stopped(0.5), ("stop", "s_max"))
    col.bad("stop.outside_below", lambda: _stopped(-0.5), ("stop", "s_min"))
    col.good("stop.on_limit", lambda: _stopped(0.1), "a body resting on its limit is inside the stop",
             lambda r: expect(close(r["mass.s"], 0.1), "stays on the limit"))
    col.bad("start.output", lambda: fixtures.osc().simulate(1.0, start={"spring.tau": 1.0}),
    ("spring.tau", ("j1.phi",)),
            needs=("osc",))
    col.bad("start.time", lambda: fixtures.osc().simulate(1.0, start={"time": 1.0}), ("time",), needs=("osc",))
    col.bad("start.der", lambda: fixtures.osc().simulate(1.0, start={"der(j1.phi)": 1.0}), ("der(j1.phi)",),
            needs=("osc",))
    col.bad("start.index_past", lambda: _pendulum_start({"rev.frame_b.r_0[3]": 1.0}), ("rev.frame_b.r_0[3]",))
    col.bad("start.quaternion_zero", lambda: _ball_start({"ball.Q": 0.0}), ("ball.Q",))
    col.bad("start.quaternion_entry_nan", lambda: _ball_start({"ball.Q[0]": math.nan}), ("ball.Q[0]",))
    col.good("start.quaternion_unnormalised", lambda: _ball_start({"ball.Q[0]": 2.0}),
             "Q is unnormalised by design (R uses Q/|Q|); the first row shows it normalised",
             lambda r: expect(close(np.linalg.norm([r[f"ball.Q[{i}]"][0] for i in range(4)]), 1.0), "|Q| = 1"))
    col.bad("start.mode_not_a_mode_value", lambda: _friction_start({"fr.mode": 7.0}), ("fr.mode",))
    col.bad("start.guess_not_finite", lambda: fixtures.osc().simulate(1.0, guess={"spring.tau": math.inf}),
            ("spring.tau",), needs=("osc",))
    col.good("start.guess_far", lambda: _cartesian({}, guess={"p.y": 5.0}),
             "a guess only seeds Newton: a far one on the right side still converges",
             lambda r: expect(close(r["p.x"][0] ** 2 + r["p.y"][0] ** 2, 1.0), "on the circle"))
    return col


def _cartesian(start, guess=None):
    return cartesian_pendulum().compile().simulate(0.1, n_out=3, start=start, guess=guess)


def _pendulum_start(start):
    return fixtures.pendulum().simulate(0.1, start=start)


def _ball_start(start):
    m = mn.Model("top")
    world = m.add(mb.World(name="world"))
    ball = m.add(mb.Spherical(name="ball", Q_start=[1, 0, 0, 0], w_rel_start=[0, 0, 1.0]))
    body = m.add(mb.Body(name="body", m=1.0, r_cm=[0, 0, 0], I=np.diag([1.0, 2.0, 3.0])))
    m.connect(world.frame_b, ball.frame_a)
    m.connect(ball.frame_b, body.frame_a)
    return m.compile().simulate(0.1, n_out=3, start=start)


def _friction_start(start):
    m = mn.Model("block")
    f = m.add(tr.Fixed(name="f"))
    fr = m.add(tr.SupportFriction(name="fr", F_Coulomb=1.0))
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=1.0))
    m.connect(f.flange, fr.flange_a)
    m.connect(fr.flange_b, mass.flange_a)
    return m.compile().simulate(0.1, start=start)
