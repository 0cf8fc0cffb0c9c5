"""Tracking metrics of a closed-loop run: one C accumulator, streamed sample by sample.

The metrics of :class:`LoopMetrics` (RMS and maximum of the velocity error over
the whole run and over its second half, RMS within windows around the
reference reversals, RMS torque) are accumulated in the C struct
``ctl_metrics`` (``controllers/csrc/ctl_metrics.h``) by ``ctl_metrics_add``,
the one implementation: the closed-loop engine holds one struct per scenario
and calls it at every controller period, and :func:`loop_metrics` runs it over
a recorded run. Sums of squares are Neumaier-compensated (Neumaier,
"Rundungsfehleranalyse einiger Verfahren zur Summation endlicher Summen",
ZAMM 54, 1974), so a one-hour run at 1 kHz loses no digits and memory does not
grow with the run length. :func:`metrics_result` and :func:`metrics_columns`
turn accumulators (a ``ctl_metrics *``, a ``ctl_metrics[]`` array, or a numpy
array of :data:`METRICS_DTYPE`) into results.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controllers._cctl import ffi, lib
from plant.errors import ParameterError, SignalError, check_nonnegative, check_signal

__all__ = ["LoopMetrics", "loop_metrics", "reversal_times", "metrics_update", "metrics_where", "metrics_add",
           "metrics_result", "metrics_columns", "new_metrics", "METRICS_DTYPE", "METRIC_NAMES", "deviation_rms",
           "first_active_time"]

#: Field names of :class:`LoopMetrics`, in order.
METRIC_NAMES = ("rms", "max", "rms_second_half", "max_second_half", "rms_reversal", "u_rms")


def _struct_dtype(ctype: str) -> np.dtype:
    """The numpy structured dtype of the C struct ``ctype`` (fields, offsets and size as the compiler laid them
    out; ``double`` as float64, integers as signed integers of their size)."""
    t = ffi.typeof(ctype)
    names, formats, offsets = [], [], []
    for name, f in t.fields:
        names.append(name)
        kind = f.type.kind
        if f.type.cname == "double":
            formats.append(np.float64)
        elif kind == "primitive" or kind == "enum":
            formats.append(np.dtype(f"i{ffi.sizeof(f.type)}"))
        else:  # pragma: no cover - ctl_metrics has scalars only
            raise TypeError(f"field {name} of {ctype} is not a scalar")
        offsets.append(f.offset)
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": ffi.sizeof(t)})


#: numpy structured dtype of the C struct ``ctl_metrics`` (a view of ``ctl_metrics[]`` memory, or memory for it:
#: ``ffi.from_buffer("ctl_metrics[]", np.zeros(B, METRICS_DTYPE))``).
METRICS_DTYPE = _struct_dtype("ctl_metrics")
_CTYPE = ffi.typeof("ctl_metrics")


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


def new_metrics(n: int | None = None):
    """Zeroed accumulators: one ``ctl_metrics *`` (``n`` None) or a ``ctl_metrics[n]`` array (cffi, owned).

    Parameters
    ----------
    n : int, optional
        Number of accumulators (one per scenario), >= 0.

    Returns
    -------
    cffi cdata
        ``ctl_metrics *`` or ``ctl_metrics[n]``, every field 0 (``ctl_metrics_init``).
    """
    if n is None:
        return ffi.new("ctl_metrics *")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ParameterError(f"n must be an integer >= 0, got {n!r}")
    return ffi.new("ctl_metrics[]", int(n))


def _revs_buffer(revs):
    """``(const double *, R)`` of a sorted reversal-time array (kept alive by the caller through the returned
    array)."""
    r = np.ascontiguousarray(revs, dtype=np.float64)
    if r.ndim != 1:
        raise SignalError(f"revs must be 1-D, got shape {r.shape}")
    return r, ffi.from_buffer("double[]", r), r.shape[0]


def metrics_where(t: float, tmid: float, revs, window: float, ip: int) -> tuple[int, int]:
    """Which sums a sample at time ``t`` (s) enters: 0 first half, 1 second half, 2 second half in a reversal window.

    Depends on the time alone, so a batch of scenarios on one reference computes it once per period
    (the engine calls the C function ``ctl_metrics_where`` directly; this is its Python face).

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
        The class of the sample and the advanced reversal pointer (C ``controllers/csrc/ctl_metrics.c``,
        ``ctl_metrics_where``).
    """
    _, r, nrev = _revs_buffer(revs)
    p = ffi.new("long *", int(ip))
    where = lib.ctl_metrics_where(t, tmid, r, nrev, window, p)
    return int(where), int(p[0])


def metrics_add(m, where: int, e: float, u: float) -> None:
    """Add one sample of class ``where`` (:func:`metrics_where`): error ``e`` (rad/s), torque ``u`` (N·m).

    ``m`` is a ``ctl_metrics *`` (:func:`new_metrics`). NaN propagates into the sums and maxima as in numpy.
    The reversal pointer ``m.ip`` is not touched. C (``ctl_metrics_add``).
    """
    lib.ctl_metrics_add(m, where, e, u)


def metrics_update(m, t: float, tmid: float, revs, window: float, e: float, u: float) -> None:
    """Add one sample: error ``e`` (rad/s) and torque ``u`` (N·m) at time ``t`` (s), times non-decreasing.

    ``m`` is a ``ctl_metrics *``; ``tmid`` the start of the second half (s); ``revs`` the sorted reversal times
    (s); a sample belongs to a reversal window when its nearest reversal is within ``window`` s (second half
    only). :func:`metrics_where` with the pointer ``m.ip``, then :func:`metrics_add` (C ``ctl_metrics_update``).
    """
    _, r, nrev = _revs_buffer(revs)
    lib.ctl_metrics_update(m, t, tmid, r, nrev, window, e, u)


def _records(states) -> np.ndarray:
    """The accumulators ``states`` as a 1-D numpy array of :data:`METRICS_DTYPE` (a view of cffi memory)."""
    if isinstance(states, np.ndarray):
        if states.dtype != METRICS_DTYPE:
            raise ParameterError(f"states must have dtype METRICS_DTYPE, got {states.dtype}")
        return states.reshape(-1)
    if isinstance(states, ffi.CData):
        t = ffi.typeof(states)
        if t.kind == "struct":
            states = ffi.addressof(states)
            t = ffi.typeof(states)
        item = t.item if t.kind in ("pointer", "array") else None
        if item is not None and item is _CTYPE:
            return np.frombuffer(ffi.buffer(states), dtype=METRICS_DTYPE)
    raise ParameterError(f"states must be ctl_metrics cdata or an array of METRICS_DTYPE, got {states!r}")


def metrics_result(st, *, n_total: int | None = None) -> LoopMetrics:
    """:class:`LoopMetrics` of one accumulator ``st``.

    Parameters
    ----------
    st : cffi ``ctl_metrics *`` or ``ctl_metrics`` (an element of a ``ctl_metrics[]`` array)
        Accumulator after the run (also a numpy record array of :data:`METRICS_DTYPE` of length 1).
    n_total : int, optional
        Samples the run should have had; a run that stopped earlier (diverged) reports NaN for every
        metric that needs the missing samples (all but a reversal RMS whose windows were complete).
    """
    rec = _records(st)
    if rec.shape != (1,):
        raise ParameterError(f"st must be one accumulator, got {rec.shape[0]}")
    nan = math.nan
    if n_total is not None and rec["n"][0] < n_total:
        return LoopMetrics(rms=nan, max=nan, rms_second_half=nan, max_second_half=nan, rms_reversal=nan,
                           u_rms=nan)
    cols = metrics_columns(rec)
    return LoopMetrics(**{k: float(v[0]) for k, v in cols.items()})


def metrics_columns(states) -> dict:
    """The metrics of B accumulators at once: one array per field of :class:`LoopMetrics`.

    Parameters
    ----------
    states : cffi ``ctl_metrics[B]`` (or ``ctl_metrics *``), or ndarray of :data:`METRICS_DTYPE`, shape (B,)
        Accumulators after the runs (the engine's per-scenario structs).

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
    st = _records(states)
    n, nh, nr = (st[k].astype(np.float64) for k in ("n", "n_half", "n_rev"))
    with np.errstate(all="ignore"):
        def rms(k, c):
            return np.where(c > 0, np.sqrt((st[k] + st[k + "_c"]) / c), np.nan)

        return {"rms": rms("e2", n), "max": np.where(n != 0, st["e_max"], np.nan),
                "rms_second_half": rms("e2_half", nh),
                "max_second_half": np.where(nh != 0, st["e_max_half"], np.nan), "rms_reversal": rms("e2_rev", nr),
                "u_rms": rms("u2", n)}


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
        ``t[k]`` for every ``k`` with ``sgn(w[k-1])*sgn(w[k]) < 0``, and for every ``k`` with ``w[k] == 0`` and
        ``sgn(w[k-1])*sgn(w[k+1]) < 0`` (a reversal whose zero crossing falls on a sample; two or more samples
        at rest in between make a stop and a start, not a reversal).
    """
    n = w.shape[0]
    out = [t[:0]]
    for i in range(0, n - 1, chunk):
        s = np.sign(w[i:i + chunk + 2])
        direct = s[1:] * s[:-1] < 0
        on_zero = np.zeros_like(direct)
        on_zero[:-1] = (s[1:-1] == 0) & (s[2:] * s[:-2] < 0)
        k = np.flatnonzero((direct | on_zero)[:chunk])
        out.append(t[i + 1 + k])
    return np.concatenate(out)


def loop_metrics(t, w_ref, w, u, *, reversals, window: float = 0.2) -> LoopMetrics:
    """Compute :class:`LoopMetrics` from a recorded run (the engine's accumulator, C ``ctl_metrics_accumulate``).

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
    m = new_metrics()
    revs, r, nrev = _revs_buffer(np.sort(np.asarray(reversals, dtype=float)))
    t = np.ascontiguousarray(t, dtype=np.float64)
    e = np.ascontiguousarray(w_ref - w, dtype=np.float64)
    u = np.ascontiguousarray(u, dtype=np.float64)
    lib.ctl_metrics_accumulate(m, ffi.from_buffer("double[]", t), ffi.from_buffer("double[]", e),
                               ffi.from_buffer("double[]", u), n, 0.5 * (t[0] + t[-1]), r, nrev, window)
    return metrics_result(m)


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
