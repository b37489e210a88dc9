"""The `mechnet` command: version, simulate, demo, and one-line errors with status 2."""
from pathlib import Path

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
    assert main(["demo", "--examples", str(examples), "--out", str(out)]) == 1
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
    assert lines[0].startswith("# units: s,") and lines[1].startswith("time,")
    assert "motor.w" in lines[1].split(",")
