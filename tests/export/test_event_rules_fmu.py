"""The event rules' cases (`mechnet.core.events`, tests/hard/test_event_rules.py) in the FMU wrapper, driven
call by call through FMPy's FMI 2.0 and 3.0 functions, each against `cm.simulate` of the same scene.

A ball (0.1 kg, e = 0.8) on a rigid floor started exactly on it: thrown up (no event), landing (it bounces
at t = 0), resting (held at t = 0), a round-off below it moving up (no event); and one an importer
stepped over (it asks for event mode from its completed step, then bounces). Values compared to 1e-12
relative (one jump: the same arithmetic); the run's horizon is the first instant or one 11 ms step.

Issue 33's table, in scenes of tests/models.py: friction pushed exactly at its static limit, and through it
mid-run (a ramp); a sliding block sticking; friction thrown across v = 0 by a stop's rebound; two balls
landing at the same instant; a line of three masses handing its momentum down in one instant. At the
instant (Driven: the states put where the event is, exactly) both must give the same modes, velocities
and number of events; over a run (FMPy's `simulate_fmu`, CVode rtol 1e-6 or Euler 1 ms, output 0.01 s)
the event times and values against the closed forms, to the tolerances each test states."""
from __future__ import annotations

import math

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import translational as tr
from mechnet.export import compiler
from mechnet.core.events import crossed_ago
from mechnet.components.signals import Ramp

from fmu_runs import Setting, fmpy_run
from models import mass_line, pushed_block, two_balls

fmpy = pytest.importorskip("fmpy")
pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler to build the FMU")

E, G, M = 0.8, 9.81, 0.1


def ball(s0: float, v0: float) -> mn.Model:
    m = mn.Model("rule_ball")
    floor = m.add(tr.Fixed(name="floor"))
    contact = m.add(tr.Contact(name="contact", e=E))
    body = m.add(tr.Mass(name="ball", m=M, s_start=s0, v_start=v0))
    gravity = m.add(tr.ConstantForce(name="gravity", f_constant=-M * G))
    m.connect(floor.flange, contact.flange_a)
    m.connect(contact.flange_b, body.flange_a)
    m.connect(gravity.flange, body.flange_b)
    return m


class Driven:
    """An FMU instance driven call by call: initialised, its first event update iterated to the end."""

    def __init__(self, path, fmi):
        from fmpy import extract, read_model_description
        self.fmi, self.md = fmi, read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        directory = extract(str(path))
        kw = dict(guid=self.md.guid, unzipDirectory=directory,
                  modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName="rules")
        if fmi == 2:
            from fmpy.fmi2 import FMU2Model
            self.fmu = FMU2Model(**kw)
            self.fmu.instantiate()
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        else:
            from fmpy.fmi3 import FMU3Model
            self.fmu = FMU3Model(**kw)
            self.fmu.instantiate()
            self.fmu.enterInitializationMode(startTime=0.0)
        self.fmu.exitInitializationMode()
        self.initial_rounds = self.update()     # the events of the start instant
        self.fmu.enterContinuousTimeMode()

    def update(self) -> int:
        """FMI's event iteration to its end; the number of rounds that changed something."""
        changed = 0
        for _ in range(200):
            if self.fmi == 2:
                info = self.fmu.newDiscreteStates()
                more, values = info[0], info[3]
            else:
                info = self.fmu.updateDiscreteStates()
                more, values = info[0], info[3]
            changed += bool(values)
            if not more:
                return changed
        raise AssertionError("the event iteration did not end")

    def get(self, name) -> float:
        if self.fmi == 2:
            return self.fmu.getReal([self.vr[name]])[0]
        return self.fmu.getFloat64([self.vr[name]])[0]

    def step_to(self, t, s, v) -> bool:
        """Time and the ball's states set as an importer's step would leave them; its completed-step answer."""
        return self.set_states(t, {"ball.s": s, "ball.v": v})

    def state_names(self) -> list:
        """The states in the FMU's order (its derivatives list names der(state) or the state's rate)."""
        return [d.variable.derivative.name if d.variable.derivative is not None else d.variable.name
                for d in self.md.derivatives]

    def set_states(self, t, states: dict) -> bool:
        """Time and every state (by name, in any order) set as an importer's step would leave them; the
        FMU's completed-step answer (does it ask for event mode)."""
        import ctypes
        names = self.state_names()
        assert sorted(names) == sorted(states), f"states {sorted(states)} given, the FMU has {names}"
        self.fmu.setTime(t)
        self.fmu.setContinuousStates((ctypes.c_double * len(names))(*(states[n] for n in names)), len(names))
        answer = self.fmu.completedIntegratorStep()
        return bool(answer[0])

    def event(self) -> int:
        self.fmu.enterEventMode()
        rounds = self.update()
        self.fmu.enterContinuousTimeMode()
        return rounds

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    made = {}

    def get(s0, v0, fmi):
        key = (s0, v0, fmi)
        if key not in made:
            cm = ball(s0, v0).compile()
            made[key] = (cm, cm.export(tmp_path_factory.mktemp("rules") / f"ball{fmi}.fmu", kind="fmu", fmi=fmi))
        return made[key]
    return get


CASES = [  # name, s0, v0, v after the instant t = 0, what the simulator records there
    ("thrown up from the floor: no event", 0.0, 1.0, 1.0, []),
    ("landing exactly on the floor: it bounces at once", 0.0, -1.0, E * 1.0, ["state"]),
    ("a round-off below the floor moving up: no event", -1e-16, 1.0, 1.0, []),
]


@pytest.mark.parametrize("fmi", (2, 3))
@pytest.mark.parametrize("name, s0, v0, v_after, kinds", CASES, ids=[c[0] for c in CASES])
def test_a_start_on_the_boundary(exported, fmi, name, s0, v0, v_after, kinds):
    cm, path = exported(s0, v0, fmi)
    native = cm.simulate(1e-3, t_out=[0.0, 1e-3])
    assert [e.kind for e in native.events if e.t == 0.0] == kinds
    assert native["ball.v"][0 if not kinds else 1] == pytest.approx(v_after, rel=1e-12)
    run = Driven(path, fmi)
    try:
        assert run.get("ball.v") == pytest.approx(v_after, rel=1e-12)
    finally:
        run.close()


@pytest.mark.parametrize("fmi", (2, 3))
def test_a_ball_resting_on_the_floor_is_held_at_once(exported, fmi):
    """ġ = 0 and g̈ = −g on the boundary: it crosses now, and its impact at 0 m/s (≤ v_rest) holds it in
    the contact's rest mode, in the FMU as in the simulator (one event at t = 0, mode −1, v = 0); held, it
    asks for no event at the next step."""
    cm, path = exported(0.0, 0.0, fmi)
    native = cm.simulate(1e-2, t_out=[0.0, 1e-2])
    assert [e.kind for e in native.events if e.t == 0.0] == ["state"] and native["contact.mode"][-1] == -1.0
    run = Driven(path, fmi)
    try:
        assert run.get("ball.v") == 0.0 and run.get("contact.mode") == -1.0
        assert not run.step_to(0.01, 0.0, 0.0)
    finally:
        run.close()


@pytest.mark.parametrize("fmi", (2, 3))
def test_a_crossing_an_importer_stepped_over_asks_for_event_mode(exported, fmi):
    """Falling at 1 m/s from 1 cm (s = 0.01 − t − g·t²/2), an importer's 1 ms steps land at s = −0.49 mm at
    t = 10 ms without locating the impact: the completed step asks for event mode, and the update bounces
    the ball where it crossed (core/events.py `crossed_ago`: s/v = 0.45 ms before the step's end, the state
    carried back along its derivatives, v → −e·v there, carried on to 10 ms: above the floor again; an impact
    losing 0.22 m/s, far more than a 1 ms step's error adds back: no rest). Exact to rel 1e-12: the same
    arithmetic, one Euler step each way."""
    cm, path = exported(0.01, -1.0, fmi)
    run = Driven(path, fmi)

    def free(t):
        return 0.01 - t - 0.5 * G * t * t, -1.0 - G * t
    try:
        assert not run.step_to(0.009, *free(0.009))      # still above the floor
        assert run.step_to(0.010, *free(0.010))          # past it: an event it must not lose
        assert run.event() >= 1
        s_end, v_end = free(0.010)
        ago = crossed_ago(s_end, v_end, 1e-3)
        assert 0 < ago < 1e-3
        s_at, v_at = s_end - v_end * ago, v_end + G * ago        # carried back along (v, −g)
        v_plus = -E * v_at
        assert run.get("ball.v") == pytest.approx(v_plus - G * ago, rel=1e-12)
        assert run.get("ball.s") == pytest.approx(s_at + v_plus * ago, rel=1e-12)
        assert run.get("ball.s") > 0                              # back above the floor
        assert run.get("contact.mode") == 0.0
    finally:
        run.close()


@pytest.mark.parametrize("fmi", (2, 3))
def test_friction_pushed_past_its_static_limit_breaks_away_at_the_start(tmp_path, fmi):
    """tests/models.py stick_slip_block: a block held by friction (static limit 0.3·9.81 = 2.94 N) and pushed
    with 5 N from the start: its `at_start` breakaway condition is past zero in its direction, so it fires in
    the first update — sliding forward (mode +1) in the FMU as in the simulator (an event at t = 0); a push of
    2 N (within the limit) keeps it stuck (mode 0) in both."""
    from models import stick_slip_block
    for push, mode in ((5.0, 1.0), (2.0, 0.0)):
        cm = stick_slip_block(push=push).compile()
        native = cm.simulate(1e-3, t_out=[0.0, 1e-3])
        assert native["fr.mode"][-1] == mode
        assert [e.kind for e in native.events if e.t == 0.0] == (["state"] if mode else [])
        run = Driven(cm.export(tmp_path / f"block{push:g}_{fmi}.fmu", kind="fmu", fmi=fmi), fmi)
        try:
            assert run.get("fr.mode") == mode
        finally:
            run.close()


# ---------------------------------------------------------------- issue 33's table of cases
A_K = 0.25 * 9.81             # m/s²: kinetic deceleration of the 1 kg block (μk = 0.25, fn = 9.81 N)
F_S = 0.5 * 9.81              # N: its static limit, exactly (μk·fn + (μs − μk)·fn: 0.25·9.81 twice)
F0, RATE = 4.0, 2.0           # N, N/s: the ramped push, f = F0 + RATE·t over 1 s
STOP, E_STOP = 0.1, 0.8       # m, 1: where the thrown block's stop is, and its restitution
CVODE, EULER = Setting("CVode", 0.01, 1e-6), Setting("Euler", 1e-3)
SCENES = {
    "limit": lambda: pushed_block(push=F_S),
    "ramp": lambda: pushed_block(ramp=Ramp(RATE * 1.0, 1.0, offset=F0)),
    "stick": lambda: pushed_block(push=0.0, v0=1.0),
    "thrown": lambda: pushed_block(push=0.0, v0=1.0, stop=STOP, e=E_STOP),
    "balls": lambda: two_balls(s0=0.5, v0=0.0, e=E),
    "line": lambda: mass_line(n=3, v0=1.0, gap=0.1, e=1.0),
    "elastic": lambda: two_balls(s0=2e-3, v0=0.0, e=1.0, name="elastic_balls"),
    "balls_euler": lambda: two_balls(s0=0.05, v0=0.0, e=E, name="balls_euler"),
}


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """(compiled, FMU path) of a scene of SCENES for FMI `fmi`: each compiled once, exported once per version."""
    compiled, made = {}, {}

    def get(key, fmi):
        if key not in compiled:
            compiled[key] = SCENES[key]().compile()
        if (key, fmi) not in made:
            made[key, fmi] = compiled[key].export(tmp_path_factory.mktemp("table") / f"{key}{fmi}.fmu", kind="fmu",
                                                  fmi=fmi)
        return compiled[key], made[key, fmi]
    return get


def native_instant(res, t, tol=1e-12):
    """The simulator's events within tol of t, and its output rows just before and just after them."""
    events = [e for e in res.events if abs(e.t - t) <= tol]
    rows = np.nonzero(np.abs(res.t - t) <= tol)[0]
    return events, rows[0], rows[-1]


def fmu_instant(run, t):
    """The FMPy output rows just before and just after the event recorded at t (its repeated time rows)."""
    rows = np.nonzero(run.t == t)[0]
    assert len(rows) >= 2, f"no event rows at t = {t}"
    return rows[0], rows[-1]


@pytest.mark.parametrize("fmi", (2, 3))
def test_friction_pushed_exactly_at_its_static_limit(scene, fmi):
    """pushed_block: a 1 kg block held by friction whose static limit F_s = 0.5·9.81 N is met exactly by a
    constant push of 0.5·9.81 N: |sa| − F_s == 0 exactly at t = 0 (sa read from both, compared with ==),
    not moving (ġ = g̈ = 0): resting on its boundary, so not past it (side 0). Whatever the simulator
    does there (measured: stays stuck, no event at t = 0), the FMU must do the same: the same mode, the
    same speed (== 0, exact), the same number of events at t = 0 (its first event iteration's rounds);
    and, stepped on 10 ms with the block still, it asks for no event and stays in that mode. Horizon 0.1 s
    in the simulator (mode and speed at its end equal to those at t = 0)."""
    cm, path = scene("limit", fmi)
    native = cm.simulate(0.1, t_out=[0.0, 0.1])
    assert abs(native["fr.sa"][0]) - F_S == 0.0
    events, _, after = native_instant(native, 0.0)
    mode, v = native["fr.mode"][after], native["block.v"][after]
    assert native["fr.mode"][-1] == mode and native["block.v"][-1] == v
    run = Driven(path, fmi)
    try:
        assert abs(run.get("fr.sa")) - F_S == 0.0
        assert (run.get("fr.mode"), run.get("block.v"), run.initial_rounds) == (mode, v, len(events))
        assert not run.set_states(0.01, {"block.s": 0.0, "block.v": 0.0})
        assert run.get("fr.mode") == mode
    finally:
        run.close()


@pytest.mark.parametrize("fmi", (2, 3))
@pytest.mark.parametrize("setting", (CVODE, EULER), ids=str)
def test_friction_pushed_through_its_static_limit_breaks_away_mid_run(scene, fmi, setting):
    """pushed_block with a ramped push f = 4 + 2·t N (over 1 s) on the 1 kg block held by friction (static
    limit F_s = 4.905 N, kinetic 2.4525 N): it breaks away once, forward (mode 0 → +1), at the closed form
    t_b = (F_s − 4)/2 = 0.4525 s, and slides on to v(1 s) = (4 − 2.4525)·(1 − t_b) + (1 − t_b²) = 1.6425 m/s.
    Horizon 1 s. The simulator (rtol 1e-6): one event, |t − t_b| ≤ 1e-9 s (measured 2.5e-13), v(1)
    rel 1e-9 (measured 1.6e-13). The FMU in FMPy: exactly one mode change, 0 → +1; CVode (rtol 1e-6, output
    0.01 s) at |t − t_b| ≤ 1e-6 s (measured 1e-16) and v(1) within rel 1e-5 of the simulator's (measured
    2.1e-6); Euler (h = 1 ms, which sees the crossing at a step's end) at t_b ≤ t ≤ t_b + h, v(1) rel 1e-3
    (measured 3.3e-4: Euler's O(h) error)."""
    cm, path = scene("ramp", fmi)
    t_b = (F_S - F0) / RATE
    v_end = (F0 - A_K) * (1 - t_b) + 0.5 * RATE * (1 - t_b ** 2)
    native = cm.simulate(1.0, t_out=[0.0, 1.0])
    assert [e.kind for e in native.events] == ["state"] and native.events[0].t == pytest.approx(t_b, abs=1e-9)
    assert native["fr.mode"][-1] == 1.0 and native["block.v"][-1] == pytest.approx(v_end, rel=1e-9)
    run = fmpy_run(path, 1.0, ["fr.mode", "block.v"], setting)
    changes = run.mode_changes("fr.mode")
    assert len(changes) == 1 and run["fr.mode"][0] == 0.0 and run["fr.mode"][-1] == 1.0
    if setting.solver == "CVode":
        assert changes[0] == pytest.approx(t_b, abs=1e-6)
        assert run["block.v"][-1] == pytest.approx(native["block.v"][-1], rel=1e-5)
    else:
        assert t_b <= changes[0] <= t_b + setting.interval + 1e-12
        assert run["block.v"][-1] == pytest.approx(native["block.v"][-1], rel=1e-3)


@pytest.mark.parametrize("fmi", (2, 3))
@pytest.mark.parametrize("setting", (CVODE, EULER), ids=str)
def test_a_sliding_block_sticks_when_its_speed_reaches_zero(scene, fmi, setting):
    """pushed_block with no push, started at 1 m/s: sliding from t = 0 (mode +1), decelerated by kinetic
    friction at μk·g = 2.4525 m/s², it stops at the closed form t_stop = 1/2.4525 = 0.40775 s and sticks:
    mode 0 and v exactly 0 (== 0.0: the plastic jump) on every output row after, in the FMU as in the
    simulator. Horizon 1 s. The simulator: events "starts sliding" at 0 and one state event at
    |t − t_stop| ≤ 1e-9 s (measured 2.5e-13). FMPy: one mode change (+1 → 0), no chatter; CVode (rtol 1e-6,
    output 0.01 s) at |t − t_stop| ≤ 1e-6 s (measured < 1e-15); Euler h = 1 ms sees it at the end of the step
    it crossed in: t_stop ≤ t ≤ t_stop + h."""
    cm, path = scene("stick", fmi)
    t_stop = 1.0 / A_K
    native = cm.simulate(1.0, t_out=[0.0, 0.5, 1.0])
    assert [e.t for e in native.events][0] == 0.0 and len(native.events) == 2
    assert native.events[1].t == pytest.approx(t_stop, abs=1e-9)
    _, _, after = native_instant(native, native.events[1].t)
    assert np.all(native["block.v"][after:] == 0.0) and np.all(native["fr.mode"][after:] == 0.0)
    run = fmpy_run(path, 1.0, ["fr.mode", "block.v"], setting)
    changes = run.mode_changes("fr.mode")
    assert run["fr.mode"][0] == 1.0 and len(changes) == 1
    if setting.solver == "CVode":
        assert changes[0] == pytest.approx(t_stop, abs=1e-6)
    else:
        assert t_stop <= changes[0] <= t_stop + setting.interval + 1e-12
    _, after = fmu_instant(run, changes[0])
    assert np.all(run["block.v"][after:] == 0.0) and np.all(run["fr.mode"][after:] == 0.0)


@pytest.mark.parametrize("fmi", (2, 3))
def test_friction_thrown_across_zero_by_a_stop_keeps_sliding_the_other_way(scene, fmi):
    """pushed_block with a HardStop at s = 0.1 m (e = 0.8): the block, sliding at 1 m/s from s = 0 against
    kinetic friction (2.4525 m/s²), hits the stop at v1 = √(1 − 2·2.4525·0.1) = 0.7138 m/s at
    t_hit = (1 − v1)/2.4525 = 0.1167 s and rebounds at −e·v1: friction's velocity is thrown across 0 by the
    stop's jump, so it keeps sliding, the other way (mode +1 → −1, never 0 there), until it sticks at
    t_hit + e·v1/2.4525 = 0.3495 s. The simulator (rtol 1e-6, horizon 0.5 s): its impact within 1e-6 s of t_hit
    (measured 7e-8), two events there, mode −1 and −e·v1 (rel 1e-6, measured 2.3e-7) after them.
    At the instant (Driven, the states put exactly on the stop at t_hit): the FMU asks for event mode, and its
    event iteration gives the simulator's mode (−1), number of events at that instant (2: the stop, then
    friction thrown) and velocity: −e·v1 to rel 1e-12 (the same jump's arithmetic), the simulator's
    after-row rel 1e-6 (its located state, rtol 1e-6: measured 2.3e-7). Over 0.5 s (FMPy CVode rtol 1e-6,
    output 0.01 s): mode changes +1 → −1 at t_hit and −1 → 0 at the sticking time, each within 1e-5 s of the
    closed form (measured 4.3e-7, 8.5e-8), v after the impact rel 1e-5 of −e·v1 (measured 1.5e-6)."""
    cm, path = scene("thrown", fmi)
    v1 = math.sqrt(1.0 - 2 * A_K * STOP)
    t_hit, v_back = (1.0 - v1) / A_K, -E_STOP * v1
    t_stick = t_hit - v_back / A_K
    native = cm.simulate(0.5, t_out=[0.0, 0.25, 0.5])
    t_native = native.events[1].t
    events, _, after = native_instant(native, t_native)
    assert t_native == pytest.approx(t_hit, abs=1e-6) and len(events) == 2
    assert native["fr.mode"][after] == -1.0 and native["block.v"][after] == pytest.approx(v_back, rel=1e-6)
    run = Driven(path, fmi)
    try:
        assert run.set_states(t_hit, {"block.s": STOP, "block.v": v1})
        assert run.event() == len(events)
        assert run.get("fr.mode") == native["fr.mode"][after] and run.get("stop.mode") == native["stop.mode"][after]
        assert run.get("block.v") == pytest.approx(v_back, rel=1e-12)
        assert run.get("block.v") == pytest.approx(native["block.v"][after], rel=1e-6)
    finally:
        run.close()
    out = fmpy_run(path, 0.5, ["fr.mode", "block.v"], CVODE)
    changes = out.mode_changes("fr.mode")
    assert changes == pytest.approx([t_hit, t_stick], abs=1e-5)
    _, after = fmu_instant(out, changes[0])
    assert out["fr.mode"][after] == -1.0 and out["block.v"][after] == pytest.approx(v_back, rel=1e-5)
    assert set(out["fr.mode"][out.t < changes[1]]) == {1.0, -1.0}       # never stuck between the two


@pytest.mark.parametrize("fmi", (2, 3))
def test_two_balls_landing_at_the_same_instant_both_bounce(scene, fmi):
    """two_balls: two 0.1 kg balls dropped together from 0.5 m onto one floor, each on its own contact (e = 0.8),
    land at the same instant t = √(1/9.81) = 0.3193 s at v = −√9.81 = −3.132 m/s, and both bounce there.
    The simulator (rtol 1e-6, horizon 0.5 s): two events at that one time (|t − closed form| ≤ 1e-7 s,
    measured 5e-9), both balls at −e·v after (rel 1e-6, measured 1.7e-7). At the instant (Driven, both balls
    put exactly on the floor at the closed-form time): the FMU asks for event mode, and its event iteration
    changes something in 2 rounds (one per contact, as the simulator's two events), leaving both at −e·v to
    rel 1e-12 (one jump each: the same arithmetic) and both contacts free (mode 0, as the simulator). Over
    0.5 s (FMPy CVode rtol 1e-6, output 0.01 s): one event time for both, within 1e-5 s of the closed form
    (measured 1.5e-7), both at −e·v after it, rel 1e-5 (measured 4.6e-7)."""
    cm, path = scene("balls", fmi)
    t_land, v_land = math.sqrt(1.0 / G), -math.sqrt(G)
    native = cm.simulate(0.5, t_out=[0.0, 0.25, 0.5])
    events, _, after = native_instant(native, native.events[0].t)
    assert len(events) == 2 and len(native.events) == 2 and events[0].t == pytest.approx(t_land, abs=1e-7)
    for k in (1, 2):
        assert native[f"ball{k}.v"][after] == pytest.approx(-E * v_land, rel=1e-6)
    run = Driven(path, fmi)
    try:
        assert run.set_states(t_land, {"ball1.s": 0.0, "ball1.v": v_land, "ball2.s": 0.0, "ball2.v": v_land})
        assert run.event() == len(events)
        for k in (1, 2):
            assert run.get(f"ball{k}.v") == pytest.approx(-E * v_land, rel=1e-12)
            assert run.get(f"contact{k}.mode") == native[f"contact{k}.mode"][after] == 0.0
    finally:
        run.close()
    out = fmpy_run(path, 0.5, ["ball1.v", "ball2.v"], CVODE)
    times = out.transitions()
    assert len(times) == 1 and times[0] == pytest.approx(t_land, abs=1e-5)
    _, after = fmu_instant(out, times[0])
    for k in (1, 2):
        assert out[f"ball{k}.v"][after] == pytest.approx(-E * v_land, rel=1e-5)


@pytest.mark.parametrize("fmi", (2, 3))
def test_a_line_of_three_masses_hands_its_momentum_down_in_one_instant(scene, fmi):
    """mass_line: three 1 kg masses on a line joined by rigid contacts (e = 1); the first, 0.1 m behind the
    other two (resting, touching), reaches them at 1 m/s at t = 0.1 s. Its impact hands its speed to the
    second, whose contact with the third is thereby thrown closed at the same instant (a cascade): the
    second impact hands it on. After the instant: (0, 0, 1) m/s, all contacts free (mode 0), in both.
    The simulator (horizon 0.2 s): two events at t = 0.1 s (|t − 0.1| ≤ 1e-9, measured 0), velocities to atol
    1e-12 m/s (measured exact). At the
    instant (Driven: the first mass put exactly on the second at t = 0.1 s): the FMU asks for event mode,
    changes something in 2 rounds (as the simulator's two events) and leaves (0, 0, 1) to atol 1e-12 and
    the simulator's modes. Over 0.2 s (FMPy CVode rtol 1e-6, output 0.01 s): one event time, within 1e-6 s
    of 0.1 (measured 0), (0, 0, 1) after it to atol 1e-9 m/s, and kept to the end (no further event)."""
    cm, path = scene("line", fmi)
    expected = {"m0.v": 0.0, "m1.v": 0.0, "m2.v": 1.0}
    native = cm.simulate(0.2, t_out=[0.0, 0.2])
    events, _, after = native_instant(native, native.events[0].t)
    assert len(events) == len(native.events) == 2 and events[0].t == pytest.approx(0.1, abs=1e-9)
    for name, v in expected.items():
        assert native[name][after] == pytest.approx(v, abs=1e-12)
    run = Driven(path, fmi)
    try:
        states = {"m0.s": 0.0, "m0.v": 1.0, "m1.s": 0.0, "m1.v": 0.0, "m2.s": 0.0, "m2.v": 0.0}
        assert run.set_states(0.1, states)
        assert run.event() == len(events)
        for name, v in expected.items():
            assert run.get(name) == pytest.approx(v, abs=1e-12)
        for k in (0, 1):
            assert run.get(f"hit{k}.mode") == native[f"hit{k}.mode"][after] == 0.0
    finally:
        run.close()
    out = fmpy_run(path, 0.2, list(expected), CVODE)
    times = out.transitions()
    assert len(times) == 1 and times[0] == pytest.approx(0.1, abs=1e-6)
    _, after = fmu_instant(out, times[0])
    for name, v in expected.items():
        assert out[name][after] == pytest.approx(v, abs=1e-9) and out[name][-1] == pytest.approx(v, abs=1e-9)


@pytest.mark.parametrize("fmi", (2, 3))
def test_an_elastic_ball_keeps_bouncing_under_fixed_steps(scene, fmi):
    """two_balls with e = 1 dropped from 2 mm (flight 40 ms, 40 steps of 1 ms), 1 s, FMPy Euler at h = 1 ms:
    an impact that keeps its speed never rests, however short the flight (core/events.py
    `rests_under_fixed_steps`). The event is taken where the ball crossed (`crossed_ago`) and the speeds the
    rest rule compares are read there, before and after the reset: read at the step's end after carrying
    back and forth, they differed by 2·g·ago and the ball was put to rest at its first impact. Asserted: the
    simulator (rtol 1e-6) bounces at least 20 times in 1 s (measured 25) and never rests; under Euler at
    least 15 impacts (measured 17: explicit Euler gains energy, its flights lengthen from 45 to 74 steps),
    the contact never in its rest mode (−1), and the ball still rising above 1 mm in the last 0.1 s."""
    cm, path = scene("elastic", fmi)
    native = cm.simulate(1.0, n_out=101)
    hits = [e for e in native.events if e.kind == "state" and e.cause.startswith("contact1")]
    assert len(hits) >= 20 and not any(e.kind == "rest" for e in native.events)
    run = fmpy_run(path, 1.0, ["ball1.s", "ball1.v", "contact1.mode"], EULER)
    rebounds = np.flatnonzero((run["ball1.v"][:-1] < 0) & (run["ball1.v"][1:] > 0))
    assert len(rebounds) >= 15, f"{len(rebounds)} impacts under Euler, the simulator {len(hits)}"
    assert np.all(run["contact1.mode"] != -1.0)
    assert np.max(run["ball1.s"][run.t >= 0.9]) >= 1e-3


@pytest.mark.parametrize("fmi", (2, 3))
def test_two_balls_stepped_over_together_stay_together(scene, fmi):
    """two_balls (e = 0.8, identical, from 5 cm), 1 s, FMPy Euler at h = 1 ms: both crossings fall in the same
    steps, so both events are taken at the one instant where the first crossed (every state carried back
    there, `crossed_ago`): the two balls stay identical to the bit. Taken only for the first, the second ball's
    transition at the step's end separated them by 1.9 mm. Also the first impact against the closed form
    t = √(2·0.05/g) = 0.101 s: seen at most two steps after it (one for seeing it at a step's end, one for
    explicit Euler's lag: its fall trails the exact one by about g·h·t/2, measured 0.102 s)."""
    _, path = scene("balls_euler", fmi)
    run = fmpy_run(path, 1.0, ["ball1.s", "ball2.s", "ball1.v", "ball2.v"], EULER)
    assert np.array_equal(run["ball1.s"], run["ball2.s"]) and np.array_equal(run["ball1.v"], run["ball2.v"])
    first = run.t[np.flatnonzero((run["ball1.v"][:-1] < 0) & (run["ball1.v"][1:] > 0))[0] + 1]
    t_hit = np.sqrt(2 * 0.05 / G)
    assert t_hit <= first <= t_hit + 2 * EULER.interval
