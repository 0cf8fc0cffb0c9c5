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

:class:`MotionMetrics` says what happened on a robot's motion (point-to-point
moves with dwell, constant speed with reversals, :mod:`plant.motion`): the RMS
error in motion and at standstill, the settling time and largest error of each
stop, the largest error at each reversal. The same C accumulates it
(``ctl_metrics_add_motion``, ``ctl_motion_where``, ``ctl_events_add`` of
``controllers/csrc/ctl_metrics.c``; the definitions are in its header and in
:class:`MotionMetrics`), in the engine and in :func:`motion_metrics` over a
recorded run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controllers._cctl import ffi, lib
from plant.errors import ParameterError, SignalError, check_nonnegative, check_signal

__all__ = ["LoopMetrics", "loop_metrics", "reversal_times", "metrics_update", "metrics_where", "metrics_add",
           "metrics_result", "metrics_columns", "new_metrics", "METRICS_DTYPE", "METRIC_NAMES", "deviation_rms",
           "first_active_time", "MotionMetrics", "motion_metrics", "motion_result", "engine_motion", "stop_intervals",
           "SETTLE_SHARE"]

#: Default settling band of a stop as a share of the move's peak speed (2 %, :class:`MotionMetrics`).
SETTLE_SHARE = 0.02

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
_NAMES = METRICS_DTYPE.names


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
    r = dict(zip(_NAMES, rec[0].item()))  # Python numbers: the IEEE operations of metrics_columns, one scenario
    n, nh, nr = float(r["n"]), float(r["n_half"]), float(r["n_rev"])
    return LoopMetrics(rms=_rms(r["e2"], r["e2_c"], n), max=float(r["e_max"]) if n != 0 else nan,
                       rms_second_half=_rms(r["e2_half"], r["e2_half_c"], nh),
                       max_second_half=float(r["e_max_half"]) if nh != 0 else nan,
                       rms_reversal=_rms(r["e2_rev"], r["e2_rev_c"], nr), u_rms=_rms(r["u2"], r["u2_c"], n))


def _rms(total, comp, count):
    """``sqrt((total + comp)/count)``: the RMS of a Neumaier-compensated sum of squares (module docstring), NaN where
    ``count`` is not > 0 or the sum is below 0. One scenario's Python floats, or B scenarios' arrays (shape (B,),
    ``count`` an ndarray): the same IEEE operations either way."""
    if isinstance(count, float):
        if not count > 0:
            return math.nan
        x = (total + comp) / count
        return math.sqrt(x) if x >= 0.0 else math.nan
    with np.errstate(all="ignore"):
        return np.where(count > 0, np.sqrt((total + comp) / count), np.nan)


def _motion_scalars(r: dict, diverged: bool) -> tuple:
    """``(rms_motion, rms_standstill, max_standstill)`` of one accumulator's fields ``r`` (Python numbers), NaN where
    the run diverged or had no such sample: :func:`engine_motion`'s operations on one scenario."""
    if diverged:
        return math.nan, math.nan, math.nan
    nm, nr = float(r["n_move"]), float(r["n_rest"])
    return (_rms(r["e2_move"], r["e2_move_c"], nm), _rms(r["e2_rest"], r["e2_rest_c"], nr),
            float(r["e_max_rest"]) if nr > 0 else math.nan)


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
    def rms(k, c):
        return _rms(st[k], st[k + "_c"], c)

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
        flips = s[1:] * s[:-1] < 0
        zero = s[1:-1] == 0
        if zero.any():  # a sample exactly at 0 between opposite signs (rare: measured data, a designed reference)
            flips[:-1] |= zero & (s[2:] * s[:-2] < 0)
        k = np.flatnonzero(flips[:chunk])
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


# --------------------------------------------------------------------------- motion: stops and reversals


def _nan_or(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class MotionMetrics:
    """What happened at each stop and reversal of a robot's motion, and the error in motion and at standstill.

    Velocity error ``e = w_ref - w`` (rad/s), the quantity the loop tracks (a position error would add the
    integral of ``e`` since the move began, which the velocity loop does not control). Definitions (C
    ``controllers/csrc/ctl_metrics.h``):

    * **at standstill**: a sample with ``w_ref == 0`` in a run of at least two such samples, or at either end of
      the reference; **in motion**: every other sample (a lone zero sample where the reference crosses zero is
      motion, a reversal);
    * **a stop**: a run of standstill samples that follows motion (:meth:`plant.excitation.Reference.stops`), the
      dwell from its first sample to its last (the sample before the next move, or the end of the run);
    * **settling band** of a stop: ``b = max(share * peak, floor)`` (rad/s), ``peak`` the largest ``|w_ref|`` of
      the move before it (since the previous standstill);
    * **settling time** of a stop: ``t[j+1] - t[k0]`` with ``k0`` its first sample and ``j`` its last sample with
      ``|e| > b`` (0 when there is none), to one sample; ``inf`` when ``|e| > b`` at the stop's last sample (it
      did not settle before the next move or the end of the run); NaN when the run ended before the stop did
      (diverged);
    * **reversal window**: the samples whose nearest reversal (the earlier of two equally near) is within
      ``window`` s (the samples of :attr:`LoopMetrics.rms_reversal`, here over the whole run); the largest
      ``|e|`` in each; NaN where the run ended before the window did.

    Attributes
    ----------
    rms_motion, rms_standstill : float
        RMS of ``e`` over the second-half samples in motion and at standstill (rad/s); NaN without such samples
        or for a diverged run.
    max_standstill : float
        Largest ``|e|`` over the second-half samples at standstill (rad/s): the drift while the reference holds
        still.
    t_mid : float
        Start of the second half (s), ``(t[0] + t[-1])/2``.
    stop_start, stop_end : ndarray, shape (S,)
        First and last sample time of each stop (s).
    settling_band : ndarray, shape (S,)
        Settling band of each stop (rad/s).
    settling_time : ndarray, shape (S,)
        Settling time of each stop (s; inf: not settled, NaN: not complete).
    stop_max : ndarray, shape (S,)
        Largest ``|e|`` during each stop (rad/s).
    reversal_times : ndarray, shape (R,)
        Reversal times of the reference (s).
    reversal_max : ndarray, shape (R,)
        Largest ``|e|`` in each reversal's window (rad/s).
    window, share, floor : float
        Half-width of the reversal windows (s), the band's share of the peak speed (-) and its floor (rad/s).

    Notes
    -----
    The aggregates (:attr:`settling_median`, :attr:`settling_max`, :attr:`n_unsettled`, :attr:`max_reversal`)
    are over the events of the second half (a stop or reversal at or after :attr:`t_mid`), as the RMS of
    :class:`LoopMetrics` (after adaptation transients); the arrays hold every event.
    """

    rms_motion: float
    rms_standstill: float
    max_standstill: float
    t_mid: float
    stop_start: np.ndarray
    stop_end: np.ndarray
    settling_band: np.ndarray
    settling_time: np.ndarray
    stop_max: np.ndarray
    reversal_times: np.ndarray
    reversal_max: np.ndarray
    window: float
    share: float
    floor: float

    @property
    def n_stops(self) -> int:
        """Number of stops of the reference."""
        return int(self.stop_start.shape[0])

    @property
    def n_reversals(self) -> int:
        """Number of reversals of the reference."""
        return int(self.reversal_times.shape[0])

    def _late_stops(self) -> np.ndarray:
        return self.settling_time[self.stop_start >= self.t_mid]

    @property
    def settling_median(self) -> float:
        """Median settling time of the second-half stops (s; inf when more than half did not settle, NaN without
        such stops or when one was not complete)."""
        s = self._late_stops()
        return float(np.median(s)) if s.size and not np.isnan(s).any() else math.nan

    @property
    def settling_max(self) -> float:
        """Longest settling time of the second-half stops (s; inf when one did not settle, NaN without such stops
        or when one was not complete)."""
        s = self._late_stops()
        return float(np.max(s)) if s.size and not np.isnan(s).any() else math.nan

    @property
    def n_unsettled(self) -> int:
        """Second-half stops whose error did not settle into the band before the stop ended."""
        return int(np.count_nonzero(np.isinf(self._late_stops())))

    @property
    def max_reversal(self) -> float:
        """Largest ``|e|`` at the second-half reversals (rad/s; NaN without such reversals or when one window was
        not complete)."""
        m = self.reversal_max[self.reversal_times >= self.t_mid]
        return float(np.max(m)) if m.size else math.nan

    def to_dict(self) -> dict:
        """Strict JSON: the aggregates, then one dict per stop and per reversal (SI units; NaN and inf as None,
        with ``settled`` False for a stop that did not settle, None for one not complete)."""
        stops = []
        for a, b, band, ts, mx in zip(self.stop_start, self.stop_end, self.settling_band, self.settling_time,
                                      self.stop_max):
            settled = None if math.isnan(ts) else bool(math.isfinite(ts))
            stops.append({"t_start": float(a), "t_end": float(b), "band": float(band), "settling_time": _nan_or(ts),
                          "settled": settled, "max": _nan_or(mx)})
        revs = [{"t": float(t), "max": _nan_or(m)} for t, m in zip(self.reversal_times, self.reversal_max)]
        return {"rms_motion": _nan_or(self.rms_motion), "rms_standstill": _nan_or(self.rms_standstill),
                "max_standstill": _nan_or(self.max_standstill), "n_stops": self.n_stops,
                "settling_median": _nan_or(self.settling_median), "settling_max": _nan_or(self.settling_max),
                "n_unsettled": self.n_unsettled, "n_reversals": self.n_reversals,
                "max_reversal": _nan_or(self.max_reversal), "t_mid": _nan_or(self.t_mid),
                "band_share": float(self.share), "band_floor": float(self.floor),
                "reversal_window": float(self.window), "stops": stops, "reversals": revs}

    def summary(self) -> str:
        """Up to three lines (velocities in deg/s): RMS in motion and at standstill, settling of the stops,
        error at the reversals (second half)."""
        d = math.degrees
        lines = [f"in motion RMS {d(self.rms_motion):.4f} deg/s; at standstill RMS {d(self.rms_standstill):.4f} "
                 f"deg/s, max {d(self.max_standstill):.4f} deg/s (second half)"]
        late = int(np.count_nonzero(self.stop_start >= self.t_mid))
        if self.n_stops:
            floor = f", floor {d(self.floor):.3g} deg/s" if self.floor > 0 else ""
            unset = f"; {self.n_unsettled} did not settle before the stop ended" if self.n_unsettled else ""
            lines.append(f"stops: {self.n_stops} ({late} in the second half), settling median "
                         f"{self.settling_median:.3f} s, max {self.settling_max:.3f} s (band {100 * self.share:g} % "
                         f"of the move's peak speed{floor}){unset}")
        if self.n_reversals:
            late = int(np.count_nonzero(self.reversal_times >= self.t_mid))
            lines.append(f"reversals: {self.n_reversals} ({late} in the second half), largest |e| "
                         f"{d(self.max_reversal):.4f} deg/s within ±{self.window:g} s")
        return "\n".join(lines)


def stop_intervals(t, w_ref, *, share: float = SETTLE_SHARE, floor: float = 0.0) -> tuple:
    """The stops of a reference and their settling bands (C ``ctl_motion_stops``; :class:`MotionMetrics`).

    Parameters
    ----------
    t, w_ref : array_like, shape (N,)
        Time (s, increasing) and reference velocity (rad/s).
    share : float, keyword-only
        Band as a share of the move's peak speed (-), >= 0; default :data:`SETTLE_SHARE`.
    floor : float, keyword-only
        The band's lower bound (rad/s), >= 0 (e.g. a noise level).

    Returns
    -------
    start, end, band : ndarray, shape (S,)
        First and last sample time of each stop (s; ``start`` equals
        :meth:`plant.excitation.Reference.stops`) and its band ``max(share*peak, floor)`` (rad/s).

    Raises
    ------
    ParameterError
        ``share`` or ``floor`` negative or not finite, shapes differ.
    """
    share = check_nonnegative("share", share)
    floor = check_nonnegative("floor", floor)
    for name, v in (("share", share), ("floor", floor)):
        if not math.isfinite(v):
            raise ParameterError(f"{name} must be finite, got {v!r}")
    t = np.ascontiguousarray(t, dtype=np.float64)
    w = np.ascontiguousarray(w_ref, dtype=np.float64)
    if t.ndim != 1 or w.shape != t.shape:
        raise ParameterError(f"t and w_ref must be 1-D of one shape, got {t.shape} and {w.shape}")
    tp, wp = ffi.from_buffer("double[]", t), ffi.from_buffer("double[]", w)
    n = t.shape[0]
    S = int(lib.ctl_motion_stops(tp, wp, n, share, floor, ffi.NULL, ffi.NULL, ffi.NULL, 0))
    out = [np.empty(S) for _ in range(3)]
    if S:
        lib.ctl_motion_stops(tp, wp, n, share, floor, *(ffi.from_buffer("double[]", a) for a in out), S)
    return tuple(out)


def motion_result(st, stops, events, *, t_mid: float, window: float, share: float, floor: float,
                  diverged: bool = False) -> MotionMetrics:
    """:class:`MotionMetrics` of one accumulator and its event arrays (what the engine or
    :func:`motion_metrics` wrote).

    Parameters
    ----------
    st : cffi ``ctl_metrics`` (pointer or element), or a numpy record of :data:`METRICS_DTYPE` of length 1
        The accumulator (its motion sums).
    stops : (ndarray, ndarray, ndarray)
        :func:`stop_intervals` of the reference.
    events : (ndarray, ndarray, ndarray, ndarray)
        ``(settle, stop_max, revs, rev_max)``: settling time (s) and largest error (rad/s) of each stop
        (``ctl_events``), shape (S,) each; reversal times (s) and the largest error in each window (rad/s), shape
        (R,) each.
    t_mid, window, share, floor : float, keyword-only
        Start of the second half (s), reversal half-window (s), band share (-) and floor (rad/s).
    diverged : bool, keyword-only
        The run stopped early: the RMS values and the standstill maximum become NaN (the event arrays hold NaN
        where an event was not complete).

    Returns
    -------
    MotionMetrics
    """
    settle, stop_max, revs, rev_max = events
    rec = _records(st)
    if rec.shape != (1,):
        raise ParameterError(f"st must be one accumulator, got {rec.shape[0]}")
    r = rec[0]
    with np.errstate(all="ignore"):
        nm, nr = float(r["n_move"]), float(r["n_rest"])
        rms_m = math.sqrt((r["e2_move"] + r["e2_move_c"]) / nm) if nm > 0 else math.nan
        rms_r = math.sqrt((r["e2_rest"] + r["e2_rest_c"]) / nr) if nr > 0 else math.nan
        mx_r = float(r["e_max_rest"]) if nr > 0 else math.nan
    if diverged:
        rms_m = rms_r = mx_r = math.nan
    a, b, band = (np.array(x, dtype=float) for x in stops)
    return MotionMetrics(rms_motion=float(rms_m), rms_standstill=float(rms_r), max_standstill=mx_r,
                         t_mid=float(t_mid), stop_start=a, stop_end=b, settling_band=band,
                         settling_time=np.array(settle, dtype=float), stop_max=np.array(stop_max, dtype=float),
                         reversal_times=np.array(revs, dtype=float), reversal_max=np.array(rev_max, dtype=float),
                         window=float(window), share=float(share), floor=float(floor))


def engine_motion(run, states, t, revs, *, window: float, diverged) -> tuple:
    """:class:`MotionMetrics` of every scenario of an engine run, one per scenario.

    Parameters
    ----------
    run : controllers.simulation.engine.EngineRun
        After ``run()``: its ``stops``, ``settle``, ``stop_max``, ``rev_max`` (the per-event arrays, shared as
        views: one row per scenario) and the band of its ``c_run``.
    states : ndarray of :data:`METRICS_DTYPE`, shape (B,)
        The scenarios' accumulators (``run.metrics()``).
    t : ndarray, shape (N,)
        Time of the reference (s).
    revs : ndarray, shape (R,)
        Its reversal times (s).
    window : float, keyword-only
        Half-width of the reversal windows (s).
    diverged : array_like of bool, shape (B,), keyword-only
        Scenarios that stopped early: NaN RMS and standstill maximum (:func:`motion_result`).

    Returns
    -------
    tuple of MotionMetrics
        Entry ``b`` equals ``motion_result(states[b], ...)`` bit for bit (the same IEEE operations, vectorised).
    """
    st = _records(states)
    dv = np.asarray(diverged, dtype=bool).reshape(-1)
    if st.shape[0] == 1:  # a single run: Python numbers, the same IEEE operations
        rm, rr, mr = ([v] for v in _motion_scalars(dict(zip(_NAMES, st[0].item())), bool(dv[0])))
    else:
        nm, nr = st["n_move"].astype(np.float64), st["n_rest"].astype(np.float64)
        rm = np.where(~dv, _rms(st["e2_move"], st["e2_move_c"], nm), np.nan)
        rr = np.where(~dv, _rms(st["e2_rest"], st["e2_rest_c"], nr), np.nan)
        mr = np.where((nr > 0) & ~dv, st["e_max_rest"], np.nan)
    c = run.c_run
    t_mid = 0.5 * (t[0] + t[-1]) if len(t) else math.nan
    a, b, band = (np.array(x, dtype=float) for x in run.stops)
    revs = np.array(revs, dtype=float)
    for x in (a, b, band, revs):
        x.flags.writeable = False  # shared by the scenarios' results
    t_mid, window, share, floor = float(t_mid), float(window), float(c.settle_share), float(c.settle_floor)
    # each result's fields set as the dataclass's __init__ sets them, in field order (it checks nothing): the
    # frozen class's per-field object.__setattr__ is most of the time of B results
    make, out = MotionMetrics.__new__, []
    for m, r, x, settle, stop_max, rev_max in zip(np.asarray(rm, dtype=float).tolist(),
                                                  np.asarray(rr, dtype=float).tolist(),
                                                  np.asarray(mr, dtype=float).tolist(), run.settle, run.stop_max,
                                                  run.rev_max):
        res = make(MotionMetrics)
        res.__dict__.update(rms_motion=m, rms_standstill=r, max_standstill=x, t_mid=t_mid, stop_start=a, stop_end=b,
                            settling_band=band, settling_time=settle, stop_max=stop_max, reversal_times=revs,
                            reversal_max=rev_max, window=window, share=share, floor=floor)
        out.append(res)
    return tuple(out)


def motion_metrics(t, w_ref, w, *, reversals, window: float = 0.2, share: float = SETTLE_SHARE,
                   floor: float = 0.0) -> MotionMetrics:
    """:class:`MotionMetrics` of a recorded run (the engine's accumulators, C ``ctl_motion_accumulate``).

    Parameters
    ----------
    t, w_ref, w : array_like, shape (N,)
        Time (s, increasing), reference and actual velocity (rad/s), every controller period.
    reversals : array_like, shape (R,)
        Reversal times of the reference (s), sorted (:func:`reversal_times`).
    window : float, keyword-only
        Half-width of the reversal windows (s).
    share, floor : float, keyword-only
        Settling band ``max(share * move peak, floor)`` (-, rad/s).

    Returns
    -------
    MotionMetrics
        Equal bit for bit to the engine's for the same run (the same C on the same samples).

    Raises
    ------
    SignalError
        ``t`` empty or not finite.
    ParameterError
        Shapes differ, ``window``, ``share`` or ``floor`` negative.
    """
    t = check_signal("t", t)
    n = t.shape[0]
    w_ref = np.ascontiguousarray(w_ref, dtype=np.float64)
    w = np.asarray(w, dtype=float)
    for name, a in (("w_ref", w_ref), ("w", w)):
        if a.shape != (n,):
            raise ParameterError(f"{name} must have shape ({n},), got {a.shape}")
    window = check_nonnegative("window", window)
    t = np.ascontiguousarray(t, dtype=np.float64)
    stops = stop_intervals(t, w_ref, share=share, floor=floor)
    revs, r, nrev = _revs_buffer(np.sort(np.asarray(reversals, dtype=float)))
    S = stops[0].shape[0]
    settle, stop_max, rev_max = np.empty(S), np.empty(S), np.empty(nrev)
    m, c, ev = new_metrics(), ffi.new("ctl_motion *"), ffi.new("ctl_events *")
    lib.ctl_motion_init(c, share, floor, window)
    lib.ctl_events_init(ev, ffi.from_buffer("double[]", settle), ffi.from_buffer("double[]", stop_max), S,
                        ffi.from_buffer("double[]", rev_max), nrev)
    e = np.ascontiguousarray(w_ref - w, dtype=np.float64)
    t_mid = 0.5 * (t[0] + t[-1])
    lib.ctl_motion_accumulate(m, c, ev, ffi.from_buffer("double[]", t), ffi.from_buffer("double[]", w_ref),
                              ffi.from_buffer("double[]", e), n, t_mid, r, nrev)
    return motion_result(m, stops, (settle, stop_max, revs, rev_max), t_mid=t_mid, window=window, share=share,
                         floor=floor)
