"""Integrators are cached per output pattern and table *shape*, not per table: a new input table of the
same size is a new parameter value of the same integrator, and the cache is bounded."""
from __future__ import annotations

import numpy as np

import mechnet as mn
from mechnet.compile.compiled import INTEGRATORS_PER_THREAD
from mechnet.components import rotational as rot

J = 0.5


def driven_inertia():
    """An inertia driven by an input torque: w(t) = w0 + (1/J)∫tau, exact for a piecewise-linear tau."""
    m = mn.Model("driven")
    tq = m.add(rot.Torque(name="tq"))
    j1 = m.add(rot.Inertia(name="j1", J=J, phi_start=0.0, w_start=0.0))
    m.connect(tq.flange, j1.flange_a)
    return m.compile()


def test_new_tables_of_one_size_reuse_one_integrator_and_are_honoured():
    cm = driven_inertia()
    times = np.array([0.0, 0.5, 1.0, 2.0])
    for k in range(5):
        values = np.array([1.0, -2.0, 3.0, 0.5]) * (k + 1)
        res = cm.simulate(2.0, inputs={"tq.tau": (times, values)}, rtol=1e-10, atol=1e-12)
        # trapezoids of the table, over J; rtol 1e-10 on |w| <= 10 rad/s: within 1e-8
        w_exact = np.trapezoid(values, times) / J
        assert abs(res["j1.w"][-1] - w_exact) < 1e-8, k
    assert len(cm.integrators()) == 1


def test_callables_sampled_on_one_grid_share_the_integrator():
    cm = driven_inertia()
    for k in range(1, 4):
        res = cm.simulate(1.0, inputs={"tq.tau": lambda t, k=k: k * t}, rtol=1e-10, atol=1e-12)
        # tau = k t sampled linearly is exact: w(1) = k / (2 J)
        assert abs(res["j1.w"][-1] - k / (2 * J)) < 1e-8
    assert len(cm.integrators()) == 1


def test_the_cache_is_bounded():
    cm = driven_inertia()
    for n in range(3, 3 + INTEGRATORS_PER_THREAD + 8):          # a new output grid per run
        res = cm.simulate(1.0, n_out=n, inputs={"tq.tau": 2.0})
        assert abs(res["j1.phi"][-1] - 2.0 / (2 * J)) < 1e-5      # phi = tau t² / (2J); rtol 1e-6
    assert len(cm.integrators()) == INTEGRATORS_PER_THREAD
