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
