"""The closed-loop scene files (four_bar, slider_crank, six_bar): physics checks beyond "runs and stays finite".

Each scene file is imported as a module, so the tests can call `build()` with other
arguments and use the scene's own closed forms (circle intersections, the piston
position). Closure residuals compare the two frames of every pin, the cut one
included: they coincide within 10·(rtol·L + atol), L the longest link.
"""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _scene(name):
    spec = importlib.util.spec_from_file_location(f"loop_example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def four_bar():
    return _scene("four_bar")


@pytest.fixture(scope="module")
def slider_crank():
    return _scene("slider_crank")


@pytest.fixture(scope="module")
def six_bar():
    return _scene("six_bar")


def _wrap(x):
    return np.angle(np.exp(1j * np.asarray(x, dtype=float)))


def _closure_gap(res, pins):
    """Largest distance, over the run and the x, y, z components, between the two frames of any pin."""
    return max(float(np.max(np.abs(res[f"{p}.frame_a.r_0[{i}]"] - res[f"{p}.frame_b.r_0[{i}]"])))
               for p in pins for i in range(3))


# --- four-bar ------------------------------------------------------------------------------------------------

FOUR_BAR_PINS = ("crank_joint", "coupler_joint", "rocker_joint", "closing_joint")


def test_four_bar_motor_work_equals_energy_gain(four_bar):
    # Lossless drive line (bearing d = 0), constant motor torque 0.1 N·m (1 N·m at the crank): the motor's
    # work τ·Δφ_motor equals ΔE of the links (SystemEnergy) plus the rotor's ½ J w². One degree of freedom
    # (2 states). rtol = atol = 1e-10, horizon 1.5 s (the crank turns about 1.4 times), scale max|W|
    # (≈ 8.9 J): |ΔE − W| < 1e-6·max|W| (measured 5.4e-8 J, 6e-9 relative). The rotor's energy (≈ 4.3 J at
    # the end) and the gear (motor angle = RATIO · crank angle, to 1e-9 rad) are part of the check.
    tau, rtol = 0.1, 1e-10
    cm = four_bar.build(d_bearing=0.0, tau=tau).compile()
    assert cm.n_states == 2
    res = cm.simulate(1.5, rtol=rtol, atol=rtol, n_out=16)
    assert res.success, res.failure
    rotor = 0.5 * four_bar.J_MOTOR * res["motor.w"] ** 2
    energy = res["energy.total"] + rotor
    work = tau * (res["motor.phi"] - res["motor.phi"][0])
    assert np.max(np.abs(work)) > 5.0                                   # the motor really drives
    assert rotor[-1] > 1.0                                              # the rotor's share is not negligible
    assert res["crank_joint.phi"][-1] - res["crank_joint.phi"][0] > 2 * np.pi
    assert np.max(np.abs(energy - energy[0] - work)) < 1e-6 * np.max(np.abs(work))
    assert np.max(np.abs(res["motor.phi"] - four_bar.RATIO * res["crank_joint.phi"])) < 1e-9
    assert _closure_gap(res, FOUR_BAR_PINS) <= 10 * (rtol * four_bar.B + rtol)


def test_four_bar_scene_closes_on_the_open_branch(four_bar):
    # The scene as demoed (bearing damper, crank from rest): over 2 s (about 1.9 crank turns) at
    # rtol = atol = 1e-9 the rocker and coupler angles follow the circle intersection for the simulated
    # crank angle within 1e-6 rad (measured 1.6e-10), and every pin's frames coincide within
    # 10·(rtol·L + atol) = 1.5e-8 m, L = 0.5 m the coupler (measured 6e-11).
    rtol = 1e-9
    cm = four_bar.build().compile()
    res = cm.simulate(2.0, rtol=rtol, atol=rtol, n_out=21)
    assert res.success, res.failure
    crank = res["crank_joint.phi"]
    assert crank[-1] - crank[0] > 2 * np.pi                               # a crank-rocker: the crank turns
    assert crank[0] == pytest.approx(four_bar.THETA0, abs=1e-12)
    th3, th4 = four_bar.assembly(crank)
    assert np.max(np.abs(_wrap(res["rocker_joint.phi"] - th4))) < 1e-6
    assert np.max(np.abs(_wrap(res["coupler_joint.phi"] - (th3 - crank)))) < 1e-6
    assert np.max(np.abs(_wrap(res["closing_joint.phi"] - (th4 - th3)))) < 1e-6
    assert _closure_gap(res, FOUR_BAR_PINS) <= 10 * (rtol * four_bar.B + rtol)


# --- slider-crank --------------------------------------------------------------------------------------------

SLIDER_CRANK_PINS = ("crank_joint", "rod_joint", "wrist_pin")


def test_slider_crank_piston_follows_the_closed_form_and_energy_is_conserved(slider_crank):
    # The scene over its t_end = 2 s (about 14.6 crank revolutions, both dead centres passed each turn) at
    # rtol = atol = 1e-10: the piston position against x = R cos θ + √(L² − R² sin² θ) for the simulated crank
    # angle within 10·(rtol·L + atol) = 1.2e-9 m, L = 0.2 m (measured 4e-11 m); every pin's frames coincide
    # as well (measured 3e-11 m). Lossless: SystemEnergy plus the gas spring's ½ c (gap − free)² stays at its
    # start value (26.1 J) within 1e-7 relative (measured 1.7e-8) while the gas spring takes and returns
    # 10 J each turn.
    rtol, sc = 1e-10, slider_crank
    cm = sc.build().compile()
    res = cm.simulate(sc.t_end, rtol=rtol, atol=rtol, n_out=201)
    assert res.success, res.failure
    theta = res["crank_joint.phi"]
    assert (theta[-1] - theta[0]) / (2 * np.pi) > 10
    assert np.min(res["crank_joint.w"]) > 0.5 * sc.W0                   # the flywheel carries it through TDC
    assert np.max(np.abs(res["slider.s"] - sc.piston_x(theta))) <= 10 * (rtol * sc.L + rtol)
    assert _closure_gap(res, SLIDER_CRANK_PINS) <= 10 * (rtol * sc.L + rtol)
    gas = sc.gas_energy(res["slider.s"])
    assert np.ptp(gas) > 5.0
    total = res["energy.total"] + gas
    assert np.max(np.abs(total - total[0])) < 1e-7 * abs(total[0])


# --- six-bar -------------------------------------------------------------------------------------------------

SIX_BAR_PINS = ("crank_joint", "coupler1_joint", "pin_c", "rocker_joint", "pin_e", "output_joint", "pin_f")


def test_six_bar_at_constant_speed_follows_the_assembly_and_balances_the_drive_work(six_bar):
    # Crank at 2π rad/s (Speed source), 3 s (3 turns), rtol = atol = 1e-8: one state (the drive takes the
    # degree of freedom), two loops. All seven joint angles against the two circle intersections for the
    # simulated crank angle within 1e-6 rad (measured 6e-9); every pin's frames coincide within
    # 10·(rtol·L + atol) = 1.4e-7 m, L = 0.4 m (measured 1e-9). The output rocker swings 112°.
    # Energy: ΔE (SystemEnergy) equals the source's work ∫ −flange.tau·w dt
    # (Simpson's rule on the 601-point output grid, h = 5 ms), scale max|W| ≈ 2.1 J: within 1e-4·max|W|
    # (measured 1.5e-5 relative, the quadrature's error).
    from scipy.integrate import cumulative_simpson

    rtol, sb = 1e-8, six_bar
    cm = sb.build().compile()
    assert cm.n_states == 1
    assert "2 kinematic loop" in cm.summary()
    t = np.linspace(0.0, 3.0, 601)
    res = cm.simulate(3.0, rtol=rtol, atol=rtol, t_out=t)
    assert res.success, res.failure
    crank = res["crank_joint.phi"]
    assert np.max(np.abs(crank - (sb.THETA0 + sb.W_CRANK * t))) < 1e-8
    expected = sb.joint_angles(crank)
    assert set(expected) == set(SIX_BAR_PINS)
    for name, angle in expected.items():
        assert np.max(np.abs(_wrap(res[f"{name}.phi"] - angle))) < 1e-6, name
    assert np.ptp(res["output_joint.phi"]) > np.radians(90)              # the output rocker really swings
    assert _closure_gap(res, SIX_BAR_PINS) <= 10 * (rtol * sb.B_COUPLER + rtol)
    work = cumulative_simpson(-res["motor.flange.tau"] * sb.W_CRANK, x=t, initial=0.0)
    energy = res["energy.total"]
    assert np.max(np.abs(work)) > 1.0
    assert np.max(np.abs(energy - energy[0] - work)) < 1e-4 * np.max(np.abs(work))


def test_six_bar_torque_driven_has_one_degree_of_freedom(six_bar):
    # DC-motor drive (constant torque + back-EMF damper) instead of the speed source: one degree of freedom,
    # so 2 states (an angle and its speed). Over 1 s at rtol = atol = 1e-9 the crank runs up from rest
    # (1.5 turns; at least half a turn asserted), the seven joint angles follow the closed-form assembly for
    # the simulated crank angle within 1e-6 rad (measured 2e-11) and the pins close within
    # 10·(rtol·L + atol) = 1.4e-8 m, L = 0.4 m (measured 3e-12).
    rtol, sb = 1e-9, six_bar
    cm = sb.build(drive="torque").compile()
    assert cm.n_states == 2
    res = cm.simulate(1.0, rtol=rtol, atol=rtol, n_out=11)
    assert res.success, res.failure
    crank = res["crank_joint.phi"]
    assert crank[0] == pytest.approx(sb.THETA0, abs=1e-12)
    assert crank[-1] - crank[0] > np.pi
    for name, angle in sb.joint_angles(crank).items():
        assert np.max(np.abs(_wrap(res[f"{name}.phi"] - angle))) < 1e-6, name
    assert _closure_gap(res, SIX_BAR_PINS) <= 10 * (rtol * sb.B_COUPLER + rtol)
