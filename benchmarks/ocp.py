"""ocp — cart-pole swing-up: mechnet.ocp against the same problem written by hand in CasADi's Opti.

The scene (mechnet.components.multibody, gravity 9.81 m/s² along −y): World → Prismatic `rail`
(n = x, use_flange; a translational Force `push` on its axis flange, a Fixed on its support) → cart
Particle (M_CART), and on the cart a Revolute `hinge` about z → FixedTranslation r = [0, −L, 0] →
pole-tip Particle (M_TIP). States rail.s, rail.v, hinge.phi, hinge.w; hinge.phi = 0 hangs, π stands.

The problem: from hanging at rest (all states 0) to upright at rest with the cart back at 0 in
T_SWING s, |push.f| <= F_MAX, minimise ∫ push.f² dt.

The hand model: the textbook cart-pole (point mass on a massless pole) in the same coordinates,
    (M + m) s'' + m L (cos φ φ'' − sin φ φ'²) = u,   L φ'' + cos φ s'' + g sin φ = 0,
checked against cm.simulate before anything is compared (a constant push from a tilted start).

Methods, each at N = 50, 100, 200 in the same run:
  * mechnet Collocation(N, degree=3) (Radau, piecewise-constant controls, exact Hessian);
  * hand: the same direct collocation in casadi.Opti — the same decision variables in the same
    order (all controls, then X_0, then per interval the 3 collocation states and the next node),
    the same constraint rows in the same order and form ((h f − Σ C x) at the collocation points,
    continuity, start and end values as rows), the same quadrature of ∫u², the same initial guess
    (states held at their start values, controls 0: mechnet's guess=None) and the same IPOPT
    options (exact Hessian, print_level 0, sb yes). The control bounds reach IPOPT as bounds of the
    variables in mechnet (lbx/ubx); Opti passes opti.bounded(...) as constraint rows unless the
    nlpsol option "detect_simple_bounds" is set, which also moves the start and end rows (each on a
    single variable) into the bounds. Both hand variants are timed: "hand-g" (rows) and "hand-b"
    (detect_simple_bounds);
  * rockit (rockit-meco, optional: skipped with a note if `import rockit` fails): the same ODE
    (hand_ode), bounds, boundary values, ∫u² (ocp.integral), initial guess and IPOPT options, with
    DirectCollocation(N, M=1, degree=3, scheme="radau"). Its variables are ordered per interval
    (X_k, U_k, collocation states) and the bounds stay rows, as in hand-g. Its collocation rows are
    (Σ C x)/h − f, i.e. the hand rows divided by h, so IPOPT's line search takes other steps.
    Two variants: "rockit" (as written above, one run, N = 50 only: thousands of iterations) and
    "rockit-s" (set_der(x, f, scale=1/h), which gives back the rows Σ C x − h f; all N, best of REPEATS);
  * mechnet MultipleShooting(N, integrator="cvodes", rtol=1e-8, atol=1e-10) (limited-memory
    Hessian, its default) at N = 50, 100 (N = 200 with --shooting-200); no hand counterpart.

Times (s): "total" = everything after the model is compiled: ocp.Problem + prob.solve
(transcription, nlpsol construction, IPOPT, the Solution) for mechnet; the Opti construction and
opti.solve() (which builds the nlpsol) for the hand code; rockit.Ocp through ocp.solve() for
rockit. "solve" = the IPOPT call alone (mechnet: sol.stats["wall_time"]; hand and rockit: the
nlpsol's t_wall_total). "fun" = time in CasADi function
evaluations (Σ t_wall_nlp_* of the nlpsol's stats = sol.stats["function_time"]); "ipopt" = solve −
fun (IPOPT's own linear algebra, plus mechnet's per-iteration progress callback). "ratio" =
mechnet/hand-b total; "ratio rk" = mechnet/rockit-s total. Collocation: best of REPEATS runs each
(by total); shooting and the unscaled rockit: one run. Objectives of mechnet collocation, the hand
code and both rockit variants must agree within 1e-6 relative (else FAIL): it is the same NLP
(rows scaled differently for rockit), and with piecewise-constant u the Radau quadrature of u² is
exactly h Σ u_k² in all of them.

Usage:  python benchmarks/ocp.py [--quick] [--repeats 3] [--shooting-200] [--profile N]
        (--quick: N = 50, 100; shooting at N = 50 only; best of 1.
         --profile N: where mechnet's collocation time goes at N, against hand-b)
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from importlib import metadata
from pathlib import Path

import casadi as ca
import numpy as np

import mechnet as mn
from mechnet import ocp
from mechnet.scene import load_scene

try:
    import rockit
except ImportError:                           # optional: the `bench` extra installs rockit-meco
    rockit = None

sys.path.insert(0, str(Path(__file__).resolve().parent))
from chain3d import _cpu_model, _git_head  # noqa: E402  (importable: its work runs under __main__ only)

CART_POLE = load_scene(Path(__file__).resolve().parents[1] / "examples" / "cart_pole_swing_up.py")
M_CART, M_TIP, L = (CART_POLE.build.__globals__[k] for k in ("M_CART", "M_TIP", "L"))   # kg, kg, m
G = 9.81                                      # m/s² (mb.World's default)
T_SWING, F_MAX = 2.5, 20.0                    # s, N (T = 2 s: 748-775 iterations at N = 200, see docs)
X_START = (0.0, 0.0, 0.0, 0.0)                # rail.s, rail.v, hinge.phi, hinge.w: hanging at rest
X_END = (0.0, 0.0, math.pi, 0.0)              # upright at rest, cart back at 0
STATES = ("rail.s", "rail.v", "hinge.phi", "hinge.w")
NS, QUICK_NS = (50, 100, 200), (50, 100)
ROCKIT_UNSCALED_NS = (50,)                    # 2267 iterations, about 20 s, at N = 50
SHOOTING_NS, QUICK_SHOOTING_NS = (50, 100), (50,)
REPEATS = 3
DEGREE = 3
IPOPT = {"print_level": 0, "sb": "yes"}       # mechnet's own defaults for a quiet solve
EXPAND = True      # nlpsol "expand" (MX graph to SX) as mechnet's Collocation does by default: the same for all
OBJ_RTOL = 1e-6
MODEL_TOL = 1e-8                              # |mechnet − hand| of the simulated states


# ---- the model, twice ---------------------------------------------------------------------------

def build() -> mn.Model:
    """mechnet's model: the example scene itself (examples/cart_pole_swing_up.py), hanging at rest."""
    return CART_POLE.model()


def hand_ode() -> ca.Function:
    """xdot = f(x, u), x = (s, v, φ, w): the cart-pole solved for s'' and φ''."""
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u")
    v, phi, w = x[1], x[2], x[3]
    sin, cos = ca.sin(phi), ca.cos(phi)
    a = (u + M_TIP * sin * (L * w ** 2 + G * cos)) / (M_CART + M_TIP * sin ** 2)
    alpha = -(G * sin + cos * a) / L
    return ca.Function("cart_pole", [x, u], [ca.vertcat(v, a, w, alpha)], ["x", "u"], ["xdot"])


def check_model(cm, f) -> float:
    """max |state(mechnet) − state(hand)| over 2 s from φ = 1 rad, w = 2 rad/s, v = −0.5 m/s under a
    constant 5 N (both integrated to 1e-12)."""
    start = {"rail.s": 0.1, "rail.v": -0.5, "hinge.phi": 1.0, "hinge.w": 2.0}
    u, t_out = 5.0, np.linspace(0.0, 2.0, 41)
    res = cm.simulate(2.0, t_out=t_out, start=start, inputs={"push.f": u}, rtol=1e-12, atol=1e-12)
    x = ca.SX.sym("x", 4)
    integ = ca.integrator("hand", "cvodes", {"x": x, "ode": f(x, u)}, 0.0, t_out[1:],
                          {"reltol": 1e-12, "abstol": 1e-12})
    X = np.asarray(integ(x0=[start[n] for n in STATES])["xf"])
    return max(float(np.max(np.abs(np.asarray(res[n])[1:] - X[k]))) for k, n in enumerate(STATES))


# ---- mechnet ---------------------------------------------------------------------------------------

def mechnet_problem(cm) -> ocp.Problem:
    prob = ocp.Problem(cm, t_final=T_SWING)
    prob.bounds("push.f", -F_MAX, F_MAX)
    for name, value in zip(STATES, X_END):
        prob.subject_to(prob.at_end(prob.var(name)) == value)
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    return prob


def run_mechnet(cm, method) -> dict:
    t0 = time.perf_counter()
    sol = mechnet_problem(cm).solve(method, ipopt=dict(IPOPT), progress=False)
    total = time.perf_counter() - t0
    s = sol.stats
    return {"ok": sol.success, "total": total, "solve": s["wall_time"], "fun": s["function_time"],
            "iter": s["iterations"], "obj": s["objective"], "status": s["status"], "sol": sol}


# ---- by hand -------------------------------------------------------------------------------------

def radau(degree):
    """tau (0 first), C[r, j] = l_r'(tau_j), D[r] = l_r(1), B[r] = ∫_0^1 l_r (the CasADi example)."""
    tau = np.append(0.0, ca.collocation_points(degree, "radau"))
    C, D, B = np.zeros((degree + 1, degree + 1)), np.zeros(degree + 1), np.zeros(degree + 1)
    for r in range(degree + 1):
        p = np.poly1d([1.0])
        for k in range(degree + 1):
            if k != r:
                p *= np.poly1d([1.0, -tau[k]]) / (tau[r] - tau[k])
        D[r], C[r], B[r] = p(1.0), np.polyder(p)(tau), np.polyint(p)(1.0)
    return tau, C, D, B


def run_hand(N, f, simple_bounds: bool) -> dict:
    t0 = time.perf_counter()
    tau, C, D, B = radau(DEGREE)
    h = T_SWING / N
    opti = ca.Opti()
    U = opti.variable(N)                                      # the controls come first, as in mechnet
    X = opti.variable(4)
    opti.set_initial(X, X_START)
    opti.subject_to(X - ca.DM(X_START) == 0)                  # start values: rows, as in mechnet
    J = 0
    for k in range(N):
        Xc = opti.variable(4, DEGREE)
        opti.set_initial(Xc, ca.repmat(ca.DM(X_START), 1, DEGREE))
        points = [X] + [Xc[:, j] for j in range(DEGREE)]
        for j in range(1, DEGREE + 1):
            slope = sum(C[r, j] * points[r] for r in range(DEGREE + 1))
            opti.subject_to(h * f(points[j], U[k]) - slope == 0)
            J = J + h * B[j] * U[k] ** 2
        end = sum(D[r] * points[r] for r in range(DEGREE + 1))
        X = opti.variable(4)
        opti.set_initial(X, X_START)
        opti.subject_to(end - X == 0)
    opti.subject_to(X - ca.DM(X_END) == 0)
    opti.subject_to(opti.bounded(-F_MAX, U, F_MAX))
    opti.set_initial(U, 0.0)
    opti.minimize(J)
    opti.solver("ipopt", {"print_time": False, "record_time": True, "detect_simple_bounds": simple_bounds,
                          "expand": EXPAND, "ipopt.hessian_approximation": "exact"}, dict(IPOPT))
    try:
        sol = opti.solve()
        stats, obj = sol.stats(), float(sol.value(J))
    except RuntimeError:
        stats, obj = opti.stats(), float(opti.debug.value(J))
    t2 = time.perf_counter()
    fun = sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_"))
    solve = stats["t_wall_total"]
    return {"ok": bool(stats.get("success")), "total": t2 - t0, "solve": solve, "fun": fun,
            "iter": int(stats.get("iter_count", 0)), "obj": obj, "status": stats.get("return_status"), "stats": stats}


# ---- rockit -------------------------------------------------------------------------------------

def run_rockit(N, f, scaled: bool) -> dict:
    """rockit's DirectCollocation on the hand ODE; scaled: collocation rows multiplied by h
    (set_der scale = 1/h), which makes them the hand code's Σ C x − h f."""
    t0 = time.perf_counter()
    prob = rockit.Ocp(T=T_SWING)
    x, u = prob.state(4), prob.control()
    prob.set_der(x, f(x, u), scale=N / T_SWING if scaled else 1)
    prob.subject_to(-F_MAX <= (u <= F_MAX), include_last=False)   # include_last would repeat U_{N-1}
    prob.subject_to(prob.at_t0(x) == ca.DM(X_START))
    prob.subject_to(prob.at_tf(x) == ca.DM(X_END))
    J = prob.integral(u ** 2)
    prob.add_objective(J)
    prob.set_initial(x, ca.DM(X_START))
    prob.set_initial(u, 0.0)
    prob.method(rockit.DirectCollocation(N=N, M=1, degree=DEGREE, scheme="radau"))
    prob.solver("ipopt", {"print_time": False, "record_time": True, "ipopt.hessian_approximation": "exact",
                          "expand": EXPAND,
                          **{f"ipopt.{k}": v for k, v in IPOPT.items()}})
    try:
        sol = prob.solve()
    except RuntimeError:
        sol = prob.non_converged_solution
    obj = float(sol.value(J))
    t2 = time.perf_counter()
    stats = sol.stats
    fun = sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_"))
    return {"ok": bool(stats.get("success")), "total": t2 - t0, "solve": stats["t_wall_total"], "fun": fun,
            "iter": int(stats.get("iter_count", 0)), "obj": obj, "status": stats.get("return_status")}


# ---- where the time goes -------------------------------------------------------------------------

def profile(cm, f, N) -> None:
    """Per-function evaluation times of mechnet's NLP (rebuilt from its transcription, the same
    objects prob.solve builds) against hand-b's; the size of the ODE and of the Lagrangian Hessian of
    one ODE call; the build stages of prob.solve under cProfile."""
    import cProfile
    import pstats

    dae = cm.dae
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u")
    none = ca.SX(0, 1)
    lam = ca.DM([1.0, 2.0, 3.0, 4.0])
    for name, expr in (("mechnet", dae.ode(0.0, x, none, u, none, none)), ("hand", f(x, u))):
        fn = ca.Function("ode", [x, u], [expr])
        hess = ca.Function("h", [x, u], [ca.hessian(ca.dot(lam, expr), ca.vertcat(x, u))[0]])
        print(f"  {name:8s} ODE: {fn.n_instructions():3d} instructions; Hessian of λ·f: {hess.n_instructions():3d}")
    print(f"  mechnet ODE: {ca.Function('ode', [x, u], [dae.ode(0.0, x, none, u, none, none)])(x, u)}")

    method = ocp.Collocation(N=N, degree=DEGREE)
    prob = mechnet_problem(cm)
    method.prepare(prob)
    nlp, layout = method.transcribe(prob, None)
    solver = ca.nlpsol("ocp", "ipopt", {"x": ca.vertcat(*nlp.w), "f": layout["objective"], "g": ca.vertcat(*nlp.g)},
                       {"print_time": False, "record_time": True, "ipopt.hessian_approximation": "exact",
                        "expand": EXPAND, **{f"ipopt.{k}": v for k, v in IPOPT.items()}})
    solver(x0=nlp.w0, lbx=nlp.lbw, ubx=nlp.ubw, lbg=nlp.lbg, ubg=nlp.ubg)
    mine = solver.stats()
    hand = run_hand(N, f, True)
    hand = dict(hand["stats"], fun_total=hand["fun"])
    print(f"\n  N = {N}: per-call wall time of the NLP functions, µs (calls) — mechnet's NLP without its callback")
    print(f"  {'function':12s} | {'mechnet':>16s} | {'hand-b':>16s} | ratio")
    for key in ("nlp_f", "nlp_grad_f", "nlp_g", "nlp_jac_g", "nlp_hess_l", "nlp_grad"):
        a, b = mine.get(f"t_wall_{key}", 0.0), hand.get(f"t_wall_{key}", 0.0)
        na, nb = mine.get(f"n_call_{key}", 0), hand.get(f"n_call_{key}", 0)
        pa, pb = (a / na * 1e6 if na else 0.0), (b / nb * 1e6 if nb else 0.0)
        print(f"  {key:12s} | {pa:9.1f} ({na:4d}) | {pb:9.1f} ({nb:4d}) | {pa / pb if pb else math.nan:5.2f}")
    print(f"  t_wall_total  mechnet {mine['t_wall_total']:.3f} s ({mine['iter_count']} it), "
          f"hand-b {hand['t_wall_total']:.3f} s ({hand['iter_count']} it)")
    f_mech = ca.Function("mechnet_ode", [x, u], [dae.ode(0.0, x, none, u, none, none)], ["x", "u"], ["xdot"])
    swapped = run_hand(N, f_mech, True)
    print(f"  hand-b with mechnet's ODE expression in place of the hand one: t_wall_total "
          f"{swapped['solve']:.3f} s, fun {swapped['fun']:.3f} s ({swapped['iter']} it; hand-b fun "
          f"{hand['fun_total']:.3f} s, mechnet fun {sum(v for k, v in mine.items() if k.startswith('t_wall_nlp_')):.3f} s)")

    prof = cProfile.Profile()
    prof.enable()
    mechnet_problem(cm).solve(ocp.Collocation(N=N, degree=DEGREE), ipopt={**IPOPT, "max_iter": 0}, progress=False)
    prof.disable()
    print("\n  prob.solve with max_iter = 0 (build, one evaluation, the Solution), cProfile, top 12 by cumulative:")
    pstats.Stats(prof).sort_stats("cumulative").print_stats(12)


# ---- the run -------------------------------------------------------------------------------------

def best(fn, repeats):
    runs = [fn() for _ in range(repeats)]
    return min(runs, key=lambda r: r["total"])


def row(label, N, r, ratio="", verify=None, ratio_rk=""):
    ok = "ok" if r["ok"] else f"FAILED ({r['status']})"
    dev = f"{verify:8.1e}" if verify is not None else f"{'-':>8s}"
    print(f"{label:12s} {N:4d} | {r['total']:7.2f} {r['solve']:7.2f} {r['solve'] - r['fun']:7.2f} {r['fun']:7.2f} | "
          f"{r['iter']:5d} {r['obj']:18.12g} | {dev} | {ratio:>5s} | {ratio_rk:>8s} | {ok}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="N = 50, 100; shooting at N = 50; best of 1")
    ap.add_argument("--repeats", type=int, help=f"collocation runs per entry, best kept (default {REPEATS})")
    ap.add_argument("--shooting-200", action="store_true", help="also multiple shooting at N = 200 (slow)")
    ap.add_argument("--profile", type=int, metavar="N", help="only: where mechnet's collocation time goes at N")
    args = ap.parse_args(argv)
    ns = QUICK_NS if args.quick else NS
    shooting_ns = QUICK_SHOOTING_NS if args.quick else SHOOTING_NS + ((200,) if args.shooting_200 else ())
    repeats = args.repeats or (1 if args.quick else REPEATS)

    print(f"ocp: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"mechnet {getattr(mn, '__version__', '?')}")
    print(f"machine: {_cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}")
    print(f"command: python {' '.join(sys.argv)}; mechnet at git {_git_head()}")
    if rockit is None:
        print("rockit: not installed (`pip install rockit-meco`, the `bench` extra): its rows are skipped")
    print(f"load average (1, 5, 15 min) at the start: {', '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"cart-pole: M = {M_CART:g} kg, m = {M_TIP:g} kg, L = {L:g} m, g = {G:g}; T = {T_SWING:g} s, "
          f"|u| <= {F_MAX:g} N; min ∫u² dt; Radau degree {DEGREE}, piecewise-constant u; IPOPT {IPOPT}")

    t0 = time.perf_counter()
    cm = build().compile()
    t_compile = time.perf_counter() - t0
    f = hand_ode()
    deviation = check_model(cm, f)
    print(f"compile {t_compile:.2f} s (once, not in 'total'); states {', '.join(cm.state_names)}")
    print(f"model check: max |mechnet − hand| over 2 s (u = 5 N, tilted moving start) = {deviation:.1e} "
          f"({'ok' if deviation < MODEL_TOL else 'FAIL'}, tolerance {MODEL_TOL:g})")
    if args.profile:
        profile(cm, f, args.profile)
        return 0
    print(f"collocation: best of {repeats} by total; shooting: one run\n")

    head = (f"{'method':12s} {'N':>4s} | {'total':>7s} {'solve':>7s} {'ipopt':>7s} {'fun':>7s} | "
            f"{'iter':>5s} {'objective':>18s} | {'verify':>8s} | {'ratio':>5s} | {'ratio rk':>8s} | status")
    print(head)
    print("-" * len(head))
    failures = []
    for N in ns:
        mine = best(lambda: run_mechnet(cm, ocp.Collocation(N=N, degree=DEGREE)), repeats)
        rows_g = best(lambda: run_hand(N, f, False), repeats)
        rows_b = best(lambda: run_hand(N, f, True), repeats)
        others = [("hand-b", rows_b), ("hand-g", rows_g)]
        if rockit is not None:
            others.append(("rockit-s", best(lambda: run_rockit(N, f, True), repeats)))
            if N in ROCKIT_UNSCALED_NS:
                others.append(("rockit", run_rockit(N, f, False)))
        rk = dict(others).get("rockit-s")
        verify = mine["sol"].verify(progress=False)["max_deviation"]
        row("mechnet coll", N, mine, f"{mine['total'] / rows_b['total']:.2f}", verify,
            f"{mine['total'] / rk['total']:.2f}" if rk else "")
        for label, other in others:
            row(label, N, other)
        for label, other in others:
            rel = abs(mine["obj"] - other["obj"]) / abs(other["obj"])
            if not rel <= OBJ_RTOL or not (mine["ok"] and other["ok"]):
                failures.append(f"N = {N}: mechnet {mine['obj']:.12g} vs {label} {other['obj']:.12g} "
                                f"(relative {rel:.1e}; success {mine['ok']}/{other['ok']})")
    print("(solve/ipopt/fun: see the docstring; ratio = mechnet total / hand-b total; ratio rk = mechnet "
          "total / rockit-s total; verify: sol.verify()['max_deviation'], re-simulation at rtol 1e-10)")
    if rockit is not None:
        print(f"(rockit-meco {metadata.version('rockit-meco')}: DirectCollocation(N, M=1, degree={DEGREE}, "
              f"scheme='radau'); rockit-s: set_der scale 1/h; rockit (unscaled, one run): N = "
              f"{', '.join(map(str, ROCKIT_UNSCALED_NS))} only)")
    for N in shooting_ns:
        r = run_mechnet(cm, ocp.MultipleShooting(N=N, integrator="cvodes", rtol=1e-8, atol=1e-10))
        row("mechnet ms", N, r, "", r["sol"].verify(progress=False)["max_deviation"])
    print("(ms: MultipleShooting(N, integrator='cvodes', rtol=1e-8, atol=1e-10), limited-memory Hessian)\n")
    if failures:
        for line in failures:
            print(f"FAIL objective agreement (collocation, rtol {OBJ_RTOL:g}): {line}")
    else:
        names = "mechnet = hand-b = hand-g" + (" = rockit-s = rockit" if rockit is not None else "")
        print(f"collocation objectives: {names} within {OBJ_RTOL:g} relative at every N: ok")
    print(f"wall time of this run: {time.perf_counter() - t0:.0f} s; load average at the end: "
          f"{', '.join(f'{v:.2f}' for v in os.getloadavg())}")
    return 1 if failures or deviation >= MODEL_TOL else 0


if __name__ == "__main__":
    sys.exit(main())
