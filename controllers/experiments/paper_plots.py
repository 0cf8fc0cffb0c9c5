"""The paper's kinds of figures from plain arrays: velocity fits (Figs. 4, 5, 9, 11), sample times (Fig. 10),
parameter convergence (Fig. 12), the quantised input torque (Fig. 7) and the Stribeck curve (Fig. 8).

Used by :func:`controllers.experiments.paper_figures.paper_figures` (which re-exports these names) for the
simulated experiments and by :func:`controllers.experiments.paper_figures.identification_figures` for a
measured log. matplotlib is imported inside the functions.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from plant.errors import ParameterError, check_positive, check_signal, check_time

if TYPE_CHECKING:  # annotations only: matplotlib is imported by the plotting functions when they run
    from matplotlib.figure import Figure

__all__ = ["AXIS_UNITS", "plot_velocity_fit", "plot_sample_times", "plot_parameter_convergence", "plot_input_torque",
           "plot_stribeck_figure"]

#: Velocity units the figures can be drawn in: name -> (factor from rad/s, label).
AXIS_UNITS = {"rad": (1.0, "rad/s"), "deg": (180.0 / math.pi, "deg/s")}


def _velocity_unit(units: str) -> tuple[float, str]:
    """``(factor from rad/s, label)`` of ``units`` (:data:`AXIS_UNITS`); ParameterError otherwise."""
    try:
        return AXIS_UNITS[units]
    except (KeyError, TypeError):
        raise ParameterError(f"units must be one of {sorted(AXIS_UNITS)}, got {units!r}") from None



def _model_curve(name: str, curve) -> tuple:
    """``(w_model, label, fit_percent or None)`` of a model curve given as ``(w_model, label[, fit_percent])``."""
    try:
        w_model, label, *fit = curve
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be (w_model, label) or (w_model, label, fit_percent), got "
                             f"{type(curve).__name__}") from None
    if len(fit) > 1:
        raise ParameterError(f"{name} must be (w_model, label) or (w_model, label, fit_percent), got {len(curve)} "
                             f"entries")
    return w_model, str(label), (fit[0] if fit else None)


def plot_velocity_fit(t, w, model, *, model2=None, measured_label: str = "measured", title: str = "",
                      units: str = "rad") -> Figure:
    """Measured (or simulated) velocity against a model's velocity over time (paper Figs. 4, 5, 9, 11).

    Parameters
    ----------
    t : array_like, shape (N,)
        Time (s).
    w : array_like, shape (N,)
        Measured velocity (rad/s).
    model : tuple
        ``(w_model, label)`` or ``(w_model, label, fit_percent)``: the model velocity (rad/s, array_like of shape
        (N,); e.g. LS one-step or free-run, RLS a-priori prediction), its legend entry and its NRMSE fit (%),
        appended to the entry.
    model2 : tuple, keyword-only, optional
        A second model curve (dotted), as ``model``.
    measured_label, title : str, keyword-only
        Legend entry of ``w`` and the title.
    units : {"rad", "deg"}, keyword-only
        Velocity axis in rad/s (SI, default) or deg/s (as the paper's robot figures).

    Returns
    -------
    matplotlib.figure.Figure
        Top: both velocities over time (s); bottom: the difference; legend above the plot.

    Raises
    ------
    SignalError
        Arrays of different lengths or non-finite ``t``/``w``.
    ParameterError
        ``w_model`` of another shape, a model curve not ``(w_model, label[, fit_percent])``, unknown ``units``.
    """
    w_model, model_label, fit_percent = _model_curve("model", model)
    w_model2, model2_label, fit2_percent = (None, "", None) if model2 is None else _model_curve("model2", model2)
    t = check_signal("t", t)
    w = check_signal("w", w, n=t.shape[0])
    wm = np.asarray(w_model, dtype=float).reshape(-1)
    if wm.shape != w.shape:
        raise ParameterError(f"w_model must have shape {w.shape}, got {wm.shape}")
    k, vu = _velocity_unit(units)
    w, wm = k * w, k * wm
    w_model2 = None if w_model2 is None else k * np.asarray(w_model2, dtype=float).reshape(-1)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 5.4), layout="constrained")
    ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[3, 1])
    ax.plot(t, w, color="0.2", lw=1.0, label=measured_label)
    lab = model_label + (f" (fit {fit_percent:.1f} %)" if fit_percent is not None else "")
    ax.plot(t, wm, color="C1", lw=0.9, label=lab)
    ax2.plot(t, wm - w, color="C1", lw=0.7)
    if w_model2 is not None:
        wm2 = np.asarray(w_model2, dtype=float).reshape(-1)
        lab2 = model2_label + (f" (fit {fit2_percent:.1f} %)" if fit2_percent is not None else "")
        ax.plot(t, wm2, color="C0", lw=0.8, ls=":", label=lab2)
        ax2.plot(t, wm2 - w, color="C0", lw=0.6, ls=":")
    ax.set_ylabel(f"velocity w ({vu})")
    ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=2, fontsize=8, frameon=False, borderaxespad=0.2)
    ax.grid(True, alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10, x=0.01, ha="left")
    lim = float(np.max(np.abs(w))) * 1.5 or 1.0
    ax.set_ylim(-lim, lim)  # a diverging free run must not squash the measured curve
    res = [wm - w] + ([np.asarray(w_model2, dtype=float).reshape(-1) - w] if w_model2 is not None else [])
    res = np.abs(np.concatenate(res))
    res = res[np.isfinite(res)]
    rlim = min(float(np.percentile(res, 99.5)) * 1.5 if res.size else lim, lim) or lim
    ax2.set_ylim(-rlim, rlim)
    ax2.set_ylabel(f"model − measured\n({vu})")
    ax2.set_xlabel("time t (s)")
    ax2.grid(True, alpha=0.3)
    return fig


def plot_sample_times(t, *, title: str = "") -> Figure:
    """Sample intervals ``Ts(i) = t(i) - t(i-1)`` over the sample index and their histogram (paper Fig. 10).

    Parameters
    ----------
    t : array_like, shape (N,)
        Time stamps (s), strictly increasing, N >= 2.
    title : str, keyword-only

    Returns
    -------
    matplotlib.figure.Figure
        Left: ``Ts`` (ms) over the sample index; right: histogram of ``Ts`` (ms)
        with the mean marked.

    Raises
    ------
    SignalError
        ``t`` not strictly increasing.
    """
    t = check_time("t", t)
    d = np.diff(t) * 1e3
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 3.6), layout="constrained")
    ax, ax2 = fig.subplots(1, 2, width_ratios=[2, 1])
    ax.plot(np.arange(1, t.shape[0]), d, ".", ms=2, color="C0")
    ax.axhline(d.mean(), color="C3", lw=1.0, label=f"mean {d.mean():.2f} ms")
    ax.set_xlabel("sample index i (-)")
    ax.set_ylabel("Ts = t(i) − t(i−1) (ms)")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(True, alpha=0.3)
    vals = np.unique(np.round(d, 6))
    step = float(np.min(np.diff(vals))) if vals.shape[0] > 1 else 1.0
    if (vals[-1] - vals[0]) / step <= 200:  # time stamps on a grid: one bar per grid value
        bins = np.arange(vals[0] - 0.5 * step, vals[-1] + step, step)
    else:
        bins = 60
    ax2.hist(d, bins=bins, color="C0", alpha=0.8)
    ax2.set_yscale("log")
    ax2.axvline(d.mean(), color="C3", lw=1.0)
    ax2.set_xlabel("Ts (ms)")
    ax2.set_ylabel("number of samples (log)")
    ax2.grid(True, alpha=0.3)
    fig.suptitle(title or f"sample time: mean {d.mean():.2f} ms, min {d.min():.2f} ms, max {d.max():.2f} ms",
                 fontsize=10)
    return fig


def plot_parameter_convergence(t, theta, names, *, true=None, title: str = "", units: str = "rad") -> Figure:
    """RLS parameter trajectories over time, one panel per parameter (paper Fig. 12), nothing clipped.

    Parameters
    ----------
    t : array_like, shape (M,)
        Time (s) of each estimate.
    theta : array_like, shape (M, p)
        Estimates (eq. 4 coefficients: a dimensionless, b in (rad/s)/(N·m),
        c, d, o in rad/s).
    names : sequence of str, length p
        Parameter names (e.g. ``RegressionModel.names``).
    true : array_like, shape (p,), keyword-only, optional
        Reference values drawn dashed (e.g. the corrected coefficients of the true plant).
    title : str, keyword-only
    units : {"rad", "deg"}, keyword-only
        Velocity unit of the b, c, d, o coefficients: rad/s (default) or deg/s (scaled by 180/pi).

    Returns
    -------
    matplotlib.figure.Figure
        The whole trajectory of every parameter is inside its panel: the
        windup bursts of plain RLS with strong forgetting (paper: lambda =
        0.85) are shown, not cut off. When the largest excursion exceeds five
        times the typical range (the 5-95 % band of the last four fifths),
        the y axis is symmetric-log, linear over the typical range, so the
        bursts and the converged value are both readable.

    Raises
    ------
    ParameterError
        Shapes disagree, unknown ``units``.
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    th = np.array(theta, dtype=float)
    names = list(names)
    if th.ndim != 2 or th.shape != (t.shape[0], len(names)):
        raise ParameterError(f"theta must have shape ({t.shape[0]}, {len(names)}), got {th.shape}")
    k, vu = _velocity_unit(units)
    units_of = {"a1": "1", "a2": "1", "b0": f"({vu})/(N·m)", "b1": f"({vu})/(N·m)", "c1": vu, "d1": vu, "o1": vu}
    scale = np.array([1.0 if n in ("a1", "a2") else k for n in names])
    th = th * scale
    ref = None if true is None else np.asarray(true, dtype=float).reshape(-1) * scale
    ncol = 2 if len(names) > 3 else 1
    nrow = math.ceil(len(names) / ncol)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 1.8 * nrow + 0.7), layout="constrained")
    axes = np.atleast_1d(fig.subplots(nrow, ncol, sharex=True, squeeze=False)).ravel()
    for i, name in enumerate(names):
        ax = axes[i]
        ax.plot(t, th[:, i], lw=0.8, color="#0072B2")
        if ref is not None:
            ax.axhline(float(ref[i]), color="k", ls="--", lw=0.8)
        ax.set_ylabel(f"{name} ({units_of.get(name, '-')})", fontsize=8)
        col = th[:, i][np.isfinite(th[:, i])]
        if col.size:
            lo, hi = np.percentile(col[col.shape[0] // 5:], [5, 95])
            centre = [float(ref[i])] if ref is not None else []
            typical = max(hi - lo, *(abs(c) for c in centre), 1e-12)
            if float(np.max(np.abs(col - np.median(col)))) > 5.0 * typical:
                ax.set_yscale("symlog", linthresh=typical)
        ax.grid(True, alpha=0.3)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    for ax in axes[max(len(names) - ncol, 0):len(names)]:
        ax.set_xlabel("time t (s)")
    fig.suptitle(title or "RLS parameter convergence" + (" (dashed: true plant)" if true is not None else ""),
                 fontsize=10)
    return fig


def plot_input_torque(t, u, *, zoom_length: float | None = None, zooms=None, title: str = "") -> Figure:
    """The applied input torque with close-up views (paper Fig. 7): quantisation and irregular sampling.

    Parameters
    ----------
    t : array_like, shape (N,)
        Read-out time stamps (s), strictly increasing.
    u : array_like, shape (N,)
        Torque (N·m) as read out, ``u = K i`` from the motor current.
    zoom_length : float, keyword-only, optional
        Length (s) of each close-up, > 0; default 25 mean sample intervals.
    zooms : sequence of float, keyword-only, optional
        Start times (s) of the close-ups; default two, at a third and two thirds of the record.
    title : str, keyword-only

    Returns
    -------
    matplotlib.figure.Figure
        Top: one close-up per zoom, the read-out samples as dots joined by
        a zero-order hold, so the quantisation steps and the uneven time grid
        show; bottom: the whole torque record (N·m) over time (s) with the
        close-up windows shaded.

    Raises
    ------
    SignalError
        ``t`` not strictly increasing or ``u`` of another length / not finite.
    ParameterError
        ``zoom_length`` not > 0.
    """
    t = check_time("t", t)
    u = check_signal("u", u, n=t.shape[0])
    span = float(t[-1] - t[0])
    length = 25.0 * span / max(t.shape[0] - 1, 1) if zoom_length is None else check_positive("zoom_length",
                                                                                             zoom_length)
    starts = [t[0] + span / 3.0, t[0] + 2.0 * span / 3.0] if zooms is None else [float(z) for z in zooms]
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 5.6), layout="constrained")
    gs = fig.add_gridspec(2, len(starts), height_ratios=[1.0, 1.1])
    whole = fig.add_subplot(gs[1, :])
    whole.plot(t, u, color="#0072B2", lw=0.6)
    for j, z0 in enumerate(starts):
        ax = fig.add_subplot(gs[0, j])
        sel = (t >= z0) & (t <= z0 + length)
        ax.step(t[sel], u[sel], where="post", color="#0072B2", lw=0.9)
        ax.plot(t[sel], u[sel], ".", color="#D55E00", ms=4)
        ax.set_xlabel("time t (s)")
        ax.set_ylabel("torque u (N·m)")
        ax.set_title(f"close-up {j + 1}: {z0:.2f}–{z0 + length:.2f} s", fontsize=9, loc="left")
        ax.grid(True, alpha=0.3)
        whole.axvspan(z0, z0 + length, color="#F0E442", alpha=0.8, lw=0)
    whole.set_xlabel("time t (s)")
    whole.set_ylabel("torque u (N·m)")
    whole.set_xlim(t[0], t[-1])
    whole.grid(True, alpha=0.3)
    fig.suptitle(title or "applied input torque with close-up views", fontsize=10)
    return fig


def plot_stribeck_figure(fit, w, F, *, F_std=None, title: str = "", units: str = "rad") -> Figure:
    """Stribeck fit over the support points (paper Fig. 8): linear axes, and a symlog zoom on low speeds.

    Parameters
    ----------
    fit : adaptive_ff.identification.stribeck_fit.StribeckFit
        The fit (SI units).
    w, F : array_like, shape (n,)
        Mean velocity (rad/s) and torque (N·m) of each run.
    F_std : array_like, shape (n,), keyword-only, optional
        Torque spread (N·m), drawn as error bars.
    title : str, keyword-only
    units : {"rad", "deg"}, keyword-only
        Velocity axis in rad/s (default) or deg/s.

    Returns
    -------
    matplotlib.figure.Figure
        Left: the support points (mean ± spread) and the fitted curve of eq. 3
        on linear axes; right: the same with a symmetric-log velocity axis
        (linear within ``±Vs/10``), so the Stribeck dip near ``Vs`` is visible.

    Raises
    ------
    TypeError
        ``fit`` not a StribeckFit.
    SignalError
        Bad ``w``, ``F``, ``F_std``.
    ParameterError
        Unknown ``units``.
    """
    from adaptive_ff.identification.stribeck_fit import StribeckFit

    if not isinstance(fit, StribeckFit):
        raise TypeError(f"fit must be a StribeckFit, got {type(fit).__name__}")
    w = check_signal("w", w)
    F = check_signal("F", F, n=w.shape[0])
    yerr = None if F_std is None else check_signal("F_std", F_std, n=w.shape[0])
    k, vu = _velocity_unit(units)
    aw = np.abs(w[w != 0.0])
    top, bottom = (float(aw.max()), float(aw.min())) if aw.size else (1.0, 1e-3)
    branch = np.unique(np.concatenate([np.linspace(0.0, top, 400)[1:],
                                       np.geomspace(min(bottom, fit.Vs) / 2.0, top, 400)]))
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10.0, 4.4), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax in axes:
        ax.errorbar(k * w, F, yerr=yerr, fmt="o", ms=4, capsize=2, color="#0072B2",
                    label="measured (mean ± spread)")
        for sgn, lab in ((1.0, f"Stribeck fit (Vs = {k * fit.Vs:.3g} {vu}, δ = {fit.delta:.3g})"), (-1.0, None)):
            ax.plot(sgn * k * branch, fit.friction(sgn * branch), "-", color="#D55E00", label=lab)
        ax.axhline(0.0, color="0.7", lw=0.5)
        ax.axvline(0.0, color="0.7", lw=0.5)
        ax.set_ylabel("friction torque F (N·m)")
        ax.grid(True, alpha=0.3)
    axes[0].set_xlabel(f"velocity w ({vu})")
    axes[0].legend(loc="upper left", fontsize=8)
    axes[1].set_xscale("symlog", linthresh=k * fit.Vs / 10.0)
    axes[1].set_xlabel(f"velocity w ({vu}, symmetric log scale)")
    fig.suptitle(title or "Stribeck curve from quasi-static runs", fontsize=10)
    return fig
