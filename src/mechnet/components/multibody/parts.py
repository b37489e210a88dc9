"""World, bodies and rigid connections (Modelica.Mechanics.MultiBody.Parts)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from ...core.component import Component
from ...core.declarations import (Flag, Param, Port, direction, nonnegative, parameter_check, positive,
                                  unit_vector)
from ...core.errors import ParameterError
from ...inertia import inertia_problem
from .frames import axis_rotation
from .interfaces import Frame, PartialBody, PartialTreeEdge


@parameter_check
def physical_inertia(value):
    """must be a physical inertia tensor (symmetric, positive semi-definite, triangle inequality)

    (The first line describes the check in help(Body) and docs/components.md.)
    """
    return inertia_problem(value)


class World(Component):
    """The inertial frame (origin, axes = world) and the gravity field; exactly one per scene.

    Uniform gravity `g` (m/s², world components) by default; with
    `point_gravity=True` a central field g(r) = −mue·r/|r|³ about the origin instead.
    """

    g = Param([0.0, -9.81, 0.0], unit="m/s2", shape=3, doc="uniform gravity acceleration, world components")
    point_gravity = Flag(False, doc="central gravity field about the world origin instead of uniform g")
    mue = Param(3.986004418e14, unit="m3/s2", check=positive, doc="gravity constant of the central field")
    frame_b = Port(Frame, doc="the world frame")

    def gravity_at(self, r):
        """Gravity acceleration (world components) at the world position r."""
        if self.point_gravity:
            return -self.mue * r / ca.power(ca.sumsqr(r), 1.5)
        return self.g


class Body(PartialBody):
    """A rigid body: mass m, mass centre r_cm (in frame_a) and inertia I about the mass centre (frame_a axes)."""

    m = Param(unit="kg", check=positive, doc="mass")
    r_cm = Param([0.0, 0.0, 0.0], unit="m", shape=3, doc="mass centre, resolved in frame_a")
    I = Param(np.zeros((3, 3)), unit="kg*m2", shape=(3, 3), check=physical_inertia,
              doc="inertia tensor about the mass centre, frame_a axes")

    def mass_properties(self):
        return self.m, self.r_cm, self.I


class Particle(PartialBody):
    """A point mass at the origin of frame_a."""

    m = Param(unit="kg", check=positive, doc="mass")

    def mass_properties(self):
        return self.m, ca.DM.zeros(3), ca.DM.zeros(3, 3)


class FixedTranslation(PartialTreeEdge):
    """frame_b rigidly fixed at r (resolved in frame_a) from frame_a, same orientation."""

    r = Param(unit="m", shape=3, doc="origin of frame_b, resolved in frame_a")

    def relative_motion(self):
        return ca.SX(self.r), ca.SX.eye(3)


class FixedRotation(PartialTreeEdge):
    """frame_b fixed at r from frame_a and rotated by `angle` (rad) about the axis n (frame_a)."""

    r = Param([0.0, 0.0, 0.0], unit="m", shape=3, doc="origin of frame_b, resolved in frame_a")
    n = Param([0.0, 0.0, 1.0], shape=3, check=direction, doc="rotation axis, resolved in frame_a")
    angle = Param(0.0, unit="rad", doc="rotation angle from frame_a to frame_b")

    def relative_motion(self):
        n = ca.DM(unit_vector(self.n))
        return ca.SX(self.r), axis_rotation(n, self.angle)


class BodyShape(PartialTreeEdge, PartialBody):
    """A rigid body with two frames (Modelica's BodyShape): frame_b fixed at r from frame_a, mass m at
    r_cm with inertia I about the mass centre (frame_a axes) — a Body and a FixedTranslation in one."""

    r = Param(unit="m", shape=3, doc="origin of frame_b, resolved in frame_a")
    r_cm = Param([0.0, 0.0, 0.0], unit="m", shape=3, doc="mass centre, resolved in frame_a")
    m = Param(unit="kg", check=positive, doc="mass")
    I = Param(np.zeros((3, 3)), unit="kg*m2", shape=(3, 3), check=physical_inertia,
              doc="inertia tensor about the mass centre, frame_a axes")

    def relative_motion(self):
        return ca.SX(self.r), ca.SX.eye(3)

    def mass_properties(self):
        return self.m, self.r_cm, self.I


class _SolidShape(PartialTreeEdge, PartialBody, abstract=True):
    """A homogeneous solid from frame_a's r_shape along length_direction (Modelica's BodyBox and
    BodyCylinder): geometry and density give m, r_cm and I; frame_b is at r. Defaults like Modelica's:
    the shape runs from r_shape to r, its width a twentieth of its length, steel's density. A size left
    at 0 takes its default even where it was made tunable (its symbol would stand for 0)."""

    r = Param(unit="m", shape=3, doc="origin of frame_b, resolved in frame_a")
    r_shape = Param([0.0, 0.0, 0.0], unit="m", shape=3, doc="where the shape starts, resolved in frame_a")
    length_direction = Param([0.0, 0.0, 0.0], shape=3,
                             doc="the shape's length axis, resolved in frame_a; zero: along r − r_shape")
    length = Param(0.0, unit="m", check=nonnegative, doc="length along length_direction; 0: |r − r_shape|")
    density = Param(7700.0, unit="kg/m3", check=positive, doc="density of the material (steel by default)")

    def _axis(self):
        """The unit length axis (numbers: directions are never tunable)."""
        given = np.asarray(self.length_direction, dtype=float)
        along = given if np.any(given) else np.asarray(self.r, dtype=float) - np.asarray(self.r_shape, dtype=float)
        if not np.any(along):
            raise ParameterError(f"{self.name} ({type(self).__name__}): length_direction is zero and r equals "
                                 f"r_shape, so the shape has no axis; give length_direction or r")
        return unit_vector(along)

    def _size(self, key, default):
        """A size parameter, or `default` where it is 0 (also when tunable: its value decides)."""
        value = self.tunable[key][1] if key in self.tunable else self._values[key]
        if _is_number(value) and float(value) == 0.0:
            return default() if callable(default) else default
        return self._values[key]

    def _length(self):
        def span():
            gap = float(np.linalg.norm(np.asarray(self.r, dtype=float) - np.asarray(self.r_shape, dtype=float)))
            if gap == 0.0:
                raise ParameterError(f"{self.name} ({type(self).__name__}): length is 0 and r equals r_shape; "
                                     f"give the length (m)")
            return gap
        return self._size("length", span)

    def relative_motion(self):
        return ca.SX(self.r), ca.SX.eye(3)

    def check(self):
        self._axis()
        self._length()


def _is_number(value) -> bool:
    return not isinstance(value, (ca.SX, ca.MX))


def _positive_size(component, **sizes):
    for key, value in sizes.items():
        if not _is_number(value) and key in component.tunable:
            value = component.tunable[key][1]                 # a tunable size: its value must be > 0
        if _is_number(value) and not float(value) > 0:
            raise ParameterError(f"{component.name} ({type(component).__name__}): {key} = {value!r} must be > 0")


class BodyBox(_SolidShape):
    """A homogeneous box (hollow when inner_width, inner_height > 0) from r_shape along length_direction,
    its width along width_direction (made perpendicular), its height along their cross product."""

    width_direction = Param([0.0, 1.0, 0.0], shape=3, check=direction,
                            doc="the width axis, resolved in frame_a (its part along the length is removed)")
    width = Param(0.0, unit="m", check=nonnegative, doc="width; 0: a twentieth of the length")
    height = Param(0.0, unit="m", check=nonnegative, doc="height; 0: the width")
    inner_width = Param(0.0, unit="m", check=nonnegative, doc="width of the hollow inside (0: solid)")
    inner_height = Param(0.0, unit="m", check=nonnegative, doc="height of the hollow inside (0: solid)")

    def _axes(self):
        e_l = self._axis()
        w = unit_vector(self.width_direction)
        w = w - (w @ e_l) * e_l
        if np.linalg.norm(w) < 1e-9:
            raise ParameterError(f"{self.name} (BodyBox): width_direction {np.asarray(self.width_direction).tolist()} "
                                 f"is parallel to the length direction {e_l.tolist()}; give one across it")
        e_w = w / np.linalg.norm(w)
        return np.column_stack([e_l, e_w, np.cross(e_l, e_w)])

    def _sizes(self):
        L = self._length()
        w = self._size("width", lambda: L / 20)
        return L, w, self._size("height", w)

    def check(self):
        super().check()
        self._axes()
        L, w, h = self._sizes()
        _positive_size(self, length=L, width=w, height=h)
        wi, hi = self.inner_width, self.inner_height
        if all(map(_is_number, (w, h, wi, hi))) and (float(wi) >= float(w) or float(hi) >= float(h)) \
                and (float(wi) > 0 or float(hi) > 0):
            raise ParameterError(f"{self.name} (BodyBox): the hollow ({wi} x {hi} m) must fit inside the box "
                                 f"({w} x {h} m)")

    def mass_properties(self):
        L, w, h = self._sizes()
        wi, hi = self.inner_width, self.inner_height
        outer, inner = self.density * L * w * h, self.density * L * wi * hi
        m = outer - inner
        # box about its centre, axes (length, width, height): outer minus the hollow
        moments = [(outer * (w * w + h * h) - inner * (wi * wi + hi * hi)) / 12,
                   (outer * (L * L + h * h) - inner * (L * L + hi * hi)) / 12,
                   (outer * (L * L + w * w) - inner * (L * L + wi * wi)) / 12]
        E = self._axes()
        I = sum(moments[k] * ca.DM(np.outer(E[:, k], E[:, k])) for k in range(3))
        return m, _centre(self.r_shape, E[:, 0], L), I


class BodyCylinder(_SolidShape):
    """A homogeneous cylinder (a tube when inner_diameter > 0) from r_shape along length_direction."""

    diameter = Param(0.0, unit="m", check=nonnegative, doc="outer diameter; 0: a twentieth of the length")
    inner_diameter = Param(0.0, unit="m", check=nonnegative, doc="inner diameter (0: solid)")

    def _sizes(self):
        L = self._length()
        return L, self._size("diameter", lambda: L / 20), self.inner_diameter

    def check(self):
        super().check()
        L, d, di = self._sizes()
        _positive_size(self, length=L, diameter=d)
        if all(map(_is_number, (d, di))) and float(di) >= float(d) and float(di) > 0:
            raise ParameterError(f"{self.name} (BodyCylinder): inner_diameter = {di} m must be below the "
                                 f"diameter {d} m")

    def mass_properties(self):
        L, d, di = self._sizes()
        m = self.density * np.pi / 4 * (d * d - di * di) * L
        about = m * (d * d + di * di) / 8                           # hollow cylinder: m(r1² + r2²)/2
        across = m * (3 * (d * d + di * di) + 4 * L * L) / 48       # m(3(r1² + r2²) + L²)/12
        e = self._axis()
        I = across * ca.DM.eye(3) + (about - across) * ca.DM(np.outer(e, e))
        return m, _centre(self.r_shape, e, L), I


def _centre(r_shape, axis, length):
    """The mass centre of a homogeneous shape: half its length along its axis from r_shape (a column;
    numbers stay numbers)."""
    return ca.DM(r_shape) + ca.DM(axis) * (length / 2)
