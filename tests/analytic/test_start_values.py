"""Consistent initialisation (Core II): fixed values enforced, too few named, steady state."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import translational as tr
from mechnet.components import rotational as rot


def _loaded_spring(**mass_kw):
    m = mn.Model("loaded")
    wall = m.add(tr.Fixed(name="wall"))
    spring = m.add(tr.Spring(name="spring", c=400.0))
    mass = m.add(tr.Mass(name="mass", m=2.0, **mass_kw))
    damper = m.add(tr.Damper(name="damper", d=3.0))
    weight = m.add(tr.ConstantForce(name="weight", f_constant=-2.0 * 9.81))
    m.connect(wall.flange, spring.flange_a)
    m.connect(spring.flange_b, mass.flange_a)
    m.connect(mass.flange_b, damper.flange_b)
    m.connect(damper.flange_a, wall.flange)
    m.connect(weight.flange, mass.flange_b)
    return m.compile()


def test_steady_state_initialisation_finds_the_static_deflection():
    # der(s) = der(v) = 0: s = -m g / c, v = 0; Newton to 1e-10 (scale 5 cm)
    cm = _loaded_spring()
    res = cm.simulate(1.0, steady_state=True)
    assert res["mass.s"][0] == pytest.approx(-2.0 * 9.81 / 400.0, abs=1e-10)
    assert abs(res["mass.v"][0]) < 1e-10
    # and it stays there: rtol 1e-6, atol 1e-8 → within 1e-7 over 1 s
    assert np.max(np.abs(res["mass.s"] - res["mass.s"][0])) < 1e-7


def test_too_few_fixed_start_values_list_the_free_states():
    cm = _loaded_spring(s_start=0.0)
    with pytest.raises(mn.InitializationError, match=r"too few fixed start values.*mass\.v"):
        cm.simulate(1.0)


def test_steady_state_plus_a_fixed_state_is_over_specified():
    cm = _loaded_spring(s_start=0.0)
    with pytest.raises(mn.InitializationError, match=r"(?s)too many fixed start values.*mass\.s = 0.*der\(mass\.s\)"):
        cm.simulate(1.0, steady_state=True)


def test_directly_connected_inertias_share_one_set_of_states():
    # Two inertias flange to flange: 2 states; the common angle follows tau t²/(2 (J1 + J2)).
    # rtol = atol = 1e-10, horizon 1 s, scale 1 rad: < 1e-9.
    m = mn.Model("rigid")
    j1 = m.add(rot.Inertia(name="j1", J=1.0, phi_start=0.0, w_start=0.0))
    j2 = m.add(rot.Inertia(name="j2", J=3.0))
    src = m.add(rot.ConstantTorque(name="src", tau_constant=2.0))
    m.connect(src.flange, j1.flange_a)
    m.connect(j1.flange_b, j2.flange_a)
    cm = m.compile()
    assert cm.n_states == 2
    res = cm.simulate(1.0, rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(res["j2.phi"] - 2.0 * res.t**2 / (2 * 4.0))) < 1e-9


def _free_pair():
    """Two masses (1 kg, 3 kg) joined by a spring (c = 300 N/m, natural length 0), nothing else."""
    m = mn.Model("pair")
    m1 = m.add(tr.Mass(name="m1", m=1.0, v_start=0.0))
    m2 = m.add(tr.Mass(name="m2", m=3.0, v_start=0.0))
    spring = m.add(tr.Spring(name="spring", c=300.0))
    m.connect(m1.flange_b, spring.flange_a)
    m.connect(spring.flange_b, m2.flange_a)
    return m.compile()


def test_a_missing_start_value_shared_by_several_states_names_them_all():
    # the spring's stretch fixes s2 − s1 only: one more value is needed, for either mass, so both are named
    cm = _free_pair()
    with pytest.raises(mn.InitializationError,
                       match=r"too few fixed start values: 1 more fixed value is needed among the states "
                             r"m1\.s, m2\.s\b"):
        cm.simulate(0.1, start={"spring.s_rel": 0.1})


def test_the_pair_with_both_positions_fixed_oscillates_about_its_mass_centre():
    # Guard for the test above. s_rel = 0.1 cos(ω t), ω² = c (1/m1 + 1/m2) = 400; the mass centre stays at
    # (1·0 + 3·0.1)/4. rtol 1e-9, atol 1e-11, horizon 1 s (~3 periods), scale 0.1 m: within 1e-7 m.
    cm = _free_pair()
    res = cm.simulate(1.0, rtol=1e-9, atol=1e-11, start={"spring.s_rel": 0.1, "m1.s": 0.0})
    assert np.max(np.abs(res["m2.s"] - res["m1.s"] - 0.1 * np.cos(20.0 * res.t))) < 1e-7
    assert np.max(np.abs((res["m1.s"] + 3.0 * res["m2.s"]) / 4.0 - 0.075)) < 1e-9
