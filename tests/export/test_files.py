"""cm.export(kind="casadi" | "c") and export.load: files that give the model back without its scene.

Settings: random points drawn with a fixed seed; trajectories at rtol 1e-8, atol 1e-10 over 2 s.
"""
import json

import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.export import ExportError, ExportWarning, c_identifiers, compiler, load, load_library
from mechnet.scene import load_scene
from models import cartesian_pendulum

EXAMPLES = __import__("pathlib").Path(__file__).parents[2] / "examples"
needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler ($CC, cc, gcc or clang) on this machine")


def example(name):
    return load_scene(EXAMPLES / f"{name}.py").build().compile()


def random_args(f, rng, n=100):
    """n random points for a Function of (t, x, z, u, p, d), each argument in [-1, 1]."""
    return [[rng.uniform(-1, 1, size=f.size_in(k)) for k in range(f.n_in())] for _ in range(n)]


@pytest.fixture(scope="module")
def double_pendulum():
    return example("double_pendulum")


@pytest.fixture(scope="module")
def four_bar():
    return example("four_bar")


def test_loaded_functions_are_bitwise_the_exported_ones(tmp_path, four_bar):
    path = four_bar.export(tmp_path / "fb")
    model = load(path)
    fns, back = four_bar.functions(), model.functions()
    rng = np.random.default_rng(0)
    for name in ("ode", "alg", "observed", "invariants", "zero", "jac_ode", "forward", "alg_jac"):
        for args in random_args(fns[name], rng, 20):
            for a, b in zip(fns[name].call(args), back[name].call(args)):
                assert np.array_equal(np.array(a), np.array(b)), name
    assert model.dae.observed_names == four_bar.dae.observed_names
    assert json.loads((path / "model.json").read_text())["kind"] == "casadi"


def test_loaded_model_simulates_like_the_scene(tmp_path, double_pendulum, four_bar):
    """Without the scene code: the double pendulum (one choice of states) gives the same numbers bit for
    bit; the four-bar (the simulator switches to the whole-branch choice at t = 0, the export holds that
    choice from the start) agrees in its states within 10·rtol·(1 + |x|) over 2 s."""
    model = load(double_pendulum.export(tmp_path / "dp"))
    a = double_pendulum.simulate(2.0, rtol=1e-8, atol=1e-10)
    b = model.simulate(2.0, rtol=1e-8, atol=1e-10)
    for name in double_pendulum.dae.observed_names:
        assert np.array_equal(a[name], b[name]), name
    model = load(four_bar.export(tmp_path / "fb"))
    assert "hold on the whole branch" in model.summary()
    a = four_bar.simulate(2.0, rtol=1e-8, atol=1e-10)
    b = model.simulate(2.0, rtol=1e-8, atol=1e-10)
    for name in model.dae.x_names:
        assert np.max(np.abs(a[name] - b[name])) <= 10 * 1e-8 * (1 + np.max(np.abs(a[name]))), name
    # tunable parameters keep their checks: a loaded model refuses what the scene refused
    assert model.dae.p_names == four_bar.dae.p_names


def test_loaded_parameters_change_the_results_as_native_ones(tmp_path):
    """An oscillator with a tunable stiffness: the loaded model's period at c = 400 is half the one at
    c = 100 (closed form T = 2π √(J/c)), like the native model's, to 1e-9 (rtol 1e-10)."""
    from models import oscillator
    m = mn.Model("osc")
    from mechnet.components import rotational as rot
    fixed, spring = m.add(rot.Fixed(name="fixed")), m.add(rot.Spring(name="spring", c=mn.tunable(100.0)))
    j = m.add(rot.Inertia(name="j", J=0.1, phi_start=0.5, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j.flange_a)
    cm = m.compile()
    model = load(cm.export(tmp_path / "osc"))
    T = 2 * np.pi * np.sqrt(0.1 / 400.0)
    for which in (cm, model):
        res = which.simulate(T, params={"spring.c": 400.0}, rtol=1e-10, atol=1e-12)
        assert abs(res["j.phi"][-1] - 0.5) < 1e-9
    with pytest.raises(mn.ParameterError, match="spring.c"):
        model.simulate(1.0, params={"spring.c": -1.0})
    del oscillator


def test_export_refuses_an_existing_path(tmp_path, double_pendulum):
    target = tmp_path / "out"
    target.mkdir()
    (target / "keep.txt").write_text("mine")
    with pytest.raises(ExportError, match="exists; pass overwrite=True"):
        double_pendulum.export(target)
    assert (target / "keep.txt").read_text() == "mine"
    with pytest.raises(ExportError, match="replaces only a previous mechnet export"):
        double_pendulum.export(target, overwrite=True)     # a folder of the user's is never emptied
    assert (target / "keep.txt").read_text() == "mine"
    (target / "keep.txt").unlink()
    double_pendulum.export(target, overwrite=True)
    assert (target / "model.json").is_file()


def test_export_checks_its_arguments(tmp_path, double_pendulum):
    with pytest.raises(ExportError, match="kind must be one of"):
        double_pendulum.export(tmp_path / "x", kind="zip")
    with pytest.raises(ExportError, match="give a file system path"):
        double_pendulum.export(42)
    with pytest.raises(ExportError, match="FMI version must be 2 or 3"):
        double_pendulum.export(tmp_path / "x.fmu", kind="fmu", fmi=1)
    with pytest.raises(ExportError, match="must end in .fmu"):
        double_pendulum.export(tmp_path / "x", kind="fmu")
    with pytest.raises(mn.MechnetError, match="overwrite"):
        double_pendulum.export(tmp_path / "y", overwrite="yes")
    for fmi in (1, 2.0, True, "3", None):
        with pytest.raises(ExportError, match=r"export\(fmi=.*FMI version must be 2 or 3"):
            double_pendulum.export(tmp_path / "x.fmu", kind="fmu", fmi=fmi)
    for kind in (None, ["casadi"], "CASADI"):
        with pytest.raises(ExportError, match=r"export\(kind=.*kind must be one of"):
            double_pendulum.export(tmp_path / "x", kind=kind)
    with pytest.raises(ExportError, match=r"export\(path=\.\.\.\) is empty"):
        double_pendulum.export("")


@pytest.mark.parametrize("kind, name", [("casadi", "sub"), ("c", "sub/deeper"), ("fmu", "sub.fmu")])
def test_a_path_under_a_file_is_refused_naming_it(tmp_path, double_pendulum, kind, name):
    """A fuzz case of issue 32: an export path below a regular file gave a raw NotADirectoryError."""
    (tmp_path / "somefile.txt").write_text("mine")
    with pytest.raises(ExportError, match=r"somefile\.txt/sub.* cannot be made: .*somefile\.txt is a file"):
        double_pendulum.export(tmp_path / "somefile.txt" / name, kind=kind)
    assert (tmp_path / "somefile.txt").read_text() == "mine"
    with pytest.raises(ExportError, match=r"somefile\.txt exists; pass overwrite=True"):
        double_pendulum.export(tmp_path / "somefile.txt")


def test_load_refuses_a_newer_format_and_other_kinds(tmp_path, double_pendulum):
    path = double_pendulum.export(tmp_path / "dp")
    record = json.loads((path / "model.json").read_text())
    record["format"] = mn.export.FORMAT_VERSION + 1
    (path / "model.json").write_text(json.dumps(record))
    with pytest.raises(ExportError, match="newer mechnet"):
        load(path)
    with pytest.raises(ExportError, match="holds no model.json"):
        load(tmp_path)
    record["format"], record["kind"] = mn.export.FORMAT_VERSION, "c"
    (path / "model.json").write_text(json.dumps(record))
    with pytest.raises(ExportError, match="load_library"):
        load(path)


def test_a_model_that_needs_a_reselection_says_so_when_loaded(tmp_path):
    """A Cartesian pendulum started above the horizontal passes x = 0 and y = 0: no one choice of states
    (x or y) serves the whole swing; the export keeps one and the loaded model warns."""
    cm = cartesian_pendulum(theta0=2.0).compile()
    assert not cm.functions()["metadata"]["selection"]["holds"]
    with pytest.warns(ExportWarning, match="may need another choice"):
        load(cm.export(tmp_path / "cp"))


def test_c_identifiers_are_mangled_deterministically():
    names = ["four-bar", "body.r_0[1]", "body_r_0_1_", "2nd", "body.r_0(1)", "ok_name"]
    ids = c_identifiers(names)
    assert ids == {"four-bar": "four_bar", "body.r_0[1]": "body_r_0_1_", "body_r_0_1_": "body_r_0_1__2",
                   "2nd": "_2nd", "body.r_0(1)": "body_r_0_1__3", "ok_name": "ok_name"}
    assert c_identifiers(names) == ids
    assert all(i.isidentifier() for i in ids.values())


@needs_cc
def test_generated_c_agrees_with_the_virtual_machine(tmp_path, four_bar):
    """The shared library's functions (CasADi `external`) against CasADi's VM at 100 random points:
    relative difference <= 1e-13 of each output's largest entry; the identifiers are in model.json."""
    path = four_bar.export(tmp_path / "fb_c", kind="c")
    record = json.loads((path / "model.json").read_text())
    assert record["c_names"]["coupler_joint.phi"] == "coupler_joint_phi"
    lib = load_library(path)
    fns = four_bar.functions()
    rng = np.random.default_rng(1)
    for name in ("ode", "alg", "observed", "jac_ode", "forward"):
        for args in random_args(fns[name], rng):
            for a, b in zip(fns[name].call(args), lib[name].call(args)):
                a, b = np.array(a), np.array(b)
                assert np.max(np.abs(a - b), initial=0) <= 1e-13 * max(1.0, np.max(np.abs(a), initial=0)), name
    assert set(lib) >= {"init", "solve_alg", "zero", "invariants"}
    for name in ("ode", "alg"):        # the library's own Jacobian (what `external` differentiates with)
        jac = lib[name].jacobian()
        assert "jac_" in jac.name()
        for args in random_args(fns[name], rng):
            blocks = jac.call(args + [fns[name].call(args)[0]])
            wrt = dict(zip(fns[name].name_in(), blocks))
            for var, block in zip("xzup", fns[f"jac_{name}"].call(args)):
                a, b = np.array(block), np.array(wrt[var])
                assert np.max(np.abs(a - b), initial=0) <= 1e-13 * max(1.0, np.max(np.abs(a), initial=0)), name


@needs_cc
def test_c_trajectories_agree_with_native_ones(tmp_path):
    """The drive line (an ODE with a torque step at 0.5 s) integrated by CVODES BDF on the C library's
    ode, in two pieces split at the step, against cm.simulate with the same method (cvodes-bdf) at
    rtol 1e-8, atol 1e-10 over 2 s: within 10·rtol·(1 + |x|). (Against the exact solution both miss
    by ~3e-6 in motor.w: the stiff shaft's global error exceeds rtol; the same method on the same
    equations does not.)"""
    cm = example("drive_line")
    lib = load_library(cm.export(tmp_path / "dl", kind="c"))
    dae = cm.dae
    x = ca.MX.sym("x", dae.x.numel())
    t = ca.MX.sym("t")
    u, p, d = (ca.DM(list(v)) if v else ca.DM(0, 1) for v in (dae.u_default, dae.p_value, dae.d_value))
    rhs = lib["ode"](t, x, ca.DM(0, 1), u, p, d)
    x0 = np.array([dae.starts.get(n, 0.0) for n in dae.x_names])
    native = cm.simulate(2.0, rtol=1e-8, atol=1e-10, t_out=[0.0, 0.25, 0.5, 1.0, 1.5, 2.0], method="cvodes-bdf")
    state = x0
    out = {0.0: x0}
    for t0, grid in ((0.0, [0.25, 0.5]), (0.5, [1.0, 1.5, 2.0])):
        F = ca.integrator("F", "cvodes", {"x": x, "t": t, "ode": rhs}, t0, grid,
                          {"reltol": 1e-8, "abstol": 1e-10})
        xs = np.array(F(x0=state)["xf"])
        out.update({tk: xs[:, k] for k, tk in enumerate(grid)})
        state = xs[:, -1]
    for k, name in enumerate(dae.x_names):
        mine = np.array([out[tk][k] for tk in native.t])
        assert np.max(np.abs(mine - native[name])) <= 10 * 1e-8 * (1 + np.max(np.abs(native[name]))), name


def test_no_c_compiler_is_said_and_casadi_still_works(tmp_path, monkeypatch, double_pendulum):
    import mechnet.export.files as files
    monkeypatch.setattr(files, "compiler", lambda: None)
    with pytest.raises(ExportError, match="no C compiler found.*kind='casadi'"):
        double_pendulum.export(tmp_path / "c", kind="c")
    assert (tmp_path / "c" / "double_pendulum.c").is_file()        # the sources are kept
    with pytest.raises(ExportError, match="no C compiler"):
        double_pendulum.export(tmp_path / "x.fmu", kind="fmu")
    assert load(double_pendulum.export(tmp_path / "casadi")).n_states == 4
