"""threads — what sharing one compiled model between threads costs and gains.

Why: a sweep or an optimiser's checks simulate one compiled model many times, often from a thread
pool. Integrators are kept per thread (one SUNDIALS integrator cannot serve two threads at once:
mechnet/caches.py), so each thread builds its own on its first run; anything symbolic is built under
one process-wide lock. This prints, for each scene:
  * the first run in a fresh thread (builds that thread's integrators) and a warm run;
  * 2 × RUNS runs done one after another, and the same runs on 2 threads (this machine has 2 cores),
    their wall times and ratio (ideal: 0.5).
Peer in the same run: the sequential runs themselves (the same calls, one thread).

    python benchmarks/threads.py
"""
from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

import models  # noqa: E402

RUNS = 40


def scenes():
    yield "oscillator (CVODES)", models.oscillator().compile(), {}
    yield "Cartesian pendulum (IDAS, monitor)", models.cartesian_pendulum().compile(), {}
    yield "four-bar (IDAS, branch check)", models.four_bar().compile(), {}


def timed(f):
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def main():
    print(f"{'scene':38s} {'1st run/thread':>14s} {'warm run':>9s} {'sequential':>11s} {'2 threads':>10s} "
          f"{'ratio':>6s}")
    for label, cm, kw in scenes():
        def run():
            cm.simulate(2.0, **kw)
        cm.simulate(2.0, **kw)                       # the model's first run: shared caches built
        first = []
        th = threading.Thread(target=lambda: first.append(timed(run)))
        th.start()
        th.join()
        warm = min(timed(run) for _ in range(5))
        sequential = timed(lambda: [run() for _ in range(2 * RUNS)])

        def pool():
            threads = [threading.Thread(target=lambda: [run() for _ in range(RUNS)]) for _ in range(2)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
        parallel = timed(pool)
        print(f"{label:38s} {first[0] * 1e3:11.1f} ms {warm * 1e3:6.1f} ms {sequential:9.2f} s "
              f"{parallel:8.2f} s {parallel / sequential:6.2f}")


if __name__ == "__main__":
    main()
