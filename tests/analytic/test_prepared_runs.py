"""`cm.prepare`: one simulation's settings fixed, called with new parameters and starts. Every call returns
the numbers `cm.simulate` returns (bit for bit), and those follow the analytic solution."""
import pickle
import threading

import numpy as np
import pytest

import mechnet as mn
import models

RTOL, ATOL = 1e-8, 1e-10


def same(a, b):
    """Two results hold the same numbers (all but the wall time and the solver's text)."""
    assert np.array_equal(a.t, b.t) and np.array_equal(a.values, b.values, equal_nan=True)
    keep = lambda s: {k: v for k, v in s.items() if k not in ("wall_time", "solver_messages")}   # noqa: E731
    assert keep(a.stats) == keep(b.stats)
    assert [(e.t, e.kind) for e in a.events] == [(e.t, e.kind) for e in b.events]


@pytest.fixture(scope="module")
def oscillator():
    return models.oscillator(J=0.1, c=mn.tunable(100.0), phi0=0.5).compile()


@pytest.fixture
def full_runs(monkeypatch):
    """How many calls of prepared runs went through cm.simulate in full."""
    from mechnet.simulate import prepared
    count, simulate = [0], prepared.simulate

    def counted(*args, **kwargs):
        count[0] += 1
        return simulate(*args, **kwargs)
    monkeypatch.setattr(prepared, "simulate", counted)
    return count


def test_a_plain_run_repeats_its_integrator_call_with_simulate_s_numbers(oscillator, full_runs):
    # Inertia J = 0.1 kg·m² on a torsional spring c (tunable), from φ0 (start value) at rest:
    # φ = φ0 cos(√(c/J) t).
    # Pass criteria: every call equals cm.simulate with the same arguments bit for bit; the angle within
    # 10·(rtol·0.5 + atol) · (ω·2 s) of the closed form over 2 s (101 outputs; the global error of a
    # controlled run grows with the periods: at most ω t / 2π ≈ 10 of them here); only the first call
    # runs cm.simulate in full; each result's lists are its own.
    run = oscillator.prepare(2.0, n_out=101, rtol=RTOL, atol=ATOL)
    assert run.plain is None
    results = []
    for c, phi0 in ((100.0, 0.5), (100.0, 0.5), (400.0, 0.5), (400.0, 0.2), (25.0, -1.0)):
        res = run(params={"spring.c": c}, start={"j1.phi": phi0})
        same(res, oscillator.simulate(2.0, n_out=101, rtol=RTOL, atol=ATOL, params={"spring.c": c},
                                      start={"j1.phi": phi0}))
        w = np.sqrt(c / 0.1)
        bound = 10 * (RTOL * abs(phi0) + ATOL) * w * 2.0
        assert np.max(np.abs(res["j1.phi"] - phi0 * np.cos(w * res.t))) <= bound, c
        results.append(res)
    assert run.plain is True and full_runs[0] == 1
    assert results[1].initial["fixed"] is not results[0].initial["fixed"]


def test_settings_are_kept_as_they_were_given(oscillator, full_runs):
    # An output grid changed by its owner after the first call changes nothing (the run keeps its copy).
    # Pass criteria: the second call equals cm.simulate on the original grid bit for bit, by the plain path.
    t_out = np.linspace(0.0, 1.0, 11)
    run = oscillator.prepare(1.0, t_out=t_out, rtol=RTOL, atol=ATOL)
    run()
    t_out[5] = 0.55
    same(run(), oscillator.simulate(1.0, t_out=np.linspace(0.0, 1.0, 11), rtol=RTOL, atol=ATOL))
    assert full_runs[0] == 1


def test_a_pendulum_wound_many_turns_repeats_its_call_without_the_turns(full_runs):
    # A 1 m, 1 kg pendulum on a revolute joint (gravity −y; angle from +x), released 0.3 rad from the
    # horizontal: its angle enters the equations through sine and cosine only, so a run leaves its whole
    # turns out of the integrator call. Started 0.3 + 2π·k rad (k = 0, 10, 1000), it is the same motion.
    # Pass criteria: each call equals cm.simulate bit for bit; the wound runs' angles less 2πk match the
    # unwound one within 100 ulp of 2πk (the turns are held exactly: only the start's rounding is left,
    # measured 2e-13 and 9e-13 rad; integrated with the turns, an error of rtol·2πk = 6e-5 rad); then a
    # wheel spun at 2000 rad/s winds past TURN_LIMIT (256 rad) within the 1 s run, so that call is
    # cm.simulate in full (its run loop splits it), with simulate's numbers; the next ordinary start
    # takes the fast path again.
    cm = models.revolute_pendulum(phi0=0.3).compile()
    run = cm.prepare(1.0, n_out=51, rtol=RTOL, atol=ATOL)
    phis = {}
    for k in (0, 10, 1000):
        res = run(start={"rev.phi": 0.3 + 2 * np.pi * k})
        same(res, cm.simulate(1.0, n_out=51, rtol=RTOL, atol=ATOL, start={"rev.phi": 0.3 + 2 * np.pi * k}))
        phis[k] = res["rev.phi"] - 2 * np.pi * k
    assert run.plain and full_runs[0] == 1
    for k in (10, 1000):
        assert np.max(np.abs(phis[k] - phis[0])) <= 100 * np.spacing(2 * np.pi * k), k
    spun = run(start={"rev.w": 2000.0})
    same(spun, cm.simulate(1.0, n_out=51, rtol=RTOL, atol=ATOL, start={"rev.w": 2000.0}))
    assert full_runs[0] == 2 and spun.stats["segments"] > 1
    same(run(start={"rev.phi": 0.4}), cm.simulate(1.0, n_out=51, rtol=RTOL, atol=ATOL, start={"rev.phi": 0.4}))
    assert full_runs[0] == 2


def test_a_run_with_events_stays_with_simulate(full_runs):
    # A ball dropped from 1 m onto a floor (e = 0.8): its run stops at each impact, so every call is
    # cm.simulate in full. Pass criteria: plain is False; both calls equal cm.simulate bit for bit; the first
    # impact at √(2h/g) within 10·rtol·t.
    cm = models.bouncing_ball(h0=1.0, e=0.8).compile()
    run = cm.prepare(1.0, n_out=51, rtol=RTOL, atol=ATOL)
    first, second = run(), run()
    assert run.plain is False and full_runs[0] == 2
    reference = cm.simulate(1.0, n_out=51, rtol=RTOL, atol=ATOL)
    same(first, reference)
    same(second, reference)
    impact = next(e.t for e in first.events if e.kind == "state")
    assert impact == pytest.approx(np.sqrt(2 * 1.0 / 9.81), rel=10 * RTOL)


def test_a_failed_call_returns_simulate_s_partial_result(oscillator):
    # 300 steps allowed: enough for c = 100 N·m/rad over 2 s (a few periods), not for c = 1e6 (3200 rad/s).
    # Pass criteria: the stiff call returns what cm.simulate returns — the same partial result, failure
    # and warning — and the next call is plain again, with simulate's numbers.
    run = oscillator.prepare(2.0, n_out=11, rtol=RTOL, atol=ATOL, max_steps=300)
    run()
    assert run.plain
    with pytest.warns(mn.IntegrationWarning) as caught:
        res = run(params={"spring.c": 1e6})
    assert caught[0].filename == __file__                  # the warning names the caller's line
    assert res.failure is not None
    with pytest.warns(mn.IntegrationWarning) as caught:
        reference = oscillator.simulate(2.0, n_out=11, rtol=RTOL, atol=ATOL, max_steps=300, params={"spring.c": 1e6})
    assert caught[0].filename == __file__
    same(res, reference)
    same(run(), oscillator.simulate(2.0, n_out=11, rtol=RTOL, atol=ATOL, max_steps=300))


def test_threads_and_processes_get_their_own_calls(oscillator, full_runs):
    # Four threads call one prepared run with four spring rates at once, and a pickled copy (another process's
    # view) runs too. Pass criteria: each result equals cm.simulate with its own rate bit for bit.
    run = oscillator.prepare(1.0, n_out=21, rtol=RTOL, atol=ATOL)
    run()
    rates = [50.0, 100.0, 200.0, 400.0]
    results = {}

    def work(c):
        for _ in range(20):
            results[c] = run(params={"spring.c": c})
    threads = [threading.Thread(target=work, args=(c,)) for c in rates]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert full_runs[0] == 1
    for c in rates:
        same(results[c], oscillator.simulate(1.0, n_out=21, rtol=RTOL, atol=ATOL, params={"spring.c": c}))
    copy = pickle.loads(pickle.dumps(run))
    assert copy.plain is None
    same(copy(params={"spring.c": 50.0}), results[50.0])


def test_prepare_names_a_wrong_setting(oscillator):
    with pytest.raises(mn.MechnetError, match=r"prepare\(\.\.\., params=\.\.\.\): params changes per call"):
        oscillator.prepare(1.0, params={"spring.c": 1.0})
    with pytest.raises(mn.MechnetError, match=r"prepare\(\.\.\., continue_from=\.\.\.\).*cm.simulate"):
        oscillator.prepare(1.0, continue_from=None)
    with pytest.raises(mn.MechnetError, match=r"prepare\(\.\.\., n_outs=\.\.\.\): no such setting.*n_out"):
        oscillator.prepare(1.0, n_outs=11)
    run = oscillator.prepare(1.0, rtol=-1.0)
    with pytest.raises(mn.MechnetError, match="rtol"):                # values are checked by the first call
        run()
    with pytest.raises(mn.UnknownNameError, match="spring.k"):
        oscillator.prepare(1.0)(params={"spring.k": 1.0})
    run = oscillator.prepare(1.0, n_out=11)
    run()
    with pytest.raises(mn.UnknownNameError, match="spring.k"):        # and by every plain call
        run(params={"spring.k": 1.0})
    with pytest.raises(mn.MechnetError, match="start value for 'j1.phj'"):
        run(start={"j1.phj": 1.0})
