"""mechnet.numeric: mapped CasADi calls on numpy memory give what the plain DM call gives."""
import casadi as ca
import numpy as np
import pytest

from mechnet.numeric import NumpyCall, dense, mapped


def _sample():
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    # a sparse matrix output (column-major in CasADi)
    return ca.Function("f", [x, p], [ca.vertcat(ca.sin(x[0]) * p[0], 0, x[1] * x[2] + p[1]),
                                     ca.jacobian(ca.vertcat(x[0] * x[1], x[2] ** 2), x)])


def test_mapped_matches_the_dm_call_exactly():
    f, n = _sample(), 7
    rng = np.random.default_rng(1)
    X, P = rng.normal(size=(3, n)), rng.normal(size=(2, n))
    y, jac = mapped(f, n)(X, P)
    ref = f.map(n)(X, P)
    assert y.shape == (3, n) and jac.shape == (2, 3 * n)
    np.testing.assert_array_equal(y, np.asarray(ref[0]))      # same evaluation, no round-off allowed
    np.testing.assert_array_equal(jac, np.asarray(ref[1]))


def test_dense_keeps_values_and_stores_zeros():
    f = _sample()
    assert not f.sparsity_out(1).is_dense()          # the Jacobian keeps 3 of 6 entries
    g = dense(f)
    assert all(g.sparsity_out(i).is_dense() for i in range(g.n_out()))
    x, p = [0.3, -1.2, 2.0], [1.5, 0.25]
    for a, b in zip(f(x, p), g(x, p)):
        np.testing.assert_array_equal(np.asarray(ca.densify(a)), np.asarray(b))


def test_sparse_outputs_and_wrong_sizes_are_refused():
    with pytest.raises(ValueError, match="dense"):
        NumpyCall(_sample())
    call = mapped(_sample(), 4)
    with pytest.raises(ValueError, match=r"input 0 has shape \(3, 3\), expected 3×4"):
        call(np.zeros((3, 3)), np.zeros((2, 4)))


def test_a_missing_input_is_refused_not_read_from_stale_memory():
    call = mapped(_sample(), 2)
    with pytest.raises(ValueError, match="1 inputs given, expected 2"):
        call(np.zeros((3, 2)))


def test_one_instance_serves_several_threads():
    """Each call takes its own buffer: 4 threads × 200 calls on one cached instance, each with its own
    inputs, get exactly what the DM call gives (with one shared buffer, calls read each other's inputs)."""
    from concurrent.futures import ThreadPoolExecutor
    f = dense(_sample())
    call = NumpyCall(f)
    rng = np.random.default_rng(2)
    points = [(rng.normal(size=3), rng.normal(size=2)) for _ in range(4)]
    expected = [np.asarray(f(x, p)[0]) for x, p in points]

    def worker(k):
        x, p = points[k]
        return all(np.array_equal(call(x, p)[0], expected[k]) for _ in range(200))
    with ThreadPoolExecutor(4) as pool:
        assert all(pool.map(worker, range(4)))
