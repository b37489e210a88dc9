"""The Gauss–Legendre step that carries a run over a change point (simulate/change_points.py): its tableau
against the textbook conditions, to round-off (1e-14)."""
import numpy as np

from mechnet.simulate import change_points as cp


def test_nodes_and_weights_are_gauss_legendre_on_the_unit_interval():
    nodes, weights = np.polynomial.legendre.leggauss(4)          # on [−1, 1]
    assert np.allclose(cp.GAUSS_C, (nodes + 1) / 2, rtol=0, atol=1e-15)
    assert np.allclose(cp.GAUSS_B, weights / 2, rtol=0, atol=1e-15)


def test_the_coefficients_are_collocation_of_order_eight():
    # C(4): Σ_j a_ij c_j^(k−1) = c_i^k / k; B(8): Σ_i b_i c_i^(k−1) = 1/k, k ≤ 8; and the dense output
    # at τ = 1 is the weights (the collocation polynomial ends where the step does).
    c, b, A = cp.GAUSS_C, cp.GAUSS_B, cp.GAUSS_A
    for k in range(1, 5):
        assert np.allclose(A @ c ** (k - 1), c ** k / k, rtol=0, atol=1e-14)
    for k in range(1, 9):
        assert abs(b @ c ** (k - 1) - 1 / k) < 1e-14
    assert np.allclose(cp._integrated(1.0), b, rtol=0, atol=1e-14)
    assert np.allclose(cp._integrated(0.0), 0.0, rtol=0, atol=0)
