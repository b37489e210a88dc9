"""Andrews' squeezing mechanism (examples/andrews_squeezer.py) against the IVP test set's published solution.

The test set (Mazzia & Magherini; Hairer & Wanner II, VII.7) gives the seven angles at t = 0.03 s to
about 14 digits. The scene's joint angles are the paper's coordinates with the paper's signs
(`COORDINATES`: beta_joint.phi is β, theta_joint.phi is θ relative to K1, phi_joint.phi is φ
relative to K5, omega_joint.phi is ω relative to K7), so the comparison maps names only.
Figures (IDAS, atol = rtol/100, t_out = [0, 0.03], the study's settings) are in docs/accuracy.md.
"""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from mechnet.accuracy import study
from mechnet.scene import load_scene

SCENE = Path(__file__).resolve().parents[2] / "examples" / "andrews_squeezer.py"
_spec = importlib.util.spec_from_file_location("andrews_squeezer_scene", SCENE)
squeezer = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(squeezer)

T = squeezer.T_END
NAMES = [f"{k}_joint.phi" for k in squeezer.COORDINATES]
PUBLISHED = np.array([squeezer.REFERENCE[k] for k in squeezer.COORDINATES])   # rad at 0.03 s


@pytest.fixture(scope="module")
def cm():
    return squeezer.build().compile()


def _angles(cm, rtol):
    res = cm.simulate(T, t_out=[0.0, T], rtol=rtol, atol=rtol * 1e-2, method="idas")
    assert res.failure is None, res.failure
    return res, np.array([float(res[n][-1]) for n in NAMES])


def test_one_degree_of_freedom_the_crank_angle(cm):
    """Seven bodies, ten pins, three loops: one degree of freedom, and its states hold over the whole run."""
    assert cm.state_names == ("beta_joint.phi", "beta_joint.w")
    res, _ = _angles(cm, 1e-6)
    assert not [e for e in res.events if e.kind == "reselection"]


def test_consistent_start(cm):
    """Initialisation keeps the published consistent position (β fixed, the other six from the loops)."""
    res = cm.simulate(1e-6, t_out=[0.0, 1e-6], rtol=1e-10, atol=1e-12, method="idas")
    start = np.array([float(res[n][0]) for n in NAMES])
    published = np.array([squeezer.START[k] for k in squeezer.COORDINATES])
    assert np.max(np.abs(start - published)) < 1e-13


def test_angles_match_the_published_solution_at_rtol_1e_10(cm):
    """Measured: 9.8e-9 rad at most (θ; β 7.8e-9, the other five below 1.4e-10)."""
    _, angles = _angles(cm, 1e-10)
    error = np.abs(angles - PUBLISHED)
    assert np.max(error) < 3e-8, dict(zip(NAMES, error))
    assert np.max(error[2:]) < 1e-9, dict(zip(NAMES, error))


def test_error_falls_from_rtol_1e_9_to_1e_10(cm):
    """No floor between 1e-9 and 1e-10: measured 3.5e-7 → 9.8e-9 (ratio 0.028)."""
    errors = {rtol: float(np.max(np.abs(_angles(cm, rtol)[1] - PUBLISHED))) for rtol in (1e-9, 1e-10)}
    assert errors[1e-10] <= 0.3 * errors[1e-9], errors


def test_error_falls_over_starts_a_few_ulps_apart(cm):
    """IDAS's error at 0.03 s scatters (a start moved by 1e-15 rad takes it at rtol 1e-10 from 9.8e-9 to
    4.9e-8), so one pair of runs can show no fall from a decade to the next; over eight starts moved by
    k·1e-15 rad (which moves the solution by < 2e-13) the largest error falls from 1.05e-6 to 2.0e-7."""
    def worst(rtol):
        errors = []
        for k in (0, 1, -1, 2, -2, 3, -3, 5):
            res = cm.simulate(T, t_out=[0.0, T], rtol=rtol, atol=rtol * 1e-2, method="idas",
                              start={"beta_joint.phi": squeezer.START["beta"] + k * 1e-15})
            errors.append(np.max(np.abs(np.array([float(res[n][-1]) for n in NAMES]) - PUBLISHED)))
        return max(errors)
    e9, e10 = worst(1e-9), worst(1e-10)
    assert e10 <= 0.3 * e9 and e10 < 5e-7, (e9, e10)


def test_published_solution_as_a_reference():
    """`published(t)` gives the published angles at 0.03 s and NaN elsewhere; the scene file loads."""
    assert load_scene(SCENE).t_end == T
    values = squeezer.published(np.array([0.0, 0.01, T]))
    for name, expected in zip(NAMES, PUBLISHED):
        assert np.isnan(values[name][:2]).all()
        assert values[name][2] == expected


def test_accuracy_study_against_the_published_solution(cm):
    """The study against the published angles: every decade of rtol lowers the error and 1e-10 reaches
    1e-8 (measured 2.9e-4, 3.9e-5, 2.1e-6, 3.5e-7, 9.8e-9, 5.1e-10)."""
    result = study(cm, T, methods=["idas"], tolerances=[1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11],
                   reference=squeezer.published, repeat=1)
    errors = {t.setting: t.error for t in result.trials if t.method == "idas"}
    assert all(errors[a] > errors[b] for a, b in zip(sorted(errors, reverse=True), sorted(errors, reverse=True)[1:]))
    assert errors[1e-10] < 1.5e-8 and errors[1e-11] < 1e-9, errors


def test_a_study_down_to_rtol_1e_11_checks_its_reference_a_decade_looser():
    """The check run at rtol 1e-14 fails at t = 0 (IDA_LINESEARCH_FAIL: below what double precision
    resolves); the study checks the 1e-13 reference by a run at 1e-12 instead and keeps the rows' errors
    reliable where they exceed that (rtol 1e-8: error ~2e-6 ≫ the check's ~1e-8)."""
    from mechnet import accuracy
    scene = load_scene(SCENE)
    result = accuracy.study(scene.model().compile(), 0.03, methods=["idas"], tolerances=(1e-8, 1e-11), repeat=1)
    assert "checked by idas at 1e-12" in result.reference
    assert np.isfinite(result.reference_error) and result.reference_error < 1e-6
    assert [t.reliable for t in result.trials if t.setting == 1e-8] == [True]
