"""Results for analysis: the CSV's units in its header (read by pandas and numpy as is), to_pandas, events."""
from __future__ import annotations

import sys

import numpy as np
import pytest

from mechnet.core.errors import MechnetError, UnknownNameError
from models import oscillator

NAMES = ["j1.phi", "spring.tau", "j1.w"]


@pytest.fixture(scope="module")
def res():
    return oscillator(d=0.1).compile().simulate(0.3, n_out=31)


def test_the_csv_header_carries_the_units(res, tmp_path):
    path = tmp_path / "out.csv"
    res.to_csv(path, NAMES)
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0] == "time [s],j1.phi [rad],spring.tau [N*m],j1.w [rad/s]"
    assert len(lines) == 1 + len(res.t) and not any(line.startswith("#") for line in lines)


def test_pandas_reads_the_csv_as_it_is(res, tmp_path):
    pd = pytest.importorskip("pandas")
    path = tmp_path / "out.csv"
    res.to_csv(path, NAMES)
    frame = pd.read_csv(path)
    assert list(frame.columns) == ["time [s]", "j1.phi [rad]", "spring.tau [N*m]", "j1.w [rad/s]"]
    assert np.array_equal(frame["time [s]"].to_numpy(), res.t)                 # bit for bit (%.17g)
    for name, column in zip(NAMES, frame.columns[1:]):
        assert np.array_equal(frame[column].to_numpy(), res[name]), name


def test_numpy_reads_the_csv_skipping_its_header(res, tmp_path):
    path = tmp_path / "out.csv"
    res.to_csv(path)                                            # every name
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert data.shape == (len(res.t), 1 + len(res.names))
    assert np.array_equal(data[:, 0], res.t) and np.array_equal(data[:, 1:], res.values)
    header = path.read_text(encoding="utf-8").splitlines()[0].split(",")
    assert [h.rsplit(" [", 1)[0] for h in header] == ["time"] + list(res.names)
    assert [h.rsplit(" [", 1)[1].rstrip("]") for h in header] == ["s"] + [res.units[n] for n in res.names]


def test_to_pandas_is_indexed_by_time_with_units_in_attrs(res):
    pytest.importorskip("pandas")
    frame = res.to_pandas(NAMES)
    assert frame.index.name == "time" and np.array_equal(frame.index.to_numpy(), res.t)
    assert list(frame.columns) == NAMES
    for name in NAMES:
        assert np.array_equal(frame[name].to_numpy(), res[name]), name
    assert frame.attrs["units"] == {"time": "s", "j1.phi": "rad", "spring.tau": "N*m", "j1.w": "rad/s"}
    assert list(res.to_pandas().columns) == list(res.names)            # default: every name
    assert list(res.to_pandas("j1.w").columns) == ["j1.w"]             # one name is one name


def test_to_pandas_refuses_an_unknown_name(res):
    pytest.importorskip("pandas")
    with pytest.raises(UnknownNameError, match="'j1.phy'.*did you mean j1.phi"):
        res.to_pandas(["j1.phy"])


def test_to_pandas_without_pandas_says_how_to_install_it(res, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)                 # `import pandas` now fails
    with pytest.raises(MechnetError, match=r'to_pandas\(\) needs pandas.*pip install "mechnet\[pandas\]"'):
        res.to_pandas()
