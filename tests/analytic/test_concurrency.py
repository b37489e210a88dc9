"""A compiled model shared by threads, and handed to another process.

Threads: `concurrent_runs.py` runs in a subprocess (a crash then fails this test instead of killing the
suite): 4 threads × 25 runs of one compiled model each with different parameters (or start values) must
give bit-identical results to the same runs done one after another (likewise linearize and
kinematics). Before integrators were kept per thread (`mechnet/caches.py`), the oscillator aborted the
interpreter within a few rounds.

Processes: a pickled compiled model, loaded in a fresh interpreter, simulates to the last bit like the
original.
"""
from __future__ import annotations

import json
import math
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import models

HERE = Path(__file__).parent
TESTS = HERE.parent


def _run(*args, stdin=None):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, *args], input=stdin, capture_output=True, env=env, timeout=600)


def test_threads_give_the_sequential_results_bit_for_bit():
    proc = _run(str(HERE / "concurrent_runs.py"))
    assert proc.returncode == 0, f"the concurrent runs crashed (rc {proc.returncode}): {proc.stderr[-2000:]!r}"
    reports = {r["scene"]: r for r in map(json.loads, proc.stdout.decode().splitlines())}
    assert set(reports) == {"oscillator", "cartesian_pendulum", "multibody_pendulum", "four_bar",
                            "linearized_pendulum"}
    for scene, r in reports.items():
        assert r["errors"] == [], scene
        assert r["succeeded"] == 25, scene
        assert r["identical"] == r["runs"] == 100, scene
    # the parameters reached each run: the oscillator's angle at t = 1 s is 0.5·cos(√(c/J)·t) for each c.
    # rtol 1e-8, atol 1e-10, amplitude 0.5, 32-42 rad of phase in 1 s: BDF's global error grows with the
    # phase (measured up to 1.5e-6), bounded by 1e-5; neighbouring cases differ by ~0.1-0.3
    expected = [0.5 * math.cos(math.sqrt((100.0 + 4.0 * k) / 0.1) * 1.0) for k in range(25)]
    np.testing.assert_allclose(reports["oscillator"]["finals"], expected, rtol=0, atol=1e-5)
    # and every g gives the Cartesian pendulum another position at t = 1 s (g 0.1 apart: x moves by
    # 1e-4-1e-3, far above the run's error)
    for scene in ("cartesian_pendulum", "multibody_pendulum", "four_bar"):
        assert np.min(np.abs(np.diff(reports[scene]["finals"]))) > 1e-5, scene


LOAD_AND_RUN = """
import pickle, sys
import numpy as np
cm = pickle.loads(sys.stdin.buffer.read())
res = cm.simulate(2.0, rtol=1e-8, atol=1e-10, n_out=101)
sys.stdout.buffer.write(pickle.dumps((res.t, {n: res[n] for n in ("joint_a.phi", "joint_d.phi", "joint_b.phi")},
                                      res.failure is None)))
"""


def test_a_pickled_four_bar_simulates_identically_in_a_fresh_process():
    cm = models.four_bar().compile()
    blob = pickle.dumps(cm)
    proc = _run("-c", LOAD_AND_RUN, stdin=blob)
    assert proc.returncode == 0, proc.stderr.decode()[-2000:]
    t, values, ok = pickle.loads(proc.stdout)
    assert ok
    here = cm.simulate(2.0, rtol=1e-8, atol=1e-10, n_out=101)
    assert np.array_equal(t, here.t)
    for name, column in values.items():
        assert np.array_equal(column, here[name]), name
    # and the run is the four-bar's: the rocker angle closes the loop with the crank's (the closed form
    # at each simulated crank angle, rtol 1e-8 on lengths of 0.2-0.6 m: within 1e-6 rad)
    th4 = [models.four_bar_angles(0.2, 0.6, 0.5, 0.6, a)[1] for a in values["joint_a.phi"]]
    np.testing.assert_allclose(values["joint_d.phi"], th4, rtol=0, atol=1e-6)


def test_a_pickled_model_keeps_its_runs_caches_out():
    """The pickle holds the model, not this process's integrators or run-time maps."""
    cm = models.four_bar().compile()
    size = len(pickle.dumps(cm))
    cm.simulate(1.0)
    assert len(cm.integrators()) >= 1
    assert len(pickle.dumps(cm)) == pytest.approx(size, rel=0.01)
    again = pickle.loads(pickle.dumps(cm))
    assert len(again.integrators()) == 0
