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
    assert lines[0] == "time [s],j1.phi [rad],spring.tau [N*m]"
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert np.array_equal(data[:, 0], res.t) and np.array_equal(data[:, 1], res["j1.phi"])


def test_plot_labels_carry_units(tmp_path):
    res = oscillator().compile().simulate(0.1, n_out=11)
    fig = res.plot(["j1.phi", "j1.w"])
    assert [[line.get_label() for line in a.get_lines()] for a in fig.axes] == [["j1.phi"], ["j1.w"]]
    assert [a.get_ylabel() for a in fig.axes] == ["rad", "rad/s"]
    assert fig.axes[-1].get_xlabel() == "time [s]"
    assert res.title == "oscillator" and fig._suptitle.get_text() == "oscillator"
    fig.savefig(tmp_path / "p.png")


def test_states_are_read_without_computing_every_name():
    # A run with one selection keeps its states and algebraics; the other names are computed on first use
    # and agree with them exactly (the observed function passes the states through). The oscillator's
    # spring torque is c·phi (c = 100 N·m/rad, phi relative to the fixed flange) at every point, to round-off (1e-12 relative, scale 50 N·m).
    cm = oscillator().compile()
    res = cm.simulate(0.5, rtol=1e-8, atol=1e-10, n_out=51)
    phi = res["j1.phi"]
    assert res._values is None                     # not computed for a state
    tau = res["spring.tau"]
    assert res._values is not None
    assert np.array_equal(res.values[:, res.names.index("j1.phi")], phi)
    assert np.max(np.abs(tau - 100.0 * phi)) < 1e-12 * 50.0


def test_a_run_that_switches_selection_computes_every_name_at_once():
    # After a re-selection the states change names: the result is observed whole, as before.
    from models import cartesian_pendulum
    res = cartesian_pendulum(theta0=1.2).compile().simulate(3.0, rtol=1e-8, atol=1e-10)
    assert any(e.kind == "reselection" for e in res.events)
    assert res.known == {} and res._values is not None
    # the point mass stays on its circle: x² + y² = L² within 10·(rtol·L + atol), L = 1 m
    assert np.max(np.abs(np.hypot(res["p.x"], res["p.y"]) - 1.0)) < 10 * (1e-8 * 1.0 + 1e-10)


def test_result_pickles_with_every_name():
    # A result goes to other processes (multiprocessing sweeps, joblib caches): pickled, it carries every
    # name's values, computed then, and equals the original exactly.
    import pickle
    res = oscillator().compile().simulate(0.5, rtol=1e-8, atol=1e-10, n_out=51)
    copy = pickle.loads(pickle.dumps(res))
    assert copy.names == res.names and np.array_equal(copy.values, res.values)
    assert np.array_equal(copy["spring.tau"], res["spring.tau"]) and copy.stats == res.stats
