"""Simulation: consistent initialisation, SUNDIALS integrators, results."""
from .integrator import IntegrationWarning, simulate
from .result import Result

__all__ = ["IntegrationWarning", "Result", "simulate"]
