"""mn.sweep: grids, cases, outputs, workers and clients. Worker processes are only started where the
case is about them (workers=2)."""
from __future__ import annotations

import math


import mechnet as mn
from fuzz import fixtures
from fuzz.framework import Collector, close, expect

NEEDS = ("driven",)


class RunsFailed(mn.MechnetError):
    """A sweep keeps a run that failed as a row with its reason (by design: one bad point must not lose
    the others); the reasons are what the user reads, so they are what the case classes."""


def _sweep(**kw):
    kw.setdefault("t_end", 0.5)
    kw.setdefault("outputs", ["j1.phi"])
    kw.setdefault("workers", 0)

    def run():
        sw = mn.sweep(fixtures.driven(), **kw)
        failed = sw.failed
        if failed:
            reasons = "; ".join(f"{r.status}: {getattr(r, 'error', None) or getattr(r, 'reason', r)}"
                                for r in failed[:3])
            raise RunsFailed(f"{len(failed)} run(s) failed: {reasons:.600}")
        return sw
    return run


def collector() -> Collector:
    col = Collector("sweep")
    bad = {
        "params.unknown": ({"params": {"spring.k": [1, 2]}}, "spring.k"),
        "params.folded": ({"params": {"j1.J": [1, 2]}}, "j1.J"),
        "params.nan": ({"params": {"spring.c": [100, math.nan]}}, "spring.c"),
        "params.negative": ({"params": {"spring.c": [100, -1]}}, "spring.c"),
        "params.text": ({"params": {"spring.c": "100"}}, "spring.c"),
        "params.list": ({"params": [100, 200]}, "params"),
        "starts.unknown": ({"starts": {"j9.phi": [0, 1]}}, "j9.phi"),
        "starts.nan": ({"starts": {"j1.phi": [math.nan]}}, "j1.phi"),
        "inputs.unknown": ({"inputs": {"drive.f": [1.0]}}, "drive.f"),
        "outputs.unknown": ({"outputs": ["j9.phi"]}, "j9.phi"),
        "outputs.number": ({"outputs": [3]}, "outputs"),
        "combine.unknown": ({"params": {"spring.c": [1, 2]}, "combine": "product"}, "combine"),
        "zip.lengths": ({"params": {"spring.c": [1, 2]}, "starts": {"j1.phi": [0, 1, 2]}, "combine": "zip"},
                        ("spring.c", "j1.phi")),
        "cases.number": ({"cases": 5}, "cases"),
        "cases.text": ({"cases": "abc"}, "cases"),
        "cases.unknown_key": ({"cases": [{"parms": {"spring.c": 1.0}}]}, "parms"),
        "cases.unknown_name": ({"cases": [{"params": {"spring.k": 1.0}}]}, "spring.k"),
        "cases.with_grid": ({"cases": [{"params": {"spring.c": 1.0}}], "params": {"spring.c": [1, 2]}}, "cases"),
        "grid.empty": ({"params": {"spring.c": []}}, "spring.c"),
        "at.past_end": ({"params": {"spring.c": [100]}, "at": 2.0}, "at"),
        "at.nan": ({"params": {"spring.c": [100]}, "at": math.nan}, "at"),
        "workers.negative": ({"workers": -2}, "workers"),
        "workers.text": ({"workers": "2"}, "workers"),
        "repeat.zero": ({"repeat": 0}, "repeat"),
        "t_end.zero": ({"t_end": 0.0}, "t_end"),
        "simulate.unknown": ({"rtoll": 1e-3}, "rtoll"),
        "simulate.rtol_nan": ({"rtol": math.nan}, "rtol"),
        "client.text": ({"client": "tcp://nowhere:1"}, "client"),
    }
    known = {"cases.number": "mn.sweep cases=5", "grid.empty": "an empty grid (0 runs, no word)",
             "at.past_end": "at past t_end (NaN rows, status ok)"}
    for what, (kw, culprit) in bad.items():
        col.bad(what, _sweep(**kw), (culprit,), needs=NEEDS, known=known.get(what, ""))
    col.bad("inputs.lambda_workers", _sweep(inputs={"drive.tau": [lambda t: 1.0]}, workers=2), ("drive.tau",),
            needs=NEEDS, known="mn.sweep with a lambda input and workers=2", slow=True, timeout=120)

    def closed_client():
        from distributed import Client
        client = Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None)
        client.close()
        return mn.sweep(fixtures.driven(), t_end=0.5, params={"spring.c": [100]}, outputs=["j1.phi"], client=client)
    col.bad("client.closed", closed_client, ("client",), needs=NEEDS, known="a closed Dask client", slow=True,
            timeout=120)
    col.bad("not_compiled", lambda: mn.sweep(fixtures.driven_model(), t_end=0.5), ("sweep",))

    def csv_quotes():
        import csv
        sw = mn.sweep(fixtures.driven(), t_end=0.2, cases=[{"params": {"spring.c": 100.0}, "start": {"j9": 1.0}}],
                      outputs=["j1.phi"], workers=0)        # fails, with a reason quoting the name 'j9'
        sw.to_csv("out.csv")
        with open("out.csv") as f:
            rows = list(csv.reader(f))
        return rows
    col.good("to_csv.quotes", csv_quotes, "a reason with quotes and commas stays one CSV field",
             lambda rows: expect(all(len(r) == len(rows[0]) for r in rows) and any(
                 "j9" in field for r in rows for field in r), "rectangular, reason kept"), needs=NEEDS,
             known="to_csv not doubling quotes")
    col.good("grid", _sweep(params={"spring.c": [100.0, 400.0]}, at=0.5), "a two-point grid",
             lambda sw: expect(len(sw.to_pandas()) == 2, "two rows"), needs=NEEDS)
    return col
