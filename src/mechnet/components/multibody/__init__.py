"""3D rigid-body mechanics (Modelica.Mechanics.MultiBody names and conventions)."""
from .interfaces import Frame, PartialBody, PartialJoint, PartialTreeEdge, PartialTwoFrames
from .joints import Prismatic, Revolute, Weld
from .parts import Body, FixedRotation, FixedTranslation, Particle, World

__all__ = ["Frame", "PartialBody", "PartialJoint", "PartialTreeEdge", "PartialTwoFrames", "World", "Body",
           "Particle", "FixedTranslation", "FixedRotation", "Revolute", "Prismatic", "Weld"]
