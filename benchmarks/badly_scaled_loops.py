"""badly_scaled_loops — a millimetre, gram, stiff-spring six-bar: mechnet against a hand-written model.

Why: issue 6 asks that badly scaled mechanisms (millimetre links, gram masses,
stiff springs) integrate as well as a hand-written model. This puts numbers on it.

Scene: `tests/models.py: stephenson_mm()` — a one-degree-of-freedom Stephenson
six-bar, two loops sharing one pin, links of 10–45 mm, masses of 2–5 g, a
5 kN/m line spring stretched 2 mm (about 1 kHz against the grams), released
at rest; 20 ms, 201 output points. mechnet compiles it to an index-1 DAE
(IDAS, 2 states, 8 algebraics).

Hand-written model: `stephenson_mm_by_hand()` (tests/models.py, derived
independently): the crank angle θ as the only coordinate, the other links
from closed-form circle intersections, Lagrange's equation as an ODE,
CVODES-BDF. Reference: the same ODE at rtol 1e-13, atol 1e-15.

Timing: best of 3 `cm.simulate` calls (after compile and one untimed call)
and of the hand integrator's call (built untimed). Error: max |θ − reference|
on the output grid; energy drift max |E − E0| (E0 = 13.6 mJ). atol = rtol/100.
eq-err: mechnet's time over the hand model's time interpolated (log-log) at
mechnet's error.

Usage:  python benchmarks/badly_scaled_loops.py
"""
from __future__ import annotations

import math
import platform
import subprocess
import sys
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
from models import stephenson_mm, stephenson_mm_by_hand  # noqa: E402

import mechnet as mn  # noqa: E402
from mechnet.components import multibody as mb  # noqa: E402
sys.path.insert(0, str(Path(__file__).resolve().parent))
import timing  # noqa: E402

T_END, N_OUT, REPEATS = 0.02, 201, 3
RTOLS = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
HAND_EXTRA = (1e-4, 1e-5)          # hand model only: its curve reaches mechnet's larger errors


def best_of(fn):
    return timing.best_of(fn, REPEATS)


def hand_run(x, rate, energy, grid, rtol, atol):
    F = ca.integrator("H", "cvodes", {"x": x, "ode": rate}, 0.0, [float(t) for t in grid[1:]],
                      {"reltol": rtol, "abstol": atol, "max_num_steps": 10 ** 6})
    F(x0=[1.0, 0.0])
    seconds, out = best_of(lambda: F(x0=[1.0, 0.0]))
    th, w = np.concatenate([[1.0], np.array(out["xf"])[0]]), np.concatenate([[0.0], np.array(out["xf"])[1]])
    E = np.array([float(energy(a, b)) for a, b in zip(th, w)])
    return seconds, th, float(np.max(np.abs(E - E[0]))), int(F.stats()["nsteps"])


def main():
    git = subprocess.run(["git", "describe", "--always", "--dirty"], capture_output=True, text=True, cwd=HERE).stdout.strip()
    print(f"badly_scaled_loops: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"mechnet {mn.__version__} (git {git}); {T_END * 1e3:g} ms, n_out {N_OUT}, atol = rtol/100")
    grid = np.linspace(0.0, T_END, N_OUT)
    x, rate, energy = stephenson_mm_by_hand()
    _, reference, _, _ = hand_run(x, rate, energy, grid, 1e-13, 1e-15)
    model = stephenson_mm()
    model.add(mb.SystemEnergy(name="energy"))
    cm = model.compile()
    hand = {}
    for rtol in HAND_EXTRA + RTOLS:
        seconds, th, drift, steps = hand_run(x, rate, energy, grid, rtol, rtol / 100)
        hand[rtol] = (seconds, float(np.max(np.abs(th - reference))), drift, steps)
    rows = []
    for rtol in RTOLS:
        def simulate():
            return cm.simulate(T_END, rtol=rtol, atol=rtol / 100, n_out=N_OUT)
        simulate()
        seconds, res = best_of(simulate)
        assert res.success, res.failure
        E = res["energy.total"]
        err = float(np.max(np.abs(res["pin_O0.phi"] - reference)))
        rows.append((rtol, seconds, err, float(np.max(np.abs(E - E[0]))), res.stats["nsteps"], res.stats["segments"]))
    curve = sorted((h[1], h[0]) for h in hand.values())
    le, lt = np.log([c[0] for c in curve]), np.log([c[1] for c in curve])

    def at_error(err):
        if not le[0] <= math.log(err) <= le[-1]:
            return None
        return math.exp(np.interp(math.log(err), le, lt))

    print()
    print(f"{'rtol':>6} {'mn s':>7} {'hand s':>7} {'ratio':>6} {'mn err':>8} {'hd err':>8} {'eq-err':>6} | "
          f"{'mn dE':>8} {'hd dE':>8} | steps mn/hd segs")
    print("-" * 96)
    for rtol, seconds, err, drift, steps, segs in rows:
        h = hand[rtol]
        eq = at_error(err)
        eq_text = f"{seconds / eq:6.0f}" if eq else "     -"
        print(f"{rtol:6.0e} {seconds:7.3f} {h[0]:7.4f} {seconds / h[0]:6.0f} {err:8.1e} {h[1]:8.1e} {eq_text} | "
              f"{drift:8.1e} {h[2]:8.1e} | {steps:>6}/{h[3]:<6} {segs:>3}")
    print("(s: best of 3; ratio: mechnet / hand at the same rtol; err: max |crank angle - reference|, rad; eq-err: mechnet\n"
          " time / hand time at mechnet's error (log-log); dE: max energy drift, J (E0 = 13.6 mJ); segs: mechnet's\n"
          " integrator calls)")
    print("mechnet:", cm.summary().split("cost: ")[1].splitlines()[0])


if __name__ == "__main__":
    main()
