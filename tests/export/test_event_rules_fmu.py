"""The event rules' cases (`mechnet.core.events`, tests/hard/test_event_rules.py) in the FMU wrapper, driven
call by call through FMPy's FMI 2.0 and 3.0 functions, each against `cm.simulate` of the same scene.

A ball (0.1 kg, e = 0.8) on a rigid floor started exactly on it: thrown up (no event), landing (it bounces
at t = 0), resting (held at t = 0), a round-off below it moving up (no event); and one an importer
stepped over (it asks for event mode from its completed step, then bounces). Values compared to 1e-12
relative (one jump: the same arithmetic); the run's horizon is the first instant or one 11 ms step."""
from __future__ import annotations

import pytest

import mechnet as mn
from mechnet.components import translational as tr
from mechnet.export import compiler
from mechnet.core.events import crossed_ago

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
        self.update()
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
        """Time and states set as an importer's step would leave them; its completed-step answer."""
        import ctypes
        self.fmu.setTime(t)
        self.fmu.setContinuousStates((ctypes.c_double * 2)(*self._order(s, v)), 2)
        answer = self.fmu.completedIntegratorStep()
        return bool(answer[0])

    def _order(self, s, v):
        """(s, v) in the FMU's order of states (its derivatives list names der(state) or the state's rate)."""
        order = [d.variable.derivative.name if d.variable.derivative is not None else d.variable.name
                 for d in self.md.derivatives]
        return [{"ball.s": s, "ball.v": v}[n] for n in order]

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
