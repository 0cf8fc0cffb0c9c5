"""Figures of a comparison run (PNG): a reversal up close, error per mode, Stribeck map, parameters, eta.

What a control engineer looks at first, one file each (:func:`plot_comparison`):

* ``tracking.png`` — the whole run (reference and the uncompensated velocity), and
  the reference reversal of the metrics window with the largest uncompensated
  error up close: reference, ``none``, ``fixed``, ``adaptive``, ``frictionless``
  velocity and their tracking errors (:func:`plot_tracking`); for a reference
  with stops (point-to-point moves) the dwells shaded and, up close, the stop
  of the metrics window with the longest settling, its band and each mode's
  settling time (:func:`pick_stop`);
* ``error.png`` — the tracking error of every mode as small multiples on one
  shared scale, drawn as min/max envelopes (:func:`plot_error`); with stops,
  the dwells shaded and each mode's RMS error in motion and longest settling
  time written in its panel;
* ``friction.png`` — the estimated friction as a Stribeck map, torque over
  velocity, estimate vs truth at a few times of the run (:func:`plot_friction`);
* ``rls_convergence.png`` — every parameter of the adaptive estimator with its
  unit, the true value dashed (:func:`plot_rls_convergence`, cf. paper Fig. 12);
* ``eta.png`` — the compensation efficiency eta and ``rms_dev`` (RMS of
  ``w - w_frictionless``) per mode (:func:`plot_eta`).

Colours are the Okabe-Ito palette (Okabe and Ito, "Color Universal Design",
2008), distinguishable with the common colour-vision deficiencies; one colour
per mode in every figure (:data:`MODE_COLORS`). Long records are drawn as
min/max envelopes over display bins (:func:`minmax_envelope`), so a 120 s run
at 1 kHz costs a few thousand vertices, and the figures use fixed margins
instead of a layout engine (both for speed). :func:`plot_comparison` is
:func:`figure_inputs` (what each figure shows, taken from the runs: well under
1 MB for a 120 s run) followed by :func:`draw_figures` (matplotlib), which
draws them one after the other, or in a ``concurrent.futures`` process pool
(``jobs``) that is sent the inputs, not the runs. Velocities are shown in
deg/s, torques in N·m.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Callable, NamedTuple

import numpy as np

from adaptive_ff.io.units import PARAMETER_UNITS
from plant.errors import ParameterError, SignalError

if TYPE_CHECKING:  # annotations only: matplotlib is imported by the functions when they run
    from matplotlib.figure import Figure

__all__ = ["plot_comparison", "figure_inputs", "draw_figures", "rls_grid", "plot_tracking", "plot_error",
           "plot_friction", "plot_rls_convergence", "plot_eta", "rms_dev", "minmax_envelope", "pick_reversal",
           "estimate_history", "MODE_COLORS", "PARAMETER_UNITS", "pick_stop"]

#: One Okabe-Ito colour per compensation mode (reference black, frictionless grey).
MODE_COLORS = {"reference": "#000000", "none": "#D55E00", "fixed": "#0072B2", "adaptive": "#009E73",
               "canudas": "#E69F00", "dob": "#CC79A7", "oracle": "#56B4E9", "frictionless": "#7A7A7A"}
_SPARE_COLORS = ("#332288", "#882255", "#44AA99", "#999933", "#AA4499")  # Tol's muted: for modes added later


_DPI = 100
_BINS = 1500  # display bins of an envelope: about two per pixel column of a 9 in figure at 100 dpi
_ZOOM_MODES = ("none", "fixed", "adaptive", "frictionless")


def mode_color(mode: str, index: int = 0) -> str:
    """Colour of ``mode`` (:data:`MODE_COLORS`; unknown modes take a spare colour by ``index``)."""
    return MODE_COLORS.get(mode, _SPARE_COLORS[index % len(_SPARE_COLORS)])


def minmax_envelope(t, y, *, n_bins: int = _BINS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Min/max envelope of a long record for display: ``n_bins`` bins, the extremes of each.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time (s), increasing.
    y : array_like, shape (N,)
        Signal, any unit; NaN samples (a diverged run) are ignored, a bin of NaN only stays NaN.
    n_bins : int, keyword-only
        Number of bins, >= 1; records of at most ``2*n_bins`` samples are returned as they are.

    Returns
    -------
    tc, lo, hi : ndarray, shape (M,)
        Bin start times (s) and the smallest and largest sample of each bin
        (``lo == hi == y`` for short records). Every sample lies in one bin, so
        ``fill_between(tc, lo, hi)`` covers every extreme of the record.

    Raises
    ------
    SignalError
        ``t`` and ``y`` of different lengths.
    ParameterError
        ``n_bins`` < 1.

    Notes
    -----
    The standard trick of waveform viewers (e.g. the M4 aggregation of Jugel et
    al., "M4: a visualization-oriented time series data aggregation", VLDB 2014,
    reduced to min and max).
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    y = np.asarray(y, dtype=float).reshape(-1)
    if t.shape != y.shape:
        raise SignalError(f"t and y must have the same length, got {t.shape[0]} and {y.shape[0]}")
    if isinstance(n_bins, bool) or not isinstance(n_bins, (int, np.integer)) or n_bins < 1:
        raise ParameterError(f"n_bins must be an integer >= 1, got {n_bins!r}")
    n = t.shape[0]
    if n <= 2 * n_bins:
        return t, y, y
    k = -(-n // n_bins)  # samples per bin (last bin shorter)
    pad = k * (-(-n // k)) - n
    yp = np.concatenate([y, np.full(pad, np.nan)]).reshape(-1, k)
    return t[::k], np.fmin.reduce(yp, axis=1), np.fmax.reduce(yp, axis=1)


#: Style of these figures: titles at a fixed height (no tight-bbox search per axes at draw time).
_RC = {"axes.titley": 1.0, "axes.titlepad": 4.0, "axes.titlesize": 9, "axes.labelsize": 9, "xtick.labelsize": 8,
       "ytick.labelsize": 8, "legend.fontsize": 8}


def _styled(fn):
    """Run a figure function under :data:`_RC` (a ``matplotlib.rc_context``; the figure keeps the style)."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        import matplotlib

        with matplotlib.rc_context(_RC):
            return fn(*args, **kwargs)

    return wrapper


def _new_figure(width: float, height: float, *, left: float = 0.8, right: float = 0.25, top: float = 0.4,
                bottom: float = 0.5) -> Figure:
    """A pyplot-free figure of ``width`` x ``height`` inches with fixed margins (inches), no layout engine."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=_DPI)
    fig.subplots_adjust(left=left / width, right=1.0 - right / width, top=1.0 - top / height,
                        bottom=bottom / height)
    return fig


def _legend_right(fig, ax, handles=None, labels=None, **kw):
    """Legend outside the axes, to the right of ``ax`` (never over the data)."""
    h, lab = ax.get_legend_handles_labels() if handles is None else (handles, labels)
    return ax.legend(h, lab, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=8,
                     frameon=False, **kw)


def _hex_rgb(color: str) -> tuple:
    """``"#RRGGBB"`` as RGB in [0, 1], as ``matplotlib.colors.to_rgb`` gives it (no matplotlib import: the figure
    inputs are taken where matplotlib is not loaded)."""
    return tuple(int(color[i:i + 2], 16) / 255 for i in (1, 3, 5))


def _deg(x):
    return np.rad2deg(np.asarray(x, dtype=float))


# --------------------------------------------------------------------------- metrics shown in the figures


def rms_dev(comp) -> dict:
    """RMS deviation of each mode's velocity from the frictionless run's, ``RMS(w - w_frictionless)`` (rad/s).

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison
        With a ``frictionless`` run (same reference and noise in every mode).

    Returns
    -------
    dict
        ``{mode: float}`` over the whole run (rad/s); NaN for a diverged run.
        Taken from ``comp.rows()`` when the comparison reports ``rms_dev``
        itself, else computed from the recorded velocities.

    Raises
    ------
    ParameterError
        No ``frictionless`` run.
    """
    rows = comp.rows()
    if rows and all("rms_dev" in r for r in rows):
        return {r["mode"]: float(r["rms_dev"]) for r in rows}
    ref = comp.results.get("frictionless")
    if ref is None:
        raise ParameterError("rms_dev needs the 'frictionless' run in the comparison")
    from controllers.simulation.metrics import deviation_rms  # the one implementation (compare's rows use it)

    return {mode: deviation_rms(r.w, ref.w) for mode, r in comp.results.items()}


def _motion_runs(comp) -> dict:
    """``{mode: MotionMetrics}`` of the runs whose reference has stops (point-to-point moves); empty otherwise."""
    return {m: r.motion for m, r in comp.results.items() if getattr(r, "has_stops", False)}


def pick_stop(comp, *, half_window: float = 1.0) -> float | None:
    """Start time (s) of the reference stop to show up close, or None when the reference has no stops or its second
    half holds more reversals than stops (then :func:`pick_reversal` chooses).

    Among the stops of the second half (the metrics window), the one with the longest settling time of the modes
    drawn up close (``none``, ``fixed``, ``adaptive``; a stop that did not settle counts as longest), ties to the
    earliest; without stops in the second half, among all. ``half_window`` is the zoom's half-width (s), kept for
    the signature of :func:`pick_reversal` (the zoom may reach past the run's ends).
    """
    motion = _motion_runs(comp)
    if not motion:
        return None
    mm = next(iter(motion.values()))
    a, t_mid = mm.stop_start, mm.t_mid
    if np.count_nonzero(mm.reversal_times >= t_mid) > np.count_nonzero(a >= t_mid):
        return None  # a motion of reversals (constant speed, reversed): the reversal is what to look at
    shown = [motion[m] for m in _ZOOM_MODES if m in motion and m != "frictionless"] or list(motion.values())
    score = np.nanmax(np.stack([np.nan_to_num(x.settling_time, nan=-1.0) for x in shown]), axis=0)
    for ok in (a >= t_mid, np.ones(a.shape, bool)):
        if ok.any():
            i = np.flatnonzero(ok)[int(np.argmax(score[ok]))]
            return float(a[i])
    return None  # pragma: no cover - a run with stops has at least one


def pick_reversal(comp, *, half_window: float = 1.0) -> float:
    """Time (s) of the reference reversal to show up close: the largest uncompensated error, in the metrics window.

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison
    half_window : float, keyword-only
        Half-width (s) of the zoom; reversals closer than that to either end are skipped.

    Returns
    -------
    float
        Among the sign changes of the reference in the second half of the run
        (the metrics window) with no other sign change within ``±half_window``,
        the one whose window has the largest RMS error of the ``none`` run.
        Falls back to any reversal of the second half, then of the whole run;
        with none at all, three quarters of the run.
    """
    r = comp.results["none"] if "none" in comp.results else next(iter(comp.results.values()))
    t, e = np.asarray(r.t), np.asarray(r.w_ref) - np.asarray(r.w)
    s = np.sign(r.w_ref)
    tr = t[np.flatnonzero(s[1:] * s[:-1] < 0) + 1]
    gap = np.diff(tr, prepend=-np.inf, append=np.inf)
    isolated = tr[(gap[:-1] > half_window) & (gap[1:] > half_window)]  # one clean sign change in the window
    cands = np.array([])
    for pool, start in ((isolated, 0.5 * t[-1]), (tr, 0.5 * t[-1]), (isolated, 0.0), (tr, 0.0)):
        cands = pool[(pool >= max(half_window, start)) & (pool <= t[-1] - half_window)]
        if cands.size:
            break
    if cands.size == 0:
        return float(0.75 * t[-1])
    lo = np.searchsorted(t, cands - half_window)
    hi = np.searchsorted(t, cands + half_window)
    c2 = np.concatenate([[0.0], np.cumsum(np.nan_to_num(e) ** 2)])
    score = (c2[hi] - c2[lo]) / np.maximum(hi - lo, 1)
    return float(cands[int(np.argmax(score))])


# --------------------------------------------------------------------------- figures
#
# Each figure is two functions: ``_<name>_inputs(comp)`` takes from the comparison what the figure shows (min/max
# envelopes, the zoom window, curves, histories: a few hundred kB, plain numbers and arrays), and ``_draw_<name>``
# draws them with matplotlib (on ``_<name>_skeleton``, the data-free part: figure, axes, fixed labels, grids).
# :func:`figure_inputs` and :func:`draw_figures` are the two halves of :func:`plot_comparison`, so that a process
# pool can draw from the inputs alone.


def _tracking_inputs(comp, *, half_window: float = 1.0) -> dict:
    """What :func:`plot_tracking` draws: the zoom time, whole-run envelopes and the zoom window of each mode (and,
    for a reference with stops, the dwells and the zoomed stop's band and settling times)."""
    motion = _motion_runs(comp)
    stop = pick_stop(comp, half_window=half_window)
    t0 = stop if stop is not None else pick_reversal(comp, half_window=half_window)
    base = comp.results["none"] if "none" in comp.results else next(iter(comp.results.values()))
    sel = slice(*np.searchsorted(base.t, [t0 - half_window, t0 + half_window]))
    zoom = []
    for i, mode in enumerate(m for m in _ZOOM_MODES if m in comp.results):
        r = comp.results[mode]
        zoom.append((mode, mode_color(mode, i), r.t[sel].copy(), _deg(r.w[sel]), _deg(r.w_ref[sel] - r.w[sel])))
    d = {"t0": t0, "half_window": half_window, "mode": base.mode, "t_span": (base.t[0], base.t[-1]),
         "reference": minmax_envelope(base.t, _deg(base.w_ref)), "w": minmax_envelope(base.t, _deg(base.w)),
         "zoom_t": base.t[sel].copy(), "zoom_reference": _deg(base.w_ref[sel]), "zoom": zoom}
    if motion:
        mm = next(iter(motion.values()))
        d["stops"] = (mm.stop_start.copy(), mm.stop_end.copy())
    if motion and stop is not None:
        i = int(np.flatnonzero(mm.stop_start == stop)[0])
        d["zoom_stop"] = {"t_end": float(mm.stop_end[i]), "band": float(_deg(mm.settling_band[i])),
                          "settle": {m: float(motion[m].settling_time[i]) for m, *_ in zoom if m in motion}}
    return d


@_styled
def _tracking_skeleton():
    """The data-free part of :func:`_draw_tracking`: the figure, its three axes, fixed labels and grids."""
    fig = _new_figure(9.0, 7.0, right=1.55, top=0.35)
    outer = fig.add_gridspec(2, 1, height_ratios=[1.0, 2.9], hspace=0.42)
    inner = outer[1].subgridspec(2, 1, height_ratios=[1.6, 1.0], hspace=0.08)
    ax0 = fig.add_subplot(outer[0])
    ax1 = fig.add_subplot(inner[0])
    ax2 = fig.add_subplot(inner[1], sharex=ax1)
    ax0.set_ylabel("w [deg/s]")
    ax0.set_xlabel("time [s]", labelpad=1)
    ax0.set_title("whole run", fontsize=9, loc="left")
    ax1.set_ylabel("w [deg/s]")
    ax1.tick_params(labelbottom=False)
    ax2.set_ylabel("w_ref − w [deg/s]")
    ax2.set_xlabel("time [s]")
    for ax in (ax0, ax1, ax2):
        ax.grid(True, alpha=0.3, lw=0.5)
    return fig, (ax0, ax1, ax2)


@_styled
def _draw_tracking(d: dict) -> Figure:
    t0, half_window = d["t0"], d["half_window"]
    fig, (ax0, ax1, ax2) = _tracking_skeleton()
    tc, lo, hi = d["reference"]
    ax0.fill_between(tc, lo, hi, color="k", lw=0.6, label="reference", step="post")
    tc, lo, hi = d["w"]
    ax0.fill_between(tc, lo, hi, color=mode_color(d["mode"]), alpha=0.8, lw=0.6, label=f"{d['mode']}",
                     step="post")
    ax0.axvspan(t0 - half_window, t0 + half_window, color="#F0E442", alpha=0.6, lw=0, label="zoom below")
    for j, (a, b) in enumerate(zip(*d.get("stops", ((), ())))):
        ax0.axvspan(a, b, color="0.8", lw=0, zorder=0, label="dwell (stop)" if j == 0 else None)
    ax0.set_xlim(*d["t_span"])
    _legend_right(fig, ax0)
    ax1.plot(d["zoom_t"], d["zoom_reference"], color="k", ls="--", lw=1.4, label="reference")
    for mode, color, t, w, e in d["zoom"]:
        lw = 1.0 if mode == "frictionless" else 1.5
        ax1.plot(t, w, color=color, lw=lw, label=mode)
        ax2.plot(t, e, color=color, lw=lw, label=mode)
    ax1.axhline(0.0, color="0.6", lw=0.6, zorder=0)
    ax2.axhline(0.0, color="0.6", lw=0.6, zorder=0)
    zs = d.get("zoom_stop")
    if zs is None:
        ax1.set_title(f"reversal at t = {t0:.2f} s (of the metrics window, largest error without compensation)",
                      fontsize=9, loc="left")
    else:
        for ax in (ax1, ax2):
            ax.axvspan(t0, zs["t_end"], color="0.85", lw=0, zorder=0)
        for y in (-zs["band"], zs["band"]):
            ax2.axhline(y, color="k", lw=0.6, ls=":")
        colors = {mode: color for mode, color, *_ in d["zoom"]}
        for mode, ts in zs["settle"].items():
            if math.isfinite(ts):
                ax2.axvline(t0 + ts, color=colors[mode], lw=1.0, ls="--")
        unset = [m for m, ts in zs["settle"].items() if math.isinf(ts)]
        note = f"; not settled: {', '.join(unset)}" if unset else ""
        ax1.set_title(f"stop at t = {t0:.2f} s (longest settling, second half; dwell shaded)\nerror: band "
                      f"±{zs['band']:.3g} deg/s dotted, settled dashed{note}", fontsize=9, loc="left")
    ax1.set_xlim(t0 - half_window, t0 + half_window)
    _legend_right(fig, ax1)
    return fig


def plot_tracking(comp, *, half_window: float = 1.0) -> Figure:
    """The whole run, and one reversal up close with every mode of interest (velocities in deg/s).

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison
    half_window : float, keyword-only
        Half-width (s) of the zoom around the reversal of :func:`pick_reversal`.

    Returns
    -------
    matplotlib.figure.Figure
        Top: reference and ``none`` velocity over the whole run (deg/s over s;
        min/max envelopes, :func:`minmax_envelope`), the zoom window shaded.
        Middle: reference and the velocity of ``none``, ``fixed``,
        ``adaptive``, ``frictionless`` (those that ran) around the reversal,
        every sample. Bottom: their tracking errors ``w_ref - w`` there.
        For a reference with stops (:func:`pick_stop`) the zoom is on a stop
        instead: the dwells shaded (top and zoom), the stop's settling band
        dotted and each mode's settling time dashed on the error panel
        (:class:`controllers.simulation.metrics.MotionMetrics`).
    """
    return _draw_tracking(_tracking_inputs(comp, half_window=half_window))


def _error_inputs(comp) -> dict:
    """What :func:`plot_error` draws: the envelope of each mode's tracking error (deg/s), its RMS, the run's end;
    for a reference with stops the dwells and each mode's RMS in motion (deg/s) and longest settling time (s)."""
    modes, runs = list(comp.results), comp.results.items()
    d = {"modes": modes, "envelopes": {m: minmax_envelope(r.t, _deg(r.w_ref - r.w)) for m, r in runs},
         "rms": {m: _deg(r.metrics.rms_second_half) for m, r in runs}, "t_end": comp.results[modes[0]].t[-1]}
    motion = _motion_runs(comp)
    if motion:
        mm = next(iter(motion.values()))
        d["stops"] = (mm.stop_start.copy(), mm.stop_end.copy())
        d["motion"] = {m: (float(_deg(x.rms_motion)), x.settling_max, x.n_unsettled) for m, x in motion.items()}
    return d


@_styled
def _error_skeleton(n: int):
    """The data-free part of :func:`_draw_error` for ``n`` modes: the panels, their locators, labels and grids."""
    from matplotlib.ticker import MaxNLocator, NullLocator

    fig = _new_figure(9.0, 0.95 * n + 0.9, left=0.85, right=0.25, top=0.35, bottom=0.5)
    axes = np.atleast_1d(fig.subplots(n, 1, sharey=True, gridspec_kw={"hspace": 0.12}))
    axes[0].yaxis.set_major_locator(MaxNLocator(nbins=2, symmetric=True))  # shared: 3 ticks on every panel
    for i, ax in enumerate(axes):
        ax.set_ylabel("e [deg/s]", fontsize=8)
        if i < n - 1:
            ax.xaxis.set_major_locator(NullLocator())  # the time axis is read on the bottom panel
        ax.grid(True, alpha=0.3, lw=0.5)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title("tracking error e = w_ref − w per mode (grey: frictionless; right of the dotted line: "
                      "metrics window)", fontsize=9, loc="left")
    return fig, axes


@_styled
def _draw_error(d: dict) -> Figure:
    modes, env = d["modes"], d["envelopes"]
    fig, axes = _error_skeleton(len(modes))
    fl = env.get("frictionless")
    peak = max((float(np.nanmax(np.abs(np.concatenate([lo, hi])))) for _, lo, hi in env.values()
                if np.isfinite(lo).any()), default=1.0)
    t_end = d["t_end"]
    for i, (ax, mode) in enumerate(zip(axes, modes)):
        tc, lo, hi = env[mode]
        if fl is not None and mode != "frictionless":
            ax.fill_between(fl[0], fl[1], fl[2], color=mode_color("frictionless"), alpha=0.45, lw=0, step="post")
        ax.fill_between(tc, lo, hi, color=mode_color(mode, i), lw=0.5, step="post")
        ax.axvline(0.5 * t_end, color="k", lw=0.6, ls=":")
        for a, b in zip(*d.get("stops", ((), ()))):
            ax.axvspan(a, b, color="0.9", lw=0, zorder=0)
        rms = d["rms"][mode]
        ax.text(0.005, 0.93, f"{mode}", transform=ax.transAxes, fontsize=9, fontweight="bold", va="top")
        x, text = 0.51, f"RMS {rms:.3f} deg/s (second half)"
        if mode in d.get("motion", {}):
            rm, smax, unset = d["motion"][mode]
            settle = (f"{unset} stop(s) not settled" if math.isinf(smax) else
                      "no stop" if math.isnan(smax) else f"settling max {smax:.3f} s")
            x, text = 0.3, f"RMS {rms:.3f} deg/s, in motion {rm:.3f} deg/s, {settle} (second half)"
        ax.text(x, 0.93, text, transform=ax.transAxes, fontsize=8, va="top")
        ax.set_xlim(0.0, t_end)
    if "stops" in d:
        axes[0].set_title("tracking error e = w_ref − w per mode (grey: frictionless; shaded: stops; right of the "
                          "dotted line: metrics window)", fontsize=9, loc="left")
    lim = 1.15 * peak if math.isfinite(peak) and peak > 0 else 1.0
    axes[0].set_ylim(-lim, lim)
    return fig


def plot_error(comp) -> Figure:
    """Tracking error of every mode as small multiples, one shared scale (deg/s over s).

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison

    Returns
    -------
    matplotlib.figure.Figure
        One panel per mode, the min/max envelope of ``w_ref - w``
        (:func:`minmax_envelope`) in the mode's colour over the frictionless
        run's envelope (grey), the metrics window (second half) marked and its
        RMS error written in the panel; for a reference with stops the dwells
        shaded and the RMS error in motion and the longest settling time of the
        second half written too.
    """
    return _draw_error(_error_inputs(comp))


def _estimator_model(comp, r):
    """The regression of an eq. 4 estimator's ``theta`` in result ``r``: the identification's model with the
    estimator's own offset column (``o1`` in ``r.info["names"]``); None for the sliding estimator."""
    from adaptive_ff.identification.regression import RegressionModel

    if r.info.get("estimator") == "sliding":
        return None
    m = comp.model
    return RegressionModel(m.Vs, m.delta, lag=m.lag, stribeck=m.stribeck, offset="o1" in r.info.get("names", ()))


def estimate_history(comp, times) -> list:
    """The adaptive mode's friction estimate at given times, as physical parameters.

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison
    times : sequence of float
        Times (s); each takes the last estimator update at or before it.

    Returns
    -------
    list of dict
        ``{"t", "Fc", "Fs", "Vs", "delta", "sigma", "offset"}`` per time (SI
        units; ``Vs``, ``delta`` the fixed pre-fit values the estimator used),
        skipping times before the first update; empty without an adaptive run.
    """
    r = comp.results.get("adaptive")
    if r is None or r.theta.size == 0:
        return []
    Vs, delta = comp.model.Vs, comp.model.delta
    names = list(r.info.get("names", ()))
    m = _estimator_model(comp, r)
    out = []
    for ti in times:
        k = int(np.searchsorted(r.t_theta, ti, side="right")) - 1
        if k < 0:
            continue
        th = r.theta[k]
        if r.info.get("estimator") == "sliding":
            v = dict(zip(names, (float(x) for x in th)))
        else:
            e = m.to_physical(th, r.info["Ts"])
            v = {"Fc": e.Fc, "Fs": e.Fs, "sigma": e.sigma, "offset": e.offset}
        if not all(math.isfinite(v.get(n, 0.0)) for n in ("Fc", "Fs", "sigma", "offset")):
            continue
        out.append({"t": float(r.t_theta[k]), "Fc": v["Fc"], "Fs": v["Fs"], "sigma": v["sigma"],
                    "offset": v.get("offset", 0.0), "Vs": Vs, "delta": delta})
    return out


def _estimate_curve(e: dict, w):
    from plant.stribeck_map import stribeck  # the one map of eq. 3 (imported here: drawing alone loads no C module)

    return stribeck(w, Fc=e["Fc"], Fs=e["Fs"], Vs=e["Vs"], delta=e["delta"], sigma=e["sigma"]) + e["offset"]


def _friction_inputs(comp, *, times=(0.05, 0.15, 0.5, 1.0)) -> dict:
    """What :func:`plot_friction` draws: per column the velocity grid (deg/s), the true map and each estimate's."""
    p = comp.plant
    r0 = next(iter(comp.results.values()))
    peak = float(np.nanmax(np.abs(r0.w_ref))) * 1.1
    t_end = float(r0.t[-1])
    p_end = p.at(t_end) if hasattr(p, "at") else p
    p_start = p.at(0.0) if hasattr(p, "at") else p
    Vs = float(comp.model.Vs if comp.model.Vs is not None else getattr(p_end, "Vs", 0.02))
    curves = []  # (label, colour, linestyle, parameters)
    if comp.offline is not None:
        e = comp.offline.estimate
        curves.append(("fixed (offline fit)", mode_color("fixed"), "--",
                       {"Fc": e.Fc, "Fs": e.Fs, "sigma": e.sigma, "offset": e.offset, "Vs": comp.model.Vs,
                        "delta": comp.model.delta}))
    hist = estimate_history(comp, [t_end * f for f in times])
    base = np.array(_hex_rgb(mode_color("adaptive")))
    for j, e in enumerate(hist):
        shade = 0.3 + 0.7 * (j + 1) / len(hist)
        curves.append((f"adaptive at t = {e['t']:.0f} s", tuple(1 - shade * (1 - base)), "-", e))
    columns = []
    for wmax in (peak, min(5.0 * Vs, peak)):
        w = np.linspace(-wmax, wmax, 801)
        columns.append({"wd": _deg(w), "truth": p_end.friction(w),
                        "start": p_start.friction(w) if p_start is not p_end else None,
                        "curves": [(label, color, ls, _estimate_curve(e, w)) for label, color, ls, e in curves]})
    return {"columns": columns, "t_end": t_end, "Vs": Vs, "peak": peak}


@_styled
def _friction_skeleton():
    """The data-free part of :func:`_draw_friction`: the 2 x 2 axes, fixed labels and grids."""
    fig = _new_figure(10.0, 6.2, right=2.05, top=0.4, bottom=0.55)
    axes = fig.subplots(2, 2, sharex="col", gridspec_kw={"wspace": 0.3, "hspace": 0.1, "height_ratios": [1.6, 1.0]})
    for ax, axe in axes.T:
        ax.grid(True, alpha=0.3, lw=0.5)
        axe.grid(True, alpha=0.3, lw=0.5)
        ax.set_ylabel("friction F(w) [N·m]")
        ax.tick_params(labelbottom=False)
        axe.set_ylabel("estimate − truth [N·m]")
        axe.set_xlabel("velocity w [deg/s]")
    axes[0, 0].set_title("static friction map (eq. 3), whole speed range", fontsize=9, loc="left")
    return fig, axes


@_styled
def _draw_friction(d: dict) -> Figure:
    t_end, Vs, peak = d["t_end"], d["Vs"], d["peak"]
    fig, axes = _friction_skeleton()
    for col, c in enumerate(d["columns"]):
        ax, axe = axes[0, col], axes[1, col]
        wd, truth = c["wd"], c["truth"]
        if c["start"] is not None:
            ax.plot(wd, c["start"], color="0.55", ls="--", lw=1.2, label="truth at t = 0")
        ax.plot(wd, truth, color="k", lw=2.4, label=f"truth at t = {t_end:.0f} s")
        for label, color, ls, F in c["curves"]:
            ax.plot(wd, F, color=color, ls=ls, lw=1.3, label=label)
            axe.plot(wd, F - truth, color=color, ls=ls, lw=1.3, label=label)
        for a in (ax, axe):
            a.axhline(0.0, color="0.6", lw=0.5, zorder=0)
            a.axvline(0.0, color="0.6", lw=0.5, zorder=0)
        ax.set_xlim(wd[0], wd[-1])
        err = [np.abs(F - truth) for _, _, _, F in c["curves"][-2:]]  # the final estimates
        lim = 1.5 * max((float(np.max(x)) for x in err), default=1.0) or 1.0
        axe.set_ylim(-lim, lim)
    axes[0, 1].set_title(f"low speeds, |w| ≤ 5 Vs = {_deg(min(5.0 * Vs, peak)):.2g} deg/s", fontsize=9, loc="left")
    _legend_right(fig, axes[0, 1])
    return fig


def plot_friction(comp, *, times=(0.05, 0.15, 0.5, 1.0)) -> Figure:
    """Estimated friction as a Stribeck map: torque (N·m) over velocity (deg/s), estimate vs truth.

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison
    times : sequence of float, keyword-only
        Fractions of the run (0, 1] at which the adaptive estimate is drawn.

    Returns
    -------
    matplotlib.figure.Figure
        Top: the static friction map (eq. 3) over the whole speed range of the
        run (left) and over the low speeds ``|w| <= 5 Vs`` where the Stribeck
        effect lives (right): the true plant at the end of the run in black
        (and at its start, dashed grey, when the plant drifts), the ``fixed``
        mode's offline estimate dashed, the ``adaptive`` estimate at the given
        times in shades of its colour (light = early). Bottom: each estimate
        minus the truth (N·m), where a good estimate is a flat line at zero.
    """
    return _draw_friction(_friction_inputs(comp, times=times))


def _true_sliding(plant, names, t):
    """True values of the sliding estimator's parameters at times ``t`` (NaN where the plant has no such parameter)."""
    out = np.full((len(t), len(names)), np.nan)
    drifting = hasattr(plant, "at")
    for j, ti in enumerate(t if drifting else t[:1]):
        p = plant.at(ti) if drifting else plant
        tau = getattr(p, "tau", None)
        vals = {"J": p.J, "Fc": p.Fc, "Fs": p.Fs, "sigma": p.sigma, "offset": 0.0}
        if tau is not None:
            vals.update(tau=tau, J_tau=p.J * tau)
        if hasattr(p, "Fc_pos"):  # asymmetric: the offset carries half the level difference
            vals["offset"] = 0.5 * (p.Fc_pos - p.Fc_neg)
        out[j] = [vals.get(n, np.nan) for n in names]
    if not drifting:
        out[:] = out[0]
    return out



def _rls_inputs(comp) -> dict | None:
    """What :func:`plot_rls_convergence` draws: the estimates (at most ~1500 updates) and the true values; None
    without an adaptive run."""
    r = comp.results.get("adaptive")
    if r is None or r.theta.size == 0:
        return None
    names = list(r.info["names"])
    stride = max(len(r.t_theta) // 1500, 1)
    tt, th = np.ascontiguousarray(r.t_theta[::stride]), np.ascontiguousarray(r.theta[::stride])
    if r.info.get("estimator") == "sliding":
        true = _true_sliding(comp.plant, names, tt)
        title = "sliding-regime estimator: physical parameters (dashed: true plant)"
    else:
        p0 = comp.plant.at(0.0) if hasattr(comp.plant, "at") else comp.plant
        true = np.tile(_estimator_model(comp, r).theta_from_physical(p0, r.info["Ts"]), (len(tt), 1))
        title = "eq. 4 RLS coefficients (dashed: true plant)"
    return {"names": names, "t": tt, "theta": th, "true": true, "title": title, "t_end": r.t[-1]}


def rls_grid(n: int) -> tuple[int, int]:
    """``(rows, columns)`` of the panels of :func:`plot_rls_convergence` for ``n`` parameters (two columns above 3)."""
    ncol = 2 if n > 3 else 1
    return -(-n // ncol), ncol


@_styled
def _rls_skeleton(grid: tuple[int, int]):
    """The data-free part of :func:`_draw_rls_convergence`: ``grid = (rows, columns)`` panels, locators, grids."""
    from matplotlib.ticker import MaxNLocator

    nrow, ncol = grid
    fig = _new_figure(10.0, 1.45 * nrow + 0.9, left=0.95, right=0.25, top=0.4, bottom=0.5)
    axes = np.atleast_1d(fig.subplots(nrow, ncol, sharex=True, squeeze=False,
                                      gridspec_kw={"hspace": 0.18, "wspace": 0.32})).ravel()
    for ax in axes:
        ax.yaxis.set_major_locator(MaxNLocator(nbins=3))
        ax.grid(True, alpha=0.3, lw=0.5)
    return fig, axes


@_styled
def _draw_rls_convergence(d: dict) -> Figure:
    names, tt, th, true = d["names"], d["t"], d["theta"], d["true"]
    n = len(names)
    nrow, ncol = rls_grid(n)
    fig, axes = _rls_skeleton((nrow, ncol))
    for i, (ax, name) in enumerate(zip(axes, names)):
        ax.plot(tt, th[:, i], lw=1.0, color=mode_color("adaptive"), label="estimate")
        ax.plot(tt, true[:, i], color="k", ls="--", lw=1.0, label="true plant")
        ax.set_ylabel(f"{name} [{PARAMETER_UNITS.get(name, '-')}]", fontsize=8)
        tail = th[len(th) // 10:, i]
        tail = tail[np.isfinite(tail)]
        tv = true[:, i][np.isfinite(true[:, i])]
        if tail.size:
            lo, hi = np.percentile(tail, [0.5, 99.5])
            if tv.size:
                lo, hi = min(lo, tv.min()), max(hi, tv.max())
            pad = 0.25 * (hi - lo) + 1e-9 * max(1.0, abs(hi))
            ax.set_ylim(lo - pad, hi + pad)
    for ax in axes[n:]:
        fig.delaxes(ax)
    for ax in axes[max(n - ncol, 0):n]:
        ax.set_xlabel("time [s]")
        ax.tick_params(labelbottom=True)
    fig.suptitle(d["title"], fontsize=9, x=0.95 / 10.0, ha="left", y=1.0 - 0.08 / (1.45 * nrow + 0.9), va="top")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="upper right", bbox_to_anchor=(1.0 - 0.25 / 10.0, 1.0),
               ncol=2, fontsize=8, frameon=False)  # in the top margin, above the panels
    axes[0].set_xlim(tt[0] if tt.size else 0.0, d["t_end"])
    return fig


def plot_rls_convergence(comp) -> Figure | None:
    """Each parameter of the adaptive estimator over time with its unit, the true value dashed (cf. paper Fig. 12).

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison

    Returns
    -------
    matplotlib.figure.Figure or None
        One panel per parameter (two columns): the estimate in the adaptive
        mode's colour, the true plant dashed black. The sliding estimator's
        parameters are physical (J in kg·m², J_tau in kg·m²·s, tau in s, Fc,
        Fs, offset in N·m, sigma in N·m·s/rad, :data:`PARAMETER_UNITS`); the
        eq. 4 estimator's are the regression coefficients of eq. 4. The y
        range follows the estimate after its first tenth, so the start-up
        transient does not flatten the rest. None without an adaptive run.
    """
    d = _rls_inputs(comp)
    return None if d is None else _draw_rls_convergence(d)


def _eta_inputs(comp) -> dict:
    """What :func:`plot_eta` draws: the modes, their eta and :func:`rms_dev` (deg/s)."""
    modes = list(comp.results)
    dev = rms_dev(comp)
    eta = [math.nan if comp.eta[m] is None else comp.eta[m] for m in modes]  # None: undefined (n/a on the bar)
    return {"modes": modes, "eta": eta, "rms_dev": [_deg(dev[m]) for m in modes]}


@_styled
def _eta_skeleton():
    """The data-free part of :func:`_draw_eta`: the two axes, fixed labels, titles and grids."""
    fig = _new_figure(10.0, 3.6, left=0.8, right=0.25, top=0.4, bottom=0.85)
    axes = fig.subplots(1, 2, gridspec_kw={"wspace": 0.25})
    for ax in axes:
        ax.set_xlabel("compensation mode")
        ax.grid(True, axis="y", alpha=0.3, lw=0.5)
    axes[0].set_ylabel("eta [-] (1 = frictionless)")
    axes[0].set_title("compensation efficiency eta (second half)", fontsize=9, loc="left")
    axes[1].set_ylabel("RMS(w − w_frictionless) [deg/s]")
    axes[1].set_title("rms_dev: distance from the frictionless run (whole run)", fontsize=9, loc="left")
    return fig, axes


@_styled
def _draw_eta(d: dict) -> Figure:
    modes = d["modes"]
    fig, axes = _eta_skeleton()
    colors = [mode_color(m, i) for i, m in enumerate(modes)]
    x = np.arange(len(modes))
    for ax, vals, fmt in ((axes[0], d["eta"], "{:.3f}"), (axes[1], d["rms_dev"], "{:.3g}")):
        v = np.array([float(a) for a in vals])
        ok = np.isfinite(v)
        ax.bar(x, np.where(ok, v, 0.0), color=colors, width=0.7)
        top = float(np.max(np.abs(v[ok]))) if ok.any() else 0.0
        top = top if top > 0.0 else 1.0  # all undefined or zero (a joint without friction): a unit axis
        for xi, vi, good in zip(x, v, ok):
            ax.text(xi, (vi if good else 0.0) + 0.02 * top, fmt.format(vi) if good else "n/a", ha="center",
                    va="bottom", fontsize=8)
        ax.set_xticks(x, modes, rotation=25, ha="right", fontsize=8)
        ax.set_ylim(min(0.0, float(np.min(v[ok])) * 1.15) if ok.any() else 0.0, 1.15 * top)
        ax.axhline(0.0, color="k", lw=0.6)
    axes[0].axhline(1.0, color="k", lw=0.8, ls="--")
    return fig


def plot_eta(comp) -> Figure:
    """Compensation efficiency eta and ``rms_dev`` per mode, as bars.

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison

    Returns
    -------
    matplotlib.figure.Figure
        Left: eta (second half of the run, 1 = frictionless, dashed line); right:
        :func:`rms_dev` in deg/s (lower is better). Values written on the bars;
        a mode with an undefined value gets an empty bar marked n/a.
    """
    return _draw_eta(_eta_inputs(comp))


class _Figure(NamedTuple):
    """One figure of :func:`plot_comparison`: ``draw(inputs(comp))`` is the figure (or None: not drawn), the same
    as ``plot_<name>(comp)``."""

    name: str
    inputs: Callable
    draw: Callable


#: The figures of :func:`plot_comparison`, in its order.
_FIGURES = (_Figure("tracking", _tracking_inputs, _draw_tracking),
            _Figure("error", _error_inputs, _draw_error),
            _Figure("friction", _friction_inputs, _draw_friction),
            _Figure("rls_convergence", _rls_inputs, _draw_rls_convergence),
            _Figure("eta", _eta_inputs, _draw_eta))


def figure_inputs(comp) -> dict:
    """What the figures of :func:`plot_comparison` show, taken from a comparison: small, picklable, enough to draw.

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison

    Returns
    -------
    dict
        ``{figure name: inputs or None}`` for :func:`draw_figures` (None: that
        figure is not drawn, e.g. ``rls_convergence`` without an adaptive run).
        The inputs are plain numbers, strings and NumPy arrays: min/max
        envelopes of the long records (:func:`minmax_envelope`, about 1500
        bins each), every sample of the zoom window, the friction curves and
        at most ~1500 estimator updates, so a 120 s comparison at 1 kHz
        (~55 MB of traces) gives well under 1 MB.
    """
    return {f.name: f.inputs(comp) for f in _FIGURES}


def draw_figures(inputs: dict, out_dir, *, dpi: int = _DPI, jobs: int = 1) -> list[Path]:
    """Draw the figures of :func:`figure_inputs` as PNG files into ``out_dir`` (created if needed).

    Parameters
    ----------
    inputs : dict
        The result of :func:`figure_inputs` (possibly in another process).
    out_dir : str or os.PathLike
        Directory.
    dpi : int, keyword-only
        Resolution (dots per inch), default 100.
    jobs : int, keyword-only
        Processes that render the figures, >= 1 (see :func:`plot_comparison`).

    Returns
    -------
    list of Path
        The files written, in the order of :func:`plot_comparison`.

    Raises
    ------
    ParameterError
        ``jobs`` not an integer >= 1.
    concurrent.futures.process.BrokenProcessPool
        With ``jobs > 1``: a pool worker died.
    """
    _check_jobs(jobs)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = [f.name for f in _FIGURES if inputs.get(f.name) is not None]
    if jobs > 1 and len(names) > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=min(int(jobs), len(names))) as pool:
            written = list(pool.map(_draw_file, names, [inputs[n] for n in names], [out] * len(names),
                                    [dpi] * len(names)))
    else:
        written = [_draw_file(n, inputs[n], out, dpi) for n in names]
    return [path for path in written if path is not None]


def _draw_file(name: str, d: dict, out: Path, dpi: int) -> Path | None:
    """Draw figure ``name`` of :data:`_FIGURES` from its inputs ``d`` into ``out/<name>.png``; its path, or None
    when the figure has nothing to show."""
    fig = next(f for f in _FIGURES if f.name == name).draw(d)
    if fig is None:
        return None
    path = out / f"{name}.png"
    fig.savefig(path, dpi=dpi, pil_kwargs={"compress_level": 1})  # fast zlib: files ~1/3 larger
    return path


def _check_jobs(jobs) -> None:
    if isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer)) or jobs < 1:
        raise ParameterError(f"jobs must be an integer >= 1, got {jobs!r}")


def plot_comparison(comp, out_dir, *, dpi: int = _DPI, jobs: int = 1) -> list[Path]:
    """Write the comparison figures as PNG files into ``out_dir`` (created if needed).

    ``draw_figures(figure_inputs(comp), out_dir, dpi=dpi, jobs=jobs)``.

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison
        The runs (velocities in rad/s are drawn in deg/s).
    out_dir : str or os.PathLike
        Directory.
    dpi : int, keyword-only
        Resolution (dots per inch), default 100.
    jobs : int, keyword-only
        Processes that render the figures, >= 1 (default 1: one after the
        other in this process). With ``jobs > 1`` a
        ``concurrent.futures.ProcessPoolExecutor`` of up to ``jobs`` workers
        (the platform's default start method) draws one figure per task from
        the figures' inputs (:func:`figure_inputs`, sent to the workers, not
        the runs); matplotlib draws a figure in one thread only, so this is how
        the figures use more than one core. The files are the same bytes as
        with ``jobs=1``; an error raised while drawing is raised here.

    Returns
    -------
    list of Path
        ``tracking.png``, ``error.png``, ``friction.png``,
        ``rls_convergence.png`` (only with an adaptive run) and ``eta.png``, as
        described in the module docstring, in this order.

    Raises
    ------
    ParameterError
        ``jobs`` not an integer >= 1.
    concurrent.futures.process.BrokenProcessPool
        With ``jobs > 1``: a pool worker died.
    """
    _check_jobs(jobs)
    return draw_figures(figure_inputs(comp), out_dir, dpi=dpi, jobs=jobs)
