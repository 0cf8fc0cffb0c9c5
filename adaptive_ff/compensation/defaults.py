"""The defaults of the components' C settings, read from the C library: the one statement of each default.

Every component of the drive's code has a config struct ``aff_X_config`` whose defaults are set by one C function,
``aff_X_default_config()`` (``adaptive_ff/csrc``). A Python class that offers a field of it as a keyword (the
gates, the feedforwards, the estimator, the supervisor, the residual switch-in, the loop's options) takes the
keyword's default from :func:`c_defaults`, read once at import, never from a literal of its own; the range of each
field is checked by the C ``aff_X_init`` (``plant.component.Component._configure`` raises a ParameterError with its
sentence naming the field).
"""

from __future__ import annotations

from pathlib import Path

from adaptive_ff._caff import ffi, lib
from plant.component import config_class, config_defaults

__all__ = ["c_defaults", "c_config_class"]


def c_defaults(ctype: str) -> dict:
    """The C defaults of the settings ``ctype`` (``aff_X_default_config()``).

    Parameters
    ----------
    ctype : str
        The config struct's C name, e.g. ``"aff_residual_config"``, ``"aff_gate_config"``.

    Returns
    -------
    dict
        Field -> default (a float, an int: a flag is 0 or 1, an enum its code; a nested struct a dict, an array a
        list), a new dict at each call.

    Raises
    ------
    ParameterError
        ``ctype`` is no config struct of the library.

    Examples
    --------
    >>> c_defaults("aff_switch_in_config")["share"]
    0.1
    """
    return config_defaults(ffi, lib, ctype)


_CSRC = Path(__file__).resolve().parent.parent / "csrc"


def c_config_class(name: str, ctype: str, header: str, *, module: str, summary: str, exclude=(),
                   fields: dict | None = None) -> type:
    """The config class of a component of this package (:func:`plant.component.config_class` on
    ``adaptive_ff._caff``): a frozen dataclass of the C settings ``ctype`` whose fields, defaults, units and ranges
    are the C struct's, declared in ``adaptive_ff/csrc/<header>``.

    Parameters
    ----------
    name, ctype : str
        The class's name and the config struct's C name.
    header : str
        The header's file name in ``adaptive_ff/csrc``.
    module, summary, exclude, fields
        As :func:`plant.component.config_class`.

    Returns
    -------
    type
    """
    return config_class(name, (ffi, lib), ctype, module=module, summary=summary, header=_CSRC / header,
                        exclude=exclude, fields=fields)
