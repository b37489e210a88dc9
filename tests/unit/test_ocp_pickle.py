"""An optimal control problem and its solution pickle (issue 32): a Solution comes back with the same
trajectories, controls and verification, a Problem solves to the same optimum with either transcription."""
import pickle

import numpy as np
import pytest

from mechnet import ocp
from models import double_integrator


@pytest.fixture(scope="module")
def problem():
    """Rest to rest over 1 m in 1 s with |f| <= 10 N and v <= 1.6 m/s, minimising ∫ f² dt."""
    prob = ocp.Problem(double_integrator().compile(), 1.0)
    prob.bounds("push.f", -10, 10)
    prob.subject_to(prob.var("mass.v") <= 1.6)
    prob.subject_to(prob.at_end(prob.var("mass.s")) == 1)
    prob.subject_to(prob.at_end(prob.var("mass.v")) == 0)
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    return prob


@pytest.mark.parametrize("method", [lambda: ocp.Collocation(N=10), lambda: ocp.MultipleShooting(N=10)],
                         ids=["collocation", "shooting"])
def test_a_solution_and_its_problem_survive_pickling(problem, method):
    sol = problem.solve(method())
    assert sol.success
    back = pickle.loads(pickle.dumps(sol))
    assert back.success and back.t_final == sol.t_final and back.stats["objective"] == sol.stats["objective"]
    for name in ("mass.s", "mass.v", "push.f"):
        np.testing.assert_array_equal(back[name], sol[name])
    np.testing.assert_array_equal(back.inputs["push.f"](back.t), sol.inputs["push.f"](sol.t))
    assert back.verify()["max_deviation"] < 1e-6
    # the problem (CasADi expressions, packed together so the symbols stay shared) solves the same again
    again = pickle.loads(pickle.dumps(problem)).solve(pickle.loads(pickle.dumps(method())))
    assert again.success and abs(again.stats["objective"] - sol.stats["objective"]) <= 1e-9
    np.testing.assert_allclose(again["push.f"], sol["push.f"], atol=1e-9)
    # the unpickled problem's placeholders are its own: a new constraint on them poses
    copy = pickle.loads(pickle.dumps(problem))
    copy.subject_to(copy.at_end(copy.var("mass.s")) <= 2)
    assert len(copy.point) == len(problem.point) + 1
