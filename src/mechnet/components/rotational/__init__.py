"""1D rotational mechanics (Modelica.Mechanics.Rotational conventions)."""
from .elements import Damper, Fixed, IdealGear, Inertia, Spring, SpringDamper
from .friction import BearingFriction, Brake, Clutch, OneWayClutch
from .interfaces import Flange, PartialCompliant, PartialOneFlange, PartialTwoFlanges
from .sensors import AngleSensor, PowerSensor, SpeedSensor, TorqueSensor
from .sources import Accelerate, ConstantTorque, Position, Speed, Torque
from .stops import HardStop

__all__ = ["BearingFriction", "Brake", "Clutch", "OneWayClutch", "HardStop", "Flange", "PartialTwoFlanges", "PartialCompliant", "PartialOneFlange", "Inertia", "Spring",
           "Damper", "SpringDamper", "Fixed", "IdealGear", "Torque", "ConstantTorque", "Position", "Speed",
           "Accelerate", "AngleSensor", "SpeedSensor", "TorqueSensor", "PowerSensor"]
