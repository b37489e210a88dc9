"""The README's Python blocks run verbatim, in order, in one namespace, as a reader would paste them."""
from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest

README = Path(__file__).resolve().parents[2] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_the_readme_has_python_blocks():
    assert len(python_blocks()) >= 3


def test_the_readme_blocks_run_in_order(tmp_path, monkeypatch):
    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)                      # the blocks write out.csv
    namespace: dict = {"__name__": "readme"}
    for k, block in enumerate(python_blocks(), 1):
        try:
            exec(compile(block, f"README.md python block {k}", "exec"), namespace)
        except Exception as exc:                     # noqa: BLE001 - named with the block
            pytest.fail(f"README python block {k} raised {type(exc).__name__}: {exc}")
    # what the blocks claim: the hold table's knots (and the Step) are time events, the CSV carries units
    # in its header, a continued run starts where the last ended
    held = namespace["held"]
    assert sorted({e.t for e in held.events if e.kind == "time"}) == [1.0, 2.0, 3.0]
    assert (tmp_path / "out.csv").read_text().startswith("time [s],")
    assert namespace["more"].t[0] == 5.0
    assert namespace["again"]["j1.phi"].tolist() == held["j1.phi"].tolist()     # the export: same numbers
    assert list(namespace["df"].columns) == list(namespace["cm"].simulate(0.1).names)
    # the optimal-control block: minimum time over 1 m with |u| <= 1 takes 2·sqrt(1) = 2 s
    assert namespace["sol"].success and abs(namespace["sol"].t_final - 2.0) < 1e-6
