"""Optimal control problems that cannot be posed or solved as given: OcpError (a MechnetError) or
UnknownNameError, each message naming the culprit; an infeasible problem is a failed Solution whose
stats name the worst constraint and its time."""
import math

import casadi as ca
import pytest

import mechnet as mn
from mechnet import ocp
from mechnet.components import translational as tr
from models import double_integrator


@pytest.fixture(scope="module")
def cm():
    return double_integrator().compile()


@pytest.fixture
def prob(cm):
    return ocp.Problem(cm, t_final=1.0)


def test_ocp_error_is_a_mechnet_error():
    assert issubclass(ocp.OcpError, mn.MechnetError)
    assert ocp.OcpError is mn.ocp.OcpError


# ---- names ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("call, name, suggestion", [
    (lambda p: p.var("mass.sx"), "mass.sx", "mass.s"),
    (lambda p: p.bounds("push.ff", -1, 1), "push.ff", "push.f"),
], ids=["var", "bounds"])
def test_unknown_name_suggests_the_closest(prob, call, name, suggestion):
    with pytest.raises(mn.UnknownNameError, match=rf"'{name}' does not exist.*did you mean {suggestion}\b"):
        call(prob)


def test_unknown_start_value_name(cm):
    with pytest.raises(mn.UnknownNameError, match=r"start value for 'mass.q' does not exist.*did you mean"):
        ocp.Problem(cm, 1.0, start={"mass.q": 1.0})


# ---- posing the problem ---------------------------------------------------------------------------

def test_lower_bound_above_upper(prob):
    with pytest.raises(ocp.OcpError, match=r"bounds\('push.f'\): lower bound 1 is above upper bound -1"):
        prob.bounds("push.f", 1, -1)


def test_bound_not_a_number(prob):
    with pytest.raises(ocp.OcpError, match=r"bounds\('push.f'\) upper is NaN"):
        prob.bounds("push.f", -1, math.nan)


def test_model_without_inputs(cm):
    m = mn.Model("free_mass")
    m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    with pytest.raises(ocp.OcpError, match=r"model 'free_mass' has no inputs to optimise.*Torque"):
        ocp.Problem(m.compile(), 1.0)


def test_problem_needs_a_compiled_model():
    m = mn.Model("uncompiled")
    m.add(tr.Mass(name="mass", m=1.0))
    with pytest.raises(ocp.OcpError, match=r"compiled model.*got Model"):
        ocp.Problem(m, 1.0)


@pytest.mark.parametrize("t_final, message", [
    (None, r"free final time needs bounds: t_final=\(lower, upper\)"),
    ((0.0, 1.0), r"t_final bounds \(0, 1\) must satisfy 0 < lower <= upper"),
    ((2.0, 1.0), r"t_final bounds \(2, 1\) must satisfy 0 < lower <= upper"),
    ((1.0, 2.0, 3.0), r"give a time, or \(lower, upper\) bounds"),
    (-1.0, r"t_final = -1 s must be > 0"),
], ids=["None", "zero-lower", "reversed", "three", "negative"])
def test_final_time(cm, t_final, message):
    with pytest.raises(ocp.OcpError, match=message):
        ocp.Problem(cm, t_final)


def test_non_scalar_objective(prob):
    with pytest.raises(ocp.OcpError, match=r"minimize\(...\): the expression must be a scalar, got shape \(2, 1\)"):
        prob.minimize(ca.vertcat(prob.at_end(prob.var("mass.s")), prob.t_final))


@pytest.mark.parametrize("objective", [
    lambda p: p.var("push.f") ** 2,
    lambda p: p.at_end(p.var("mass.s")) + p.var("mass.v"),
    lambda p: p.time,
], ids=["bare", "mixed", "time"])
def test_objective_with_a_path_quantity(prob, objective):
    with pytest.raises(ocp.OcpError, match=r"objective holds a path quantity.*prob.integral\(...\) or prob.at_end"):
        prob.minimize(objective(prob))


def test_objective_not_an_expression(prob):
    with pytest.raises(ocp.OcpError, match=r"minimize\(...\): 'fast' is not a CasADi expression"):
        prob.minimize("fast")


@pytest.mark.parametrize("constraint", [True, False, 1.0 <= 2.0], ids=["True", "False", "decided"])
def test_subject_to_a_python_bool(prob, constraint):
    with pytest.raises(ocp.OcpError, match=r"decided in Python"):
        prob.subject_to(constraint)


def test_subject_to_not_a_comparison(prob):
    with pytest.raises(ocp.OcpError, match=r"subject_to\(mass.s\): not a comparison"):
        prob.subject_to(prob.var("mass.s"))


def test_constraint_mixing_path_and_boundary(prob):
    with pytest.raises(ocp.OcpError, match=r"mixes path quantities with at_start/at_end/integral"):
        prob.subject_to(prob.var("mass.s") <= prob.at_end(prob.var("mass.s")))


def test_nested_placeholder(prob):
    with pytest.raises(ocp.OcpError, match=r"integral\(...\) takes an expression along the path"):
        prob.integral(prob.at_end(prob.var("mass.s")))


def test_solve_without_objective(prob):
    with pytest.raises(ocp.OcpError, match=r"no objective: call prob.minimize"):
        prob.solve(ocp.Collocation(N=10))


def test_solve_with_a_method_name(prob):
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    with pytest.raises(ocp.OcpError, match=r"solve takes Collocation\(...\) or MultipleShooting\(...\), got str"):
        prob.solve("collocation")


@pytest.mark.parametrize("make, message", [
    (lambda: ocp.Collocation(N=10, scheme="gauss"), r"scheme = 'gauss': choose 'radau' or 'legendre'"),
    (lambda: ocp.Collocation(N=10, controls="cubic"), r"controls = 'cubic': choose 'constant'"),
    (lambda: ocp.MultipleShooting(N=10, integrator="euler"), r"integrator = 'euler': choose one of cvodes, idas, rk"),
    (lambda: ocp.MultipleShooting(N=10, hessian="bfgs"), r"hessian = 'bfgs': choose 'exact' or 'limited-memory'"),
], ids=["scheme", "controls", "integrator", "hessian"])
def test_transcription_options(make, message):
    with pytest.raises(ocp.OcpError, match=message):
        make()


# ---- infeasible at t = 0 -------------------------------------------------------------------------

def test_bounds_excluding_the_fixed_start_value(prob):
    # s_start = 0 fixed in the model: bounds(mass.s, 1, 2) cannot hold at t = 0, refused when posed
    with pytest.raises(ocp.OcpError, match=r"bounds\('mass.s', 1, 2\) cannot hold at t = 0.*mass.s = 0"):
        prob.bounds("mass.s", 1, 2)


@pytest.mark.parametrize("method", [ocp.Collocation(N=10), ocp.MultipleShooting(N=10, integrator="rk")],
                         ids=["collocation", "shooting-rk"])
def test_path_constraint_infeasible_at_the_start(prob, method):
    # the same conflict as a path constraint is only found by IPOPT: a failed Solution whose worst
    # constraint is the fixed start value of mass.s at t = 0 (violated by ~1 m or less, > 0.1)
    prob.subject_to(prob.var("mass.s") >= 1.0)
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    sol = prob.solve(method)
    assert sol.success is False
    assert sol.stats["status"] == "Infeasible_Problem_Detected"
    what, t = sol.stats["worst_constraint"]
    assert "mass.s" in what and t == 0.0
    assert sol.stats["max_violation"] > 0.1
    assert "FAILED" in repr(sol)


def test_bounds_on_an_observed_quantity_infeasible(prob):
    # |push.f| <= 1 but mass.a = push.f / m must lie in [2, 3]: the worst constraint names the bound
    prob.bounds("push.f", -1, 1)
    prob.bounds("mass.a", 2, 3)
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    sol = prob.solve(ocp.Collocation(N=10))
    assert sol.success is False
    what, t = sol.stats["worst_constraint"]
    assert what == "bounds on mass.a" and 0.0 <= t <= 1.0
    assert sol.stats["max_violation"] == pytest.approx(1.0, abs=1e-6)


def test_linear_controls_need_two_collocation_points():
    with pytest.raises(ocp.OcpError, match="degree >= 2"):
        ocp.Collocation(N=10, degree=1, controls="linear")


def test_unknown_ipopt_option_is_named(prob):
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    with pytest.raises(ocp.OcpError, match="IPOPT refused the options"):
        prob.solve(ocp.Collocation(N=4), ipopt={"no_such_option": 3})


def test_shooting_tolerances_must_be_positive():
    with pytest.raises(ocp.OcpError, match="must be > 0"):
        ocp.MultipleShooting(N=4, rtol=-1.0)


def test_a_nan_in_a_constraint_is_refused(prob):
    with pytest.raises(ocp.OcpError, match="NaN or infinite"):
        prob.subject_to(prob.var("mass.s") <= math.nan)


def test_a_fixed_parameter_outside_its_bounds_is_refused():
    prob = ocp.Problem(double_integrator(m=mn.tunable(1.0)).compile(), t_final=1.0)
    with pytest.raises(ocp.OcpError, match="free it with prob.free_parameter"):
        prob.bounds("mass.m", 2.0, 3.0)


def _pushed_block():
    """A 1 kg block pushed by the input push.f over a surface with tunable mu_k = 0.2, mu_s = 0.3."""
    from mechnet.components import translational as tr
    m = mn.Model("pushed_block")
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    push = m.add(tr.Force(name="push"))
    ground = m.add(tr.Fixed(name="ground"))
    fr = m.add(tr.Friction(name="fr", fn=9.81, mu_k=mn.tunable(0.2), mu_s=mn.tunable(0.3)))
    m.connect(push.flange, mass.flange_a)
    m.connect(ground.flange, fr.flange_a)
    m.connect(fr.flange_b, mass.flange_b)
    return m.compile()


def test_a_problems_parameters_meet_the_requirements_between_them():
    """params= of a Problem is checked as simulate's (mu_s below mu_k was accepted), and a freed mu_s
    is kept at or above mu_k by a constraint: minimising it ends at mu_k = 0.2 (within IPOPT's 1e-6),
    not at its lower bound 0."""
    cm = _pushed_block()
    with pytest.raises(mn.ParameterError, match=r"Problem\(params=\.\.\.\): fr \(Friction\): mu_s = 0\.1 is below"):
        ocp.Problem(cm, t_final=1.0, params={"fr.mu_s": 0.1})
    prob = ocp.Problem(cm, t_final=1.0)
    prob.free_parameter("fr.mu_s", 0.0, 1.0)
    prob.bounds("push.f", -5.0, 5.0)
    prob.minimize(prob.var("fr.mu_s") + prob.integral(prob.var("push.f") ** 2))
    sol = prob.solve(ocp.Collocation(N=10))
    assert sol.success and sol.params["fr.mu_s"] == pytest.approx(0.2, abs=1e-6)
    # IPOPT keeps the requirement to its tolerance (it ended 7.5e-9 below mu_k): the solution moves the
    # freed value onto it, so it replays in cm.simulate (which refused it)
    assert sol.params["fr.mu_s"] >= 0.2 and sol.verify()["max_deviation"] < 1e-6


def test_a_freed_parameter_is_kept_to_its_own_check():
    """A freed mu_k (check: >= 0) without bounds, its cost pushing it down: the optimum is on the check's
    bound, 0 (it went to −0.2, or diverged to −1.6e30 when minimised alone), and replays in simulate."""
    cm = _pushed_block()
    prob = ocp.Problem(cm, t_final=1.0)
    prob.free_parameter("fr.mu_k")
    prob.bounds("push.f", -5.0, 5.0)
    prob.minimize(prob.var("fr.mu_k") + prob.integral(prob.var("push.f") ** 2))
    sol = prob.solve(ocp.Collocation(N=10))
    assert sol.success and 0.0 <= sol.params["fr.mu_k"] <= 1e-8
    assert sol.verify()["max_deviation"] < 1e-6


# ---- fuzzed bad inputs (issue 32): each refused by name, none a raw Python or CasADi error ------------

@pytest.mark.parametrize("kwargs, message", [
    (dict(start=[1, 2]), r"Problem\(start=...\) takes a mapping .*got list"),
    (dict(start="mass.s"), r"Problem\(start=...\) takes a mapping .*got str"),
    (dict(start={1: 2.0}), r"Problem\(start=...\): keys are dotted names .*got 1"),
    (dict(params=[1.0]), r"Problem\(params=...\) takes a mapping"),
    (dict(params={3: 1.0}), r"Problem\(params=...\): keys are dotted names"),
], ids=["start-list", "start-str", "start-key", "params-list", "params-key"])
def test_start_and_params_must_be_mappings(cm, kwargs, message):
    with pytest.raises(ocp.OcpError, match=message):
        ocp.Problem(cm, 1, **kwargs)


def test_a_symbol_the_problem_did_not_make_is_refused(prob):
    stray = ca.SX.sym("y")
    with pytest.raises(ocp.OcpError, match=r"subject_to\(...\): y is not one of the problem's quantities"):
        prob.subject_to(prob.var("mass.s") + stray <= 1)
    with pytest.raises(ocp.OcpError, match=r"minimize\(...\): y is not one of the problem's quantities"):
        prob.minimize(prob.at_end(prob.var("mass.s")) * stray)
    # a symbol of the same name is another symbol: not the problem's either
    with pytest.raises(ocp.OcpError, match=r"integral\(...\): mass.s is not one of the problem's quantities"):
        prob.integral(ca.SX.sym("mass.s"))


@pytest.mark.parametrize("call, message", [
    (lambda p: p.minimize(ca.SX(math.nan)), r"minimize\(nan\): holds a NaN"),
    (lambda p: p.subject_to(p.var("mass.s") <= 1, label=3), r"label=3.*a string"),
    (lambda p: p.free_parameter(3), r"parameter names are dotted strings .*got 3"),
], ids=["nan-objective", "label", "parameter-name"])
def test_other_bad_arguments_are_named(prob, call, message):
    with pytest.raises(ocp.OcpError, match=message):
        call(prob)


@pytest.mark.parametrize("make, message", [
    (lambda: ocp.Collocation(N=10 ** 9), r"N = 1000000000: .* exceed the 1e\+06 decision variables"),
    (lambda: ocp.Collocation(N=10, degree=10), r"degree = 10: collocation points go up to degree 9"),
    (lambda: ocp.Collocation(N=0), r"N \(intervals\) = 0 must be a whole number of at least 2"),
    (lambda: ocp.MultipleShooting(N=10 ** 9), r"N = 1000000000: .* exceed the 1e\+06"),
    (lambda: ocp.MultipleShooting(N=10, integrator="rk", steps=10 ** 9), r"steps = 1000000000: "),
    (lambda: ocp.MultipleShooting(N=10, constraint_points=10 ** 9), r"constraint_points = 1000000000: "),
], ids=["collocation-N", "degree", "N-zero", "shooting-N", "rk-steps", "constraint-points"])
def test_a_transcription_too_large_is_refused_before_it_is_built(make, message):
    with pytest.raises(mn.MechnetError, match=message):
        make()


@pytest.mark.parametrize("method, message", [
    (lambda: ocp.Collocation(N=200_000), r"N = 200000: collocation of model 'double_integrator' at degree 3 would "
                                         r"have 1.8e\+06 decision variables"),
    (lambda: ocp.MultipleShooting(N=400_000), r"N = 400000: multiple shooting of model 'double_integrator' would "
                                              r"hold 2e\+06 variables"),
], ids=["collocation", "shooting"])
def test_a_transcription_too_large_for_its_model_is_refused_when_solved(prob, method, message):
    """Sized from the model's states, algebraics and inputs before any variable is made (N = 10**9 once ran
    a minute into a MemoryError)."""
    import time
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    t0 = time.perf_counter()
    with pytest.raises(ocp.OcpError, match=message):
        prob.solve(method())
    assert time.perf_counter() - t0 < 10
