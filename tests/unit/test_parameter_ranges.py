"""Moving an optimiser's parameters onto their checks' ranges and requirements (ocp/solution.py,
core/requirements.py): only breaks within IPOPT's tolerance (1e-6 relative, absolute below 1) are moved,
a strict bound lands 1e-12 inside, and nothing leaves another range."""
from __future__ import annotations

import math

import pytest

from mechnet.core.declarations import nonnegative, positive, value_range_text
from mechnet.core.requirements import onto_requirements
from mechnet.components.switched import restitution
from mechnet.ocp.solution import _into


@pytest.mark.parametrize("value, expected", [
    (-5e-7, 1e-12), (0.0, 1e-12), (0.3, 0.3), (-2e-6, -2e-6),   # a strict lower bound of 0 (a mass)
])
def test_a_strict_bound_is_met_one_step_inside(value, expected):
    assert _into(value, *positive.value_range) == expected


@pytest.mark.parametrize("value, expected", [(-7.5e-9, 0.0), (1.0 + 5e-7, 1.0), (1.1, 1.1)])
def test_a_closed_range_is_met_on_its_bound(value, expected):
    assert _into(value, *restitution.value_range) == expected


MU = {"owner": "fr (Friction)", "lhs": "fr.mu_s", "rhs": "fr.mu_k", "lhs_value": None, "rhs_value": None,
      "op": ">=", "why": "a surface holds at least what it resists sliding with"}
LIMITS = {**MU, "lhs": "stop.s_max", "rhs": "stop.s_min", "op": ">"}


def test_a_requirement_broken_by_round_off_is_met_and_a_real_break_is_left():
    moved = onto_requirements([MU], {"fr.mu_s": 0.2 - 7.5e-9, "fr.mu_k": 0.2}, {"fr.mu_s"})
    assert moved["fr.mu_s"] == 0.2
    kept = onto_requirements([MU], {"fr.mu_s": 0.1, "fr.mu_k": 0.2}, {"fr.mu_s"})
    assert kept["fr.mu_s"] == 0.1
    strict = onto_requirements([LIMITS], {"stop.s_max": 0.05, "stop.s_min": 0.05}, {"stop.s_min"})
    assert strict["stop.s_min"] == math.nextafter(0.05, -math.inf)


def test_each_range_is_said_in_its_checks_own_words():
    """The FMU logs these (its tables read the check's value_range)."""
    assert [value_range_text(c) for c in (positive, nonnegative, restitution)] == \
        ["must be > 0", "must be >= 0", "must lie in [0, 1] (0 plastic, 1 elastic)"]
