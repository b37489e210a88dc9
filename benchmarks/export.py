"""export — what an exported model costs: the right-hand side as CasADi VM, generated C and FMU, and a
whole simulation natively against the FMU in FMPy.

Scenes: examples/double_pendulum.py (4 states) and examples/chain20.py (20-link chain, 40 states),
both explicit ODEs. Each is exported once as kind="c" (generated C built into a shared library,
read back with mechnet.export.load_library) and once as an FMI 2.0 Model Exchange FMU; both export
times are printed (they include the C compiler).

1. Right-hand side, µs per evaluation of ode(t, x, z, u, p, d) -> xdot at random states (angles
   in [-π, π] rad, speeds in [-3, 3] rad/s): median over --repeats of a loop of --calls calls.
     vm      cm.functions()["ode"] (CasADi's virtual machine) called from Python on numpy arrays;
     c       load_library(dir)["ode"], the same call from Python into the compiled C: the same call
             overhead as vm, so c/vm shows what the generated code saves;
     fmu     the FMU through FMPy's low-level API: fmi2SetContinuousStates + fmi2GetDerivatives
             (ctypes buffers built before the loop);
     vm map, c map   f.map(BATCH) called once on BATCH columns, time per column: Python's call
             overhead spread over BATCH points, i.e. close to the cost of the code itself.
   All are checked to give the same xdot (to 1e-9 relative) before anything is timed.
2. The double pendulum from rest at its start values, 10 s: cm.simulate(10, rtol=1e-8, atol=1e-10,
   n_out=1001) (its default method, after a warm-up call that builds the integrator) against
   fmpy.simulate_fmu on the extracted FMU (CVode BDF, relative_tolerance=1e-8, which FMPy also uses
   as absolute tolerance times the nominal, output_interval=0.01): wall time best of --repeats, the
   ratio, and the largest state deviation at the FMU's output times (up to 2 s and up to 10 s: the
   motion is chaotic, so two runs at rtol 1e-8 part after a few seconds). A third line runs mechnet with
   FMPy's method and tolerances (cvodes-bdf, atol = 1e-8) to separate solver settings from the FMU.

Usage:  python benchmarks/export.py [--quick] [--repeats 5] [--calls 2000]
        (--quick: 200 calls per loop, 3 repeats)
"""
from __future__ import annotations

import argparse
import ctypes
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import fmpy
import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model

import mechnet.scene
from mechnet.export import load_library
sys.path.insert(0, str(Path(__file__).resolve().parent))
import chain3d  # noqa: E402  (machine and git description)
import timing  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SCENES = {"double pendulum": "examples/double_pendulum.py", "chain 20": "examples/chain20.py"}
CALLS, QUICK_CALLS, REPEATS, BATCH = 2000, 200, 5, 1000
T_END, RTOL, ATOL, N_OUT, DT_OUT = 10.0, 1e-8, 1e-10, 1001, 0.01
T_EARLY = 2.0          # the double pendulum is chaotic: runs at rtol 1e-8 part visibly after a few seconds


def per_call_us(loop, calls: int, repeats: int) -> float:
    """Median over `repeats` of (wall time of loop() / calls), in µs."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        loop()
        times.append((time.perf_counter() - t0) / calls)
    return 1e6 * statistics.median(times)


def open_fmu(path: Path):
    md = read_model_description(str(path))
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(path)),
                    modelIdentifier=md.modelExchange.modelIdentifier, instanceName="bench")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.newDiscreteStates()
    fmu.enterContinuousTimeMode()
    return fmu


def bench_rhs(cm, c_dir: Path, fmu_path: Path, calls: int, repeats: int) -> dict:
    dae, rng = cm.dae, np.random.default_rng(0)
    nx = dae.x.numel()
    scale = np.array([np.pi if n.endswith(".phi") else 3.0 for n in dae.x_names])
    X = scale[:, None] * rng.uniform(-1.0, 1.0, (nx, max(calls, BATCH)))
    rest = (np.zeros(dae.z.numel()), np.array(dae.u_default), np.array(dae.p_value), np.array(dae.d_value))
    fns = {"vm": cm.functions()["ode"], "c": load_library(c_dir)["ode"]}
    xs = [X[:, k].copy() for k in range(calls)]
    ref = np.hstack([np.array(fns["vm"](0.0, x, *rest)) for x in xs])
    out = {}
    for key, f in fns.items():
        assert np.allclose(np.hstack([np.array(f(0.0, x, *rest)) for x in xs]), ref, rtol=1e-9, atol=1e-9)
        out[key] = per_call_us(lambda: [f(0.0, x, *rest) for x in xs], calls, repeats)
        F, Xb = f.map(BATCH), X[:, :BATCH]
        assert np.allclose(np.array(F(0.0, Xb, *rest)), np.array(fns["vm"].map(BATCH)(0.0, Xb, *rest)), rtol=1e-9)
        out[key + " map"] = per_call_us(lambda: F(0.0, Xb, *rest), BATCH, repeats)
    fmu = open_fmu(fmu_path)
    try:
        bufs = [(ctypes.c_double * nx)(*x) for x in xs]
        dx = (ctypes.c_double * nx)()
        for k in (0, calls - 1):
            fmu.setContinuousStates(bufs[k], nx)
            fmu.getDerivatives(dx, nx)
            assert np.allclose(np.array(dx), ref[:, k], rtol=1e-9, atol=1e-9), "FMU derivatives differ from the VM"

        def loop():
            for b in bufs:
                fmu.setContinuousStates(b, nx)
                fmu.getDerivatives(dx, nx)
        out["fmu"] = per_call_us(loop, calls, repeats)
    finally:
        fmu.terminate()
        fmu.freeInstance()
    return out


def bench_simulation(cm, fmu_path: Path, repeats: int) -> dict:
    fmu_dir, md = extract(str(fmu_path)), read_model_description(str(fmu_path))
    native = lambda **kw: cm.simulate(T_END, n_out=N_OUT, **kw)  # noqa: E731
    t0 = time.perf_counter()
    native(rtol=RTOL, atol=ATOL)
    first = time.perf_counter() - t0
    t_mn, res = timing.best_of(lambda: native(rtol=RTOL, atol=ATOL), repeats)
    native(rtol=RTOL, atol=RTOL, method="cvodes-bdf")
    t_bdf, res_bdf = timing.best_of(lambda: native(rtol=RTOL, atol=RTOL, method="cvodes-bdf"), repeats)
    t_fmu, fres = timing.best_of(lambda: fmpy.simulate_fmu(
        fmu_dir, model_description=md, stop_time=T_END, relative_tolerance=RTOL, fmi_type="ModelExchange",
        output_interval=DT_OUT, output=list(cm.dae.x_names)), repeats)

    def deviation(r, until=T_END):
        early = fres["time"] <= until
        return max(float(np.abs(np.interp(fres["time"][early], r.t, np.asarray(r[n])) - fres[n][early]).max())
                   for n in cm.dae.x_names)
    return {"first": first, "mn": t_mn, "bdf": t_bdf, "fmu": t_fmu, "dev": deviation(res),
            "dev_bdf": deviation(res_bdf), "dev_early": deviation(res, T_EARLY),
            "dev_bdf_early": deviation(res_bdf, T_EARLY), "steps": int(res.stats["nsteps"]), "method": res.stats["method"],
            "steps_bdf": int(res_bdf.stats["nsteps"]), "points": len(fres["time"])}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help=f"{QUICK_CALLS} calls per loop, 3 repeats")
    ap.add_argument("--repeats", type=int, help=f"repeats of each loop and simulation (default {REPEATS})")
    ap.add_argument("--calls", type=int, help=f"calls per timed loop (default {CALLS})")
    args = ap.parse_args(argv)
    calls = args.calls or (QUICK_CALLS if args.quick else CALLS)
    repeats = args.repeats or (3 if args.quick else REPEATS)
    print(f"export: python {platform.python_version()}, casadi {ca.__version__}, fmpy {fmpy.__version__}, "
          f"git {chain3d._git_head()}; {chain3d._cpu_model()}, {__import__('os').cpu_count()} cores")
    print(f"command: python {' '.join(sys.argv)}\n", flush=True)

    rows, sim = {}, None
    with tempfile.TemporaryDirectory() as tmp:
        for name, scene in SCENES.items():
            t0 = time.perf_counter()
            cm = mechnet.scene.load_scene(ROOT / scene).build().compile()
            row = {"nx": cm.dae.x.numel(), "compile": time.perf_counter() - t0}
            c_dir, fmu_path = Path(tmp) / f"{cm.name}_c", Path(tmp) / f"{cm.name}.fmu"
            row["export c"], _ = timing.best_of(lambda: cm.export(c_dir, kind="c", overwrite=True), 1)
            row["export fmu"], _ = timing.best_of(lambda: cm.export(fmu_path, kind="fmu", fmi=2, overwrite=True), 1)
            row.update(bench_rhs(cm, c_dir, fmu_path, calls, repeats))
            if name == "double pendulum":
                sim = bench_simulation(cm, fmu_path, repeats)
            rows[name] = row
            print(f"  {name}: done", flush=True)

    print(f"\nright-hand side, µs per evaluation (median of {repeats} loops of {calls} calls; map: one call on "
          f"{BATCH} columns)")
    keys = ("vm", "c", "fmu", "vm map", "c map")
    head = (f"{'scene':16} {'nx':>3} | {'compile s':>9} {'export c s':>10} {'export fmu s':>12} | "
            + " ".join(f"{k:>7}" for k in keys) + f" | {'c/vm':>5} {'fmu/vm':>6} {'c map/vm map':>12}")
    print(head + "\n" + "-" * len(head))
    for name, r in rows.items():
        print(f"{name:16} {r['nx']:3d} | {r['compile']:9.2f} {r['export c']:10.2f} {r['export fmu']:12.2f} | "
              + " ".join(f"{r[k]:7.2f}" for k in keys)
              + f" | {r['c'] / r['vm']:5.2f} {r['fmu'] / r['vm']:6.2f} {r['c map'] / r['vm map']:12.2f}")
    print("(vm: cm.functions()['ode'] from Python; c: load_library(...)['ode']; fmu: FMPy setContinuousStates + "
          "getDerivatives;\n export: cm.export(kind='c' | 'fmu'), one run each, C compiler included)")

    s = sim
    print(f"\ndouble pendulum, {T_END:g} s, wall time best of {repeats}")
    print(f"  mechnet cm.simulate, rtol {RTOL:g}, atol {ATOL:g} ({s['method']}, {s['steps']} steps): "
          f"{s['mn']:.4f} s (first call {s['first']:.3f} s)")
    print(f"  mechnet cm.simulate, cvodes-bdf, rtol = atol = {RTOL:g} ({s['steps_bdf']} steps):      "
          f"{s['bdf']:.4f} s")
    print(f"  FMPy simulate_fmu, CVode BDF, relative_tolerance {RTOL:g}, output_interval {DT_OUT:g}:     "
          f"{s['fmu']:.4f} s")
    print(f"  ratio FMU / mechnet: {s['fmu'] / s['mn']:.1f} (against the same settings: {s['fmu'] / s['bdf']:.1f})")
    print(f"  max |state(mechnet) - state(FMU)|, rad and rad/s, at the FMU's output points up to {T_EARLY:g} s: "
          f"{s['dev_early']:.1e} (same settings: {s['dev_bdf_early']:.1e});\n  up to {T_END:g} s: {s['dev']:.1e} "
          f"(same settings: {s['dev_bdf']:.1e}) -- the motion is chaotic, so runs at rtol {RTOL:g} part")


if __name__ == "__main__":
    main()
