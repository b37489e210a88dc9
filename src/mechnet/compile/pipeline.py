"""`compile()`: a thin façade over the stages, keeping every artifact.

Each stage reads only its own options object; nothing is relayed as **kwargs.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

from ..caches import builds_symbols
from ..core.errors import MechnetError
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


@builds_symbols
def compile_model(model, options: CompileOptions | None = None):
    """Under the build lock (`caches.py`): a compile in one thread and a run's first build in another
    would otherwise create expressions at once."""
    from .compiled import CompiledModel

    options = options or CompileOptions()
    if not isinstance(options, CompileOptions):
        raise MechnetError(f"compile(options=...) takes a mechnet.compile.CompileOptions, got "
                           f"{type(options).__name__} {options!r:.40}")
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
    cm = CompiledModel(model.name, stages, timings, options)
    cm._source = model                 # to compile again in another form (the OCP's smooth friction)
    return cm
