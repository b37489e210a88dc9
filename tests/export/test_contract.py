"""cm.functions(): the contract every export is built from.

`init` must reproduce the simulator's consistent initialisation at the same start points, `solve_alg`
the loop equations from a perturbed guess, `forward` the derivatives of the solution manifold that
central differences of (ode, solve_alg) give, and the declared dependencies the Jacobians' sparsity.
"""
import casadi as ca
import numpy as np
import pytest

import mechnet as mn
from mechnet.scene import load_scene
from mechnet.simulate.initialize import initialize
from models import cartesian_pendulum, four_bar, slider_crank

EXAMPLES = __import__("pathlib").Path(__file__).parents[2] / "examples"


def example(name):
    return load_scene(EXAMPLES / f"{name}.py").build().compile()


def exported_dae(cm):
    """The compiled selection the export holds (the one whose states the metadata names)."""
    states = cm.functions()["metadata"]["selection"]["states"]
    return next(d for d in (cm.dae, *cm._selections.values()) if list(d.x_names) == states)


def defaults(dae):
    return (np.array(dae.u_default, dtype=float), np.array(dae.p_value, dtype=float),
            np.array(dae.d_value, dtype=float))


SCENES = {
    "double_pendulum": lambda: example("double_pendulum"),
    "four_bar": lambda: example("four_bar"),
    "slider_crank": lambda: example("slider_crank"),
    "six_bar": lambda: example("six_bar"),
    "four_bar_driven_free": lambda: four_bar(theta2=1.1).compile(),
    "slider_crank_model": lambda: slider_crank(theta0=2.0).compile(),
    "cartesian_pendulum": lambda: cartesian_pendulum(theta0=0.7).compile(),
}


@pytest.fixture(scope="module", params=sorted(SCENES))
def scene(request):
    return request.param, SCENES[request.param]()


def test_contract_lists_every_documented_function(scene):
    _, cm = scene
    fns = cm.functions()
    for name in ("ode", "alg", "observed", "invariants", "zero", "transition", "init", "solve_alg", "jac_ode",
                 "jac_alg", "forward", "alg_jac", "metadata"):
        assert name in fns, name
    for name in ("ode", "alg", "observed", "invariants", "zero", "jac_ode", "jac_alg", "alg_jac"):
        assert fns[name].name_in() == ["t", "x", "z", "u", "p", "d"], name
    meta = fns["metadata"]
    assert meta["format"] == mn.export.FORMAT_VERSION
    assert [v["name"] for v in meta["observed"]] == list(cm.dae.observed_names)
    assert all(v["unit"] for v in meta["observed"])


def test_init_reproduces_the_simulators_start(scene):
    """At the model's own start values (and with one start value changed), init's damped Newton lands
    on the simulator's initial point: |difference| <= 1e-9·(1 + max |w|) (both stop at a residual of
    1e-10·(1 + max |w|); the six-bar's accelerations reach |w| ~ 140)."""
    label, cm = scene
    fns = cm.functions()
    dae = exported_dae(cm)
    u, p, d = defaults(dae)
    meta = fns["metadata"]
    starts = {s["name"]: s["value"] for s in meta["starts"]}
    guesses = np.array([dae.guesses.get(n, 0.0) for n in dae.x_names + dae.z_names])
    variants = [dict(starts)]
    moved = next((n for n in starts if n.endswith(".phi")), None)
    if moved is not None:
        variants.append({**starts, moved: starts[moved] + 0.05})
    for fixed in variants:
        ref = initialize(dae, 0.0, u, p, {**dae.starts, **fixed}, {})
        x, z, norm = fns["init"](0.0, u, p, d, np.array([fixed[n] for n in starts]), guesses)
        assert float(norm) <= 1e-10 * (1 + np.max(np.abs(np.r_[ref.x, ref.z]), initial=0)), label
        tol = 1e-9 * (1 + np.max(np.abs(np.r_[ref.x, ref.z]), initial=0))
        np.testing.assert_allclose(np.array(x).ravel(), ref.x, rtol=0, atol=tol, err_msg=label)
        np.testing.assert_allclose(np.array(z).ravel(), ref.z, rtol=0, atol=tol, err_msg=label)


def test_solve_alg_returns_to_the_loop_solution(scene):
    """From z perturbed by 0.05, solve_alg finds the loop's solution again to 1e-12·(1 + max |z|) (one
    polishing Newton step after the damped iteration)."""
    label, cm = scene
    dae = exported_dae(cm)
    if not dae.z.numel():
        pytest.skip(f"{label} has no algebraic variables")
    u, p, d = defaults(dae)
    ref = initialize(dae, 0.0, u, p, dict(dae.starts), {})
    z, norm = cm.functions()["solve_alg"](0.0, ref.x, ref.z + 0.05, u, p, d)
    scale = 1 + np.max(np.abs(ref.z))
    np.testing.assert_allclose(np.array(z).ravel(), ref.z, rtol=0, atol=1e-12 * scale)
    assert float(norm) < 1e-12 * scale


def _manifold(cm, dae, x, u, p, d, z_guess):
    fns = cm.functions()
    z = np.array(fns["solve_alg"](0.0, x, z_guess, u, p, d)[0]).ravel()
    return (np.array(fns["ode"](0.0, x, z, u, p, d)).ravel(), np.array(fns["observed"](0.0, x, z, u, p, d)).ravel(), z)


def test_forward_derivatives_match_central_differences(scene):
    """forward(...) along random state seeds against central differences of (ode, observed) with z
    re-solved: step 1e-6, relative error <= 1e-6 of the largest entry (difference error ~ h² + 1e-16/h)."""
    label, cm = scene
    dae = exported_dae(cm)
    u, p, d = defaults(dae)
    ref = initialize(dae, 0.0, u, p, dict(dae.starts), {})
    rng = np.random.default_rng(3)
    fwd = cm.functions()["forward"]
    for _ in range(3):
        seed = rng.normal(size=dae.x.numel())
        dxdot, dy, _ = fwd(0.0, ref.x, ref.z, u, p, d, seed, np.zeros(dae.u.numel()), np.zeros(dae.p.numel()))
        h = 1e-6
        plus = _manifold(cm, dae, ref.x + h * seed, u, p, d, ref.z)
        minus = _manifold(cm, dae, ref.x - h * seed, u, p, d, ref.z)
        for k, exact in enumerate((dxdot, dy)):
            exact = np.array(exact).ravel()
            approx = (plus[k] - minus[k]) / (2 * h)
            scale = max(1.0, np.max(np.abs(exact)))
            assert np.max(np.abs(exact - approx)) <= 1e-6 * scale, (label, k)


def test_declared_dependencies_are_the_jacobians_sparsity(scene):
    """The metadata's xdot_x pattern (z eliminated) contains every entry of the Jacobian forward() gives
    at the start point and every explicit dependency of ode on x; and no entry outside those explicit
    ones and the ones that can pass through z (xdot_i uses some z and alg uses x_j): an upper bound
    derived here, equal to the explicit pattern for a model without loops."""
    label, cm = scene
    dae = exported_dae(cm)
    fns = cm.functions()
    u, p, d = defaults(dae)
    ref = initialize(dae, 0.0, u, p, dict(dae.starts), {})
    n = dae.x.numel()
    declared = {tuple(e) for e in fns["metadata"]["dependencies"]["xdot_x"]}
    numeric = set()
    for j in range(n):
        seed = np.zeros(n)
        seed[j] = 1.0
        col = np.array(fns["forward"](0.0, ref.x, ref.z, u, p, d, seed, np.zeros(dae.u.numel()),
                                      np.zeros(dae.p.numel()))[0]).ravel()
        numeric |= {(i, j) for i in np.flatnonzero(col)}
    assert numeric <= declared, label
    # the structural pattern: the explicit part plus the implicit one through z
    jx = ca.jacobian_sparsity(dae.ode(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d), dae.x)
    structural = set(zip(*jx.get_triplet()))
    assert structural <= declared, label
    ode_z = ca.jacobian_sparsity(dae.ode(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d), dae.z) if dae.z.numel() else None
    uses_z = {i for i, _ in zip(*ode_z.get_triplet())} if ode_z is not None else set()
    alg_x = ca.jacobian_sparsity(dae.alg(dae.t, dae.x, dae.z, dae.u, dae.p, dae.d), dae.x) if dae.z.numel() else None
    alg_uses = {j for _, j in zip(*alg_x.get_triplet())} if alg_x is not None else set()
    through_z = {(i, j) for i in uses_z for j in alg_uses}
    assert declared <= structural | through_z, label


def test_model_without_loops_has_trivial_alg_functions():
    cm = example("double_pendulum")
    fns = cm.functions()
    assert fns["alg"].size1_out(0) == 0
    z, norm = fns["solve_alg"](0.0, np.zeros(cm.dae.x.numel()), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))
    assert z.numel() == 0 and float(norm) == 0.0
