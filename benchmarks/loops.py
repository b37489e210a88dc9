"""loops — work-precision of mechnet on planar kinematic loops against hand-written CasADi.

Why: a kinematic loop makes a multibody model an index-3 DAE; mechnet cuts the loop,
reduces the index and watches its state selection while integrating, where a modeller
writing the mechanism by hand picks coordinates once. What does that cost at equal accuracy?

Scenes (tests/models.py), 1 DOF each, released at rest under gravity (9.81 m/s², -y),
a constant crank torque against a crank damper (added here), 5-6 crank turns in 2 s:
  * four_bar():     a, b, c, d = 0.2, 0.6, 0.5, 0.6 m (crank-rocker), 5 N·m, 0.2 N·m·s;
  * slider_crank(): r, l = 0.1, 0.35 m, piston 0.5 kg, 1 N·m, 0.05 N·m·s.

Hand-written model (derived here, not from mechnet): absolute link angles (and the
piston position) q; bodies with mass centres p(q) and angles th(q) (rods: centre at
L/2, m L²/12 about it); M = sum m J_pᵀJ_p + I J_thᵀJ_th, Q = -dV/dq - sum m J_pᵀ J_p' qd
+ drive; loop closure Phi(q) = 0 (2 equations). Index-1 DAE for IDAS (CasADi defaults):
x = (crank angle, speed), z = (dependent q, dependent qd, qdd, lambda),
alg = [Phi; Phi_q qd; M qdd + Phi_qᵀ lambda - Q; Phi_q qdd + (Phi_q qd)_q qd].

Timing: best of 7 of `cm.simulate` (after `compile()` and one untimed call per rtol) and
of the call of the hand integrator (built untimed). Error: max |crank angle - reference|
on the output grid.

Equal error: a single run's error moves by 3-6x between neighbouring rtols, for either
tool. Both are therefore also run at 41 rtols (quarter decades, 1e-2 ... 1e-12, best of 3),
and each tool's front (its runs that no other of its runs beats in both time and error)
gives its time to reach an error level, log-log between front points. The target is
judged on those times; the single-run ratios are printed too. Reference: the hand equations as an ODE in (crank angle, speed)
(dependent coordinates in closed form, qdd from the KKT system), CVODES-Adams at
rtol = atol = 1e-13 (the DAE's Newton iteration fails in IDAS below rtol 1e-10).
Before timing, mechnet at rtol 1e-10 must match it to 3e-7 rad at t_end (8e-9 of the
crank travel; measured 3e-8 with the monitor checking every 2 solver steps, 1e-7 with every 8).

mechnet checks once per compiled model, parameters and start point that its state selection
holds on the whole branch (mechnet/simulate/branch.py); both mechanisms pass, so the timed runs
integrate in one IDAS call without the monitor. The check's own cost is printed per mechanism
(a run from a new start point against a rerun).

Diagnostics (private mechnet internals, patched per call): the shares of mechnet's time in
its integrator calls and its state-selection monitor; runs with the monitor forced on (the
whole-branch check overridden), as before the check existed.

Usage:  python benchmarks/loops.py [--quick] [--no-plot]
"""
from __future__ import annotations

import argparse
import contextlib
import math
import platform
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
from models import four_bar, four_bar_angles, slider_crank  # noqa: E402

import mechnet as mn  # noqa: E402
from mechnet.components import rotational as rot  # noqa: E402
from mechnet.simulate import pieces as mn_pieces  # noqa: E402
from mechnet.simulate import run as mn_run  # noqa: E402
from mechnet.simulate.branch import Verdict  # noqa: E402
sys.path.insert(0, str(Path(__file__).resolve().parent))
import timing  # noqa: E402

G, T_END, N_OUT, REPEATS = 9.81, 2.0, 201, 7
RTOLS = (1e-4, 1e-6, 1e-8, 1e-10)
HAND_EXTRA = (1e-2, 1e-3)      # hand model only: extends its curve to mechnet's larger errors
SWEEP = tuple(10.0 ** (-2 - k / 4) for k in range(41))     # quarter decades, rtol 1e-2 ... 1e-12, both models
SWEEP_REPEATS = 3
LEVELS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)        # errors (rad) at which the fronts are compared
TARGET = 1.3
REF_TOL = 1e-13                # reference: the hand equations as an ODE, CVODES-Adams, rtol = atol
AGREE_RTOL, AGREE = 1e-10, 3e-7   # rad after ~38 rad of crank travel (8e-9 relative): the setups agree
FOUR_BAR = dict(a=0.2, b=0.6, c=0.5, d=0.6, theta2=0.3, masses=(1.0, 2.0, 1.5), tau=5.0, damping=0.2)
SLIDER = dict(r=0.1, l=0.35, theta0=0.4, masses=(1.0, 0.8, 0.5), tau=1.0, damping=0.05)


def atol_for(rtol):
    return max(rtol * 1e-2, 1e-11)     # mechnet's IDAS restarts can fail at atol 1e-12


# ----------------------------------------------------------------------------- mechnet
def mechnet_model(kind):
    """The factory's scene with the motor torque; a crank damper added between its `fixed` and the crank axis."""
    p = FOUR_BAR if kind == "four-bar" else SLIDER
    motor = rot.ConstantTorque(name="motor", tau_constant=p["tau"])
    model = four_bar(p["a"], p["b"], p["c"], p["d"], p["theta2"], masses=p["masses"], g=G, drive=motor) \
        if kind == "four-bar" else slider_crank(p["r"], p["l"], p["theta0"], masses=p["masses"], g=G, crank_drive=motor)
    damper = model.add(rot.Damper(name="damper", d=p["damping"]))
    model.connect(model.fixed.flange, damper.flange_a)
    model.connect(damper.flange_b, model.joint_a.axis)
    return model


# ----------------------------------------------------------------------------- hand-written CasADi
def e(th):
    return ca.vertcat(ca.cos(th), ca.sin(th))


def planar_model(q, bodies, closure, tau, damping):
    """M qdd + Phi_qᵀ lam = Q, Phi_q qdd = gamma; q[0] is the crank angle, driven by tau - damping·qd[0]."""
    n = q.numel()
    qd = ca.SX.sym("qd", n)
    M, Q = ca.SX.zeros(n, n), ca.SX.zeros(n)
    for mass, inertia, p, th in bodies:
        Jp, Jth = ca.jacobian(p, q), ca.jacobian(th, q)
        M += mass * Jp.T @ Jp + inertia * Jth.T @ Jth
        Q -= mass * Jp.T @ (ca.jacobian(Jp @ qd, q) @ qd)   # convective acceleration
        Q -= mass * G * Jp[1, :].T                          # gravity along -y
    Q[0] += tau - damping * qd[0]
    Phi_q = ca.jacobian(closure, q)
    return dict(q=q, qd=qd, M=M, Q=Q, Phi=closure, Phi_q=Phi_q, gamma=-ca.jacobian(Phi_q @ qd, q) @ qd)


def index1_dae(pm, q0):
    """The DAE for IDAS and a consistent (x0, z0) at rest from Newton's method."""
    q, qd, n = pm["q"], pm["qd"], pm["q"].numel()
    qdd, lam = ca.SX.sym("qdd", n), ca.SX.sym("lam", 2)
    x, z = ca.vertcat(q[0], qd[0]), ca.vertcat(q[1:], qd[1:], qdd, lam)
    alg = ca.vertcat(pm["Phi"], pm["Phi_q"] @ qd, pm["M"] @ qdd + pm["Phi_q"].T @ lam - pm["Q"],
                     pm["Phi_q"] @ qdd - pm["gamma"])
    x0 = np.array([q0[0], 0.0])
    newton = ca.rootfinder("init", "newton", ca.Function("g", [z, x], [alg]))
    z0 = np.array(newton(np.concatenate([q0[1:], np.zeros(2 * n + 1)]), x0)).ravel()
    return {"x": x, "z": z, "ode": ca.vertcat(qd[0], qdd[0]), "alg": alg}, x0, z0


def reference_ode(pm, q_of_crank):
    """The same equations as an ODE in (crank angle, speed), dependent coordinates in closed form."""
    q, qd = pm["q"], pm["qd"]
    th, w = ca.SX.sym("th"), ca.SX.sym("w")
    qq = q_of_crank(th)
    A = ca.substitute(pm["Phi_q"], q, qq)
    qdq = ca.vertcat(w, -ca.solve(A[:, 1:], A[:, 0] * w))
    kkt = ca.blockcat([[pm["M"], pm["Phi_q"].T], [pm["Phi_q"], ca.SX.zeros(2, 2)]])
    acc = ca.solve(kkt, ca.vertcat(pm["Q"], pm["gamma"]))[0]
    return {"x": ca.vertcat(th, w), "ode": ca.vertcat(w, ca.substitute(ca.substitute(acc, q, qq), qd, qdq))}


def hand_four_bar():
    p = FOUR_BAR
    a, b, c, d = p["a"], p["b"], p["c"], p["d"]
    m1, m2, m3 = p["masses"]
    q = ca.SX.sym("q", 3)                        # absolute angles of crank, coupler, rocker
    bodies = [(m1, m1 * a**2 / 12, a / 2 * e(q[0]), q[0]),
              (m2, m2 * b**2 / 12, a * e(q[0]) + b / 2 * e(q[1]), q[1]),
              (m3, m3 * c**2 / 12, ca.vertcat(d, 0) + c / 2 * e(q[2]), q[2])]
    closure = a * e(q[0]) + b * e(q[1]) - ca.vertcat(d, 0) - c * e(q[2])

    def angles(t2):      # Freudenstein's equation, open branch (rocker above the ground line)
        K1, K2, K3 = d / a, d / c, (a**2 - b**2 + c**2 + d**2) / (2 * a * c)
        A, B, C = ca.cos(t2) - K1 - K2 * ca.cos(t2) + K3, -2 * ca.sin(t2), K1 - (K2 + 1) * ca.cos(t2) + K3
        t4 = 2 * ca.atan2(-B - ca.sqrt(B**2 - 4 * A * C), 2 * A)
        return ca.vertcat(t2, ca.atan2(c * ca.sin(t4) - a * ca.sin(t2), d + c * ca.cos(t4) - a * ca.cos(t2)), t4)

    pm = planar_model(q, bodies, closure, p["tau"], p["damping"])
    q0 = np.array([p["theta2"], *four_bar_angles(a, b, c, d, p["theta2"])])
    return index1_dae(pm, q0), reference_ode(pm, angles)


def hand_slider_crank():
    p = SLIDER
    r, l = p["r"], p["l"]
    m1, m2, m3 = p["masses"]
    q = ca.SX.sym("q", 3)                        # crank angle, rod angle, piston position
    bodies = [(m1, m1 * r**2 / 12, r / 2 * e(q[0]), q[0]),
              (m2, m2 * l**2 / 12, r * e(q[0]) + l / 2 * e(q[1]), q[1]),
              (m3, 0.0, ca.vertcat(q[2], 0), 0 * q[2])]   # the piston slides without turning
    closure = r * e(q[0]) + l * e(q[1]) - ca.vertcat(q[2], 0)

    def coords(th):
        beta = -ca.asin(r * ca.sin(th) / l)
        return ca.vertcat(th, beta, r * ca.cos(th) + l * ca.cos(beta))

    pm = planar_model(q, bodies, closure, p["tau"], p["damping"])
    return index1_dae(pm, np.array(ca.evalf(coords(p["theta0"]))).ravel()), reference_ode(pm, coords)


def integrator(dae, grid, plugin, **opts):
    return ca.integrator("H", plugin, dae, float(grid[0]), [float(t) for t in grid[1:]],
                         dict(opts, max_num_steps=10**7, disable_internal_warnings=True))


def crank(F, x0, z0=None):
    out = F(x0=x0) if z0 is None else F(x0=x0, z0=z0)
    return np.concatenate([[x0[0]], np.array(out["xf"])[0]])


# ----------------------------------------------------------------------------- measurement
def best_of(fn, repeats=REPEATS):
    return timing.best_of(fn, repeats)


@contextlib.contextmanager
def patched(cls, name, value):
    saved = vars(cls).get(name)
    setattr(cls, name, value)
    try:
        yield
    finally:
        setattr(cls, name, saved) if saved is not None else delattr(cls, name)


def time_split(simulate):
    """Shares of one mechnet call spent in its integrator calls (_call) and its state-selection monitor."""
    spent = {"_call": 0.0, "_ratios": 0.0}

    def timer(key, f):
        def wrapper(*args, **kw):
            t0 = time.perf_counter()
            try:
                return f(*args, **kw)
            finally:
                spent[key] += time.perf_counter() - t0
        return wrapper
    run = mn_run.Run
    call = timer("_call", mn_run.call)           # the plain segments' calls and the monitored pieces'
    with patched(mn_run, "call", call), patched(mn_pieces, "call", call), \
            patched(run, "_ratios", timer("_ratios", run._ratios)):
        total, _ = best_of(simulate, 1)
    return spent["_call"] / total, spent["_ratios"] / total


def log_interp(err, curve):
    """The hand model's time at `err` (log-log); (time, '>') past its largest error (ratio is a lower bound)."""
    pts = sorted((c[2], c[1]) for c in curve)
    le, lt = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    if math.log(err) > le[-1]:
        return pts[-1][1], ">"
    return (math.exp(np.interp(math.log(err), le, lt)), "") if math.log(err) >= le[0] else (None, "")


def front(points):
    """The work-precision front of (error, time) runs: those no other run beats in both, by error."""
    out = []
    for err, t in sorted(points):
        if not out or t < out[-1][1]:
            out.append((err, t))
    return out


def time_to_reach(err, points):
    """A tool's time to reach error `err` from its runs (error, time): log-log interpolation on its front.
    Past the front's least accurate point it is that point's time: exact when some run was that
    inaccurate (it was slower), an upper bound '<' when none was. None below its most accurate run (or
    with no successful run)."""
    fr = front(points)
    if not fr:
        return None, ""
    le, lt = np.log([p[0] for p in fr]), np.log([p[1] for p in fr])
    if math.log(err) < le[0]:
        return None, ""
    if math.log(err) > le[-1]:
        return fr[-1][1], "<" if err > max(p[0] for p in points) else ""
    return math.exp(np.interp(math.log(err), le, lt)), ""


def sweep(cm, F_of, x0, z0, ref):
    """(error, time) of mechnet and of the hand model at every rtol of SWEEP (best of SWEEP_REPEATS),
    and the rtols at which each failed."""
    pts = {"mechnet": [], "hand": []}
    failed = {"mechnet": [], "hand": []}
    for rtol in SWEEP:
        atol = atol_for(rtol)

        def simulate():
            return cm.simulate(T_END, rtol=rtol, atol=atol, n_out=N_OUT)
        if simulate().success:
            t_mn, res = best_of(simulate, SWEEP_REPEATS)
            pts["mechnet"].append((float(np.abs(res["joint_a.phi"] - ref).max()), t_mn))
        else:
            failed["mechnet"].append(rtol)
        try:
            F = F_of(rtol, atol)
            t_hd, hd = best_of(lambda: crank(F, x0, z0), SWEEP_REPEATS)
            pts["hand"].append((float(np.abs(hd - ref).max()), t_hd))
        except RuntimeError:                     # IDAS's Newton iteration fails on the hand DAE below ~1e-10
            failed["hand"].append(rtol)
    return pts, failed


def bench(name, build_hand, rtols):
    grid = np.linspace(0.0, T_END, N_OUT)
    cm = mechnet_model(name).compile()
    (dae, x0, z0), ode = build_hand()
    ref, ref2 = (crank(integrator(ode, grid, "cvodes", reltol=tol, abstol=tol, linear_multistep_method="adams"), x0)
                 for tol in (REF_TOL, 10 * REF_TOL))
    check = cm.simulate(T_END, rtol=AGREE_RTOL, atol=atol_for(AGREE_RTOL), n_out=N_OUT)
    assert check.success and np.allclose(check.t, grid, rtol=0, atol=1e-12), check.failure
    gap = abs(check["joint_a.phi"][-1] - ref[-1])
    print(f"{name}: crank angle at t = {T_END:g} s: reference {ref[-1]:.9f} rad ({ref[-1] / (2 * math.pi):.2f} turns; "
          f"{np.abs(ref2 - ref).max():.0e} rad from tol {10 * REF_TOL:g}); mechnet at rtol {AGREE_RTOL:g} "
          f"differs by {gap:.1e} rad", flush=True)
    assert gap < AGREE, f"{name}: mechnet and the hand model disagree by {gap:.1e} rad at t_end"

    rows, curve = [], []               # curve: the hand model's (rtol, time, error), HAND_EXTRA included
    for rtol in sorted(set(rtols) | set(HAND_EXTRA), reverse=True):
        atol = atol_for(rtol)
        F = integrator(dae, grid, "idas", reltol=rtol, abstol=atol)
        t_hd, hd = best_of(lambda: crank(F, x0, z0))
        curve.append((rtol, t_hd, float(np.abs(hd - ref).max()), F.stats()["nsteps"]))
        if rtol not in rtols:
            continue

        def simulate():
            return cm.simulate(T_END, rtol=rtol, atol=atol, n_out=N_OUT)
        simulate()                                              # untimed: builds mechnet's integrators
        t_mn, res = best_of(simulate)
        assert res.success, f"{name}: mechnet failed at rtol {rtol:g}: {res.failure}"
        integ, monitor = time_split(simulate)
        if rtol == rtols[0]:                                    # the check's cost: a new start point each time
            def fresh():
                cm.selection_factory.__dict__.pop("_branch_verdicts", None)
                return cm.simulate(T_END, rtol=rtol, atol=atol, n_out=N_OUT)
            t_fresh, _ = best_of(fresh)
            print(f"  whole-branch check: {res.stats['selection']}; a new start point adds "
                  f"{(t_fresh - t_mn) * 1e3:.1f} ms to the run ({t_fresh:.3f} s against {t_mn:.3f} s)", flush=True)
        forced = lambda self, values, params: Verdict(False, "forced on (diagnostic)")     # noqa: E731
        with patched(mn_run.SelectionMonitor, "whole_branch", forced):
            simulate()
            t_nm, nm = best_of(simulate)
        row = dict(mech=name, rtol=rtol, atol=atol, t_mn=t_mn, t_hd=t_hd, err_hd=curve[-1][2], steps_hd=curve[-1][3],
                   err_mn=float(np.abs(res["joint_a.phi"] - ref).max()), steps_mn=res.stats["nsteps"],
                   segments=res.stats["segments"], integ=integ, monitor=monitor, t_nm=t_nm,
                   err_nm=float(np.abs(nm["joint_a.phi"] - ref).max()))
        rows.append(row)
        print(f"  rtol {rtol:.0e}: mechnet {t_mn:.3f} s (monitor forced on {t_nm:.3f} s), hand {t_hd:.4f} s", flush=True)
    for row in rows:
        row["eq"], row["eq_nm"] = log_interp(row["err_mn"], curve), log_interp(row["err_nm"], curve)
    points = sweep(cm, lambda rtol, atol: integrator(dae, grid, "idas", reltol=rtol, abstol=atol), x0, z0, ref)
    cost = [ln.strip() for ln in cm.summary().splitlines() if ln.strip().startswith(("states", "algebraics", "cost"))]
    n_alg = ca.Function("alg", [dae["x"], dae["z"]], [dae["alg"]]).n_instructions()
    return rows, curve, points, (f"{name}: mechnet {'; '.join(cost)}\n    hand: 2 states, {dae['z'].numel()} algebraics, "
                         f"{n_alg} instructions in alg")


def ratio_text(t, eq):
    return "n/a" if eq[0] is None else f"{eq[1]}{t / eq[0]:.1f}"


def plot(rows, curves, path, sweeps):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    for k, (mech, curve) in enumerate(curves.items()):
        sel = [r for r in rows if r["mech"] == mech]
        ax.loglog([r["t_mn"] for r in sel], [r["err_mn"] for r in sel], "o-", color=f"C{k}", label=f"{mech}: mechnet")
        ax.loglog([r["t_nm"] for r in sel], [r["err_nm"] for r in sel], "^:", color=f"C{k}",
                  label=f"{mech}: mechnet, monitor forced on (diagnostic)")
        ax.loglog([c[1] for c in curve], [c[2] for c in curve], "s--", color=f"C{k}", mfc="none",
                  label=f"{mech}: hand-written CasADi DAE")
        for who, pts, mark in (("mechnet", sweeps[mech][0]["mechnet"], "-"), ("hand", sweeps[mech][0]["hand"], "--")):
            fr = front(pts)
            ax.loglog([p[1] for p in pts], [p[0] for p in pts], ".", color=f"C{k}", alpha=0.35, ms=3)
            ax.loglog([p[1] for p in fr], [p[0] for p in fr], mark, color=f"C{k}", lw=0.8, alpha=0.6,
                      label=f"{mech}: {who} front ({len(SWEEP)} rtols)")
        for r in sel:
            ax.annotate(f"{r['rtol']:.0e}", (r["t_mn"], r["err_mn"]), fontsize=7, xytext=(4, 2), textcoords="offset points")
    ax.set(xlabel=f"wall time per simulation [s] (best of {REPEATS})", ylabel="max |crank angle error| [rad]",
           title=f"kinematic loops: work-precision, IDAS, {T_END:g} s (labels: mechnet's rtol)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="rtol 1e-4 and 1e-6 only")
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args()
    rev = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=HERE, capture_output=True, text=True).stdout
    print(f"loops: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"mechnet {mn.__version__} (git {rev.strip()}); {T_END:g} s, n_out {N_OUT}, IDAS, atol = max(rtol/100, 1e-11)")
    rows, curves, sweeps, costs = [], {}, {}, []
    for name, build_hand in (("four-bar", hand_four_bar), ("slider-crank", hand_slider_crank)):
        r, curves[name], sweeps[name], cost = bench(name, build_hand, RTOLS[:2] if args.quick else RTOLS)
        rows += r
        costs.append(cost)

    head = (f"{'mechanism':<13}{'rtol':>6} {'mn s':>6} {'hand s':>6} {'ratio':>5} {'mn err':>7} {'hd err':>7} "
            f"{'eq-err':>6} | {'steps mn/hd':>11} {'segs':>4} {'integ':>5} {'monit':>5} | {'forced s':>8} "
            f"{'err':>7} {'eq-err':>6}")
    print("\n" + head + "\n" + "-" * len(head))
    for r in rows:
        print(f"{r['mech']:<13}{r['rtol']:6.0e} {r['t_mn']:6.3f} {r['t_hd']:6.4f} {r['t_mn'] / r['t_hd']:5.1f} "
              f"{r['err_mn']:7.1e} {r['err_hd']:7.1e} {ratio_text(r['t_mn'], r['eq']):>6} | "
              f"{str(r['steps_mn']) + '/' + str(r['steps_hd']):>11} {r['segments']:4d} {r['integ']:5.0%} "
              f"{r['monitor']:5.0%} | {r['t_nm']:8.3f} {r['err_nm']:7.1e} {ratio_text(r['t_nm'], r['eq_nm']):>6}")
    print(f"(s: best of {REPEATS}; ratio: mechnet / hand at the same rtol; err: max |crank angle - reference| on the "
          "output grid, rad; eq-err: mechnet time / hand\n time interpolated log-log at mechnet's error ('>': lower "
          "bound); segs: mechnet's integrator calls; integ, monit: shares of mechnet's time in\n those calls and in "
          "its state-selection monitor; forced: mechnet with the monitor forced on (diagnostic, private patch))")
    print("\n".join(costs))
    eq = [(r, r["t_mn"] / r["eq"][0]) for r in rows if r["eq"][0] is not None]
    print("single runs (the rows above): " + ", ".join(f"{r['mech']} {r['rtol']:.0e} {r['eq'][1]}{v:.1f}x"
                                                       for r, v in eq))
    passed, missed, undecided = print_fronts(sweeps)
    verdict = "MISSED" if missed or not passed else "UNDECIDED" if undecided else "MET"
    print(f"{verdict}: mechnet's time to reach each error of {LEVELS[0]:.0e} … {LEVELS[-1]:.0e} rad within {TARGET}x "
          f"of the hand-written model's (work-precision fronts)" + (": " + ", ".join(missed) if missed else "")
          + (f"; undecided (a time known only as a bound): {', '.join(undecided)}" if undecided else ""))
    if not args.no_plot:
        plot(rows, curves, HERE / "loops.png", sweeps)


def print_fronts(sweeps):
    """Time to reach each error level on each tool's front, mechnet / hand, and the verdict per level:
    a ratio where both reach it; a miss where only the hand model does (mechnet cannot reach that
    accuracy in the sweep); a '<' bound where one tool's least accurate run is already more accurate,
    counted only when the bound decides; no verdict where neither reaches it or only mechnet does."""
    head = f"{'mechanism':<13}" + "".join(f"{e:>10.0e}" for e in LEVELS)
    print(f"\ntime to reach a crank-angle error (rad) on the work-precision fronts ({len(SWEEP)} rtols, "
          f"{SWEEP[0]:.0e} … {SWEEP[-1]:.0e}, quarter decades, best of {SWEEP_REPEATS}): mechnet / hand\n{head}\n"
          + "-" * len(head))
    passed, missed, undecided = [], [], []
    for mech, (pts, failed) in sweeps.items():
        cells = []
        for level in LEVELS:
            (t_mn, b_mn), (t_hd, b_hd) = time_to_reach(level, pts["mechnet"]), time_to_reach(level, pts["hand"])
            if t_hd is None:                      # the hand model cannot reach it: no verdict
                cells.append("hd -" if t_mn is not None else "-")
                continue
            if t_mn is None:                      # only the hand model reaches it: a miss
                cells.append("mn -")
                missed.append(f"{mech} {level:.0e} (mechnet does not reach it)")
                continue
            ratio = t_mn / t_hd
            if b_mn and b_hd:                     # both upper bounds: undecided
                cells.append(f"~{ratio:.2f}")
                undecided.append(f"{mech} {level:.0e}")
            elif b_mn:                            # mechnet's time is an upper bound: decides a pass only
                cells.append(f"<{ratio:.2f}")
                (passed.append(ratio) if ratio <= TARGET else undecided.append(f"{mech} {level:.0e}"))
            elif b_hd:                            # the hand model's is: decides a miss only
                cells.append(f">{ratio:.2f}")
                (missed.append(f"{mech} {level:.0e} >{ratio:.2f}x") if ratio > TARGET
                 else undecided.append(f"{mech} {level:.0e}"))
            else:
                cells.append(f"{ratio:.2f}")
                (passed if ratio <= TARGET else missed).append(ratio if ratio <= TARGET else
                                                               f"{mech} {level:.0e} {ratio:.2f}x")
        print(f"{mech:<13}" + "".join(f"{c:>10}" for c in cells))
        for who in ("mechnet", "hand"):
            if failed[who]:
                print(f"  {mech}: {who} failed at rtol " + ", ".join(f"{r:.1e}" for r in failed[who]))
        if failed["mechnet"]:                     # a failed run is a miss whatever the fronts say
            missed.append(f"{mech}: mechnet failed at {len(failed['mechnet'])} rtol(s)")
    print("(each tool's front: its runs that no other of its runs beats in both time and error; times between "
          "front points\n interpolated log-log. '<' / '>': no run of one tool was that inaccurate, the ratio "
          "is a bound;\n 'mn -': only the hand model reaches that error (a miss), 'hd -': "
          "only mechnet. A single run's error moves by 3-6x\n between neighbouring rtols, so the fronts, not single "
          "runs, give the time at equal error.)")
    return passed, missed, undecided


if __name__ == "__main__":
    main()
