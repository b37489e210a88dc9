"""Every examples/*.py scene loads, compiles and simulates to finite results."""
from pathlib import Path

import numpy as np
import pytest

from mechnet.scene import load_scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCENE_FILES = sorted(p for p in EXAMPLES.glob("*.py") if not p.name.startswith("_"))
T_SHORT = 0.5  # s: long enough to move every scene, short enough for the default test run


def test_examples_exist():
    assert SCENE_FILES, f"no scene files in {EXAMPLES}"


@pytest.fixture(scope="module", params=SCENE_FILES, ids=lambda p: p.stem)
def run(request):
    """(scene, compiled model, result over min(t_end, 0.5) s), computed once per scene."""
    scene = load_scene(request.param)
    cm = scene.model().compile()
    res = cm.simulate(min(scene.t_end, T_SHORT))
    return scene, cm, res


def test_time_grid_spans_the_run(run):
    scene, _, res = run
    t = np.asarray(res.t)
    assert t[0] == pytest.approx(0.0)
    assert t[-1] == pytest.approx(min(scene.t_end, T_SHORT))
    # time only grows; it repeats only at an event (left and right limits of a jump)
    assert np.all(np.diff(t) >= 0.0)
    repeated = set(t[1:][np.diff(t) == 0].tolist())
    assert repeated <= {e.t for e in res.events}


def test_states_are_finite(run):
    _, cm, res = run
    assert cm.n_states > 0
    for name in cm.state_names:
        values = np.asarray(res[name], dtype=float)
        assert values.shape == np.asarray(res.t).shape, name
        assert np.all(np.isfinite(values)), f"{name} is not finite"


def test_plot_names_are_readable_and_finite(run):
    scene, _, res = run
    for name in scene.plot:
        values = np.asarray(res[name], dtype=float)
        assert np.all(np.isfinite(values)), f"{name} is not finite"


def test_matches_reference(run):
    """Scenes with a closed form agree with it well within the default tolerances (rtol 1e-6, atol 1e-8)."""
    scene, _, res = run
    if scene.reference is None:
        pytest.skip(f"{scene.name} has no reference solution")
    t = np.asarray(res.t)
    for name, expected in scene.reference(t).items():
        expected = np.asarray(expected, dtype=float)
        scale = max(1.0, float(np.max(np.abs(expected))))
        error = float(np.nanmax(np.abs(np.asarray(res[name], dtype=float) - expected)))   # NaN: not compared
        assert error < 1e-4 * scale, f"{name}: max deviation from reference {error:.2e}"


def _chain_energy(res):
    """inertia_chain: kinetic + spring energy in J (constants as in the scene file)."""
    n, c, j = 20, 1e3, 0.01
    phi = np.array([np.asarray(res[f"j{k}.phi"], dtype=float) for k in range(n)])
    w = np.array([np.asarray(res[f"j{k}.w"], dtype=float) for k in range(n)])
    stretch = np.diff(np.vstack([np.zeros_like(phi[:1]), phi]), axis=0)
    return 0.5 * j * np.sum(w**2, axis=0) + 0.5 * c * np.sum(stretch**2, axis=0)


def _oscillator_energy(res):
    """two_inertia_oscillator: kinetic + spring energy in J (constants as in the scene file)."""
    c1, c2, j1, j2 = 100.0, 50.0, 0.1, 0.2
    phi1, phi2 = np.asarray(res["j1.phi"], dtype=float), np.asarray(res["j2.phi"], dtype=float)
    w1, w2 = np.asarray(res["j1.w"], dtype=float), np.asarray(res["j2.w"], dtype=float)
    return 0.5 * (j1 * w1**2 + j2 * w2**2 + c1 * phi1**2 + c2 * (phi2 - phi1) ** 2)


ENERGY = {"inertia_chain": _chain_energy, "two_inertia_oscillator": _oscillator_energy}


def test_damped_energy_does_not_grow(run):
    """Both showcase scenes only lose energy (dampers); allow integration error of 1e-5 relative."""
    scene, _, res = run
    if scene.name not in ENERGY:
        pytest.skip(f"no energy expression written for {scene.name}")
    energy = ENERGY[scene.name](res)
    assert energy[0] > 0.0
    assert np.all(energy <= energy[0] * (1.0 + 1e-5)), f"energy grew to {energy.max():.6g} from {energy[0]:.6g}"
    assert np.all(np.diff(energy) <= 1e-5 * energy[0])
