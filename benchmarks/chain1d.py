"""chain1d — 1D inertia chain benchmark (Core I b).

A fixed end, then N × (rot.SpringDamper(c=1e3, d=0.1) + rot.Inertia(J=0.01));
the last inertia starts at phi = 1 rad, every other angle and every speed at 0.

For each N this measures
  * mechnet compile time (total, and per stage from `cm.timings`);
  * for each method: the 10 s simulation at rtol = atol = 1e-8, n_out = 101
      - `cm.simulate` wall time on the first call (builds the CasADi integrator),
      - `cm.simulate` wall time with the cached integrator (best of 3),
      - the bare call of mechnet's cached CasADi integrator (best of 3), i.e.
        without initialisation and output evaluation;
  * a hand-written CasADi ODE of the same chain (SX, plain time, no scaling)
    integrated by `ca.integrator` with the same plugin, options and output grid,
    timed the same way (best of 3 after construction);
  * the ratio mechnet / hand-written, and the max difference of the two
    solutions at the output points: angles in rad, speeds relative to the
    peak speed (|w| reaches ~66 rad/s), both asserted to be below 1e-6. The
    absolute speed difference (~1e-5 rad/s) is printed too; it is below each
    solver's own global error at rtol = 1e-8 over ~500 periods (~1e-4 against
    an rtol = 1e-13 reference at N = 10), so an absolute 1e-6 on w would test
    SUNDIALS, not the model.

Usage:  python benchmarks/chain1d.py [--quick] [--n 10 100 1000] [--profile N] [--no-plot]
"""
from __future__ import annotations

import argparse
import cProfile
import io
import math
import os
import platform
import pstats
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

import mechnet as mn
from mechnet.components import rotational as rot
sys.path.insert(0, str(Path(__file__).resolve().parent))
import timing  # noqa: E402

C, D, J = 1e3, 0.1, 0.01
PHI_LAST = 1.0
T_END, N_OUT = 10.0, 101
RTOL = ATOL = 1e-8
METHODS = ("cvodes-bdf", "cvodes-adams", "idas")
MAX_STEPS = 20_000          # mechnet's simulate() default, used for both models
TOL_DIFF = 1e-6             # mechnet and hand-written solutions must agree to this (rad; relative for w)
REPEATS = 3
SLOW_CALL = 30.0            # s: a cm.simulate slower than this is timed once instead of best of 3

# Same plugin / options mapping as mechnet.simulate.solvers.plugin_for.
PLUGIN = {
    "idas": ("idas", {}),
    "cvodes-bdf": ("cvodes", {"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton"}),
    "cvodes-adams": ("cvodes", {"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"}),
}


# ----------------------------------------------------------------------------- models
def build_chain(n: int) -> mn.Model:
    m = mn.Model("chain")
    previous = m.add(rot.Fixed(name="fixed")).flange
    for k in range(n):
        sd = m.add(rot.SpringDamper(name=f"sd{k}", c=C, d=D))
        inertia = m.add(rot.Inertia(name=f"j{k}", J=J, phi_start=PHI_LAST if k == n - 1 else 0.0, w_start=0.0))
        m.connect(previous, sd.flange_a)
        m.connect(sd.flange_b, inertia.flange_a)
        previous = inertia.flange_b
    return m


def hand_integrator(n: int, method: str, grid: np.ndarray):
    """The natural hand-written model: x = [phi; w], plain time, no scaling."""
    phi = ca.SX.sym("phi", n)
    w = ca.SX.sym("w", n)
    phi_prev = ca.vertcat(0, phi[:-1])          # the fixed end at phi = 0
    w_prev = ca.vertcat(0, w[:-1])
    tau = C * (phi - phi_prev) + D * (w - w_prev)   # torque in spring-damper k (on its flange_b)
    tau_next = ca.vertcat(tau[1:], 0)               # the last inertia's flange_b is free
    ode = ca.vertcat(w, (tau_next - tau) / J)
    plugin, extra = PLUGIN[method]
    opts = dict(extra, reltol=RTOL, abstol=ATOL, max_num_steps=MAX_STEPS,
                disable_internal_warnings=True, show_eval_warnings=False)
    F = ca.integrator("H", plugin, {"x": ca.vertcat(phi, w), "ode": ode}, float(grid[0]), list(grid[1:]), opts)
    x0 = np.zeros(2 * n)
    x0[n - 1] = PHI_LAST
    return F, x0


# ----------------------------------------------------------------------------- timing helpers
def best_of(fn, repeats=REPEATS):
    return timing.best_of(fn, repeats)


def bench_n(n: int):
    row = {"n": n}
    t0 = time.perf_counter()
    model = build_chain(n)
    row["build"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    cm = model.compile()
    row["compile"] = time.perf_counter() - t0
    row["stages"] = dict(cm.timings)
    dae = cm.dae
    assert dae.is_ode, "the chain should compile to an explicit ODE"
    grid = np.linspace(0.0, T_END, N_OUT)
    xn = np.array(dae.x_nominal, dtype=float)
    # mechnet state k -> column in the hand-written [phi; w]
    index = {f"j{k}.phi": k for k in range(n)} | {f"j{k}.w": n + k for k in range(n)}
    cols = np.array([index[name] for name in dae.x_names])

    row["methods"] = {}
    for method in METHODS:
        r = {}
        before = set(cm.integrators().keys())
        t0 = time.perf_counter()
        res = cm.simulate(T_END, rtol=RTOL, atol=ATOL, method=method, n_out=N_OUT)
        r["first"] = time.perf_counter() - t0
        assert res.success, f"mechnet {method} failed at N={n}: {res.failure}"
        r["nsteps_m"] = res.stats.get("nsteps")
        # Best of 3 — unless one call already takes minutes (the time is then dominated by
        # deterministic Python work, and the repeat would add little but wall time).
        r["sim_repeats"] = 1 if r["first"] > SLOW_CALL else REPEATS
        r["sim"], res = best_of(lambda: cm.simulate(T_END, rtol=RTOL, atol=ATOL, method=method, n_out=N_OUT),
                                r["sim_repeats"])
        # The bare CasADi integrator mechnet built (private cache; benchmark only).
        (key,) = set(cm.integrators().keys()) - before
        Fm = cm.integrators()[key]
        pvec = np.concatenate([dae.u_default, dae.p_value, dae.d_value, [0.0, T_END]]).astype(float)
        xs0 = res.x[0] / xn
        r["integ"], _ = best_of(lambda: Fm(x0=xs0, p=pvec))

        t0 = time.perf_counter()
        Fh, x0h = hand_integrator(n, method, grid)
        r["hand_build"] = time.perf_counter() - t0
        r["hand"], out = best_of(lambda: Fh(x0=x0h))
        r["nsteps_h"] = Fh.stats().get("nsteps")
        Xh = np.vstack([x0h, np.asarray(out["xf"]).T])
        delta = np.abs(res.x - Xh[:, cols])
        is_phi = np.array([name.endswith(".phi") for name in dae.x_names])
        r["diff"] = float(delta[:, is_phi].max())                       # rad
        r["diff_w"] = float(delta[:, ~is_phi].max())                    # rad/s
        r["diff_wrel"] = r["diff_w"] / float(np.abs(Xh[:, n:]).max())   # relative to the peak speed
        r["ratio"] = r["sim"] / r["hand"]
        r["ratio_integ"] = r["integ"] / r["hand"]
        assert np.allclose(res.t, grid), "output grids differ"
        assert r["diff"] < TOL_DIFF and r["diff_wrel"] < TOL_DIFF, (
            f"N={n} {method}: mechnet and hand-written solutions differ by {r['diff']:.3g} rad in phi, "
            f"{r['diff_wrel']:.3g} (relative) in w; limit {TOL_DIFF} — the comparison is wrong")
        row["methods"][method] = r
        print(f"  N={n:5d} {method:13s} first {r['first']:.3f} s, cached {r['sim']:.3f} s, "
              f"integrator {r['integ']:.3f} s, hand {r['hand']:.3f} s, diff phi {r['diff']:.1e} rad, "
              f"w {r['diff_w']:.1e} rad/s", flush=True)

    return row


def profile_n(n: int):
    print(f"\n--- cProfile: compile at N = {n} ---")
    _profile(lambda: build_chain(n).compile(), "cumulative")
    _profile(lambda: build_chain(n).compile(), "tottime")
    cm = build_chain(n).compile()
    cm.simulate(T_END, rtol=RTOL, atol=ATOL, method="cvodes-adams", n_out=N_OUT)
    print(f"\n--- cProfile: cached cm.simulate, cvodes-adams, N = {n} ---")
    _profile(lambda: cm.simulate(T_END, rtol=RTOL, atol=ATOL, method="cvodes-adams", n_out=N_OUT), "cumulative")


def _profile(fn, sort):
    pr = cProfile.Profile()
    pr.enable()
    fn()
    pr.disable()
    s = io.StringIO()
    pstats.Stats(pr, stream=s).strip_dirs().sort_stats(sort).print_stats(20)
    print(s.getvalue())


# ----------------------------------------------------------------------------- report
def print_table(rows):
    head = (f"{'N':>5} {'method':13} {'compile s':>9} {'mn first s':>10} {'mn sim s':>9} {'mn integ s':>10} "
            f"{'hand sim s':>10} {'ratio':>6} {'ratio integ':>11} {'steps mn/hand':>15} {'dphi rad':>8} "
            f"{'dw rad/s':>8} {'dw rel':>7}")
    print(head)
    print("-" * len(head))
    for row in rows:
        for k, (method, r) in enumerate(row["methods"].items()):
            comp = f"{row['compile']:9.3f}" if k == 0 else " " * 9
            sim = f"{r['sim']:.3f}" + ("*" if r["sim_repeats"] < REPEATS else "")
            print(f"{row['n']:5d} {method:13} {comp} {r['first']:10.3f} {sim:>9} {r['integ']:10.3f} "
                  f"{r['hand']:10.3f} {r['ratio']:6.2f} {r['ratio_integ']:11.2f} "
                  f"{str(r['nsteps_m']) + '/' + str(r['nsteps_h']):>15} {r['diff']:8.1e} {r['diff_w']:8.1e} "
                  f"{r['diff_wrel']:7.0e}")
    print("(mn first: first cm.simulate, builds the integrator; mn sim: cm.simulate with the cached integrator, "
          f"best of {REPEATS}, * = one call only;\n mn integ: the bare call of mechnet's CasADi integrator; ratio = mn sim / "
          "hand sim; ratio integ = mn integ / hand sim;\n dphi: max |Δphi| in rad, dw: max |Δw| in rad/s, dw rel: "
          "relative to the peak |w|)")
    print()
    print("compile stages (s):")
    stages = list(rows[0]["stages"])
    print(f"{'N':>5} {'model build':>11} " + " ".join(f"{s:>9}" for s in stages) + f" {'total':>9}")
    for row in rows:
        print(f"{row['n']:5d} {row['build']:11.3f} " + " ".join(f"{row['stages'][s]:9.3f}" for s in stages)
              + f" {row['compile']:9.3f}")


def growth(rows):
    by_n = {row["n"]: row["compile"] for row in rows}
    pairs = [(100, 1000)] if {100, 1000} <= set(by_n) else []
    if not pairs and len(by_n) >= 2:
        ns = sorted(by_n)
        pairs = [(ns[-2], ns[-1])]
    for a, b in pairs:
        exp = math.log(by_n[b] / by_n[a]) / math.log(b / a)
        ref = math.log(b * math.log(b) / (a * math.log(a))) / math.log(b / a)
        print(f"compile-time growth N={a}->{b}: exponent {exp:.2f}  (N·log N: {ref:.2f}, N: 1.00, N²: 2.00)")


def plot(rows, path: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ns = [row["n"] for row in rows]
    fig, ax = plt.subplots(figsize=(7, 5))
    for method, color in zip(METHODS, ("C0", "C1", "C2")):
        ax.loglog(ns, [row["methods"][method]["sim"] for row in rows], "o-", color=color,
                  label=f"mechnet {method} (cm.simulate)")
        ax.loglog(ns, [row["methods"][method]["hand"] for row in rows], "s--", color=color,
                  label=f"hand-written {method}")
    ax.set_xlabel("N (inertias)")
    ax.set_ylabel("10 s simulation wall time [s] (best of 3)")
    ax.set_title(f"chain1d: rtol = atol = {RTOL:g}, n_out = {N_OUT}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def _git_head() -> str:
    import subprocess
    try:
        root = Path(__file__).resolve().parent.parent
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True)
        dirty = subprocess.run(["git", "status", "--porcelain", "src"], cwd=root, capture_output=True, text=True)
        return head.stdout.strip() + (" (src modified)" if dirty.stdout.strip() else "")
    except OSError:
        return "?"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.machine()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="N = 10, 100 only")
    ap.add_argument("--n", type=int, nargs="+", help="list of N (default 10 100 1000)")
    ap.add_argument("--profile", type=int, metavar="N", help="afterwards, cProfile compile and a cached simulate at this N")
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)
    ns = args.n or ([10, 100] if args.quick else [10, 100, 1000])

    print(f"chain1d: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"mechnet {getattr(mn, '__version__', '?')}")
    print(f"machine: platform.processor() = {platform.processor()!r}, {_cpu_model()}, {os.cpu_count()} cores, "
          f"{platform.system()} {platform.release()}")
    print(f"command: python {' '.join(sys.argv)}; mechnet at git {_git_head()}")
    print(f"chain: c = {C:g}, d = {D:g}, J = {J:g}; t_end = {T_END:g} s, rtol = {RTOL:g}, atol = {ATOL:g}, "
          f"n_out = {N_OUT}, timings best of {REPEATS}\n")

    rows = []
    for n in ns:
        rows.append(bench_n(n))
    print()
    print_table(rows)
    print()
    growth(rows)
    if len(rows) >= 2 and not args.no_plot:
        plot(rows, Path(__file__).with_suffix(".png"))
    if args.profile:
        profile_n(args.profile)


if __name__ == "__main__":
    main()
