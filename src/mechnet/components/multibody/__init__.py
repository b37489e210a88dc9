"""3D rigid-body mechanics (Modelica.Mechanics.MultiBody names and conventions)."""
from .forces import Damper, Gravitation, PartialLineForce, Spring, SpringDamper, WorldForce, WorldTorque
from .interfaces import Frame, PartialBody, PartialJoint, PartialMultiJoint, PartialTreeEdge, PartialTwoFrames
from .joints import Cylindrical, FreeMotion, Planar, Prismatic, Revolute, Spherical, Universal, Weld
from .parts import Body, BodyBox, BodyCylinder, BodyShape, FixedRotation, FixedTranslation, Particle, World
from .sensors import (CutForceTorque, PartialSceneSensor, RelativePosition, RelativeVelocity, SystemEnergy,
                      SystemMomentum)

__all__ = ["Frame", "PartialBody", "PartialJoint", "PartialMultiJoint", "PartialTreeEdge", "PartialTwoFrames",
           "PartialLineForce", "PartialSceneSensor", "World", "Body", "BodyShape", "BodyBox", "BodyCylinder",
           "Particle", "FixedTranslation", "FixedRotation", "Revolute", "Prismatic", "Spherical", "FreeMotion", "Universal", "Cylindrical", "Planar",
           "Weld", "Spring", "Damper", "SpringDamper", "Gravitation", "WorldForce", "WorldTorque",
           "RelativePosition", "RelativeVelocity", "CutForceTorque", "SystemEnergy", "SystemMomentum"]
