"""Pantelides: the integer algorithm on hand-made incidences, and mechnet's counts against CasADi's.

`_Graph` is fed FlatSystems whose residuals are plain sums of symbols, so the
incidence is exactly what is written here. The cross-checks run
`casadi.dae_reduce_index` (its own Pantelides) on the same simplified systems
that mechnet reduced; CasADi's stats dict has one key, "index", and the
per-equation counts are read off its reduced system by
`mechnet.compile.baumgarte.casadi_reduction`.
"""
from __future__ import annotations

import casadi as ca
import pytest

import mechnet as mn
from mechnet.compile.artifacts import FlatEquation, FlatSystem, FlatVariable
from mechnet.compile.baumgarte import casadi_reduction, implicit_form
from mechnet.compile.index_reduction import IndexReductionOptions, _Graph
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from mechnet.components.signals import Sine
from models import cartesian_pendulum

# ---- the integer algorithm on hand-made incidences -------------------------------------------------


def _flat(names, der, equations):
    """A FlatSystem with incidence `equations` = [(label, [variable names])]; der = {v: der(v)}."""
    syms = {n: ca.SX.sym(n) for n in names}
    index = {n: i for i, n in enumerate(names)}
    variables = tuple(FlatVariable(n, syms[n], "state" if n in der else "algebraic") for n in names)
    eqs = tuple(FlatEquation(sum((syms[v] for v in row), ca.SX(0)), "hand", label) for label, row in equations)
    return FlatSystem("hand", variables, eqs, (), {index[a]: (index[b], 1.0) for a, b in der.items()},
                      ca.SX.sym("t"))


def _pantelides(flat):
    """(times each original equation was differentiated, structural index, the graph)."""
    graph = _Graph(flat)
    assert graph.pantelides(len(flat.equations), max_rounds=len(flat.variables) + 2)
    counts = {}
    for e, eq in enumerate(flat.equations):
        n = 0
        while e in graph.diff:
            e, n = graph.diff[e], n + 1
        counts[eq.label] = n
    return counts, max(counts.values()) + 1, graph


def _assert_final_matching(graph):
    """Highest-order unknowns and highest-derivative equations are matched one to one."""
    top = {e for e in range(len(graph.inc)) if e not in graph.diff}
    unknowns = [v for v in range(len(graph.kind)) if graph.visible(v)]
    assert len(unknowns) == len(top)
    assert {graph.assign[v] for v in unknowns} == top
    for v in unknowns:
        assert v in graph.inc[graph.assign[v]]


# The pendulum in first-order form: velocity equations written out, as CasADi sees it.
PENDULUM_NAMES = ["x", "y", "u", "v", "lam", "x'", "y'", "u'", "v'"]
PENDULUM_DER = {"x": "x'", "y": "y'", "u": "u'", "v": "v'"}
PENDULUM_EQS = [("vel x", ["x'", "u"]), ("vel y", ["y'", "v"]), ("force x", ["u'", "lam", "x"]),
                ("force y", ["v'", "lam", "y"]), ("rod", ["x", "y"])]


def test_pendulum_structure_constraint_twice_velocity_equations_once():
    counts, index, graph = _pantelides(_flat(PENDULUM_NAMES, PENDULUM_DER, PENDULUM_EQS))
    assert counts == {"vel x": 1, "vel y": 1, "force x": 0, "force y": 0, "rod": 2}
    assert index == 3
    # one new variable per differentiated level: x'' and y''
    assert len(graph.kind) == len(PENDULUM_NAMES) + 2
    _assert_final_matching(graph)


def test_pendulum_structure_with_velocities_as_derivatives():
    # mechnet's own form: der(x) IS u (der_of), no velocity equations: only the rod length is differentiated
    names = ["x", "y", "u", "v", "lam", "u'", "v'"]
    der = {"x": "u", "y": "v", "u": "u'", "v": "v'"}
    eqs = [("force x", ["u'", "lam", "x"]), ("force y", ["v'", "lam", "y"]), ("rod", ["x", "y"])]
    counts, index, graph = _pantelides(_flat(names, der, eqs))
    assert counts == {"force x": 0, "force y": 0, "rod": 2}
    assert index == 3
    _assert_final_matching(graph)


def test_gear_pair_structure():
    # phi1 = r·phi2 couples two inertias: the coupling is differentiated twice (to the accelerations)
    names = ["p1", "w1", "a1", "p2", "w2", "a2", "t1", "t2"]
    der = {"p1": "w1", "w1": "a1", "p2": "w2", "w2": "a2"}
    eqs = [("inertia 1", ["a1", "t1"]), ("kinematics", ["p1", "p2"]), ("torques", ["t1", "t2"]),
           ("inertia 2", ["a2", "t2"])]
    counts, index, graph = _pantelides(_flat(names, der, eqs))
    assert counts == {"inertia 1": 0, "kinematics": 2, "torques": 0, "inertia 2": 0}
    assert index == 3
    _assert_final_matching(graph)


def test_index_one_structure_is_left_alone():
    # an inertia on a spring: every equation matches an unknown, nothing is differentiated
    names = ["phi", "w", "a", "tau"]
    der = {"phi": "w", "w": "a"}
    eqs = [("spring", ["tau", "phi"]), ("inertia", ["a", "tau"])]
    counts, index, graph = _pantelides(_flat(names, der, eqs))
    assert counts == {"spring": 0, "inertia": 0}
    assert index == 1
    assert not graph.diff
    _assert_final_matching(graph)


# ---- mechnet against casadi.dae_reduce_index ------------------------------------------------------


def _gear_pair():
    m = mn.Model("gear")
    tq = m.add(rot.ConstantTorque(name="tq", tau_constant=1.5))
    j1 = m.add(rot.Inertia(name="j1", J=0.2, phi_start=0.1, w_start=-0.4))
    gear = m.add(rot.IdealGear(name="gear", ratio=3.0))
    j2 = m.add(rot.Inertia(name="j2", J=0.5))
    m.connect(tq.flange, j1.flange_a)
    m.connect(j1.flange_b, gear.flange_a)
    m.connect(gear.flange_b, j2.flange_a)
    return m


def _position_on_mass():
    m = mn.Model("shaker")
    src = m.add(tr.Position(name="src", s_ref=Sine(0.1, 2.0)))
    mass = m.add(tr.Mass(name="mass", m=1.0))
    m.connect(src.flange, mass.flange_a)
    return m


# CasADi's DAE is first order: each state x with der(x) = v (v itself a state) gets a relation
# der(x) - v = 0, which CasADi differentiates along with the constraints. These are its counts for them.
CASES = {
    "pendulum": (lambda: cartesian_pendulum(0.5), {"der(p.x) = p.vx": 1, "der(p.y) = p.vy": 1}),
    "gear": (_gear_pair, {"der(j1.phi) = j1.w": 1, "der(j2.phi) = j2.w": 1}),
    "position": (_position_on_mass, {"der(mass.s) = mass.v": 1, "der(mass.v) = mass.a": 0}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_differentiation_counts_agree_with_casadi(case):
    factory, relations = CASES[case]
    cm = factory().compile()
    index = cm.stages["index"]
    form = implicit_form(cm.stages["simplified"])
    reduced, stats = ca.dae_reduce_index(form.dae, {})       # CasADi's Pantelides, no stabilisation
    # the structural index: CasADi's stats["index"] is max differentiations + 1, like mechnet's
    assert stats["index"] == index.index == 3
    counted = casadi_reduction(form)
    assert counted.index == stats["index"]
    # CasADi keeps one invariant per differentiation: the decoded counts add up to that
    assert sum(counted.counts) == reduced["I"].numel()
    flat_counts = {form.labels[k]: n for k, n in enumerate(counted.counts[:form.n_flat]) if n > 0}
    assert flat_counts == dict(index.differentiated)
    assert {form.labels[k]: n for k, n in enumerate(counted.counts) if k >= form.n_flat} == relations
    # the Baumgarte route reports CasADi's counts through the same interface
    baumgarte = factory().compile(mn.CompileOptions(reduce=IndexReductionOptions(method="baumgarte")))
    report = baumgarte.stages["index"]
    assert report.differentiated == index.differentiated
    assert report.index == index.index
    assert dict(report.state_relations) == {k: n for k, n in relations.items() if n > 0}


def test_summary_lists_a_loops_differentiated_residuals_once_under_their_loop():
    # The six-bar's two loops: each loop's label (cut joint, loop, its joints) appears once in the
    # index line, followed by its three planar closure residuals and how often each was differentiated.
    from models import stephenson_mm

    line = next(l for l in stephenson_mm().compile().summary().splitlines() if l.strip().startswith("index:"))
    for cut in ("pin_O1", "pin_R"):
        head = f"{cut} (Revolute), loop "
        assert line.count(head) == 1
        tail = line.split(head)[1].split("(Revolute), loop")[0].split("; dummy derivatives")[0]
        assert "closure residual position x (world axes) ×2" in tail
        assert "closure residual rotation about z (frame_a axes) ×1" in tail
