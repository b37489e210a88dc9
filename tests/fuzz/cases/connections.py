"""Connections and models: what connect(), add(), expose() and compile() are given, and models whose
equations do not determine their variables."""
from __future__ import annotations

import math

import mechnet as mn
from mechnet.components import multibody as mb
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from fuzz.framework import Collector, close, expect


def _two():
    m = mn.Model("m")
    j1 = m.add(rot.Inertia(name="j1", J=1.0, phi_start=0.0, w_start=0.0))
    j2 = m.add(rot.Inertia(name="j2", J=1.0))
    return m, j1, j2


def _connect(a, b):
    def run():
        m, j1, j2 = _two()
        mass = m.add(tr.Mass(name="mass", m=1.0))
        world = m.add(mb.World(name="world"))
        things = {"j1a": j1.flange_a, "j1b": j1.flange_b, "j2a": j2.flange_a, "mass": mass.flange_a,
                  "frame": world.frame_b, "j1": j1, "none": None, "text": "j1.flange_a", "model": m, "num": 1.0}
        m.connect(things[a], things[b])
        return m
    return run


class _Floating(mn.Component):
    """x with no equation: under-determined."""
    x = mn.Var(unit="m")
    y = mn.Var(unit="m")

    def equations(self):
        return [mn.Eq(self.x + self.y, 1.0)]


class _Over(mn.Component):
    x = mn.Var(unit="m")

    def equations(self):
        return [mn.Eq(self.x, 1.0), mn.Eq(self.x, 2.0)]


class _NoReturn(mn.Component):
    x = mn.State(unit="m")

    def equations(self):
        [mn.Eq(mn.der(self.x), 1.0)]


class _Comparison(mn.Component):
    x = mn.State(unit="m")

    def equations(self):
        return [mn.der(self.x) == 1.0]


class _Text(mn.Component):
    x = mn.State(unit="m")

    def equations(self):
        return ["der(x) = 1"]


def _single(cls, **kw):
    def run():
        m = mn.Model("m")
        m.add(cls(name="c", **kw))
        return m.compile()
    return run


def collector() -> Collector:
    col = Collector("connections")
    incompatible = [("j1a", "mass"), ("j1a", "frame"), ("mass", "frame"), ("frame", "j2a")]
    for a, b in incompatible:
        col.bad(f"connect.{a}_{b}", _connect(a, b), ("cannot connect",))
    col.bad("connect.self", _connect("j1a", "j1a"), ("j1.flange_a", "itself"))
    for a, b in (("j1", "j2a"), ("none", "j2a"), ("text", "j2a"), ("j1a", "model"), ("j1a", "num")):
        col.bad(f"connect.not_connector.{a}_{b}", _connect(a, b), ("connect()",))

    def foreign():
        m, j1, j2 = _two()
        other = rot.Inertia(name="j3", J=1.0)
        m.connect(j1.flange_b, other.flange_a)
    col.bad("connect.not_added", foreign, ("j3.flange_a",))

    def other_model():
        m, j1, j2 = _two()
        m2 = mn.Model("m2")
        j4 = m2.add(rot.Inertia(name="j4", J=1.0))
        m.connect(j1.flange_b, j4.flange_a)
    col.bad("connect.other_model", other_model, ("j4.flange_a",))

    def disabled():
        m = mn.Model("m")
        rev = m.add(mb.Revolute(name="rev"))
        j = m.add(rot.Inertia(name="j", J=1.0))
        m.connect(rev.axis, j.flange_a)
    col.bad("connect.disabled_port", disabled, ("axis", "use_flange"))

    def duplicate():
        m = mn.Model("m")
        m.add(rot.Inertia(name="j", J=1.0))
        m.add(rot.Inertia(name="j", J=2.0))
    col.bad("add.duplicate_name", duplicate, ("j",))

    def twice():
        m = mn.Model("m")
        j = m.add(rot.Inertia(name="j", J=1.0))
        m.add(j)
    col.bad("add.same_twice", twice, ("j",))

    def two_models():
        j = rot.Inertia(name="j", J=1.0)
        mn.Model("a").add(j)
        mn.Model("b").add(j)
    col.bad("add.two_models", two_models, ("j",))
    for what, value in (("none", None), ("text", "j1"), ("class", rot.Inertia), ("number", 3)):
        col.bad(f"add.{what}", lambda v=value: mn.Model("m").add(v), ("add()",))

    def itself():
        m = mn.Model("m")
        m.add(m)
    col.bad("add.itself", itself, ("itself",))
    for what, value in (("none", None), ("dotted", "a.b"), ("empty", ""), ("number", 3), ("keyword", "class")):
        col.bad(f"model.name.{what}", lambda v=value: mn.Model(v), ("name",))

    def after_compile(action):
        def run():
            m, j1, j2 = _two()
            m.connect(j1.flange_b, j2.flange_a)
            m.add(rot.Fixed(name="f"))
            m.connect(m.f.flange, j1.flange_a)
            m.compile()
            if action == "add":
                m.add(rot.Inertia(name="j9", J=1.0))
            elif action == "connect":
                m.connect(j2.flange_b, m.f.flange)
            else:
                m.compile()
                return "compiled again"
        return run
    col.bad("frozen.add", after_compile("add"), ("frozen",))
    col.bad("frozen.connect", after_compile("connect"), ("frozen",))
    col.good("frozen.compile_again", after_compile("compile"), "compiling a frozen model again is reading it",
             lambda v: expect(v == "compiled again", "compiled"))

    def expose(name, conn):
        def run():
            sub = mn.Model("drive")
            j = sub.add(rot.Inertia(name="j", J=1.0))
            sub.expose(name, {"good": j.flange_b, "none": None, "foreign": rot.Inertia(name="k", J=1.0).flange_a,
                              "text": "j.flange_b"}[conn])
        return run
    col.bad("expose.bad_name", expose("1flange", "good"), ("1flange",))
    col.bad("expose.component_name", expose("j", "good"), ("j",))
    col.bad("expose.none", expose("out", "none"), ("drive",))
    col.bad("expose.foreign", expose("out", "foreign"), ("k.flange_a",))
    col.bad("expose.text", expose("out", "text"), ("drive",))
    col.bad("model.getattr", lambda: mn.Model("m").nothing, ("nothing",))

    # models whose equations do not determine their variables
    def free_inertia():
        m = mn.Model("m")
        m.add(rot.Inertia(name="j1", J=1.0, phi_start=0.0, w_start=0.0))
        return m.compile().simulate(1.0, n_out=3)
    col.good("model.free_inertia", free_inertia, "an unconnected flange is a free end (zero torque)",
             lambda r: expect(close(r["j1.phi"], 0.0), "stays at rest"))
    col.bad("model.underdetermined", _single(_Floating), ("c.x", "c.y"))
    col.bad("model.overdetermined", _single(_Over), ("c", "equation 2"))
    col.bad("model.no_return", _single(_NoReturn), ("c", "equations()"))
    col.bad("model.comparison", _single(_Comparison), ("c", "Eq"))
    col.bad("model.text_equation", _single(_Text), ("c", "equation 1"))
    col.bad("model.empty", lambda: mn.Model("m").compile(), ("m",))

    def two_fixed():
        m = mn.Model("m")
        f1, f2 = m.add(rot.Fixed(name="f1")), m.add(rot.Fixed(name="f2", phi0=1.0))
        m.connect(f1.flange, f2.flange)
        return m.compile().simulate(1.0)
    col.bad("model.conflicting_fixed", two_fixed, (("f1", "f2"),))

    def massless():
        m = mn.Model("m")
        f = m.add(rot.Fixed(name="f"))
        s = m.add(rot.Spring(name="s", c=1.0))
        tq = m.add(rot.Torque(name="tq", tau=1.0))
        m.connect(f.flange, s.flange_a)
        m.connect(s.flange_b, tq.flange)
        return m.compile().simulate(1.0)
    col.good("model.massless_spring", massless, "a spring between a fixed end and a torque is statics: phi = tau/c",
             lambda r: expect(close(r["s.phi_rel"], 1.0), "phi_rel = 1"))

    def gear_zero_inertia():
        m = mn.Model("m")
        tq = m.add(rot.Torque(name="tq", tau=1.0))
        g = m.add(rot.IdealGear(name="g", ratio=2.0))
        m.connect(tq.flange, g.flange_a)
        return m.compile().simulate(1.0)
    col.bad("model.torque_into_nothing", gear_zero_inertia, (("tq", "g"),))
    col.bad("compile.options_dict", lambda: _two()[0].compile({"rtol": 1}), ("options",))
    col.bad("compile.options_text", lambda: _two()[0].compile("fast"), ("options",))

    def bad_signal_input():
        m = mn.Model("m")
        j = m.add(rot.Inertia(name="j", J=1.0, phi_start=0, w_start=0))
        s = m.add(rot.Speed(name="s", w_ref=math.nan))
        m.connect(s.flange, j.flange_a)
    col.bad("source.speed_nan", bad_signal_input, ("w_ref", "s"))
    return col
