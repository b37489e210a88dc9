"""Objects the cases share, built once in the runner's parent process before it forks (cached functions):
a child finds them already built, in its copy of the parent's memory. Files go under one temporary root;
a case that changes a file copies it into its own working folder first."""
from __future__ import annotations

import functools
import os
import tempfile

import mechnet as mn
from mechnet.components import rotational as rot
from mechnet.components import translational as tr
from models import oscillator, revolute_pendulum

_ROOT: list[str] = []


def root() -> str:
    """The shared temporary folder (the runner removes it)."""
    if not _ROOT:
        _ROOT.append(tempfile.mkdtemp(prefix="mechnet-fuzz-"))
    return _ROOT[0]


@functools.cache
def osc():
    """j1 on a spring (c = 100, J = 0.1) from phi = 0.5: phi(t) = 0.5 cos(sqrt(1000) t)."""
    return oscillator().compile()


def driven_model(c=None) -> mn.Model:
    """j1 (J = 0.1) on a spring, driven by the input drive.tau; `c` tunable when given."""
    m = mn.Model("driven")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=mn.tunable(c) if c else 100.0))
    j1 = m.add(rot.Inertia(name="j1", J=0.1, phi_start=0.0, w_start=0.0))
    drive = m.add(rot.Torque(name="drive"))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j1.flange_a)
    m.connect(drive.flange, j1.flange_b)
    return m


@functools.cache
def driven():
    return driven_model(c=100.0).compile()


def mass_model(friction=False) -> mn.Model:
    """The README's double integrator: mass (m = 1) pushed by the control push.f."""
    m = mn.Model("double_integrator")
    mass = m.add(tr.Mass(name="mass", m=1.0, s_start=0.0, v_start=0.0))
    push = m.add(tr.Force(name="push"))
    m.connect(push.flange, mass.flange_a)
    return m


@functools.cache
def mass():
    return mass_model().compile()


@functools.cache
def pendulum():
    """The README's multibody pendulum (one revolute about z, a particle 1 m out)."""
    return revolute_pendulum().compile()


@functools.cache
def casadi_export() -> str:
    """The driven model exported as CasADi files (a folder with model.json)."""
    return str(driven().export(os.path.join(root(), "driven_casadi"), kind="casadi"))


@functools.cache
def fmu() -> str:
    """The driven model (spring.c tunable, input drive.tau) as an FMI 2.0 FMU."""
    return str(driven().export(os.path.join(root(), "driven.fmu"), kind="fmu"))


SCENE = '''
import mechnet as mn
from mechnet.components import rotational as rot

t_end = 1.0
plot = ["j1.phi"]


def build():
    m = mn.Model("osc")
    fixed = m.add(rot.Fixed(name="fixed"))
    spring = m.add(rot.Spring(name="spring", c=100.0))
    j1 = m.add(rot.Inertia(name="j1", J=0.1, phi_start=0.5, w_start=0.0))
    m.connect(fixed.flange, spring.flange_a)
    m.connect(spring.flange_b, j1.flange_a)
    return m
'''


def scene(text: str = SCENE, name: str = "scene.py", extra: str = "") -> str:
    """A scene file in the working folder (the case's own); `extra` is appended to the good scene."""
    with open(name, "w") as f:
        f.write(text + extra)
    return name


FIXTURES = {"osc": osc, "driven": driven, "mass": mass, "pendulum": pendulum, "casadi_export": casadi_export,
            "fmu": fmu}
