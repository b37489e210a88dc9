"""Emit: from the structured flat system to CasADi functions ẋ = ode(...), 0 = alg(...).

Blocks are solved in BLT order (see tearing.py); each solved variable becomes an
expression of the base symbols (states x, tearing variables z, inputs u,
tunable parameters p, modes d, time t), substituted only where the next blocks use it so
the work stays linear in the model size. Every name of the scene — aliases,
constants, eliminated and torn variables — gets an `observed` expression.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from ..core.errors import StructureError

from .artifacts import AliasMap, FlatSystem, Selection, SemiExplicitDAE, StructureReport
from .tearing import BlockSolution, compose, solve_block

ARGS = ("t", "x", "z", "u", "p", "d")


@dataclass(frozen=True)
class EmitOptions:
    tearing: bool = True


def _fn(name, args, outputs, out_name):
    return ca.Function(name, list(args), [outputs], list(ARGS), [out_name], {"cse": True})


def _pivot(equation, position: dict, aliases: AliasMap, name_index: dict):
    """The variable an equation may be divided for (FlatEquation.pivot), also when simplification
    replaced it by an alias (c·v + k: its coefficient times c still cannot vanish); None when there is
    none, or when the pivot became one of the variables in `pivot_unless` (then the row holds v twice
    and its coefficient on v is no longer the pivot's)."""
    if not equation.pivot:
        return None
    resolved = [_resolve(n, position, aliases, name_index) for n in (equation.pivot, *equation.pivot_unless)]
    if resolved[0] is None or resolved[0] in resolved[1:]:
        return None
    return resolved[0]


def _resolve(name: str, position: dict, aliases: AliasMap, name_index: dict):
    """The remaining variable a name stands for (itself, or c·v + k after alias elimination), or None."""
    expr = aliases.expressions.get(name)
    if expr is None:
        return name_index.get(name)
    syms = ca.symvar(ca.SX(expr))
    if len(syms) != 1 or ca.depends_on(ca.jacobian(expr, syms[0]), syms[0]):
        return None
    return position.get(syms[0].element_hash())


def emit(original: FlatSystem, flat: FlatSystem, aliases: AliasMap, structure: StructureReport,
         options: EmitOptions = EmitOptions()) -> SemiExplicitDAE:
    variables = flat.variables
    symbols = [v.symbol for v in variables]
    # parameters whose check forbids zero: a coefficient made of them cannot vanish
    param_hashes = {p.symbol.element_hash() for p in flat.parameters
                    if p.declaration is None or p.declaration.check(0.0) is not None}
    value: dict[int, ca.SX] = {}          # variable index -> expression in base symbols
    z_index: list[int] = []
    alg: list[ca.SX] = []
    alg_labels: list[str] = []

    position = {s.element_hash(): i for i, s in enumerate(symbols)}
    name_index = {v.name: i for i, v in enumerate(variables)}
    depends: dict[int, set] = {}           # variable -> the unknowns its block reads
    linear_tears: list[str] = []           # algebraic variables closing a large linear block (tearing.py)
    for block in structure.blocks:
        block_vars = [structure.unknowns[structure.matching[e]] for e in block]
        residuals = [flat.equations[e].residual for e in block]
        outside = set()
        for r in residuals:
            outside.update(i for i in (position.get(s.element_hash()) for s in ca.symvar(r)) if i in value)
        if options.tearing:
            guarded = any(flat.equations[e].order > 0 or flat.equations[e].regular for e in block)
            pivots = {k: v for k, e in enumerate(block)
                      if (v := _pivot(flat.equations[e], position, aliases, name_index)) in block_vars}
            sol = solve_block(residuals, block_vars, symbols, param_hashes, guarded, pivots)
        else:
            sol = BlockSolution([], list(block_vars), residuals, list(range(len(block))))
        # compose: the block's own chain first (local, small), then the values from earlier blocks
        defs, res = compose([symbols[i] for i, _ in sol.solved], [e for _, e in sol.solved], sol.residuals)
        used = sorted(outside)
        if used and (defs or res):
            full = ca.substitute(ca.vertcat(*defs, *res), ca.vertcat(*[symbols[i] for i in used]),
                                 ca.vertcat(*[value[i] for i in used]))
            defs = [full[k] for k in range(len(defs))]
            res = [full[len(defs) + k] for k in range(len(res))]
        for (i, _), expr in zip(sol.solved, defs):
            value[i] = expr
        for i in block_vars:
            depends[i] = outside
        z_index.extend(sol.tears)
        if sol.linear:
            linear_tears.extend(variables[i].name for i in sol.tears)
        alg.extend(res)
        alg_labels.extend(flat.equations[block[k]].describe() for k in sol.rows)
    # torn variables are base symbols: substitute them nowhere, but observed reads them
    x_index = sorted(flat.der_of)
    u_index = [i for i, v in enumerate(variables) if v.kind == "input"]
    t = flat.time
    x = ca.vertcat(*[symbols[i] for i in x_index]) if x_index else ca.SX(0, 1)
    z = ca.vertcat(*[symbols[i] for i in z_index]) if z_index else ca.SX(0, 1)
    u = ca.vertcat(*[symbols[i] for i in u_index]) if u_index else ca.SX(0, 1)
    p = ca.vertcat(*[q.symbol for q in flat.parameters]) if flat.parameters else ca.SX(0, 1)
    modes = original.modes                 # (simplify keeps no modes: they are no variables)
    d = ca.vertcat(*[m.symbol for m in modes]) if modes else ca.SX(0, 1)

    def current(i):
        return value.get(i, symbols[i])

    ode_list = []
    for i in x_index:
        j, s = flat.der_of[i]
        ode_list.append(ca.SX(s) if j is None else s * current(j))
    ode_expr = ca.vertcat(*ode_list) if ode_list else ca.SX(0, 1)
    alg_expr = ca.vertcat(*alg) if alg else ca.SX(0, 1)
    args = (t, x, z, u, p, d)

    # observed: every name of the original flat system
    names, exprs = [], []
    survivor = {v.name: i for i, v in enumerate(variables)}
    solved_idx = list(value)
    sub_from = ca.vertcat(*[symbols[i] for i in solved_idx]) if solved_idx else None
    sub_to = ca.vertcat(*[value[i] for i in solved_idx]) if solved_idx else None
    for v in original.variables:
        names.append(v.name)
        if v.name in survivor:
            exprs.append(current(survivor[v.name]))
        else:
            exprs.append(aliases.expressions[v.name])
    if original.observed_only:
        extra = original.expand([ca.vertcat(*[expr for _, _, _, expr in original.observed_only])])[0]
        gone = [v for v in original.variables if v.name not in survivor]
        if gone:
            extra = ca.substitute(extra, ca.vertcat(*[v.symbol for v in gone]),
                                  ca.vertcat(*[aliases.expressions[v.name] for v in gone]))
        names.extend(name for name, _, _, _ in original.observed_only)
        exprs.extend(extra[k] for k in range(extra.numel()))
    obs = ca.vertcat(*exprs)
    if sub_from is not None:
        obs = ca.substitute(obs, sub_from, sub_to)
    # a derivative that survived as a state stands for itself; its own derivative is in ode
    for q in flat.parameters:
        names.append(q.name)
    names.extend(m.name for m in modes)
    obs = ca.vertcat(obs, p, d)

    # the tree's shared state-only intermediates, expanded once for everything (sharing kept)
    constraints = [eq for eq in flat.equations if eq.constraint]
    inv = ca.vertcat(*[eq.residual for eq in constraints]) if constraints else ca.SX(0, 1)
    if constraints and sub_from is not None:
        inv = ca.substitute(inv, sub_from, sub_to)
    quaternions, norms, norm_names = _quaternion_states(original, variables, x_index, x)
    inv = ca.vertcat(inv, norms)
    ode_expr, alg_expr, obs, inv = flat.expand([ode_expr, alg_expr, obs, inv])
    ode = _fn("ode", args, ode_expr, "xdot")
    algf = _fn("alg", args, alg_expr, "res")
    observed = _fn("observed", args, obs, "y")
    resolve = _without_aliases(original, survivor, aliases) if modes else None
    zero, transitions, rests = _events(flat, x_index, symbols, current, args, x, resolve, ode_expr, alg_expr,
                                       original.releases)
    invariants = _fn("invariants", args, inv, "c")
    requirements = _requirements(original, flat, symbols, current, args, survivor, aliases)
    x_names = tuple(variables[i].name for i in x_index)
    z_names = tuple(variables[i].name for i in z_index)
    units = {v.name: v.unit for v in original.variables}
    units.update({name: unit for name, _, unit, _ in original.observed_only})
    units.update({q.name: q.unit for q in flat.parameters})
    units.update({m.name: "1" for m in modes})
    starts = {v.name: v.start for v in original.variables if v.start is not None}
    guesses = {v.name: (v.guess if v.guess is not None else v.default_start) for v in original.variables}
    nominal = {v.name: v.nominal for v in original.variables}
    info = {"alg_labels": tuple(alg_labels), "linear_tears": tuple(linear_tears), "solved": len(value), "folded_parameters": flat.folded_parameters,
            "parameter_checks": {q.name: (q.declaration, q.owner) for q in flat.parameters}, "torn": len(z_index),
            "parameter_requirements": original.parameter_requirements,
            "observed_only": _count_observed_only(value, depends, flat, z_index, original),
            "nominal": nominal, "quaternions": quaternions,
            "zero_at_start": tuple(zc.at_start for zc in flat.zero_crossings), "rest_transition": rests,
            "impulses": tuple(m.name for m in modes if m.impulse), "start_requirements": requirements,
            "mode_values": {m.name: m.values for m in modes if m.values is not None}}
    return SemiExplicitDAE(
        name=flat.name, t=t, x=x, z=z, u=u, p=p, d=d,
        x_names=x_names, z_names=z_names,
        u_names=tuple(variables[i].name for i in u_index),
        p_names=tuple(q.name for q in flat.parameters), d_names=tuple(m.name for m in modes),
        ode=ode, alg=algf, observed=observed, observed_names=tuple(names),
        zero=zero, transition=transitions, invariants=invariants,
        invariant_names=tuple(eq.describe() for eq in constraints) + norm_names,
        zero_labels=tuple(zc.label for zc in flat.zero_crossings),
        zero_directions=tuple(zc.direction for zc in flat.zero_crossings),
        selections=(Selection(x_names, z_names, ode, algf, observed),),
        x_nominal=tuple(variables[i].nominal for i in x_index),
        z_nominal=tuple(variables[i].nominal for i in z_index),
        units=units, starts=starts, guesses=guesses,
        u_default=tuple(variables[i].input_default for i in u_index),
        p_value=tuple(q.value for q in flat.parameters), d_value=tuple(m.start for m in modes), time_events=flat.time_events, info=info)


def _requirements(original, flat, symbols, current, args, survivor, aliases):
    """(Function (t,x,z,u,p,d) -> values that must be >= 0 at the start, what each is), or None."""
    if not original.requirements:
        return None
    resolve = _without_aliases(original, survivor, aliases)
    position = {s.element_hash(): i for i, s in enumerate(symbols)}
    exprs = []
    for expr, _ in original.requirements:
        expr = resolve(expr)
        used = [position[s.element_hash()] for s in ca.symvar(expr) if s.element_hash() in position]
        subs = [(symbols[i], current(i)) for i in used if current(i) is not symbols[i]]
        if subs:
            expr = ca.substitute(expr, ca.vertcat(*[a for a, _ in subs]), ca.vertcat(*[b for _, b in subs]))
        exprs.append(expr)
    values = flat.expand([ca.vertcat(*exprs)])[0]
    return _fn("start_requirements", args, values, "r"), tuple(text for _, text in original.requirements)


def _quaternion_states(original, variables, x_index, x):
    """The quaternions among the states: their indices in x (the simulator renormalises them at every
    restart), |Q| − 1 as invariants, and those invariants' names. Only quaternions kept as states whole."""
    position = {variables[i].name: k for k, i in enumerate(x_index)}
    groups, norms, names = [], [], []
    for what, members in original.unit_quaternions:
        if not all(n in position for n in members):
            # a user's constraints on the orientation (a body guided about a line) solve part of it:
            # R uses Q/|Q| and those constraints hold R, so they are blind to |Q|, and the quaternion
            # kinematics' pull keeps |Q| near 1; scaling only the states at a restart would leave the
            # solved part behind, so it is not renormalised and |Q| − 1 is not an invariant
            continue
        index = tuple(position[n] for n in members)
        groups.append(index)
        norms.append(ca.sqrt(ca.sumsqr(ca.vertcat(*[x[k] for k in index]))) - 1)
        names.append(what)
    return tuple(groups), ca.vertcat(*norms) if norms else ca.SX(0, 1), tuple(names)


def _count_observed_only(value, depends, flat, z_index, original) -> int:
    """Variables the integrated equations never need, computed only when observed (pruned).

    Solved variables outside the dependency cone of ode/alg, plus sensor outputs
    that simplify already reduced to an alias or a constant.
    """
    stack = [j for j, _ in flat.der_of.values() if j is not None] + list(z_index)
    needed = set()
    while stack:
        i = stack.pop()
        if i in needed:
            continue
        needed.add(i)
        stack.extend(depends.get(i, ()))
    survivors = {v.name for v in flat.variables}
    eliminated_outputs = sum(1 for v in original.variables if v.kind == "output" and v.name not in survivors)
    return sum(1 for i in value if i not in needed) + eliminated_outputs


def _without_aliases(original, survivor, aliases):
    """expr -> expr with the variables simplification eliminated replaced by what they equal (a mode's
    new value: simplify maps only the conditions and state resets)."""
    gone = [v for v in original.variables if v.name not in survivor]
    if not gone:
        return lambda expr: expr
    olds = ca.vertcat(*[v.symbol for v in gone])
    news = ca.vertcat(*[aliases.expressions[v.name] for v in gone])
    return lambda expr: ca.substitute(expr, olds, news)


def _jump(ode, alg, args, velocities, impulses):
    """The impulse–momentum equations of the whole scene along `impulses` (Impulse modes, each added to
    a force): an impulse P changes the states by Δx = B·P and the velocities by W·P.

    B = ∂ẋ/∂λ: the accelerations' response to a force λ is the velocity jump's response to an impulse,
    because both solve the same equations of motion with the same (constrained) mass matrix; through a
    loop the algebraic unknowns follow by the implicit function theorem (ż = −alg_z⁻¹·alg_λ), so
    the loop's velocity constraints still hold after the jump. Only velocity states move: nothing else
    has a derivative that a force reaches."""
    _, x, z = args[:3]
    lam = ca.vertcat(*impulses)
    B = ca.jacobian(ode, lam)
    V = ca.jacobian(velocities, x)
    if z.numel():
        alg_z = ca.jacobian(alg, z)
        B = B + ca.jacobian(ode, z) @ (-ca.solve(alg_z, ca.jacobian(alg, lam)))
        V = V + ca.jacobian(velocities, z) @ (-ca.solve(alg_z, ca.jacobian(alg, x)))
    return B, V @ B


def _events(flat, x_index, symbols, current, args, x, resolve, ode=None, alg=None, releases=()):
    """zero(t,x,z,u,p,d) stacks the conditions; transition[i] maps the state and the modes to their values
    after event i (new values computed from those before it), through the scene's impulse–momentum
    equations where the event makes a jump; rest[i] (or None) is the plastic jump and the mode
    values that end an accumulation of event i's firings (a ball coming to rest)."""
    if not flat.zero_crossings:
        return _fn("zero", args, ca.SX(0, 1), "g"), (), ()
    position = {s.element_hash(): i for i, s in enumerate(symbols)}

    def in_base(expr):
        used = [position[s.element_hash()] for s in ca.symvar(expr) if s.element_hash() in position]
        subs = [(symbols[i], current(i)) for i in used if current(i) is not symbols[i]]
        if subs:
            expr = ca.substitute(expr, ca.vertcat(*[a for a, _ in subs]), ca.vertcat(*[b for _, b in subs]))
        return expr

    g = flat.expand([ca.vertcat(*[in_base(zc.g) for zc in flat.zero_crossings])])[0]
    state_pos = {i: k for k, i in enumerate(x_index)}
    d = args[5]

    released = [(k, during, flat.expand([in_base(resolve(stays))])[0], flat.expand([in_base(resolve(after))])[0])
                for k, during, stays, after in releases]
    held = ca.vertcat(*[d[k] for k, _, _, _ in released]) if released else None

    def with_modes(values):
        """ode and alg with the released elements' modes replaced by `values`."""
        return ca.substitute(ode, held, values), ca.substitute(alg, held, values)

    def solve_jump(zc, goal, vel, modes):
        o, a = with_modes(modes) if modes is not None else (ode, alg)
        B, W = _jump(o, a, args, vel, [d[k] for k, _, _ in zc.jumps])
        return x + B @ ca.solve(W, goal - vel)

    def jumped(zc, plastic):
        """(x after the jump of zc, the released elements' modes after it): x itself and no modes without a
        jump. An impact is solved with every held element released; those its state says stay held are held
        rigidly in a second solve from the same start (their speed stays exactly 0), the others keep the
        first solve's freedom and get their mode from the final state."""
        if not zc.jumps:
            return x, []
        vel = flat.expand([ca.vertcat(*[in_base(resolve(v)) for _, v, _ in zc.jumps])])[0]
        goal = ca.DM.zeros(len(zc.jumps)) if plastic else \
            flat.expand([ca.vertcat(*[in_base(resolve(g)) for _, _, g in zc.jumps])])[0]
        if not released or not zc.release:
            return solve_jump(zc, goal, vel, None), []
        free = ca.vertcat(*[ca.SX(during) for _, during, _, _ in released])
        x_free = solve_jump(zc, goal, vel, free)
        stays = ca.substitute(ca.vertcat(*[s for _, _, s, _ in released]), x, x_free)
        modes = ca.vertcat(*[ca.if_else(stays[j], held[j], free[j]) for j in range(stays.numel())])
        x_new = solve_jump(zc, goal, vel, modes)
        after = ca.substitute(ca.vertcat(*[a for _, _, _, a in released]), x, x_new)
        return x_new, [(k, ca.if_else(stays[j], held[j], after[j])) for j, (k, _, _, _) in enumerate(released)]

    transitions, rests = [], []
    for n, zc in enumerate(flat.zero_crossings):
        x_jumped, released_modes = jumped(zc, False)
        x_plus = [x_jumped[k] for k in range(x.numel())]
        for i, value in zc.resets:
            if i not in state_pos:
                raise StructureError(f"{zc.label}: resets {flat.variables[i].name}, which is not a state of the "
                                     f"compiled model (it is computed from other variables); reset a state "
                                     f"({', '.join(flat.variables[j].name for j in x_index)})")
            x_plus[state_pos[i]] = in_base(value)
        transitions.append(_transition(f"transition_{n}", flat, args, x_plus, zc.mode_resets, in_base, resolve,
                                       released_modes))
        if zc.rest is None:
            rests.append(None)
        else:
            x_rest, rest_modes = jumped(zc, True)
            rests.append(_transition(f"rest_{n}", flat, args, [x_rest[k] for k in range(x.numel())], zc.rest,
                                     in_base, resolve, rest_modes))
    return _fn("zero", args, g, "g"), tuple(transitions), tuple(rests)


def _transition(name, flat, args, x_plus, mode_resets, in_base, resolve, released=()):
    d = args[5]
    d_plus = [d[k] for k in range(d.numel())]
    for k, value in released:                     # already in base symbols
        d_plus[k] = value
    for k, value in mode_resets:
        d_plus[k] = in_base(resolve(value))
    out = ca.vertcat(*x_plus) if x_plus else ca.SX(0, 1)
    out = flat.expand([out])[0]
    d_out = flat.expand([ca.vertcat(*d_plus)])[0] if (mode_resets or released) else d
    return ca.Function(name, list(args), [out, d_out], list(ARGS), ["x_plus", "d_plus"])
