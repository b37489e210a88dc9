"""Quarter car on a sine road: the steady state against the analytic frequency response."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechnet.components.signals import Sine
from mechnet.scene import load_scene

SCENE = load_scene(Path(__file__).resolve().parents[2] / "examples" / "quarter_car.py")
Q = SCENE.build.__globals__        # the example's constants


def _response(omega):
    """Complex amplitudes (X_body, X_wheel) for a road A·e^{iωt} with A = 1."""
    ms, mu, ks, cs, kt = Q["M_BODY"], Q["M_WHEEL"], Q["K_SUSPENSION"], Q["C_SUSPENSION"], Q["K_TYRE"]
    k = ks + 1j * omega * cs
    A = np.array([[-omega**2 * ms + k, -k], [-k, -omega**2 * mu + k + kt]])
    return np.linalg.solve(A, np.array([0.0, kt]))


@pytest.mark.parametrize("f", [1.2, 9.0])      # near the body mode and near the wheel hop mode
def test_sine_road_steady_state_matches_frequency_response(f):
    # Started on the steady-state orbit (x(0) = Im X, v(0) = ω Re X), the solution is
    # Im(X e^{iωt}) for all t. rtol = atol = 1e-10 (states nominal 1), horizon 3 s,
    # scale: each amplitude |X|·A: relative error < 1e-6.
    amplitude, omega = 0.02, 2 * np.pi * f
    Xb, Xw = amplitude * _response(omega)
    cm = SCENE.build(road=Sine(amplitude, f)).compile()
    assert cm.n_states == 4 and cm.dae.is_ode
    start = {"body.s": Xb.imag, "body.v": omega * Xb.real, "wheel.s": Xw.imag, "wheel.v": omega * Xw.real}
    res = cm.simulate(3.0, rtol=1e-10, atol=1e-10, start=start, n_out=3001)
    for name, X in (("body.s", Xb), ("wheel.s", Xw)):
        exact = np.imag(X * np.exp(1j * omega * res.t))
        assert np.max(np.abs(res[name] - exact)) < 1e-6 * abs(X), name


def test_road_table_knots_are_events():
    res = SCENE.model().compile().simulate(SCENE.t_end, n_out=31)
    assert [e.t for e in res.events] == [1.0, 1.15, 1.3]
    assert np.max(np.abs(res["road.s_ref"] - np.interp(res.t, Q["ROAD_TIMES"], Q["ROAD_HEIGHTS"]))) < 1e-15
