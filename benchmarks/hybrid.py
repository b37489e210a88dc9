"""hybrid — friction, stops and impacts: mechnet's state events against a hand-written SciPy event loop.

Two scenes with closed-form event times, each run by mechnet (`cm.simulate`, method "auto") and by a
hand-written loop on `scipy.integrate.solve_ivp` (a terminal event, the reset applied by hand, a new
`solve_ivp` call per phase), in the same run:

1. Bouncing ball: a 0.1 kg mass dropped from h = 1 m at rest (g = 9.81 m/s², a ConstantForce), a
   rigid tr.Contact with the floor, restitution e = 0.8. Impact times are the geometric series
   t_k = T1 + 2·T1·e·(1 − e^k)/(1 − e), T1 = sqrt(2h/g), k = 0, 1, ...; they accumulate at
   T∞ = T1·(1 + e)/(1 − e) = 4.064 s. Two runs: to half-way between the 6th and 7th impact (6
   impacts) and to 0.9·T∞ (10 impacts). A third, mechnet only, runs 5 s: the ball comes to rest.
   SciPy: y = (s, v), y' = (v, −g), event s = 0 falling (terminal, direction −1), restart at s = 0,
   v = −e·v.
2. Stick-slip oscillator: a 1 kg mass on a belt moving at v_b = 0.4 m/s (tr.Speed driven by
   signals.Constant), tied to a wall by a spring c = 1 N/m, tr.Friction between belt and mass with
   fn = 1 N, mu_s = 1, mu_k = 0.6 (F_s = 1 N, F_k = 0.6 N). It starts stuck at s = 0. Stuck, s = v_b·t
   until c·s = F_s (breakaway at F_s/(c·v_b) = 2.5 s); slipping, m·s'' = −c·s + F_k, harmonic about
   F_k/c, until v = v_b again, after (2π − 2φ)/ω with ω = sqrt(c/m), φ = atan2(ω·(F_s − F_k)/c, v_b),
   at s = (2F_k − F_s)/c; then stuck for 2(F_s − F_k)/(c·v_b). 30 s: 9 events. SciPy: stuck,
   y' = (v_b, 0) with the event c·s − F_s rising; slipping, y' = (v, (−c·s + F_k)/m) with the event
   v − v_b rising, restart with v = v_b.

For each scene and rtol in 1e-4, 1e-6, 1e-8, 1e-10 (atol = rtol/100 for both):
  * wall time of one whole run, best of REPEATS after a warm-up call (compile and integrator
    construction excluded; compile time is printed apart), mechnet's `cm.simulate(T, n_out=11)`
    against the SciPy loop with LSODA (a variable-order multistep method like CVODES; the cheapest of
    SciPy's methods here) and, for reference, DOP853;
  * the largest event-time error against the closed form, for both;
  * mechnet's solver statistics of that run: CVODES steps (res.stats["nsteps"]), integrator calls
    (every call of mechnet's integrators: pieces, their finer re-integration, and the re-integrations
    of the crossing search and location, counted by wrapping Run._call in this script), the zero
    functions' rate evaluations (Run._rates) and the share of the run's wall time spent inside the
    integrator calls;
  * "ratio": mechnet time / LSODA time at the same rtol; "same-err": mechnet time / the cheapest SciPy
    run (LSODA or DOP853, any rtol from 1e-2 to 1e-10) whose event-time error is at most mechnet's —
    the ratio at equal accuracy of the event times.

3. Effects one at a time: a 1 kg block on an incline (θ = 0.3 rad) starting at s = 0.5 m at rest; the
   effects added one after another: gravity along the slope (ConstantForce −m·g·sin θ), a spring
   to the wall (c = 20 N/m), friction with the surface (fn = m·g·cos θ, mu_s = 0.3, mu_k = 0.2), a hard
   stop (s in [−0.4, 1] m, e = 0.5). For each: states, modes (cm.dae.d_names), zero-crossing
   functions, the ODE's instructions, compile time, and a 10 s run at rtol 1e-8 (atol 1e-10,
   n_out = 101): wall time (best of REPEATS), steps, integrator calls, events. With the stop, the
   block's velocity after its first impact is printed against restitution alone (−e·v before).

--profile: cProfile of the 6-impact ball run at rtol 1e-8 (PROFILE_RUNS runs): the cumulative share of
the event machinery's parts in the run, and the top functions by internal time.

Usage:  python benchmarks/hybrid.py [--quick] [--profile]
        (--quick: rtol 1e-4 and 1e-8 only, 3 repeats)
"""
from __future__ import annotations

import argparse
import contextlib
import math
import platform
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
import scipy
from scipy.integrate import solve_ivp

import mechnet as mn
from mechnet.components import translational as tr
from mechnet.components.signals import Constant
from mechnet.simulate import run as mn_run
sys.path.insert(0, str(Path(__file__).resolve().parent))
import chain3d  # noqa: E402  (machine and git description)
import timing  # noqa: E402

TOLS, QUICK_TOLS = (1e-4, 1e-6, 1e-8, 1e-10), (1e-4, 1e-8)
SCIPY_TOLS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)   # for the same-error ratio
ATOL_RATIO = 1e-2
REPEATS, QUICK_REPEATS = 5, 3
PEER, OTHER = "LSODA", "DOP853"
N_OUT = 11
PROFILE_RUNS = 20
PROFILE_PARTS = ((("pieces.py", "_dense"), "pieces: integrating forward (_dense)"),
                 (("state_events.py", "_first_crossing"), "crossing search on the pieces (_first_crossing)"),
                 (("state_events.py", "_bracket"), "  of which re-integration to extrema (_bracket)"),
                 (("state_events.py", "_handle_event"), "event handling (_handle_event)"),
                 (("state_events.py", "_locate"), "  locating the crossing (_locate, regula falsi)"),
                 (("state_events.py", "_fire"), "  resets, re-arming (_fire)"),
                 (("state_events.py", "_advance_to"), "re-integrations from a bracket start (_advance_to)"),
                 (("state_events.py", "_rates"), "zero functions' g, ġ, g̈ (_rates)"),
                 (("run.py", "_call"), "all integrator calls (Run._call)"),
                 (("~", "<built-in method casadi._casadi.Function_call>"), "all CasADi Function calls"))

# ball
G, E, H, M_BALL = 9.81, 0.8, 1.0, 0.1
T1 = math.sqrt(2 * H / G)
T_INF = T1 * (1 + E) / (1 - E)

# stick-slip
M_SS, C_SS, V_BELT, FN_SS, MU_S, MU_K = 1.0, 1.0, 0.4, 1.0, 1.0, 0.6
F_S, F_K = MU_S * FN_SS, MU_K * FN_SS
T_SS = 30.0

# effects scene
M_BLOCK, THETA, C_WALL, MUS_BLOCK, MUK_BLOCK, S_MIN, S_MAX, E_STOP = 1.0, 0.3, 20.0, 0.3, 0.2, -0.4, 1.0, 0.5
T_SCENE, RTOL_SCENE, N_OUT_SCENE = 10.0, 1e-8, 101
EFFECTS = ("mass", "+ gravity", "+ spring", "+ friction", "+ stop")


# ----------------------------------------------------------------------------- closed forms
def ball_impacts(n: int) -> np.ndarray:
    k = np.arange(n)
    return T1 + 2 * T1 * E * (1 - E ** k) / (1 - E)


def stick_slip_events(t_end: float) -> np.ndarray:
    """Breakaway and sticking times up to t_end (breakaway first)."""
    w = math.sqrt(C_SS / M_SS)
    phi = math.atan2(w * (F_S - F_K) / C_SS, V_BELT)
    slip, stick = (2 * math.pi - 2 * phi) / w, 2 * (F_S - F_K) / (C_SS * V_BELT)
    out, t = [], F_S / (C_SS * V_BELT)
    while t <= t_end:
        out.append(t)
        t += slip
        if t > t_end:
            break
        out.append(t)
        t += stick
    return np.array(out)


def event_error(times, exact) -> float:
    times = np.asarray(times, dtype=float)
    if times.size != exact.size:
        return math.inf
    return float(np.abs(times - exact).max()) if times.size else 0.0


# ----------------------------------------------------------------------------- mechnet models
def build_ball():
    mdl = mn.Model("ball")
    ball = mdl.add(tr.Mass(name="ball", m=M_BALL, s_start=H, v_start=0.0))
    floor = mdl.add(tr.Fixed(name="floor"))
    contact = mdl.add(tr.Contact(name="contact", e=E))
    gravity = mdl.add(tr.ConstantForce(name="gravity", f_constant=-M_BALL * G))
    mdl.connect(floor.flange, contact.flange_a)
    mdl.connect(contact.flange_b, ball.flange_a)
    mdl.connect(gravity.flange, ball.flange_b)
    return mn.compile(mdl)


def build_stick_slip():
    mdl = mn.Model("stick_slip")
    mass = mdl.add(tr.Mass(name="mass", m=M_SS, s_start=0.0, v_start=V_BELT))
    # a plain number v_ref is an external input, which index reduction cannot differentiate: a signal
    belt = mdl.add(tr.Speed(name="belt", v_ref=Constant(V_BELT), s_start=0.0))
    wall = mdl.add(tr.Fixed(name="wall"))
    spring = mdl.add(tr.Spring(name="spring", c=C_SS))
    fr = mdl.add(tr.Friction(name="fr", fn=FN_SS, mu_k=MU_K, mu_s=MU_S))
    mdl.connect(wall.flange, spring.flange_a)
    mdl.connect(spring.flange_b, mass.flange_a)
    mdl.connect(belt.flange, fr.flange_a)
    mdl.connect(fr.flange_b, mass.flange_b)
    return mn.compile(mdl)


def build_scene(n_effects: int):
    """The block with the first n_effects of gravity, spring, friction, stop."""
    mdl = mn.Model("incline")
    block = mdl.add(tr.Mass(name="block", m=M_BLOCK, s_start=0.5, v_start=0.0))
    surface = mdl.add(tr.Fixed(name="surface"))
    if n_effects >= 1:
        gravity = mdl.add(tr.ConstantForce(name="gravity", f_constant=-M_BLOCK * G * math.sin(THETA)))
        mdl.connect(gravity.flange, block.flange_b)
    if n_effects >= 2:
        spring = mdl.add(tr.Spring(name="spring", c=C_WALL))
        mdl.connect(surface.flange, spring.flange_a)
        mdl.connect(spring.flange_b, block.flange_a)
    if n_effects >= 3:
        fr = mdl.add(tr.Friction(name="fr", fn=M_BLOCK * G * math.cos(THETA), mu_k=MUK_BLOCK, mu_s=MUS_BLOCK))
        mdl.connect(surface.flange, fr.flange_a)
        mdl.connect(fr.flange_b, block.flange_a)
    if n_effects >= 4:
        stop = mdl.add(tr.HardStop(name="stop", s_min=S_MIN, s_max=S_MAX, e=E_STOP))
        mdl.connect(surface.flange, stop.flange_a)
        mdl.connect(stop.flange_b, block.flange_b)
    return mn.compile(mdl)


# ----------------------------------------------------------------------------- counting mechnet's work
@contextlib.contextmanager
def counted():
    """Count (and time) every integrator call of mechnet's simulation loop (Run._call: pieces, their
    finer re-integration, the crossing search and location) and the zero functions' rate evaluations
    (Run._rates), by wrapping the two methods for the duration."""
    tally = {"calls": 0, "call_s": 0.0, "rates": 0}
    call, rates = mn_run.Run._call, mn_run.Run._rates

    def call_counted(self, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return call(self, *args, **kwargs)
        finally:
            tally["calls"] += 1
            tally["call_s"] += time.perf_counter() - t0

    def rates_counted(self, *args, **kwargs):
        tally["rates"] += 1
        return rates(self, *args, **kwargs)

    mn_run.Run._call, mn_run.Run._rates = call_counted, rates_counted
    try:
        yield tally
    finally:
        mn_run.Run._call, mn_run.Run._rates = call, rates


def state_event_times(res) -> np.ndarray:
    return np.array([e.t for e in res.events if e.kind == "state"])


def run_mechnet(cm, t_end, rtol, exact, repeats) -> dict:
    sim = lambda: cm.simulate(t_end, n_out=N_OUT, rtol=rtol, atol=rtol * ATOL_RATIO)  # noqa: E731
    res = sim()                                              # warm-up: builds the integrators
    assert res.success, f"mechnet failed: {res.failure}"
    best, res = timing.best_of(sim, repeats)
    with counted() as tally:
        t0 = time.perf_counter()
        sim()
        wall = time.perf_counter() - t0
    times = state_event_times(res)
    return {"time": best, "err": event_error(times, exact), "n": times.size, "steps": int(res.stats["nsteps"]),
            "calls": tally["calls"], "rates": tally["rates"], "in_calls": tally["call_s"] / wall,
            "rest": [e for e in res.events if e.kind == "rest"]}


# ----------------------------------------------------------------------------- SciPy event loops
def scipy_ball(t_end, method, rtol, atol):
    """Impact times up to t_end: solve_ivp with a terminal event per flight."""
    def hit(t, y):
        return y[0]
    hit.terminal, hit.direction = True, -1

    def rhs(t, y):
        return (y[1], -G)

    t, y, times = 0.0, np.array([H, 0.0]), []
    while t < t_end:
        sol = solve_ivp(rhs, (t, t_end), y, method=method, events=hit, rtol=rtol, atol=atol)
        if sol.status != 1:
            assert sol.status == 0, sol.message
            break
        t = float(sol.t_events[0][0])
        times.append(t)
        y = np.array([0.0, -E * sol.y_events[0][0][1]])
    return np.array(times)


def scipy_stick_slip(t_end, method, rtol, atol):
    """Breakaway and sticking times up to t_end: stuck s' = v_b until c·s = F_s; slipping (the belt
    faster than the mass: friction +F_k) until v = v_b, then v = v_b exactly and stuck again."""
    def breaks(t, y):
        return C_SS * y[0] - F_S
    breaks.terminal, breaks.direction = True, 1

    def sticks(t, y):
        return y[1] - V_BELT
    sticks.terminal, sticks.direction = True, 1

    def stuck(t, y):
        return (V_BELT, 0.0)

    def slipping(t, y):
        return (y[1], (-C_SS * y[0] + F_K) / M_SS)

    t, y, mode, times = 0.0, np.array([0.0, V_BELT]), "stuck", []
    while t < t_end:
        rhs, ev = (stuck, breaks) if mode == "stuck" else (slipping, sticks)
        sol = solve_ivp(rhs, (t, t_end), y, method=method, events=ev, rtol=rtol, atol=atol)
        if sol.status != 1:
            assert sol.status == 0, sol.message
            break
        t = float(sol.t_events[0][0])
        times.append(t)
        y = sol.y_events[0][0].copy()
        if mode == "slip":
            y[1] = V_BELT
        mode = "slip" if mode == "stuck" else "stuck"
    return np.array(times)


def run_scipy(loop, t_end, method, rtol, exact, repeats) -> dict:
    fn = lambda: loop(t_end, method, rtol, rtol * ATOL_RATIO)  # noqa: E731
    fn()
    best, times = timing.best_of(fn, repeats)
    return {"time": best, "err": event_error(times, exact), "n": len(times)}


def cheapest_at(curve: list[dict], err: float) -> dict | None:
    ok = [p for p in curve if p["err"] <= err]
    return min(ok, key=lambda p: p["time"]) if ok else None


# ----------------------------------------------------------------------------- benchmarks
def bench_scene(name, cm, loop, t_end, exact, tols, repeats) -> list[dict]:
    curve = [dict(run_scipy(loop, t_end, m, tol, exact, repeats), method=m, rtol=tol)
             for m in (PEER, OTHER) for tol in SCIPY_TOLS]
    rows = []
    for tol in tols:
        mech = run_mechnet(cm, t_end, tol, exact, repeats)
        peer = next(p for p in curve if p["method"] == PEER and p["rtol"] == tol)
        other = next(p for p in curve if p["method"] == OTHER and p["rtol"] == tol)
        same = cheapest_at(curve, mech["err"])
        rows.append({"scene": name, "rtol": tol, "mn": mech, "peer": peer, "other": other, "same": same})
    return rows


def bench_ball(tols, repeats):
    t0 = time.perf_counter()
    cm = build_ball()
    compile_s = time.perf_counter() - t0
    impacts6 = ball_impacts(7)
    rows = []
    for label, t_end, n in (("ball, 6 impacts", 0.5 * (impacts6[5] + impacts6[6]), 6),
                            ("ball, to 0.9 T∞", 0.9 * T_INF, None)):
        if n is None:
            n = int(np.sum(ball_impacts(60) <= t_end))
        rows += bench_scene(label, cm, scipy_ball, t_end, ball_impacts(n), tols, repeats)
        print(f"  {label}: done", flush=True)
    return rows, compile_s, cm


def ball_to_rest(cm, rtol, repeats):
    """mechnet only (the SciPy loop has no rest logic): a 5 s run, the ball comes to rest at T∞."""
    sim = lambda: cm.simulate(5.0, n_out=N_OUT, rtol=rtol, atol=rtol * ATOL_RATIO)  # noqa: E731
    sim()
    best, res = timing.best_of(sim, repeats)
    times = state_event_times(res)
    rest = [e.t for e in res.events if e.kind == "rest"]
    return {"time": best, "impacts": times.size, "rest": rest[0] if rest else math.nan, "steps": res.stats["nsteps"]}


def bench_stick_slip(tols, repeats):
    t0 = time.perf_counter()
    cm = build_stick_slip()
    compile_s = time.perf_counter() - t0
    rows = bench_scene("stick-slip, 30 s", cm, scipy_stick_slip, T_SS, stick_slip_events(T_SS), tols, repeats)
    print("  stick-slip: done", flush=True)
    return rows, compile_s


def bench_effects(repeats) -> list[dict]:
    rows = []
    for n, label in enumerate(EFFECTS):
        t0 = time.perf_counter()
        cm = build_scene(n)
        compile_s = time.perf_counter() - t0
        dae = cm.dae
        sim = lambda: cm.simulate(T_SCENE, n_out=N_OUT_SCENE, rtol=RTOL_SCENE,  # noqa: E731
                                  atol=RTOL_SCENE * ATOL_RATIO)
        res = sim()
        assert res.success, f"{label}: {res.failure}"
        best, res = timing.best_of(sim, repeats)
        with counted() as tally:
            sim()
        kinds = [e.kind for e in res.events]
        impacts = [e.t for e in res.events if e.kind == "state" and e.cause.startswith("stop")]
        if impacts:                                    # the block's speed just before and after its first impact
            at = np.flatnonzero(np.asarray(res.t) == impacts[0])
            v = np.asarray(res["block.v"])
            impact = (impacts[0], float(v[at[0]]), float(v[at[-1]]),
                      [e.cause.split(" — ")[-1] for e in res.events if e.t == impacts[0]])
        else:
            impact = None
        rows.append({"effect": label, "x": len(dae.x_names), "z": len(dae.z_names), "d": len(dae.d_names),
                     "zeros": len(dae.zero_labels), "instr": dae.ode.n_instructions(), "compile": compile_s,
                     "time": best, "steps": int(res.stats["nsteps"]), "calls": tally["calls"],
                     "events": kinds.count("state"), "rests": kinds.count("rest"),
                     "s_end": float(res["block.s"][-1]), "impact": impact})
    print("  effects: done", flush=True)
    return rows


def profile_ball(cm, rtol):
    import cProfile
    import pstats
    t_end = 0.5 * (ball_impacts(7)[5] + ball_impacts(7)[6])
    cm.simulate(t_end, n_out=N_OUT, rtol=rtol, atol=rtol * ATOL_RATIO)
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(PROFILE_RUNS):
        cm.simulate(t_end, n_out=N_OUT, rtol=rtol, atol=rtol * ATOL_RATIO)
    prof.disable()
    stats = pstats.Stats(prof)
    table = {(Path(f).name, name): (nc, tt, ct) for (f, _, name), (_, nc, tt, ct, _) in stats.stats.items()}
    total = max(ct for _, _, ct in table.values())
    print(f"cProfile: {PROFILE_RUNS} runs of the ball to 6 impacts, rtol {rtol:g}: {1e3 * total / PROFILE_RUNS:.1f} ms "
          f"a run under the profiler")
    print(f"{'part (cumulative)':52} {'calls/run':>9} {'ms/run':>7} {'share':>6}")
    for key, what in PROFILE_PARTS:
        nc, _, ct = table.get(key, (0, 0.0, 0.0))
        print(f"{what:52} {nc / PROFILE_RUNS:9.1f} {1e3 * ct / PROFILE_RUNS:7.2f} {100 * ct / total:5.0f}%")
    print("top functions by internal time:")
    for (fname, name), (nc, tt, _) in sorted(table.items(), key=lambda kv: -kv[1][1])[:8]:
        print(f"  {fname}:{name:40} {nc / PROFILE_RUNS:9.1f} calls/run {1e3 * tt / PROFILE_RUNS:7.2f} ms/run "
              f"{100 * tt / total:5.0f}%")


# ----------------------------------------------------------------------------- report
def print_rows(rows):
    head = (f"{'scene':17} {'rtol':>6} {'ev':>3} | {'mn ms':>7} {'LSODA ms':>8} {'DOP853 ms':>9} | {'ratio':>6} "
            f"{'same-err':>8} | {'mn err':>8} {'LSODA err':>9} {'DOP853 err':>10} | {'steps':>5} {'calls':>5} "
            f"{'rates':>5} {'in calls':>8}")
    print(head)
    print("-" * len(head))
    for r in rows:
        m, p, o, s = r["mn"], r["peer"], r["other"], r["same"]
        same = f"{m['time'] / s['time']:8.1f}" if s else f"{'-':>8}"
        assert m["n"] == p["n"], f"{r['scene']}: mechnet found {m['n']} events, SciPy {p['n']}"
        print(f"{r['scene']:17} {r['rtol']:6.0e} {m['n']:3d} | {1e3 * m['time']:7.2f} {1e3 * p['time']:8.2f} "
              f"{1e3 * o['time']:9.2f} | {m['time'] / p['time']:6.1f} {same} | {m['err']:8.1e} {p['err']:9.1e} "
              f"{o['err']:10.1e} | {m['steps']:5d} {m['calls']:5d} {m['rates']:5d} {100 * m['in_calls']:7.0f}%")
    print("(ms: one whole run, best of the repeats after a warm-up call, compile excluded; ev: events found;\n"
          " ratio = mechnet / LSODA at the same rtol (atol = rtol/100); same-err = mechnet / the cheapest SciPy run\n"
          " (LSODA or DOP853, rtol 1e-2..1e-10) with an event-time error at most mechnet's; err: max |t_event − "
          "closed form|, s;\n steps: CVODES steps; calls: mechnet's integrator calls (pieces, re-integration, "
          "crossing search and location);\n rates: evaluations of the zero functions' Lie derivatives; in calls: "
          "share of the run's wall time inside the integrator calls)")


def print_effects(rows):
    head = (f"{'scene':11} | {'states':>6} {'alg':>3} {'modes':>5} {'zeros':>5} {'ODE instr':>9} {'compile s':>9} | "
            f"{'run ms':>7} {'steps':>5} {'calls':>5} {'events':>6} {'rest':>4} | {'s(T) m':>8}")
    print(f"effects one at a time: block on an incline, {T_SCENE:g} s, rtol {RTOL_SCENE:g}, "
          f"atol {RTOL_SCENE * ATOL_RATIO:g}, n_out {N_OUT_SCENE}")
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['effect']:11} | {r['x']:6d} {r['z']:3d} {r['d']:5d} {r['zeros']:5d} {r['instr']:9d} "
              f"{r['compile']:9.3f} | {1e3 * r['time']:7.2f} {r['steps']:5d} {r['calls']:5d} {r['events']:6d} "
              f"{r['rests']:4d} | {r['s_end']:8.4f}")
    print("(states: len(cm.dae.x_names); alg: algebraic variables; modes: cm.dae.d_names; zeros: zero-crossing "
          "functions;\n ODE instr: cm.dae.ode.n_instructions(); compile: construction + mn.compile; run: best of the "
          "repeats;\n calls: integrator calls; events: state events; rest: rest events)")
    for r in rows:
        if r["impact"] is not None:
            t, v_minus, v_plus, causes = r["impact"]
            print(f"{r['effect']}: first impact on the stop at t = {t:.6f} s, v before {v_minus:+.4f} m/s, after every "
                  f"reset at that instant {v_plus:+.4f} m/s (restitution alone: {-E_STOP * v_minus:+.4f} m/s); "
                  f"fired there: {', '.join(causes)}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="rtol 1e-4 and 1e-8 only, 3 repeats")
    ap.add_argument("--profile", action="store_true", help="cProfile of the 6-impact ball at rtol 1e-8")
    args = ap.parse_args(argv)
    tols = QUICK_TOLS if args.quick else TOLS
    repeats = QUICK_REPEATS if args.quick else REPEATS

    print(f"hybrid: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"scipy {scipy.__version__}, mechnet {getattr(mn, '__version__', '?')} at git {chain3d._git_head()}")
    print(f"machine: {chain3d._cpu_model()}, {__import__('os').cpu_count()} cores, "
          f"{platform.system()} {platform.release()}")
    print(f"command: python {' '.join(sys.argv)}\n", flush=True)

    t0 = time.perf_counter()
    ball_rows, ball_compile, cm_ball = bench_ball(tols, repeats)
    rest = ball_to_rest(cm_ball, 1e-8, repeats)
    ss_rows, ss_compile = bench_stick_slip(tols, repeats)
    effects = bench_effects(repeats)
    print(f"total {time.perf_counter() - t0:.0f} s\n")

    print(f"compile (construction + mn.compile, once): ball {ball_compile:.3f} s, stick-slip {ss_compile:.3f} s")
    print(f"closed forms: ball T1 = {T1:.6f} s, T∞ = {T_INF:.6f} s; stick-slip events at "
          + ", ".join(f"{t:.4f}" for t in stick_slip_events(T_SS)) + " s\n")
    print_rows(ball_rows + ss_rows)
    print(f"\nball to rest (mechnet only), 5 s, rtol 1e-8: {1e3 * rest['time']:.1f} ms, {rest['impacts']} impacts, "
          f"rest at {rest['rest']:.9f} s (T∞ = {T_INF:.9f} s), {rest['steps']} steps\n")
    print_effects(effects)
    if args.profile:
        print()
        profile_ball(cm_ball, 1e-8)


if __name__ == "__main__":
    main()
