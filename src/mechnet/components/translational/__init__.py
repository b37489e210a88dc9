"""1D translational mechanics (Modelica.Mechanics.Translational conventions)."""
from .elements import Damper, Fixed, Mass, Spring, SpringDamper
from .interfaces import Flange, PartialCompliant, PartialOneFlange, PartialTwoFlanges
from .sensors import ForceSensor, PositionSensor, PowerSensor, SpeedSensor
from .sources import Accelerate, ConstantForce, Force, Position, Speed

__all__ = ["Flange", "PartialTwoFlanges", "PartialCompliant", "PartialOneFlange", "Mass", "Spring", "Damper",
           "SpringDamper", "Fixed", "Force", "ConstantForce", "Position", "Speed", "Accelerate",
           "PositionSensor", "SpeedSensor", "ForceSensor", "PowerSensor"]
