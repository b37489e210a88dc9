"""CompiledModel: the user's handle on the pipeline's artifacts and the simulator."""
from __future__ import annotations

import difflib
import inspect
import pickle

import casadi as ca

from ..caches import BUILD_LOCK, PerThread, built
from ..core.errors import MechnetError
from .artifacts import SemiExplicitDAE
from .index_reduction import grouped_differentiations

INTEGRATORS_PER_THREAD = 32     # output patterns and table shapes each thread keeps integrators for


class CompiledModel:
    """What `Model.compile()` returns: the artifacts of every stage and the simulation entry point."""

    def __init__(self, name: str, stages: dict, timings: dict, options):
        self.name = name
        self.stages = stages
        self.timings = timings
        self.options = options
        self._integrators = PerThread(INTEGRATORS_PER_THREAD)
        self._selections: dict = {}

    def integrators(self):
        """This thread's integrators (`caches.py`: one integrator cannot serve two threads at once)."""
        return self._integrators.cache()

    def __getstate__(self):
        """A compiled model crosses a process boundary (multiprocessing, dask) as CasADi's serialisation
        of its expressions: plain pickle refuses SX ("Cannot pickle SX objects without a casadi
        context"), and one context for the whole model keeps the expressions' shared nodes shared.
        Integrators and other selections are rebuilt on demand in the receiving process."""
        state = {k: v for k, v in self.__dict__.items() if k not in ("_integrators", "_selections", "_source")}
        with BUILD_LOCK, ca.global_pickle_context():
            return {"casadi": pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL),
                    "integrators_per_thread": self._integrators.size}

    def __setstate__(self, packed):
        with BUILD_LOCK, ca.global_unpickle_context():
            self.__dict__.update(pickle.loads(packed["casadi"]))
        self._integrators = PerThread(packed["integrators_per_thread"])
        self._selections = {}

    def smoothed(self):
        """(compiled model, names): this model with every switched friction element in its smooth form
        (compiled again; what an optimiser needs), or (self, ()) when there is none. A model that crossed
        a process boundary has no source to compile again: (self, ())."""
        source = getattr(self, "_source", None)
        names = tuple(path for path, _, form in self.stages["flat"].switched if form == "switched"
                      and hasattr(_component(source, path), "form")) if source is not None else ()
        if not names:
            return self, ()
        from ..components.switched import smooth_friction
        from .pipeline import compile_model
        with smooth_friction():
            return compile_model(source, self.options), names

    @property
    def dae(self) -> SemiExplicitDAE:
        return self.stages["dae"]

    @property
    def selection_factory(self):
        """Re-chooses states at another point (None when index reduction chose none)."""
        index = self.stages.get("index")
        return getattr(index, "factory", None) if index is not None else None

    def selection(self, dummies: frozenset) -> SemiExplicitDAE:
        """The compiled model for another choice of dummy derivatives (cached)."""
        from .casadi_dae import emit
        from .structure import analyze_structure

        def build():
            flat = self.selection_factory.build(dummies)
            structure = analyze_structure(flat, self.options.structure)
            return emit(self.stages["flat"], flat, self.stages["aliases"], structure, self.options.emit)
        return built(self._selections, dummies, build)

    @property
    def n_states(self) -> int:
        return self.dae.x.numel()

    @property
    def state_names(self) -> tuple:
        return self.dae.x_names

    @property
    def algebraic_names(self) -> tuple:
        return self.dae.z_names

    @property
    def parameter_names(self) -> tuple:
        return self.dae.p_names

    @property
    def input_names(self) -> tuple:
        return self.dae.u_names

    @property
    def names(self) -> tuple:
        return self.dae.observed_names

    def functions(self) -> dict:
        """The documented contract every export is built from (`mechnet.export.contract`): ode, alg,
        observed, invariants, zero, transition, init, solve_alg, Jacobians, forward, metadata."""
        from ..export import functions
        return _Functions(functions(self))

    def export(self, path, kind: str = "casadi", *, fmi: int = 2, overwrite: bool = False):
        """Write the model as CasADi files, generated C or an FMU (`mechnet.export.export`)."""
        from ..export import export
        return export(self, path, kind, fmi=fmi, overwrite=overwrite)

    def simulate(self, t_end: float, *positional, **kwargs):
        """Integrate from t = 0 (or `t_start`) to `t_end` (s) and return a `Result`.

        Keyword settings (all optional; `mechnet.simulate.integrator.simulate` does the work):

        t_start : s, default None (0)
            start time; with `continue_from`, only its final time is allowed.
        rtol : 1, default 1e-6
            relative error each step may make, in [1e-14, 1).
        atol : a variable's unit per unit of its nominal, default 1e-8
            absolute error each step may make (what holds near zero); must be > 0.
        method : default "auto"
            "auto", "idas", "cvodes-bdf" or "cvodes-adams". "auto": CVODES Adams for an explicit ODE,
            BDF from the first sign of stiffness on; IDAS for a DAE (`res.stats["method"]`).
        n_out : output points, default None (501)
            evenly spaced output times from t_start to t_end (at least 2); events add their times.
        t_out : s, default None
            the output times instead of n_out: increasing, ending at t_end.
        params : {name: value}, default None
            tunable parameter values for this run (in the parameter's unit).
        inputs : {name: value}, default None
            input values: a number, a callable f(t) (sampled: jumps are smeared), (times, values) pairs or
            an N×2 array (a time given twice is a jump), or a `Table`/`Signal` (exact, its knots time events).
        start : {name: value}, default None
            fixed start values (any dotted name, in its unit).
        guess : {name: value}, default None
            start guesses: they only seed the Newton iteration, they fix nothing.
        max_steps : steps, default 20000
            the integrator's steps per call before it gives up.
        progress : default None
            True/False shows/hides a progress bar; None shows one when a long grid (>= 1000 points) takes
            more than a second.
        steady_state : default False
            start from der(x) = 0 (every state; fixed start values then over-specify).
        continue_from : Result, default None
            go on from that result's final time and states (its other final values are guesses).

        A solver failure returns the partial result with `result.failure` set (and a warning); it does
        not raise.
        """
        from ..simulate.integrator import simulate
        _only_t_end(positional, "simulate")
        _known_settings(simulate, kwargs, "simulate")
        return simulate(self, t_end, **kwargs)

    def prepare(self, t_end: float, *positional, **settings):
        """`simulate(t_end, **settings)` as a function of `params`, `start` and `guess`, for many calls:
        `run = cm.prepare(2.0, n_out=101, rtol=1e-8)`, then `run(params={...})`. After the first call, a
        run that is one integrator call skips simulate's fixed cost; any other runs `simulate` in full
        (`run.plain` says which; `simulate/prepared.py`)."""
        from ..simulate.prepared import PreparedRun
        _only_t_end(positional, "prepare")
        return PreparedRun(self, t_end, settings)

    def summary(self) -> str:
        from ..simulate.solvers import choose_method
        d = self.dae
        flat, simp = self.stages["flat"], self.stages["simplified"]
        al, st = self.stages["aliases"], self.stages["structure"]
        kind = "explicit ODE" if d.is_ode else "index-1 DAE"

        def names(seq, limit=8):
            seq = list(seq)
            more = f", ... (+{len(seq) - limit})" if len(seq) > limit else ""
            return ", ".join(seq[:limit]) + more

        effects = ", ".join(f"{k} ×{n}" for k, n in flat.effects)
        lines = [
            f"model {self.name!r}: {kind}",
            f"  states ({d.x.numel()}): {names(d.x_names)}",
            f"  algebraics ({d.z.numel()}): {names(d.z_names) or '-'}",
            f"  inputs ({d.u.numel()}): {names(d.u_names) or '-'}",
            f"  tunable parameters ({d.p.numel()}): {names(d.p_names) or '-'}",
            f"  equations: flatten {len(flat.equations)} -> simplify {len(simp.equations)} "
            f"-> emit {d.x.numel()} ode + {d.z.numel()} alg",
            f"  variables: flatten {len(flat.variables)} -> simplify {len(simp.variables)} "
            f"({al.n_alias} aliases, {al.n_constant} constants eliminated)",
            f"  structure: {len(st.blocks)} BLT blocks, largest {max((len(b) for b in st.blocks), default=0)}; "
            f"{d.info['solved']} solved symbolically, {d.info['torn']} torn; "
            f"{d.info['observed_only']} only observed (pruned from ode/alg)",
            self._index_line(),
            f"  effects: {effects or '-'}",
            f"  method (auto): {choose_method(d, 'auto').reason}",
        ] + ([f"  {flat.multibody.summary()}; {len(flat.observed_only)} frame quantities observed only"]
             if flat.multibody is not None else []) + [
            f"  {loop.summary()}" for loop in (flat.multibody.loops if flat.multibody is not None else [])] + [
            f"  cost: {d.ode.n_instructions()} instructions in ode, {d.alg.n_instructions()} in alg",
        ] + self._switched_lines() + [
            "  compile time: " + ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in self.timings.items()),
        ]
        return "\n".join(lines)

    def _switched_lines(self) -> list:
        """What each friction element, stop, contact or relay adds: its form, modes, zero-crossing
        functions, and the instructions of its conditions and event transitions."""
        flat, d = self.stages["flat"], self.dae
        if not flat.switched:
            return []
        g = d.zero(*d.zero.sx_in()) if d.zero_labels else None
        lines = [f"  switched elements ({len(flat.switched)}):"]
        for path, ctype, form in flat.switched:
            modes = [n for n in d.d_names if n.startswith(path + ".")]
            rows = [k for k, label in enumerate(d.zero_labels) if label.startswith(f"{path} (")]
            cost = 0
            if rows:
                cost = ca.Function("g", d.zero.sx_in(), [ca.vertcat(*[g[k] for k in rows])], {"cse": True})\
                    .n_instructions() + sum(d.transition[k].n_instructions() for k in rows)
            lines.append(f"    {path} ({ctype}, {form}): {len(modes)} modes, {len(rows)} zero-crossing functions, "
                         f"{cost} instructions in its conditions and transitions")
        return lines

    def _index_line(self) -> str:
        index = self.stages.get("index")
        if index is None or not index.differentiated:
            return f"  index: {0 if self.dae.is_ode else 1} (no index reduction needed)"
        diffs = grouped_differentiations(index.differentiated)
        how = (f"dummy derivatives {', '.join(index.dummies)}" if index.dummies
               else "no dummy derivatives (Baumgarte-stabilised, every coordinate a state)")
        return f"  index: structural index {index.index} reduced; differentiated {diffs}; {how}"

    def __repr__(self):
        return f"<CompiledModel {self.name}: {self.n_states} states, {len(self.algebraic_names)} algebraics>"

    def linearize(self, x_op=None, u_op=None, **kw):
        """Linear model (A, B, C, D) about an operating point; see `mechnet.linear.linearize`."""
        from ..linear import linearize
        _known_settings(linearize, kw, "linearize")
        return linearize(self, x_op, u_op, **kw)

    def trim(self, **kw):
        """Steady state (or the inputs that hold one); see `mechnet.linear.trim`."""
        from ..linear import trim
        _known_settings(trim, kw, "trim")
        return trim(self, **kw)


class _Functions(dict):
    """cm.functions(): a plain dict whose missing key is an UnknownNameError listing the functions there are
    (a bare KeyError('odee') said nothing of them)."""

    def __missing__(self, key):
        from ..core.errors import UnknownNameError
        close = difflib.get_close_matches(str(key), list(self), n=1)
        raise UnknownNameError(f"cm.functions() has no function {key!r}" + (f"; did you mean {close[0]}?" if close
                                                                             else "") + f"; it has {', '.join(self)}")


def _known_settings(function, settings: dict, what: str) -> None:
    """A misspelled setting (`rtoll=`) as a MechnetError naming it and the closest valid one, not Python's
    TypeError from deep inside (fuzz, issue 32)."""
    valid = [p.name for p in inspect.signature(function).parameters.values() if p.kind == p.KEYWORD_ONLY]
    unknown = [k for k in settings if k not in valid]
    if unknown:
        hints = [f"{k} (did you mean {close[0]}?)" if (close := difflib.get_close_matches(k, valid, n=1)) else k
                 for k in unknown]
        raise MechnetError(f"{what}(): unknown setting(s) {', '.join(hints)}; valid settings are {', '.join(valid)}")


def _only_t_end(positional: tuple, what: str) -> None:
    """Settings given by position (`simulate(1.0, 1e-6)`): which setting a number meant cannot be guessed,
    so it is refused naming the call, rather than as Python's TypeError about positional arguments."""
    if positional:
        given = ", ".join(repr(v) for v in positional)
        raise MechnetError(f"{what}() takes t_end as its only positional argument; {given} must be given by "
                           f"name, e.g. {what}(1.0, rtol=1e-6)")


def _component(model, path):
    return next((c for c in model.components() if c.path == path), None)
