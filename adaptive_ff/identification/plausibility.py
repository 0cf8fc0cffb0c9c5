"""Typed warnings of an identification: which parameter failed, and why (plausibility, identifiability).

Every identification method of :mod:`adaptive_ff.identification` checks its
physical result against the sign constraints of the model, Ruderman eqs. 1-3:

* ``J > 0`` (inertia of eq. 1),
* ``tau >= 0`` (time constant of the friction lag, eq. 2),
* ``sigma >= 0``, ``Fc >= 0``, ``Fs >= 0`` (viscous, Coulomb and stiction
  levels of eq. 3: friction dissipates energy),

and every value must be finite. A failed check becomes an
:class:`IdentificationWarning` with a machine-readable ``code`` and the
``parameter`` it concerns; it is a ``str`` (its message), so text output and
older consumers keep working, and :meth:`IdentificationWarning.to_dict` gives
the JSON form ``{"code", "parameter", "message"}``.

Codes (:data:`WARNING_CODES`):

``"implausible"``
    A value violates a sign constraint above or is not finite.
``"identifiability"``
    The record does not excite the parameter (persistence of excitation,
    Ljung, *System Identification*, 2nd ed., Sec. 13.2), or the structure is
    not supported by the data (e.g. the redundant inertia of the lag structure).
``"conditioning"``
    The regressor matrix is ill-conditioned: the estimates are sensitive to noise.
``"model_form"``
    The answer's friction curve does not reproduce the log's own steady state (the mean torque of its
    constant-velocity stretches), while a static line through those points does
    (:mod:`adaptive_ff.identification.steady_state_check`): the model form or the log's signals do not fit
    the fit's assumptions (e.g. a torque log with the inertia already removed). Not refusing: the report
    names the static line, and the user decides.
``"method"``
    A note on the method (e.g. the eq. 4 regression on a closed-loop log with
    slow torque readouts is biased); informative, not a verdict on a value.

:data:`REFUSING_CODES` are the codes on which ``adaptive-ff design --from``
refuses to design a controller unless told ``--accept-warnings``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from plant.errors import ParameterError

__all__ = ["IdentificationWarning", "WARNING_CODES", "REFUSING_CODES", "check_physical", "warning_from_dict",
           "PHYSICAL_BOUNDS"]

#: Allowed warning codes (module docstring).
WARNING_CODES = ("implausible", "identifiability", "conditioning", "model_form", "method")

#: Codes that make ``adaptive-ff design --from`` refuse the identification (exit status 3).
REFUSING_CODES = ("implausible", "identifiability", "conditioning")

#: ``{parameter: (strict, reason)}``: ``strict`` True means ``> 0``, False ``>= 0`` (Ruderman eqs. 1-3).
PHYSICAL_BOUNDS = {
    "J": (True, "the inertia of eq. 1 must be > 0"),
    "tau": (False, "the friction-lag time constant of eq. 2 must be >= 0"),
    "sigma": (False, "viscous friction dissipates (eq. 3): sigma must be >= 0"),
    "Fc": (False, "the Coulomb level of eq. 3 must be >= 0"),
    "Fs": (False, "the stiction level of eq. 3 must be >= 0"),
}


class IdentificationWarning(str):
    """A warning of an identification: a ``str`` (its message) with a ``code`` and a ``parameter``.

    Parameters
    ----------
    code : str
        One of :data:`WARNING_CODES`.
    parameter : str
        The parameter concerned (``"J"``, ``"tau"``, ``"sigma"``, ``"Fc"``,
        ``"Fs"``, ``"offset"``), or ``"all"`` when the record excites none.
    message : str
        What failed and why (names the value and the constraint).

    Raises
    ------
    ParameterError
        Unknown ``code`` or an empty ``parameter``/``message``.

    Notes
    -----
    The constraints are those of Ruderman, eqs. 1-3 (module docstring).
    """

    code: str
    parameter: str

    def __new__(cls, code: str, parameter: str, message: str):
        if code not in WARNING_CODES:
            raise ParameterError(f"warning code must be one of {WARNING_CODES}, got {code!r}")
        if not isinstance(parameter, str) or not parameter:
            raise ParameterError(f"warning parameter must be a non-empty str, got {parameter!r}")
        if not isinstance(message, str) or not message:
            raise ParameterError(f"warning message must be a non-empty str, got {message!r}")
        obj = super().__new__(cls, message)
        obj.code = code
        obj.parameter = parameter
        return obj

    @property
    def message(self) -> str:
        """The message (the plain ``str`` value)."""
        return str.__str__(self)

    @property
    def refusing(self) -> bool:
        """True if ``design --from`` refuses an identification carrying this warning."""
        return self.code in REFUSING_CODES

    def to_dict(self) -> dict:
        """Strict-JSON ``{"code", "parameter", "message"}``."""
        return {"code": self.code, "parameter": self.parameter, "message": self.message}

    def __reduce__(self):
        return (IdentificationWarning, (self.code, self.parameter, self.message))

    def __repr__(self) -> str:
        return f"IdentificationWarning({self.code!r}, {self.parameter!r}, {self.message!r})"


def warning_from_dict(d) -> IdentificationWarning:
    """Rebuild a warning from its JSON form (a dict, or a plain message string of an older file).

    Parameters
    ----------
    d : dict or str
        ``{"code", "parameter", "message"}``; a bare string is taken as an
        ``"identifiability"`` warning about ``"all"`` (the conservative reading).

    Returns
    -------
    IdentificationWarning

    Raises
    ------
    ParameterError
        Not a dict/str, a missing key or an unknown code.
    """
    if isinstance(d, str):
        return IdentificationWarning("identifiability", "all", d or "(empty warning)")
    if not isinstance(d, Mapping) or not all(k in d for k in ("code", "parameter", "message")):
        raise ParameterError(f"a warning must be a {{'code', 'parameter', 'message'}} object, got {d!r}")
    return IdentificationWarning(d["code"], d["parameter"], d["message"])


def check_physical(params: Mapping, *, source: str) -> list:
    """Check identified physical parameters against the sign constraints of eqs. 1-3.

    Parameters
    ----------
    params : mapping
        ``{name: value}`` (SI units); the names of :data:`PHYSICAL_BOUNDS` that are
        present are checked, any other present name (e.g. ``"offset"``) only for finiteness.
    source : str
        The method that produced them, put at the front of each message (e.g.
        ``"output_error"``, ``"LS (eq. 4)"``).

    Returns
    -------
    list of IdentificationWarning
        One ``"implausible"`` warning per failing parameter (empty if all pass).

    Notes
    -----
    Ruderman, eqs. 1-3: ``J > 0``; ``tau, sigma, Fc, Fs >= 0``.
    """
    out = []
    for name, value in params.items():
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = math.nan
        if not math.isfinite(v):
            out.append(IdentificationWarning("implausible", name, f"{source}: {name} = {value!r} is not finite"))
            continue
        if name not in PHYSICAL_BOUNDS:
            continue
        strict, reason = PHYSICAL_BOUNDS[name]
        if (v <= 0.0) if strict else (v < 0.0):
            op = "<=" if strict else "<"
            out.append(IdentificationWarning("implausible", name, f"{source}: {name} = {v:.6g} {op} 0; {reason}"))
    return out
