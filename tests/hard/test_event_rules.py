"""The event rules of `mechnet.core.events`, case by case, and the simulator's array form of them.

Each case is a condition's values (g, ġ, g̈) at a time and the side or crossing the rules give: a ball
landing exactly on the floor, leaving it, resting on it; friction breaking away exactly at its limit; a
condition 0 at the start. The simulator's `_sides`/`_allowed` (numpy, on arrays) must give the same
answers as the scalar rules; the FMU wrapper's C is held to them through the exported scenes
(tests/export: the bouncing ball at importer settings, the clutch and brake, the cascade)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mechnet.core import events as ev
from mechnet.simulate.state_events import StateEvents, _allowed

#  name, (g, ġ, g̈), t, expected (side, on, by_rate)
SIDES = [
    ("ball above the floor, falling", (0.5, -3.0, -9.81), 0.2, (1, False, True)),
    ("ball landed exactly on the floor, falling", (0.0, -4.43, -9.81), 0.45, (-1, True, True)),
    ("ball thrown back up from the floor", (0.0, 3.54, -9.81), 0.45, (1, True, True)),
    ("ball resting on the floor, pulled into it", (0.0, 0.0, -9.81), 4.1, (-1, True, False)),
    ("ball resting, nothing pulling (rest mode)", (0.0, 0.0, 0.0), 4.1, (0, True, False)),
    ("a round-off below the floor, moving up: its rate decides", (-1e-16, 1.0, -9.81), 1.0, (1, True, True)),
    ("friction force exactly at its limit, rising", (0.0, 2.0, 0.0), 0.3, (1, True, True)),
    ("friction force at its limit, still, pushed on by g̈", (0.0, 0.0, 5.0), 0.3, (1, True, False)),
    ("a condition 0 at the start, not moving", (0.0, 0.0, 0.0), 0.0, (0, True, False)),
    ("below, well away from the boundary", (-0.1, 5.0, 0.0), 1e3, (-1, False, True)),
]

#  name, direction, armed side, side now, crosses?
CROSSINGS = [
    ("falling through the floor", ev.FALLING, 1, -1, True),
    ("falling onto the boundary and resting there", ev.FALLING, 1, 0, True),
    ("rising across a falling condition", ev.FALLING, -1, 1, False),
    ("rising through its limit", ev.RISING, -1, 1, True),
    ("both ways, falling", ev.BOTH, 1, -1, True),
    ("both ways, rising", ev.BOTH, -1, 1, True),
    ("leaving a rest into its direction (a force stepping on)", ev.RISING, 0, 1, True),
    ("leaving a rest against its direction (a ball thrown up)", ev.FALLING, 0, 1, False),
    ("a 'both' condition leaving 0 has not changed sign", ev.BOTH, 0, 1, False),
    ("staying on its side", ev.FALLING, 1, 1, False),
]


@pytest.mark.parametrize("name, rates, t, expected", SIDES, ids=[c[0] for c in SIDES])
def test_side_of_a_condition(name, rates, t, expected):
    assert ev.side(*rates, t) == expected


@pytest.mark.parametrize("name, rates, t, expected", SIDES, ids=[c[0] for c in SIDES])
def test_the_simulators_sides_follow_the_rules(name, rates, t, expected):
    """StateEvents._sides on arrays gives the scalar rule's side, boundary and rate flags."""
    sides, on, by_rate = StateEvents._sides(StateEvents(), t, tuple(np.array([v]) for v in rates))
    assert (int(sides[0]), bool(on[0]), bool(by_rate[0])) == expected


@pytest.mark.parametrize("name, direction, before, after, expected", CROSSINGS, ids=[c[0] for c in CROSSINGS])
def test_crossings(name, direction, before, after, expected):
    assert ev.crosses(direction, before, after) is expected
    simulator = _allowed(np.array([direction]), np.array([float(before)]), np.array([float(after)]))
    assert bool(simulator[0]) is expected


def test_coming_to_rest_on_the_boundary_does_not_fire():
    """Judged by sides: a contact left touching at rest by an impact (side 0) does not strike again; one
    landing on it at speed does (side −1, falling)."""
    assert not ev.fires(ev.FALLING, 1, ev.side(0.0, 0.0, 0.0, 0.25)[0])
    assert ev.fires(ev.FALLING, 1, ev.side(0.0, -2.49, 0.0, 0.25)[0])
    assert not ev.fires(ev.RISING, -1, 0)


def test_a_reset_that_leaves_a_ball_held_into_the_floor_fires_again():
    """v → −e·0 leaves the ball on the floor with ġ = 0 and g̈ = −g: it crosses again (an accumulation its
    rest ends); thrown back up with speed it has left; a sensor going on across has completed its crossing."""
    assert ev.fires_again(ev.FALLING, ev.side(0.0, 0.0, -9.81, 4.0))
    assert not ev.fires_again(ev.FALLING, ev.side(0.0, 1.0, -9.81, 4.0))
    assert not ev.fires_again(ev.FALLING, ev.side(0.0, -1.0, 0.0, 4.0))


def test_accumulation_of_a_bouncing_ball():
    """Impacts of a ball dropped from 1 m with e = 0.8 (closed form: t1 = √(2/g), gaps 2·e^k·v1/g) predict
    T∞ = t1·(1 + e)/(1 − e) to round-off (rtol 1e-12); gaps that do not shrink predict nothing."""
    g, e = 9.81, 0.8
    t1, v1 = math.sqrt(2 / g), math.sqrt(2 * g)
    times = [t1]
    for k in range(1, 6):
        times.append(times[-1] + 2 * e ** k * v1 / g)
    assert ev.accumulation_time(times) == pytest.approx(t1 * (1 + e) / (1 - e), rel=1e-12)
    assert ev.accumulation_time([0.0, 1.0, 2.0, 3.0]) is None
    assert ev.accumulation_time(times[:3]) is None
    remaining = ev.accumulation_time(times) - times[-1]
    assert ev.rests(times, 1.01 * remaining) and not ev.rests(times, 0.99 * remaining)


def test_flight_time_of_a_rebound():
    """Thrown up at 1 m/s under g = 9.81 m/s²: back after 2/9.81 s; pushed on by g̈: never."""
    assert ev.flight_time(1.0, -9.81) == pytest.approx(2 / 9.81, rel=1e-15)
    assert ev.flight_time(1.0, 9.81) == math.inf and ev.flight_time(0.0, -9.81) == math.inf


def test_a_rebound_euler_cannot_let_decay_rests():
    """Euler at h = 1 ms keeps a ball (e = 0.8) bouncing at 0.198 → 0.158 m/s (measured in FMPy: the
    impact takes 0.04 m/s, what the step adds back over a 32-step flight): it rests. The first impact from
    1 m (4.43 → 3.54 m/s) does not, nor a rebound whose flight lasts hundreds of steps."""
    assert ev.rests_under_fixed_steps(-0.198, 0.158, -9.81, 1e-3)
    assert not ev.rests_under_fixed_steps(-4.43, 3.54, -9.81, 1e-3)
    assert not ev.rests_under_fixed_steps(-0.2, 0.19, -9.81, 1e-4)
    assert not ev.rests_under_fixed_steps(-0.198, 0.198, -9.81, 1e-3)     # e = 1: nothing lost, never rests


def test_where_a_stepped_over_crossing_happened():
    """A ball found 0.49 mm below the floor at 1.098 m/s at the end of a 1 ms fixed step crossed s/v = 0.446 ms
    before it; never more than the step (found far past it, as after a long step); and a condition moving
    back towards its boundary (s < 0, v > 0) or not moving was not carried across by its rate: 0."""
    assert ev.crossed_ago(-0.49e-3, -1.098, 1e-3) == pytest.approx(0.49e-3 / 1.098, rel=1e-15)
    assert ev.crossed_ago(-0.5, -1.0, 1e-3) == 1e-3
    assert ev.crossed_ago(-0.49e-3, 1.0, 1e-3) == 0.0 and ev.crossed_ago(-0.49e-3, 0.0, 1e-3) == 0.0
    assert ev.crossed_ago(1.2e-3, 1.47, 1e-3) == pytest.approx(1.2e-3 / 1.47, rel=1e-15)   # rising: friction


def test_the_fmu_wrapper_keeps_the_rules_constants():
    """The C wrapper states the rules' constants again (it has no Python): they are the same numbers."""
    import re
    from pathlib import Path

    import mechnet.export
    source = (Path(mechnet.export.__file__).parent / "mechnet_fmu.c").read_text()

    def define(name):
        return float(re.search(rf"#define {name} ([0-9.eE+-]+)", source).group(1))
    assert define("MN_FIXED_STEP_GAIN") == ev.FIXED_STEP_GAIN
    assert define("MN_FIXED_STEP_FLIGHT") == ev.FIXED_STEP_FLIGHT
    assert f"fabs(r2 - r1) <= {ev.GEOMETRIC_SPREAD} * r" in source
    assert "1e-12 * (fabs(t) > 1 ? fabs(t) : 1)" in source and ev.location_tolerance(0.5) == 1e-12
    assert "if (gd != 0 && sign_of(g) == sign_of(gd)) ago = fmin(g / gd, m->h_step);" in source   # crossed_ago
