"""The FMU's C wrapper refuses what an importer should not pass (issue 32, item 1): an FMI 3.0 buffer of another
length than its value references need (nValues, nSeed, nSensitivity: once 4 references with nValues = 1 wrote
3 doubles past the caller's buffer), and NaN or infinite times, states, inputs and parameters, in FMI 2.0
and 3.0. Each is an error status with the reason logged, and leaves the instance as it was.

The calls go to the binary's functions directly (ctypes), not through FMPy's wrappers, which size the
buffers themselves and raise on an error status."""
import ctypes
import math

import pytest

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.export import compiler

fmpy = pytest.importorskip("fmpy", reason="fmpy (extra 'test') loads FMUs")
from fmpy import extract, read_model_description  # noqa: E402

pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler ($CC, cc, gcc or clang) to build FMUs")
MESSAGES = []


def _log2(env, name, status, category, message):
    MESSAGES.append(message.decode() if isinstance(message, bytes) else str(message))


def _log3(env, status, category, message):
    MESSAGES.append(message.decode() if isinstance(message, bytes) else str(message))


# FMPy's native proxy formats the wrapper's "%s" messages for Python, calling the logger of the callbacks
# last given to it (other tests give it theirs, which die with them): each FMI 2.0 instance here gets fresh
# callbacks registered just before it is made, kept for the whole session
_KEPT = []


def _callbacks2():
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    from fmpy.logging import addLoggerProxy
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(_log2)
    addLoggerProxy(ctypes.byref(callbacks))
    _KEPT.append(callbacks)
    return callbacks


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    m = mn.Model("driven")
    j = m.add(rot.Inertia(name="j", J=mn.tunable(2.0), phi_start=0.5, w_start=0.0))
    tq = m.add(rot.Torque(name="tq"))
    m.connect(tq.flange, j.flange_a)
    cm = m.compile()
    folder = tmp_path_factory.mktemp("guards")
    return {fmi: cm.export(folder / f"driven{fmi}.fmu", kind="fmu", fmi=fmi) for fmi in (2, 3)}


class _Instance:
    """An FMU instance in continuous-time mode, its raw C functions by name, its variables' references."""

    def __init__(self, path, fmi):
        md = read_model_description(str(path))
        self.fmi, self.vr = fmi, {v.name: v.valueReference for v in md.modelVariables}
        self.causality = {v.name: v.causality for v in md.modelVariables}
        kw = dict(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.modelExchange.modelIdentifier,
                  instanceName="guarded")
        if fmi == 2:
            from fmpy.fmi2 import FMU2Model
            self.fmu = FMU2Model(**kw)
            self.fmu.instantiate(callbacks=_callbacks2())
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
            self.fmu.newDiscreteStates()
        else:
            from fmpy.fmi3 import FMU3Model
            self.fmu = FMU3Model(**kw)
            self.fmu.instantiate(logMessage=_log3)
            self.fmu.enterInitializationMode(startTime=0.0)
            self.fmu.exitInitializationMode()
            self.fmu.updateDiscreteStates()
        self.fmu.enterContinuousTimeMode()
        MESSAGES.clear()

    def raw(self, name, *argtypes):
        """The binary's function `name`, without FMPy's error check (a new ctypes object each time)."""
        f = self.fmu.dll[name]
        f.restype, f.argtypes = ctypes.c_int, [ctypes.c_void_p, *argtypes]
        return lambda *args: f(self.fmu.component, *args)

    def get(self, names):
        return self.get_vr([self.vr[n] for n in names])

    def get_vr(self, refs):
        vrs = (ctypes.c_uint32 * len(refs))(*refs)
        out = (ctypes.c_double * len(refs))()
        if self.fmi == 2:
            status = self.raw("fmi2GetReal", ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p)(vrs, len(refs), out)
        else:
            status = self.raw("fmi3GetFloat64", ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t)(
                vrs, len(refs), out, len(refs))
        assert status == 0
        return list(out)

    def set(self, name, value):
        vrs, values = (ctypes.c_uint32 * 1)(self.vr[name]), (ctypes.c_double * 1)(value)
        if self.fmi == 2:
            return self.raw("fmi2SetReal", ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p)(vrs, 1, values)
        return self.raw("fmi3SetFloat64", ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t)(
            vrs, 1, values, 1)

    def states(self):
        out = (ctypes.c_double * 2)()
        self.raw(f"fmi{self.fmi}GetContinuousStates", ctypes.c_void_p, ctypes.c_size_t)(out, 2)
        return list(out)

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture(params=(2, 3))
def instance(request, fmus):
    made = _Instance(fmus[request.param], request.param)
    yield made
    made.close()


def _names(instance, causality):
    return [n for n, c in instance.causality.items() if c == causality]


@pytest.mark.parametrize("fmi", (3,))
@pytest.mark.parametrize("n_values", (1, 3, 5, 0))
def test_fmi3_get_float64_refuses_a_buffer_of_another_length(fmus, fmi, n_values):
    inst = _Instance(fmus[3], 3)
    try:
        names = list(inst.vr)[1:5]                     # 4 scalar variables (0 is time)
        assert len(names) == 4
        vrs = (ctypes.c_uint32 * 4)(*(inst.vr[n] for n in names))
        guard = 12345.0
        buffer = (ctypes.c_double * 8)(*[guard] * 8)
        get = inst.raw("fmi3GetFloat64", ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t)
        assert get(vrs, 4, buffer, n_values) == 3
        assert list(buffer) == [guard] * 8             # nothing written, past the buffer or in it
        assert any("nValues" in m and "scalar" in m for m in MESSAGES), MESSAGES
        assert get(vrs, 4, buffer, 4) == 0 and list(buffer[4:]) == [guard] * 4
    finally:
        inst.close()


def test_fmi3_set_float64_and_directional_derivatives_check_their_lengths(fmus):
    inst = _Instance(fmus[3], 3)
    try:
        u = _names(inst, "input")[0]
        before = inst.get([u])
        vrs, values = (ctypes.c_uint32 * 1)(inst.vr[u]), (ctypes.c_double * 2)(7.0, 8.0)
        set_ = inst.raw("fmi3SetFloat64", ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t)
        assert set_(vrs, 1, values, 2) == 3 and inst.get([u]) == before
        state = next(n for n in inst.vr if n.startswith("j.phi") or n == "j.phi")
        der = next(n for n in inst.vr if n.startswith("der("))
        known, unknown = (ctypes.c_uint32 * 1)(inst.vr[state]), (ctypes.c_uint32 * 1)(inst.vr[der])
        seed, sens = (ctypes.c_double * 1)(1.0), (ctypes.c_double * 4)(*[99.0] * 4)
        directional = inst.raw("fmi3GetDirectionalDerivative", ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p,
                               ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t)
        assert directional(unknown, 1, known, 1, seed, 1, sens, 3) == 3 and list(sens) == [99.0] * 4
        assert directional(unknown, 1, known, 1, seed, 2, sens, 1) == 3
        assert any("nSensitivity" in m for m in MESSAGES) and any("nSeed" in m for m in MESSAGES), MESSAGES
        assert directional(unknown, 1, known, 1, seed, 1, sens, 1) == 0 and list(sens[1:]) == [99.0] * 3
    finally:
        inst.close()


@pytest.mark.parametrize("bad", (math.nan, math.inf, -math.inf))
def test_non_finite_time_and_states_are_refused(instance, bad):
    set_time = instance.raw(f"fmi{instance.fmi}SetTime", ctypes.c_double)
    assert set_time(0.25) == 0
    assert set_time(bad) == 3
    assert instance.get_vr([0]) == [0.25]                # value reference 0: the time
    assert any("set time" in m and "not finite" in m for m in MESSAGES), MESSAGES
    MESSAGES.clear()
    before = instance.states()
    set_states = instance.raw(f"fmi{instance.fmi}SetContinuousStates", ctypes.c_void_p, ctypes.c_size_t)
    assert set_states((ctypes.c_double * 2)(1.0, bad), 2) == 3
    assert instance.states() == before
    assert any("set continuous states: state j." in m and "not finite" in m for m in MESSAGES), MESSAGES


@pytest.mark.parametrize("bad", (math.nan, math.inf))
@pytest.mark.parametrize("causality", ("input", "parameter"))
def test_non_finite_inputs_and_parameters_are_refused(instance, causality, bad):
    if causality == "parameter":
        enter = instance.raw(f"fmi{instance.fmi}EnterEventMode")
        assert enter() == 0                           # tunable parameters change in event mode
    name = _names(instance, causality)[0]
    before = instance.get([name])
    assert instance.set(name, bad) == 3
    assert instance.get([name]) == before
    assert any(name in m and "not finite" in m for m in MESSAGES), MESSAGES


def test_a_non_finite_start_time_is_refused(fmus):
    from fmpy.fmi3 import FMU3Model
    md = read_model_description(str(fmus[3]))
    fmu = FMU3Model(guid=md.guid, unzipDirectory=extract(str(fmus[3])), instanceName="start",
                    modelIdentifier=md.modelExchange.modelIdentifier)
    fmu.instantiate(logMessage=_log3)
    try:
        MESSAGES.clear()
        enter = fmu.dll["fmi3EnterInitializationMode"]
        enter.restype = ctypes.c_int
        enter.argtypes = [ctypes.c_void_p, ctypes.c_bool, ctypes.c_double, ctypes.c_double, ctypes.c_bool,
                          ctypes.c_double]
        assert enter(fmu.component, False, 0.0, math.nan, False, 0.0) == 3
        assert any("start time" in m for m in MESSAGES), MESSAGES
    finally:
        fmu.freeInstance()
