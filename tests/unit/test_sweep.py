"""mn.sweep: many runs of one compiled model, here, in worker processes, or on a Dask cluster.

Physics: an inertia on a torsional spring, φ(t) = φ0·cos(√(c/J)·t), swept over c and φ0 (rtol 1e-10,
atol 1e-12, 1 s: within 1e-8 rad of the closed form). Sameness: the runs of a sweep in worker
processes or on a 2-worker LocalCluster are bitwise those of the same cases run one after the other
here (the same compiled functions, the same settings)."""
import numpy as np
import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from models import bouncing_ball

J = 0.1


def oscillator():
    m = mn.Model("osc")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=mn.tunable(100.0)))
    inertia = m.add(rot.Inertia(name="j1", J=J, phi_start=0.5, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, inertia.flange_a)
    return m.compile()


SETTINGS = dict(t_end=1.0, rtol=1e-10, atol=1e-12, outputs=["j1.phi"])


def test_a_grid_of_parameters_and_starts_matches_the_closed_form():
    cm = oscillator()
    out = mn.sweep(cm, params={"spring.c": [50.0, 100.0, 400.0]}, starts={"j1.phi": [0.1, 0.5]}, workers=0,
                   **SETTINGS)
    rows = out.rows()
    assert len(rows) == 6 and all(r["status"] == "ok" for r in rows)
    assert [(r["spring.c"], r["start:j1.phi"]) for r in rows] == [(50.0, 0.1), (50.0, 0.5), (100.0, 0.1),
                                                                  (100.0, 0.5), (400.0, 0.1), (400.0, 0.5)]
    for r in rows:
        exact = r["start:j1.phi"] * np.cos(np.sqrt(r["spring.c"] / J) * 1.0)
        assert r["j1.phi"] == pytest.approx(exact, abs=1e-8)


def test_zip_runs_the_ith_values_together_and_cases_are_explicit():
    cm = oscillator()
    zipped = mn.sweep(cm, params={"spring.c": [50.0, 400.0]}, starts={"j1.phi": [0.1, 0.5]}, combine="zip",
                      workers=0, **SETTINGS)
    assert [(r["spring.c"], r["start:j1.phi"]) for r in zipped.rows()] == [(50.0, 0.1), (400.0, 0.5)]
    explicit = mn.sweep(cm, cases=[{"params": {"spring.c": 50.0}, "start": {"j1.phi": 0.1}},
                                   {"params": {"spring.c": 400.0}, "start": {"j1.phi": 0.5}}], workers=0, **SETTINGS)
    assert [r["j1.phi"] for r in explicit.rows()] == [r["j1.phi"] for r in zipped.rows()]


def test_worker_processes_give_the_same_numbers():
    cm = oscillator()
    grid = dict(params={"spring.c": [50.0, 100.0, 200.0, 400.0]}, starts={"j1.phi": [0.1, 0.5]})
    here = mn.sweep(cm, workers=0, **grid, **SETTINGS)
    there = mn.sweep(cm, workers=2, **grid, **SETTINGS)
    for a, b in zip(here.runs, there.runs):
        np.testing.assert_array_equal(a.result["j1.phi"], b.result["j1.phi"])


def test_failures_keep_their_partial_result_and_reason():
    """The hand-written ball has no rest mode: with e = 0.8 its bounces accumulate at T∞ = 4.06 s and the
    run stops there (status failed, the solution up to there kept); e = 1 bounces for the whole 5 s; a
    negative e is refused before it runs (status error, no result)."""
    cm = bouncing_ball(e=mn.tunable(0.8)).compile()
    out = mn.sweep(cm, t_end=5.0, params={"b.e": [0.8, 1.0, -0.5]}, workers=0, outputs=["b.h"])
    ok, failed, error = out.runs
    assert ok.status == "failed" and "event accumulation" in ok.reason and 3.9 < ok.result.t[-1] < 4.1
    assert failed.status == "ok" and failed.result.t[-1] == 5.0
    assert error.status == "error" and "b.e" in error.reason and error.result is None
    rows = out.rows()
    assert np.isnan(rows[2]["b.h"]) and rows[0]["t_end"] < 4.1
    assert len(out.failed) == 2


@pytest.mark.parametrize("kwargs, match", [
    (dict(params={"spring.c": 100.0}), "'spring.c' takes a list of values"),
    (dict(params={"spring.c": [1.0, 2.0]}, starts={"j1.phi": [0.1]}, combine="zip"), "lists of one length"),
    (dict(params={"spring.c": [1.0]}, combine="diagonal"), "combine='diagonal'"),
    (dict(cases=[{"parameters": {}}]), "keys are 'params', 'start', 'inputs' and 'settings'"),
    (dict(cases=[{}], params={"spring.c": [1.0]}), "not both"),
    (dict(params={"spring.c": [1.0]}, outputs=["j1.omega"]), "'j1.omega' is not a name"),
    (dict(params={"spring.c": [1.0]}, workers=-1), "workers"),
    (dict(params=[("spring.c", 1.0)]), "takes a mapping"),
    (dict(params={"spring.c": [1.0]}, start={"j1.phi": 0.1}), "starts="),
    (dict(params={"spring.c": [1.0]}, rtoll=1e-6), "'rtoll' is not a setting of cm.simulate"),
    (dict(cases=[{"settings": {"t_end": 1.0}}]), "'t_end' is set by the sweep itself"),
    (dict(params={"spring.c": [1.0]}, at="end"), "at"),
    (dict(params={"spring.c": [1.0]}, t_end=-1.0), "must be > 0"),
    (dict(cases=5), r"cases=5\) takes a list of cases"),
    (dict(cases=[]), r"cases=\[\]\): no cases"),
    (dict(params={"spring.c": []}), "'spring.c' has no values"),
    (dict(params={"spring.c": [1.0]}, starts={"j1.phi": []}, combine="zip"), "'j1.phi' has no values"),
    (dict(params={"spring.c": [1.0]}, at=1.5), r"at=1.5\) lies outside the runs"),
    (dict(params={"spring.c": [1.0]}, at=-0.5), r"at=-0.5\) lies outside the runs"),
    (dict(params={"spring.c": [1.0]}, client=3), r"client=3\) takes a dask.distributed.Client"),
])
def test_bad_arguments_are_refused_by_name(kwargs, match):
    kwargs = {"t_end": 1.0, **kwargs}
    with pytest.raises(mn.MechnetError, match=match):
        mn.sweep(oscillator(), **kwargs)


def test_a_dask_cluster_gives_the_same_numbers_as_sequential_runs():
    """50 parameter sets on a LocalCluster of 2 worker processes: the compiled model scattered once to
    each, the table equal to 50 sequential runs here (bitwise), one failing case kept with its reason."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed (extra 'test') runs sweeps on clusters")
    cm = oscillator()
    c_values = list(np.linspace(10.0, 500.0, 49)) + [-1.0]          # the last one is refused
    here = mn.sweep(cm, params={"spring.c": c_values}, workers=0, **SETTINGS)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        there = mn.sweep(cm, params={"spring.c": c_values}, client=client, **SETTINGS)
    assert [r["status"] for r in there.rows()] == ["ok"] * 49 + ["error"]
    assert "must be >= 0" in there.rows()[-1]["reason"]
    for a, b in zip(here.rows()[:49], there.rows()[:49]):
        assert a["j1.phi"] == b["j1.phi"]


def test_an_input_worker_processes_cannot_receive_is_refused_by_name():
    """Worker processes receive each case pickled: a lambda is refused, naming the input, before any worker
    starts (here, with workers=0, it runs)."""
    m = mn.Model("driven")
    inertia = m.add(rot.Inertia(name="j1", J=J, phi_start=0.0, w_start=0.0))
    torque = m.add(rot.Torque(name="tq"))
    m.connect(torque.flange, inertia.flange_a)
    cm = m.compile()
    with pytest.raises(mn.MechnetError, match=r"sweep\(inputs=...\): 'tq.tau' \(case 0\).*cannot be sent to worker"):
        mn.sweep(cm, t_end=1.0, inputs={"tq.tau": [lambda t: 1.0, 2.0]}, workers=2)
    here = mn.sweep(cm, t_end=1.0, inputs={"tq.tau": [lambda t: 1.0, 2.0]}, workers=0, outputs=["j1.phi"])
    assert [r["j1.phi"] for r in here.rows()] == pytest.approx([5.0, 10.0])


def test_a_closed_dask_client_is_refused():
    distributed = pytest.importorskip("distributed", reason="dask.distributed (extra 'test') runs sweeps on clusters")
    client = distributed.Client(processes=False, dashboard_address=None)
    client.close()
    with pytest.raises(mn.MechnetError, match="the Dask client is closed"):
        mn.sweep(oscillator(), t_end=1.0, params={"spring.c": [1.0]}, client=client)


def test_to_csv_quotes_text_as_the_csv_module_reads_it(tmp_path):
    """A text holding quotes and commas (the method 'a"b, c' and the error naming it) is quoted with its
    quotes doubled (RFC 4180): the csv module reads back the table's own text, floats bit for bit."""
    import csv
    out = mn.sweep(oscillator(), cases=[{"params": {"spring.c": 100.0}},
                                        {"params": {"spring.c": 100.0}, "settings": {"method": 'a"b, c'}}],
                   workers=0, **SETTINGS)
    path = tmp_path / "sweep.csv"
    out.to_csv(path)
    with open(path, newline="", encoding="utf-8") as f:
        back = list(csv.DictReader(f))
    rows = out.rows()
    assert back[1]["method"] == 'a"b, c' and back[1]["reason"] == rows[1]["reason"] and '"' in rows[1]["reason"]
    assert float(back[0]["j1.phi"]) == rows[0]["j1.phi"]
