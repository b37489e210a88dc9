"""1D translational mechanics (Modelica.Mechanics.Translational conventions)."""
from .elements import Damper, Fixed, Mass, Spring, SpringDamper
from .interfaces import Flange, PartialCompliant, PartialOneFlange, PartialTwoFlanges
from .sensors import ForceSensor, PositionSensor, PowerSensor, SpeedSensor
from .sources import ConstantForce, Force, Position

__all__ = ["Flange", "PartialTwoFlanges", "PartialCompliant", "PartialOneFlange", "Mass", "Spring",
           "Damper", "SpringDamper", "Fixed", "Force", "ConstantForce", "Position", "PositionSensor", "SpeedSensor",
           "ForceSensor", "PowerSensor"]
