"""Modelling layer: declarations, connectors, components, equations, models, errors."""
from .component import Component, Connector
from .declarations import (Across, Impulse, Input, Mode, Output, Param, Port, State, Through, Var, every_parameter_tunable,
                           nonnegative, nonzero, positive, tunable)
from .equation import Eq, When, der, time
from .errors import *  # noqa: F401,F403
from .model import Model
