"""chain3d — N-link planar pendulum built from 3D components (Multibody I).

Scene: World (g = 9.81 along -y), then N × (Revolute about z + FixedTranslation
r = [1, 0, 0] + Particle m = 1): unit point masses at the link ends, unit
lengths, released horizontal at rest (every relative angle and speed 0), 10 s at
rtol = atol = 1e-8, n_out = 101 (so t = 1 s is an output point).

Three tools, in the same run:
  * mechnet: model construction + `compile()`; `cm.simulate` with
    method = "cvodes-adams" and "idas";
  * a hand-written CasADi joint-coordinate model: states the relative angles and
    speeds (the same coordinates as mechnet's Revolute states), the dense
    N×N mass matrix and the force vector in absolute angles as SX, wrapped in a
    Function and solved in the right-hand side by `ca.solve(M, f, "lapacklu")`
    (an MX linear-solver node); the same explicit ODE is integrated by
    `ca.integrator` with CVODES (Adams, functional iteration) and with IDAS
    (IDAS on the ODE, no algebraic variables — as mechnet's "idas" on this
    model), with mechnet's plugin options and output grid;
  * PyDy: `sympy.physics.mechanics.KanesMethod` in absolute angles, the mass
    matrix and forcing through `pydy.codegen.ode_function_generators.
    generate_ode_function` (generator "cython" if Cython and a C compiler work,
    else "lambdify"; the one used is printed), integrated by SciPy's
    `solve_ivp(method="DOP853")` with the same tolerances and output grid.

For each N this measures
  * build time — mechnet: model construction + compile; hand: symbolic build +
    `ca.integrator` construction (per solver); PyDy: KanesMethod derivation +
    code generation;
  * the first simulation call (mechnet's first `cm.simulate` also builds its
    CasADi integrator) and the simulation time with everything cached, best of
    3 after the first call;
  * "total" = build + first simulation call: the wall time from nothing to the
    first result, for each tool (Adams for mechnet and the hand model);
  * mechnet's ODE size, `cm.dae.ode.n_instructions()`, in total and per link;
  * the solutions at t = 1 s (the chain is chaotic; later states are not
    comparable at this tolerance): the max difference of every model's relative
    angles from mechnet's Adams solution, asserted below 1e-5 rad, and every
    model's error against a reference (the hand model, CVODES-Adams at
    rtol = atol = 1e-12, integrated to t = 1 s only).

PyDy's generated right-hand side returns the same output array on every call;
SciPy's DOP853 keeps a reference to the last derivative for its dense output,
so the values at t_eval are wrong (errors ~1e-4 at N = 5) unless the wrapper
copies the array — it does here.

Usage:  python benchmarks/chain3d.py [--quick] [--n 2 5 10 20 40 100] [--pydy-max 40] [--no-plot]
"""
from __future__ import annotations

import argparse
import gc
import os
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
import scipy
from scipy.integrate import solve_ivp

import mechnet as mn
from mechnet.components import multibody as mb
sys.path.insert(0, str(Path(__file__).resolve().parent))
import timing  # noqa: E402

G, MASS, LENGTH = 9.81, 1.0, 1.0
T_END, N_OUT, T_CMP = 10.0, 101, 1.0
RTOL = ATOL = 1e-8
REF_TOL = 1e-12            # reference: hand model, CVODES-Adams, to t = T_CMP only
METHODS = ("cvodes-adams", "idas")
MAX_STEPS = 20_000          # mechnet's simulate() default, used for the hand model too
TOL_AGREE = 1e-5            # rad: every model's relative angles at t = 1 s must agree to this
REPEATS = 3
SLOW_CALL = 30.0            # s: a call slower than this is timed once instead of best of 3
HAND_LINSOL = "lapacklu"    # dense LU for the hand model's mass matrix
DEFAULT_NS = (2, 5, 10, 20, 40, 100)
QUICK_NS = (2, 5, 10)

# Same plugin / options mapping as mechnet.simulate.solvers.plugin_for.
PLUGIN = {
    "idas": ("idas", {}),
    "cvodes-bdf": ("cvodes", {"linear_multistep_method": "bdf", "nonlinear_solver_iteration": "newton"}),
    "cvodes-adams": ("cvodes", {"linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"}),
}


# ----------------------------------------------------------------------------- mechnet
def build_chain(n: int) -> mn.Model:
    m = mn.Model("chain")
    world = m.add(mb.World(name="world"))
    previous = world.frame_b
    for k in range(n):
        rev = m.add(mb.Revolute(name=f"rev{k}", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[LENGTH, 0, 0]))
        mass = m.add(mb.Particle(name=f"mass{k}", m=MASS))
        m.connect(previous, rev.frame_a)
        m.connect(rev.frame_b, rod.frame_a)
        m.connect(rod.frame_b, mass.frame_a)
        previous = rod.frame_b
    return m


# ----------------------------------------------------------------------------- hand-written CasADi
def hand_ode(n: int):
    """x = [phi; w] (relative angles and speeds); returns (x, ode, SX part of the right-hand side).

    With absolute angles th = cumsum(phi), the mass at the end of link i sits at
    sum_{j<=i} L (cos th_j, sin th_j), so link j carries the n - j outboard
    masses (0-based j) and
        M_jk = m L² (n - max(j, k)) cos(th_j - th_k),
        f_j  = -m g L (n - j) cos th_j - m L² sum_k (n - max(j, k)) sin(th_j - th_k) thd_k²,
    M thdd = f; the relative accelerations are the differences of thdd.
    """
    phi, w = ca.SX.sym("phi", n), ca.SX.sym("w", n)
    th, thd = ca.cumsum(phi), ca.cumsum(w)
    c, s = ca.cos(th), ca.sin(th)
    outboard = ca.DM([[n - max(j, k) for k in range(n)] for j in range(n)])
    cos_diff = c @ c.T + s @ s.T                 # cos(th_j - th_k)
    sin_diff = s @ c.T - c @ s.T                 # sin(th_j - th_k)
    mass_matrix = MASS * LENGTH**2 * (outboard * cos_diff)
    force = (-MASS * G * LENGTH * ca.DM(list(range(n, 0, -1))) * c
             - MASS * LENGTH**2 * (outboard * sin_diff) @ (thd * thd))
    parts = ca.Function("mass_matrix_force", [ca.vertcat(phi, w)], [mass_matrix, force])
    x = ca.MX.sym("x", 2 * n)
    Mx, fx = parts(x)
    thdd = ca.solve(Mx, fx, HAND_LINSOL)        # absolute angular accelerations
    return x, ca.vertcat(x[n:], thdd - ca.vertcat(0, thdd[:-1])), parts


def hand_integrator(n: int, method: str, grid, tol=RTOL, max_steps=MAX_STEPS):
    x, ode, parts = hand_ode(n)
    plugin, extra = PLUGIN[method]
    opts = dict(extra, reltol=tol, abstol=tol, max_num_steps=max_steps,
                disable_internal_warnings=True, show_eval_warnings=False)
    F = ca.integrator("H", plugin, {"x": x, "ode": ode}, float(grid[0]), [float(t) for t in grid[1:]], opts)
    return F, parts


# ----------------------------------------------------------------------------- PyDy
_PYDY_GENERATOR: list[str] = []      # the generator that worked (decided on first use)


def pydy_derive(n: int):
    """KanesMethod for the chain in absolute angles q_i (link i from the x axis), u_i = q_i'."""
    import sympy as sm
    import sympy.physics.mechanics as me

    q = me.dynamicsymbols(f"q:{n}")
    u = me.dynamicsymbols(f"u:{n}")
    g, length, mass = sm.symbols("g l m")
    frame = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(frame, 0)
    particles, loads, kinematics = [], [], []
    previous = origin
    for i in range(n):
        link = frame.orientnew(f"A{i}", "Axis", [q[i], frame.z])
        link.set_ang_vel(frame, u[i] * frame.z)
        point = previous.locatenew(f"P{i}", length * link.x)
        point.v2pt_theory(previous, frame, link)
        particles.append(me.Particle(f"pa{i}", point, mass))
        loads.append((point, -mass * g * frame.y))
        kinematics.append(q[i].diff() - u[i])
        previous = point
    kane = me.KanesMethod(frame, q_ind=q, u_ind=u, kd_eqs=kinematics)
    kane.kanes_equations(particles, loads)
    return kane, q, u, [g, length, mass]


def pydy_codegen(kane, q, u, constants):
    import sympy as sm
    from pydy.codegen.ode_function_generators import generate_ode_function

    candidates = _PYDY_GENERATOR[:1] or ["cython", "lambdify"]
    last_error = None
    for generator in candidates:
        try:
            rhs = generate_ode_function(kane.forcing, q, u, constants, mass_matrix=kane.mass_matrix,
                                        coordinate_derivatives=sm.Matrix(u), generator=generator)
        except Exception as exc:          # no Cython, no compiler, ...: fall back
            last_error = exc
            print(f"  PyDy generator {generator!r} failed ({type(exc).__name__}: {exc}); falling back", flush=True)
            continue
        if not _PYDY_GENERATOR:
            _PYDY_GENERATOR.append(generator)
        return rhs, generator
    raise RuntimeError(f"no PyDy generator worked: {last_error}")


# ----------------------------------------------------------------------------- helpers
def best_of(fn, repeats=REPEATS):
    return timing.best_of(fn, repeats)


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def first_then_best(fn):
    """(first call, best of REPEATS further calls — or of one if the first was slow, repeats, output)."""
    first, out = timed(fn)
    repeats = 1 if first > SLOW_CALL else REPEATS
    best, out = best_of(fn, repeats)
    return first, best, repeats, out


def relative_from_absolute(a: np.ndarray) -> np.ndarray:
    """Absolute link angles (or rates) along axis 0 -> relative joint angles (rates)."""
    return np.diff(a, axis=0, prepend=np.zeros((1,) + a.shape[1:]))


# ----------------------------------------------------------------------------- one N
def bench_n(n: int, pydy_max: int):
    row = {"n": n}
    grid = np.linspace(0.0, T_END, N_OUT)
    i_cmp = int(np.argmin(np.abs(grid - T_CMP)))
    assert abs(grid[i_cmp] - T_CMP) < 1e-12, "t = 1 s must be an output point"
    angles = {}                     # model -> relative angles at t = 1 s
    speeds = {}

    # --- mechnet
    row["mn_construct"], model = timed(lambda: build_chain(n))
    row["mn_compile"], cm = timed(model.compile)
    row["mn_build"] = row["mn_construct"] + row["mn_compile"]
    row["stages"] = dict(cm.timings)
    dae = cm.dae
    assert dae.is_ode, "the chain should compile to an explicit ODE"
    row["ops"] = int(dae.ode.n_instructions())
    row["mn"] = {}
    for method in METHODS:
        before = set(cm.integrators().keys())
        first, best, reps, res = first_then_best(
            lambda: cm.simulate(T_END, rtol=RTOL, atol=ATOL, method=method, n_out=N_OUT))
        assert res.success, f"mechnet {method} failed at N={n}: {res.failure}"
        assert np.allclose(res.t, grid), "output grids differ"
        # The bare call of the CasADi integrator mechnet built (private cache; benchmark only):
        # the simulation without mechnet's initialisation and output evaluation.
        (key,) = set(cm.integrators().keys()) - before
        Fm = cm.integrators()[key]
        pvec = np.concatenate([dae.u_default, dae.p_value, dae.d_value, [0.0, T_END]]).astype(float)
        xs0 = res.x[0] / np.array(dae.x_nominal, dtype=float)
        integ, _ = best_of(lambda: Fm(x0=xs0, p=pvec))
        row["mn"][method] = {"first": first, "sim": best, "reps": reps, "integ": integ,
                             "nsteps": res.stats.get("nsteps")}
        angles[f"mn {method}"] = np.array([res[f"rev{k}.phi"][i_cmp] for k in range(n)])
        speeds[f"mn {method}"] = np.array([res[f"rev{k}.w"][i_cmp] for k in range(n)])
    print(f"  N={n:4d} mechnet: build {row['mn_build']:.3f} s (construct {row['mn_construct']:.3f}, "
          f"compile {row['mn_compile']:.3f}); adams first {row['mn']['cvodes-adams']['first']:.3f}, "
          f"sim {row['mn']['cvodes-adams']['sim']:.3f} s; idas sim {row['mn']['idas']['sim']:.3f} s; "
          f"{row['ops']} ops", flush=True)
    del cm, model
    gc.collect()

    # --- hand-written CasADi
    row["hand"] = {}
    x0 = np.zeros(2 * n)
    for method in METHODS:
        build, (F, parts) = timed(lambda: hand_integrator(n, method, grid))
        first, best, reps, out = first_then_best(lambda: F(x0=x0))
        X = np.hstack([x0[:, None], np.asarray(out["xf"])])
        row["hand"][method] = {"build": build, "first": first, "sim": best, "reps": reps,
                               "nsteps": F.stats().get("nsteps")}
        row["hand_ops"] = int(parts.n_instructions())
        angles[f"hand {method}"] = X[:n, i_cmp]
        speeds[f"hand {method}"] = X[n:, i_cmp]
        print(f"  N={n:4d} hand {method:12s}: build {build:.3f} s, first {first:.3f} s, sim {best:.3f} s",
              flush=True)
        del F
    # reference: hand model, CVODES-Adams at REF_TOL, to t = T_CMP only (not timed)
    Fr, _ = hand_integrator(n, "cvodes-adams", [0.0, T_CMP], tol=REF_TOL, max_steps=1_000_000)
    xr = np.asarray(Fr(x0=x0)["xf"]).ravel()
    ref_phi, ref_w = xr[:n], xr[n:]
    del Fr
    gc.collect()

    # --- PyDy
    row["pydy"] = None
    if n <= pydy_max:
        t_derive, (kane, q, u, constants) = timed(lambda: pydy_derive(n))
        t_gen, (rhs, generator) = timed(lambda: pydy_codegen(kane, q, u, constants))
        p = np.array([G, LENGTH, MASS])

        # pydy's rhs returns one reused array; DOP853's dense output (t_eval) needs a copy.
        def fun(t, x):
            return rhs(x, t, p).copy()

        def solve():
            return solve_ivp(fun, (0.0, T_END), np.zeros(2 * n), method="DOP853", rtol=RTOL, atol=ATOL,
                             t_eval=grid)

        first, best, reps, sol = first_then_best(solve)
        assert sol.success, f"PyDy/DOP853 failed at N={n}: {sol.message}"
        row["pydy"] = {"derive": t_derive, "codegen": t_gen, "build": t_derive + t_gen, "first": first,
                       "sim": best, "reps": reps, "nfev": int(sol.nfev), "generator": generator}
        angles["pydy DOP853"] = relative_from_absolute(sol.y[:n, i_cmp])
        speeds["pydy DOP853"] = relative_from_absolute(sol.y[n:, i_cmp])
        print(f"  N={n:4d} PyDy ({generator}): derive {t_derive:.3f} s, codegen {t_gen:.3f} s, "
              f"first {first:.3f} s, sim {best:.3f} s", flush=True)
        del kane, rhs
        gc.collect()

    # --- agreement at t = 1 s
    base = angles["mn cvodes-adams"]
    row["dphi"] = {k: float(np.abs(v - base).max()) for k, v in angles.items() if k != "mn cvodes-adams"}
    row["dw"] = {k: float(np.abs(v - speeds["mn cvodes-adams"]).max())
                 for k, v in speeds.items() if k != "mn cvodes-adams"}
    row["err_ref"] = {k: float(np.abs(v - ref_phi).max()) for k, v in angles.items()}
    row["err_ref_w"] = {k: float(np.abs(speeds[k] - ref_w).max()) for k in speeds}
    row["agree"] = max(row["dphi"].values()) < TOL_AGREE
    worst = max(row["dphi"], key=row["dphi"].get)
    print(f"  N={n:4d} at t = {T_CMP:g} s: max |dphi| vs mechnet Adams {row['dphi'][worst]:.1e} rad ({worst}); "
          f"errors vs reference: " + ", ".join(f"{k} {v:.1e}" for k, v in row["err_ref"].items()), flush=True)

    # --- totals (build + first call: from nothing to the first result)
    row["mn_total"] = row["mn_build"] + row["mn"]["cvodes-adams"]["first"]
    row["hand_total"] = row["hand"]["cvodes-adams"]["build"] + row["hand"]["cvodes-adams"]["first"]
    row["pydy_total"] = row["pydy"]["build"] + row["pydy"]["first"] if row["pydy"] else None
    return row


# ----------------------------------------------------------------------------- report
def _f(v, fmt="{:.3f}", width=8, star=False):
    if v is None:
        return f"{'skip':>{width}}"
    return f"{fmt.format(v) + ('*' if star else ''):>{width}}"


def print_tables(rows, pydy_max):
    a, i = "cvodes-adams", "idas"
    head = (f"{'N':>4} | {'mn build':>8} {'mn first':>8} {'mn sim':>7} {'mn integ':>8} {'mn idas':>8} | {'hd build':>8} "
            f"{'hd sim':>7} {'hd idas':>8} | {'sim':>5} {'idas':>5} | {'py build':>8} {'py sim':>7} | "
            f"{'mn tot':>7} {'hd tot':>7} {'py tot':>7} | {'mn<hd':>5} {'mn<py':>5}")
    print("timings (s)")
    print(head)
    print("-" * len(head))
    for r in rows:
        mn_a, mn_i, hd_a, hd_i, py = r["mn"][a], r["mn"][i], r["hand"][a], r["hand"][i], r["pydy"]
        ratio_a, ratio_i = mn_a["sim"] / hd_a["sim"], mn_i["sim"] / hd_i["sim"]
        beats_py = "skip" if py is None else ("yes" if r["mn_total"] < r["pydy_total"] else "no")
        print(f"{r['n']:4d} | {r['mn_build']:8.3f} {mn_a['first']:8.3f} {_f(mn_a['sim'], width=7, star=mn_a['reps'] < REPEATS)} "
              f"{mn_a['integ']:8.3f} {_f(mn_i['sim'], star=mn_i['reps'] < REPEATS)} | {hd_a['build']:8.3f} "
              f"{_f(hd_a['sim'], width=7, star=hd_a['reps'] < REPEATS)} {_f(hd_i['sim'], star=hd_i['reps'] < REPEATS)} | "
              f"{ratio_a:5.2f} {ratio_i:5.2f} | {_f(py and py['build'])} "
              f"{_f(py and py['sim'], width=7, star=bool(py) and py['reps'] < REPEATS)} | "
              f"{r['mn_total']:7.3f} {r['hand_total']:7.3f} {_f(r['pydy_total'], width=7)} | "
              f"{'yes' if r['mn_total'] < r['hand_total'] else 'no':>5} {beats_py:>5}")
    print(f"(mn build: model construction + compile; mn first: first cm.simulate (builds the CasADi integrator); "
          f"sim: best of {REPEATS} after the first call,\n * = one call only; mn integ: the bare call of mechnet's CasADi integrator (Adams), without initialisation and\n output evaluation; hd build: symbolic build + "
          f"ca.integrator construction, per solver; py build: KanesMethod + code generation; sim, idas: the ratios\n"
          f" mechnet / hand-written for the same solver; tot = build + first call (from nothing to the first result), "
          f"Adams for mechnet and hand, DOP853 for PyDy;\n skip = PyDy not run (N > --pydy-max {pydy_max}))")
    print()

    head = (f"{'N':>4} {'mn ops':>7} {'ops/link':>8} {'hd SX ops':>9} {'steps mn/hd Adams':>17} "
            f"{'steps mn/hd IDAS':>16} {'py nfev':>8} | {'dphi mn idas':>12} {'hd Adams':>8} {'hd IDAS':>8} "
            f"{'PyDy':>8} | {'max dw':>7} | {'max err ref':>11}")
    print(f"size, steps and agreement at t = {T_CMP:g} s (dphi: max |Δ relative angle| vs mechnet Adams, rad; "
          f"dw: rad/s; err ref: worst model vs the reference, rad)")
    print(head)
    print("-" * len(head))
    for r in rows:
        py = r["pydy"]
        d = r["dphi"]
        print(f"{r['n']:4d} {r['ops']:7d} {r['ops'] / r['n']:8.1f} {r['hand_ops']:9d} "
              f"{str(r['mn'][a]['nsteps']) + '/' + str(r['hand'][a]['nsteps']):>17} "
              f"{str(r['mn'][i]['nsteps']) + '/' + str(r['hand'][i]['nsteps']):>16} "
              f"{_f(py and py['nfev'], '{:d}')} | {d['mn idas']:12.1e} {d['hand cvodes-adams']:8.1e} "
              f"{d['hand idas']:8.1e} {_f(d.get('pydy DOP853'), '{:.1e}')} | {max(r['dw'].values()):7.1e} | "
              f"{max(r['err_ref'].values()):11.1e}")
    print(f"(hd SX ops: instructions of the hand model's SX mass matrix + force function, before the dense "
          f"{HAND_LINSOL} solve; reference: hand model, CVODES-Adams, rtol = atol = {REF_TOL:g}, to t = {T_CMP:g} s)")
    print()

    print("mechnet compile stages (s):")
    stages = list(rows[0]["stages"])
    print(f"{'N':>4} {'construct':>9} " + " ".join(f"{s:>8}" for s in stages) + f" {'compile':>8}")
    for r in rows:
        print(f"{r['n']:4d} {r['mn_construct']:9.3f} " + " ".join(f"{r['stages'][s]:8.3f}" for s in stages)
              + f" {r['mn_compile']:8.3f}")
    pyrows = [r for r in rows if r["pydy"]]
    if pyrows:
        print()
        print(f"PyDy (generator {pyrows[0]['pydy']['generator']!r}):")
        print(f"{'N':>4} {'derive s':>9} {'codegen s':>9} {'first s':>8} {'sim s':>7}")
        for r in pyrows:
            py = r["pydy"]
            print(f"{r['n']:4d} {py['derive']:9.3f} {py['codegen']:9.3f} {py['first']:8.3f} {py['sim']:7.3f}")


def check_targets(rows):
    """Print each target of the issue as met / missed, with the measured figures."""
    a = "cvodes-adams"
    by_n = {r["n"]: r for r in rows}
    lines = []

    def verdict(ok):
        return "MET   " if ok else "MISSED"

    sel = [r for r in rows if r["n"] >= 10 and r["pydy"]]
    if sel:
        ok = all(r["mn_total"] < r["pydy_total"] for r in sel)
        lines.append(f"{verdict(ok)} build + simulation faster than PyDy for N >= 10: " + ", ".join(
            f"N={r['n']} {r['mn_total']:.2f} vs {r['pydy_total']:.2f} s" for r in sel))
    sel = [r for r in rows if r["n"] >= 40]
    if sel:
        ok = all(r["mn_total"] < r["hand_total"] for r in sel)
        lines.append(f"{verdict(ok)} build + simulation faster than the hand-written model for N >= 40: " + ", ".join(
            f"N={r['n']} {r['mn_total']:.2f} vs {r['hand_total']:.2f} s" for r in sel))
    ratios = {r["n"]: r["mn"][a]["sim"] / r["hand"][a]["sim"] for r in rows}
    lines.append(f"{verdict(all(v <= 1.3 for v in ratios.values()))} simulation within 1.3x of the hand-written "
                 f"CVODES-Adams model at every N: " + ", ".join(f"N={n} {v:.2f}x" for n, v in ratios.items())
                 + "  (bare integrator / hand: " + ", ".join(
                     f"N={r['n']} {r['mn'][a]['integ'] / r['hand'][a]['sim']:.2f}x" for r in rows) + ")")
    if 40 in by_n:
        r = by_n[40]
        lines.append(f"{verdict(r['mn_compile'] < 1.0)} N = 40 compiles in under 1 s: compile {r['mn_compile']:.3f} s "
                     f"(+ construction {r['mn_construct']:.3f} s = {r['mn_build']:.3f} s)")
        lines.append(f"{verdict(r['mn'][a]['sim'] < 0.5)} N = 40 simulates in under 0.5 s (cvodes-adams): "
                     f"{r['mn'][a]['sim']:.3f} s cached (first call, incl. building the integrator: "
                     f"{r['mn'][a]['first']:.3f} s)")
    if 100 in by_n:
        r = by_n[100]
        lines.append(f"{verdict(r['mn_compile'] < 5.0)} N = 100 compiles in under 5 s: compile {r['mn_compile']:.3f} s "
                     f"(+ construction {r['mn_construct']:.3f} s = {r['mn_build']:.3f} s)")
    print("targets:")
    for line in lines:
        print("  " + line)


def plot(rows, path: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a, i = "cvodes-adams", "idas"
    ns = [r["n"] for r in rows]
    py = [r for r in rows if r["pydy"]]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 5))
    ax1.loglog(ns, [r["mn_build"] for r in rows], "o-", color="C0", label="mechnet: construct + compile")
    ax1.loglog(ns, [r["mn_build"] + r["mn"][a]["first"] for r in rows], "o:", color="C0",
               label="mechnet: + first simulate (Adams)")
    ax1.loglog(ns, [r["hand"][a]["build"] for r in rows], "s-", color="C1",
               label="hand CasADi: symbolic + ca.integrator (Adams)")
    ax1.loglog(ns, [r["hand_total"] for r in rows], "s:", color="C1", label="hand CasADi: + first call (Adams)")
    if py:
        ax1.loglog([r["n"] for r in py], [r["pydy"]["build"] for r in py], "^-", color="C2",
                   label=f"PyDy: KanesMethod + codegen ({py[0]['pydy']['generator']})")
        ax1.loglog([r["n"] for r in py], [r["pydy_total"] for r in py], "^:", color="C2",
                   label="PyDy: + first solve_ivp")
    ax1.set_xlabel("N (links)")
    ax1.set_ylabel("wall time [s]")
    ax1.set_title("build (solid) and build + first simulation (dotted)")
    ax2.loglog(ns, [r["mn"][a]["sim"] for r in rows], "o-", color="C0", label="mechnet cvodes-adams")
    ax2.loglog(ns, [r["mn"][i]["sim"] for r in rows], "o--", color="C0", label="mechnet idas")
    ax2.loglog(ns, [r["hand"][a]["sim"] for r in rows], "s-", color="C1", label="hand CasADi cvodes-adams")
    ax2.loglog(ns, [r["hand"][i]["sim"] for r in rows], "s--", color="C1", label="hand CasADi idas")
    if py:
        ax2.loglog([r["n"] for r in py], [r["pydy"]["sim"] for r in py], "^-", color="C2", label="PyDy + DOP853")
    ax2.set_xlabel("N (links)")
    ax2.set_ylabel(f"10 s simulation wall time [s] (best of {REPEATS})")
    ax2.set_title(f"simulation, rtol = atol = {RTOL:g}, n_out = {N_OUT}")
    for ax in (ax1, ax2):
        ax.set_xticks(ns, [str(n) for n in ns])
        ax.minorticks_off()
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("chain3d: N-link planar pendulum")
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


def _versions() -> str:
    out = []
    for name, mod in (("sympy", "sympy"), ("pydy", "pydy"), ("cython", "Cython")):
        try:
            out.append(f"{name} {__import__(mod).__version__}")
        except ImportError:
            out.append(f"{name} missing")
    return ", ".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help=f"N = {', '.join(map(str, QUICK_NS))} only")
    ap.add_argument("--n", type=int, nargs="+", help=f"list of N (default {' '.join(map(str, DEFAULT_NS))})")
    ap.add_argument("--pydy-max", type=int, default=40, metavar="N",
                    help="run PyDy only up to this N (its derivation grows fast; default 40; 0 = never)")
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)
    ns = args.n or list(QUICK_NS if args.quick else DEFAULT_NS)

    print(f"chain3d: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"scipy {scipy.__version__}, {_versions()}, mechnet {getattr(mn, '__version__', '?')}")
    print(f"machine: platform.processor() = {platform.processor()!r}, {_cpu_model()}, {os.cpu_count()} cores, "
          f"{platform.system()} {platform.release()}")
    print(f"command: python {' '.join(sys.argv)}; mechnet at git {_git_head()}")
    print(f"chain: m = {MASS:g}, L = {LENGTH:g}, g = {G:g}; t_end = {T_END:g} s, rtol = {RTOL:g}, atol = {ATOL:g}, "
          f"n_out = {N_OUT}; timings best of {REPEATS}; hand model linear solver {HAND_LINSOL!r}; "
          f"PyDy up to N = {args.pydy_max}\n")

    rows = []
    for n in ns:
        rows.append(bench_n(n, args.pydy_max))
    print()
    print_tables(rows, args.pydy_max)
    print()
    check_targets(rows)
    if len(rows) >= 2 and not args.no_plot:
        plot(rows, Path(__file__).with_suffix(".png"))
    bad = [r for r in rows if not r["agree"]]
    assert not bad, "models disagree at t = 1 s: " + "; ".join(
        f"N={r['n']}: " + ", ".join(f"{k} {v:.1e}" for k, v in r["dphi"].items() if v >= TOL_AGREE) for r in bad)
    print(f"all models agree at t = {T_CMP:g} s to {TOL_AGREE:g} rad in every relative angle")


if __name__ == "__main__":
    main()
