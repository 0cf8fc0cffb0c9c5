"""The typed errors of the package: defined in :mod:`plant.errors` (the bottom layer), re-exported here.

This module exists so that :mod:`adaptive_ff` can hand the errors on lazily, like its other names,
from a module of its own (``lazy_loader`` attaches submodules of the package only).
"""

from plant.errors import ExcitationError, FrictionError, ParameterError, SignalError

__all__ = ["FrictionError", "ParameterError", "SignalError", "ExcitationError"]
