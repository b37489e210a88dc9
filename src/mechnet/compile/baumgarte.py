"""Reduce + emit with CasADi's own index reduction and Baumgarte stabilisation (for comparison studies).

`IndexReductionOptions(method="baumgarte", baumgarte_pole=-10.0)` replaces
mechnet's reduce / analyze / emit stages by CasADi's building blocks:

1. the simplified `FlatSystem` is written as CasADi's fully implicit DAE
   (`implicit_form`): `x_impl` = the states, `dx_impl` = one symbol per
   state for its derivative, `z` = the other unknowns, `alg` = the flat
   residuals followed by one *state relation* `der(x) - v = 0` per state
   whose derivative is not a plain unknown of its own (CasADi's form is first
   order: `dx_impl` symbols cannot also be states). Inputs and tunable
   parameters are passed as CasADi's `p`;
2. `casadi.dae_reduce_index(dae, {"baumgarte_pole": pole})` runs Pantelides,
   differentiates, and replaces each equation differentiated n times by
   `e⁽ⁿ⁾ + Σ_k c_k e⁽ᵏ⁾` with the coefficients of `(s - pole)ⁿ` — ONE pole,
   repeated for every order (Ascher, Chin & Reich 1994, eq. 1.5 with
   γ = −pole). The differentiated constraints are dropped from the system
   (kept as CasADi's invariants `I`), so all coordinates stay states and the
   constraints drift, damped at the rate |pole|;
3. `casadi.dae_map_semi_expl` gives the semi-explicit index-1 DAE, and this
   module builds the `SemiExplicitDAE` from it directly (every dotted name of
   the scene observed, like `casadi_dae.emit`).

There is no dummy-derivative state selection here (`dummies=()`, no
re-pivoting): every coordinate stays a state, so the start point must satisfy
the invariants. They are observed as "invariant[k]" (descriptions in
`dae.invariant_names`) and fixed to 0 as start values: the simulator's own
initialisation then starts on the constraint manifold, whatever the other
start values and parameters are.

CasADi's stats dict has a single key, "index" (max differentiation count + 1);
the per-equation counts are read off the reduced system (`casadi_reduction`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca

from ..core.errors import StructureError
from .artifacts import AliasMap, FlatSystem, Selection, SemiExplicitDAE, StructureReport
from .structure import analyze_structure, maximum_matching

ARGS = ("t", "x", "z", "u", "p", "d")
_COUNT_POLE = -2.0          # decoding pole: an equation differentiated n times carries (−pole)ⁿ = 2ⁿ


@dataclass(frozen=True)
class ImplicitForm:
    """A FlatSystem as CasADi's fully implicit DAE, with the names and labels to map it back."""

    dae: dict                 # x_impl, dx_impl, z, alg, t, p (CasADi's keys)
    labels: tuple             # one per alg row: the flat equation, then the state relations
    n_flat: int               # the first n_flat rows are the flat equations, in order
    names: dict               # symbol element hash -> dotted name (every x_impl, dx_impl, z symbol)
    nominal: dict             # symbol element hash -> nominal value
    units: dict               # symbol element hash -> unit
    u: tuple                  # input symbols (the tail of dae["p"])
    params: tuple             # tunable parameter symbols (the head of dae["p"])


def implicit_form(flat: FlatSystem) -> ImplicitForm:
    """Write `flat` as CasADi's implicit DAE: 0 = alg(x_impl, dx_impl, z, p, t)."""
    variables = flat.variables
    syms = [v.symbol for v in variables]
    states = sorted(flat.der_of)
    inputs = [i for i, v in enumerate(variables) if v.kind == "input"]
    in_equations = set()
    for eq in flat.equations:
        in_equations.update(s.element_hash() for s in ca.symvar(eq.residual))
    names = {s.element_hash(): v.name for s, v in zip(syms, variables)}
    nominal = {s.element_hash(): v.nominal for s, v in zip(syms, variables)}
    units = {s.element_hash(): v.unit for s, v in zip(syms, variables)}
    taken = {v.name for v in variables}

    dx_impl, relations, labels_rel, direct = [], [], [], set()
    for i in states:
        j, sign = flat.der_of[i]
        if (j is not None and sign == 1.0 and j not in flat.der_of and variables[j].kind != "input"
                and j not in direct and syms[j].element_hash() in in_equations):
            direct.add(j)                     # der(x_i) is an unknown of its own: use it as dx_impl
            dx_impl.append(syms[j])
            continue
        name = f"der({variables[i].name})"
        while name in taken:
            name += "'"
        taken.add(name)
        d = ca.SX.sym(name)
        names[d.element_hash()] = name
        nominal[d.element_hash()] = variables[i].nominal
        units[d.element_hash()] = f"({variables[i].unit})/s"
        dx_impl.append(d)
        if j is None:
            relations.append(d - sign)
            labels_rel.append(f"{name} = {sign:g}")
        else:
            relations.append(d - sign * syms[j])
            labels_rel.append(f"{name} = {'' if sign == 1.0 else f'{sign:g}·'}{variables[j].name}")
    z = [syms[i] for i in flat.unknowns() if i not in direct]
    params = tuple(q.symbol for q in flat.parameters)
    u = tuple(syms[i] for i in inputs)
    alg = [eq.residual for eq in flat.equations] + relations

    def col(items):
        return ca.vertcat(*items) if items else ca.SX(0, 1)

    dae = {"x_impl": col([syms[i] for i in states]), "dx_impl": col(dx_impl), "z": col(z), "alg": col(alg),
           "t": flat.time, "p": col(list(params) + list(u))}
    return ImplicitForm(dae, tuple(eq.describe() for eq in flat.equations) + tuple(labels_rel),
                        len(flat.equations), names, nominal, units, u, params)


@dataclass(frozen=True)
class CasadiReduction:
    """What `casadi.dae_reduce_index` did to an implicit form."""

    counts: tuple             # times each alg row of the implicit form was differentiated
    index: int                # CasADi's stats["index"]
    stats: dict               # CasADi's stats dict as returned
    row_source: tuple         # per row of the reduced alg: the implicit-form row it descends from


def casadi_reduction(form: ImplicitForm, max_iter: int = 500) -> CasadiReduction:
    """Run CasADi's Pantelides and read how often each equation was differentiated.

    CasADi reports only the index. Each equation gets a marker parameter
    q_k added to its residual; with the Baumgarte pole −2 the reduced
    equation that descends from equation k after n differentiations contains
    q_k with coefficient (−pole)ⁿ = 2ⁿ (the derivatives of q_k vanish).
    """
    n = form.dae["alg"].numel()
    q = ca.SX.sym("marker", n)
    dae = dict(form.dae, alg=form.dae["alg"] + q, p=ca.vertcat(form.dae["p"], q))
    try:
        reduced, stats = ca.dae_reduce_index(dae, {"baumgarte_pole": _COUNT_POLE, "max_iter": max_iter})
    except RuntimeError as exc:
        raise StructureError(f"CasADi's index reduction (dae_reduce_index) failed: "
                             f"{str(exc).strip().splitlines()[-1]}") from None
    J = ca.evalf(ca.jacobian(reduced["alg"], q)) if n else ca.DM(0, 0)
    counts = [0] * n
    row_source = []
    for r in range(J.shape[0]):
        nz = [(k, float(J[r, k])) for k in range(n) if float(J[r, k]) != 0.0]
        if len(nz) != 1:
            raise StructureError("could not map CasADi's reduced equations back to the model's equations")
        k, c = nz[0]
        counts[k] = int(round(math.log(c, -_COUNT_POLE)))
        row_source.append(k)
    return CasadiReduction(tuple(counts), int(stats["index"]), dict(stats), tuple(row_source))


@dataclass(frozen=True)
class BaumgarteReport:
    """The `stages["index"]` object of the Baumgarte route (same reading interface as IndexReport)."""

    differentiated: tuple     # (flat equation label, times differentiated), like IndexReport
    index: int                # CasADi's structural index
    state_relations: tuple    # (label "der(x) = v", times differentiated): the first-order relations CasADi added
    baumgarte_pole: float
    invariants: tuple         # labels of what CasADi dropped: each differentiated constraint and its
                              # derivatives below the order kept (dae.invariants, observed "invariant[k]")
    stats: dict = field(default_factory=dict)   # CasADi's stats dict
    states: tuple = ()
    dummies: tuple = ()
    levels: tuple = ()
    factory: object = None

    def summary(self) -> str:
        if not self.differentiated:
            return (f"reduce (CasADi, Baumgarte pole {self.baumgarte_pole:g}): no constraint among states, "
                    f"nothing differentiated")
        diffs = ", ".join(f"{label} ×{n}" for label, n in self.differentiated)
        rel = ", ".join(f"{label} ×{n}" for label, n in self.state_relations)
        return (f"reduce (CasADi dae_reduce_index, Baumgarte pole {self.baumgarte_pole:g}): structural index "
                f"{self.index}; differentiated {diffs}" + (f"; state relations {rel}" if rel else "")
                + f"; {len(self.states)} states, constraints kept as invariants (they drift, damped)")


def _fn(name, args, out, out_name):
    return ca.Function(name, list(args), [out], list(ARGS), [out_name], {"cse": True})


def reduce_baumgarte(original: FlatSystem, flat: FlatSystem, aliases: AliasMap, options):
    """The Baumgarte route: (reduced FlatSystem, BaumgarteReport, StructureReport, SemiExplicitDAE)."""
    if original.modes:
        raise StructureError(f"model {original.name!r} has modes ({', '.join(m.name for m in original.modes)}); "
                             f"the Baumgarte route does not carry them: compile with the default method")
    pole = float(options.baumgarte_pole)
    if not pole <= 0.0:
        raise StructureError(f"baumgarte_pole = {pole:g} must be negative (0 switches the correction off); "
                             f"a positive pole makes constraint drift grow")
    if len(flat.unknowns()) != len(flat.equations):
        analyze_structure(flat)           # names the over- and under-determined parts
    form = implicit_form(flat)
    try:
        counted = casadi_reduction(form)
    except StructureError:
        analyze_structure(flat)           # structurally singular: named like the default route names it
        raise
    _check_differentiable(flat, form, counted)
    try:
        reduced, stats = ca.dae_reduce_index(form.dae, {"baumgarte_pole": pole})
    except RuntimeError as exc:
        raise StructureError(f"CasADi's index reduction failed: {str(exc).strip().splitlines()[-1]}") from None
    se, _state_to_orig, _phi = ca.dae_map_semi_expl(form.dae, reduced)

    x, z = se["x"], se["z"]
    names, nominal, units = _name_symbols(form, x, z, se["ode"])
    t = flat.time
    u = ca.vertcat(*form.u) if form.u else ca.SX(0, 1)
    p = ca.vertcat(*form.params) if form.params else ca.SX(0, 1)
    d = ca.SX(0, 1)
    args = (t, x, z, u, p, d)
    x_names = tuple(names[s.element_hash()] for s in ca.vertsplit(x))
    z_names = tuple(names[s.element_hash()] for s in ca.vertsplit(z))

    # observed: every name of the scene, then the new derivative symbols, then the parameters
    survivor = {v.name: v.symbol for v in flat.variables}
    obs_names, obs = [], []
    own = dict(zip(x_names + z_names, ca.vertsplit(ca.vertcat(x, z))))
    for v in original.variables:
        obs_names.append(v.name)
        if v.name in survivor:
            obs.append(survivor[v.name])
        elif v.name in own:           # der(p.x): an alias of p.vx before, a state of its own here
            obs.append(own[v.name])
        else:
            obs.append(aliases.expressions[v.name])
    known = set(obs_names)
    for s, name in zip(ca.vertsplit(ca.vertcat(x, z)), x_names + z_names):
        if name not in known:
            obs_names.append(name)
            obs.append(s)
            known.add(name)

    # invariants: each differentiated constraint and its derivatives below the order CasADi used, i.e.
    # what CasADi dropped (its "I"), with labels. Observed as "invariant[k]" and fixed to 0 as start
    # values, so the simulator's initialisation starts on the constraint manifold whatever the other
    # start values and parameters are.
    inv_expr, inv_labels = _invariants(form, counted, x, se["ode"], t)
    if inv_expr.numel() != reduced["I"].numel():
        raise StructureError(f"internal: {inv_expr.numel()} invariants against CasADi's {reduced['I'].numel()}")
    inv_names = tuple(f"invariant[{k}]" for k in range(inv_expr.numel()))
    invariants = _fn("invariants", args, inv_expr, "c")
    obs_names.extend(inv_names)
    obs.extend(ca.vertsplit(inv_expr))
    obs_names.extend(q.name for q in flat.parameters)
    obs.append(p)
    observed = _fn("observed", args, ca.vertcat(*obs) if obs else ca.SX(0, 1), "y")
    if reduced["alg"].numel() != len(counted.row_source):
        raise StructureError("internal: CasADi's reductions with and without markers differ")
    alg_labels = []
    for k in counted.row_source:
        n = counted.counts[k]
        alg_labels.append(form.labels[k] if n == 0 else
                          f"d{'' if n == 1 else n}/dt{'' if n == 1 else n} {form.labels[k]} "
                          f"+ Baumgarte terms (pole {pole:g})")

    ode = _fn("ode", args, se["ode"], "xdot")
    algf = _fn("alg", args, se["alg"], "res")
    zero, transitions, zero_labels, zero_dirs = _events(flat, x, args)

    units_out = {v.name: v.unit for v in original.variables}
    units_out.update({q.name: q.unit for q in flat.parameters})
    for s, name in zip(ca.vertsplit(ca.vertcat(x, z)), x_names + z_names):
        units_out.setdefault(name, units[s.element_hash()])
    starts = {v.name: v.start for v in original.variables if v.start is not None}
    guesses = {v.name: (v.guess if v.guess is not None else v.default_start) for v in original.variables}
    u_default = tuple(v.input_default for v in flat.variables if v.kind == "input")
    p_value = tuple(q.value for q in flat.parameters)
    units_out.update({n: "1" for n in inv_names})
    starts.update({n: 0.0 for n in inv_names})
    report = BaumgarteReport(
        differentiated=tuple((form.labels[k], n) for k, n in enumerate(counted.counts[:form.n_flat]) if n > 0),
        index=int(stats["index"]),
        state_relations=tuple((form.labels[k], n) for k, n in enumerate(counted.counts)
                              if k >= form.n_flat and n > 0),
        baumgarte_pole=pole, invariants=inv_labels, stats=dict(stats),
        states=x_names)
    structure = _structure(se["alg"], z)
    info = {"alg_labels": tuple(alg_labels), "solved": 0, "torn": z.numel(), "observed_only": 0,
            "folded_parameters": flat.folded_parameters,
            "parameter_checks": {q.name: (q.declaration, q.owner) for q in flat.parameters},
            "parameter_requirements": original.parameter_requirements,
            "nominal": {v.name: v.nominal for v in original.variables},
            "index_reduction": "casadi-baumgarte", "baumgarte_pole": pole,
            "casadi_invariants": _fn("casadi_invariants", args, reduced["I"], "I")}
    dae = SemiExplicitDAE(
        name=flat.name, t=t, x=x, z=z, u=u, p=p, d=d,
        x_names=x_names, z_names=z_names, u_names=tuple(v.name for v in flat.variables if v.kind == "input"),
        p_names=tuple(q.name for q in flat.parameters), d_names=(),
        ode=ode, alg=algf, observed=observed, observed_names=tuple(obs_names),
        zero=zero, transition=transitions, invariants=invariants, invariant_names=inv_labels,
        selections=(Selection(x_names, z_names, ode, algf, observed),),
        x_nominal=tuple(nominal[s.element_hash()] for s in ca.vertsplit(x)),
        z_nominal=tuple(nominal[s.element_hash()] for s in ca.vertsplit(z)),
        units=units_out, starts=starts, guesses=guesses, u_default=u_default, p_value=p_value, d_value=(),
        time_events=flat.time_events, zero_labels=zero_labels, zero_directions=zero_dirs, info=info)
    return flat, report, structure, dae


def _check_differentiable(flat, form, counted):
    """What mechnet's own reduction refuses, refused here too (CasADi would silently take du/dt = 0)."""
    u_hashes = {s.element_hash() for s in form.u}
    for k, n in enumerate(counted.counts):
        if n == 0:
            continue
        residual = form.dae["alg"][k]
        inputs = [s.name() for s in ca.symvar(residual) if s.element_hash() in u_hashes]
        if inputs:
            raise StructureError(
                f"{form.labels[k]} would have to be differentiated for index reduction, but it contains the "
                f"external input {', '.join(inputs)}, whose derivative is unknown; drive it with a smooth "
                f"signal (mechnet.components.signals) instead")
        if k < form.n_flat and n > flat.equations[k].smoothness:
            eq = flat.equations[k]
            raise StructureError(
                f"{eq.describe()} would have to be differentiated {n} time(s) for index reduction, but its "
                f"signal is smooth only to order {eq.smoothness:g}: a prescribed motion needs a signal with "
                f"continuous derivatives (e.g. Sine, or a smoother profile) when it drives an element rigidly")


def _name_symbols(form, x, z, ode):
    """Dotted names for the semi-explicit states and algebraics; CasADi's new symbols become der(...)."""
    names, nominal, units = dict(form.names), dict(form.nominal), dict(form.units)
    pairs = [(a, b) for a, b in zip(ca.vertsplit(x), ca.vertsplit(ode)) if b.is_symbolic()]
    progress = True
    while progress:
        progress = False
        for a, b in pairs:
            ha, hb = a.element_hash(), b.element_hash()
            if ha in names and hb not in names:
                names[hb] = f"der({names[ha]})"
                nominal[hb] = nominal.get(ha, 1.0)
                units[hb] = f"({units.get(ha, '1')})/s"
                progress = True
    for s in ca.vertsplit(ca.vertcat(x, z)):
        h = s.element_hash()
        if h not in names:
            names[h], nominal[h], units[h] = s.name(), 1.0, "1"
    return names, nominal, units


def _events(flat, x, args):
    crossings = getattr(flat, "zero_crossings", ())
    if not crossings:
        return _fn("zero", args, ca.SX(0, 1), "g"), (), (), ()
    position = {s.element_hash(): k for k, s in enumerate(ca.vertsplit(x))}
    transitions = []
    for n, zc in enumerate(crossings):
        x_plus = ca.vertsplit(x)
        for i, value in zc.resets:
            k = position.get(flat.variables[i].symbol.element_hash())
            if k is None:
                raise StructureError(f"{zc.label}: resets {flat.variables[i].name}, which is not a state of the "
                                     f"Baumgarte-reduced model")
            x_plus[k] = value
        transitions.append(ca.Function(f"transition_{n}", list(args), [ca.vertcat(*x_plus), args[5]],
                                       list(ARGS), ["x_plus", "d_plus"]))
    g = ca.vertcat(*[zc.g for zc in crossings])
    return (_fn("zero", args, g, "g"), tuple(transitions), tuple(zc.label for zc in crossings),
            tuple(zc.direction for zc in crossings))


def _structure(alg, z) -> StructureReport:
    """One implicit block (what IDAS solves): incidence and matching of alg against z."""
    n = z.numel()
    sp = ca.jacobian(alg, z).sparsity() if n else None
    incidence = [sorted(k for k in range(n) if sp.has_nz(r, k)) for r in range(alg.numel())] if n else []
    matching = maximum_matching(incidence, n) if n else {}
    return StructureReport(tuple(range(n)), tuple(tuple(r) for r in incidence),
                           tuple(matching.get(e, -1) for e in range(len(incidence))),
                           (tuple(range(alg.numel())),) if alg.numel() else (), alg.numel())


def _invariants(form, counted, x, ode, t):
    """e, de/dt, …, up to the order below the one CasADi kept, for every differentiated equation e."""
    deriv = {a.element_hash(): b for a, b in zip(ca.vertsplit(x), ca.vertsplit(ode))}
    constant = {s.element_hash() for s in ca.vertsplit(form.dae["p"])} | {t.element_hash()}
    rows, labels = [], []
    for k, n in enumerate(counted.counts):
        e = form.dae["alg"][k]
        for m in range(n):
            rows.append(e)
            labels.append(form.labels[k] if m == 0 else f"d{'' if m == 1 else m}/dt{'' if m == 1 else m} "
                                                          f"{form.labels[k]}")
            if m + 1 < n:
                vs = [s for s in ca.symvar(e) if s.element_hash() in deriv]
                if any(s.element_hash() not in deriv and s.element_hash() not in constant for s in ca.symvar(e)):
                    raise StructureError(f"internal: no derivative for a variable of {form.labels[k]}")
                e = ca.jtimes(e, ca.vertcat(t, *vs), ca.vertcat(1.0, *[deriv[s.element_hash()] for s in vs]))
    return (ca.vertcat(*rows) if rows else ca.SX(0, 1)), tuple(labels)
