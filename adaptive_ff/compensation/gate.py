"""Plausibility gates for a sampled signal: non-finite samples, physically impossible jumps, out-of-range values.

:class:`OutlierGate` judges the change from the last accepted sample (a velocity cannot jump);
:class:`RangeGate` judges the magnitude against the signal's own running envelope (a torque or a velocity
sample far above anything seen recently is a fault, not a measurement).
"""

from __future__ import annotations

import math

from plant.component import Component
from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.jit import kernel

__all__ = ["OutlierGate", "gate_check", "GATE_NPAR", "GATE_NSTATE", "RangeGate", "range_ok", "range_commit",
           "RANGE_NPAR", "RANGE_NSTATE"]

# params: max_step, n_sigma, alpha, max_consecutive; state: last, has_last, scale, n_held, n_rejected,
# n_nonfinite, n_outliers
_MAX_STEP, _N_SIGMA, _ALPHA, _MAX_CONSEC = range(4)
_LAST, _HAS, _SCALE, _HELD, _REJ, _NONFIN, _OUTL = range(7)
#: Lengths of the gate's parameter and state arrays.
GATE_NPAR, GATE_NSTATE = 4, 7


@kernel(inline="always")
def gate_check(par, st, x):
    """Validate one sample ``x`` against the gate in ``(par, st)``; return acceptance (see :class:`OutlierGate`).

    A rejected sample changes only the counters. The one implementation of the gate, called by
    :meth:`OutlierGate.check` and by compiled components (estimator, closed-loop engine).
    """
    if not math.isfinite(x):
        st[_REJ] += 1.0
        st[_NONFIN] += 1.0
        st[_HELD] += 1.0
        return False
    if st[_HAS] == 0.0:
        st[_LAST] = x
        st[_HAS] = 1.0
        return True
    last = st[_LAST]
    d = x - last if x >= last else last - x
    bound = (par[_MAX_STEP] + par[_N_SIGMA] * st[_SCALE]) * (1.0 + st[_HELD])
    if d > bound:
        if st[_HELD] < par[_MAX_CONSEC]:
            st[_REJ] += 1.0
            st[_OUTL] += 1.0
            st[_HELD] += 1.0
            return False
    else:
        st[_SCALE] += par[_ALPHA] * (d - st[_SCALE])
    st[_LAST] = x
    st[_HELD] = 0.0
    return True


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

    def __init__(self, *, max_step: float = math.inf, n_sigma: float = 8.0, alpha: float = 0.01,
                 max_consecutive: int = 20):
        if max_step != math.inf:
            max_step = check_nonnegative("max_step", max_step)
        n_sigma = check_positive("n_sigma", n_sigma)
        alpha = check_positive("alpha", alpha)
        if alpha > 1.0:
            raise ParameterError(f"alpha must be in (0, 1], got {alpha!r}")
        if isinstance(max_consecutive, bool) or not isinstance(max_consecutive, int) or max_consecutive < 1:
            raise ParameterError(f"max_consecutive must be an integer >= 1, got {max_consecutive!r}")
        self._init_arrays(GATE_NPAR, GATE_NSTATE)
        self.params[:] = (float(max_step), n_sigma, alpha, float(max_consecutive))

    def __repr__(self) -> str:
        return (f"OutlierGate(max_step={self.max_step!r}, n_sigma={self.n_sigma!r}, "
                f"n_rejected={self.n_rejected})")

    max_step = property(lambda self: float(self.params[_MAX_STEP]), doc="Largest plausible step (signal unit).")
    n_sigma = property(lambda self: float(self.params[_N_SIGMA]), doc="Noise allowance in running-scale units.")
    alpha = property(lambda self: float(self.params[_ALPHA]), doc="Smoothing factor of the running scale.")
    max_consecutive = property(lambda self: int(self.params[_MAX_CONSEC]),
                               doc="Consecutive outlier rejections after which a sample is accepted again.")

    @property
    def last(self) -> float | None:
        """Last accepted value, or None before the first."""
        return float(self.state[_LAST]) if self.state[_HAS] else None

    @last.setter
    def last(self, value) -> None:
        if value is None:
            self.state[_HAS] = 0.0
        else:
            self.state[_LAST] = float(value)
            self.state[_HAS] = 1.0

    @property
    def scale(self) -> float:
        """Running mean of ``|x(k) - x(k-1)|`` over accepted samples."""
        return float(self.state[_SCALE])

    @scale.setter
    def scale(self, value) -> None:
        self.state[_SCALE] = float(value)

    n_held = property(lambda self: int(self.state[_HELD]), doc="Samples rejected since the last accepted one.")
    n_rejected = property(lambda self: int(self.state[_REJ]), doc="Rejections in total.")
    n_nonfinite = property(lambda self: int(self.state[_NONFIN]), doc="Non-finite samples rejected.")
    n_outliers = property(lambda self: int(self.state[_OUTL]), doc="Outlier spikes rejected.")

    def check(self, x: float) -> bool:
        """Return True and accept ``x`` if it is plausible; False (counted) if it is rejected.

        Parameters
        ----------
        x : float
            The new sample.

        Returns
        -------
        bool
            Acceptance. A rejected sample changes only the counters.
        """
        return bool(gate_check(self.params, self.state, float(x)))


# RangeGate arrays. params: x_max, factor, floor, decay, max_consecutive; state: envelope, n_held, n_rejected
_RMAX, _RFAC, _RFLOOR, _RDECAY, _RCONSEC = range(5)
_RENV, _RHELD, _RREJ = range(3)
#: Lengths of the range gate's parameter and state arrays.
RANGE_NPAR, RANGE_NSTATE = 5, 3


@kernel(inline="always")
def range_ok(par, st, x):
    """Whether ``x`` passes the range gate in ``(par, st)`` (see :class:`RangeGate`); reads only, writes nothing.

    Components that check several signals test all of them with this function first and then
    :func:`range_commit` each, so that a sample rejected for one signal leaves every other state unchanged.
    """
    if not math.isfinite(x):
        return False
    ax = x if x >= 0.0 else -x
    if ax > par[_RMAX]:
        return False
    env = st[_RENV]
    ref = env if env > par[_RFLOOR] else par[_RFLOOR]
    if ref == 0.0 or st[_RHELD] >= par[_RCONSEC]:  # no scale yet, or the signal really moved
        return True
    return ax <= par[_RFAC] * ref


@kernel
def range_commit(par, st, x, ok):
    """Record the decision ``ok`` of :func:`range_ok` for ``x``: an accepted sample updates the envelope
    ``env = max(|x|, decay*env)``, a rejected one only the counters."""
    if ok:
        ax = x if x >= 0.0 else -x
        e = par[_RDECAY] * st[_RENV]
        st[_RENV] = ax if ax > e else e
        st[_RHELD] = 0.0
    else:
        st[_RHELD] += 1.0
        st[_RREJ] += 1.0


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

    def __init__(self, *, x_max: float = math.inf, factor: float = 100.0, floor: float = 0.0,
                 memory: float = 10000.0, max_consecutive: int = 20):
        if x_max != math.inf:
            x_max = check_positive("x_max", x_max)
        factor = check_positive("factor", factor)
        if factor <= 1.0:
            raise ParameterError(f"factor must be > 1, got {factor!r}")
        floor = check_nonnegative("floor", floor)
        memory = check_positive("memory", memory)
        if isinstance(max_consecutive, bool) or not isinstance(max_consecutive, int) or max_consecutive < 1:
            raise ParameterError(f"max_consecutive must be an integer >= 1, got {max_consecutive!r}")
        self._init_arrays(RANGE_NPAR, RANGE_NSTATE)
        self.params[:] = (float(x_max), factor, floor, math.exp(-1.0 / memory), float(max_consecutive))

    def __repr__(self) -> str:
        return (f"RangeGate(x_max={self.x_max!r}, factor={self.factor!r}, floor={self.floor!r}, "
                f"n_rejected={self.n_rejected})")

    x_max = property(lambda self: float(self.params[_RMAX]), doc="Absolute bound on |x| (signal unit).")
    factor = property(lambda self: float(self.params[_RFAC]), doc="Relative bound (times the reference scale).")
    floor = property(lambda self: float(self.params[_RFLOOR]), doc="Smallest reference scale (signal unit).")
    memory = property(lambda self: -1.0 / math.log(float(self.params[_RDECAY])),
                      doc="Decay time of the envelope (samples).")
    max_consecutive = property(lambda self: int(self.params[_RCONSEC]),
                               doc="Consecutive rejections after which a sample is accepted again.")
    envelope = property(lambda self: float(self.state[_RENV]), doc="Envelope of the accepted |x| (signal unit).")
    n_held = property(lambda self: int(self.state[_RHELD]), doc="Samples rejected since the last accepted one.")
    n_rejected = property(lambda self: int(self.state[_RREJ]), doc="Samples rejected in total.")

    def with_floor(self, floor: float) -> "RangeGate":
        """A copy with another ``floor`` (signal unit); components set it from what they know."""
        g = RangeGate(x_max=self.x_max, factor=self.factor, floor=floor, memory=self.memory,
                      max_consecutive=self.max_consecutive)
        g.state[:] = self.state
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
            Acceptance. A rejected sample changes only the counters.
        """
        x = float(x)
        ok = bool(range_ok(self.params, self.state, x))
        range_commit(self.params, self.state, x, ok)
        return ok
