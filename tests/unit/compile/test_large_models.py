"""Large models: nothing in the compiler may depend on Python's recursion limit (issue 15, item 7).

A chain of 400+ bodies used to fail with RecursionError in networkx's recursive Hopcroft–Karp
matching (structure stage). The checks on the compiled chains are physical: forward kinematics
against the closed form of a planar chain, and the hanging chain as an equilibrium.
"""
import inspect
import sys

import numpy as np
import pytest

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.compile.structure import maximum_matching

G = 9.81        # World's default gravity, along −y


def test_matching_needs_no_recursion_on_a_long_augmenting_path():
    """Equation 0 uses x0, equation e uses x(e−1) and xe: the one perfect matching is e → xe, but a
    search that first gives x(e−1) to equation e must undo it along a path through all 20000 pairs
    (networkx's recursive search overflowed at a few hundred)."""
    n = 20000
    incidence = [[0]] + [[e - 1, e] for e in range(1, n)]
    assert maximum_matching(incidence, n) == {e: e for e in range(n)}


def _chain(n: int) -> mn.Model:
    """World — n × (revolute about z, unit rod along x, 1 kg particle at the rod's end)."""
    m = mn.Model(f"chain{n}")
    previous = m.add(mb.World(name="world")).frame_b
    for k in range(n):
        rev = m.add(mb.Revolute(name=f"rev{k}", n=[0, 0, 1], phi_start=0.0, w_start=0.0))
        rod = m.add(mb.FixedTranslation(name=f"rod{k}", r=[1.0, 0, 0]))
        mass = m.add(mb.Particle(name=f"mass{k}", m=1.0))
        m.connect(previous, rev.frame_a)
        m.connect(rev.frame_b, rod.frame_a)
        m.connect(rod.frame_b, mass.frame_a)
        previous = rod.frame_b
    return m


def _check_chain(cm, n: int):
    """2n states and an explicit ODE; the tip where the closed form puts it; the hanging chain at rest."""
    assert cm.n_states == 2 * n and cm.dae.z.numel() == 0
    # tip = Σ_k (cos θ_k, sin θ_k), θ_k = φ_0 + … + φ_k (unit links); atol 1e-9 m on a chain n m long
    phi = np.random.default_rng(1).uniform(-0.3, 0.3, n)
    frames = mn.kinematics(cm, q={f"rev{k}": phi[k] for k in range(n)})
    theta = np.cumsum(phi)
    tip = frames[f"rod{n - 1}.frame_b"]["r_0"]
    assert np.allclose(np.ravel(tip)[:2], [np.sum(np.cos(theta)), np.sum(np.sin(theta))], rtol=0, atol=1e-9)
    # hanging straight down (φ_0 = −π/2, the rest 0) at rest: every acceleration 0 (atol 1e-9 rad/s²,
    # scale g = 9.81 m/s² per metre)
    x = np.zeros(2 * n)
    x[cm.state_names.index("rev0.phi")] = -np.pi / 2
    dae = cm.dae
    rates = np.ravel(dae.ode(0.0, x, np.zeros(0), list(dae.u_default), list(dae.p_value), list(dae.d_value)).full())
    assert np.max(np.abs(rates)) < 1e-9


def test_compiling_a_chain_does_not_depend_on_the_recursion_limit():
    """A 80-body chain compiles with the recursion limit set 80 frames above the caller (the
    compiler itself nests ~40 deep; the recursive matching needed ~2 frames per body)."""
    n, limit = 80, sys.getrecursionlimit()
    model = _chain(n)
    sys.setrecursionlimit(len(inspect.stack(0)) + 80)
    try:
        cm = model.compile()
    finally:
        sys.setrecursionlimit(limit)
    _check_chain(cm, n)


@pytest.mark.slow
@pytest.mark.parametrize("n", [500, 2000])
def test_a_long_chain_compiles(n):
    """Measured on a shared 2-core machine: N = 500 in 15–19 s, N = 2000 in 134 s (compile time grows
    faster than N: Pantelides' augmenting searches and the tree pass, not this test's concern)."""
    cm = _chain(n).compile()
    _check_chain(cm, n)
