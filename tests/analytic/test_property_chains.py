"""Property test: random 1D chains compile, simulate, and conserve energy like a hand-written model."""
from __future__ import annotations

import casadi as ca
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components import translational as tr

LIBS = {
    "rotational": (rot, "J", "phi", "w", "phi_rel", "c"),
    "translational": (tr, "m", "s", "v", "s_rel", "c"),
}

chains = st.fixed_dictionaries({
    "domain": st.sampled_from(sorted(LIBS)),
    "masses": st.lists(st.floats(0.1, 10.0), min_size=1, max_size=6),
    "stiffness": st.lists(st.floats(1.0, 1000.0), min_size=7, max_size=7),
    "damping": st.lists(st.one_of(st.just(0.0), st.floats(0.01, 1.0)), min_size=7, max_size=7),
    "wall_at_end": st.booleans(),
    "kicked": st.integers(0, 5),
})


def _build(spec, undamped):
    lib, mass_par, pos, vel, _, _ = LIBS[spec["domain"]]
    m = mn.Model("chain")
    previous = m.add(lib.Fixed(name="left")).flange
    n = len(spec["masses"])
    kicked = spec["kicked"] % n
    for k, mass in enumerate(spec["masses"]):
        c, d = spec["stiffness"][k], 0.0 if undamped else spec["damping"][k]
        element = m.add(lib.SpringDamper(name=f"e{k}", c=c, d=d) if d > 0 else lib.Spring(name=f"e{k}", c=c))
        body = m.add(getattr(lib, "Inertia" if lib is rot else "Mass")(
            name=f"b{k}", **{mass_par: mass, f"{pos}_start": 0.1 if k == kicked else 0.0, f"{vel}_start": 0.0}))
        m.connect(previous, element.flange_a)
        m.connect(element.flange_b, body.flange_a)
        previous = body.flange_b
    if spec["wall_at_end"]:
        element = m.add(lib.Spring(name="e_end", c=spec["stiffness"][n]))
        right = m.add(lib.Fixed(name="right"))
        m.connect(previous, element.flange_a)
        m.connect(element.flange_b, right.flange)
    return m


def _stiffness_matrix(spec):
    n = len(spec["masses"])
    K = np.zeros((n, n))
    for k in range(n):
        c = spec["stiffness"][k]
        K[k, k] += c
        if k > 0:
            K[k - 1, k - 1] += c
            K[k, k - 1] -= c
            K[k - 1, k] -= c
    if spec["wall_at_end"]:
        K[n - 1, n - 1] += spec["stiffness"][n]
    return K


def _hand_written_energy_drift(spec, t_grid, rtol, atol):
    """The same undamped chain written directly in CasADi, same CVODES-BDF settings: max |ΔE|."""
    n = len(spec["masses"])
    M = np.array(spec["masses"])
    K = _stiffness_matrix(spec)
    q, v = ca.SX.sym("q", n), ca.SX.sym("v", n)
    ode = ca.vertcat(v, -ca.mtimes(ca.DM(K), q) / ca.DM(M))
    F = ca.integrator("F", "cvodes", {"x": ca.vertcat(q, v), "ode": ode}, t_grid[0], list(t_grid[1:]),
                      {"reltol": rtol, "abstol": atol, "linear_multistep_method": "bdf",
                       "nonlinear_solver_iteration": "newton", "max_num_steps": 20000})
    x0 = np.zeros(2 * n)
    x0[spec["kicked"] % n] = 0.1
    X = np.column_stack([x0, np.asarray(F(x0=x0)["xf"])])
    E = 0.5 * np.sum(M[:, None] * X[n:] ** 2, axis=0) + 0.5 * np.einsum("it,ij,jt->t", X[:n], K, X[:n])
    return np.max(np.abs(E - E[0])), E[0]


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spec=chains, undamped=st.booleans())
def test_random_chains_compile_simulate_and_conserve_energy(spec, undamped):
    lib, mass_par, pos, vel, rel, c_name = LIBS[spec["domain"]]
    cm = _build(spec, undamped).compile()
    n = len(spec["masses"])
    assert cm.dae.is_ode and cm.n_states == 2 * n
    rtol = atol = 1e-8
    res = cm.simulate(1.0, rtol=rtol, atol=atol, method="cvodes-bdf", n_out=201)
    assert res.success
    assert all(np.all(np.isfinite(res[name])) for name in cm.state_names)
    if not undamped:
        return
    M = np.array(spec["masses"])
    E = sum(0.5 * M[k] * res[f"b{k}.{vel}"] ** 2 for k in range(n))
    E = E + sum(0.5 * spec["stiffness"][k] * res[f"e{k}.{rel}"] ** 2 for k in range(n))
    if spec["wall_at_end"]:
        E = E + 0.5 * spec["stiffness"][n] * res[f"e_end.{rel}"] ** 2
    drift = np.max(np.abs(E - E[0]))
    # Bound: 3× the drift of a hand-written CasADi model with the same method, tolerances (rtol = atol
    # = 1e-8), horizon (1 s) and grid; scale E0 sets a floor of 1e-12·E0 where the reference drifts less.
    hand, E0 = _hand_written_energy_drift(spec, res.t, rtol, atol)
    assert abs(E[0] - E0) < 1e-12 * max(E0, 1e-300)
    assert drift <= 3 * max(hand, 1e-12 * E0), (drift, hand, E0)
