"""rotation — 3D rotation at equal error: mechnet against a hand-written CasADi quaternion model and MuJoCo.

Scenes (gravity (0, 0, -9.81) in all three):
  * tumbling: a free body (FreeMotion; m = 2 kg, I = diag(0.3, 0.35, 0.4) kg·m² about its mass centre)
    spun near its intermediate axis, w0 = (0.5, 6, 1) rad/s in body axes, thrown with v0 = (1, 0.5, 5)
    m/s; 10 s (three flips of the intermediate axis);
  * top: a heavy symmetric top on a spherical pivot at its tip (m = 1 kg, mass centre 0.1 m up the
    symmetry axis, I_cm = diag(0.002, 0.002, 0.0036) kg·m²), tilted 0.5 rad about x and released
    spinning at 50 rad/s about its axis, no precession (so it nutates); 5 s;
  * chain: 10 links on spherical joints hanging from the world origin (each link: 0.5 kg, 0.25 m,
    a rod of radius 0.02 m, mass centre at mid-length); start: joint k turned by 0.8 rad (k = 0) or
    0.2 rad (k > 0) about x (even k) or y (odd k), joint 0 spinning at 3 rad/s about the world's z,
    the others at rest relative to their parent; 2 s (the motion is chaotic; later states are not
    comparable at loose tolerances).

Error measure, at the final time only: tumbling and top, max |R - R_ref| over the entries of the body's
rotation matrix (≈ the orientation error in rad); chain, max |r - r_ref| over the 10 link ends' world
positions (m; the chain is 2.5 m long). The reference is mechnet at rtol = atol = 1e-12 (method
"auto"), checked against the hand-written model at 1e-12 (tumbling, top), against MuJoCo RK4 at its
smallest step, and for the tumbling body its angular velocity against SciPy DOP853 on Euler's
equations at rtol = atol = 1e-13.

Methods (timing: wall time of one whole simulation to the final time, best of 3 after a warm-up call;
compile and integrator construction excluded; a run slower than 1 s is timed once, marked *):
  * mechnet `cm.simulate(T, rtol, atol=rtol, n_out=2)` with method "auto" (CVODES Adams on these
    explicit ODEs) and "cvodes-bdf", rtol = 1e-3 ... 1e-10;
  * hand: the quaternion rigid-body ODE written by hand in CasADi SX (Q' = ½·Q ⊗ (0, w), R = R(Q/|Q|),
    Euler's equations I·w' = -w × I·w + τ with the gravity torque about the pivot for the top; the free
    body's translation r' = v, v' = g), integrated by `ca.integrator` with CVODES Adams (functional
    iteration: mechnet's "cvodes-adams" options) and BDF (Newton), same rtol = atol, one output time.
    No hand model for the chain: a 10-link spherical chain needs either a 30×30 mass matrix in
    quaternion coordinates or an articulated-body recursion written by hand — mechnet's own job;
    the chain is compared against MuJoCo only (its reference checked against MuJoCo RK4);
  * MuJoCo (MJCF built as strings: a free joint, a ball joint, a 10-body ball-joint chain; the same
    masses, inertias (`inertial` elements, no geoms), gravity; contacts disabled, no damping, no
    armature, no friction loss) with integrator "RK4", "implicit" and "implicitfast" at fixed steps
    dt = T/n, n growing by ≈ √10 until the error is below 1e-8 or one run would take more than
    MUJOCO_MAX_RUN s; `mujoco.mj_step(m, d, nstep=n)` in one call (no Python loop). Quaternions (w, x,
    y, z) in qpos; ball and free joints' angular velocities in qvel are in the child (body) frame, as
    mechnet's w_rel (checked: the reference agrees with MuJoCo RK4).

Time to reach an error e: the cheapest runs on either side of e, interpolated linearly in log(time)
against log(error); "~" = extrapolated from the two most accurate runs (e not reached), "<=" = already
the cheapest run meets it, "-" = not reached within a factor EXTRAPOLATE (10) of the most accurate run. Ratios: mechnet (auto) / hand (Adams), mechnet / the best MuJoCo integrator.

Part 2 (compile and per-step cost of 3D spherical chains, N = 10, 20, 40, the chain above made longer):
construction + compile time, the ODE's instruction count (in total and per link), the ODE's evaluation
time per point (`ode.map(1000)` on 1000 random states, median of 5: Python's call overhead spread over
the batch), the wall time per integrator step of a 2 s simulation (cvodes-adams, rtol = atol = 1e-8,
at most SCALING_MAX_STEPS steps: a failed run still gives its cost per step), and the ODE's joint
accelerations der(w_rel) at the start state against MuJoCo's qacc (the same child-frame components);
the simulation is skipped when they differ by more than ACC_AGREE of the largest (a run of such an
ODE fails after 16-70 s).

Usage:  python benchmarks/rotation.py [--quick] [--no-plot]
        (--quick: rtol 1e-3..1e-8 every second decade, fewer MuJoCo steps, N = 10, 20 in part 2)
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
import warnings
from pathlib import Path

import casadi as ca
import numpy as np
import scipy
from scipy.integrate import solve_ivp

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components.multibody.frames import matrix_of_quaternion, quaternion_of_axis_angle

sys.path.insert(0, str(Path(__file__).resolve().parent))
import chain3d  # noqa: E402  (machine and git description)
import timing  # noqa: E402

G = 9.81
GRAV = np.array([0.0, 0.0, -G])
REPEATS = 3
SLOW_RUN = 1.0                # s: a run slower than this is timed once
REF_TOL = 1e-12
TARGETS = (1e-3, 1e-6)
RTOLS = tuple(10.0 ** -k for k in range(3, 11))
QUICK_RTOLS = (1e-3, 1e-5, 1e-7, 1e-8)
MN_METHODS = ("auto", "cvodes-bdf")
HAND_METHODS = ("cvodes-adams", "cvodes-bdf")
MJ_INTEGRATORS = ("RK4", "implicit", "implicitfast")
MUJOCO_MAX_RUN = 2.0          # s: no finer MuJoCo step once a run takes longer than this
QUICK_MUJOCO_MAX_RUN = 0.4
MUJOCO_ERR_FLOOR = 1e-8       # stop refining a MuJoCo integrator below this error
MAX_STEPS = 1_000_000
EXTRAPOLATE = 10.0            # extrapolate at most this factor below the most accurate run's error
PLUGIN = dict(chain3d.PLUGIN)
CHAIN_NS = (10, 20, 40)
ACC_AGREE = 1e-3              # part 2: simulate only when der(w_rel) matches MuJoCo's qacc to this share
SCALING_MAX_STEPS = 2000      # per output interval, part 2's timing runs
QUICK_CHAIN_NS = (10, 20)

# ----------------------------------------------------------------------------- scene data
TUMBLE = dict(m=2.0, I=np.array([0.3, 0.35, 0.4]), w0=np.array([0.5, 6.0, 1.0]), r0=np.zeros(3),
              v0=np.array([1.0, 0.5, 5.0]), Q0=np.array([1.0, 0.0, 0.0, 0.0]), T=10.0)
TOP = dict(m=1.0, l=0.1, A=0.002, C=0.0036, theta0=0.5, spin=50.0, T=5.0)
TOP["Q0"] = quaternion_of_axis_angle([1, 0, 0], TOP["theta0"])
TOP["w0"] = np.array([0.0, 0.0, TOP["spin"]])
CHAIN = dict(m=0.5, L=0.25, radius=0.02, w0_world=np.array([0.0, 0.0, 3.0]), T=2.0)


def chain_start(n):
    """Relative start quaternions and w_rel (child frame) of the n joints."""
    Qs = [quaternion_of_axis_angle([1, 0, 0] if k % 2 == 0 else [0, 1, 0], 0.8 if k == 0 else 0.2) for k in range(n)]
    ws = [np.zeros(3) for _ in range(n)]
    ws[0] = matrix_of_quaternion(Qs[0]).T @ CHAIN["w0_world"]
    return Qs, ws


def rod_inertia(m, L, r):
    a = m * (3 * r * r + L * L) / 12
    return np.array([a, a, m * r * r / 2])


# ----------------------------------------------------------------------------- mechnet models
def mn_tumbling():
    s = TUMBLE
    m = mn.Model("tumbling")
    world = m.add(mb.World(name="world", g=list(GRAV)))
    free = m.add(mb.FreeMotion(name="free", Q_start=list(s["Q0"]), w_rel_start=list(s["w0"]),
                               r_rel_start=list(s["r0"]), v_rel_start=list(s["v0"])))
    body = m.add(mb.Body(name="body", m=s["m"], I=np.diag(s["I"])))
    m.connect(world.frame_b, free.frame_a)
    m.connect(free.frame_b, body.frame_a)
    return m


def mn_top():
    s = TOP
    m = mn.Model("top")
    world = m.add(mb.World(name="world", g=list(GRAV)))
    pivot = m.add(mb.Spherical(name="pivot", Q_start=list(s["Q0"]), w_rel_start=list(s["w0"])))
    body = m.add(mb.Body(name="body", m=s["m"], r_cm=[0.0, 0.0, s["l"]], I=np.diag([s["A"], s["A"], s["C"]])))
    m.connect(world.frame_b, pivot.frame_a)
    m.connect(pivot.frame_b, body.frame_a)
    return m


def mn_chain(n):
    s = CHAIN
    Qs, ws = chain_start(n)
    m = mn.Model(f"chain{n}")
    world = m.add(mb.World(name="world", g=list(GRAV)))
    previous = world.frame_b
    for k in range(n):
        ball = m.add(mb.Spherical(name=f"ball{k}", Q_start=list(Qs[k]), w_rel_start=list(ws[k])))
        body = m.add(mb.Body(name=f"link{k}", m=s["m"], r_cm=[0.0, 0.0, -s["L"] / 2],
                             I=np.diag(rod_inertia(s["m"], s["L"], s["radius"]))))
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[0.0, 0.0, -s["L"]]))
        m.connect(previous, ball.frame_a)
        m.connect(ball.frame_b, body.frame_a)
        m.connect(ball.frame_b, rod.frame_a)
        previous = rod.frame_b
    return m


def mn_output(scene, res):
    """The compared quantity at the final time (flat vector)."""
    if scene == "chain":
        n = sum(1 for name in res.state_names if name.startswith("ball") and name.endswith(".Q[0]"))
        return np.array([res[f"rod{k}.frame_b.r_0[{i}]"][-1] for k in range(n) for i in range(3)])
    return np.array([res[f"body.frame_a.R[{k}]"][-1] for k in range(9)])


# ----------------------------------------------------------------------------- hand-written CasADi
def _qmul_w(Q, w):
    """½·Q ⊗ (0, w)."""
    q0, v = Q[0], Q[1:4]
    return 0.5 * ca.vertcat(-ca.dot(v, w), q0 * w + ca.cross(v, w))


def _R(Q):
    q = Q / ca.norm_2(Q)
    w, x, y, z = q[0], q[1], q[2], q[3]
    return ca.vertcat(ca.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
                      ca.horzcat(2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
                      ca.horzcat(2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))


def hand_model(scene):
    """(x, ode, x0, output function x -> flat R row-major)."""
    if scene == "tumbling":
        s = TUMBLE
        r, v, Q, w = ca.SX.sym("r", 3), ca.SX.sym("v", 3), ca.SX.sym("Q", 4), ca.SX.sym("w", 3)
        I = ca.DM(s["I"])
        wdot = (-ca.cross(w, I * w)) / I
        x = ca.vertcat(r, v, Q, w)
        ode = ca.vertcat(v, ca.DM(GRAV), _qmul_w(Q, w), wdot)
        x0 = np.concatenate([s["r0"], s["v0"], s["Q0"], s["w0"]])
        out = ca.Function("out", [x], [ca.reshape(_R(Q).T, 9, 1)])
    elif scene == "top":
        s = TOP
        Q, w = ca.SX.sym("Q", 4), ca.SX.sym("w", 3)
        Ip = ca.DM([s["A"] + s["m"] * s["l"] ** 2, s["A"] + s["m"] * s["l"] ** 2, s["C"]])
        c = ca.DM([0.0, 0.0, s["l"]])
        R = _R(Q)
        tau = ca.cross(c, R.T @ ca.DM(s["m"] * GRAV))         # gravity torque about the pivot, body axes
        wdot = (tau - ca.cross(w, Ip * w)) / Ip
        x = ca.vertcat(Q, w)
        ode = ca.vertcat(_qmul_w(Q, w), wdot)
        x0 = np.concatenate([s["Q0"], s["w0"]])
        out = ca.Function("out", [x], [ca.reshape(R.T, 9, 1)])
    else:
        raise ValueError(scene)
    return x, ode, x0, out


def hand_integrator(scene, method, tol, T):
    x, ode, x0, out = hand_model(scene)
    plugin, extra = PLUGIN[method]
    opts = dict(extra, reltol=tol, abstol=tol, max_num_steps=MAX_STEPS, disable_internal_warnings=True,
                show_eval_warnings=False)
    F = ca.integrator("H", plugin, {"x": x, "ode": ode}, 0.0, T, opts)
    return lambda: np.asarray(out(F(x0=x0)["xf"])).ravel(), F


# ----------------------------------------------------------------------------- MuJoCo
def _quat(q):
    return " ".join(f"{v:.17g}" for v in q)


MJ_HEAD = ('<mujoco model="{name}"><compiler angle="radian" autolimits="true"/>'
           '<option timestep="0.001" integrator="RK4" gravity="0 0 {g:.17g}">'
           '<flag contact="disable" constraint="disable" actuation="disable" frictionloss="disable" '
           'energy="disable"/></option><worldbody>')


def mj_xml(scene, n=10):
    head = MJ_HEAD.format(name=scene, g=-G)
    if scene == "tumbling":
        s = TUMBLE
        body = (f'<body name="body"><freejoint name="free"/><inertial pos="0 0 0" mass="{s["m"]}" '
                f'diaginertia="{_quat(s["I"])}"/></body>')
        return head + body + "</worldbody></mujoco>"
    if scene == "top":
        s = TOP
        body = (f'<body name="body"><joint name="pivot" type="ball" damping="0" armature="0"/>'
                f'<inertial pos="0 0 {s["l"]}" mass="{s["m"]}" diaginertia="{s["A"]} {s["A"]} {s["C"]}"/></body>')
        return head + body + "</worldbody></mujoco>"
    s = CHAIN
    inertia = _quat(rod_inertia(s["m"], s["L"], s["radius"]))
    parts = []
    for k in range(n):
        pos = "0 0 0" if k == 0 else f"0 0 {-s['L']}"
        parts.append(f'<body name="link{k}" pos="{pos}"><joint name="ball{k}" type="ball" damping="0" armature="0"/>'
                     f'<inertial pos="0 0 {-s["L"] / 2}" mass="{s["m"]}" diaginertia="{inertia}"/>'
                     f'<site name="end{k}" pos="0 0 {-s["L"]}"/>')
    return head + "".join(parts) + "</body>" * n + "</worldbody></mujoco>"


class MjScene:
    def __init__(self, scene, n=10):
        import mujoco
        self.mujoco, self.scene, self.n = mujoco, scene, n
        self.model = mujoco.MjModel.from_xml_string(mj_xml(scene, n))
        self.data = mujoco.MjData(self.model)
        if scene == "tumbling":
            s = TUMBLE
            self.qpos0 = np.concatenate([s["r0"], s["Q0"]])
            self.qvel0 = np.concatenate([s["v0"], s["w0"]])     # free joint: linear in world, angular in body axes
        elif scene == "top":
            self.qpos0, self.qvel0 = np.array(TOP["Q0"]), np.array(TOP["w0"])
        else:
            Qs, ws = chain_start(n)
            self.qpos0, self.qvel0 = np.concatenate(Qs), np.concatenate(ws)

    def run(self, integrator, nsteps, T):
        mj, m, d = self.mujoco, self.model, self.data
        m.opt.integrator = getattr(mj.mjtIntegrator, f"mjINT_{integrator.upper()}")
        m.opt.timestep = T / nsteps
        mj.mj_resetData(m, d)
        d.qpos[:] = self.qpos0
        d.qvel[:] = self.qvel0
        mj.mj_step(m, d, nstep=nsteps)
        if d.warning[mj.mjtWarning.mjWARN_BADQACC].number > 0 or not np.all(np.isfinite(d.qpos)):
            return None
        mj.mj_forward(m, d)
        if self.scene == "chain":
            return np.array(d.site_xpos).ravel().copy()
        return np.array(d.xmat[1]).ravel().copy()


# ----------------------------------------------------------------------------- measuring
def timed_best(fn):
    """(best wall time, repeats, output): a warm-up call, then best of REPEATS (once if slow)."""
    t0 = time.perf_counter()
    out = fn()
    first = time.perf_counter() - t0
    if first > SLOW_RUN:
        t0 = time.perf_counter()
        out = fn()
        return time.perf_counter() - t0, 1, out
    best, out = timing.best_of(fn, REPEATS)
    return best, REPEATS, out


def err_of(y, ref):
    return math.inf if y is None else float(np.max(np.abs(np.asarray(y) - ref)))


def time_to(points, target):
    """(time, mark) to reach error <= target from [(time, err)]; mark '' / '~' / '<=' / '-'."""
    pts = sorted((t, e) for t, e in points if np.isfinite(e) and e > 0)
    if not pts:
        return None, "-"
    good = [(t, e) for t, e in pts if e <= target]
    if good:
        t_hi, e_hi = good[0]
        bad = [(t, e) for t, e in pts if e > target and t < t_hi]
        if not bad:
            return t_hi, "<="
        t_lo, e_lo = bad[-1]
        f = (math.log(target) - math.log(e_lo)) / (math.log(e_hi) - math.log(e_lo))
        return math.exp(math.log(t_lo) + f * (math.log(t_hi) - math.log(t_lo))), ""
    # not reached: extrapolate from the two most accurate runs (in time order, the error must fall)
    if len(pts) < 2:
        return None, "-"
    (t1, e1), (t2, e2) = sorted(sorted(pts, key=lambda p: p[1])[:2])
    if e2 >= e1 or t2 <= t1:
        return None, "-"
    if target < min(e1, e2) / EXTRAPOLATE:
        return None, "-"
    slope = (math.log(t2) - math.log(t1)) / (math.log(e2) - math.log(e1))
    return math.exp(math.log(t2) + slope * (math.log(target) - math.log(e2))), "~"


def sweep_scene(scene, rtols, mj_max_run):
    T = TUMBLE["T"] if scene == "tumbling" else TOP["T"] if scene == "top" else CHAIN["T"]
    print(f"--- {scene}: T = {T:g} s", flush=True)
    model = {"tumbling": mn_tumbling, "top": mn_top, "chain": lambda: mn_chain(10)}[scene]()
    t0 = time.perf_counter()
    cm = model.compile()
    compile_s = time.perf_counter() - t0
    ops = int(cm.dae.ode.n_instructions())

    # reference and its checks
    ref_res = cm.simulate(T, rtol=REF_TOL, atol=REF_TOL, n_out=2, max_steps=MAX_STEPS)
    assert ref_res.success, ref_res.failure
    ref = mn_output(scene, ref_res)
    checks = {}
    bdf_ref = cm.simulate(T, rtol=REF_TOL, atol=REF_TOL, n_out=2, max_steps=MAX_STEPS, method="cvodes-bdf")
    checks["mechnet BDF 1e-12"] = err_of(mn_output(scene, bdf_ref), ref)
    if scene != "chain":
        f, _ = hand_integrator(scene, "cvodes-adams", REF_TOL, T)
        checks["hand Adams 1e-12"] = err_of(f(), ref)
    if scene == "tumbling":
        w_mn = np.array([ref_res[f"free.w_rel[{i}]"][-1] for i in range(3)])
        I = TUMBLE["I"]

        def euler(t, w):
            return [(I[1] - I[2]) / I[0] * w[1] * w[2], (I[2] - I[0]) / I[1] * w[2] * w[0],
                    (I[0] - I[1]) / I[2] * w[0] * w[1]]
        w_ex = solve_ivp(euler, (0, T), TUMBLE["w0"], method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
        checks["w vs Euler/DOP853 (rad/s)"] = float(np.max(np.abs(w_mn - w_ex)))
        r_mn = np.array([ref_res[f"body.frame_a.r_0[{i}]"][-1] for i in range(3)])
        checks["r vs parabola (m)"] = float(np.max(np.abs(r_mn - (TUMBLE["r0"] + TUMBLE["v0"] * T + 0.5 * GRAV * T * T))))
    hand_ops = None
    if scene != "chain":
        hx, hode, _, _ = hand_model(scene)
        hand_ops = int(ca.Function("f", [hx], [hode]).n_instructions())
    mjs = MjScene(scene)

    curves = {}                                   # label -> [(time, err, setting, reps, nsteps)]
    for method in MN_METHODS:
        label = f"mechnet {method}"
        curves[label] = []
        for tol in rtols:
            def run(tol=tol, method=method):
                return cm.simulate(T, rtol=tol, atol=tol, n_out=2, method=method, max_steps=MAX_STEPS)
            t, reps, res = timed_best(run)
            e = err_of(mn_output(scene, res), ref) if res.success else math.inf
            curves[label].append((t, e, f"rtol {tol:.0e}", reps, int(res.stats.get("nsteps", 0))))
        print(f"  {label:24s} " + "  ".join(f"{p[2][5:]}: {p[1]:.1e}/{p[0] * 1e3:.2f}ms" for p in curves[label]),
              flush=True)
    if scene != "chain":
        for method in HAND_METHODS:
            label = f"hand {method}"
            curves[label] = []
            for tol in rtols:
                f, F = hand_integrator(scene, method, tol, T)
                t, reps, y = timed_best(f)
                curves[label].append((t, err_of(y, ref), f"rtol {tol:.0e}", reps, int(F.stats().get("nsteps", 0))))
            print(f"  {label:24s} " + "  ".join(f"{p[2][5:]}: {p[1]:.1e}/{p[0] * 1e3:.2f}ms" for p in curves[label]),
                  flush=True)
    n0 = {"tumbling": 100, "top": 100, "chain": 20}[scene]
    mj_fine = None
    for integ in MJ_INTEGRATORS:
        label = f"MuJoCo {integ}"
        curves[label] = []
        n = n0
        while True:
            t, reps, y = timed_best(lambda: mjs.run(integ, n, T))
            e = err_of(y, ref)
            curves[label].append((t, e, f"dt {T / n:.1e}", reps, n))
            if integ == "RK4" and y is not None:
                mj_fine = (T / n, e)
            if e < MUJOCO_ERR_FLOOR or t * math.sqrt(10) > mj_max_run:
                break
            n = int(round(n * math.sqrt(10)))
        print(f"  {label:24s} " + "  ".join(f"{p[2][3:]}: {p[1]:.1e}/{p[0] * 1e3:.2f}ms" for p in curves[label]),
              flush=True)
    if mj_fine:
        checks[f"MuJoCo RK4 dt {mj_fine[0]:.1e}"] = mj_fine[1]
    print("  reference checks (max |difference| in the compared quantity): "
          + ", ".join(f"{k} {v:.1e}" for k, v in checks.items()), flush=True)
    return {"scene": scene, "T": T, "compile": compile_s, "ops": ops, "hand_ops": hand_ops, "curves": curves, "checks": checks,
            "ref_steps": int(ref_res.stats.get("nsteps", 0))}


# ----------------------------------------------------------------------------- part 2: chain scaling
def chain_scaling(ns):
    rows = []
    for n in ns:
        t0 = time.perf_counter()
        model = mn_chain(n)
        t1 = time.perf_counter()
        cm = model.compile()
        t2 = time.perf_counter()
        dae = cm.dae
        assert dae.is_ode
        ops = int(dae.ode.n_instructions())
        rng = np.random.default_rng(0)
        nx = dae.x.numel()
        X = rng.normal(size=(nx, 1000))
        names = list(dae.x_names)
        for k in range(n):        # quaternions on the unit sphere
            idx = [names.index(f"ball{k}.Q[{i}]") for i in range(4)]
            X[idx] /= np.linalg.norm(X[idx], axis=0)
        F = dae.ode.map(1000)
        args = (0.0, X, np.zeros((dae.z.numel(), 1000)), np.zeros((dae.u.numel(), 1000)),
                np.tile(np.asarray(dae.p_value, dtype=float).reshape(-1, 1), (1, 1000)),
                np.tile(np.asarray(dae.d_value, dtype=float).reshape(-1, 1), (1, 1000)))
        F(*args)
        times = []
        for _ in range(5):
            s0 = time.perf_counter()
            F(*args)
            times.append((time.perf_counter() - s0) / 1000)
        rhs_us = 1e6 * statistics.median(times)
        # der(w_rel) at the start state against MuJoCo's qacc (ball joints: the same child-frame components)
        xs0 = cm.simulate(1e-9, n_out=2).x[0]
        xd = np.asarray(dae.ode(0.0, xs0, np.zeros(0), np.zeros(0), dae.p_value, dae.d_value)).ravel()
        acc = np.array([xd[names.index(f"ball{k}.w_rel[{i}]")] for k in range(n) for i in range(3)])
        mjs = MjScene("chain", n)
        mjs.mujoco.mj_resetData(mjs.model, mjs.data)
        mjs.data.qpos[:], mjs.data.qvel[:] = mjs.qpos0, mjs.qvel0
        mjs.mujoco.mj_forward(mjs.model, mjs.data)
        dacc = float(np.max(np.abs(acc - mjs.data.qacc)))
        acc_max = float(np.max(np.abs(mjs.data.qacc)))
        # per-step cost: Adams (no fallback to BDF, a bounded step budget: a failed run still times its steps)
        def run():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return cm.simulate(CHAIN["T"], rtol=1e-8, atol=1e-8, n_out=21, method="cvodes-adams",
                                   max_steps=SCALING_MAX_STEPS)
        if dacc > ACC_AGREE * acc_max:          # the ODE is not the chain's: a run fails slowly (16-70 s), skip it
            rows.append({"n": n, "construct": t1 - t0, "compile": t2 - t1, "ops": ops, "rhs_us": rhs_us, "nx": nx,
                         "dacc": dacc, "acc_max": acc_max, "ok": False, "reached": 0.0})
            print(f"  N={n:3d}: construct {t1 - t0:.3f} s, compile {t2 - t1:.3f} s, {ops} ops, rhs {rhs_us:.2f} µs, "
                  f"max |der(w_rel) - MuJoCo qacc| {dacc:.1e} (of {acc_max:.0f}): simulation skipped", flush=True)
            continue
        s0 = time.perf_counter()
        res = run()
        if res.success:
            sim, reps, res = timed_best(run)
        else:                                  # a failed run is not repeated; its steps are not counted
            sim = time.perf_counter() - s0
        nsteps = int(res.stats["nsteps"]) if res.success else 0
        reached = float(res.t[-1])
        rows.append({"n": n, "construct": t1 - t0, "compile": t2 - t1, "ops": ops, "rhs_us": rhs_us, "sim": sim,
                     "nsteps": nsteps, "step_us": 1e6 * sim / max(nsteps, 1), "nx": nx, "dacc": dacc,
                     "acc_max": acc_max, "reached": reached, "ok": res.success})
        print(f"  N={n:3d}: construct {t1 - t0:.3f} s, compile {t2 - t1:.3f} s, {ops} ops, rhs {rhs_us:.2f} µs, "
              f"max |der(w_rel) - MuJoCo qacc| {dacc:.1e} (of {acc_max:.0f}), sim {sim:.3f} s / {nsteps} steps to "
              f"t = {reached:.3g} s{'' if res.success else ' (failed)'}", flush=True)
    return rows


# ----------------------------------------------------------------------------- report
def fmt_t(t, mark):
    if t is None:
        return f"{'-':>10}"
    return f"{mark:>2}{t * 1e3:8.1f}" if t < 10 else f"{mark:>2}{t:7.1f}s"


def report(results):
    print("\nwork-precision: time (ms) to reach the error (best of 3 per run; ~ extrapolated, <= met by the cheapest run)")
    head = f"{'scene':9} {'method':24} | " + " | ".join(f"{'t(' + f'{e:.0e}' + ')':>10}" for e in TARGETS) + \
        f" | {'runs':>4} {'err range':>17}"
    print(head)
    print("-" * len(head))
    summary = {}
    for r in results:
        for label, pts in r["curves"].items():
            tt = [time_to([(p[0], p[1]) for p in pts], e) for e in TARGETS]
            summary[(r["scene"], label)] = tt
            errs = [p[1] for p in pts if np.isfinite(p[1])]
            rng = f"{max(errs):.0e}..{min(errs):.0e}" if errs else "diverged"
            print(f"{r['scene']:9} {label:24} | " + " | ".join(fmt_t(*x) for x in tt) + f" | {len(pts):4d} {rng:>17}")
    print()
    print("ratios at equal error (time of mechnet auto / time of the peer; < 1: mechnet faster)")
    head = f"{'scene':9} {'peer':24} | " + " | ".join(f"{f'{e:.0e}':>8}" for e in TARGETS)
    print(head)
    print("-" * len(head))
    for r in results:
        peers = [lab for lab in r["curves"] if lab.startswith("hand")]
        best_mj = []
        for i, e in enumerate(TARGETS):
            cands = [(summary[(r["scene"], lab)][i][0], lab) for lab in r["curves"] if lab.startswith("MuJoCo")
                     and summary[(r["scene"], lab)][i][0] is not None]
            best_mj.append(min(cands) if cands else (None, None))
        for lab in peers + ["best MuJoCo"]:
            cells = []
            for i, e in enumerate(TARGETS):
                mine, mark_m = summary[(r["scene"], "mechnet auto")][i]
                if lab == "best MuJoCo":
                    theirs, who = best_mj[i]
                    mark = summary[(r["scene"], who)][i][1] if who else "-"
                else:
                    theirs, mark = summary[(r["scene"], lab)][i]
                    who = None
                if mine is None or theirs is None:
                    cells.append(f"{'-':>8}")
                else:
                    tag = ("~" if "~" in (mark, mark_m) else "") + (f"{who[7:]}" if who else "")
                    cells.append(f"{mine / theirs:8.2f} {tag}".rstrip())
            print(f"{r['scene']:9} {lab:24} | " + " | ".join(f"{c:<14}" for c in cells))
    print()
    print("per-run detail (setting: error, ms, steps)")
    for r in results:
        hand = f"; hand model {r['hand_ops']} ops" if r["hand_ops"] else ""
        print(f"{r['scene']} (mechnet compile {r['compile']:.3f} s, ODE {r['ops']} ops{hand}; reference {r['ref_steps']} steps)")
        for label, pts in r["curves"].items():
            print(f"  {label:22s} " + "; ".join(
                f"{p[2].split()[1]} {p[1]:.1e} {p[0] * 1e3:.2f}{'*' if p[3] < REPEATS else ''} {p[4]}" for p in pts))
    return summary


def report_scaling(rows):
    print("\n3D spherical chain, compile and per-step cost (cvodes-adams, rtol = atol = 1e-8, 2 s, "
          f"max_steps {SCALING_MAX_STEPS})")
    head = (f"{'N':>3} {'nx':>4} | {'construct s':>11} {'compile s':>9} {'total s':>7} | {'ODE ops':>8} {'ops/N':>6} | "
            f"{'rhs µs':>7} {'µs/N':>5} | {'steps':>6} {'t reached':>9} {'µs/step':>8} {'µs/step/N':>9} | {'d acc':>8}")
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['n']:3d} {r['nx']:4d} | {r['construct']:11.3f} {r['compile']:9.3f} {r['construct'] + r['compile']:7.3f} | "
              f"{r['ops']:8d} {r['ops'] / r['n']:6.1f} | {r['rhs_us']:7.2f} {r['rhs_us'] / r['n']:5.2f} | "
              + (f"{r['nsteps']:6d} {r['reached']:9.3g} {r['step_us']:8.1f} {r['step_us'] / r['n']:9.2f}" if r["ok"] else
                 f"{'skip' if 'sim' not in r else 'failed':>6} {r['reached']:9.3g} {'-':>8} {'-':>9}") + f" | {r['dacc']:8.1e}")
    print("(rhs: cm.dae.ode.map(1000) on 1000 random states, time per point, median of 5; µs/step: simulation wall "
          "time / CVODES steps,\n skip: not simulated, the ODE's accelerations differ from MuJoCo's by more than "
          f"{ACC_AGREE:g} of the largest; failed: the run failed at t reached; d acc: max |der(w_rel) - MuJoCo qacc| at the "
          "start state, rad/s², the largest |qacc| being " + ", ".join(f"{r['acc_max']:.0f}" for r in rows) + ")")
    if len(rows) >= 2:
        a, b = rows[0], rows[-1]
        k = math.log(b["n"] / a["n"])
        print(f"growth exponents N = {a['n']} -> {b['n']}: ops {math.log(b['ops'] / a['ops']) / k:.2f}, "
              f"rhs {math.log(b['rhs_us'] / a['rhs_us']) / k:.2f}, "
              + (f"µs/step {math.log(b['step_us'] / a['step_us']) / k:.2f}, " if a["ok"] and b["ok"] else "")
              + f"compile {math.log(b['compile'] / a['compile']) / k:.2f}  (1 = linear)")


def plot(results, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(results), figsize=(5.5 * len(results), 4.8))
    styles = {"mechnet auto": ("o-", "C0"), "mechnet cvodes-bdf": ("o--", "C0"), "hand cvodes-adams": ("s-", "C1"),
              "hand cvodes-bdf": ("s--", "C1"), "MuJoCo RK4": ("^-", "C2"), "MuJoCo implicit": ("v-", "C3"),
              "MuJoCo implicitfast": ("v--", "C4")}
    for ax, r in zip(np.atleast_1d(axes), results):
        for label, pts in r["curves"].items():
            pts = [p for p in pts if np.isfinite(p[1]) and p[1] > 0]
            if pts:
                st, c = styles.get(label, (".-", "k"))
                ax.loglog([p[1] for p in pts], [p[0] for p in pts], st, color=c, label=label, ms=4)
        for e in TARGETS:
            ax.axvline(e, color="gray", lw=0.8, ls=":")
        ax.invert_xaxis()
        ax.set_xlabel("error at t_end" + (" (link ends, m)" if r["scene"] == "chain" else " (max |R - R_ref|)"))
        ax.set_ylabel("wall time [s]")
        ax.set_title(f"{r['scene']} ({r['T']:g} s)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("rotation: work-precision (best of 3)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


_MJ_WARNINGS = []


def _count_warning(msg):
    _MJ_WARNINGS.append(msg)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)
    import mujoco
    mujoco.set_mju_user_warning(_count_warning)   # MuJoCo's instability warnings: counted, not printed
    rtols = QUICK_RTOLS if args.quick else RTOLS
    mj_max = QUICK_MUJOCO_MAX_RUN if args.quick else MUJOCO_MAX_RUN
    t_start = time.perf_counter()
    print(f"rotation: python {platform.python_version()}, casadi {ca.__version__}, numpy {np.__version__}, "
          f"scipy {scipy.__version__}, mujoco {mujoco.__version__}, mechnet {getattr(mn, '__version__', '?')}")
    print(f"machine: {chain3d._cpu_model()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, "
          f"load average {os.getloadavg()[0]:.2f}")
    print(f"command: python {' '.join(sys.argv)}; mechnet at git {chain3d._git_head()}")
    print(f"rtol = atol in {', '.join(f'{t:.0e}' for t in rtols)}; reference mechnet at {REF_TOL:g}; "
          f"MuJoCo runs up to {mj_max:g} s\n")
    results = [sweep_scene(s, rtols, mj_max) for s in ("tumbling", "top", "chain")]
    report(results)
    print("\npart 2", flush=True)
    rows = chain_scaling(QUICK_CHAIN_NS if args.quick else CHAIN_NS)
    report_scaling(rows)
    if not args.no_plot:
        plot(results, Path(__file__).with_suffix(".png"))
    print(f"\nMuJoCo warnings (diverged runs, marked inf): {len(_MJ_WARNINGS)}")
    print(f"\ntotal wall time {time.perf_counter() - t_start:.0f} s, load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
