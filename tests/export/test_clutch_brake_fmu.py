"""examples/clutch_brake.py as an FMU, run as importers run it (issue 31, item 2: the open brake and the
rows at events, in the FMU too): FMPy's CVode at rtol 1e-4 and 1e-6 and its fixed-step Euler (1 ms),
and fmusim's CVode at 1e-6, all with outputs every 0.01 s over 3 s, through four mode changes mid-run
(clutch slides at 0.5 s, sticks at 0.75 s; brake slides at 2.0 s, sticks at 2.2 s).

The speeds are piecewise linear in time, so every integrator follows them exactly between events:
against cm.simulate at rtol 1e-10, within 1e-6 rad/s at outputs more than 0.02 s from an event
(measured 6e-12 in all four runs); brake.tau exactly 0 before 1.99 s (the brake is not pressed)."""
from __future__ import annotations

import csv
import subprocess
from pathlib import Path

import numpy as np
import pytest

from mechnet.export import compiler
from mechnet.export.model_description import fmi_name
from mechnet.scene import load_scene

fmpy = pytest.importorskip("fmpy", reason="fmpy (extra 'test') runs FMUs")
pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler ($CC, cc, gcc or clang) to build FMUs")
ROOT = Path(__file__).resolve().parents[2]
FMUSIM = ROOT.parent / "shared" / "tools" / "fmusim"
NAMES = ["motor.w", "load.w", "brake.tau", "clutch.tau"]
EVENTS = np.array([0.5, 0.75, 2.0, 2.2])


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    cm = load_scene(ROOT / "examples" / "clutch_brake.py").build().compile()
    reference = cm.simulate(3.0, t_out=np.linspace(0.0, 3.0, 301), rtol=1e-10, atol=1e-12)
    return cm.export(tmp_path_factory.mktemp("cb") / "clutch_brake.fmu", kind="fmu"), reference


def _check(t, values, reference):
    away = np.min(np.abs(t[:, None] - EVENTS[None]), axis=1) > 0.02
    for name, y in values.items():
        assert np.max(np.abs(y - np.interp(t, reference.t, reference[name]))[away]) < 1e-6, name
    assert np.all(values["brake.tau"][t < 1.99] == 0.0)
    assert np.interp(1.0, t, values["load.w"]) == pytest.approx(2.5, abs=1e-6)   # clutch stuck
    assert np.interp(2.5, t, values["load.w"]) == pytest.approx(0.0, abs=1e-6)   # brake holding


@pytest.mark.parametrize("solver, settings", [("CVode", dict(relative_tolerance=1e-4)),
                                              ("CVode", dict(relative_tolerance=1e-6)),
                                              ("Euler", dict(step_size=1e-3))])
def test_the_clutch_brake_fmu_in_fmpy(exported, solver, settings):
    path, reference = exported
    res = fmpy.simulate_fmu(str(path), stop_time=3.0, output_interval=0.01, solver=solver,
                            output=[fmi_name(n) for n in NAMES], fmi_type="ModelExchange", **settings)
    _check(res["time"], {n: res[fmi_name(n)] for n in NAMES}, reference)


@pytest.mark.skipif(not FMUSIM.exists(), reason=f"no second importer at {FMUSIM}")
def test_the_clutch_brake_fmu_in_fmusim(exported, tmp_path):
    path, reference = exported
    out = tmp_path / "cb.csv"
    variables = [arg for n in NAMES for arg in ("--output-variable", fmi_name(n))]
    subprocess.run([str(FMUSIM), "--interface-type", "me", "--solver", "cvode", "--tolerance", "1e-6",
                    "--output-interval", "0.01", "--stop-time", "3", "--output-file", str(out), *variables,
                    str(path)], check=True, capture_output=True)
    rows = list(csv.reader(out.open()))
    data = np.array(rows[1:], dtype=float)
    _check(data[:, 0], {n: data[:, rows[0].index(fmi_name(n))] for n in NAMES}, reference)
