"""The fuzz suite as tests (issue 32): A + OK >= 97 % and no D (raw CasADi/SUNDIALS), E (NaN or a wrong
answer) or F (hang, crash). The full run is slow-marked; by default a fixed sample of every 10th case.
`python tests/fuzz/runner.py` prints the table by area and class."""
from __future__ import annotations

import pytest

from fuzz import fixtures, runner


@pytest.fixture(scope="module", autouse=True)
def _shared_files():
    """The shared exports the cases load are removed after the module."""
    yield
    import shutil
    shutil.rmtree(fixtures.root(), ignore_errors=True)


def _check(records) -> None:
    problems = runner.verdict(records)
    assert not problems, (f"{len(problems)} problem(s):\n" + "\n".join(problems) + "\n\n" + runner.table(records)
                          + "\n\n" + runner.findings(records))


def test_a_sample_of_the_fuzz_cases():
    """Every 10th case (slow ones left out): well under a minute on 2 cores."""
    _check(runner.run(runner.select(runner.all_cases(), every=10, include_slow=False), jobs=2))


@pytest.mark.slow
def test_every_fuzz_case():
    cases = runner.all_cases()
    assert len(cases) >= 600
    _check(runner.run(cases, jobs=2))
