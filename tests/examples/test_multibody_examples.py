"""The multibody scene files: physics checks beyond "runs and stays finite"."""
from pathlib import Path

import numpy as np
import pytest

import mechnet as mn
from mechnet.scene import load_scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_double_pendulum_conserves_energy_and_matches_lagrange_early():
    """4 states, explicit ODE; rtol = atol = 1e-10 over 3 s: |ΔE|/(m g L) ≤ 1e-7 and the angles agree with the
    scene's Lagrange reference to 1e-6 rad up to t = 1 s (later the motion is chaotic)."""
    scene = load_scene(EXAMPLES / "double_pendulum.py")
    cm = scene.model().compile()
    assert cm.n_states == 4 and cm.dae.z.numel() == 0
    res = cm.simulate(3.0, rtol=1e-10, atol=1e-10, t_out=np.linspace(0.0, 3.0, 61))
    energy = np.asarray(res["energy.total"])
    assert np.max(np.abs(energy - energy[0])) / (1.0 * 9.81 * 1.0) < 1e-7
    ref = scene.reference(np.asarray(res.t))
    early = np.asarray(res.t) <= 1.0
    for name, expected in ref.items():
        assert np.max(np.abs(np.asarray(res[name])[early] - np.asarray(expected)[early])) < 1e-6


def test_robot_arm_kinematics_match_hand_forward_kinematics():
    """mn.kinematics of the arm against the scene's hand-written forward kinematics: 1e-12 m."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("robot_arm_example", EXAMPLES / "robot_arm.py")
    arm = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(arm)
    cm = arm.build().compile()
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-2, 2, 3)
        frames = mn.kinematics(cm, q={"base": q[0], "shoulder": q[1], "elbow": q[2]})
        assert np.allclose(frames["tool.frame_a"]["r_0"], arm.forward_kinematics(q), atol=1e-12)


def test_robot_arm_states_are_joint_coordinates():
    """Geared motors do not take the states from the joints (priority 'always')."""
    scene = load_scene(EXAMPLES / "robot_arm.py")
    cm = scene.model().compile()
    assert set(cm.state_names) == {f"{j}.{v}" for j in ("base", "shoulder", "elbow") for v in ("phi", "w")}


def test_chain20_is_linear_size_and_conserves_energy():
    """40 states, explicit ODE, < 200 operations per link; |ΔE|/(N m g L) ≤ 1e-6 over 2 s at rtol = atol = 1e-9."""
    scene = load_scene(EXAMPLES / "chain20.py")
    cm = scene.model().compile()
    assert cm.n_states == 40 and cm.dae.z.numel() == 0
    assert cm.dae.ode.n_instructions() < 200 * 20
    res = cm.simulate(2.0, rtol=1e-9, atol=1e-9, n_out=41)
    energy = np.asarray(res["energy.total"])
    assert np.max(np.abs(energy - energy[0])) / (20 * 1.0 * 9.81 * 1.0) < 1e-6
    assert energy[0] == pytest.approx(0.0, abs=1e-12)      # released horizontal at rest, links along +x
