"""`cm.functions()`: the documented contract every export kind is built from.

Every function takes the compiled model's arguments in one order,
(t, x, z, u, p, d): time, differential states, algebraic variables (the torn
loop unknowns), inputs, tunable parameters, discrete modes. Modes are
piecewise-constant numbers changed only at events (a relay on or off, a
friction element stuck or sliding); in an FMU they are discrete variables.

    ode(t,x,z,u,p,d) -> xdot            the state derivatives
    alg(t,x,z,u,p,d) -> res             0 = res determines z (empty for an ODE)
    observed(t,x,z,u,p,d) -> y          every dotted name of the scene, `observed_names` order
    invariants(t,x,z,u,p,d) -> c        the constraints index reduction differentiated, and |Q| − 1 of each
                                        quaternion (0 on the solution)
    zero(t,x,z,u,p,d) -> g              event conditions; an event is g crossing 0 in its direction
    transition[i](t,x,z,u,p,d) -> (x_plus, d_plus)   the states and modes after event i
    rest[i]: like transition[i], or None            the plastic jump and rest modes that end an
                                        accumulation of event i (a ball coming to rest)
    init(t, u, p, d, s, w0) -> (x, z, residual_norm)  consistent start from the start values s
    solve_alg(t, x, z0, u, p, d) -> (z, residual_norm)   z from the states, warm-started at z0
    jac_ode, jac_alg (t,x,z,u,p,d) -> (d/dx, d/dz, d/du, d/dp)    sparse Jacobians
    alg_jac(t,x,z,u,p,d) -> d alg/d(x, z), dense: the FMU's branch and conditioning watch
    forward(t,x,z,u,p,d, dx,du,dp) -> (dxdot, dy, dz)  directional derivatives along the solution
                                        manifold (z follows x, u, p through alg = 0)

`init` and `solve_alg` are damped Newton iterations built from CasADi Functions
(`newton.py`), so they code-generate into C and FMUs. `metadata` is a plain
record (JSON-ready) of names, units, start and nominal values, causality,
variability and the dependency sparsity.
"""
from __future__ import annotations

import sys

import casadi as ca
import numpy as np

from ..caches import BUILD_LOCK, built
from ..core.errors import MechnetError
from ..simulate.initialize import _start_terms, initial_equations, start_conditions
from .newton import damped_newton, linear_solve

FORMAT_VERSION = 1
ARGS = ("t", "x", "z", "u", "p", "d")


class ExportError(MechnetError):
    """An export that cannot be written or loaded as asked."""


def functions(cm) -> dict:
    """The contract (module docstring), built once per compiled model, for the choice of states the
    simulator runs with from the model's start (`exported_selection`)."""
    with BUILD_LOCK:
        made = built(cm.dae.info, "_export_functions", lambda: _build(cm, *exported_selection(cm)))
    return dict(made)


def _build(cm, dae, verdict: dict) -> dict:
    args = [dae.t, dae.x, dae.z, dae.u, dae.p, dae.d]
    out = {"ode": dae.ode, "alg": dae.alg, "observed": dae.observed, "invariants": dae.invariants,
           "zero": dae.zero, "transition": tuple(dae.transition),
           "rest": tuple(dae.info.get("rest_transition", ()) or (None,) * len(dae.transition))}
    ode = dae.ode(*args)
    alg = dae.alg(*args)
    wrt = (dae.x, dae.z, dae.u, dae.p)
    for name, expr in (("jac_ode", ode), ("jac_alg", alg)):
        out[name] = ca.Function(name, args, [ca.jacobian(expr, v) for v in wrt], list(ARGS),
                                [f"d{name[4:]}_d{v}" for v in "xzup"])
    out["solve_alg"] = _solve_alg(dae, args, alg)
    out["forward"] = _forward(dae, args, ode, alg)
    out["alg_jac"] = ca.Function("alg_jac", args, [ca.densify(ca.jacobian(alg, ca.vertcat(dae.x, dae.z)))],
                                 list(ARGS), ["J"])
    init, starts, init_dependencies = _init(dae)
    out["init"] = init
    out["metadata"] = metadata(cm, dae, starts, verdict)
    out["metadata"]["dependencies"].update(init_dependencies)
    return out


def _solve_alg(dae, args, alg) -> ca.Function:
    t, x, z, u, p, d = args
    newton = damped_newton("solve_alg_newton", alg, z, [t, x, u, p, d])
    z0 = ca.MX.sym("z0", z.numel())
    m = [ca.MX.sym(n, a.numel()) for n, a in zip("txupd", (t, x, u, p, d))]
    z_sol, norm = newton(z0, *m)
    return ca.Function("solve_alg", [m[0], m[1], z0, *m[2:]], [z_sol, norm],
                       ["t", "x", "z0", "u", "p", "d"], ["z", "residual_norm"])


def _forward(dae, args, ode, alg) -> ca.Function:
    """Directional derivatives of (xdot, y, z) along seeds of (x, u, p), with z following through
    alg = 0: dz = -alg_z⁻¹ (alg_x dx + alg_u du + alg_p dp), a sparse QR solve in MX (generates C)."""
    t, x, z, u, p, d = args
    y = dae.observed(*args)
    seeds = [ca.SX.sym("d" + n, v.numel()) for n, v in (("x", x), ("u", u), ("p", p))]
    known = ca.vertcat(x, u, p)
    seed = ca.vertcat(*seeds)
    parts = ca.Function("forward_parts", [*args, *seeds],
                        [ca.jtimes(ode, known, seed), ca.jtimes(y, known, seed),
                         ca.jtimes(alg, known, seed) if alg.numel() else ca.SX(0, 1),
                         ca.jacobian(alg, z), ca.jacobian(ode, z), ca.jacobian(y, z)])
    m = [ca.MX.sym(n, a.numel()) for n, a in zip(ARGS, args)]
    ms = [ca.MX.sym("d" + n, v.numel()) for n, v in (("x", x), ("u", u), ("p", p))]
    f_ode, f_y, f_alg, a_z, o_z, y_z = parts(*m, *ms)
    if z.numel():
        dz = -linear_solve(a_z, f_alg)
        f_ode, f_y = f_ode + ca.mtimes(o_z, dz), f_y + ca.mtimes(y_z, dz)
    else:
        dz = ca.MX(0, 1)
    return ca.Function("forward", [*m, *ms], [f_ode, f_y, dz], [*ARGS, "dx", "du", "dp"],
                       ["dxdot", "dy", "dz"])


def _init(dae):
    """init(t, u, p, d, s, w0) for the model's own start values (`dae.starts`), the system the simulator
    solves at t = 0 with the default inputs and parameters: the same conditions (constants dropped,
    aliases once), the same equations, the same seeds (a start fixing one variable linearly sets it)."""
    u0, p0 = np.array(dae.u_default, dtype=float), np.array(dae.p_value, dtype=float)
    names, conditions, implied = start_conditions(dae, 0.0, u0, p0, dict(dae.starts))
    kept = tuple(c[1] for c in conditions)
    nw = dae.x.numel() + dae.z.numel()
    w, (t, u, p, d, fixed), res = initial_equations(dae, names, kept, conditions)
    exprs, _, linear, _ = _start_terms(dae, names)
    w0 = ca.SX.sym("w0", nw)
    seeded = [w0[j] for j in range(nw)]
    row = {c[0]: r for r, c in enumerate(conditions)}
    for j, (name, _) in implied.items():
        k = names.index(name)
        offset = ca.substitute(exprs[k], w, ca.DM.zeros(nw))
        coef = ca.jacobian(exprs[k], w)[j]
        seeded[j] = (fixed[row[name]] - offset) / coef
    seed = ca.Function("init_seed", [t, u, p, d, fixed, w0], [ca.vertcat(*seeded) if nw else ca.SX(0, 1)])
    newton = damped_newton("init_newton", res, w, [t, u, p, d, fixed])
    m = [ca.MX.sym(n, a.numel()) for n, a in (("t", t), ("u", u), ("p", p), ("d", d), ("s", fixed), ("w0", w0))]
    w_sol, norm = newton(seed(*m), *m[:5])
    nx_ = dae.x.numel()
    init = ca.Function("init", m, [w_sol[:nx_], w_sol[nx_:], norm], ["t", "u", "p", "d", "s", "w0"],
                       ["x", "z", "residual_norm"])
    return init, [(c[0], c[2]) for c in conditions], _init_dependencies(dae, w, (t, u, p, d, fixed), res)


def _init_dependencies(dae, w, knowns, res) -> dict:
    """Which start values s, inputs u, parameters p and modes d each state, derivative and observed
    value depends on at the start (FMI's initial unknowns): structural, through the initial system solved as
    an implicit function (`dependencies`)."""
    t, u, p, d, fixed = (ca.MX.sym(n, a.numel()) for n, a in zip("tupds", knowns))
    nx_ = dae.x.numel()
    if w.numel():
        g = ca.Function("g", [w, ca.vertcat(*knowns)], [res])
        w_of = ca.rootfinder("w_of", "newton", g)(ca.DM.zeros(w.numel()), ca.vertcat(t, u, p, d, fixed))
    else:
        w_of = ca.MX(0, 1)
    x, z = w_of[:nx_], w_of[nx_:]
    exprs = {"x": x, "xdot": dae.ode(t, x, z, u, p, d), "y": dae.observed(t, x, z, u, p, d)}
    return {f"init_{name}_{k}": _pattern(ca.jacobian_sparsity(e, v)) if e.numel() and v.numel() else []
            for name, e in exprs.items() for k, v in (("s", fixed), ("u", u), ("p", p), ("d", d))}


def _pattern(sp: ca.Sparsity) -> list:
    """[[row, col], ...] of a sparsity pattern (JSON-ready)."""
    rows, cols = sp.get_triplet()
    return [[int(r), int(c)] for r, c in zip(rows, cols)]


def dependencies(dae) -> dict:
    """Which knowns each unknown depends on, with z eliminated through alg = 0: structural, from
    CasADi's sparsity propagation through an implicit function (`rootfinder` propagates the block
    triangular form of alg_z). Keys: "xdot_x", "xdot_u", "y_x", "y_u", "y_p", "z_x" ... as patterns."""
    args = [ca.MX.sym(n, a.numel()) for n, a in zip(ARGS, (dae.t, dae.x, dae.z, dae.u, dae.p, dae.d))]
    t, x, z, u, p, d = args
    if dae.z.numel():
        g = ca.Function("g", [z, ca.vertcat(t, x, u, p, d)], [dae.alg(t, x, z, u, p, d)])
        z = ca.rootfinder("z_of", "newton", g)(ca.DM.zeros(dae.z.numel()), ca.vertcat(t, x, u, p, d))
    xdot = dae.ode(t, x, z, u, p, d)
    y = dae.observed(t, x, z, u, p, d)
    out = {}
    for name, expr in (("xdot", xdot), ("y", y), ("z", z)):
        for wrt_name, wrt in (("x", x), ("u", u), ("p", p)):
            out[f"{name}_{wrt_name}"] = _pattern(ca.jacobian_sparsity(expr, wrt)) if expr.numel() and wrt.numel() \
                else []
    return out


def metadata(cm, dae, starts: list, verdict: dict) -> dict:
    """The JSON-ready description of the exported model (module docstring)."""
    flat = cm.stages.get("flat")
    kinds = {v.name: v.kind for v in flat.variables} if flat is not None else {}
    nominal = dae.info.get("nominal", {})

    def var(name, **more):
        return {"name": name, "unit": dae.units.get(name, "1"), **more}

    return {
        "format": FORMAT_VERSION,
        "name": cm.name,
        "x": [var(n, nominal=float(v)) for n, v in zip(dae.x_names, dae.x_nominal)],
        "z": [var(n, nominal=float(v)) for n, v in zip(dae.z_names, dae.z_nominal)],
        "u": [var(n, default=float(v), causality="input", variability="continuous")
              for n, v in zip(dae.u_names, dae.u_default)],
        "p": [var(n, value=float(v), causality="parameter", variability="tunable", **_check(dae, n))
              for n, v in zip(dae.p_names, dae.p_value)],
        "d": [var(n, start=float(v), variability="discrete") for n, v in zip(dae.d_names, dae.d_value)],
        "observed": [var(n, kind=kinds.get(n, "parameter" if n in dae.p_names else "mode"
                                             if n in dae.d_names else "frame"),
                         nominal=float(nominal.get(n, 1.0))) for n in dae.observed_names],
        "starts": [{"name": n, "value": float(v)} for n, v in starts],
        "declared_starts": [{"name": n, "value": float(v)} for n, v in dae.starts.items()],
        "guesses": {n: float(v) for n, v in dae.guesses.items()},
        "zero": [{"label": lab, "direction": int(s), "at_start": bool(a)} for lab, s, a in
                 zip(dae.zero_labels, dae.zero_directions,
                     dae.info.get("zero_at_start", ()) or [False] * len(dae.zero_labels))],
        "time_events": [[float(tt), str(cause)] for tt, cause in dae.time_events],
        "invariants": list(dae.invariant_names),
        "quaternions": [list(index) for index in dae.info.get("quaternions", ())],   # x indices, renormalised
        "alg_labels": list(dae.info.get("alg_labels", ())),
        "linear_tears": list(dae.info.get("linear_tears", ())),       # large linear blocks left to the solver
        "folded_parameters": list(dae.info.get("folded_parameters", ())),
        # comparisons between parameters a new value must keep (`core/requirements.py`): `load` and the
        # FMU's C wrapper check them as simulate(params=) does
        "parameter_requirements": [dict(entry) for entry in dae.info.get("parameter_requirements", ())],
        "dependencies": dependencies(dae),
        "selection": verdict,
    }


def exported_selection(cm):
    """(dae, verdict): the choice of states an export holds — the one the simulator runs with from
    the model's own start: the start-point choice, or the one its whole-branch check picks
    (`simulate/branch.py`). `verdict["holds"]` is False when no choice serves the whole branch: a run
    may then need a re-selection an export cannot make (`load` and the FMU say so)."""
    from ..simulate.initialize import initialize
    from ..simulate.reselection import SelectionMonitor
    dae = cm.dae
    monitor = SelectionMonitor.create(cm, dae)
    if monitor is None:
        return dae, {"holds": True, "states": list(dae.x_names),
                     "reason": "no state selection to watch (a tree, or constant constraint Jacobians)"}
    u0, p0 = np.array(dae.u_default, dtype=float), np.array(dae.p_value, dtype=float)
    d0 = np.array(dae.d_value, dtype=float)
    start = initialize(dae, 0.0, u0, p0, dict(dae.starts), {})
    verdict = monitor.whole_branch(monitor.values_at(dae, 0.0, start.x, start.z, u0, p0, d0), p0)
    if verdict.holds and verdict.dummies != monitor.current:
        dae = cm.selection(verdict.dummies)
    return dae, {"holds": bool(verdict.holds), "states": list(dae.x_names), "reason": verdict.describe()}


def _check(dae, name: str) -> dict:
    """A tunable parameter's owner, doc and check: by its name for one of core/declarations.py's checks,
    as "module:name" for one defined elsewhere in mechnet (a coefficient of restitution's), so `load`
    finds it again; None for a check of the user's own."""
    from ..core import declarations
    declaration, owner = dae.info.get("parameter_checks", {}).get(name, (None, name))
    check = getattr(declaration, "check", None)
    known, module = getattr(check, "__name__", ""), getattr(check, "__module__", "") or ""
    if getattr(declarations, known, None) is check:
        where = known
    elif module.startswith("mechnet.") and getattr(sys.modules.get(module), known, None) is check:
        where = f"{module}:{known}"
    else:
        where = None
    return {"owner": owner, "doc": getattr(declaration, "doc", ""), "check": where}
