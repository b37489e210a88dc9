"""Optimal control problems (mechnet.ocp): the problem's arguments, its names, bounds, constraints and
objective, and the transcription methods' settings. Solves are kept small (N <= 10)."""
from __future__ import annotations

import math
import pickle

from mechnet import ocp
from fuzz import fixtures
from fuzz.framework import Collector, close, expect

NEEDS = ("mass",)


def _problem(**kw):
    prob = ocp.Problem(fixtures.mass(), kw.pop("t_final", 2.0), **kw)
    prob.bounds("push.f", -1.0, 1.0)
    return prob


def _posed():
    prob = _problem()
    prob.subject_to(prob.at_end(prob.var("mass.s")) == 1.0)
    prob.subject_to(prob.at_end(prob.var("mass.v")) == 0.0)
    prob.minimize(prob.integral(prob.var("push.f") ** 2))
    return prob


def collector() -> Collector:
    col = Collector("ocp")
    for what, t_final, culprit in (("zero", 0.0, "t_final"), ("negative", -1.0, "t_final"),
    ("nan", math.nan, "t_final"),
                                   ("text", "2", "t_final"), ("reversed", (3.0, 1.0), "t_final"),
                                   ("triple", (0.1, 1.0, 2.0), "t_final"), ("inf", math.inf, "t_final"),
                                   ("none", None, "t_final")):
        col.bad(f"problem.t_final.{what}", lambda t=t_final: ocp.Problem(fixtures.mass(), t), (culprit,), needs=NEEDS)
    col.bad("problem.start.list", lambda: ocp.Problem(fixtures.mass(), 1, start=[1, 2]), ("start",), needs=NEEDS,
            known="Problem(cm, 1, start=[1, 2])")
    col.bad("problem.start.unknown", lambda: ocp.Problem(fixtures.mass(), 1, start={"mass.x": 1}), ("mass.x",),
            needs=NEEDS)
    col.bad("problem.start.nan", lambda: ocp.Problem(fixtures.mass(), 1, start={"mass.s": math.nan}), ("mass.s",),
            needs=NEEDS)
    col.bad("problem.params.list", lambda: ocp.Problem(fixtures.mass(), 1, params=[1.0]), ("params",), needs=NEEDS)
    col.bad("problem.not_compiled", lambda: ocp.Problem(fixtures.mass_model(), 1), ("Problem",))
    col.bad("problem.no_inputs", lambda: ocp.Problem(fixtures.osc(), 1), ("input",), needs=("osc",))
    col.bad("bounds.unknown", lambda: _problem().bounds("mass.x", 0, 1), ("mass.x",), needs=NEEDS)
    col.bad("bounds.reversed", lambda: _problem().bounds("mass.s", 1, 0), ("mass.s",), needs=NEEDS)
    col.bad("bounds.nan", lambda: _problem().bounds("mass.s", math.nan, 1), ("mass.s",), needs=NEEDS)
    col.bad("bounds.text", lambda: _problem().bounds("mass.s", "0", 1), ("mass.s",), needs=NEEDS)
    col.bad("bounds.name_number", lambda: _problem().bounds(3, 0, 1), ("3",), needs=NEEDS)
    col.bad("rate_bounds.state", lambda: _problem().rate_bounds("mass.s", -1, 1), ("mass.s",), needs=NEEDS)
    col.bad("free_parameter.folded", lambda: _problem().free_parameter("mass.m", 0.5, 2), ("mass.m",), needs=NEEDS)
    col.bad("var.unknown", lambda: _problem().var("mass.x"), ("mass.x",), needs=NEEDS)
    col.bad("subject_to.bool", lambda: _problem().subject_to(True), ("subject_to",), needs=NEEDS)
    col.bad("subject_to.text", lambda: _problem().subject_to("mass.s <= 1"), ("subject_to",), needs=NEEDS)
    col.bad("subject_to.nan", lambda: (lambda p: p.subject_to(p.var("mass.s") <= math.nan))(_problem()),
            ("subject_to",), needs=NEEDS)
    col.bad("minimize.text", lambda: _problem().minimize("time"), ("minimize",), needs=NEEDS)
    col.bad("minimize.path_quantity", lambda: (lambda p: p.minimize(p.var("mass.s")))(_problem()),
            (("integral", "at_end"),), needs=NEEDS)
    col.bad("solve.without_objective", lambda: _problem().solve(ocp.Collocation(N=5)), ("minimize",), needs=NEEDS)
    col.bad("solve.method_text", lambda: _posed().solve("collocation"), ("solve",), needs=NEEDS)
    col.bad("solve.ipopt_unknown", lambda: _posed().solve(ocp.Collocation(N=5), ipopt={"max_iterz": 3}),
            ("max_iterz",), needs=NEEDS)
    col.bad("solve.guess_text", lambda: _posed().solve(ocp.Collocation(N=5), guess="zero"), ("guess",), needs=NEEDS)
    for what, make, culprit in (
            ("N.zero", lambda: ocp.Collocation(N=0), "N"), ("N.float", lambda: ocp.Collocation(N=2.5), "N"),
            ("N.text", lambda: ocp.Collocation(N="10"), "N"), ("degree.zero", lambda: ocp.Collocation(N=5, degree=0),
            "degree"),
            ("scheme", lambda: ocp.Collocation(N=5, scheme="gauss"), "scheme"),
            ("controls", lambda: ocp.Collocation(N=5, controls="cubic"), "controls"),
            ("hessian", lambda: ocp.Collocation(N=5, hessian="bfgs"), "hessian"),
            ("shooting.integrator", lambda: ocp.MultipleShooting(N=5, integrator="euler"), "integrator"),
            ("shooting.rtol", lambda: ocp.MultipleShooting(N=5, rtol=-1), "rtol"),
            ("shooting.steps", lambda: ocp.MultipleShooting(N=5, steps=0), "steps"),
            ("shooting.points", lambda: ocp.MultipleShooting(N=5, constraint_points=0), "constraint_points")):
        col.bad(f"method.{what}", make, (culprit,))
    col.bad("method.N_huge", lambda: _posed().solve(ocp.Collocation(N=10**9)), ("N",), needs=NEEDS, timeout=60,
            known="Collocation(N=10**9)")
    col.good("problem.infeasible", lambda: (lambda p: (p.subject_to(p.at_end(p.var("mass.s")) == 100.0),
                                                       p.minimize(p.t_final), p.solve(ocp.Collocation(N=5)))[-1])(
        _problem(t_final=(0.1, 1.0))), "an infeasible problem returns a solution marked failed, with IPOPT's status",
        lambda sol: expect(not sol.stats["success"] and "nfeasible" in str(sol.stats.get("status", sol)), "failed"),
        needs=NEEDS)
    col.good("solve.double_integrator", lambda: _posed().solve(ocp.Collocation(N=10)),
             "the README's rest-to-rest move", lambda sol: expect(close(sol["mass.s"][-1], 1.0, 1e-6), "arrives"),
             needs=NEEDS)
    col.good("pickle.solution", lambda: pickle.loads(pickle.dumps(_posed().solve(ocp.Collocation(N=6)))),
             "a solution goes to another process (issue 32)", lambda sol: expect(close(sol["mass.s"][-1], 1.0, 1e-6),
                                                                                 "same answer"),
             needs=NEEDS, known="ocp.Solution not picklable")
    col.good("pickle.problem", lambda: pickle.loads(pickle.dumps(_posed())).solve(ocp.Collocation(N=6)),
             "a problem goes to another process (issue 32)", lambda sol: expect(close(sol["mass.s"][-1], 1.0, 1e-6),
                                                                                "same answer"),
             needs=NEEDS, known="ocp.Problem not picklable")
    return col
