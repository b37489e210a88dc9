"""mechnet.accuracy: the work-precision study, its reference, its recommendation and its command line.

Acceptance (issue 22): for a 5-link pendulum chain (error at t = 1 s) and the four-bar the error falls
by at least four decades as rtol goes from 1e-4 to 1e-10 while the cost grows, and a run with the
recommended setting for 1e-6 reaches it. The reference is a run 100× tighter than the tightest
setting, checked by a second method 10× tighter still."""
import numpy as np
import pytest

import mechnet as mn
from mechnet import accuracy
from mechnet.cli import main
from mechnet.components import multibody as mb
from models import four_bar

EXAMPLES = __import__("pathlib").Path(__file__).parents[2] / "examples"
TOLS = (1e-4, 1e-6, 1e-8, 1e-10)


def chain(n=5):
    m = mn.Model(f"chain{n}")
    world = m.add(mb.World(name="world", g=[0.0, -9.81, 0.0]))
    previous = world.frame_b
    for k in range(n):
        joint = m.add(mb.Revolute(name=f"j{k}", n=[0, 0, 1], phi_start=0.3 if k == 0 else 0.1, w_start=0.0))
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[0.2, 0, 0]))
        bob = m.add(mb.Particle(name=f"bob{k}", m=0.5))
        m.connect(previous, joint.frame_a)
        m.connect(joint.frame_b, rod.frame_a)
        m.connect(rod.frame_b, bob.frame_a)
        previous = rod.frame_b
    return m


def _four_decades(result, method):
    rows = sorted((t.setting, t.error, t.evaluations) for t in result.trials if t.method == method and t.status == "ok")
    errors = {tol: err for tol, err, _ in rows}
    assert errors[1e-4] / errors[1e-10] >= 1e4, errors
    # the cost grows: counted in right-hand-side evaluations (wall time on a shared machine flakes: once
    # 11.0 ms at 1e-10 against 11.5 ms at 1e-4 with two test runs side by side)
    work = {tol: n for tol, _, n in rows}
    assert work[1e-10] > work[1e-4], work
    return errors


def _reaches(cm, result, target):
    """Run the recommended cm.simulate setting and measure its error against the study's reference."""
    best = result.recommend(target, simulate_only=True)
    assert best is not None
    res = cm.simulate(result.at, method=best.method, rtol=best.setting, atol=best.setting * accuracy.ATOL_RATIO)
    reference = {t.method: t for t in result.trials}
    err = max(abs(res[n][-1] - v) for n, v in zip(result.names, _truth(cm, result)))
    assert err <= target
    return best, reference


def _truth(cm, result):
    tight = min(TOLS) * 1e-3
    res = cm.simulate(result.at, t_out=[0.0, result.at], rtol=tight, atol=tight * accuracy.ATOL_RATIO,
                      method="cvodes-bdf" if cm.dae.is_ode else "idas", max_steps=10 ** 7)
    return [res[n][-1] for n in result.names]


def test_a_five_link_chain_error_falls_four_decades_and_the_recommendation_holds():
    cm = chain(5).compile()
    result = accuracy.study(cm, 1.0, methods=["cvodes-adams", "cvodes-bdf", "rk", "scipy-dop853"], tolerances=TOLS,
                            steps=(30, 100, 300), repeat=1)
    assert "run at rtol 1e-13 (checked by a run at 1e-12" in result.reference and not result.warnings
    _four_decades(result, "cvodes-adams")
    _four_decades(result, "cvodes-bdf")
    best, _ = _reaches(cm, result, 1e-6)
    assert best.method in ("cvodes-adams", "cvodes-bdf")
    assert "method=" in result.recommendation(1e-6) and "rtol=" in result.recommendation(1e-6)
    rk = sorted((t.setting, t.error) for t in result.trials if t.method == "rk")
    assert rk[0][1] > rk[-1][1] * 1e3                  # RK4: 10x the steps, about 1e4 less error
    table = result.to_markdown()
    assert "| cvodes-adams | 1e-06 |" in table and "for error <= 1e-06" in table


def test_the_four_bar_error_falls_four_decades_and_its_closure_is_measured():
    cm = four_bar().compile()
    result = accuracy.study(cm, 1.0, methods=["idas", "cvodes-adams", "collocation"], tolerances=TOLS,
                            steps=(30, 100), repeat=1)
    _four_decades(result, "idas")
    skipped = {t.method: t.reason for t in result.trials if t.status == "skipped"}
    assert "explicit ODE" in skipped["cvodes-adams"]
    idas = [t for t in result.trials if t.method == "idas"]
    # the loop's closure at t = 1 s, within 10·(rtol·scale + atol) (links of 0.2-0.6 m: scale 1 m)
    assert all(np.isfinite(t.drift) and t.drift <= 10 * (t.setting + t.setting * accuracy.ATOL_RATIO) for t in idas)
    _reaches(cm, result, 1e-6)


def test_the_baumgarte_formulation_is_compared_where_it_applies():
    """The Cartesian pendulum (index 3) compiled with Baumgarte stabilisation next to the index-reduced
    one: both errors fall with the tolerance, and Baumgarte's constraint drift at 1 s is reported. A
    multibody loop, which the Baumgarte path does not take, is skipped with the compiler's reason."""
    from models import cartesian_pendulum
    result = accuracy.study(cartesian_pendulum(0.5).compile(), 1.0, methods=["idas", "baumgarte"],
                            tolerances=(1e-4, 1e-8), repeat=1)
    baumgarte = {t.setting: t for t in result.trials if t.method == "baumgarte"}
    assert all(t.status == "ok" for t in baumgarte.values()), [t.reason for t in baumgarte.values()]
    assert baumgarte[1e-8].error < baumgarte[1e-4].error and np.isfinite(baumgarte[1e-8].drift)
    loop = accuracy.study(four_bar().compile(), 0.5, methods=["baumgarte"], tolerances=(1e-6,), repeat=1)
    assert loop.trials[0].status == "skipped" and "index" in loop.trials[0].reason


def test_a_chaotic_scene_is_said_to_be_so():
    """The double pendulum (0.5, 0.8 rad) is chaotic: at 10 s runs at rtol 1e-10 and 1e-11 differ by 2e-2."""
    from mechnet.scene import load_scene
    cm = load_scene(EXAMPLES / "double_pendulum.py").model().compile()
    result = accuracy.study(cm, 10.0, methods=["cvodes-adams"], tolerances=(1e-4, 1e-8), repeat=1)
    assert any("chaotic" in w for w in result.warnings)


def test_an_unreliable_run_is_recommended_only_where_the_reference_cannot_spoil_it():
    # A reference whose own error is 1e-5 (a chaotic scene late in its run): a run measured at 2e-6 lies
    # within 10× of it (unreliable); its true error is at most 2e-6 + 1e-5 = 1.2e-5. It is the cheapest
    # run for a 1e-3 target; for 1.1e-5 nothing qualifies (that bound exceeds it, the other run errs 5e-4).
    fast = accuracy.Trial("auto", 1e-8, error=2e-6, time=0.010, reliable=False)
    slow = accuracy.Trial("auto", 1e-10, error=5e-4, time=0.050)
    study = accuracy.AccuracyStudy("chain", 10.0, ("rev0.phi",), [fast, slow], "two tighter runs", 1e-5)
    assert study.recommend(1e-3) is fast
    assert study.recommend(1.1e-5) is None
    assert study.recommend(1e-3, simulate_only=True) is fast


def test_the_command_line_writes_its_plot_against_the_scenes_reference(tmp_path, capsys):
    status = main(["accuracy", str(EXAMPLES / "double_pendulum.py"), "--t-end", "0.5", "--methods", "cvodes-adams",
                   "idas", "rk", "--tolerances", "1e-4", "1e-6", "1e-8", "-o", str(tmp_path)])
    out = capsys.readouterr().out
    assert status == 0
    assert "against the scene's reference(t)" in out and "recommended for error <= 1e-06" in out
    for suffix in (".png", ".md", ".csv"):
        assert (tmp_path / f"double_pendulum_accuracy{suffix}").stat().st_size > 0


@pytest.mark.parametrize("kwargs, match", [
    (dict(at=2.0), r"at = 2 s must lie in \(0, t_end = 1 s\]"),
    (dict(methods=["rk45"]), "unknown method 'rk45'"),
    (dict(names=["j0.omega"]), "no reference value for 'j0.omega'"),
    (dict(repeat=0), "repeat"),
    (dict(tolerances=[]), "tolerances"),
    (dict(tolerances=1e-6), "tolerances"),
    (dict(tolerances=[-1e-6]), "tolerances"),
    (dict(steps=[2.7]), "steps"),
    (dict(methods=[]), "at least one method"),
])
def test_bad_arguments_are_refused_by_name(kwargs, match):
    with pytest.raises(mn.MechnetError, match=match):
        accuracy.study(chain(2).compile(), 1.0, **kwargs)


@pytest.mark.slow
@pytest.mark.parametrize("scene", sorted(p.stem for p in EXAMPLES.glob("*.py")))
def test_the_command_line_finishes_on_every_example(scene, tmp_path, capsys):
    """`mechnet accuracy` on each example scene (over min(t_end, 1 s), three tolerances, every method that
    applies) finishes and writes its plot; with reference(t) it reports against it."""
    status = main(["accuracy", str(EXAMPLES / f"{scene}.py"), "--t-end", "1.0", "--tolerances", "1e-4", "1e-6",
                   "1e-8", "-o", str(tmp_path)])
    assert status == 0
    assert list(tmp_path.glob("*_accuracy.png"))
    source = (EXAMPLES / f"{scene}.py").read_text()
    if "def reference(" in source:          # against it, or told why not (a closed form ending earlier)
        out = capsys.readouterr().out
        assert "against the scene's reference(t)" in out or "reference(t) gives no value" in out


def test_a_diverging_fixed_step_says_so_in_its_note_and_prints_nothing(capfd):
    """A stiff oscillator (J = 1e-3 kg m², c = 1e5 N m/rad: 1e4 rad/s) under RK4 with 100 steps over 1 s
    (h·ω = 100) overflows: CasADi prints "NaN detected" / "Inf detected" many times, and a collocation
    whose Newton solve fails dumps its step function's inputs. All of it lands in the rows' notes."""
    from models import oscillator
    result = accuracy.study(oscillator(J=0.001, c=1e5).compile(), 1.0, methods=["rk", "collocation"],
                            tolerances=(1e-4,), steps=(100, 1000), repeat=2)
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    rk = {t.setting: t for t in result.trials if t.method == "rk"}
    assert rk[100].status == "failed" and "diverged" in rk[100].reason
    assert "NaN detected" in rk[100].output and "suppressed" in rk[100].output
    assert "NaN detected" in result.to_markdown()


def test_timings_are_taken_round_robin_and_a_tie_is_decided_on_counted_work():
    calls = []
    rows = [accuracy.Trial("rk", n, error=1e-7, time=1.0, evaluations=4 * n) for n in (100, 300)]
    for t in rows:
        t.timer = (lambda t: lambda: calls.append(t.setting) or 1e-3 * t.setting)(t)
    accuracy._time_rounds(rows, 3)
    assert calls == [100, 300] * 3
    assert rows[0].times == [0.1] * 3 and rows[0].time == 0.1 and rows[0].timer is None

    def trial(method, best, median, evaluations):
        return accuracy.Trial(method, 1e-6, error=1e-7, time=best, times=[best, median, median],
                              evaluations=evaluations)
    # ranges 1.0-1.3 ms and 1.2-1.5 ms overlap: a tie, the one with fewer evaluations wins
    fast, lean = trial("cvodes-adams", 1.0e-3, 1.3e-3, 900), trial("cvodes-bdf", 1.2e-3, 1.5e-3, 300)
    study = accuracy.AccuracyStudy("s", 1.0, ("x",), [fast, lean], "reference(t)", 0.0)
    assert study.recommend(1e-6) is lean
    # 1.0-1.1 ms against 1.7-1.8 ms: no tie, the faster wins whatever it counts
    slow = trial("cvodes-bdf", 1.7e-3, 1.8e-3, 300)
    quick = trial("cvodes-adams", 1.0e-3, 1.1e-3, 900)
    assert accuracy.AccuracyStudy("s", 1.0, ("x",), [quick, slow], "reference(t)", 0.0).recommend(1e-6) is quick
    table = study.to_markdown()
    assert "| 1 / 1.3 |" in table and "median of 3 repeats" in table
    with pytest.raises(mn.MechnetError, match="recommend"):
        study.recommend(float("nan"))


def test_a_scene_reference_that_raises_is_named(tmp_path):
    def reference(t):
        raise ValueError("boom")
    with pytest.raises(mn.MechnetError, match=r"reference\(t\) failed .*ValueError: boom"):
        accuracy.study(chain(2).compile(), 0.2, methods=["cvodes-adams"], tolerances=(1e-4,), reference=reference)


@pytest.mark.parametrize("args, match", [
    (["--target", "nan"], "--target nan"),
    (["--target", "-1"], "--target -1"),
    (["-o", "FILE"], "is a file"),
])
def test_the_command_line_refuses_before_the_study(args, match, tmp_path, capsys):
    (tmp_path / "FILE").write_text("x")
    args = [str(tmp_path / a) if a == "FILE" else a for a in args]
    assert main(["accuracy", str(EXAMPLES / "double_pendulum.py"), *args]) != 0
    assert match in capsys.readouterr().err
    assert not list(tmp_path.glob("*_accuracy*"))


def test_a_study_on_worker_processes_times_its_rows_round_robin():
    """workers=2 with repeat=2: the rows' settings go back to the workers for each timed round (a Case
    object was refused by the sweep); each native row gets its two times and the same error as in-process
    (the same runs: rtol 1e-4 and 1e-6 on the two-body chain at t = 0.2 s, agreeing to 1e-12)."""
    cm = chain(2).compile()
    kwargs = dict(methods=["cvodes-bdf"], tolerances=(1e-4, 1e-6))
    parallel = accuracy.study(cm, 0.2, workers=2, repeat=2, **kwargs)
    local = accuracy.study(cm, 0.2, workers=0, repeat=1, **kwargs)
    rows = [t for t in parallel.trials if t.method == "cvodes-bdf"]
    assert len(rows) == 2 and all(len(t.times) == 2 and t.status == "ok" for t in rows)
    for a, b in zip(rows, [t for t in local.trials if t.method == "cvodes-bdf"]):
        assert a.error == pytest.approx(b.error, rel=1e-12, abs=1e-15)


def test_quiet_blocks_in_two_threads_leave_the_descriptors_as_they_were(capfd):
    """Two threads in `_quiet` at once take turns: afterwards what the process writes to its descriptors
    1 and 2 reaches them again (overlapping, the blocks restored each other's copies and silenced it)."""
    import os
    import threading
    import time

    def quiet():
        with accuracy._quiet():
            os.write(1, b"swallowed\n")
            time.sleep(0.05)
    threads = [threading.Thread(target=quiet) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    os.write(1, b"out again\n")
    os.write(2, b"err again\n")
    captured = capfd.readouterr()
    assert "out again" in captured.out and "err again" in captured.err and "swallowed" not in captured.out
