"""Small hand-made scenes and user components for the compile-stage unit tests.

Each scene is a factory (a compiled Model is frozen, so every test builds its
own). The user components are written so that the structure of their flat
system is known by hand: the BLT order, the size of the algebraic loop, the
block that must stay torn.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

import mechnet as mn
from mechnet.components import rotational as rot


# ---- user components ------------------------------------------------------------------------

class ReversedChain(mn.Component):
    """y1 = x, y2 = y1 + 1, der(x) = -y2 — declared in reverse, so BLT must reorder them.

    Equation 1 (der(x) = -y2) needs y2, equation 2 (y2 = y1 + 1) needs y1,
    equation 3 (y1 = x) needs only the state: the solving order is 3, 2, 1.
    """

    x = mn.State(start=1.0)
    y1 = mn.Var()
    y2 = mn.Var()

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.y2, "decay driven by y2"),
                mn.Eq(self.y2, self.y1 + 1, "y2 from y1"),
                mn.Eq(self.y1, self.x, "y1 from the state")]


class LinearLoop(mn.Component):
    """A 2×2 algebraic loop a + b = x, a - b = 2x (a = 1.5x, b = -0.5x), read by y = a·b."""

    x = mn.State(start=1.0)
    a = mn.Var()
    b = mn.Var()
    y = mn.Var()

    def equations(self):
        return [mn.Eq(self.a + self.b, self.x, "sum"),
                mn.Eq(self.a - self.b, 2 * self.x, "difference"),
                mn.Eq(self.y, self.a * self.b, "product, downstream of the loop"),
                mn.Eq(mn.der(self.x), -self.y, "decay")]


class Cubic(mn.Component):
    """der(x) = -z with z + z³ = x: z has no explicit solution, so the model stays a DAE."""

    x = mn.State(start=1.0)
    z = mn.Var()

    def equations(self):
        return [mn.Eq(mn.der(self.x), -self.z, "decay"),
                mn.Eq(self.z + self.z ** 3, self.x, "cubic constraint")]


# ---- scenes ---------------------------------------------------------------------------------

def oscillator(J=2.0, c=8.0, phi0=1.0, sensor=None, sensor_name="sensor") -> mn.Model:
    """fixed — spring — j1, optionally a sensor on j1.flange_b (absolute) or in series (relative)."""
    m = mn.Model("osc")
    j1 = m.add(rot.Inertia("j1", J=J, phi_start=phi0, w_start=0.0))
    spring = m.add(rot.Spring("spring", c=c))
    fixed = m.add(rot.Fixed("fixed"))
    m.connect(fixed.flange, spring.flange_a)
    if sensor is None:
        m.connect(spring.flange_b, j1.flange_a)
    elif issubclass(sensor, rot.PartialOneFlange):
        m.connect(spring.flange_b, j1.flange_a)
        probe = m.add(sensor(sensor_name))
        m.connect(j1.flange_b, probe.flange)
    else:                                   # a two-flange sensor goes in series
        probe = m.add(sensor(sensor_name))
        m.connect(spring.flange_b, probe.flange_a)
        m.connect(probe.flange_b, j1.flange_a)
    return m


def rigid_pair(J1=2.0, J2=3.0, tau=5.0) -> mn.Model:
    """Constant torque on j1, and j1.flange_b connected directly to j2.flange_a (one rigid body)."""
    m = mn.Model("pair")
    source = m.add(rot.ConstantTorque("source", tau_constant=tau))
    j1 = m.add(rot.Inertia("j1", J=J1, phi_start=0.0, w_start=0.0))
    j2 = m.add(rot.Inertia("j2", J=J2))
    m.connect(source.flange, j1.flange_a)
    m.connect(j1.flange_b, j2.flange_a)
    return m


def single(component: mn.Component) -> mn.Model:
    m = mn.Model("single")
    m.add(component)
    return m


# ---- numerics -------------------------------------------------------------------------------

def evaluate(exprs, symbols, values) -> np.ndarray:
    """Evaluate SX expressions numerically with symbols[i] = values[i] (a tiny independent path)."""
    exprs = ca.vertcat(*[ca.SX(e) for e in exprs])
    f = ca.Function("f", [ca.vertcat(*symbols)] if symbols else [ca.SX(0, 1)], [exprs])
    return np.asarray(f(np.asarray(values, dtype=float))).ravel()
