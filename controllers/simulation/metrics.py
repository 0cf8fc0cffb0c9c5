"""Tracking metrics of a closed-loop run: one compiled accumulator, streamed sample by sample.

The metrics of :class:`LoopMetrics` (RMS and maximum of the velocity error over
the whole run and over its second half, RMS within windows around the
reference reversals, RMS torque) are accumulated by :func:`metrics_update`,
the one implementation: the closed-loop engine calls it at every controller
period, and :func:`loop_metrics` runs it over a recorded run. Sums of squares
are Neumaier-compensated (Neumaier, "Rundungsfehleranalyse einiger Verfahren
zur Summation endlicher Summen", ZAMM 54, 1974), so a one-hour run at 1 kHz
loses no digits and memory does not grow with the run length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plant.errors import ParameterError, SignalError, check_nonnegative, check_signal
from plant.jit import kernel

__all__ = ["LoopMetrics", "loop_metrics", "reversal_times", "metrics_update", "metrics_where", "metrics_add",
           "metrics_result", "metrics_columns", "METRICS_NSTATE", "METRIC_NAMES", "deviation_rms",
           "first_active_time"]

# accumulator state: compensated sums (value, compensation) of e^2 (all, second half, reversal windows) and u^2,
# maxima of |e| (all, second half), counts (second half, reversal windows), reversal pointer
_SE, _SEC, _ME, _SH, _SHC, _MH, _NH, _SR, _SRC, _NR, _SU, _SUC, _N, _IP = range(14)
#: Length of the accumulator state.
METRICS_NSTATE = 14
#: Field names of :class:`LoopMetrics`, in order.
METRIC_NAMES = ("rms", "max", "rms_second_half", "max_second_half", "rms_reversal", "u_rms")


@dataclass(frozen=True)
class LoopMetrics:
    """Tracking metrics of one closed-loop run (velocity error ``e = w_ref - w``, rad/s).

    Attributes
    ----------
    rms, max : float
        RMS and max |e| over the whole run (rad/s).
    rms_second_half, max_second_half : float
        The same over the second half (after adaptation transients).
    rms_reversal : float
        RMS of e within ``±window`` s of the reference reversals (second half).
    u_rms : float
        RMS control effort (N·m).
    """

    rms: float
    max: float
    rms_second_half: float
    max_second_half: float
    rms_reversal: float
    u_rms: float

    def to_dict(self) -> dict:
        """Plain-float dict; NaN (an empty window, a diverged run) becomes None (strict JSON)."""
        return {k: (float(v) if math.isfinite(v) else None) for k, v in self.__dict__.items()}

    def summary(self) -> str:
        """One line: second-half RMS and max error (deg/s), reversal RMS, torque RMS."""
        d = math.degrees
        return (f"RMS {d(self.rms_second_half):.4f} deg/s, max {d(self.max_second_half):.4f} deg/s "
                f"(second half), reversal RMS {d(self.rms_reversal):.4f} deg/s, u RMS {self.u_rms:.2f} N·m")


@kernel(inline="always")
def _add(st, i, x):
    """Neumaier-compensated ``sum += x`` on slots ``st[i]`` (sum) and ``st[i + 1]`` (compensation)."""
    s = st[i]
    q = s + x
    st[i + 1] += (s - q) + x if abs(s) >= abs(x) else (x - q) + s
    st[i] = q


@kernel(inline="always")
def metrics_where(t, tmid, revs, window, ip):
    """Which sums a sample at time ``t`` (s) enters: 0 first half, 1 second half, 2 second half in a reversal window.

    Depends on the time alone, so a batch of scenarios on one reference computes it once per period.

    Parameters
    ----------
    t : float
        Sample time (s), non-decreasing from call to call.
    tmid : float
        Start of the second half (s).
    revs : ndarray, shape (R,)
        Sorted reversal times (s).
    window : float
        Half-width of the reversal windows (s): a sample is in a window when its nearest reversal is within it.
    ip : int
        Reversal pointer of the previous call (0 at the start).

    Returns
    -------
    (int, int)
        The class of the sample and the advanced reversal pointer.
    """
    if not t >= tmid:
        return 0, ip
    nrev = revs.shape[0]
    if nrev > 0:
        while ip < nrev and revs[ip] < t:
            ip += 1
        lo = revs[ip - 1] if ip >= 1 else revs[0]
        hi = revs[ip] if ip < nrev else revs[nrev - 1]
        if min(abs(t - lo), abs(hi - t)) <= window:
            return 2, ip
    return 1, ip


@kernel(inline="always")
def metrics_add(st, where, e, u):
    """Add one sample of class ``where`` (:func:`metrics_where`): error ``e`` (rad/s), torque ``u`` (N·m).

    NaN propagates into the sums and maxima as in numpy. The reversal pointer slot of ``st`` is not touched.
    """
    e2 = e * e
    _add(st, _SE, e2)
    ae = abs(e)
    if ae > st[_ME] or ae != ae:
        st[_ME] = ae if st[_ME] == st[_ME] else st[_ME]
    st[_N] += 1.0
    if where > 0:
        _add(st, _SH, e2)
        st[_NH] += 1.0
        if ae > st[_MH] or ae != ae:
            st[_MH] = ae if st[_MH] == st[_MH] else st[_MH]
        if where == 2:
            _add(st, _SR, e2)
            st[_NR] += 1.0
    _add(st, _SU, u * u)


@kernel
def metrics_update(st, t, tmid, revs, window, e, u):
    """Add one sample: error ``e`` (rad/s) and torque ``u`` (N·m) at time ``t`` (s), times non-decreasing.

    ``tmid`` is the start of the second half (s); ``revs`` the sorted reversal times (s); a sample belongs to
    a reversal window when its nearest reversal is within ``window`` s (second half only). NaN propagates into
    the sums and maxima as in numpy. :func:`metrics_where` then :func:`metrics_add` (the reversal pointer kept
    in ``st``).
    """
    where, ip = metrics_where(t, tmid, revs, window, np.int64(st[_IP]))
    st[_IP] = ip
    metrics_add(st, where, e, u)


@kernel
def _accumulate(st, t, tmid, revs, window, e, u):
    for k in range(t.shape[0]):
        metrics_update(st, t[k], tmid, revs, window, e[k], u[k])


def metrics_result(st, *, n_total: int | None = None) -> LoopMetrics:
    """:class:`LoopMetrics` of an accumulator state ``st`` (shape (METRICS_NSTATE,)).

    Parameters
    ----------
    st : ndarray, shape (METRICS_NSTATE,)
        Accumulator state after the run.
    n_total : int, optional
        Samples the run should have had; a run that stopped earlier (diverged) reports NaN for every
        metric that needs the missing samples (all but a reversal RMS whose windows were complete).
    """
    nan = math.nan
    if n_total is not None and st[_N] < n_total:
        return LoopMetrics(rms=nan, max=nan, rms_second_half=nan, max_second_half=nan, rms_reversal=nan,
                           u_rms=nan)
    cols = metrics_columns(np.asarray(st, dtype=float)[None, :])
    return LoopMetrics(**{k: float(v[0]) for k, v in cols.items()})


def metrics_columns(states) -> dict:
    """The metrics of B accumulator states at once: one array per field of :class:`LoopMetrics`.

    Parameters
    ----------
    states : ndarray, shape (B, METRICS_NSTATE)
        Accumulator states after the runs.

    Returns
    -------
    dict
        ``{name: ndarray of shape (B,)}`` for every name of :data:`METRIC_NAMES`: an RMS is
        ``sqrt((sum + compensation)/count)`` (NaN where the count is 0), a maximum NaN where no sample was
        seen. The IEEE operations of a scalar evaluation (division, square root), so entry ``b`` equals the
        field of ``metrics_result(states[b])`` bit for bit.

    Notes
    -----
    RMS of the Neumaier-compensated sums of squares (module docstring).
    """
    st = np.asarray(states, dtype=float)
    n, nh, nr = st[:, _N], st[:, _NH], st[:, _NR]
    with np.errstate(all="ignore"):
        def rms(i, c):
            return np.where(c > 0, np.sqrt((st[:, i] + st[:, i + 1]) / c), np.nan)

        return {"rms": rms(_SE, n), "max": np.where(n != 0, st[:, _ME], np.nan), "rms_second_half": rms(_SH, nh),
                "max_second_half": np.where(nh != 0, st[:, _MH], np.nan), "rms_reversal": rms(_SR, nr),
                "u_rms": rms(_SU, n)}


def reversal_times(t, w, chunk: int = 1 << 16) -> np.ndarray:
    """Times (s) at which the sampled velocity ``w`` changes sign (as :meth:`plant.excitation.Reference.reversals`).

    Computed in chunks of ``chunk`` samples (no full-length temporaries).

    Parameters
    ----------
    t, w : ndarray, shape (N,)
        Time (s) and velocity (rad/s).

    Returns
    -------
    ndarray, shape (R,)
        ``t[k]`` for every ``k`` with ``sgn(w[k-1])*sgn(w[k]) < 0``.
    """
    n = w.shape[0]
    out = [t[:0]]
    for i in range(0, n - 1, chunk):
        s = np.sign(w[i:i + chunk + 1])
        out.append(t[i + 1 + np.flatnonzero(s[1:] * s[:-1] < 0)])
    return np.concatenate(out)


def loop_metrics(t, w_ref, w, u, *, reversals, window: float = 0.2) -> LoopMetrics:
    """Compute :class:`LoopMetrics` from a recorded run (the engine's accumulator, :func:`metrics_update`).

    Parameters
    ----------
    t, w_ref, w, u : array_like, shape (N,)
        Time (s, increasing), reference and actual velocity (rad/s), control torque (N·m).
    reversals : array_like, shape (R,)
        Reversal times of the reference (s), sorted.
    window : float, keyword-only
        Half-width of the reversal windows (s).

    Returns
    -------
    LoopMetrics

    Raises
    ------
    SignalError
        Arrays of different lengths, empty, or ``t`` not finite.
    ParameterError
        ``window`` negative.
    """
    t = check_signal("t", t)
    n = t.shape[0]
    w_ref = np.asarray(w_ref, dtype=float)
    w = np.asarray(w, dtype=float)
    u = np.asarray(u, dtype=float)
    for name, a in (("w_ref", w_ref), ("w", w), ("u", u)):
        if a.shape != (n,):
            raise ParameterError(f"{name} must have shape ({n},), got {a.shape}")
    window = check_nonnegative("window", window)
    st = np.zeros(METRICS_NSTATE)
    revs = np.ascontiguousarray(np.sort(np.asarray(reversals, dtype=float)))
    _accumulate(st, np.ascontiguousarray(t), 0.5 * (t[0] + t[-1]), revs, window,
                np.ascontiguousarray(w_ref - w), np.ascontiguousarray(u))
    return metrics_result(st)


def deviation_rms(w, w_limit) -> float:
    """RMS of ``w - w_limit`` (rad/s): how far a run's trajectory is from a limit trajectory.

    Used with the frictionless run of the same reference and noise as ``w_limit`` (``rms_dev`` of
    :class:`controllers.experiments.compare.Comparison`): unlike the tracking error, it does not saturate
    when a compensator is at the frictionless tracking level.

    Parameters
    ----------
    w, w_limit : array_like, shape (N,)
        Velocity of the run and of the limit run (rad/s), same time base.

    Returns
    -------
    float
        ``sqrt(mean((w - w_limit)**2))`` (rad/s); NaN if either contains NaN (a diverged run) or ``N = 0``.

    Raises
    ------
    SignalError
        Shapes differ.
    """
    w = np.asarray(w, dtype=float)
    w_limit = np.asarray(w_limit, dtype=float)
    if w.shape != w_limit.shape or w.ndim != 1:
        raise SignalError(f"w and w_limit must be 1-D of the same shape, got {w.shape} and {w_limit.shape}")
    if w.size == 0:
        return math.nan
    return float(np.sqrt(np.mean((w - w_limit) ** 2)))


def first_active_time(t, u_c) -> float | None:
    """Time (s) of the first sample at which a compensator's torque ``u_c`` is non-zero, or None if never.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time (s).
    u_c : array_like, shape (N,)
        Compensation torque of the run (N·m), e.g. :attr:`controllers.ClosedLoopResult.u_ff`.

    Returns
    -------
    float or None
        ``t[k]`` of the first ``k`` with a finite ``u_c[k] != 0``; None if there is none (no compensator,
        a feedforward that never switched on, or no record).

    Raises
    ------
    SignalError
        Shapes differ.
    """
    t = np.asarray(t, dtype=float)
    u_c = np.asarray(u_c, dtype=float)
    if t.shape != u_c.shape:
        raise SignalError(f"t and u_c must have the same shape, got {t.shape} and {u_c.shape}")
    k = np.flatnonzero(np.isfinite(u_c) & (u_c != 0.0))
    return float(t[k[0]]) if k.size else None
