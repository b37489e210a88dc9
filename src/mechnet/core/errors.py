"""Errors a user can cause. Every one derives from MechnetError and names the culprit."""
from __future__ import annotations


class MechnetError(Exception):
    """Base of every error a user of mechnet can cause."""


class ParameterError(MechnetError, ValueError):
    """A component parameter is non-physical (J <= 0, c < 0, NaN, ...)."""


class ConnectError(MechnetError):
    """Connectors that cannot be connected (incompatible types, self-connection, foreign)."""


class NameConflictError(MechnetError):
    """Two components (or subsystems) with the same name in one model."""


class FrozenModelError(MechnetError):
    """A model was edited after compile() froze it."""


class StructureError(MechnetError):
    """The equations do not determine the variables (counts, matching)."""


class UnbalancedModelError(StructureError):
    """Over- or under-determined: lists the equations and variables involved."""


class HigherIndexError(StructureError):
    """The model needs index reduction (differentiated constraints)."""


class UnknownNameError(MechnetError, KeyError):
    """A dotted name that the model does not contain."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class InputError(MechnetError, ValueError):
    """An input value that cannot be used: wrong shape, not finite, not increasing in time."""


class InitializationError(MechnetError):
    """No consistent initial point: conflicting or missing start values."""


class IntegrationError(MechnetError):
    """The integrator failed; `result` holds what was computed up to the failure. `reason`: "failed"
    (the solver, an event accumulation, ...) or "interrupted" (Ctrl-C: `mechnet.interrupts`)."""

    def __init__(self, message: str, *, t: float, step: float, worst: str, solver_message: str, result=None,
                 reason: str = "failed"):
        super().__init__(message)
        self.t = t
        self.step = step
        self.worst = worst
        self.solver_message = solver_message
        self.result = result
        self.reason = reason

    def __reduce__(self):
        """Pickled (a failed run coming back from a worker process) with its details, without the
        result it belongs to (that result carries it as `failure`)."""
        return (_integration_error, (str(self), self.t, self.step, self.worst, self.solver_message, self.reason))


def _integration_error(message, t, step, worst, solver_message, reason="failed"):
    return IntegrationError(message, t=t, step=step, worst=worst, solver_message=solver_message, reason=reason)


class SceneError(MechnetError):
    """A scene file that cannot be loaded (missing build(), build() not returning a Model)."""


class OcpError(MechnetError):
    """An optimal control problem that cannot be posed as given (mechnet.ocp)."""
