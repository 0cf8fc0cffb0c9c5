"""Plausibility gates for a sampled signal: non-finite samples, physically impossible jumps, out-of-range values.

:class:`OutlierGate` judges the change from the last accepted sample (a velocity cannot jump);
:class:`RangeGate` judges the magnitude against the signal's own running envelope (a torque or a velocity
sample far above anything seen recently is a fault, not a measurement). Both are C structs
(``adaptive_ff/csrc/aff_gate.h``: ``aff_gate``, ``aff_range_gate``), configured from their settings
(``aff_gate_config``, ``aff_range_gate_config``: :attr:`plant.component.Component.config`) by ``aff_gate_init`` and
``aff_range_gate_init`` and advanced by ``aff_gate_check``, ``aff_range_gate_ok`` and ``aff_range_gate_commit``, the
one implementation, which the C components that embed a gate (estimator, closed-loop engine, peers) call as well.
"""

from __future__ import annotations

import math

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.defaults import c_defaults
from plant.component import Component, struct_field, struct_fields
from plant.errors import ParameterError

__all__ = ["OutlierGate", "RangeGate", "range_gates", "range_gate_in", "RANGE_DEFAULTS"]

#: The C defaults (``aff_gate_default_config``, ``aff_range_gate_default_config``): the keywords' defaults.
_GATE = c_defaults("aff_gate_config")
_RANGE = c_defaults("aff_range_gate_config")
#: The settings of a default range gate, ``RangeGate()``'s: the C ``aff_range_gate_default_config()`` (a cffi struct;
#: a composite's settings take a copy of it for a range gate not given).
RANGE_DEFAULTS = lib.aff_range_gate_default_config()


@struct_fields(
    "max_step", "n_sigma", "alpha", "max_consecutive", "scale", "n_held", "n_rejected", "n_nonfinite", "n_outliers",
    settable=("scale",)
)
class OutlierGate(Component):
    """Reject non-finite samples and outlier spikes of a sampled signal (e.g. the measured velocity).

    Parameters
    ----------
    max_step : float, keyword-only
        Largest physically possible change between two consecutive samples, in
        the signal's unit (for a velocity: peak acceleration times the sample
        period, rad/s), >= 0. Default ``inf``: only non-finite samples are rejected.
    n_sigma : float, keyword-only
        Width of the noise allowance in units of the running mean absolute
        sample-to-sample change, > 0; default 8.
    alpha : float, keyword-only
        Smoothing factor of that running mean, in (0, 1]; default 0.01.
    max_consecutive : int, keyword-only
        After this many consecutive outlier rejections the next finite sample
        is accepted again (the signal really moved, e.g. after a re-start);
        default 20.

    Attributes
    ----------
    last : float or None
        Last accepted value.
    scale : float
        Running mean of ``|x(k) - x(k-1)|`` over accepted samples.
    n_rejected, n_nonfinite, n_outliers : int
        Rejections in total, of them non-finite and outlier spikes.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    A finite sample ``x`` is an outlier if
    ``|x - last| > (max_step + n_sigma*scale) * (1 + n_held)`` with ``n_held``
    the number of samples rejected since ``last`` (the bound grows with the
    time since the last accepted sample). This is a validation gate on the
    innovation (the "gating" of target tracking: Bar-Shalom, Li,
    Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
    Wiley 2001) with the innovation predicted by the last accepted sample, a
    physical bound on its size and a running noise scale (updated only by
    accepted samples, so a burst of spikes cannot widen the gate).
    """

    _ffi = ffi
    _ctype = "aff_gate"
    _repr_fields = ("max_step", "n_sigma", "n_rejected")

    def __init__(self, *, max_step: float = _GATE["max_step"], n_sigma: float = _GATE["n_sigma"],
                 alpha: float = _GATE["alpha"], max_consecutive: int = _GATE["max_consecutive"]):
        cfg, _ = self._plan(max_step=max_step, n_sigma=n_sigma, alpha=alpha, max_consecutive=max_consecutive)
        self._configure(lib.aff_gate_init, cfg, lib.aff_error_message)

    _lib = lib

    def _plan(self, *, max_step=_GATE["max_step"], n_sigma=_GATE["n_sigma"], alpha=_GATE["alpha"],
              max_consecutive=_GATE["max_consecutive"]):
        """The constructor's settings (``(cfg, None)``), their types checked (their ranges are C's to check)."""
        return self._settings_from(lib, {"max_step": max_step, "n_sigma": n_sigma, "alpha": alpha,
                                         "max_consecutive": max_consecutive}, counts=("max_consecutive",)), None

    last = struct_field("last", float, "Last accepted value, or None before the first.", settable=True,
                        flag="has_last")

    def check(self, x: float) -> bool:
        """Return True and accept ``x`` if it is plausible; False (counted) if it is rejected.

        Parameters
        ----------
        x : float
            The new sample.

        Returns
        -------
        bool
            Acceptance. A rejected sample changes only the counters. C: ``aff_gate_check``.
        """
        return bool(lib.aff_gate_check(self._c, float(x)))


@struct_fields("x_max", "factor", "floor", "max_consecutive", "n_held", "n_rejected")
class RangeGate(Component):
    """Reject non-finite and out-of-range samples of a signal (a torque, a velocity): magnitude against a bound.

    Parameters
    ----------
    x_max : float, keyword-only
        Absolute bound on ``|x|`` in the signal's unit (e.g. the drive's torque
        limit in N·m, the largest possible speed in rad/s), > 0; default inf.
    factor : float, keyword-only
        Relative bound: ``|x|`` above ``factor`` times the reference scale is
        out of range, > 1; default 100 (two orders of magnitude).
    floor : float, keyword-only
        Smallest reference scale, in the signal's unit, >= 0 (e.g. the Stribeck
        velocity for a velocity: the scale at which friction acts); default 0.
    memory : float, keyword-only
        Decay time of the envelope in samples, > 0; default 10000 (10 s at 1 kHz).
    max_consecutive : int, keyword-only
        After this many consecutive rejections the next finite sample within
        ``x_max`` is accepted again (the signal really moved to a new level);
        default 20.

    Attributes
    ----------
    envelope : float
        Peak envelope of the accepted ``|x|`` (signal unit).
    n_rejected : int
        Samples rejected (non-finite or out of range).

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    With ``env`` the envelope of the accepted samples (``env = max(|x|,
    exp(-1/memory)*env)``: a peak detector with exponential release) and the
    reference ``ref = max(env, floor)``, a sample is rejected if it is not
    finite, if ``|x| > x_max`` or if ``ref > 0`` and ``|x| > factor*ref``.
    The envelope rises with every accepted sample at once, so a physical signal
    that grows from rest (a torque ramped by an integrator, a velocity that
    follows its acceleration) never trips the relative bound; a spike far above
    everything seen within ``memory`` does. A rejected sample changes only the
    counters. This is range (limit) checking of a sensor value, the first
    plausibility test of fault detection (Isermann, *Fault-Diagnosis Systems*,
    Springer 2006, Sec. 7.1), with an adaptive limit.
    """

    _ffi = ffi
    _ctype = "aff_range_gate"
    _repr_fields = ("x_max", "factor", "floor", "n_rejected")

    def __init__(self, *, x_max: float = _RANGE["x_max"], factor: float = _RANGE["factor"],
                 floor: float = _RANGE["floor"], memory: float = _RANGE["memory"],
                 max_consecutive: int = _RANGE["max_consecutive"]):
        self._configure_from(lib, {"x_max": x_max, "factor": factor, "floor": floor, "memory": memory,
                                   "max_consecutive": max_consecutive}, counts=("max_consecutive",))

    @property
    def memory(self) -> float:
        """Decay time of the envelope (samples), as configured."""
        cfg = self.config
        return float(cfg.memory) if cfg is not None else -1.0 / math.log(float(self._c.decay))

    envelope = struct_field("env", float, "Envelope of the accepted |x| (signal unit).")

    def with_floor(self, floor: float) -> "RangeGate":
        """A copy with another ``floor`` (signal unit) and this gate's state; components set it from what they
        know."""
        g = RangeGate(x_max=self.x_max, factor=self.factor, floor=floor, memory=self.memory,
                      max_consecutive=self.max_consecutive)
        g._c.env, g._c.n_held, g._c.n_rejected = self._c.env, self._c.n_held, self._c.n_rejected
        return g

    def check(self, x: float) -> bool:
        """Return True and accept ``x`` if it is in range; False (counted) if it is rejected.

        Parameters
        ----------
        x : float
            The new sample (signal unit).

        Returns
        -------
        bool
            Acceptance. A rejected sample changes only the counters. C: ``aff_range_gate_ok`` then
            ``aff_range_gate_commit``.
        """
        x = float(x)
        ok = lib.aff_range_gate_ok(self._c, x)
        lib.aff_range_gate_commit(self._c, x, ok)
        return bool(ok)


def range_gates(u_range: RangeGate | None, w_range: RangeGate | None, *, w_floor: float = 0.0) -> tuple:
    """The torque and velocity range gates of a component that embeds them: each the one given, or a new
    ``RangeGate()`` (the velocity's with ``floor=w_floor``), its type checked.

    Parameters
    ----------
    u_range, w_range : RangeGate or None
        The gates given (torque, N·m; velocity, rad/s).
    w_floor : float, keyword-only
        The floor (rad/s) of a new velocity gate, default 0.

    Returns
    -------
    tuple of RangeGate
        ``(u_range, w_range)``.

    Raises
    ------
    ParameterError
        A gate given that is not a RangeGate (naming the argument), or an invalid ``w_floor``.
    """
    u_range = RangeGate() if u_range is None else u_range
    w_range = RangeGate(floor=w_floor) if w_range is None else w_range
    for name, g in (("u_range", u_range), ("w_range", w_range)):
        if not isinstance(g, RangeGate):
            raise ParameterError(f"{name} must be a RangeGate, got {type(g).__name__}")
    return u_range, w_range


def range_gate_in(owner, field: str, floor: float = 0.0) -> RangeGate:
    """A default range gate (:data:`RANGE_DEFAULTS`, ``floor`` set) over the field ``field`` of ``owner``'s struct,
    which ``owner``'s C init configured from those settings: ``RangeGate(floor=floor)`` made in place, no struct of
    its own built, checked and copied in (:meth:`plant.component.Component._in_place`).

    Parameters
    ----------
    owner : plant.component.Component
        The composite (configured), which embeds an ``aff_range_gate`` at ``field``.
    field : str
        The C field (a dotted path for a nested one).
    floor : float
        The floor its init was given (signal unit; the composite's init checked it).

    Returns
    -------
    RangeGate
        Points into ``owner``'s struct; its :attr:`config` the settings with ``floor``.
    """
    cfg = ffi.new("aff_range_gate_config *", RANGE_DEFAULTS)
    cfg.floor = floor
    return RangeGate._in_place(owner, field, cfg)
