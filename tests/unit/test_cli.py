"""The `mechnet` command: version, simulate, demo, and one-line errors with status 2."""
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mechnet.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
OSCILLATOR = EXAMPLES / "two_inertia_oscillator.py"


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == "mechnet 0.1.0"


def test_no_command_prints_help_and_fails(capsys):
    assert main([]) == 2
    assert "usage: mechnet" in capsys.readouterr().out


def test_simulate_example(capsys):
    assert main(["simulate", str(OSCILLATOR), "--t-end", "0.1"]) == 0
    out = capsys.readouterr().out
    assert "j1.phi" in out


def test_simulate_writes_plot(tmp_path):
    png = tmp_path / "oscillator.png"
    assert main(["simulate", str(OSCILLATOR), "--t-end", "0.1", "--method", "idas", "--plot", str(png)]) == 0
    assert png.stat().st_size > 0


def test_scene_without_build_is_a_one_line_error(tmp_path, capsys):
    scene = tmp_path / "no_build_here.py"
    scene.write_text("t_end = 1.0\n")
    assert main(["simulate", str(scene)]) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("error:")
    assert "no_build_here.py" in lines[0]
    assert "Traceback" not in err


def test_missing_scene_file_is_an_error(tmp_path, capsys):
    assert main(["simulate", str(tmp_path / "absent.py")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and "absent.py" in err


def test_demo_only_one_scene(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--only", "two_inertia_oscillator"]) == 0
    assert (tmp_path / "two_inertia_oscillator.png").stat().st_size > 0
    out = capsys.readouterr().out
    assert "two_inertia_oscillator" in out
    assert "reference" in out


def test_demo_unknown_scene_lists_the_available_ones(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--only", "no_such_scene"]) == 2
    err = capsys.readouterr().err
    assert "no_such_scene" in err and "two_inertia_oscillator" in err


def test_demo_reports_a_failing_scene_and_goes_on(tmp_path, capsys):
    examples = tmp_path / "examples"
    examples.mkdir()
    (examples / "a_bad.py").write_text("def build():\n    return None\n")
    (examples / "b_good.py").write_text(OSCILLATOR.read_text())
    out = tmp_path / "out"
    assert main(["demo", "--dir", str(examples), "--out", str(out)]) == 1
    captured = capsys.readouterr()
    assert "a_bad" in captured.err
    assert (out / "b_good.png").exists()


@pytest.mark.parametrize("method", ["--rtol", "--atol", "--t-end", "--n-out"])
def test_bad_numbers_are_usage_errors(method):
    with pytest.raises(SystemExit) as info:
        main(["simulate", str(OSCILLATOR), method, "not-a-number"])
    assert info.value.code == 2


def test_simulate_writes_csv_and_lists_time_events(tmp_path, capsys):
    out = tmp_path / "drive.csv"
    assert main(["simulate", str(EXAMPLES / "drive_line.py"), "--t-end", "1.0", "--csv", str(out)]) == 0
    text = capsys.readouterr().out
    assert "event at t = 0.5 s (time)" in text
    lines = out.read_text().splitlines()
    assert lines[0].startswith("time [s],")                   # units in the header: read_csv takes it as is
    assert "motor.w [rad/s]" in lines[0].split(",")


# --- issue 16, the command line: one `error: <file>:<line>: ...` line, status 2, traceback only with --debug

OSCILLATOR_SCENE = """\
import mechnet as mn
from mechnet.components import rotational as rot

t_end = 2.0
plot = ["j.phi"]
C, J = 4.0, 0.25


def build():
    m = mn.Model("oscillator")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=C))
    j = m.add(rot.Inertia(name="j", J=J, phi_start=0.5, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    return m
"""


def scene_file(tmp_path, body, name="scene.py"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return path


def one_error_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("error:")
    assert "Traceback" not in captured.err + captured.out
    return lines[0]


@pytest.mark.parametrize("body, line, cause", [
    ("def build():\n    x = 1\n    raise RuntimeError('no model today')\n", 3, "RuntimeError: no model today"),
    ("\n\ndef build(n):\n    return None\n", 3, "missing 1 required positional argument"),
    ("import sys\n\ndef build():\n    sys.exit(3)\n", 4, "sys.exit(3)"),
    ("import mechnet as mn\nfrom mechnet.components import multibody as mb\n\ndef build():\n"
     "    m = mn.Model('typo')\n    m.add(mb.Revolue(name='joint'))\n    return m\n", 6, "Revolue"),
], ids=["raises", "needs-an-argument", "sys-exit", "attribute-typo"])
def test_a_failing_build_is_one_error_line_with_file_and_line(tmp_path, capsys, body, line, cause):
    path = scene_file(tmp_path, body)
    assert main(["simulate", str(path)]) == 2
    error = one_error_line(capsys)
    assert f"{path}:{line}:" in error and cause in error


def test_debug_keeps_the_traceback(tmp_path, capsys):
    path = scene_file(tmp_path, "def build():\n    raise RuntimeError('boom')\n")
    assert main(["simulate", str(path), "--debug"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}:2:")
    assert "Traceback" in err and "RuntimeError: boom" in err


@pytest.mark.parametrize("option, target", [
    ("--csv", lambda tmp: tmp),                                 # a directory
    ("--plot", lambda tmp: tmp),
    ("--csv", lambda tmp: tmp / "a_file.txt" / "out.csv"),     # under a file: cannot be written
    ("--plot", lambda tmp: tmp / "out.notaformat"),
])
def test_output_paths_are_refused_before_the_run(tmp_path, capsys, option, target):
    (tmp_path / "a_file.txt").write_text("")
    path = target(tmp_path)
    assert main(["simulate", str(OSCILLATOR), option, str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""                     # refused before compiling, let alone simulating
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {option}") and str(path) in lines[0]


def test_a_missing_output_folder_is_made(tmp_path, capsys):
    # as before issue 16 (and as demo --out does): --csv into a new folder writes the oscillator's run there
    csv = tmp_path / "new" / "deeper" / "out.csv"
    assert main(["simulate", str(OSCILLATOR), "--csv", str(csv)]) == 0
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert data.shape[0] > 10 and data[0, 0] == 0.0


def test_a_directory_as_the_scene_file(tmp_path, capsys):
    assert main(["simulate", str(tmp_path)]) == 2
    error = one_error_line(capsys)
    assert str(tmp_path) in error and "is a directory" in error


@pytest.mark.parametrize("with_plot", [False, True])
def test_a_typo_in_plot_names_is_reported_with_or_without_plot(tmp_path, capsys, with_plot):
    path = scene_file(tmp_path, OSCILLATOR_SCENE.replace('plot = ["j.phi"]', 'plot = ["j.phi", "j.phy"]'))
    png = tmp_path / "out.png"
    assert main(["simulate", str(path)] + (["--plot", str(png)] if with_plot else [])) == 2
    error = one_error_line(capsys)
    assert f"{path}:5:" in error and "'j.phy'" in error and "j.phi" in error
    assert not png.exists()


def test_a_typo_in_plot_names_is_reported_before_the_summary(tmp_path, capsys):
    """The error is the only output: no model summary printed before it (issue 32, item 7)."""
    path = scene_file(tmp_path, OSCILLATOR_SCENE.replace('plot = ["j.phi"]', 'plot = ["j.phy"]'))
    assert main(["simulate", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "'j.phy'" in captured.err


def test_simulate_overlays_the_reference_and_prints_its_error(tmp_path, capsys, monkeypatch):
    """reference(t) = 0.5 cos(sqrt(c/J) t) is the exact solution: the printed error is the solver's alone."""
    path = scene_file(tmp_path, OSCILLATOR_SCENE + textwrap.dedent("""
        def reference(t):
            import numpy as np
            return {"j.phi": 0.5 * np.cos(np.sqrt(C / J) * t)}
    """))
    import matplotlib.figure
    labels, titles = [], []
    save = matplotlib.figure.Figure.savefig

    def spy(fig, *args, **kwargs):
        labels.extend(line.get_label() for line in fig.axes[0].lines)
        titles.append((fig.get_suptitle(), [a.get_ylabel() for a in fig.axes]))
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    png = tmp_path / "out.png"
    assert main(["simulate", str(path), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    errors = re.findall(r"max \|j\.phi - reference\| = (\S+)", out)
    assert len(errors) == 1 and float(errors[0]) < 1e-4, out
    assert png.stat().st_size > 0
    assert labels == ["j.phi", "j.phi reference"]              # the scene's `plot` names, each overlaid
    assert titles == [("scene", ["rad"])]                       # drawn by res.plot: titled with the scene


def test_demo_runs_the_package_examples_whatever_the_current_folder(tmp_path, capsys, monkeypatch):
    (tmp_path / "examples").mkdir()
    (tmp_path / "examples" / "two_inertia_oscillator.py").write_text("raise RuntimeError('not mine')\n")
    monkeypatch.chdir(tmp_path)
    assert main(["demo", "--out", str(tmp_path / "out"), "--only", "two_inertia_oscillator"]) == 0
    assert "not mine" not in capsys.readouterr().err


def test_demo_dir_runs_other_scene_files(tmp_path, capsys):
    scene_file(tmp_path, OSCILLATOR_SCENE, name="my_oscillator.py")
    assert main(["demo", "--dir", str(tmp_path), "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "my_oscillator.png").stat().st_size > 0
    assert "1 of 1 scenes" in capsys.readouterr().out


def test_demo_without_a_checkout_runs_no_stranger_s_examples(tmp_path, capsys, monkeypatch):
    """Installed from a wheel there are no examples: a folder near site-packages is not mechnet's."""
    import mechnet.cli

    site = tmp_path / "lib" / "python3" / "site-packages" / "mechnet"
    site.mkdir(parents=True)
    (tmp_path / "lib" / "python3" / "examples").mkdir()
    (tmp_path / "lib" / "python3" / "examples" / "stranger.py").write_text("raise RuntimeError('not mine')\n")
    monkeypatch.setattr(mechnet.cli, "__file__", str(site / "cli.py"))
    assert main(["demo", "--out", str(tmp_path / "out")]) == 2
    error = one_error_line(capsys)
    assert "--dir" in error and "stranger" not in error and "not mine" not in error


def test_export_casadi_then_load_and_simulate(tmp_path, capsys):
    """`mechnet export` writes a loadable model: the loaded copy simulates to the scene's own result (the
    oscillator, 0.5 s, default tolerances: identical functions give identical numbers)."""
    from mechnet.export import load
    from mechnet.scene import load_scene
    out = tmp_path / "osc"
    assert main(["export", str(OSCILLATOR), "--kind", "casadi", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith(f"wrote {out}") and "states" in text
    loaded = load(out).simulate(0.5)
    native = load_scene(OSCILLATOR).build().compile().simulate(0.5)
    assert np.array_equal(loaded["j1.phi"], native["j1.phi"])


def test_export_all_parameters_exposes_the_folded_ones(tmp_path, capsys):
    import json
    plain, every = tmp_path / "plain", tmp_path / "every"
    assert main(["export", str(OSCILLATOR), "--kind", "casadi", "-o", str(plain)]) == 0
    assert "folded into the equations" in capsys.readouterr().out
    assert main(["export", str(OSCILLATOR), "--kind", "casadi", "--all-parameters", "-o", str(every)]) == 0
    few, many = (len(json.loads((path / "model.json").read_text())["p"]) for path in (plain, every))
    assert many > few


def test_export_refuses_an_existing_output_unless_overwrite(tmp_path, capsys):
    out = tmp_path / "taken"
    out.mkdir()
    assert main(["export", str(OSCILLATOR), "--kind", "casadi", "-o", str(out)]) == 2
    err = one_error_line(capsys)
    assert "taken" in err and "overwrite" in err
    assert main(["export", str(OSCILLATOR), "--kind", "casadi", "--overwrite", "-o", str(out)]) == 0


@pytest.mark.parametrize("args", [["--kind", "zip"], ["--fmi", "4"], []])
def test_export_bad_options_are_usage_errors(tmp_path, args):
    """An unknown kind or FMI version, or no -o, is argparse's usage error (status 2)."""
    with pytest.raises(SystemExit) as exit_:
        main(["export", str(OSCILLATOR), *args] + (["-o", str(tmp_path / "x")] if args else []))
    assert exit_.value.code == 2
