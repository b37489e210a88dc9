"""Runs fuzz cases, each in its own forked process, and classes what mechnet did with each input.

    python tests/fuzz/runner.py [--area AREA] [--every N] [--jobs J] [--id ID ...]

Classes (issue 32): A a MechnetError naming the culprit; B a MechnetError that does not; C another Python
exception; D a raw CasADi/SUNDIALS error; E a silent wrong answer or NaN (a result holding NaN, or a
legitimate input whose check fails); F a hang (past the case's timeout) or a crash (the process died);
S a bad input accepted silently; OK a legitimate input accepted with a right result; R a legitimate
input refused (an error where the case says why the input is fine).

Why fork: the parent imports mechnet (and builds the shared fixtures) once, so a case costs a fork, not
an import; a case that hangs, crashes or corrupts global state takes only its own process down.
"""
from __future__ import annotations

import argparse
import multiprocessing
import multiprocessing.connection
import os
import re
import shutil
import signal
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter, defaultdict

_TESTS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _TESTS not in sys.path:             # as a script or `python -m tests.fuzz.runner`: tests/ on the path, as in pytest
    sys.path.insert(0, _TESTS)

import matplotlib  # noqa: E402

matplotlib.use("Agg")

import mechnet as mn  # noqa: E402
from fuzz import fixtures  # noqa: E402
from fuzz.framework import contains_nan  # noqa: E402

CLASSES = ("A", "B", "C", "D", "E", "F", "S", "OK", "R")
GOOD = ("A", "OK")
RAW = re.compile(r"casadi|Error in Function|\.cpp:|\b(CV|IDA|KIN|CVODE|IDAS)_[A-Z_]+|SUNDIALS|\bcvodes\b",
                 re.IGNORECASE)


def all_cases():
    from fuzz.cases import collect
    return collect()


def names_culprit(message: str, culprit) -> bool:
    """Every culprit word (or one of a tuple of alternatives) in the message, as a whole word."""
    def found(word):
        return re.search(r"(?<![A-Za-z0-9_])" + re.escape(word) + r"(?![A-Za-z0-9_])", message) is not None
    return all(any(found(w) for w in (c if isinstance(c, tuple) else (c,))) for c in culprit)


def classify(case, value=None, error: BaseException | None = None) -> tuple[str, str]:
    """(class, message) of one finished case: `error` raised, or `value` returned."""
    if error is not None:
        message = f"{type(error).__name__}: {error}"
        if isinstance(error, mn.MechnetError):
            cls = "A" if names_culprit(str(error), case.culprit) else "B"
        elif RAW.search(str(error)):
            cls = "D"
        else:
            cls = "C"
        if case.ok is not None:
            return "R", message
        return cls, message
    if case.ok is not None:
        try:
            verdict = case.check(value)
        except Exception as exc:       # the check failed: accepted, but the answer is wrong
            return "E", f"check failed: {type(exc).__name__}: {exc}"
        if verdict is False:
            return "E", "check failed"
        return "OK", case.ok
    if contains_nan(value):
        return "E", f"accepted, and the result holds NaN: {value!r:.200}"
    return "S", f"accepted: {value!r:.200}"


def _child(index: int, conn, workdir: str) -> None:
    """In the forked process: own process group (a timeout kills its workers too), own working folder,
    output captured at the file-descriptor level (SUNDIALS prints from C)."""
    os.setpgid(0, 0)
    case = CASES[index]
    os.makedirs(workdir, exist_ok=True)
    os.chdir(workdir)
    chatter = os.path.join(workdir, ".chatter")
    fd = os.open(chatter, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    sys.stdout.flush()
    sys.stderr.flush()
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    started = time.perf_counter()
    value = error = None
    trace = ""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            value = case.run()
        except BaseException as exc:     # noqa: BLE001 - SystemExit, KeyboardInterrupt are findings too
            error = exc
            trace = traceback.format_exc(limit=-4)
        try:
            cls, message = classify(case, value, error)
        except BaseException as exc:     # noqa: BLE001
            cls, message = "C", f"classifying the result raised {type(exc).__name__}: {exc}"
    sys.stdout.flush()
    sys.stderr.flush()
    with open(chatter, errors="replace") as f:
        printed = f.read().strip()
    notes = [f"warning {w.category.__name__}: {w.message}"[:300] for w in caught[:3]]
    if printed:
        notes.append(f"printed: {printed[:300]!r}")
    if cls in ("C", "D"):
        notes.append(trace[-1500:])
    conn.send({"id": case.id, "area": case.area, "cls": cls, "message": message[:1500], "notes": notes,
               "seconds": time.perf_counter() - started})
    conn.close()


CASES: list = []


def run(cases, jobs: int = 2, progress=None) -> list[dict]:
    """Every case in its own process, `jobs` at a time; a record per case, in the given order."""
    global CASES
    CASES = list(cases)
    for name in sorted({n for c in CASES for n in c.needs}):
        fixtures.FIXTURES[name]()                   # built once here, inherited by every child
    ctx = multiprocessing.get_context("fork")
    base = tempfile.mkdtemp(prefix="mechnet-fuzz-cases-")
    records: dict[int, dict] = {}
    pending = list(range(len(CASES)))[::-1]
    running: dict = {}                 # sentinel -> (index, process, conn, start)
    try:
        while pending or running:
            while pending and len(running) < jobs:
                i = pending.pop()
                receive, send = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_child, args=(i, send, os.path.join(base, str(i))), daemon=False)
                proc.start()
                send.close()
                running[proc.sentinel] = (i, proc, receive, time.monotonic())
            ready = multiprocessing.connection.wait(list(running), timeout=0.5)
            now = time.monotonic()
            for sentinel in list(running):
                i, proc, receive, start = running[sentinel]
                case = CASES[i]
                overdue = now - start > case.timeout
                if sentinel not in ready and not overdue:
                    continue
                record = None
                if receive.poll():
                    try:
                        record = receive.recv()
                    except (EOFError, OSError):
                        record = None
                if sentinel not in ready and record is None:       # overdue: a hang
                    _kill(proc)
                    record = _failed(case, f"hang: no answer after {case.timeout:g} s (killed)", now - start)
                proc.join(5)
                if proc.is_alive():
                    _kill(proc)
                if record is None:
                    code = proc.exitcode
                    how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit status {code}"
                    record = _failed(case, f"crash: the process died ({how}) without an answer", now - start)
                receive.close()
                records[i] = record
                del running[sentinel]
                if progress:
                    progress(record)
    finally:
        for i, proc, receive, start in running.values():
            _kill(proc)
        shutil.rmtree(base, ignore_errors=True)
    return [records[i] for i in range(len(CASES))]


def _kill(proc) -> None:
    """The case's process group (it and whatever it started), by its id."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    proc.join(5)


def _failed(case, message, seconds) -> dict:
    return {"id": case.id, "area": case.area, "cls": "F", "message": message, "notes": [], "seconds": seconds}


def table(records) -> str:
    """Markdown: areas × classes, with totals and the share of A + OK."""
    by_area = defaultdict(Counter)
    for r in records:
        by_area[r["area"]][r["cls"]] += 1
    total = Counter(r["cls"] for r in records)
    head = "| area | cases | " + " | ".join(CLASSES) + " | A+OK |"
    lines = [head, "|" + "---|" * (len(CLASSES) + 3)]
    for area in sorted(by_area) + ["total"]:
        counts = total if area == "total" else by_area[area]
        n = sum(counts.values())
        good = sum(counts[c] for c in GOOD)
        cells = " | ".join(str(counts[c] or "") for c in CLASSES)
        lines.append(f"| {area} | {n} | {cells} | {100 * good / max(n, 1):.1f} % |")
    return "\n".join(lines)


def findings(records) -> str:
    """Every case that is neither A nor OK, with its message."""
    out = []
    for r in records:
        if r["cls"] not in GOOD:
            out.append(f"{r['cls']:>2} {r['id']}: {r['message'][:400]}")
    return "\n".join(out)


def verdict(records, share: float = 0.97) -> list[str]:
    """What fails the target (A + OK >= share, no D, E or F): empty when the run passes."""
    problems = []
    n = len(records)
    good = sum(r["cls"] in GOOD for r in records)
    if n and good / n < share:
        problems.append(f"A + OK = {good}/{n} = {100 * good / n:.1f} % < {100 * share:g} %")
    worst = [r for r in records if r["cls"] in ("D", "E", "F")]
    problems += [f"{r['cls']} {r['id']}: {r['message'][:300]}" for r in worst]
    return problems


def select(cases, area=None, ids=None, every=1, include_slow=True):
    chosen = [c for c in cases if (area is None or c.area == area) and (not ids or c.id in ids or
                                                                       any(c.id.startswith(i) for i in ids))]
    if not include_slow:
        chosen = [c for c in chosen if not c.slow]
    return chosen[::every]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--area")
    parser.add_argument("--id", nargs="+", help="case ids (or id prefixes)")
    parser.add_argument("--every", type=int, default=1, help="every N-th case (a sample)")
    parser.add_argument("--no-slow", action="store_true", help="leave out slow cases")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    parser.add_argument("-v", "--verbose", action="store_true", help="print every case as it ends")
    args = parser.parse_args(argv)
    cases = select(all_cases(), args.area, args.id, args.every, not args.no_slow)
    started = time.perf_counter()

    def show(record):
        if args.verbose:
            print(f"{record['cls']:>2} {record['seconds']:6.2f}s {record['id']}: {record['message'][:200]}",
                  flush=True)
    try:
        records = run(cases, args.jobs, show)
    finally:
        shutil.rmtree(fixtures.root(), ignore_errors=True)
    print(table(records))
    print(f"\n{len(records)} cases in {time.perf_counter() - started:.1f} s\n")
    print(findings(records))
    slowest = sorted(records, key=lambda r: -r["seconds"])[:5]
    print("\nslowest: " + ", ".join(f"{r['id']} {r['seconds']:.1f} s" for r in slowest))
    return 1 if verdict(records) else 0


if __name__ == "__main__":
    sys.exit(main())
