"""A joint that moves no mass itself is well posed when its loop determines it (issue 15, item 8).

The slider-crank of examples/slider_crank.py with the piston a `Particle` and a plain slider: the
compiler then cuts the loop at the slider, and the wrist pin stays in the spanning tree with only
the particle (on its axis) beyond it. The loop fixes the wrist angle, so the mechanism is well posed;
it used to be refused as "wrist_pin moves no mass". Both variants (the example's Body piston on a
flange-driven slider, cut at a pin; the Particle piston, cut at the slider) must follow the
closed form x = R cos θ + √(L² − R² sin² θ) and conserve energy.
"""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import translational as tr

R, L = 0.05, 0.2                       # m: crank radius and rod length, as in the example
THETA0, W0, G = 0.4, 12.0, 9.81        # rad, rad/s, m/s²: off dead centre, about 2 turns a second


def piston_x(theta):
    return R * np.cos(theta) + np.sqrt(L ** 2 - (R * np.sin(theta)) ** 2)


def _slider_crank(particle: bool) -> mn.Model:
    """The example's mechanism. particle=False: a Body piston, the slider driven through its flange by
    no force (the loop is cut at a plain pin, the crank's); particle=True: a Particle piston, a plain slider (cut
    at the slider, so the wrist pin carries only the particle on its axis)."""
    beta = -np.arcsin(R * np.sin(THETA0) / L)
    m = mn.Model("slider_crank_" + ("particle" if particle else "body"))
    world = m.add(mb.World(name="world", g=[0.0, -G, 0.0]))
    crank_j = m.add(mb.Revolute(name="crank_joint", n=[0, 0, 1], phi_start=THETA0, w_start=W0))
    rod_j = m.add(mb.Revolute(name="rod_joint", n=[0, 0, 1], phi_guess=float(beta - THETA0)))
    wrist = m.add(mb.Revolute(name="wrist_pin", n=[0, 0, 1], phi_guess=float(-beta)))
    slider = m.add(mb.Prismatic(name="slider", n=[1, 0, 0], use_flange=not particle,
                                s_guess=float(piston_x(THETA0))))
    crank = m.add(mb.FixedTranslation(name="crank", r=[R, 0, 0]))
    conrod = m.add(mb.FixedTranslation(name="conrod", r=[L, 0, 0]))
    flywheel = m.add(mb.Body(name="flywheel", m=2.0, I=np.diag([0.01, 0.01, 0.02])))
    rod_body = m.add(mb.Body(name="rod_body", m=0.4, r_cm=[L / 2, 0, 0], I=np.diag([0.0, 1.3e-3, 1.3e-3])))
    piston = m.add(mb.Particle(name="piston", m=0.5) if particle else
                   mb.Body(name="piston", m=0.5, I=np.diag([2e-4, 2e-4, 2e-4])))
    for a, b in ((world.frame_b, crank_j.frame_a), (crank_j.frame_b, flywheel.frame_a),
                 (crank_j.frame_b, crank.frame_a), (crank.frame_b, rod_j.frame_a),
                 (rod_j.frame_b, conrod.frame_a), (conrod.frame_a, rod_body.frame_a),
                 (conrod.frame_b, wrist.frame_a), (world.frame_b, slider.frame_a),
                 (slider.frame_b, piston.frame_a), (slider.frame_b, wrist.frame_b)):
        m.connect(a, b)
    if not particle:                   # the flange driven by no force: the slider is free all the same
        ground = m.add(tr.Fixed(name="ground"))
        push = m.add(tr.ConstantForce(name="push", f_constant=0.0))
        m.connect(slider.support, ground.flange)
        m.connect(slider.axis, push.flange)
    m.add(mb.SystemEnergy(name="energy"))
    return m


@pytest.mark.parametrize("particle, cut", [(False, "crank_joint"), (True, "slider")], ids=["body", "particle"])
def test_slider_crank_follows_the_closed_form_wherever_the_loop_is_cut(particle, cut):
    # 1 s (about 1.9 crank turns, both dead centres) at rtol = atol = 1e-9: the piston position against the
    # closed form for the simulated crank angle within 10·(rtol·L + atol) = 1.2e-8 m (stroke 0.1 m), and
    # the lossless mechanism's SystemEnergy (≈ 1.5 J) constant within 1e-6 relative (measured, both
    # variants: 8e-11 m and 6e-8).
    cm = _slider_crank(particle).compile()
    assert f"closed by {cut}" in cm.summary()
    rtol = 1e-9
    res = cm.simulate(1.0, rtol=rtol, atol=rtol, n_out=201)
    assert res.success, res.failure
    theta = res["crank_joint.phi"]
    assert theta[-1] > 3 * np.pi                    # both dead centres passed at least once
    assert np.max(np.abs(res["slider.s"] - piston_x(theta))) <= 10 * (rtol * L + rtol)
    total = res["energy.total"]
    assert np.max(np.abs(total - total[0])) <= 1e-6 * abs(total[0])
