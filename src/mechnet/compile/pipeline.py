"""`compile()`: a thin façade over the stages, keeping every artifact.

Each stage reads only its own options object; nothing is relayed as **kwargs.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field, replace

from .alias import SimplifyOptions, simplify
from .casadi_dae import EmitOptions, emit
from .flatten import FlattenOptions, flatten
from .index_reduction import IndexReductionOptions, reduce_index
from .structure import StructureOptions, analyze_structure


@dataclass(frozen=True)
class CompileOptions:
    flatten: FlattenOptions = field(default_factory=FlattenOptions)
    simplify: SimplifyOptions = field(default_factory=SimplifyOptions)
    reduce: IndexReductionOptions = field(default_factory=IndexReductionOptions)
    structure: StructureOptions = field(default_factory=StructureOptions)
    emit: EmitOptions = field(default_factory=EmitOptions)


def expand_unless_states(flat):
    """The tree's intermediates stand for expressions of the joint coordinates and speeds, which the
    structural stages may treat as known only while they are states. When index reduction made one of
    them a dummy (a joint driven by a prescribed motion or geared to another state), the equations get
    the expressions themselves: correct, at the price of larger residuals."""
    syms, _ = flat.intermediates
    if not syms or flat.multibody is None:
        return flat
    states = {flat.variables[i].symbol.element_hash() for i in flat.der_of}
    needed = [s for _, q, qd in flat.multibody.coordinates for s in (q, qd)]
    if all(s.element_hash() in states for s in needed):
        return flat
    touched = [k for k, eq in enumerate(flat.equations) if flat.uses_intermediates(eq.residual)]
    expanded = flat.expand([flat.equations[k].residual for k in touched])
    equations = list(flat.equations)
    for k, r in zip(touched, expanded):
        equations[k] = replace(equations[k], residual=r)
    return replace(flat, equations=tuple(equations), intermediates=((), ()))


def compile_model(model, options: CompileOptions | None = None):
    from .compiled import CompiledModel

    options = options or CompileOptions()
    timings = {}
    t0 = _time.perf_counter()
    flat = flatten(model, options.flatten)
    timings["flatten"] = _time.perf_counter() - t0
    t0 = _time.perf_counter()
    simplified, aliases = simplify(flat, options.simplify)
    timings["simplify"] = _time.perf_counter() - t0
    t0 = _time.perf_counter()
    if options.reduce.method == "baumgarte":      # CasADi's Pantelides + Baumgarte, for comparison studies
        from .baumgarte import reduce_baumgarte
        reduced, index, structure, dae = reduce_baumgarte(flat, simplified, aliases, options.reduce)
        timings["reduce"] = _time.perf_counter() - t0
    else:
        reduced, index = reduce_index(simplified, options.reduce)
        reduced = expand_unless_states(reduced)
        timings["reduce"] = _time.perf_counter() - t0
        t0 = _time.perf_counter()
        structure = analyze_structure(reduced, options.structure)
        timings["analyze"] = _time.perf_counter() - t0
        t0 = _time.perf_counter()
        dae = emit(flat, reduced, aliases, structure, options.emit)
        timings["emit"] = _time.perf_counter() - t0
    model.freeze()
    stages = {"flat": flat, "simplified": simplified, "aliases": aliases, "reduced": reduced, "index": index,
              "structure": structure, "dae": dae}
    return CompiledModel(model.name, stages, timings, options)
