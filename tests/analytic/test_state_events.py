"""State events: zero crossings located by re-integration, resets applied, accumulation stopped."""
from __future__ import annotations

import numpy as np
import pytest

import mechnet as mn
from models import BouncingBall, bouncing_ball

G, E, H0 = 9.81, 0.8, 1.0


def _impact_times(n):
    """t_1 = sqrt(2 h0/g); each flight after an impact lasts 2 v_k/g with v_k = e^k v_1."""
    t = [np.sqrt(2 * H0 / G)]
    v = G * t[0]
    for _ in range(n - 1):
        v *= E
        t.append(t[-1] + 2 * v / G)
    return np.array(t)


def test_bounce_times_and_heights_match_the_closed_form():
    # rtol = atol = 1e-10 (states nominal 1), horizon 3 s (6 impacts); event times are located to 1e-12 s,
    # so their error is the integration error carried from impact to impact: measured 1e-9 at the first
    # and +4e-9 per impact after it; bound 5e-9 · k for impact k (scale 1 s).
    res = bouncing_ball().compile().simulate(3.0, rtol=1e-10, atol=1e-10, n_out=3001)
    assert res.success
    impacts = [e for e in res.events if e.kind == "state"]
    assert all("b (BouncingBall), event 1 — impact" == e.cause for e in impacts)
    times = np.array([e.t for e in impacts])
    assert np.all(np.abs(times - _impact_times(len(times))) < 5e-9 * np.arange(1, len(times) + 1))
    assert len(times) == 6
    # after each impact the speed is -e times the speed just before (both limits are in the result)
    for t in times:
        k = np.flatnonzero(res.t == t)
        assert k.size == 2, "the left and right limits are both recorded"
        v_before, v_after = res["b.v"][k[0]], res["b.v"][k[1]]
        assert v_after == pytest.approx(-E * v_before, rel=1e-12)
        assert abs(res["b.h"][k[0]]) < 1e-9
    # the height never goes (measurably) below the floor: bounded by the event location tolerance
    assert np.min(res["b.h"]) > -1e-9


def test_energy_between_impacts_is_conserved_and_drops_by_e_squared():
    # Energy per unit mass g h + v²/2, scale g h0: constant between impacts (rtol = atol = 1e-10: < 1e-8),
    # multiplied by e² at each impact (< 1e-8 relative).
    res = bouncing_ball().compile().simulate(2.0, rtol=1e-10, atol=1e-10, n_out=2001)
    energy = G * res["b.h"] + 0.5 * res["b.v"] ** 2
    times = [e.t for e in res.events]
    edges = [0.0] + times + [2.0]
    levels = []
    for a, b in zip(edges[:-1], edges[1:]):
        inside = (res.t > a) & (res.t < b)
        if inside.sum() > 2:
            seg = energy[inside]
            assert np.max(np.abs(seg - seg[0])) < 1e-8 * G * H0
            levels.append(seg[0])
    ratios = np.array(levels[1:]) / np.array(levels[:-1])
    assert np.max(np.abs(ratios - E**2)) < 1e-8


def test_event_accumulation_returns_the_partial_result():
    # The impacts accumulate at t_inf = t_1 (1 + 2e/(1 − e)); the run must stop near it with a failure
    # naming the accumulation, keeping everything before it.
    t1 = np.sqrt(2 * H0 / G)
    t_inf = t1 * (1 + 2 * E / (1 - E))
    cm = bouncing_ball().compile()
    with pytest.warns(mn.IntegrationWarning, match="event accumulation"):
        res = cm.simulate(t_inf + 1.0, rtol=1e-10, atol=1e-10)
    assert not res.success and isinstance(res.failure, mn.IntegrationError)
    assert "event accumulation" in str(res.failure)
    assert t_inf - 1e-3 < res.t[-1] <= t_inf + 1e-6
    assert len(res.events) > 30


@pytest.mark.parametrize("direction", ["sideways", 2])
def test_bad_direction_is_named(direction):
    class Bad(BouncingBall):
        def events(self):
            return [mn.When(self.h, reset={self.v: -self.v}, direction=direction)]

    m = mn.Model("bad")
    m.add(Bad(name="b", h_start=1.0, v_start=0.0))
    with pytest.raises(mn.StructureError, match=r"b \(Bad\), event 1.*direction"):
        m.compile()


def test_reset_target_must_be_a_variable():
    class Bad(BouncingBall):
        def events(self):
            return [mn.When(self.h, reset={2.0 * self.v: 0.0})]

    m = mn.Model("bad")
    m.add(Bad(name="b", h_start=1.0, v_start=0.0))
    with pytest.raises(mn.StructureError, match=r"b \(Bad\), event 1: reset targets"):
        m.compile()


@pytest.mark.parametrize("condition", ["h", True, None])
def test_a_condition_that_is_no_expression_is_named(condition):
    # issue 16: When(condition='h') escaped as a raw CasADi overload error
    class Bad(BouncingBall):
        def events(self):
            return [mn.When(condition, reset={self.v: -self.v})]

    m = mn.Model("bad")
    m.add(Bad(name="b", h_start=1.0, v_start=0.0))
    with pytest.raises(mn.StructureError, match=r"b \(Bad\), events\(\): When: condition .* must be an expression"):
        m.compile()
