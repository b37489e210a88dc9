"""Result.plot: one subplot per unit on a shared time axis, events marked, a reference overlaid, a title."""
from __future__ import annotations

import dataclasses

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import mechnet as mn  # noqa: E402
from mechnet.components import rotational as rot  # noqa: E402
from mechnet.components.signals import Step  # noqa: E402
from mechnet.core.errors import MechnetError, UnknownNameError  # noqa: E402
from mechnet.simulate.events import Event  # noqa: E402
from mechnet.simulate.result import Result  # noqa: E402

T_KICK = 0.3       # s: the torque step, a time event
MIXED = ["j1.phi", "j1.w", "spring.tau", "spring.phi_rel", "kick.tau"]    # rad, rad/s, N*m, rad, N*m


@pytest.fixture(scope="module")
def kicked():
    """An inertia on a spring, kicked by a 2 N·m torque step at 0.3 s (one time event)."""
    m = mn.Model("kicked")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=100.0))
    j1 = m.add(rot.Inertia(name="j1", J=0.1, phi_start=0.5, w_start=0.0))
    kick = m.add(rot.Torque(name="kick", tau=Step(2.0, start_time=T_KICK)))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j1.flange_a)
    m.connect(kick.flange, j1.flange_b)
    return m.compile().simulate(0.5, n_out=51)


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def event_times(axis, label=None) -> list:
    """x of every vertical event line drawn in `axis` (optionally only the collection labelled `label`)."""
    return sorted(float(seg[0][0]) for c in axis.collections if label in (None, c.get_label())
                  for seg in c.get_segments())


def test_one_subplot_per_unit_on_a_shared_time_axis(kicked):
    fig = kicked.plot(MIXED)
    axes = fig.axes
    assert [a.get_ylabel() for a in axes] == ["rad", "rad/s", "N*m"]      # in the order the names use them
    assert [[line.get_label() for line in a.lines] for a in axes] == \
        [["j1.phi", "spring.phi_rel"], ["j1.w"], ["spring.tau", "kick.tau"]]
    assert all(axes[0].get_shared_x_axes().joined(axes[0], a) for a in axes[1:])
    assert axes[-1].get_xlabel() == "time [s]"
    assert np.array_equal(axes[1].lines[0].get_ydata(), kicked["j1.w"])
    assert all(a.get_legend() is not None for a in axes)


def test_events_are_vertical_lines_on_every_subplot_at_their_times(kicked):
    assert [(e.t, e.kind) for e in kicked.events] == [(T_KICK, "time")]
    assert "kick.tau" in kicked.events[0].cause
    fig = kicked.plot(MIXED)
    for axis in fig.axes:
        assert event_times(axis) == [T_KICK]
        (segment,) = axis.collections[0].get_segments()
        assert [segment[0][1], segment[1][1]] == [0.0, 1.0]                   # full height, in axes units
    # named once, in the top legend
    legends = [[t.get_text() for t in a.get_legend().get_texts()] for a in fig.axes]
    assert "time event" in legends[0] and not any("event" in text for lg in legends[1:] for text in lg)


def test_event_lines_leave_the_value_axis_alone():
    """A line from 0 to 1 in data units would stretch a piston's 0.2..0.3 m axis down to 0; drawn in axes
    units it does not."""
    t = np.linspace(0.0, 1.0, 11)
    piston = Result(t, np.column_stack([0.2 + 0.1 * t]), ("piston.s",), {"piston.s": "m"}, {}, np.zeros((11, 0)),
                    np.zeros((11, 0)), (), events=[Event(0.5, "time", "a step")])
    low, high = piston.plot(["piston.s"]).axes[0].get_ylim()
    assert 0.19 < low < 0.2 and 0.3 < high < 0.31


def test_each_event_kind_has_its_colour_and_one_legend_entry(kicked):
    events = [Event(0.1, "time", "a step"), Event(0.2, "state", "ball.h < 0"), Event(0.25, "time", "a knot"),
              Event(0.4, "reselection", "loop1")]
    fig = dataclasses.replace(kicked, events=events).plot(["j1.phi", "j1.w"])
    top = fig.axes[0]
    assert event_times(top, "time event") == [0.1, 0.25]
    assert event_times(top, "state event") == [0.2]
    assert event_times(top, "reselection event") == [0.4]
    assert event_times(fig.axes[1]) == [0.1, 0.2, 0.25, 0.4]
    colours = {c.get_label(): tuple(c.get_edgecolor()[0]) for c in top.collections}
    assert len(set(colours.values())) == 3
    texts = [t.get_text() for t in top.get_legend().get_texts()]
    assert sorted(t for t in texts if "event" in t) == ["reselection event", "state event", "time event"]


def test_a_reference_is_drawn_dashed_over_its_curve(kicked):
    expected = kicked["spring.tau"] + 1.0
    fig = kicked.plot(MIXED, reference={"spring.tau": expected})
    torque = fig.axes[2]
    curve, reference = (next(line for line in torque.lines if line.get_label() == label)
                        for label in ("spring.tau", "spring.tau reference"))
    assert reference.get_linestyle() == "--" and reference.get_color() == curve.get_color()
    assert np.array_equal(reference.get_ydata(), expected)
    assert np.array_equal(reference.get_xdata(), kicked.t)
    assert all("reference" not in line.get_label() for a in fig.axes[:2] for line in a.lines)


def test_the_title_is_given_or_the_model_s(kicked):
    assert kicked.plot(["j1.phi"], title="Kicked oscillator").get_suptitle() == "Kicked oscillator"
    named = dataclasses.replace(kicked, title="kicked")
    assert named.plot(["j1.phi"]).get_suptitle() == "kicked"
    assert named.plot(["j1.phi"], title="").get_suptitle() == ""


def test_a_failed_run_keeps_its_red_title(kicked):
    failed = dataclasses.replace(kicked, failure=MechnetError("step size too small"))
    fig = failed.plot(MIXED, title="scene")
    assert fig.axes[0].get_title() == "integration failed at t = 0.5 s"
    assert matplotlib.colors.same_color(fig.axes[0].title.get_color(), "red")
    assert fig.get_suptitle() == "scene"


def test_ax_takes_one_axes_per_unit(kicked):
    fig, single = plt.subplots()
    assert kicked.plot(["j1.phi", "spring.phi_rel"], ax=single) is fig
    assert len(single.lines) == 2 and single.get_ylabel() == "rad"
    assert fig.get_suptitle() == ""                          # the caller's figure: no title unless asked

    fig, pair = plt.subplots(1, 2)
    assert kicked.plot(["j1.phi", "j1.w"], ax=pair) is fig
    assert [a.get_ylabel() for a in pair] == ["rad", "rad/s"]


def test_one_axes_takes_every_unit_as_before(kicked):
    # review: res.plot(names, ax=ax) drew everything into ax before the unit groups; it still does
    fig, single = plt.subplots()
    kicked.plot(MIXED, ax=single)
    assert sorted(line.get_label() for line in single.get_lines()) == sorted(MIXED)
    assert single.get_ylabel() == "rad, rad/s, N*m"


@pytest.mark.parametrize("ax", ["too few", "not axes"])
def test_ax_that_does_not_fit_the_units_is_refused(kicked, ax):
    fig, axes = plt.subplots(1, 2)
    given = {"too few": list(axes), "not axes": ["a", "b", "c"]}[ax]
    with pytest.raises(MechnetError, match=r"plot\(ax=\.\.\.\): the names have 3 unit\(s\) \(rad, rad/s, N\*m\)"):
        kicked.plot(MIXED, ax=given)


def test_names_without_a_unit_share_the_dimensionless_axis(kicked):
    fig = dataclasses.replace(kicked, units={}).plot(["j1.phi", "j1.w"])
    assert [a.get_ylabel() for a in fig.axes] == ["1"]


@pytest.mark.parametrize("reference, error, match", [
    ({"j1.phy": 0.0}, UnknownNameError, r"plot\(reference=\.\.\.\): variable 'j1.phy' .*did you mean j1.phi"),
    ({"j1.w": 0.0}, MechnetError, r"plot\(reference=\.\.\.\): 'j1.w' is not among the plotted names"),
    ({"j1.phi": [1.0, 2.0]}, MechnetError, r"plot\(reference=\.\.\.\)\['j1.phi'\]: expected values on res.t"),
    (["j1.phi"], MechnetError, r"plot\(reference=\.\.\.\) takes a mapping"),
])
def test_a_bad_reference_names_the_argument(kicked, reference, error, match):
    with pytest.raises(error, match=match):
        kicked.plot(["j1.phi"], reference=reference)


def test_the_figure_is_written(kicked, tmp_path):
    kicked.plot(MIXED, reference={"j1.phi": kicked["j1.phi"]}, title="kicked").savefig(tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 0
