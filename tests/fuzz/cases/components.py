"""Every component class and each of its parameters, inputs and start values, given what a number must
not be: generated from the declarations, so a new component or parameter is fuzzed without a new line.
Hand-written beside them: relations between parameters, names, and axes at any scale (legitimate)."""
from __future__ import annotations

import importlib
import inspect
import math
import pkgutil

import numpy as np

import mechnet as mn
import mechnet.components
from mechnet.core.declarations import Flag, Input, Param, Variable, direction, nonnegative, nonzero, positive
from fuzz.framework import Collector, close, expect

NAME = "part"

# valid values where the check alone does not say (required parameters and the relations between them)
VALID = {"phi_min": -1.0, "phi_max": 1.0, "s_min": -1.0, "s_max": 1.0, "mu_k": 0.3, "mu_s": 0.5,
         "r": [1.0, 0.0, 0.0], "e": 0.5}


def component_classes() -> list:
    found = {}
    for info in pkgutil.walk_packages(mechnet.components.__path__, "mechnet.components."):
        module = importlib.import_module(info.name)
        for _, cls in vars(module).items():
            if inspect.isclass(cls) and issubclass(cls, mn.Component) and not cls.abstract:
                label = f"{cls.__module__.split('.')[2]}.{cls.__name__}"
                found.setdefault(label, cls)
    return sorted(found.items())


def valid_kwargs(cls) -> dict:
    """Keyword arguments that build `cls` (every required parameter given)."""
    out = {}
    for key, decl in cls._declarations.items():
        if isinstance(decl, Param) and decl.default is None:
            if key in VALID:
                out[key] = VALID[key]
            elif decl.check in (positive, nonnegative):
                out[key] = 1.0
            elif decl.check is nonzero:
                out[key] = 2.0
            else:
                out[key] = 0.5
        elif isinstance(decl, Param) and key in ("mu_k", "mu_s"):
            out[key] = VALID[key]
    return out


def build(cls, **kw):
    return lambda: cls(name=NAME, **{**valid_kwargs(cls), **kw})


def _range_values(check) -> list:
    """Values outside the check's range (with why)."""
    if check is positive:
        return [("zero", 0.0), ("negative", -1.0)]
    if check is nonnegative:
        return [("negative", -1e-3)]
    if check is nonzero:
        return [("zero", 0.0)]
    if getattr(check, "value_range", None):         # restitution and the like: just outside each end
        lower, _, upper = check.value_range
        return [(f"below", lower - 0.5)] + ([("above", upper + 0.5)] if math.isfinite(upper) else [])
    return []


SCALAR_BAD = [("nan", math.nan), ("inf", -math.inf), ("text", "1.5"), ("none", None)]
# the rarer kinds, for a class's first scalar parameter only (the check is one function for all of them)
SCALAR_RARE = [("complex", 1 + 2j), ("bool", True), ("list", [1.0, 2.0]), ("tunable_nan", mn.tunable(math.nan))]


def _scalar(col, label, cls, key, decl, first: bool) -> None:
    for what, value in SCALAR_BAD + (SCALAR_RARE if first else []) + _range_values(decl.check):
        col.bad(f"{label}.{key}.{what}", build(cls, **{key: value}), (key, NAME))


def _vector(col, label, cls, key, decl) -> None:
    shape = decl.shape
    if isinstance(shape, int):
        good = [1.0] + [0.0] * (shape - 1)
        bad = [("nan", [math.nan] + good[1:]), ("short", good[:-1]), ("long", good + [0.0]), ("text", "abc"),
               ("entry_text", ["1"] + good[1:]), ("matrix", [good, good])]
        if decl.check is direction:
            bad.append(("zero", [0.0] * shape))
    else:
        eye = np.eye(shape[0]).tolist()
        bad = [("nan", [[math.nan, 0, 0], [0, 1, 0], [0, 0, 1]]), ("2x2", [[1, 0], [0, 1]]), ("vector", [1, 1, 1]),
               ("text", "I"),
               ("negative", [[1, 0, 0], [0, 1, 0], [0, 0, -1]]), ("asymmetric", [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]),
               ("triangle", [[1, 0, 0], [0, 1, 0], [0, 0, 3]]), ("flat9", sum(eye, []) + [0.0])]
    for what, value in bad:
        col.bad(f"{label}.{key}.{what}", build(cls, **{key: value}), (key, NAME))


def _variable(col, label, cls, key, decl) -> None:
    n = decl.shape
    col.bad(f"{label}.{key}_start.nan", build(cls, **{f"{key}_start": [math.nan] * n if n > 1 else math.nan}),
            (f"{key}_start", NAME))
    col.bad(f"{label}.{key}_start.length", build(cls, **{f"{key}_start": [0.1] * (n + 1)}), (f"{key}_start", NAME))


def _per_class(col, label, cls, rare: bool) -> None:
    """`rare`: also the kinds of mistake that go through one shared path (nominal, guess, name None)."""
    decls = cls._declarations
    scalars = [k for k, d in decls.items() if isinstance(d, Param) and d.shape == 1]
    for key, decl in decls.items():
        if isinstance(decl, Param) and decl.shape == 1:
            _scalar(col, label, cls, key, decl, key == scalars[0])
        elif isinstance(decl, Param):
            _vector(col, label, cls, key, decl)
        elif isinstance(decl, Flag):
            col.bad(f"{label}.{key}.number", build(cls, **{key: 1}), (key, NAME))
            col.bad(f"{label}.{key}.text", build(cls, **{key: "yes"}), (key, NAME))
        elif isinstance(decl, Input):
            col.bad(f"{label}.{key}.nan", build(cls, **{key: math.nan}), (key, NAME))
            col.bad(f"{label}.{key}.text", build(cls, **{key: "drive"}), (key, NAME))
            col.bad(f"{label}.{key}.callable", build(cls, **{key: lambda t: t}), (key, NAME))
            col.bad(f"{label}.{key}.list", build(cls, **{key: [1.0, 2.0]}), (key, NAME))
    variables = [(k, d) for k, d in decls.items() if isinstance(d, Variable) and not isinstance(d, Input)]
    for key, decl in variables[:1]:
        _variable(col, label, cls, key, decl)
    if variables:
        key = variables[0][0]
        if rare:
            col.bad(f"{label}.{key}_nominal.zero", build(cls, **{f"{key}_nominal": 0.0}), (f"{key}_nominal", NAME))
            col.bad(f"{label}.{key}_guess.text", build(cls, **{f"{key}_guess": "x"}), (f"{key}_guess", NAME))
        col.bad(f"{label}.typo", build(cls, **{f"{key}_strat": 1.0}), (f"{key}_strat", NAME))
    else:
        col.bad(f"{label}.typo", build(cls, stat=1.0), ("stat", NAME))
    if rare:
        col.bad(f"{label}.name.dotted", lambda: cls(name="a.b", **valid_kwargs(cls)), ("a.b",))
        col.bad(f"{label}.name.none", lambda: cls(name=None, **valid_kwargs(cls)), ("name", cls.__name__))


def _relations(col) -> None:
    from mechnet.components import rotational as rot, translational as tr
    col.bad("rel.friction.mu_s_below_mu_k", lambda: tr.Friction(name=NAME, fn=1, mu_k=0.5, mu_s=0.3), ("mu_s", "mu_k"))
    col.bad("rel.clutch.mu_s_below_mu_k", lambda: rot.Clutch(name=NAME, fn_max=1, mu_k=0.5, mu_s=0.3), ("mu_s", "mu_k"))
    col.bad("rel.brake.mu_s_below_mu_k",
            lambda: rot.Brake(name=NAME, fn_max=1, mu_k=mn.tunable(0.5), mu_s=0.3), ("mu_s", "mu_k"))
    col.bad("rel.hardstop.reversed", lambda: rot.HardStop(name=NAME, phi_min=1, phi_max=-1), ("phi_max", "phi_min"))
    col.bad("rel.hardstop.equal", lambda: tr.HardStop(name=NAME, s_min=1, s_max=1), ("s_max", "s_min"))
    col.good("rel.hardstop.wide", lambda: tr.HardStop(name=NAME, s_min=-1e300, s_max=1e300),
             "any finite limits in order are a stop", lambda c: expect(c.name == NAME, "built"))
    col.bad("keyword.name_missing", lambda: rot.Inertia(J=1.0), ("name",))


def _axes(col) -> None:
    """Axes are directions: any finite non-zero length is normalised (legitimate, issue 32)."""
    from fuzz import fixtures
    from mechnet.components import multibody as mb

    def pendulum(n):
        m = mn.Model("pendulum")
        world = m.add(mb.World(name="world"))
        rev = m.add(mb.Revolute(name="rev", n=n, phi_start=0.3, w_start=0.0))
        rod = m.add(mb.FixedTranslation(name="rod", r=[1.0, 0, 0]))
        bob = m.add(mb.Particle(name="bob", m=1.0))
        m.connect(world.frame_b, rev.frame_a)
        m.connect(rev.frame_b, rod.frame_a)
        m.connect(rod.frame_b, bob.frame_a)
        return m.compile().simulate(1.0, n_out=11)["bob.frame_a.r_0[1]"]

    def same_as_unit(y):
        expect(close(y, fixtures.pendulum().simulate(1.0, n_out=11)["bob.frame_a.r_0[1]"], 1e-6),
               "a scaled axis swings as the unit axis")
    for what, n in (("long", [0, 0, 3.0]), ("tiny", [0, 0, 1e-200]), ("huge", [0, 0, 1e200]), ("int", [0, 0, 1])):
        col.good(f"axis.revolute.{what}", lambda n=n: pendulum(n), "an axis is a direction; its length is normalised",
                 same_as_unit, needs=("pendulum",))
    col.bad("axis.revolute.reversed_zero", lambda: pendulum([0, 0, -0.0]), ("n", "rev"))
    col.bad("axis.revolute.subnormal_nan", lambda: pendulum([0, 0, math.nan]), ("n", "rev"))


def _spherical(col) -> None:
    """Issue 32's known cases: Spherical start values of the wrong size."""
    from mechnet.components import multibody as mb
    col.bad("spherical.Q_start.three", lambda: mb.Spherical(name=NAME, Q_start=[1, 0, 0]), ("Q_start", NAME),
            known="Spherical(Q_start of 3 numbers)")
    col.bad("spherical.w_rel_a_start.two",
            lambda: mb.Spherical(name=NAME, Q_start=[1, 0, 0, 0], w_rel_a_start=[1, 2]), ("w_rel_a_start", NAME),
            known="Spherical(w_rel_a_start of 2)")
    col.bad("spherical.w_rel_a_start.text",
            lambda: mb.Spherical(name=NAME, Q_start=[1, 0, 0, 0], w_rel_a_start="abc"), ("w_rel_a_start", NAME))
    col.bad("spherical.w_rel_a_start.nan",
            lambda: mb.Spherical(name=NAME, Q_start=[1, 0, 0, 0], w_rel_a_start=[math.nan, 0, 0]),
            ("w_rel_a_start", NAME))
    col.bad("spherical.Q_start.zero", lambda: mb.Spherical(name=NAME, Q_start=[0, 0, 0, 0]), ("Q_start", NAME))
    col.bad("spherical.R_rel_start.not_rotation",
            lambda: mb.Spherical(name=NAME, R_rel_start=np.diag([1, 1, -1])), ("R_rel_start", NAME))
    col.bad("spherical.axis_without_angle", lambda: mb.Spherical(name=NAME, axis_start=[0, 0, 1]), ("angle_start",))
    col.bad("spherical.angle_text", lambda: mb.Spherical(name=NAME, axis_start=[0, 0, 1], angle_start="x"),
            ("angle_start", NAME))
    col.bad("spherical.Q_and_R", lambda: mb.Spherical(name=NAME, Q_start=[1, 0, 0, 0], R_rel_start=np.eye(3)),
            ("Q_start", "R_rel_start"))
    col.good("spherical.Q_start.unnormalised",
             lambda: mb.Spherical(name=NAME, Q_start=[2, 0, 0, 0]),
             "Q is unnormalised by design (R uses Q/|Q|)", lambda j: expect(j.name == NAME, "built"))


def collector() -> Collector:
    col = Collector("components")
    for k, (label, cls) in enumerate(component_classes()):
        _per_class(col, label, cls, rare=k % 5 == 0)
    _relations(col)
    _axes(col)
    _spherical(col)
    return col
