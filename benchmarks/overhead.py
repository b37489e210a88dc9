"""overhead — the fixed cost of `cm.simulate` beyond the bare integrator call (issue 22's target: under
50 µs for a 2-state model at 11 output points, under 10 % of the call at 501 points over 5 s).

Scene: a mass on a spring (1 kg, 100 N/m, released from 0.1 m), 2 states, compiled by mechnet. Peer in
the same run: the same ODE written by hand as a CasADi `integrator` (CVODES Adams, functional iteration:
what `method="auto"` runs), the same tolerances (rtol 1e-6, atol 1e-8) and output grid, called with the
same start. Both take the same steps (printed). Times: best of `--repeat` calls each. The breakdown
times the pieces of one `cm.simulate` call (initialisation, the integrator call inside mechnet, the rest).
`prepared`: the same run through `cm.prepare` (settings fixed once; each call one integrator call and the
Result, with the same numbers), and its overhead over the hand model.

Usage:  python benchmarks/overhead.py [--repeat 300]
"""
from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import mechnet as mn  # noqa: E402
from mechnet.components import translational as tr  # noqa: E402

RTOL, ATOL = 1e-6, 1e-8
CASES = ((1.0, 11), (5.0, 501))


def oscillator() -> mn.Model:
    m = mn.Model("oscillator")
    fixed = m.add(tr.Fixed(name="fixed"))
    spring = m.add(tr.Spring(name="spring", c=100.0))
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.1, v_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, mass.flange_a)
    return m


def best(fn, repeat):
    shortest = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        shortest = min(shortest, time.perf_counter() - t0)
    return shortest


def by_hand(t_end, n_out):
    x = ca.SX.sym("x", 2)
    return ca.integrator("by_hand", "cvodes", {"x": x, "ode": ca.vertcat(x[1], -100.0 * x[0])}, 0.0,
                         list(np.linspace(0.0, t_end, n_out)[1:]),
                         {"reltol": RTOL, "abstol": ATOL, "linear_multistep_method": "adams",
                          "nonlinear_solver_iteration": "functional"})


def breakdown(cm, t_end, n_out, repeat):
    """Shortest times of the initialisation and of mechnet's own integrator call inside cm.simulate."""
    from mechnet.simulate import integrator as I
    from mechnet.simulate import run as R
    spent = {"initialize": [], "integrator call": []}
    init, call = I.initialize, R.Run._call

    def timed_init(*a, **k):
        t0 = time.perf_counter()
        out = init(*a, **k)
        spent["initialize"].append(time.perf_counter() - t0)
        return out

    def timed_call(self, *a, **k):
        t0 = time.perf_counter()
        out = call(self, *a, **k)
        spent["integrator call"].append(time.perf_counter() - t0)
        return out
    I.initialize, R.Run._call = timed_init, timed_call
    try:
        for _ in range(repeat):
            cm.simulate(t_end, n_out=n_out, rtol=RTOL, atol=ATOL)
    finally:
        I.initialize, R.Run._call = init, call
    return {k: min(v) for k, v in spent.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=300)
    args = ap.parse_args()
    print(f"overhead: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}")
    print(f"command: python benchmarks/overhead.py {' '.join(sys.argv[1:])}".rstrip())
    cm = oscillator().compile()
    print(f"\n{'t_end':>6} {'n_out':>6} {'steps':>11} {'simulate':>10} {'by hand':>9} {'overhead':>9} {'share':>6}"
          f" {'target':>9} | {'init':>6} {'call':>6} {'rest':>6} | {'prepared':>9} {'overhead':>9} {'share':>6} "
          f"{'target':>4}")
    for t_end, n_out in CASES:
        res = cm.simulate(t_end, n_out=n_out, rtol=RTOL, atol=ATOL)
        F = by_hand(t_end, n_out)
        F(x0=[0.1, 0.0])
        steps = f"{res.stats['nsteps']}/{int(F.stats()['nsteps'])}"
        t_m = best(lambda: cm.simulate(t_end, n_out=n_out, rtol=RTOL, atol=ATOL), args.repeat)
        t_h = best(lambda: F(x0=[0.1, 0.0]), args.repeat)
        parts = breakdown(cm, t_end, n_out, args.repeat)
        over = t_m - t_h
        target = "50 µs" if n_out == 11 else "10 %"
        met = over <= 50e-6 if n_out == 11 else over / t_m <= 0.10
        rest = t_m - parts["initialize"] - parts["integrator call"]
        prepared = cm.prepare(t_end, n_out=n_out, rtol=RTOL, atol=ATOL)
        assert np.array_equal(prepared().values, res.values) and np.array_equal(prepared().values, res.values)
        assert prepared.plain, "the oscillator's run is one integrator call"
        t_p = best(prepared, args.repeat)
        over_p = t_p - t_h
        met_p = over_p <= 50e-6 if n_out == 11 else over_p / t_p <= 0.10
        print(f"{t_end:6g} {n_out:6d} {steps:>11} {t_m * 1e6:8.0f}µs {t_h * 1e6:7.0f}µs {over * 1e6:7.0f}µs"
              f" {over / t_m:6.0%} {target:>6} {'met' if met else 'MISS':>3} | {parts['initialize'] * 1e6:4.0f}µs"
              f" {parts['integrator call'] * 1e6:4.0f}µs {rest * 1e6:4.0f}µs | {t_p * 1e6:7.0f}µs"
              f" {over_p * 1e6:7.0f}µs {over_p / t_p:6.0%} {'met' if met_p else 'MISS':>4}")
    print("(steps: mechnet/by hand; overhead = simulate − by hand; init, call: shortest initialisation and "
          "mechnet's own integrator call inside simulate, rest = simulate − both; prepared: cm.prepare's "
          "call, the same numbers)")


if __name__ == "__main__":
    main()
