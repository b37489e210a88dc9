"""Absolute tolerances are scaled by nominal values: small quantities keep their relative accuracy."""
from __future__ import annotations

import numpy as np

import mechnet as mn
from mechnet.components import rotational as rot


def _tiny_oscillator(nominal):
    m = mn.Model("tiny")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=100.0))
    kw = {} if nominal is None else dict(phi_nominal=nominal, w_nominal=nominal * 30)
    j = m.add(rot.Inertia(name="j", J=0.1, phi_start=1e-7, w_start=0.0, **kw))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    return m.compile()


def test_nominal_values_scale_the_absolute_tolerance():
    # Amplitude 1e-7 rad, rtol = 1e-6, atol = 1e-8 (scaled by the nominal), horizon 1 s (5 periods).
    # Without a nominal, atol = 1e-8 is 10 % of the amplitude: the error is loose.
    # With phi_nominal = 1e-7, the effective atol is 1e-15: relative error < 1e-3 of the amplitude.
    omega = np.sqrt(1000.0)
    errors = {}
    for nominal in (None, 1e-7):
        res = _tiny_oscillator(nominal).simulate(1.0, rtol=1e-6, atol=1e-8)
        errors[nominal] = np.max(np.abs(res["j.phi"] - 1e-7 * np.cos(omega * res.t))) / 1e-7
    assert errors[1e-7] < 1e-3
    assert errors[None] > 10 * errors[1e-7]
