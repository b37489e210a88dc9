"""Which coordinates repeat after a whole turn (`simulate/winding.py`): decided on the structure of ode
and alg, one pass for every candidate, whatever the parameters and wherever the state.

Each case is a hand-written SX function with the verdict the mathematics gives: f(v + 2π) ≡ f(v) for
every value of the other arguments (exact statements, no tolerance)."""
from __future__ import annotations

import time
from types import SimpleNamespace

import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components.rotational.interfaces import PartialOneFlange
from mechnet.simulate.winding import TURN, periodic_inputs, turns_of, whole_turns

t, v, a, p = ca.SX.sym("t"), ca.SX.sym("v"), ca.SX.sym("a"), ca.SX.sym("p")

CASES = [
    ("sin and cos", ca.sin(v) * ca.cos(a) + ca.cos(v) ** 2, True),
    ("integer multiples and sums", ca.sin(2 * v - a) + ca.cos(-3 * (v + a)) + ca.tan(v / 0.5), True),
    ("anything after the sine", ca.sqrt(1 + ca.fmax(ca.sin(v), 0) ** 2) * a, True),
    ("a cancelled angle", ca.sin((v + a) - v) + a * ca.cos(v), True),
    ("time inside the sine (sin(v - w t))", ca.sin(v - 3.0 * t), True),
    ("the angle itself", 2.0 * v + ca.sin(v), False),
    ("a prescribed angle v - w t (a residual)", v - 3.0 * t, False),
    ("half the angle", ca.sin(0.5 * v), False),
    ("a tunable multiple (p v)", ca.sin(p * v), False),
    ("a spring with a tunable rate", -p * v, False),
    ("an end stop c·max(v − 10, 0)", 1e3 * ca.fmax(v - 10.0, 0.0), False),
    ("the angle beside its sine", ca.cos(v + ca.sin(v)), False),
    ("the angle squared", ca.sin(v * v), False),
]


@pytest.mark.parametrize("expr, periodic", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_periodic_in_the_angle(expr, periodic):
    f = ca.Function("f", [t, v, a, p], [expr])
    assert bool(periodic_inputs([f], [(1, 0)])[0]) is periodic


def test_all_candidates_in_one_pass_and_every_function():
    # one function of x = [v0, v1, v2], candidates all three: v0 only inside sines, v1 also linearly
    # in the second output, v2 inside sines in f but linear in g (every function must agree)
    x = ca.SX.sym("x", 3)
    f = ca.Function("f", [t, x], [ca.vertcat(ca.sin(x[0] + x[1]), x[1] + ca.cos(x[2]))])
    g = ca.Function("g", [t, x], [x[2] - t])
    assert periodic_inputs([f], [(1, 0), (1, 1), (1, 2)]).tolist() == [True, False, True]
    assert periodic_inputs([f, g], [(1, 0), (1, 1), (1, 2)]).tolist() == [True, False, False]


def _fake_dae(x_names, units, ode, z_names=(), alg=None):
    xs = ca.SX.sym("x", len(x_names))
    zs = ca.SX.sym("z", len(z_names))
    u, pp, d = ca.SX.sym("u", 0), ca.SX.sym("p", 0), ca.SX.sym("d", 0)
    args = [t, xs, zs, u, pp, d]
    out_alg = alg(xs, zs) if alg is not None else ca.SX(0, 1)
    return SimpleNamespace(x_names=tuple(x_names), z_names=tuple(z_names), units=units, info={},
                           ode=ca.Function("ode", args, [ode(xs, zs)]), alg=ca.Function("alg", args, [out_alg]))


def test_only_angles_count():
    # s (m) and φ (rad) both enter only through their sines: only φ is an angle; z = φ − 3t (a
    # prescribed angle, rad) is not periodic, ψ (rad) inside cos(ψ − 3t) is
    dae = _fake_dae(["s", "phi"], {"s": "m", "phi": "rad", "z": "rad", "psi": "rad"},
                    lambda x, z: ca.vertcat(ca.sin(x[0]), ca.sin(x[1]) + ca.cos(z[1] - 3 * t)),
                    z_names=["z", "psi"], alg=lambda x, z: ca.vertcat(z[0] - 3 * t, ca.sin(z[1]) - x[0]))
    px, pz = whole_turns(dae)
    assert px.tolist() == [0.0, TURN] and pz.tolist() == [0.0, TURN]
    assert whole_turns(dae) is dae.info["_whole_turns"]             # cached once per selection


def test_turns_of():
    assert turns_of([7.0, -7.0, 7.0, 3.0], np.array([TURN, TURN, 0.0, TURN])).tolist() == [TURN, -TURN, 0.0, 0.0]


class EndStop(PartialOneFlange):
    """No torque below 10 rad, c·(φ − 10) beyond."""
    c = mn.Param(1e3)

    def equations(self):
        return [mn.Eq(self.flange.tau, self.c * ca.fmax(self.flange.phi - 10.0, 0.0))]


def _compiled(element):
    m = mn.Model("wheel")
    j = m.add(rot.Inertia(name="j", J=1.0, phi_start=9.0, w_start=2.0))
    if element is not None:
        fixed = m.add(rot.Fixed(name="fixed"))
        m.add(element)
        m.connect(fixed.flange, element.flange_a)
        m.connect(element.flange_b, j.flange_a)
    else:
        stop = m.add(EndStop(name="stop"))
        m.connect(stop.flange, j.flange_a)
    return m.compile()


@pytest.mark.parametrize("element, periodic", [
    (None, False),                                                   # the end stop
    (rot.Spring(name="spring", c=mn.tunable(0.0)), False),           # a spring, whatever its rate
    (rot.Damper(name="damper", d=0.5), True),                        # a damper sees the speed only
], ids=["end stop", "tunable spring at c = 0", "damper"])
def test_compiled_scenes(element, periodic):
    dae = _compiled(element).dae
    px, _ = whole_turns(dae)
    assert bool(px[dae.x_names.index("j.phi")]) is periodic


@pytest.mark.slow
def test_a_hundred_link_chain_in_one_pass():
    # planar chain of 100 revolute joints (9966 ode instructions): every joint angle repeats after a
    # turn, the speeds (rad/s) are no candidates; the pass takes well under a second (measured 0.09 s,
    # the compilation 2.9 s)
    from analytic.test_multibody_acceptance import _chain
    dae = _chain(100).dae
    started = time.perf_counter()
    px, _ = whole_turns(dae)
    elapsed = time.perf_counter() - started
    assert {n for n, q in zip(dae.x_names, px) if q} == {f"rev{k}.phi" for k in range(100)}
    assert elapsed < 1.0, elapsed
