"""methods — `method="auto"` (CVODES Adams, BDF on stiffness) against the old auto (CVODES BDF).

Until this change `cm.simulate(method="auto")` integrated an explicit ODE with
CVODES BDF (Newton); it now starts with CVODES Adams (functional iteration) and
falls back to BDF when stiffness shows. "before" = method="cvodes-bdf",
"after" = method="auto", measured in the same run beside the hand-written
CasADi joint-coordinate model of benchmarks/chain3d.py (CVODES Adams).

Scenes (all from mechnet.components.multibody, built by chain3d.build_chain):
World (g = 9.81 m/s² along −y), then N × (Revolute about z + FixedTranslation
r = [1, 0, 0] + Particle m = 1), released horizontal at rest: the pendulum
(N = 1), the double pendulum (N = 2) and the chains N = 10 and N = 40.

Three measurements:
  1. default tolerances (rtol 1e-6, atol 1e-8): wall time of a 10 s run
     (n_out = 101), best of 3 after a warm-up call (integrator construction
     excluded); the error over the 11 outputs in [0, 1] s (the chains are
     chaotic; one time point alone is noisy, an error changes sign) against a
     reference (hand model, CVODES Adams, rtol = atol = 1e-13, to t = 1 s);
     nsteps and res.stats["method"]; for bdf, auto and the hand model.
  2. work-precision: rtol = 1e-4 … 1e-10 (atol = rtol / 100, the default
     ratio) on the pendulum and the 10-link chain; "time to the same error":
     the bdf time over the auto time interpolated (log-log) at bdf's error.
  3. energy: the pendulum (phi = -π/2 hangs straight down) released at rest
     θ0 = 1 rad and θ0 = π/2 (horizontal) from the bottom, phi_start = θ0 - π/2;
     period from the closed form T = 4 sqrt(L/g) K(sin²(θ0/2)); 10^4 periods
     (--periods) at the default tolerances, n_out = 2001, timed once;
     E = energy.total of an mb.SystemEnergy sensor; the change is reported
     relative to the swing energy E(0) − E_bottom = m g L (1 − cos θ0).

Usage:  python benchmarks/methods.py [--quick] [--periods 10000] [--no-plot]
        (--quick: N = 1, 2, 10; a 3-point work-precision sweep; 10^3 periods)
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.special import ellipk

from mechnet.components import multibody as mb
sys.path.insert(0, str(Path(__file__).resolve().parent))
import chain3d  # noqa: E402  (importable: its work runs under __main__ only)
import timing  # noqa: E402

RTOL, ATOL = 1e-6, 1e-8               # simulate()'s defaults
ATOL_RATIO = ATOL / RTOL              # work-precision: atol = rtol * this
T_END, N_OUT, T_CMP = 10.0, 101, 1.0  # output grid holds t = 1 s
REF_TOL = 1e-13                       # 1e-12 differs from it by 9e-12 rad at N = 10, 1e-14 by 2e-12
REPEATS = 3
METHODS = ("cvodes-bdf", "auto")      # before, after
NS, QUICK_NS = (1, 2, 10, 40), (1, 2, 10)
WP_NS = (1, 10)
WP_TOLS, QUICK_WP_TOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10), (1e-4, 1e-6, 1e-8)
THETA0S = (1.0, math.pi / 2)          # rad from the bottom, energy runs (1 rad; horizontal)
PERIODS, QUICK_PERIODS = 10_000, 1_000
ENERGY_N_OUT = 2001
SCENE = {1: "pendulum", 2: "double pendulum"}


def scene_name(n: int) -> str:
    return SCENE.get(n, f"chain {n}")


# ----------------------------------------------------------------------------- models
def compiled_chain(n: int, energy: bool = False):
    model = chain3d.build_chain(n)
    if energy:
        model.add(mb.SystemEnergy(name="energy"))
    cm = model.compile()
    assert cm.dae.is_ode, "the chain should compile to an explicit ODE"
    return cm


def hand_ode(n: int):
    """The hand-written model, x = [phi; w] (relative angles and speeds) -> (x, ode): chain3d.hand_ode
    for N >= 2 (dense mass matrix, lapacklu solve); for N = 1, where chain3d's `thdd[:-1]` cannot be
    stacked, the pendulum's closed form phi'' = -g cos(phi) / L."""
    if n > 1:
        x, ode, _ = chain3d.hand_ode(n)
        return x, ode
    phi, w = ca.SX.sym("phi"), ca.SX.sym("w")
    return ca.vertcat(phi, w), ca.vertcat(w, -chain3d.G / chain3d.LENGTH * ca.cos(phi))


def hand_adams(n: int, grid, rtol: float, atol: float, max_steps: int = chain3d.MAX_STEPS):
    """The hand-written joint-coordinate ODE under CVODES Adams (functional iteration)."""
    x, ode = hand_ode(n)
    plugin, extra = chain3d.PLUGIN["cvodes-adams"]
    opts = dict(extra, reltol=rtol, abstol=atol, max_num_steps=max_steps,
                disable_internal_warnings=True, show_eval_warnings=False)
    return ca.integrator("H", plugin, {"x": x, "ode": ode}, float(grid[0]), [float(t) for t in grid[1:]], opts)


def reference(n: int) -> np.ndarray:
    """Relative angles (N × points) on the output grid up to T_CMP: hand model, CVODES Adams,
    rtol = atol = REF_TOL."""
    grid = np.linspace(0.0, T_END, N_OUT)
    F = hand_adams(n, grid[grid <= T_CMP + 1e-12], REF_TOL, REF_TOL, max_steps=1_000_000)
    return np.hstack([np.zeros((n, 1)), np.asarray(F(x0=np.zeros(2 * n))["xf"])[:n]])


# ----------------------------------------------------------------------------- measurements
def run_mechnet(cm, n: int, method: str, rtol: float, atol: float, ref: np.ndarray) -> dict:
    """Warm-up call, then best of REPEATS; error over the outputs up to T_CMP from the last call."""
    sim = lambda: cm.simulate(T_END, rtol=rtol, atol=atol, method=method, n_out=N_OUT)  # noqa: E731
    res = sim()
    best, res = timing.best_of(sim, REPEATS)
    assert res.success, f"{scene_name(n)} {method} failed: {res.failure}"
    i = ref.shape[1]
    assert abs(res.t[i - 1] - T_CMP) < 1e-12, "t = 1 s must be an output point"
    phi = np.array([res[f"rev{k}.phi"][:i] for k in range(n)])
    switches = [e for e in res.events if e.kind == "method"]
    return {"time": best, "err": float(np.abs(phi - ref).max()), "nsteps": int(res.stats["nsteps"]),
            "method": res.stats["method"], "switches": len(switches)}


def run_hand(n: int, rtol: float, atol: float, ref: np.ndarray) -> dict:
    grid = np.linspace(0.0, T_END, N_OUT)
    F = hand_adams(n, grid, rtol, atol)
    x0 = np.zeros(2 * n)
    F(x0=x0)
    best, out = timing.best_of(lambda: F(x0=x0), REPEATS)
    X = np.hstack([x0[:, None], np.asarray(out["xf"])])
    return {"time": best, "err": float(np.abs(X[:n, :ref.shape[1]] - ref).max()), "nsteps": int(F.stats()["nsteps"]),
            "method": "hand Adams", "switches": 0}


def bench_defaults(ns) -> list[dict]:
    rows = []
    for n in ns:
        t0 = time.perf_counter()
        cm, ref = compiled_chain(n), reference(n)
        row = {"n": n, "hand": run_hand(n, RTOL, ATOL, ref)}
        for method in METHODS:
            row[method] = run_mechnet(cm, n, method, RTOL, ATOL, ref)
        rows.append(row)
        print(f"  {scene_name(n)}: done in {time.perf_counter() - t0:.1f} s", flush=True)
    return rows


def bench_work_precision(ns, tols) -> dict:
    curves = {}
    for n in ns:
        cm, ref = compiled_chain(n), reference(n)
        for method in METHODS:
            curves[n, method] = [run_mechnet(cm, n, method, tol, tol * ATOL_RATIO, ref) for tol in tols]
        curves[n, "hand"] = [run_hand(n, tol, tol * ATOL_RATIO, ref) for tol in tols]
        print(f"  work-precision {scene_name(n)}: done", flush=True)
    return curves


def time_at_error(points: list[dict], err: float) -> float | None:
    """Time a curve needs for `err`, interpolated in log-log between its points (None outside its range)."""
    pts = sorted((p["err"], p["time"]) for p in points)
    for (e0, t0), (e1, t1) in zip(pts, pts[1:]):
        if e0 <= err <= e1 and e1 > e0:
            w = math.log(err / e0) / math.log(e1 / e0)
            return math.exp(math.log(t0) + w * math.log(t1 / t0))
    return None


def pendulum_period(theta0: float) -> float:
    """T = 4 sqrt(L/g) K(k²), k = sin(θ0/2) (scipy's ellipk takes the parameter m = k²)."""
    return 4.0 * math.sqrt(chain3d.LENGTH / chain3d.G) * float(ellipk(math.sin(theta0 / 2) ** 2))


def bench_energy(periods: int) -> list[dict]:
    cm = compiled_chain(1, energy=True)
    runs = []
    for theta0 in THETA0S:
        period = pendulum_period(theta0)
        swing = chain3d.MASS * chain3d.G * chain3d.LENGTH * (1 - math.cos(theta0))
        out = {"theta0": theta0, "T": period, "periods": periods, "swing": swing}
        for method in METHODS:
            t0 = time.perf_counter()
            res = cm.simulate(periods * period, method=method, n_out=ENERGY_N_OUT, progress=False,
                              start={"rev0.phi": theta0 - math.pi / 2})
            wall = time.perf_counter() - t0
            assert res.success, f"energy run {method} failed: {res.failure}"
            E = np.asarray(res["energy.total"])
            bottom = -chain3d.MASS * chain3d.G * chain3d.LENGTH
            assert abs(E[0] - swing - bottom) < 1e-9, f"start is not {theta0:g} rad from the bottom"
            out[method] = {"time": wall, "dE_end": float((E[-1] - E[0]) / swing),
                           "dE_max": float(np.abs(E - E[0]).max() / swing), "nsteps": int(res.stats["nsteps"]),
                           "method": res.stats["method"], "t": np.asarray(res.t), "E": (E - E[0]) / swing}
        runs.append(out)
        print(f"  energy θ0 = {theta0:.4g}: " + ", ".join(f"{m} {out[m]['time']:.1f} s" for m in METHODS),
              flush=True)
    return runs


# ----------------------------------------------------------------------------- report
def print_defaults(rows):
    b, a, h = "cvodes-bdf", "auto", "hand"
    head = (f"{'scene':16} | {'bdf s':>7} {'auto s':>7} {'hand s':>7} | {'bdf/hd':>6} {'auto/hd':>7} {'bdf/auto':>8} | "
            f"{'bdf err':>8} {'auto err':>8} {'hand err':>8} | {'steps bdf/auto/hand':>19} | auto ends with")
    print(f"default tolerances (rtol {RTOL:g}, atol {ATOL:g}): {T_END:g} s, n_out {N_OUT}")
    print(head)
    print("-" * len(head))
    for r in rows:
        steps = f"{r[b]['nsteps']}/{r[a]['nsteps']}/{r[h]['nsteps']}"
        ends = r[a]["method"] + (f" ({r[a]['switches']} switch)" if r[a]["switches"] else "")
        print(f"{scene_name(r['n']):16} | {r[b]['time']:7.4f} {r[a]['time']:7.4f} {r[h]['time']:7.4f} | "
              f"{r[b]['time'] / r[h]['time']:6.2f} {r[a]['time'] / r[h]['time']:7.2f} "
              f"{r[b]['time'] / r[a]['time']:8.2f} | {r[b]['err']:8.1e} {r[a]['err']:8.1e} {r[h]['err']:8.1e} | "
              f"{steps:>19} | {ends}")
    print(f"(s: cm.simulate, best of {REPEATS} after a warm-up call; hand: chain3d's hand-written CasADi model, "
          f"CVODES Adams, best of {REPEATS};\n err: max |relative angle − reference| over the outputs in "
          f"[0, {T_CMP:g}] s, rad; "
          f"reference: hand model, CVODES Adams, rtol = atol = {REF_TOL:g})")


def print_work_precision(curves, ns, tols):
    print(f"work-precision (atol = rtol × {ATOL_RATIO:g}; s: best of {REPEATS}; err over [0, {T_CMP:g}] s, rad)")
    head = (f"{'scene':10} {'rtol':>6} | {'bdf s':>7} {'bdf err':>8} | {'auto s':>7} {'auto err':>8} | "
            f"{'hand s':>7} {'hand err':>8} | {'same-err bdf/auto':>17}")
    print(head)
    print("-" * len(head))
    for n in ns:
        for k, tol in enumerate(tols):
            pb, pa, ph = curves[n, "cvodes-bdf"][k], curves[n, "auto"][k], curves[n, "hand"][k]
            t_auto = time_at_error(curves[n, "auto"], pb["err"])
            ratio = f"{pb['time'] / t_auto:17.2f}" if t_auto else f"{'-':>17}"
            print(f"{scene_name(n):10} {tol:6.0e} | {pb['time']:7.4f} {pb['err']:8.1e} | {pa['time']:7.4f} "
                  f"{pa['err']:8.1e} | {ph['time']:7.4f} {ph['err']:8.1e} | {ratio}")
    print("(same-err bdf/auto: bdf's time over auto's time interpolated (log-log) at bdf's error; "
          "- = bdf's error outside auto's range)")


def print_energy(runs):
    print(f"pendulum energy: released at rest θ0 from the bottom (rev0.phi = θ0 − π/2), {runs[0]['periods']} "
          f"periods (T closed form), rtol {RTOL:g}, atol {ATOL:g}, n_out {ENERGY_N_OUT}")
    head = (f"{'θ0 rad':>6} {'T s':>6} {'method':12} | {'wall s':>7} {'steps':>8} | {'ΔE(end)/E_swing':>15} "
            f"{'max|ΔE|/E_swing':>16} | ends with")
    print(head)
    print("-" * len(head))
    for en in runs:
        for method in METHODS:
            m = en[method]
            print(f"{en['theta0']:6.3f} {en['T']:6.3f} {method:12} | {m['time']:7.2f} {m['nsteps']:8d} | "
                  f"{m['dE_end']:+15.2e} {m['dE_max']:16.2e} | {m['method']}")
    print("(E = energy.total of an mb.SystemEnergy sensor; E_swing = m g L (1 − cos θ0), the energy above the "
          "bottom: " + ", ".join(f"{en['swing']:.3f} J" for en in runs) + "; one run each)")


def plot(curves, ns, runs, path: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    style = {"cvodes-bdf": ("o-", "C3", "cvodes-bdf (old auto)"), "auto": ("s-", "C0", "auto (Adams)"),
             "hand": ("^--", "C2", "hand CasADi, Adams")}
    fig, axes = plt.subplots(1, len(ns) + 1, figsize=(5 * (len(ns) + 1), 4.5))
    for ax, n in zip(axes, ns):
        for key, (fmt, color, label) in style.items():
            pts = curves[n, key]
            ax.loglog([p["err"] for p in pts], [p["time"] for p in pts], fmt, color=color, label=label)
        ax.set_xlabel(f"max |angle error| over [0, {T_CMP:g}] s [rad]")
        ax.set_ylabel(f"{T_END:g} s run, wall time [s]")
        ax.set_title(f"{scene_name(n)}: work-precision")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    ax = axes[-1]
    for en, dash in zip(runs, ("-", ":")):
        for method in METHODS:
            m = en[method]
            ax.plot(m["t"] / en["T"], m["E"], dash, color=style[method][1],
                    label=f"{style[method][2]}, θ0 = {en['theta0']:.3g} rad")
    ax.set_xlabel("periods")
    ax.set_ylabel("(E − E(0)) / E_swing")
    ax.set_title(f"pendulum energy, rtol {RTOL:g}, atol {ATOL:g}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="N = 1, 2, 10; 3 tolerances; 10^3 periods")
    ap.add_argument("--periods", type=int, help=f"pendulum periods of the energy run (default {PERIODS})")
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)
    ns = QUICK_NS if args.quick else NS
    tols = QUICK_WP_TOLS if args.quick else WP_TOLS
    periods = args.periods or (QUICK_PERIODS if args.quick else PERIODS)

    import mechnet as mn
    import platform
    print(f"methods: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"mechnet {getattr(mn, '__version__', '?')} at git {chain3d._git_head()}")
    print(f"machine: {chain3d._cpu_model()}, {__import__('os').cpu_count()} cores, "
          f"{platform.system()} {platform.release()}")
    print(f"command: python {' '.join(sys.argv)}\n", flush=True)

    t0 = time.perf_counter()
    rows = bench_defaults(ns)
    curves = bench_work_precision(WP_NS, tols)
    runs = bench_energy(periods)
    print(f"total {time.perf_counter() - t0:.0f} s\n")
    print_defaults(rows)
    print()
    print_work_precision(curves, WP_NS, tols)
    print()
    print_energy(runs)
    if not args.no_plot:
        plot(curves, WP_NS, runs, Path(__file__).with_suffix(".png"))


if __name__ == "__main__":
    main()
