"""Force elements between frames (Modelica.Mechanics.MultiBody.Forces).

They are not part of the tree: each writes its own equations in terms of the
frame positions, orientations and (through `der`) velocities, and its cut
forces load the bodies it connects. Line forces act along the line between
the two frame origins; `f > 0` pulls the frames together.
"""
from __future__ import annotations

import casadi as ca

from ...core.component import Component
from ...core.declarations import Param, Port, Var, finite_number, nonnegative, positive
from ...core.equation import Eq, der, time
from ...core.errors import ParameterError
from .interfaces import Frame, PartialTwoFrames

S_SMALL = 1e-12     # m: regularises the direction of a line force at zero length


class PartialLineForce(PartialTwoFrames, abstract=True):
    """A force f along the line frame_a → frame_b, no torques; subclasses give `line_force()`."""

    s = Var(unit="m", doc="distance between the frame origins", start=1.0)
    f = Var(unit="N", doc="line force, > 0 pulls the frames together")

    def line_force(self):
        raise NotImplementedError

    def direction(self):
        r = self.frame_b.r_0 - self.frame_a.r_0
        return r / ca.sqrt(ca.sumsqr(r) + S_SMALL ** 2)

    def equations(self):
        r = self.frame_b.r_0 - self.frame_a.r_0
        e = self.direction()
        Ra, Rb = self.frame_a.rotation(), self.frame_b.rotation()
        return [Eq(self.s, ca.sqrt(ca.sumsqr(r) + S_SMALL ** 2), "distance of the frame origins"),
                Eq(self.f, self.line_force(), "force law"),
                Eq(self.frame_a.f, -ca.mtimes(Ra.T, self.f * e), "pulls frame_a towards frame_b"),
                Eq(self.frame_b.f, ca.mtimes(Rb.T, self.f * e), "pulls frame_b towards frame_a"),
                Eq(self.frame_a.t, 0), Eq(self.frame_b.t, 0)]

    def potential_energy(self):
        """Energy stored in the element (J); None if it dissipates or has none."""
        return None

    def elongation_rate(self):
        """ds/dt = e · (v_b − v_a): the frames' velocities come from the tree."""
        return ca.dot(self.direction(), der(self.frame_b.r_0) - der(self.frame_a.r_0))


class Spring(PartialLineForce):
    """Linear line spring: f = c (s − s_unstretched)."""

    c = Param(unit="N/m", check=nonnegative, doc="spring constant")
    s_unstretched = Param(0.0, unit="m", check=nonnegative, doc="unstretched length")

    def line_force(self):
        return self.c * (self.s - self.s_unstretched)

    def potential_energy(self):
        return 0.5 * self.c * (self.s - self.s_unstretched) ** 2


class Damper(PartialLineForce):
    """Linear line damper: f = d · ds/dt."""

    d = Param(unit="N*s/m", check=nonnegative, doc="damping constant")

    def line_force(self):
        return self.d * self.elongation_rate()


class SpringDamper(PartialLineForce):
    """Spring and damper in parallel: f = c (s − s_unstretched) + d · ds/dt."""

    c = Param(unit="N/m", check=nonnegative, doc="spring constant")
    d = Param(unit="N*s/m", check=nonnegative, doc="damping constant")
    s_unstretched = Param(0.0, unit="m", check=nonnegative, doc="unstretched length")

    def line_force(self):
        return self.c * (self.s - self.s_unstretched) + self.d * self.elongation_rate()

    def potential_energy(self):
        return 0.5 * self.c * (self.s - self.s_unstretched) ** 2


class Gravitation(PartialLineForce):
    """Newton's law of gravitation between two point masses at the frame origins: f = G m_a m_b / s²."""

    m_a = Param(unit="kg", check=positive, doc="mass at frame_a")
    m_b = Param(unit="kg", check=positive, doc="mass at frame_b")
    G = Param(6.67430e-11, unit="m3/(kg*s2)", check=positive, doc="gravitational constant")

    def line_force(self):
        return self.G * self.m_a * self.m_b / self.s ** 2

    def potential_energy(self):
        return -self.G * self.m_a * self.m_b / self.s


def _vector_source(label: str, value):
    """Three numbers or signals (mechnet.components.signals) → (expressions in time, the signals)."""
    try:
        entries = list(value)
    except TypeError:
        raise ParameterError(f"{label} = {value!r} must be three numbers or signals") from None
    if len(entries) != 3:
        raise ParameterError(f"{label} = {value!r} must be three numbers or signals")
    exprs, signals = [], {}
    for i, v in enumerate(entries):
        if hasattr(v, "expr") and hasattr(v, "events"):
            exprs.append(v.expr(time))
            signals[i] = v
        else:
            exprs.append(ca.SX(finite_number(v, f"{label}[{i}] (a number or a signal)")))
    return ca.vertcat(*exprs), signals


class _WorldLoad(Component, abstract=True):
    """A force or torque on frame_b given by three numbers or signals, resolved in world or in frame_b."""

    frame_b = Port(Frame, doc="the frame the load acts on")
    _what = "force"

    def __init__(self, name: str | None = None, value=(0.0, 0.0, 0.0), resolve_in: str = "world", **kwargs):
        label = f"{name} ({type(self).__name__})"
        if resolve_in not in ("world", "frame_b"):
            raise ParameterError(f"{label}: resolve_in = {resolve_in!r} must be 'world' or 'frame_b'")
        self._load, signals = _vector_source(f"{label}: {self._what}", value)
        self._resolve_in = resolve_in
        super().__init__(name, **kwargs)
        for i, sig in signals.items():
            self.signals[f"{self._what}[{i}]"] = sig
        self._signal_values = dict(self.signals)
        self.signals.clear()                  # driven through equations below, not through an Input

    def time_events(self):
        return [(float(t), f"{self.path}.{key}: {sig!r}") for key, sig in self._signal_values.items()
                for t in sig.events()]

    def load_world(self):
        if self._resolve_in == "world":
            return self._load
        return ca.mtimes(self.frame_b.rotation(), self._load)


class WorldForce(_WorldLoad):
    """A force on frame_b's origin: three numbers or signals (N), resolved in world (default) or frame_b."""

    _what = "force"
    _argument_docs = {"force": ("N", "three numbers or signals (mechnet.components.signals)"),
                      "resolve_in": ("", "'world' or 'frame_b': the axes the force is given in")}

    def __init__(self, name: str | None = None, force=(0.0, 0.0, 0.0), resolve_in: str = "world", **kwargs):
        super().__init__(name, force, resolve_in, **kwargs)

    def equations(self):
        Rb = self.frame_b.rotation()
        return [Eq(self.frame_b.f, -ca.mtimes(Rb.T, self.load_world()), "the element pushes frame_b with +force"),
                Eq(self.frame_b.t, 0)]


class WorldTorque(_WorldLoad):
    """A torque on frame_b: three numbers or signals (N·m), resolved in world (default) or frame_b."""

    _what = "torque"
    _argument_docs = {"torque": ("N*m", "three numbers or signals (mechnet.components.signals)"),
                      "resolve_in": ("", "'world' or 'frame_b': the axes the torque is given in")}

    def __init__(self, name: str | None = None, torque=(0.0, 0.0, 0.0), resolve_in: str = "world", **kwargs):
        super().__init__(name, torque, resolve_in, **kwargs)

    def equations(self):
        Rb = self.frame_b.rotation()
        return [Eq(self.frame_b.t, -ca.mtimes(Rb.T, self.load_world()), "the element turns frame_b with +torque"),
                Eq(self.frame_b.f, 0)]
