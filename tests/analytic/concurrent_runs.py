"""Run by test_concurrency.py in a subprocess (a crash then fails the test, not the suite): one compiled
model per scene, simulated 4 threads × 25 runs with different parameters or start values, against the same
runs done one after another. Prints one JSON line per scene."""
from __future__ import annotations

import json
import sys
import threading

import numpy as np

import mechnet as mn
import models
from mechnet.components import multibody as mb

THREADS, RUNS = 4, 25


def oscillator():
    cm = models.oscillator(c=mn.tunable(100.0)).compile()
    return cm, [{"params": {"spring.c": 100.0 + 4.0 * k}} for k in range(RUNS)], "j1.phi"


def cartesian_pendulum():
    cm = models.cartesian_pendulum(theta0=0.5, g=mn.tunable(9.81)).compile()
    return cm, [{"params": {"p.g": 9.0 + 0.1 * k}} for k in range(RUNS)], "p.x"


def multibody_pendulum():
    m = mn.Model("pendulum")
    world = m.add(mb.World(name="world"))
    rev = m.add(mb.Revolute(name="rev", n=[0, 0, 1], phi_start=0.3, w_start=0.0))
    rod = m.add(mb.FixedTranslation(name="rod", r=[1.0, 0, 0]))
    bob = m.add(mb.Particle(name="bob", m=1.0))
    spring = m.add(mb.Spring(name="spring", c=mn.tunable(10.0)))
    anchor = m.add(mb.FixedTranslation(name="anchor", r=[1.0, 0.5, 0]))
    m.connect(world.frame_b, rev.frame_a)
    m.connect(rev.frame_b, rod.frame_a)
    m.connect(rod.frame_b, bob.frame_a)
    m.connect(world.frame_b, anchor.frame_a)
    m.connect(anchor.frame_b, spring.frame_a)
    m.connect(spring.frame_b, bob.frame_a)
    return m.compile(), [{"params": {"spring.c": 5.0 + k}} for k in range(RUNS)], "rev.phi"


def four_bar():
    cm = models.four_bar().compile()
    return cm, [{"start": {"joint_a.phi": 0.2 + 0.02 * k}} for k in range(RUNS)], "joint_d.phi"


def linearized_pendulum():
    """linearize and kinematics build expressions on every call: they take turns (caches.builds_symbols)."""
    cm, _, _ = multibody_pendulum()
    angles = [0.05 * k for k in range(RUNS)]

    def analyse(case):
        lin = cm.linearize(x_op={"rev.phi": case, "rev.w": 0.0})
        frames = mn.kinematics(cm, q={"rev": case})
        return np.sort_complex(lin.eigenvalues()), np.asarray(frames["bob.frame_a"]["r_0"], dtype=float)
    return cm, angles, analyse


SCENES = {"oscillator": oscillator, "cartesian_pendulum": cartesian_pendulum,
          "multibody_pendulum": multibody_pendulum, "four_bar": four_bar, "linearized_pendulum": linearized_pendulum}


def main(names):
    for name in names:
        cm, cases, watch = SCENES[name]()

        def run(case):
            if callable(watch):
                first, second = watch(case)
                return first, second, True
            res = cm.simulate(1.0, rtol=1e-8, atol=1e-10, n_out=51, **case)
            return res.t.copy(), res[watch].copy(), res.failure is None

        results, errors = {}, []

        def worker(i):
            try:
                for k in range(RUNS):
                    j = (7 * k + 3 * i) % RUNS             # every thread walks the cases in another order
                    results[(i, k)] = (j, run(cases[j]))
            except Exception as exc:                       # noqa: BLE001 - reported, then the test fails
                errors.append(f"{type(exc).__name__}: {exc}")

        threads = [threading.Thread(target=worker, args=(i,)) for i in range(THREADS)]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        sequential = [run(case) for case in cases]
        identical = sum(np.array_equal(t, sequential[j][0]) and np.array_equal(y, sequential[j][1])
                        for j, (t, y, _) in results.values())
        finals = [float(y[-1]) for _, y, _ in sequential]
        print(json.dumps({"scene": name, "runs": len(results), "identical": identical, "errors": errors[:3],
                          "succeeded": sum(ok for _, _, ok in sequential), "finals": finals}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or list(SCENES))
