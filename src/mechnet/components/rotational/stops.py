"""A rotational hard stop: rigid impacts with restitution and rest against a limit (switched.py)."""
from __future__ import annotations

from ...core.declarations import Impulse, Mode, Param, Var, nonnegative
from ..switched import SwitchedStop, restitution
from .interfaces import PartialCompliant


class HardStop(SwitchedStop, PartialCompliant):
    """flange_b turns relative to flange_a between phi_min and phi_max (phi_rel = phi_b − phi_a); at a
    limit it rebounds with restitution e, solved through the whole scene (a stop on a revolute joint
    inside a linkage: connect the joint's support to flange_a and its axis to flange_b), or rests there
    until pulled away."""

    phi_min = Param(unit="rad", doc="lower limit of phi_rel")
    phi_max = Param(unit="rad", doc="upper limit of phi_rel")
    e = Param(1.0, unit="1", doc="coefficient of restitution (0 plastic, 1 elastic)", check=restitution)
    v_rest = Param(0.0, unit="rad/s", doc="impact speed at or below which it rests (0: only when its "
                                          "impacts accumulate)", check=nonnegative)
    v_rel = Var(unit="rad/s", doc="relative angular velocity")
    a_rel = Var(unit="rad/s^2", doc="relative angular acceleration")
    sa = Var(unit="N*m", doc="path parameter: the contact torque while resting, a_rel while free")
    mode = Mode(0.0, values=(-1.0, 0.0, 1.0), doc="0 free, -1 resting on phi_min, +1 on phi_max")
    impulse = Impulse(doc="carrier of the impact impulse (0 between events)")

    def _flow(self):
        return self.tau

    def _position(self):
        return self.flange_b.phi - self.flange_a.phi

    def _limit_keys(self):
        return "phi_min", "phi_max"
