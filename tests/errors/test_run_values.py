"""Values entering a run after construction are checked as at construction, and a run never returns rows
that are not a solution (issue 31, item 4).

- a start the model cannot be integrated from (a derivative not finite there, a zero quaternion) is
  refused by name before integrating; a quaternion start of any length is scaled to |Q| = 1;
- `continue_from=res` with another `t_start`, `t_out` or with `start=` values is refused, naming the conflict;
- the requirements between parameters (mu_s >= mu_k, phi_max > phi_min: `core/requirements.py`) hold for
  values given through `simulate(params=)`, `cm.prepare` and a model loaded from an export;
- a failed run's partial result ends at its last finite row.
"""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from models import oscillator, stick_slip_block, stopped_oscillator


class Reciprocal(mn.Component):
    """der(x) = 1/x: not finite at x = 0."""

    x = mn.State(unit="1")

    def equations(self):
        return [mn.Eq(mn.der(self.x), 1 / self.x)]


def _spherical(**kw):
    """A body hung from a Spherical joint (L = 0.5 m below it along z)."""
    m = mn.Model("top")
    world = m.add(mb.World(name="world"))
    joint = m.add(mb.Spherical(name="sph", w_rel_start=[1.0, 2.0, 3.0], **kw))
    body = m.add(mb.Body(name="body", m=1.0, r_cm=[0.0, 0.0, 0.5], I=np.diag([0.02, 0.01, 0.03])))
    m.connect(world.frame_b, joint.frame_a)
    m.connect(joint.frame_b, body.frame_a)
    return m.compile()


@pytest.fixture(scope="module")
def osc():
    return oscillator().compile()


# ---- starts that are no point to integrate from ----------------------------------------------------

def test_a_derivative_not_finite_at_the_start_is_refused_by_name():
    m = mn.Model("reciprocal")
    m.add(Reciprocal(name="r", x_start=0.0))
    with pytest.raises(mn.InitializationError, match=re.escape("der(r.x) = inf at the start")):
        m.compile().simulate(1.0, n_out=5)


def test_a_start_whose_forces_overflow_is_refused_naming_it(osc):
    # phi = 1e308 is finite, the spring torque c·phi is not: the run used to return one row of -inf
    with pytest.raises(mn.InitializationError, match=r"der\(j1\.w\) = -inf at the start, from j1\.phi = 1e\+308"):
        osc.simulate(1.0, n_out=5, start={"j1.phi": 1e308})


@pytest.mark.parametrize("argument", ["start", "guess"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_start_or_guess_names_the_argument_and_variable(osc, argument, value):
    with pytest.raises(mn.InitializationError, match=rf"simulate\({argument}=\.\.\.\).*j1\.phi = {value}"):
        osc.simulate(1.0, n_out=5, **{argument: {"j1.phi": value}})


def test_a_zero_quaternion_given_through_start_is_refused():
    cm = _spherical()
    zero = {f"sph.Q[{k}]": 0.0 for k in range(4)}
    with pytest.raises(mn.InitializationError, match=r"sph\.Q\[0\], .*sph\.Q\[3\] starts at .*zero quaternion"):
        cm.simulate(1.0, n_out=5, start=zero)


def test_a_quaternion_start_is_judged_zero_alike_when_built_and_when_given_to_a_run():
    """|Q| <= 1e-12 is no orientation as Q_start and through simulate(start=...) alike: one threshold,
    not the constructor's 1e-12 and the run's exact zero (which |Q| = 1e-200 reached by underflow)."""
    tiny = [0.0, 0.0, 0.0, 1e-200]
    with pytest.raises(mn.ParameterError, match="zero quaternion"):
        _spherical(Q_start=tiny)
    with pytest.raises(mn.InitializationError, match="zero quaternion"):
        _spherical().simulate(0.1, n_out=3, start={f"sph.Q[{k}]": v for k, v in enumerate(tiny)})


def test_a_quaternion_start_of_length_two_is_scaled_to_one_in_the_first_row():
    """Q_start = [2, 0, 0, 0] is the identity orientation (R uses Q/|Q|); the first row used to read |Q| = 2."""
    res = _spherical(Q_start=[2.0, 0.0, 0.0, 0.0]).simulate(0.5, n_out=6, rtol=1e-10, atol=1e-12)
    Q = np.column_stack([res[f"sph.Q[{k}]"] for k in range(4)])
    np.testing.assert_allclose(Q[0], [1.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-15)
    reference = _spherical(Q_start=[1.0, 0.0, 0.0, 0.0]).simulate(0.5, n_out=6, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(res["body.frame_a.r_0[2]"], reference["body.frame_a.r_0[2]"], rtol=0, atol=1e-12)


# ---- continued runs ---------------------------------------------------------------------------

def test_continue_from_with_another_t_start_is_refused(osc):
    first = osc.simulate(1.0, n_out=5)
    with pytest.raises(mn.MechnetError, match=r"continue_from=res goes on from res's final time 1 s.*t_start = 0\.5 s"):
        osc.simulate(2.0, n_out=5, continue_from=first, t_start=0.5)
    with pytest.raises(mn.MechnetError, match=r"continue_from=res .* t_out starts at 0\.5 s"):
        osc.simulate(2.0, t_out=[0.5, 1.0, 2.0], continue_from=first)


def test_continue_from_with_start_values_is_refused(osc):
    first = osc.simulate(1.0, n_out=5)
    jump = r"continue_from=res starts from res's final state.*\(j1\.phi\) would jump"
    with pytest.raises(mn.MechnetError, match=jump):
        osc.simulate(2.0, n_out=5, continue_from=first, start={"j1.phi": 3.0})


def test_continue_from_at_its_own_final_time_still_runs(osc):
    """Guard for the two tests above: t_start = res.final_time is no conflict, and the run goes on."""
    first = osc.simulate(1.0, n_out=5, rtol=1e-10, atol=1e-12)
    second = osc.simulate(2.0, n_out=5, continue_from=first, t_start=1.0, rtol=1e-10, atol=1e-12)
    w = np.sqrt(100.0 / 0.1)
    assert second["j1.phi"][-1] == pytest.approx(0.5 * np.cos(w * 2.0), abs=1e-7)


# ---- requirements between parameters, wherever a value enters ---------------------------------------

@pytest.fixture(scope="module")
def friction():
    with mn.every_parameter_tunable():
        return stick_slip_block().compile()


@pytest.fixture(scope="module")
def stops():
    with mn.every_parameter_tunable():
        return stopped_oscillator().compile()


FRICTION_BROKEN = r"fr \(Friction\): mu_s = 0\.1 is below mu_k = 0\.2; mu_s must be >= mu_k"
STOPS_BROKEN = r"stop \(HardStop\): s_max = 0\.05 is not above s_min = 0\.06; s_max must be > s_min"


def test_construction_refuses_mu_s_below_mu_k():
    from mechnet.components import translational as tr
    with pytest.raises(mn.ParameterError, match=FRICTION_BROKEN):
        tr.Friction(name="fr", fn=1.0, mu_k=0.2, mu_s=0.1)
    with pytest.raises(mn.ParameterError, match=r"stop \(HardStop\): phi_max = -1 is not above phi_min = 1"):
        rot.HardStop(name="stop", phi_min=1.0, phi_max=-1.0)


def test_simulate_params_refuses_mu_s_below_mu_k(friction):
    with pytest.raises(mn.ParameterError, match=r"simulate\(params=\.\.\.\): " + FRICTION_BROKEN):
        friction.simulate(1.0, n_out=5, params={"fr.mu_s": 0.1})


def test_simulate_params_refuses_reversed_stop_limits(stops):
    # used to fail as an InitializationError about the start position, which was not the culprit
    with pytest.raises(mn.ParameterError, match=STOPS_BROKEN):
        stops.simulate(1.0, n_out=5, params={"stop.s_min": 0.06})


def test_a_prepared_run_refuses_mu_s_below_mu_k(friction):
    run = friction.prepare(0.5, n_out=5)
    run(params={"fr.mu_s": 0.4})                 # a first call that decides the path
    with pytest.raises(mn.ParameterError, match=FRICTION_BROKEN):
        run(params={"fr.mu_s": 0.1})


def test_both_coefficients_changed_together_are_checked_together(friction):
    """Guard: mu_k and mu_s raised in one call are judged together (0.5 >= 0.45), not one at a time."""
    res = friction.simulate(0.2, n_out=3, params={"fr.mu_k": 0.45, "fr.mu_s": 0.5})
    assert res.success


def test_a_loaded_export_refuses_mu_s_below_mu_k(friction, tmp_path):
    from mechnet.export import load
    friction.export(tmp_path / "fr", kind="casadi")
    loaded = load(tmp_path / "fr")
    with pytest.raises(mn.ParameterError, match=FRICTION_BROKEN):
        loaded.simulate(1.0, n_out=5, params={"fr.mu_s": 0.1})


class Decay(mn.Component):
    """der(x) = −k·x, k checked by the user's own function (which an export cannot name)."""

    k = mn.Param(1.0, unit="1/s", check=lambda value: None if value < 1e3 else "too fast")
    x = mn.State(unit="1")

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.k * self.x)]


def test_a_loaded_export_refuses_a_nan_parameter_whose_check_it_cannot_name(tmp_path):
    from mechnet.export import load
    m = mn.Model("decay")
    m.add(Decay(name="decay", k=mn.tunable(2.0), x_start=1.0))
    m.compile().export(tmp_path / "decay", kind="casadi")
    loaded = load(tmp_path / "decay")
    with pytest.raises(mn.ParameterError, match=r"simulate\(params=\{'decay\.k': \.\.\.\}\).*not finite"):
        loaded.simulate(1.0, n_out=5, params={"decay.k": np.nan})


# ---- a failed run ends at its last finite row -----------------------------------------------------

def test_a_failed_run_ends_at_its_last_finite_row(osc):
    """Rows past the failure that hold inf or NaN (whatever wrote them) are cut, and the failure says so."""
    from mechnet.simulate import integrator

    res = osc.simulate(1.0, n_out=5)
    run = _FailedRun(osc.dae, res, bad_from=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mn.IntegrationWarning)
        out = integrator.assemble(osc, osc.dae, run, 0.0, [], _Initial(), _Plan(osc.dae), np.zeros(0))
    np.testing.assert_array_equal(out.t, res.t[:3])
    assert np.all(np.isfinite(out.values))
    assert out.final_time == res.t[2]
    assert out.failure.t == res.t[2] and "were dropped" in str(out.failure)


class _Initial:
    fixed, free_states, residual = [], [], 0.0


class _Plan:
    def __init__(self, dae):
        self.n = len(dae.u_names)

    def at(self, t):
        return np.zeros((self.n, np.size(t)))


class _FailedRun:
    """What `assemble` reads of a run: `res`'s rows, the states from row `bad_from` on overwritten by
    NaN, and a failure at the last of them."""

    def __init__(self, dae, res, bad_from):
        from types import SimpleNamespace

        from mechnet.simulate.rows import Rows

        X = np.array(res.x, dtype=float)
        X[bad_from:] = np.nan
        self.rows = Rows()
        self.rows.add(res.t, X, np.zeros((res.t.size, 0)), dae, np.array(dae.d_value, dtype=float))
        self.events, self.choice = [], SimpleNamespace(plugin="cvodes")
        self.stats = {}
        self.failure = mn.IntegrationError("integration failed", t=float(res.t[-1]), step=1e-3, worst="j1.phi",
                                           solver_message="CV_ERR_FAILURE")
        self._u_at = lambda t: np.zeros(len(dae.u_names))


def test_a_loaded_export_keeps_a_check_defined_outside_declarations(stops, tmp_path):
    """The coefficient of restitution's check lives in components/switched.py: a loaded model used to
    accept e = 2 (model.json named no check it could find)."""
    from mechnet.export import load
    stops.export(tmp_path / "stops", kind="casadi")
    loaded = load(tmp_path / "stops")
    with pytest.raises(mn.ParameterError, match=r"stop \(HardStop\): parameter e = 2(\.0)? must lie in \[0, 1\]"):
        loaded.simulate(1.0, n_out=5, params={"stop.e": 2.0})
    with pytest.raises(mn.ParameterError, match=STOPS_BROKEN):
        loaded.simulate(1.0, n_out=5, params={"stop.s_min": 0.06})


_KEPT = []


def _callbacks():
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    if not _KEPT:
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(lambda *args: None)
        _KEPT.append(callbacks)
    return _KEPT[0]


# FMPy's CVode wrapper of a run refused at its start is collected later and calls back into a freed
# solver (an ignored ValueError in a ctypes callback): FMPy's, not the FMU's
_FMPY_LEFTOVERS = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")


def _refused_at_initialisation(friction, tmp_path, start_values):
    """Build the friction FMU, run it in FMPy with `start_values` (the run must fail): (what it logged,
    the FMU's path)."""
    fmpy = pytest.importorskip("fmpy", reason="fmpy (extra 'test') runs FMUs")
    from mechnet.export.files import compiler
    if compiler() is None:
        pytest.skip("no C compiler to build the FMU")
    path = friction.export(tmp_path / "fr.fmu", kind="fmu")
    messages = []
    with pytest.raises(Exception):
        fmpy.simulate_fmu(str(path), stop_time=0.5, fmi_type="ModelExchange", start_values=start_values,
                          logger=lambda *a: messages.append(a[-1]))
    return " ".join(m.decode() if isinstance(m, bytes) else str(m) for m in messages), path


@_FMPY_LEFTOVERS
def test_an_fmu_refuses_mu_s_below_mu_k_at_the_end_of_initialisation(friction, tmp_path):
    """The FMU's C wrapper reads the same requirements (model_data.h): parameter values set before
    initialisation are judged together when it ends, and a broken one is an error naming it."""
    text, path = _refused_at_initialisation(friction, tmp_path, {"fr.mu_s": 0.1})
    import fmpy
    assert "fr (Friction): mu_s must be >= mu_k" in text and "0.1 and 0.2" in text
    res = fmpy.simulate_fmu(str(path), stop_time=0.5, fmi_type="ModelExchange", start_values={"fr.mu_s": 0.4})
    assert res["time"][-1] == pytest.approx(0.5)          # guard: a value that keeps it runs


@_FMPY_LEFTOVERS
def test_an_fmu_refuses_a_broken_tuning_in_event_mode_whole(friction, tmp_path):
    """In event mode a call that sets mu_s below mu_k, or sets it and then fails on a variable that cannot
    be set, or sets a parameter to NaN or outside its own check's range (mu_k < 0), is refused whole:
    mu_s and a state set in the same call keep their values (FMI 2 ME through FMPy)."""
    pytest.importorskip("fmpy", reason="fmpy (extra 'test') runs FMUs")
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model
    from mechnet.export.files import compiler
    if compiler() is None:
        pytest.skip("no C compiler to build the FMU")
    path = friction.export(tmp_path / "fr.fmu", kind="fmu")
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    calculated = vr["mass.a"]                            # an acceleration: calculated, never set
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(path)),
                    modelIdentifier=md.modelExchange.modelIdentifier, instanceName="fr")
    # callbacks of our own, kept alive by the module: FMPy's default logger proxy points at the logger of
    # the last simulate_fmu(logger=...) call, freed since, and the refusals below log through it
    fmu.instantiate(loggingOn=False, callbacks=_callbacks())
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()                     # now in event mode
        watched = [vr["fr.mu_s"], vr["mass.s"]]
        before = fmu.getReal(watched)
        for refs, values in (([vr["fr.mu_s"]], [0.1]),                      # below mu_k = 0.2
                             ([vr["fr.mu_s"], calculated], [0.5, 1.0]),      # then a variable it cannot set
                             ([vr["fr.mu_s"]], [float("nan")]),
                             ([vr["fr.mu_k"], vr["fr.mu_s"]], [-0.1, 0.4]),  # mu_k's own check: >= 0
                             ([vr["mass.s"], vr["fr.mu_s"]], [0.7, 0.1])):   # a state with it: kept too
            with pytest.raises(Exception):
                fmu.setReal(refs, values)
            assert fmu.getReal(watched) == before
        fmu.setReal([vr["fr.mu_s"]], [0.5])              # guard: a value that keeps the requirement is taken
        assert fmu.getReal([vr["fr.mu_s"]])[0] == 0.5
    finally:
        fmu.terminate()
        fmu.freeInstance()


def test_a_loaded_export_calls_nothing_but_parameter_checks(stops, tmp_path, monkeypatch):
    """model.json names each parameter's check; `load` calls only functions marked as parameter checks of
    modules mechnet has loaded: a file that names another function (here mechnet.cli's main) is refused,
    naming the entry, and the function is never called."""
    import json

    import mechnet.cli
    from mechnet.export import ExportError, load
    called = []
    monkeypatch.setattr(mechnet.cli, "main", lambda *a, **k: called.append(a))
    stops.export(tmp_path / "stops", kind="casadi")
    record = json.loads((tmp_path / "stops" / "model.json").read_text())
    k, entry = next((k, v) for k, v in enumerate(record["p"]) if v["name"] == "stop.e")
    assert entry["check"] == "mechnet.components.switched:restitution"
    entry["check"] = "mechnet.cli:main"
    (tmp_path / "stops" / "model.json").write_text(json.dumps(record))
    with pytest.raises(ExportError, match=re.escape(f"p[{k}]['check']")):
        load(tmp_path / "stops")
    assert called == []


@_FMPY_LEFTOVERS
def test_an_fmu_refuses_a_parameter_outside_its_own_check(friction, tmp_path):
    """A parameter's own check (mass m > 0) is kept by the FMU as a range: a value set before
    initialisation outside it is an error naming the parameter when initialisation ends."""
    text, _ = _refused_at_initialisation(friction, tmp_path, {"mass.m": -1.0})
    assert "parameter mass.m = -1 must be > 0" in text
