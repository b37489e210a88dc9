"""Equations in residual form, the time symbol and the `der()` operator.

Every variable symbol a component creates is registered here with its owner, so
that `der(x)` can hand back one derivative symbol per variable (created on first
use) and flatten can tell a declared variable from a stray CasADi symbol.
`der` of an expression is the total time derivative by the chain rule.

The registry holds each symbol (so its element hash, the node's address, cannot be
reused by another symbol while the entry exists), and drops a variable together with
its derivative symbols once nothing else in the process refers to any of them: then
no expression, component or Function can reach them, so no `der()` or flatten can
ever look them up again. Whether anything else refers to a node is read from CasADi's
own reference count (`_node_count`); pruning runs when the registry has doubled since
the last one, so a process that builds thousands of models stays flat.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Optional, Union

import casadi as ca

from ..caches import BUILD_LOCK
from .errors import StructureError

Expr = Union[ca.SX, float, int]

time = ca.SX.sym("time")
"""Simulation time inside equations (Modelica's `time`; never `t`)."""

# element hash -> [symbol, derivative symbol or None]; holding the symbol keeps the hash unique. A
# derivative symbol has an entry of its own, whose symbol is the same Python object as its parent's
# entry[1]: the registry holds exactly one reference to each node. These Python objects are never handed
# out (only copies, which count), so a node whose count is 1 is referred to by nothing else.
_REGISTRY: dict[int, list] = {}
# element hash of a derivative symbol -> element hash of the symbol it is the derivative of
_DERIVATIVE_OF: dict[int, int] = {}


def _find_count_offset() -> Optional[int]:
    """Where CasADi keeps an SX node's reference count (`SXNode::count`, an unsigned int after the
    vtable pointer; at byte 12 in casadi 3.8), found by watching it follow copies made and dropped.
    None when no candidate behaves so (another CasADi layout): the registry then keeps everything."""
    probe = ca.SX.sym("registry_probe")
    address = probe.element_hash()
    for offset in (12, 8, 16):                  # within any symbol node (vtable, two ints, its name)
        def count():
            return ctypes.c_uint.from_address(address + offset).value
        seen = [count()]
        copies = [ca.SX(probe), probe * 2.0]
        seen.append(count())
        copies.append(ca.vertcat(probe, probe))
        seen.append(count())
        del copies
        seen.append(count())
        if seen == [1, 3, 5, 1]:
            return offset
    return None  # pragma: no cover - another CasADi layout


_COUNT_OFFSET = _find_count_offset()
_PRUNE_FLOOR = 256       # never prune a registry smaller than this
_prune_at = _PRUNE_FLOOR  # prune when the registry reaches this size (twice what the last prune kept)


def _node_count(symbol: ca.SX) -> int:
    """CasADi's reference count of a scalar symbol's node: the references every SX matrix, expression
    and Function in the process hold to it (the registry's own entry included)."""
    return ctypes.c_uint.from_address(symbol.element_hash() + _COUNT_OFFSET).value


def prune_registry() -> int:
    """Drop every variable whose symbol and derivative symbols nothing but the registry refers to (its
    component, model and compiled model gone); returns how many entries are left. Runs by itself as
    the registry grows; call it to see how many symbols are still in use."""
    global _prune_at
    if _COUNT_OFFSET is None:
        return len(_REGISTRY)
    with BUILD_LOCK:
        groups: dict[int, list[int]] = {}
        for key in _REGISTRY:
            root, seen = key, {key}
            while root in _DERIVATIVE_OF and _DERIVATIVE_OF[root] in _REGISTRY and _DERIVATIVE_OF[root] not in seen:
                root = _DERIVATIVE_OF[root]
                seen.add(root)
            groups.setdefault(root, []).append(key)
        for members in groups.values():
            if all(_node_count(_REGISTRY[key][0]) == 1 for key in members):
                for key in members:
                    del _REGISTRY[key]
                    _DERIVATIVE_OF.pop(key, None)
        # a derivative link whose derivative entry is gone (its parent re-registered and then dropped)
        for key in [k for k in _DERIVATIVE_OF if k not in _REGISTRY]:
            del _DERIVATIVE_OF[key]
        _prune_at = max(_PRUNE_FLOOR, 2 * len(_REGISTRY))
        return len(_REGISTRY)


def register(symbol: ca.SX) -> None:
    """Record a scalar variable symbol so `der` and flatten know it. Under the build lock: a prune in
    another thread iterates the registry."""
    with BUILD_LOCK:
        if len(_REGISTRY) >= _prune_at:
            prune_registry()
        _REGISTRY[symbol.element_hash()] = [ca.SX(symbol), None]   # a copy of its own (see _REGISTRY)


def is_registered(symbol: ca.SX) -> bool:
    return symbol.element_hash() in _REGISTRY


def derivative_parent(symbol: ca.SX):
    """The symbol whose derivative `symbol` is, or None."""
    parent = _DERIVATIVE_OF.get(symbol.element_hash())
    entry = None if parent is None else _REGISTRY.get(parent)
    return None if entry is None else ca.SX(entry[0])


def _derivative_symbol(symbol: ca.SX) -> ca.SX:
    key = symbol.element_hash()
    with BUILD_LOCK:                                # one derivative symbol per variable, whatever the thread
        entry = _REGISTRY.get(key)
        if entry is None:
            return None
        if entry[1] is None:
            d = ca.SX.sym(f"der({symbol.name()})")
            register(d)
            d = _REGISTRY[d.element_hash()][0]      # the registry's own object: parent and child share it
            _DERIVATIVE_OF[d.element_hash()] = key
            entry[1] = d
        return ca.SX(entry[1])                      # a copy: what the caller holds must count


def der(expr: Expr) -> ca.SX:
    """Total time derivative. For a variable: its derivative symbol; for an expression: chain rule.

    Parameters and numbers have derivative zero, `time` has derivative one.
    """
    expr = ca.SX(expr)
    if expr.is_constant():
        return ca.SX.zeros(expr.shape)
    symbols = ca.symvar(expr)
    if expr.is_scalar() and expr.is_symbolic():
        if ca.is_equal(expr, time):
            return ca.SX(1.0)
        d = _derivative_symbol(expr)
        return d if d is not None else ca.SX(0.0)
    seeds = []
    for s in symbols:
        if ca.is_equal(s, time):
            seeds.append(ca.SX(1.0))
        else:
            d = _derivative_symbol(s)
            seeds.append(d if d is not None else ca.SX(0.0))
    if expr.is_column() or expr.is_scalar():
        return ca.jtimes(expr, ca.vertcat(*symbols), ca.vertcat(*seeds))
    flat = ca.reshape(expr, -1, 1)
    return ca.reshape(ca.jtimes(flat, ca.vertcat(*symbols), ca.vertcat(*seeds)), expr.shape)


@dataclass(frozen=True)
class Eq:
    """`lhs = rhs`, kept as the residual `lhs - rhs`; `doc` says what the equation states.

    `regular=True` promises that the equation's coefficients on its unknowns never make the system
    singular, whatever the modes: a friction element's path form (stuck: a = 0, f = sa; sliding:
    a = sa − f₀, f = f(v)) has coefficients that switch with the mode, yet each mode is solvable. The
    compiler may then solve its block symbolically, modes and all, instead of leaving it to the
    integrator's Newton iteration.
    """

    lhs: Expr
    rhs: Expr = 0.0
    doc: str = ""
    regular: bool = False

    def residual(self) -> ca.SX:
        return ca.SX(self.lhs) - ca.SX(self.rhs)


_DIRECTIONS = {"both": 0, "rising": 1, "falling": -1, 0: 0, 1: 1, -1: -1}


@dataclass(frozen=True)
class When:
    """A state event: when `condition` crosses zero (in `direction`), assign `reset` to states and modes.

    `reset` maps a state variable or a `Mode` to its new value, an expression evaluated
    just before the event (a bouncing ball: `{self.v: -self.e * self.v}`; a relay:
    `{self.on: 1.0}`).
    `direction`: "falling" (+ to −), "rising" (− to +) or "both".
    `jump` maps an `Impulse` of the component to (velocity, target): the impulse along it that makes
    the velocity expression equal the target (evaluated before the event) is applied to the *whole*
    scene through its impulse–momentum equations, so an impact on one link changes every link
    consistently (`{self.impulse: (self.v_rel, -self.e * self.v_rel)}`). Several impulses in one
    `jump` are solved together.
    `release=False` keeps every held element (stuck friction, resting contacts) holding during the
    jump: for a jump that only corrects what the event location left (a friction element sticking).
    An impact (`release=True`) frees them: what holds them carries a bounded or one-sided force.
    `rest` maps modes to their values when the events of this condition accumulate (a Zeno point:
    a ball bouncing ever lower): the jump is then made plastic (targets 0) and these modes set, and the
    run goes on instead of stopping.
    `at_start=True`: a condition already past zero in its direction at the start fires there (a
    friction element that starts stuck but is pushed beyond its static limit breaks away at once).
    """

    condition: Expr
    reset: dict = None
    direction: object = "both"
    doc: str = ""
    jump: dict = None
    rest: dict = None
    at_start: bool = False
    release: bool = True

    def __post_init__(self):
        """Checked where it is written (the component's events()), not deep in flatten as a CasADi error."""
        if isinstance(self.condition, (str, bytes, bool)) or not isinstance(self.condition, (ca.SX, ca.MX, ca.DM,
                                                                                              int, float)):
            raise StructureError(f"When: condition {self.condition!r} must be an expression of the component's "
                                 f"variables (such as self.h), not {type(self.condition).__name__}")
        for what, value in (("reset", self.reset), ("rest", self.rest), ("jump", self.jump)):
            if value is not None and not isinstance(value, dict):
                raise StructureError(f"When: {what} takes a mapping, got {type(value).__name__}")
        for impulse, pair in (self.jump or {}).items():
            if not (isinstance(pair, tuple) and len(pair) == 2):
                raise StructureError(f"When: jump maps an Impulse to (velocity, target), got {pair!r}")

    def sign(self) -> int:
        if not isinstance(self.direction, (str, int)) or self.direction not in _DIRECTIONS:
            raise ValueError(f"When: direction {self.direction!r} must be 'falling', 'rising' or 'both'")
        return _DIRECTIONS[self.direction]
