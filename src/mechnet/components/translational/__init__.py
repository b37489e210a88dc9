"""1D translational mechanics (Modelica.Mechanics.Translational conventions)."""
from .elements import Damper, Fixed, Mass, Spring, SpringDamper
from .friction import Friction, SupportFriction
from .interfaces import Flange, PartialCompliant, PartialOneFlange, PartialTwoFlanges
from .sensors import ForceSensor, PositionSensor, PowerSensor, SpeedSensor
from .sources import Accelerate, ConstantForce, Force, Position, Speed
from .stops import Contact, ElastoGap, HardStop

__all__ = ["Friction", "SupportFriction", "Contact", "ElastoGap", "HardStop", "Flange", "PartialTwoFlanges", "PartialCompliant", "PartialOneFlange", "Mass", "Spring", "Damper",
           "SpringDamper", "Fixed", "Force", "ConstantForce", "Position", "Speed", "Accelerate",
           "PositionSensor", "SpeedSensor", "ForceSensor", "PowerSensor"]
