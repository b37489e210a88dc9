"""mechnet: acausal mechanical modelling on CasADi."""
from .compile import CompiledModel, CompileOptions
from .core import (Across, Component, Connector, Eq, Impulse, Input, Mode, Model, Output, Param, Port, State, Through, Var,
                   When, der, every_parameter_tunable, nonnegative, positive, time, tunable)
from .core.errors import (ConnectError, FrozenModelError, HigherIndexError, InitializationError,
                          IntegrationError, InputError, MechnetError, NameConflictError, OcpError, ParameterError,
                          SceneError, StructureError, UnbalancedModelError, UnknownNameError)
from .components.switched import smooth_friction
from .interrupts import Interrupted
from .kinematics import kinematics
from .simulate import IntegrationWarning, Result
from .sweep import Sweep, sweep
from . import ocp  # noqa: E402 - mechnet.ocp, after the core it builds on

__version__ = "0.1.0"

__all__ = ["Across", "CompileOptions", "CompiledModel", "Component", "ConnectError", "Connector", "Eq",
           "FrozenModelError", "HigherIndexError", "Impulse", "InitializationError", "Input", "InputError",
           "Interrupted", "IntegrationError", "IntegrationWarning", "MechnetError", "Mode", "Model",
           "NameConflictError", "OcpError",
           "Output",
           "Param", "ParameterError", "Port", "Result", "SceneError", "State", "StructureError", "Through",
           "UnbalancedModelError", "UnknownNameError", "Var", "When", "compile", "der", "every_parameter_tunable",
           "kinematics", "nonnegative",
           "ocp",
           "positive", "smooth_friction", "Sweep", "sweep", "time", "tunable"]


def compile(model: Model, options: CompileOptions | None = None) -> CompiledModel:  # noqa: A001
    """Compile a model (same as `model.compile(options)`)."""
    return model.compile(options)
