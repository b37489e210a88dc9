"""Result: continuation from final_state, CSV, plots with units."""
from __future__ import annotations

import numpy as np

from models import oscillator


def test_two_runs_of_5_s_equal_one_run_of_10_s():
    # Continuation restarts the integrator; both paths have local error control at rtol = atol = 1e-8.
    # Scale 0.5 rad, horizon 10 s (damped). Bound: 10·(rtol·0.5 + atol) × (1 + number of periods ≈ 50)
    # would be loose; we assert the 10× the tolerance on the scale: < 10·(1e-8·0.5 + 1e-8) · 50.
    cm = oscillator(d=0.1).compile()
    full = cm.simulate(10.0, rtol=1e-8, atol=1e-8, n_out=1001)
    first = cm.simulate(5.0, rtol=1e-8, atol=1e-8, n_out=501)
    second = cm.simulate(10.0, t_start=first.final_time, start=first.final_state, rtol=1e-8, atol=1e-8,
                         n_out=501)
    assert second.t[0] == 5.0
    err = max(abs(second["j1.phi"][-1] - full["j1.phi"][-1]), abs(second["j1.w"][-1] - full["j1.w"][-1]) / 31.6)
    assert err < 10 * (1e-8 * 0.5 + 1e-8) * 50, err
    # and at the seam the second run starts exactly where the first ended
    assert second["j1.phi"][0] == first["j1.phi"][-1]


def test_to_csv_round_trips(tmp_path):
    res = oscillator().compile().simulate(0.1, n_out=11)
    path = tmp_path / "out.csv"
    res.to_csv(path, ["j1.phi", "spring.tau"])
    lines = path.read_text().splitlines()
    assert lines[0] == "# units: s,rad,N*m"
    assert lines[1] == "time,j1.phi,spring.tau"
    data = np.loadtxt(path, delimiter=",", skiprows=2)
    assert np.array_equal(data[:, 0], res.t) and np.array_equal(data[:, 1], res["j1.phi"])


def test_plot_labels_carry_units(tmp_path):
    res = oscillator().compile().simulate(0.1, n_out=11)
    fig = res.plot(["j1.phi", "j1.w"])
    ax = fig.axes[0]
    labels = [line.get_label() for line in ax.get_lines()]
    assert labels == ["j1.phi [rad]", "j1.w [rad/s]"]
    assert ax.get_xlabel() == "time [s]"
    fig.savefig(tmp_path / "p.png")
