"""1D rotational mechanics (Modelica.Mechanics.Rotational conventions)."""
from .elements import Damper, Fixed, IdealGear, Inertia, Spring, SpringDamper
from .interfaces import Flange, PartialCompliant, PartialOneFlange, PartialTwoFlanges
from .sensors import AngleSensor, PowerSensor, SpeedSensor, TorqueSensor
from .sources import Accelerate, ConstantTorque, Position, Speed, Torque

__all__ = ["Flange", "PartialTwoFlanges", "PartialCompliant", "PartialOneFlange", "Inertia", "Spring",
           "Damper", "SpringDamper", "Fixed", "IdealGear", "Torque", "ConstantTorque", "Position", "Speed",
           "Accelerate", "AngleSensor", "SpeedSensor", "TorqueSensor", "PowerSensor"]
