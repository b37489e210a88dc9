"""1D rotational mechanics (Modelica.Mechanics.Rotational conventions)."""
from .elements import Damper, Fixed, Inertia, Spring, SpringDamper
from .interfaces import Flange, PartialCompliant, PartialOneFlange, PartialTwoFlanges
from .sensors import AngleSensor, PowerSensor, SpeedSensor, TorqueSensor
from .sources import ConstantTorque, Torque

__all__ = ["Flange", "PartialTwoFlanges", "PartialCompliant", "PartialOneFlange", "Inertia", "Spring",
           "Damper", "SpringDamper", "Fixed", "Torque", "ConstantTorque", "AngleSensor", "SpeedSensor",
           "TorqueSensor", "PowerSensor"]
