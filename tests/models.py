"""Canonical scene factories shared by the tests."""
from __future__ import annotations

import mechnet as mn
from mechnet.components import rotational as rot


def oscillator(J=0.1, c=100.0, d=0.0, phi0=0.5, w0=0.0, name="oscillator") -> mn.Model:
    """Inertia on a torsional spring (and damper if d > 0) to a fixed housing."""
    m = mn.Model(name)
    fixed = m.add(rot.Fixed(name="fixed"))
    j1 = m.add(rot.Inertia(name="j1", J=J, phi_start=phi0, w_start=w0))
    if d > 0:
        element = m.add(rot.SpringDamper(name="spring", c=c, d=d))
    else:
        element = m.add(rot.Spring(name="spring", c=c))
    m.connect(fixed.flange, element.flange_a)
    m.connect(element.flange_b, j1.flange_a)
    return m


def inertia_chain(n=20, J=0.01, c=1e3, d=0.0, phi_last=1.0, name="chain") -> mn.Model:
    """Fixed end, then n × (spring[-damper] + inertia); the last inertia starts displaced."""
    m = mn.Model(name)
    previous = m.add(rot.Fixed(name="fixed")).flange
    for k in range(n):
        element = m.add(rot.SpringDamper(name=f"sd{k}", c=c, d=d) if d > 0 else rot.Spring(name=f"s{k}", c=c))
        inertia = m.add(rot.Inertia(name=f"j{k}", J=J, phi_start=phi_last if k == n - 1 else 0.0, w_start=0.0))
        m.connect(previous, element.flange_a)
        m.connect(element.flange_b, inertia.flange_a)
        previous = inertia.flange_b
    return m


class CartesianPendulum(mn.Component):
    """Point mass on a massless rod, written as raw equations in x, y and the multiplier lam (index 3)."""

    m = mn.Param(1.0, unit="kg", check=mn.positive)
    L = mn.Param(1.0, unit="m", check=mn.positive)
    g = mn.Param(9.81, unit="m/s^2")
    x = mn.State(unit="m", priority="default")
    y = mn.State(unit="m", priority="default")
    vx = mn.State(unit="m/s", priority="default")
    vy = mn.State(unit="m/s", priority="default")
    lam = mn.Var(unit="N/m", doc="rod force per unit length (Lagrange multiplier)")

    def equations(self):
        return [mn.Eq(mn.der(self.x), self.vx), mn.Eq(mn.der(self.y), self.vy),
                mn.Eq(self.m * mn.der(self.vx), -self.lam * self.x),
                mn.Eq(self.m * mn.der(self.vy), -self.lam * self.y - self.m * self.g),
                mn.Eq(self.x**2 + self.y**2, self.L**2, "rod length")]


def cartesian_pendulum(theta0=0.5, L=1.0, **kw) -> mn.Model:
    import math

    m = mn.Model("pendulum")
    m.add(CartesianPendulum(name="p", L=L, x_start=L * math.sin(theta0), y_guess=-L * math.cos(theta0),
                            vx_start=0.0, **kw))
    return m


class BouncingBall(mn.Component):
    """A ball falling under gravity, reflected with restitution e at h = 0 (a state event)."""

    e = mn.Param(0.8, check=mn.positive, doc="coefficient of restitution")
    g = mn.Param(9.81, unit="m/s^2")
    h = mn.State(unit="m", doc="height")
    v = mn.State(unit="m/s", doc="upward speed")

    def equations(self):
        return [mn.Eq(mn.der(self.h), self.v), mn.Eq(mn.der(self.v), -self.g)]

    def events(self):
        return [mn.When(self.h, reset={self.v: -self.e * self.v}, direction="falling", doc="impact")]


def bouncing_ball(h0=1.0, e=0.8) -> mn.Model:
    m = mn.Model("ball")
    m.add(BouncingBall(name="b", e=e, h_start=h0, v_start=0.0))
    return m
