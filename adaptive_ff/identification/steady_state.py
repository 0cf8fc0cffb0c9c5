r"""Quasi-static support points of the Stribeck curve from a drive log (paper Sec. V-C, Fig. 8).

At constant velocity the joint does not accelerate and the friction lag has
settled, so ``J*dw/dt = u - f = 0`` and ``f = F(w)`` (eqs. 1-3): the mean
input torque of a constant-velocity stretch is a point of the static map
``F(w)``. The paper fits eq. 3 to such points from bidirectional quasi-static
drive experiments (:func:`adaptive_ff.identification.stribeck_fit.fit_stribeck`). Two ways
to get them from a log:

* :func:`constant_velocity_segments` — the log holds constant-velocity runs
  (e.g. a velocity loop stepping through setpoints). Runs are found as the
  longest stretches whose (moving-averaged) velocity stays within a tolerance
  of the stretch's running mean; a settling time is cut from the start of
  each; each run gives one point (mean and spread of ``w`` and ``u``).
* :func:`binned_steady_state` — a long log without designed runs. Samples at
  small acceleration (or, with a known inertia ``J``, all samples with
  ``u - J*dw/dt`` as the friction torque) are binned by velocity on a
  logarithmic grid in each direction; each bin gives one point.

:func:`support_points` picks one of them for a :class:`MeasuredData` record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from adaptive_ff.io.data import MeasuredData
from plant.errors import ExcitationError, ParameterError, check_nonnegative, check_positive, check_signal, check_time
from plant.results import axes_or_new, json_safe

__all__ = [
    "SupportPoints",
    "noise_std_estimate",
    "constant_velocity_segments",
    "binned_steady_state",
    "support_points",
    "METHODS",
]

#: Methods of :func:`support_points`.
METHODS = ("auto", "segments", "bins")

# fewest support points the Stribeck fit can use (five parameters + 1), see adaptive_ff.identification.stribeck_fit.MIN_POINTS
_MIN_POINTS = 6


@dataclass(frozen=True)
class SupportPoints:
    """Steady-state (velocity, torque) support points of the Stribeck curve.

    Attributes
    ----------
    w_mean : ndarray, shape (n,)
        Mean velocity of each run or bin (rad/s), sorted ascending.
    w_std : ndarray, shape (n,)
        Its standard deviation (rad/s).
    u_mean : ndarray, shape (n,)
        Mean torque (N·m): the friction ``F(w_mean)`` in steady state.
    u_std : ndarray, shape (n,)
        Torque spread (standard deviation, N·m): the error bars of Fig. 8.
    n_samples : ndarray of int, shape (n,)
        Samples behind each point.
    t_start, t_end : ndarray, shape (n,)
        First and last time (s) of the samples behind each point.
    method : str
        ``"segments"`` or ``"bins"``.
    notes : tuple of str
        Settings and what was discarded.
    """

    w_mean: np.ndarray
    w_std: np.ndarray
    u_mean: np.ndarray
    u_std: np.ndarray
    n_samples: np.ndarray
    t_start: np.ndarray
    t_end: np.ndarray
    method: str
    notes: tuple = field(default_factory=tuple)

    @property
    def n_points(self) -> int:
        """Number of support points."""
        return int(self.w_mean.shape[0])

    def to_dict(self) -> dict:
        """Strict-JSON dict: the arrays as lists (SI units), ``method``, ``notes``; NaN/inf as None."""
        return json_safe({"w_mean": self.w_mean, "w_std": self.w_std, "u_mean": self.u_mean, "u_std": self.u_std,
                          "n_samples": self.n_samples, "t_start": self.t_start, "t_end": self.t_end,
                          "method": self.method, "notes": list(self.notes)})

    def summary(self) -> str:
        """A few lines: number of points, velocity and torque ranges, the notes."""
        lines = [f"{self.n_points} support points of the Stribeck curve (method {self.method!r})"]
        if self.n_points:
            lines.append(f"  w from {self.w_mean.min():.4g} to {self.w_mean.max():.4g} rad/s, "
                         f"u from {self.u_mean.min():.4g} to {self.u_mean.max():.4g} N·m, "
                         f"{int(self.n_samples.sum())} samples")
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def plot(self, ax=None):
        """Mean torque over mean velocity with the torque spread as error bars (paper Fig. 8).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
        """
        ax = axes_or_new(ax, figsize=(6.0, 4.0))
        ax.errorbar(self.w_mean, self.u_mean, xerr=self.w_std, yerr=self.u_std, fmt="o", ms=4, capsize=2,
                    label=f"support points ({self.method})")
        ax.axhline(0.0, color="0.7", lw=0.5)
        ax.axvline(0.0, color="0.7", lw=0.5)
        ax.set_xlabel("velocity w (rad/s)")
        ax.set_ylabel("torque u (N·m)")
        ax.legend(loc="best")
        ax.grid(True, alpha=0.3)
        return ax


def _points(rows: list, method: str, notes: list) -> SupportPoints:
    rows = sorted(rows, key=lambda r: r[0])
    cols = list(zip(*rows)) if rows else [()] * 7
    arr = [np.asarray(c, dtype=float) for c in cols]
    return SupportPoints(w_mean=arr[0], w_std=arr[1], u_mean=arr[2], u_std=arr[3],
                         n_samples=arr[4].astype(np.int64), t_start=arr[5], t_end=arr[6], method=method,
                         notes=tuple(notes))


def noise_std_estimate(w) -> float:
    """Robust standard deviation (rad/s) of white noise on a slowly varying signal.

    ``1.4826*MAD(diff(w))/sqrt(2)``: first differences of white noise have
    twice its variance, a smooth signal sampled fast adds little, and the
    median absolute deviation (scaled to the normal standard deviation,
    Hampel 1974) ignores the few large steps of setpoint changes.

    Parameters
    ----------
    w : array_like, shape (N,), N >= 3

    Returns
    -------
    float
        >= 0 (0 for noise-free piecewise-constant data).

    Raises
    ------
    SignalError
        Fewer than 3 samples or non-finite values.
    """
    w = check_signal("w", w, min_len=3)
    d = np.diff(w)
    return 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0)


def _check_log(t, u, w):
    t = check_time("t", t, min_len=_MIN_POINTS)
    u = check_signal("u", u, n=t.shape[0])
    w = check_signal("w", w, n=t.shape[0])
    return t, u, w


def constant_velocity_segments(t, u, w, *, min_duration: float = 0.5, settle: float = 0.2, rel_tol: float = 0.05,
                               abs_tol: float | None = None) -> SupportPoints:
    """Support points from the constant-velocity runs of a log, one per run.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time stamps (s), strictly increasing (need not be uniform).
    u : array_like, shape (N,)
        Input torque (N·m).
    w : array_like, shape (N,)
        Velocity (rad/s).
    min_duration : float, keyword-only
        Shortest run kept (s), measured after ``settle``, > 0.
    settle : float, keyword-only
        Time cut from the start of each run (s), >= 0: the tail of the
        transient into the run, and the settling of the friction lag.
    rel_tol, abs_tol : float, keyword-only
        A run continues while the velocity, averaged over a centred window of
        ``L = 0.1*min_duration`` (in samples, at the median interval), stays
        within ``max(rel_tol*|m|, abs_tol)`` of the run's running mean ``m``.
        ``rel_tol`` > 0 (default 5 %); ``abs_tol`` (rad/s) >= 0, default four
        standard deviations of the averaged noise, ``4*s/sqrt(L)`` with ``s``
        from :func:`noise_std_estimate` (floored at ``1e-6*max|w|``).

    Returns
    -------
    SupportPoints
        ``method="segments"``; runs whose mean speed does not exceed
        ``abs_tol`` (standstill, ``F(0)`` is not a sliding friction) are
        dropped. May hold no points.

    Raises
    ------
    SignalError
        Bad ``t``, ``u``, ``w``.
    ParameterError
        A setting out of range.

    Notes
    -----
    Greedy segmentation of piecewise-constant signals: each run is extended
    sample by sample while the next averaged sample agrees with the running
    mean; the moving average (``scipy.ndimage.uniform_filter1d``) keeps noise
    spikes from splitting a run and lets close setpoints be told apart.
    Statistics are of the raw samples. Source of the
    experiment: Ruderman, Sec. V-C.
    """
    from scipy.ndimage import uniform_filter1d

    t, u, w = _check_log(t, u, w)
    min_duration = check_positive("min_duration", min_duration)
    settle = check_nonnegative("settle", settle)
    rel_tol = check_positive("rel_tol", rel_tol)
    sd = noise_std_estimate(w)
    m_avg = max(1, int(round(min(0.1 * min_duration / float(np.median(np.diff(t))), t.shape[0]))))
    if abs_tol is None:
        abs_tol = max(4.0 * sd / math.sqrt(m_avg), 1e-6 * float(np.max(np.abs(w))))
    else:
        abs_tol = check_nonnegative("abs_tol", abs_tol)
    wf = uniform_filter1d(w, m_avg, mode="nearest")
    n = w.shape[0]
    rows, n_short, n_still = [], 0, 0
    wl = wf.tolist()
    i = 0
    while i < n:
        s = wl[i]
        j = i + 1
        while j < n:
            m = s / (j - i)
            if abs(wl[j] - m) > max(rel_tol * abs(m), abs_tol):
                break
            s += wl[j]
            j += 1
        # samples i .. j-1 form a run
        k0 = int(np.searchsorted(t, t[i] + settle - 1e-12 * max(1.0, abs(t[i]))))
        if k0 < j and t[j - 1] - t[k0] >= min_duration * (1 - 1e-9):
            ws, us = w[k0:j], u[k0:j]
            wm = float(ws.mean())
            if abs(wm) > abs_tol:
                rows.append((wm, float(ws.std()), float(us.mean()), float(us.std()), j - k0, float(t[k0]),
                             float(t[j - 1])))
            else:
                n_still += 1
        elif j - i > 1:
            n_short += 1
        i = j
    notes = [f"constant-velocity runs: tolerance max({rel_tol:g}*|mean|, {abs_tol:.3g} rad/s), settle {settle:g} s, "
             f"min duration {min_duration:g} s; {len(rows)} runs kept, {n_still} at standstill dropped, "
             f"{n_short} shorter stretches dropped"]
    return _points(rows, "segments", notes)


def binned_steady_state(data: MeasuredData, *, n_bins: int = 12, w_min: float | None = None, max_accel: float | None = None,
                        J: float | None = None, min_count: int = 20, smooth_time: float | None = None
                        ) -> SupportPoints:
    """Support points by binning the (quasi-)steady-state samples of a long log by velocity.

    Parameters
    ----------
    data : MeasuredData
        The log: time ``t`` (s), input torque ``u`` (N·m), velocity ``w`` (rad/s), shape (N,) each.
    n_bins : int, keyword-only
        Logarithmic velocity bins per direction (>= 1, at most the samples of the log), between ``w_min`` and
        ``max|w|``.
    w_min : float, keyword-only, optional
        Smallest speed binned (rad/s), > 0. Default ``max(4*noise, 1e-3*max|w|)``
        with the noise of :func:`noise_std_estimate`: slower samples are
        indistinguishable from standstill.
    max_accel : float, keyword-only, optional
        Samples with ``|dw/dt| > max_accel`` (rad/s²) are dropped, > 0.
        Default: without ``J``, 5 % of the 99th percentile of ``|dw/dt|``;
        with ``J``, no limit.
    J : float, keyword-only, optional
        Inertia (kg·m²), > 0. If given, each sample's friction torque is
        ``u - J*dw/dt`` (eq. 1 with the lag neglected), so accelerating
        samples can be used too.
    min_count : int, keyword-only
        Fewest samples for a bin to count (>= 2).
    smooth_time : float, keyword-only, optional
        Length (s) of the Savitzky-Golay window (order 2) that smooths ``w``
        before differentiating it; default 20 median sample intervals.

    Returns
    -------
    SupportPoints
        ``method="bins"``, bins with at least ``min_count`` samples, sorted
        by velocity. ``u_mean``/``u_std`` are of ``u`` (or of ``u - J*dw/dt``).

    Raises
    ------
    TypeError
        ``data`` not a :class:`MeasuredData`.
    SignalError
        Fewer than 6 samples in ``data``.
    ParameterError
        A setting out of range.

    Notes
    -----
    Acceleration: ``scipy.signal.savgol_filter`` (Savitzky & Golay 1964) on
    the samples, then ``numpy.gradient`` with the actual time stamps (non-uniform
    allowed). Bins are chosen by the measured velocity, so with velocity
    noise comparable to the lowest speeds the bin means are biased (errors in
    variables: the bin edges cut the noise distribution); prefer
    :func:`constant_velocity_segments` for noisy logs with designed runs.
    The steady-state condition ``J*dw/dt << F`` underlies the
    paper's quasi-static experiments (Sec. V-C); binning a long log is the
    usual substitute when no such experiments exist.
    """
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    t, u, w = _check_log(data.t, data.u, data.w)
    if isinstance(n_bins, bool) or not isinstance(n_bins, (int, np.integer)) or n_bins < 1:
        raise ParameterError(f"n_bins must be an integer >= 1, got {n_bins!r}")
    if n_bins > t.shape[0]:  # more bins than samples cannot hold a sample each
        raise ParameterError(f"n_bins = {n_bins!r} is more than the log's {t.shape[0]} samples")
    if isinstance(min_count, bool) or not isinstance(min_count, (int, np.integer)) or min_count < 2:
        raise ParameterError(f"min_count must be an integer >= 2, got {min_count!r}")
    a = _smoothed_acceleration(t, w, smooth_time)
    F = u.copy()
    notes = []
    if J is not None:
        J = check_positive("J", J)
        F = u - J * a
        notes.append(f"friction torque u - J*dw/dt with J = {J:g} kg·m²")
    if max_accel is None:
        max_accel = math.inf if J is not None else 0.05 * float(np.percentile(np.abs(a), 99))
        if max_accel == 0.0:
            max_accel = math.inf
    else:
        max_accel = check_positive("max_accel", max_accel)
    aw = np.abs(w)
    top = float(aw.max())
    if w_min is None:
        w_min = max(4.0 * noise_std_estimate(w), 1e-3 * top)
    else:
        w_min = check_positive("w_min", w_min)
    if not top > w_min:
        raise ExcitationError(f"the log never moves faster than w_min = {w_min:.3g} rad/s (max |w| = {top:.3g})")
    keep = (np.abs(a) <= max_accel) & (aw >= w_min)
    edges = np.geomspace(w_min, top * (1 + 1e-12), n_bins + 1)
    rows = _bin_rows(t, w, F, keep, edges, min_count)
    notes.insert(0, f"velocity bins: {n_bins} per direction, log-spaced {w_min:.3g}..{top:.3g} rad/s; |dw/dt| <= "
                    f"{max_accel:.3g} rad/s²; {int(keep.sum())} of {w.shape[0]} samples used; min {min_count} per bin")
    return _points(rows, "bins", notes)


def _smoothed_acceleration(t, w, smooth_time):
    """``dw/dt`` (rad/s²): Savitzky-Golay smoothing (order 2, window ``smooth_time`` s, default 21 samples),
    then ``numpy.gradient`` on the actual time stamps."""
    from scipy.signal import savgol_filter

    T = float(np.median(np.diff(t)))
    n = w.shape[0]
    win = 21 if smooth_time is None else int(round(check_positive("smooth_time", smooth_time) / T))
    win = max(win, 5)
    win += 1 - win % 2  # odd
    if win > n:
        win = n if n % 2 else n - 1
    ws = savgol_filter(w, win, 2) if win >= 5 else w
    return np.gradient(ws, t)


def _bin_rows(t, w, F, keep, edges, min_count) -> list:
    """One support-point row per direction and velocity bin (``edges`` on ``|w|``) with ``min_count`` samples."""
    aw = np.abs(w)
    rows = []
    for sgn in (-1.0, 1.0):
        sel = keep & (np.sign(w) == sgn)
        idx = np.searchsorted(edges, aw[sel], side="right") - 1
        tt, ww, FF = t[sel], w[sel], F[sel]
        for b in range(edges.shape[0] - 1):
            m = idx == b
            c = int(m.sum())
            if c >= min_count:
                rows.append((float(ww[m].mean()), float(ww[m].std()), float(FF[m].mean()), float(FF[m].std()), c,
                             float(tt[m].min()), float(tt[m].max())))
    return rows


def support_points(data: MeasuredData, *, method: str = "auto", **options) -> SupportPoints:
    """Support points of the Stribeck curve from a measured record.

    Parameters
    ----------
    data : MeasuredData
        The log (``t`` s, ``u`` N·m, ``w`` rad/s).
    method : {"auto", "segments", "bins"}, keyword-only
        ``segments``: :func:`constant_velocity_segments`; ``bins``:
        :func:`binned_steady_state`; ``auto``: segments if they give at
        least 6 points, else bins.
    **options
        Keyword settings of the chosen function (for ``auto``, each function
        receives the settings it accepts).

    Returns
    -------
    SupportPoints

    Raises
    ------
    TypeError
        ``data`` not a :class:`MeasuredData`, or an option the method does not take.
    ParameterError
        Unknown ``method`` or a bad setting.
    ExcitationError
        Fewer than 6 points (the Stribeck fit needs 6); the message says
        what was found.
    """
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    if method not in METHODS:
        raise ParameterError(f"method must be one of {list(METHODS)}, got {method!r}")
    seg_keys = {"min_duration", "settle", "rel_tol", "abs_tol"}
    bin_keys = {"n_bins", "w_min", "max_accel", "J", "min_count", "smooth_time"}
    if method == "segments":
        pts = constant_velocity_segments(data.t, data.u, data.w, **options)
    elif method == "bins":
        pts = binned_steady_state(data, **options)
    else:
        unknown = set(options) - seg_keys - bin_keys
        if unknown:
            raise TypeError(f"unknown option(s) {sorted(unknown)} for support_points")
        pts = constant_velocity_segments(data.t, data.u, data.w, **{k: v for k, v in options.items() if k in seg_keys})
        if pts.n_points < _MIN_POINTS:
            seg_note = pts.notes
            pts = binned_steady_state(data, **{k: v for k, v in options.items() if k in bin_keys})
            pts = replace(pts, notes=seg_note + ("too few runs; binned instead",) + pts.notes)
    if pts.n_points < _MIN_POINTS:
        raise ExcitationError(f"{data.source or 'data'}: only {pts.n_points} support point(s) found by "
                              f"{pts.method!r}, the Stribeck fit needs {_MIN_POINTS}: {'; '.join(pts.notes)}")
    return pts
