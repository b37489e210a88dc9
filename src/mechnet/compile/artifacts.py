"""The frozen objects passed between compile stages. Each has a `summary()`.

Structural data is kept as integers (variable and equation indices); the CasADi
symbols sit beside them in the same order.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import casadi as ca


@dataclass(frozen=True)
class FlatVariable:
    """One scalar variable of the flat system."""

    name: str
    symbol: ca.SX
    kind: str                 # state | algebraic | output | across | through | input | derivative
    unit: str = "1"
    start: Optional[float] = None     # fixed start value (enforced)
    guess: Optional[float] = None     # Newton guess (not enforced)
    default_start: float = 0.0        # declared start, used when nothing else is known
    nominal: float = 1.0
    priority: str = "default"
    origin: str = ""                  # component path ("" for derivative variables)
    component_type: str = ""
    input_default: float = 0.0


@dataclass(frozen=True)
class FlatEquation:
    """One scalar residual 0 = residual, remembering where it came from."""

    residual: ca.SX
    origin: str               # component path, or "connection"
    label: str                # "j1 (Inertia), equation 4" / "connection {a.flange, b.flange}: phi equal"
    doc: str = ""
    order: int = 0            # how often index reduction differentiated it (0: as written)
    constraint: bool = False  # an original equation that index reduction differentiated (an invariant)
    smoothness: float = float("inf")   # how often its signals may be differentiated
    regular: bool = False     # its coefficients on its unknowns never make it singular (a multibody pivot
                              # is an articulated inertia > 0), so emit may divide by them
    pivot: str = ""           # the unknown it may be solved for by division, whatever the coefficient's
                              # arguments (a joint acceleration: its coefficient is that inertia)
    pivot_unless: tuple = ()  # unless simplification made the pivot one of these (the parent link's
                              # accelerations, which the row also holds: the coefficient would mix)

    def describe(self) -> str:
        return f"{self.label}" + (f" — {self.doc}" if self.doc else "")


@dataclass(frozen=True)
class ZeroCrossing:
    """g(...) crossing zero in `direction` (−1, 0, +1) triggers `resets`: (variable index, new value),
    and `mode_resets`: (index in FlatSystem.modes, new value)."""

    g: ca.SX
    resets: tuple
    direction: int
    label: str
    mode_resets: tuple = ()
    jumps: tuple = ()            # (index in FlatSystem.modes of an Impulse, velocity, target)
    rest: tuple = None           # mode resets (index, value) at an accumulation of these events, or None
    at_start: bool = False       # fires at the start when already past zero in its direction
    release: bool = True         # its jump frees held elements (an impact), or keeps them (sticking)


@dataclass(frozen=True)
class FlatMode:
    """A discrete variable (`Mode`): a symbol like a parameter, constant between events."""

    name: str
    symbol: ca.SX
    start: float
    impulse: bool = False        # an Impulse: always 0 between events, the direction a jump acts along
    values: tuple = None         # the values it can take (`Mode(values=...)`), None: any


@dataclass(frozen=True)
class Parameter:
    name: str
    symbol: ca.SX
    value: float
    unit: str = "1"
    declaration: object = None        # the Param, so a new value is checked like at construction
    owner: str = ""                   # "s (Spring)"


@dataclass(frozen=True)
class FlatSystem:
    """Namespaced scalar variables and residual equations in CasADi SX.

    `der_of[i] = (j, sign)` says der(variable i) = sign · variable j.
    """

    name: str
    variables: tuple
    equations: tuple
    parameters: tuple
    der_of: dict
    time: ca.SX
    effects: tuple = ()
    stage: str = "flatten"
    time_events: tuple = ()       # (time, cause): where a signal jumps or kinks
    folded_parameters: tuple = ()  # names of parameters folded into the equations as numbers
    zero_crossings: tuple = ()    # ZeroCrossing: state events declared with When
    multibody: object = None      # MultibodyTree from the tree pass (frames as expressions), or None
    observed_only: tuple = ()     # (name, symbol, unit, expression): names that left the equations (frames)
    intermediates: tuple = ((), ())  # (symbols, definitions): state-only quantities the equations share
    modes: tuple = ()             # FlatMode: discrete variables, the DAE's d
    unit_quaternions: tuple = ()  # (what, names): quaternion states, renormalised at restarts, |Q| − 1 watched
    switched: tuple = ()          # (path, type, form) of each component with modes: friction, stops, relays
    releases: tuple = ()          # (mode index, released value, stays, value when released): `jump_releases`
    requirements: tuple = ()      # (expression >= 0 at the start, what): `Component.start_requirements`
    parameter_requirements: tuple = ()   # dicts: `core/requirements.compiled`, checked on new values

    def expand(self, exprs: list) -> list:
        """`exprs` with the intermediates replaced by their definitions (sharing kept: one pass)."""
        syms, defs = self.intermediates
        if not syms or not exprs:
            return list(exprs)
        _, out = ca.substitute_inplace(list(syms), list(defs), [ca.SX(e) for e in exprs], False)
        return list(out)

    def uses_intermediates(self, expr) -> bool:
        syms = self.intermediates[0]
        return bool(syms) and ca.depends_on(ca.SX(expr), ca.vertcat(*syms))

    def index_of(self) -> dict[str, int]:
        return {v.name: i for i, v in enumerate(self.variables)}

    def states(self) -> list[int]:
        return sorted(self.der_of)

    def unknowns(self) -> list[int]:
        """Variables solved for at each instant: all but inputs and states."""
        return [i for i, v in enumerate(self.variables) if v.kind != "input" and i not in self.der_of]

    def summary(self) -> str:
        return (f"{self.stage}: {len(self.variables)} variables ({len(self.der_of)} with derivatives), "
                f"{len(self.equations)} equations, {len(self.parameters)} tunable parameters")


@dataclass(frozen=True)
class AliasMap:
    """Eliminated variables as expressions of the remaining ones: every dotted name stays addressable."""

    expressions: dict           # name -> SX expression in the remaining symbols
    n_alias: int = 0
    n_constant: int = 0
    n_removed_equations: int = 0

    def summary(self) -> str:
        return (f"simplify: {self.n_alias} aliases and {self.n_constant} constants eliminated, "
                f"{self.n_removed_equations} equations removed")


@dataclass(frozen=True)
class StructureReport:
    """Incidence, matching and BLT blocks of the simplified system (integers only).

    `unknowns` are variable indices; `incidence[e]` lists the positions (in
    `unknowns`) that equation e contains; `matching[e]` is that position;
    `blocks` are lists of equation indices in solving order.
    """

    unknowns: tuple
    incidence: tuple
    matching: tuple
    blocks: tuple
    n_equations: int

    def summary(self) -> str:
        sizes = [len(b) for b in self.blocks]
        big = max(sizes) if sizes else 0
        return (f"structure: {self.n_equations} equations, {len(self.unknowns)} unknowns, "
                f"{len(self.blocks)} BLT blocks (largest {big})")


@dataclass(frozen=True)
class Selection:
    """One choice of states and algebraics (DESIGN.md, `selections`)."""

    x_names: tuple
    z_names: tuple
    ode: ca.Function
    alg: ca.Function
    observed: ca.Function


@dataclass(frozen=True)
class SemiExplicitDAE:
    """The compiled model everything downstream reads: ẋ = ode(...), 0 = alg(...).

    All functions take (t, x, z, u, p, d). `observed` returns every dotted name
    of the scene, in `observed_names` order.
    """

    name: str
    t: ca.SX
    x: ca.SX
    z: ca.SX
    u: ca.SX
    p: ca.SX
    d: ca.SX
    x_names: tuple
    z_names: tuple
    u_names: tuple
    p_names: tuple
    d_names: tuple
    ode: ca.Function
    alg: ca.Function
    observed: ca.Function
    observed_names: tuple
    zero: ca.Function
    transition: tuple            # one Function per zero crossing: (t,x,z,u,p,d) -> (x+, d+)
    invariants: ca.Function
    invariant_names: tuple
    selections: tuple
    x_nominal: tuple
    z_nominal: tuple
    units: dict
    starts: dict                 # dotted name -> fixed start value
    guesses: dict                # dotted name -> guess (declared start for unfixed ones)
    u_default: tuple
    p_value: tuple
    d_value: tuple
    time_events: tuple = ()      # (time, cause), sorted
    zero_labels: tuple = ()      # what each zero crossing is, for Result.events
    zero_directions: tuple = ()  # −1 falling, +1 rising, 0 both
    info: dict = field(default_factory=dict)

    def __getstate__(self):
        """Pickled without the run-time caches kept in `info` under "_" keys (maps, Newton functions):
        they are rebuilt on first use, and would only make the pickle larger."""
        state = dict(self.__dict__)
        info = dict(self.info)        # one copy (atomic): a run in another thread may be adding its caches
        state["info"] = {k: v for k, v in info.items() if not k.startswith("_")}
        return state

    @property
    def is_ode(self) -> bool:
        return self.z.numel() == 0

    def n_instructions(self) -> int:
        return self.ode.n_instructions() + self.alg.n_instructions()

    def summary(self) -> str:
        kind = "explicit ODE" if self.is_ode else "index-1 DAE"
        return (f"emit: {kind} with {self.x.numel()} states, {self.z.numel()} algebraics, "
                f"{self.n_instructions()} instructions in ode + alg")
