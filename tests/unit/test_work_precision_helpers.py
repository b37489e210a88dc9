"""The benchmarks' reading of a work-precision line: the time to reach an error (benchmarks/rotation.py)."""
import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
rotation = pytest.importorskip("rotation")


def test_time_to_an_error_interpolates_extrapolates_and_refuses_too_few_points():
    # errors falling tenfold per doubled time: 1e-4 is reached at 2^(1/2) s on the log-log line
    t, mark = rotation.time_to([(1.0, 1e-3), (2.0, 1e-5)], 1e-4)
    assert mark == "" and t == pytest.approx(2 ** 0.5, rel=1e-12)
    assert rotation.time_to([(1.0, 1e-3), (2.0, 1e-5)], 1e-2) == (1.0, "<=")
    t, mark = rotation.time_to([(1.0, 1e-3), (2.0, 1e-5)], 2e-6)        # fivefold past: extrapolated
    assert mark == "~" and t == pytest.approx(2 * 2 ** (math.log(0.2) / math.log(0.01)), rel=1e-12)
    assert rotation.time_to([(1.0, 1e-3), (2.0, 1e-5)], 1e-7) == (None, "-")     # a hundredfold: too far
    assert rotation.time_to([(1.0, 1e-3)], 1e-6) == (None, "-")          # one point: no line to follow
    assert rotation.time_to([], 1e-6) == (None, "-")
