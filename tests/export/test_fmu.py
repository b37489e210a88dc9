"""FMUs (FMI 2.0 and 3.0 Model Exchange) checked by clients that did not write them: FMPy's validator and
simulator, and CasADi's own FMU import calling the binary.

Settings: FMPy's CVode at relative tolerance 1e-10, cm.simulate at rtol 1e-10, atol 1e-12, 2 s; random
points with a fixed seed.
"""
import ctypes
import shutil
import zipfile

import numpy as np
import pytest

import mechnet as mn
from mechnet.export import compiler
from mechnet.export.model_description import fmi_name
from mechnet.scene import load_scene
from models import bouncing_ball, cartesian_pendulum, stick_slip_block, stopped_oscillator

fmpy = pytest.importorskip("fmpy", reason="fmpy (extra 'test') checks FMUs")
from fmpy import extract, read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler ($CC, cc, gcc or clang) to build FMUs")
EXAMPLES = __import__("pathlib").Path(__file__).parents[2] / "examples"
SCENES = {
    "double_pendulum": lambda: load_scene(EXAMPLES / "double_pendulum.py").build().compile(),
    "four_bar": lambda: load_scene(EXAMPLES / "four_bar.py").build().compile(),     # loop equations inside
    "drive_line": lambda: load_scene(EXAMPLES / "drive_line.py").build().compile(),  # a torque step: time event
    "bouncing_ball": lambda: bouncing_ball().compile(),                                # state events
    "stick_slip": lambda: stick_slip_block().compile(),          # friction modes, breaking away at the start
    "stopped_oscillator": lambda: stopped_oscillator().compile(),  # impacts through the impulse carrier
}


def _quiet(*args):
    pass


def _permanent_callbacks():
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(_quiet)
    return callbacks


# FMPy's default FMI 2.0 callbacks format messages through one native proxy that points at the logger
# last given to simulate_fmu(logger=...), which dies with that call: instances made here log to this one
_PERMANENT_CALLBACKS = _permanent_callbacks()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(compiled model, FMU path) per (scene, FMI version), built once for the module."""
    cache = {}

    def get(name, fmi):
        if (name, fmi) not in cache:
            cm = cache.get(name) or SCENES[name]()
            cache[name] = cm
            cache[name, fmi] = (cm, cm.export(tmp_path_factory.mktemp(name) / f"{name}{fmi}.fmu", kind="fmu", fmi=fmi))
        return cache[name, fmi]
    return get


CASES = [(name, fmi) for name in SCENES for fmi in (2, 3)]


@pytest.mark.parametrize("name,fmi", CASES)
def test_fmpy_validates_the_fmu(built, name, fmi):
    _, path = built(name, fmi)
    assert validate_fmu(str(path)) == []
    with zipfile.ZipFile(path) as z:
        files = set(z.namelist())
    assert "sources/mechnet_fmu.c" in files and "modelDescription.xml" in files
    assert any(f.startswith("binaries/") and f.endswith(".so") for f in files)


def _grid_rows(t):
    """Rows whose time is not repeated: an event repeats its time (left and right limits), and at an event
    time the two simulators may sit on different sides of the event (their event times agree to 1e-6 s)."""
    repeated = np.r_[np.diff(t) == 0, False] | np.r_[False, np.diff(t) == 0]
    return ~repeated


def _rows_at(run, times):
    """The run's rows at `times` (its right limits where an event repeats a time)."""
    t = np.asarray(run.t)
    last = np.r_[np.diff(t) > 0, True]
    index = {tt: i for i, tt in enumerate(t) if last[i]}
    return np.array([index[tt] for tt in times])


@pytest.mark.parametrize("name,fmi", CASES)
def test_fmpy_simulation_matches_native(built, name, fmi):
    """FMPy's CVode on the FMU against cm.simulate, both at relative tolerance 1e-10, states within 1e-6
    over 2 s; the ball's impacts within 1e-6 s; the drive line's torque step at 0.5 s."""
    cm, path = built(name, fmi)
    states = list(cm.functions()["metadata"]["selection"]["states"])
    res = simulate_fmu(str(path), stop_time=2.0, relative_tolerance=1e-10, output_interval=0.01,
                       output=[fmi_name(n) for n in states], fmi_type="ModelExchange")
    t = res["time"]
    keep = _grid_rows(t)
    native = cm.simulate(2.0, rtol=1e-10, atol=1e-12, t_out=t[keep])
    rows = _rows_at(native, t[keep])
    for n in states:
        assert np.max(np.abs(res[fmi_name(n)][keep] - native[n][rows])) < 1e-6, n
    event_times = t[:-1][np.diff(t) == 0]
    if name == "bouncing_ball":
        impacts = [e.t for e in native.events if e.kind == "state"]
        assert len(impacts) == 3
        # each impact is an event of the FMU (the rising crossings just after are events too, without resets)
        for ti in impacts:
            assert np.min(np.abs(event_times - ti)) < 1e-6
    if name == "drive_line":
        assert np.min(np.abs(event_times - 0.5)) < 1e-12
    if name in ("stick_slip", "stopped_oscillator"):
        # every mode switch and impact of the native run is an event of the FMU, within 1e-6 s
        switches = [e.t for e in native.events if e.kind == "state"]
        assert len(switches) >= 2
        for ti in switches:
            assert np.min(np.abs(np.r_[0.0, event_times] - ti)) < 1e-6


@pytest.mark.parametrize("name,fmi", [(n, f) for n in ("double_pendulum", "four_bar") for f in (2, 3)])
def test_declared_dependencies_and_directional_derivatives(built, name, fmi):
    """Through the FMU's own C API at a random state: the Jacobian of the derivatives by directional
    derivatives has its nonzeros exactly where ModelStructure declares dependencies, and each column
    matches central differences of GetDerivatives (step 1e-6) within 1e-6 relative."""
    cm, path = built(name, fmi)
    md = read_model_description(str(path))
    instance = _instance(md, str(path), fmi)
    try:
        nx = md.numberOfContinuousStates
        x0 = _get_states(instance, fmi, nx) + np.random.default_rng(2).uniform(-0.05, 0.05, nx)
        ders = md.derivatives
        state_vr = [d.variable.derivative.valueReference for d in ders]
        der_vr = [d.variable.valueReference for d in ders]
        jac = np.zeros((nx, nx))
        for j in range(nx):
            seed = np.zeros(nx)
            seed[j] = 1.0
            _set_states(instance, fmi, x0)
            jac[:, j] = _directional(instance, fmi, der_vr, [state_vr[j]], [1.0])
            h = 1e-6
            _set_states(instance, fmi, x0 + h * seed)
            plus = _derivatives(instance, fmi, nx)
            _set_states(instance, fmi, x0 - h * seed)
            minus = _derivatives(instance, fmi, nx)
            fd = (plus - minus) / (2 * h)
            assert np.max(np.abs(fd - jac[:, j])) <= 1e-6 * max(1.0, np.max(np.abs(jac[:, j]))), (name, j)
        declared = {(i, state_vr.index(dep.valueReference)) for i, d in enumerate(ders) for dep in d.dependencies
                    if dep.valueReference in state_vr}
        assert {tuple(e) for e in np.argwhere(jac != 0)} == declared
    finally:
        instance.terminate()
        instance.freeInstance()


def test_casadi_imports_the_fmu_and_calls_its_binary(built, tmp_path):
    """A second client: CasADi's DaeBuilder on the unzipped FMI 2.0 FMU (without CasADi's own serialised
    oracle, so FmuFunction calls the binary): the double pendulum's derivatives at 100 random states
    within 1e-12 of the contract's ode."""
    import casadi as ca
    cm, path = built("double_pendulum", 2)
    folder = tmp_path / "unzipped"
    with zipfile.ZipFile(path) as z:
        z.extractall(folder)
    shutil.rmtree(folder / "extra", ignore_errors=True)
    dae = ca.DaeBuilder("dp", str(folder))
    assert list(dae.x()) == list(cm.dae.x_names)
    f = dae.create("f", ["x"], ["ode"])
    assert f.class_name() == "FmuFunction"
    ode = cm.functions()["ode"]
    rng = np.random.default_rng(4)
    for _ in range(100):
        x = rng.uniform(-3, 3, cm.dae.x.numel())
        mine = np.array(ode(0.0, x, np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))).ravel()
        theirs = np.array(f(x)).ravel()
        assert np.max(np.abs(mine - theirs)) <= 1e-12 * max(1.0, np.max(np.abs(mine)))


def _tunable_oscillator():
    from mechnet.components import rotational as rot
    m = mn.Model("osc")
    fixed, spring = m.add(rot.Fixed(name="fixed")), m.add(rot.Spring(name="spring", c=mn.tunable(100.0)))
    j = m.add(rot.Inertia(name="j", J=0.1, phi_start=0.5, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    return m


@pytest.mark.parametrize("fmi", (2, 3))
def test_tunable_parameters_change_the_fmu_as_the_native_model(tmp_path, fmi):
    """spring.c = 400 set through FMI: the FMU's trajectory equals the native one at the same value
    (within 1e-6, rtol 1e-10 both) and the period halves (closed form 2π√(J/c))."""
    cm = _tunable_oscillator().compile()
    path = cm.export(tmp_path / f"osc{fmi}.fmu", kind="fmu", fmi=fmi)
    T = 2 * np.pi * np.sqrt(0.1 / 400.0)
    res = simulate_fmu(str(path), stop_time=T, relative_tolerance=1e-10, output_interval=T / 50,
                       start_values={"spring.c": 400.0}, output=["j.phi"], fmi_type="ModelExchange")
    native = cm.simulate(T, rtol=1e-10, atol=1e-12, params={"spring.c": 400.0}, t_out=res["time"])
    assert np.max(np.abs(res["j.phi"] - native["j.phi"])) < 1e-6
    assert abs(res["j.phi"][-1] - 0.5) < 1e-6


def test_every_parameter_can_be_exposed(tmp_path):
    """mn.every_parameter_tunable(): the inertia J, folded otherwise, becomes an FMI parameter; J = 0.4
    doubles the period like the closed form says."""
    from mechnet.components import rotational as rot
    with mn.every_parameter_tunable():
        m = mn.Model("osc_all")
        fixed, spring = m.add(rot.Fixed(name="fixed")), m.add(rot.Spring(name="spring", c=100.0))
        j = m.add(rot.Inertia(name="j", J=0.1, phi_start=0.5, w_start=0.0))
        m.connect(fixed.flange, spring.flange_a)
        m.connect(spring.flange_b, j.flange_a)
    cm = m.compile()
    assert {"j.J", "spring.c"} <= set(cm.dae.p_names)
    path = cm.export(tmp_path / "all.fmu", kind="fmu")
    names = {v.name: v for v in read_model_description(str(path)).modelVariables}
    assert names["j.J"].causality == "parameter" and names["j.J"].variability == "tunable"
    T = 2 * np.pi * np.sqrt(0.4 / 100.0)
    res = simulate_fmu(str(path), stop_time=T, relative_tolerance=1e-10, output_interval=T / 50,
                       start_values={"j.J": 0.4}, output=["j.phi"], fmi_type="ModelExchange")
    assert abs(res["j.phi"][-1] - 0.5) < 1e-6


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")   # FMPy's callback raising
def test_leaving_the_assembly_branch_is_an_error_with_its_reason(tmp_path):
    """A Cartesian pendulum started above the horizontal: the exported states (y, vy) stop determining x
    at the bottom (x = 0). The FMU returns an error status and logs why; it does not switch silently."""
    cm = cartesian_pendulum(theta0=2.0).compile()
    path = cm.export(tmp_path / "cp.fmu", kind="fmu")
    messages = []
    with pytest.raises(Exception):
        simulate_fmu(str(path), stop_time=3.0, relative_tolerance=1e-8, fmi_type="ModelExchange",
                     logger=lambda *a: messages.append(a[-1]))
    text = " ".join(m.decode() if isinstance(m, bytes) else str(m) for m in messages)
    assert "no longer functions of the states p.y, p.vy" in text


def test_start_values_and_units_are_in_the_model_description(built):
    cm, path = built("four_bar", 2)
    md = read_model_description(str(path))
    names = {v.name: v for v in md.modelVariables}
    meta = cm.functions()["metadata"]
    for s in meta["starts"]:
        v = names[fmi_name(s["name"])]
        assert v.initial == "exact" and float(v.start) == s["value"]
    for v in meta["observed"]:
        assert names[fmi_name(v["name"])].unit == v["unit"]
    assert md.numberOfContinuousStates == len(meta["x"])


# ---- the FMU's C API through FMPy's low-level classes (both versions)

def _instance(md, path, fmi):
    directory = extract(path)
    if fmi == 2:
        from fmpy.fmi2 import FMU2Model
        fmu = FMU2Model(guid=md.guid, unzipDirectory=directory, modelIdentifier=md.modelExchange.modelIdentifier,
                        instanceName="test")
        fmu.instantiate(callbacks=_PERMANENT_CALLBACKS)   # not FMPy's default, whose proxy may point at freed memory
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.newDiscreteStates()
    else:
        from fmpy.fmi3 import FMU3Model
        fmu = FMU3Model(guid=md.guid, unzipDirectory=directory, modelIdentifier=md.modelExchange.modelIdentifier,
                        instanceName="test")
        fmu.instantiate()
        fmu.enterInitializationMode(startTime=0.0)
        fmu.exitInitializationMode()
        fmu.updateDiscreteStates()
    fmu.enterContinuousTimeMode()
    return fmu


def _get_states(fmu, fmi, nx):
    buf = (ctypes.c_double * nx)()
    fmu.getContinuousStates(buf, nx)
    return np.array(buf)


def _set_states(fmu, fmi, x):
    fmu.setContinuousStates((ctypes.c_double * len(x))(*x), len(x))


def _derivatives(fmu, fmi, nx):
    buf = (ctypes.c_double * nx)()
    if fmi == 2:
        fmu.getDerivatives(buf, nx)
    else:
        fmu.getContinuousStateDerivatives(buf, nx)
    return np.array(buf)


def _directional(fmu, fmi, unknowns, knowns, seed):
    return np.array(fmu.getDirectionalDerivative(unknowns, knowns, seed))


@pytest.mark.parametrize("fmi", (2, 3))
def test_modes_are_discrete_variables_switched_at_events(tmp_path, fmi):
    """A relay with hysteresis (tests/models.py Relay: mode `relay.on`) on an inertia held by a spring: the
    mode is a discrete FMI variable with its start value; FMPy (CVode, rtol 1e-10) sees it switch at the
    same times as cm.simulate (rtol 1e-10, atol 1e-12) within 1e-6 s over 3 s, and the angle agrees
    within 1e-6 rad away from the switches."""
    from models import relay_inertia
    cm = relay_inertia(J=0.5, w0=3.0, tau_on=-1.0, phi_on=0.6, phi_off=0.2, c=8.0).compile()
    path = cm.export(tmp_path / f"relay{fmi}.fmu", kind="fmu", fmi=fmi)
    on = next(v for v in read_model_description(str(path)).modelVariables if v.name == "relay.on")
    assert on.variability == "discrete" and float(on.start) == 0.0
    res = simulate_fmu(str(path), stop_time=3.0, relative_tolerance=1e-10, output_interval=0.01,
                       output=["relay.on", "j1.phi"], fmi_type="ModelExchange")
    t = res["time"]
    keep = _grid_rows(t)
    native = cm.simulate(3.0, rtol=1e-10, atol=1e-12, t_out=t[keep])
    rows = _rows_at(native, t[keep])
    assert np.max(np.abs(res["j1.phi"][keep] - native["j1.phi"][rows])) < 1e-6
    switches = [e.t for e in native.events if e.kind == "state"]
    assert len(switches) >= 4                                   # closes and opens at least twice
    fmu_switches = t[1:][np.diff(res["relay.on"]) != 0]
    assert len(fmu_switches) == len(switches)
    assert np.max(np.abs(fmu_switches - np.array(switches))) < 1e-6
    assert set(np.unique(res["relay.on"])) == {0.0, 1.0}


class _Chatter(mn.Component):
    """x grows at 1 m/s; at x = 1 mode m is set, which throws `drop` across (it clears m), which throws
    `raise` across (it sets m again), and so on: resets that make each other fire without end."""

    x = mn.Var(unit="m")
    m = mn.Mode(0.0)

    def equations(self):
        return [mn.Eq(mn.der(self.x), 1.0)]

    def events(self):
        return [mn.When(self.x - 1.0, reset={self.m: 1.0}, direction="rising", doc="start"),
                mn.When(self.m - 0.5, reset={self.m: 0.0}, direction="rising", doc="drop"),
                mn.When(0.5 - self.m, reset={self.m: 1.0}, direction="rising", doc="raise")]


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_events_that_never_settle_are_an_error_naming_the_condition(tmp_path):
    """The FMU iterates its discrete-state update while conditions fire (FMI's event iteration); after 100
    rounds at one time it returns an error whose log names the component and a condition. The native
    run stops there too (x reaches 1 at t = 0.7 s), with an event accumulation, keeping the result so far."""
    model = mn.Model("chatter")
    model.add(_Chatter(name="chatter", x_start=0.3))
    cm = model.compile()
    with pytest.warns(mn.IntegrationWarning, match="event accumulation"):
        native = cm.simulate(2.0)
    assert native.failure is not None and "event accumulation at t = 0.7 s" in str(native.failure)
    path = cm.export(tmp_path / "chatter.fmu", kind="fmu")
    messages = []
    with pytest.raises(Exception, match="status 3"):
        simulate_fmu(str(path), stop_time=2.0, fmi_type="ModelExchange", logger=lambda *a: messages.append(a[-1]))
    text = " ".join(m.decode() if isinstance(m, bytes) else str(m) for m in messages)
    assert "events keep firing after 100 rounds" in text and "chatter (_Chatter), event" in text


@pytest.mark.parametrize("fmi", (2, 3))
def test_vectors_of_the_wrong_length_are_refused(built, fmi):
    """An importer passing more or fewer states than the model has gets an error status, not a write past
    the FMU's arrays."""
    cm, path = built("double_pendulum", fmi)
    md = read_model_description(str(path))
    instance = _instance(md, str(path), fmi)
    try:
        nx = md.numberOfContinuousStates
        with pytest.raises(Exception, match="status 3"):
            _set_states(instance, fmi, np.zeros(nx + 1))
        with pytest.raises(Exception, match="status 3"):
            _derivatives(instance, fmi, nx - 1)
        assert np.all(np.isfinite(_derivatives(instance, fmi, nx)))     # the instance still works
    finally:
        instance.terminate()
        instance.freeInstance()


@pytest.mark.parametrize("fmi", (2, 3))
def test_event_iteration_fires_a_condition_a_reset_threw_across(tmp_path, fmi):
    """tests/models.py Cascade: mode a set at x = 1 makes the second condition cross at the same instant;
    FMPy's run ends with both modes set, as the native run does, and both switch at t = 0.7 s (within
    1e-6 s: CVode's event location at its default tolerance)."""
    from models import cascade
    cm = cascade().compile()
    path = cm.export(tmp_path / f"cascade{fmi}.fmu", kind="fmu", fmi=fmi)
    res = simulate_fmu(str(path), stop_time=2.0, fmi_type="ModelExchange", output=["c.a", "c.b"])
    native = cm.simulate(2.0)
    assert res["c.a"][-1] == native["c.a"][-1] == 1.0 and res["c.b"][-1] == native["c.b"][-1] == 1.0
    t = res["time"]
    for mode in ("c.a", "c.b"):
        assert abs(t[1:][np.diff(res[mode]) != 0][0] - 0.7) < 1e-6


class _StartOnOutput(mn.Component):
    """der(x) = -x with an output y = x + u whose start value is fixed: x(0) = 1 - u depends on the input."""

    u = mn.Input(unit="1")
    x = mn.Var(unit="1")
    y = mn.Output(unit="1")

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.x), mn.Eq(self.y, self.x + self.u)]


def test_an_input_set_in_initialisation_mode_redoes_the_start(tmp_path):
    """Read in initialisation mode, then set the input, then read again (what a master's initialisation
    loop does): the start is solved again with the new input, x(0) = y_start - u = 0.5, as natively."""
    from fmpy.fmi2 import FMU2Model
    m = mn.Model("start_on_output")
    m.add(_StartOnOutput(name="c", y_start=1.0))
    cm = m.compile()
    assert abs(cm.simulate(0.1, inputs={"c.u": 0.5})["c.x"][0] - 0.5) < 1e-12
    path = cm.export(tmp_path / "initu.fmu", kind="fmu")
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.modelExchange.modelIdentifier,
                    instanceName="initu")
    fmu.instantiate(callbacks=_PERMANENT_CALLBACKS)
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        assert abs(fmu.getReal([vr["c.x"]])[0] - 1.0) < 1e-12          # with u at its default 0
        fmu.setReal([vr["c.u"]], [0.5])
        x, y = fmu.getReal([vr["c.x"], vr["c.y"]])
        assert abs(x - 0.5) < 1e-12 and abs(y - 1.0) < 1e-12
        fmu.exitInitializationMode()
    finally:
        fmu.terminate()
        fmu.freeInstance()


def test_initial_unknowns_depend_on_the_modes_they_start_from(tmp_path):
    """The relay's torque is on·tau_on: at the start, der(j1.w) depends on the mode relay.on (an exact
    start value the importer may set), and ModelStructure says so."""
    from models import relay_inertia
    path = relay_inertia().compile().export(tmp_path / "relay.fmu", kind="fmu")
    md = read_model_description(str(path))
    on = next(v for v in md.modelVariables if v.name == "relay.on")
    der_w = next(u for u in md.initialUnknowns if u.variable.name == "der(j1.w)")
    assert on in der_w.dependencies


def test_fmus_are_refused_off_linux_x86_64(tmp_path, monkeypatch):
    """The binary inside is built for linux64 / x86_64-linux; elsewhere the export says so instead of
    mislabelling it."""
    import platform
    monkeypatch.setattr(platform, "machine", lambda: "aarch64")
    cm = _tunable_oscillator().compile()
    with pytest.raises(mn.MechnetError, match="Linux on x86_64 only.*aarch64.*kind='c' or 'casadi'"):
        cm.export(tmp_path / "osc.fmu", kind="fmu")
