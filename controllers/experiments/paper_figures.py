"""The paper's figures regenerated from the simulation (Figs. 4, 5, 7-12), and the same kinds of figures for any log.

Experiments, following Ruderman's paper on the simulated joint (``paper`` preset by default):

* **Sec. IV-A/B, Figs. 4, 5** — open loop, low-pass band-limited white-noise
  torque, 1 kHz RK4 plant, sampled every 10 ms; offline LS fit of eq. 4 (Fig. 4:
  simulated vs LS model velocity) and RLS from ``theta = 0`` on the same data
  (Fig. 5: simulated vs RLS a-priori predicted velocity).
* **Sec. V-C, Fig. 8** — bidirectional constant-velocity runs
  (:func:`controllers.experiments.quasi_static.quasi_static_runs`) and the
  Levenberg-Marquardt Stribeck fit (:func:`adaptive_ff.identification.stribeck_fit.fit_stribeck`);
  its ``Vs``, ``delta`` fix the regression model of every other figure.
* **Sec. V-B/D/E, Figs. 7, 9-12** — a stiff PI velocity loop (200 rad/s
  crossover, like an industrial robot's) tracks a 0.01-1 Hz multi-sine
  reference (up to 20 deg/s, frequent reversals; the joint is stuck below
  0.2 deg/s only a few per cent of the time, :func:`joint_motion`); torque and
  velocity are read out at irregular instants (Fig. 10: about 22 ms mean,
  outliers up to twice that), with velocity noise and torque quantisation
  (Fig. 7). Offline LS on the irregular samples as they are, with
  ``Ts`` = their mean (Fig. 9), and RLS with ``lam = 0.85`` as in the paper
  (Fig. 11: velocity, Fig. 12: parameter convergence, windup bursts shown,
  not clipped). Fig. 7 is the read-out torque with close-ups of its
  quantisation steps and uneven time grid. Axes in rad/s, or deg/s as in the
  paper (``PaperFigureOptions(units="deg")``).

Plotting functions take plain arrays, so :func:`identification_figures` draws
the same figures for a measured log identified by :func:`adaptive_ff.identification.identify.identify`.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.regression import RegressionModel, nrmse_fit
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers.experiments.quasi_static import bidirectional_velocities, quasi_static_runs
from controllers.experiments.synthetic_logs import (closed_loop_readout, encoder_counts, quasi_static_log,
                                                    write_controller_log, write_log_csv)
from plant.errors import ParameterError, check_nonnegative, check_positive, check_signal, check_time
from plant.excitation import bandlimited_noise
from plant.friction import JointParams, preset
from plant.joint import simulate
from plant.results import json_safe
from plant.sampling import sample

if TYPE_CHECKING:  # annotations only: matplotlib is imported by the plotting functions when they run
    from matplotlib.figure import Figure

__all__ = [
    "PaperFigures",
    "PaperFigureOptions",
    "paper_figures",
    "rls_pass",
    "plot_velocity_fit",
    "plot_sample_times",
    "plot_parameter_convergence",
    "plot_stribeck_figure",
    "plot_input_torque",
    "joint_motion",
    "AXIS_UNITS",
    "identification_figures",
    "save_figures",
    "FIGURE_CAPTIONS",
    "DEMO_CURRENT_TO_TORQUE",
    "DEMO_COUNTS_PER_REV",
]

#: Captions of the regenerated figures (keys are the output file stems).
FIGURE_CAPTIONS = {
    "fig04_ls_simulation": "Fig. 4: simulated and offline (LS) estimated output velocity",
    "fig05_rls_simulation": "Fig. 5: simulated and online (RLS) estimated output velocity",
    "fig07_input_torque": "Fig. 7: applied input joint torque signal with close-up views",
    "fig08_stribeck": "Fig. 8: Stribeck curve from bidirectional quasi-static drive experiments",
    "fig09_ls_experiment": "Fig. 9: measured and offline identified joint velocity",
    "fig10_sample_time": "Fig. 10: evaluated sample time of the identification experiment",
    "fig11_rls_experiment": "Fig. 11: measured and online identified joint velocity",
    "fig12_rls_parameters": "Fig. 12: parameter convergence of RLS identification",
}

#: Torque constant (N·m/A, joint side) of the demonstration log: 0.5 N·m/A motor constant times gear ratio 120.
DEMO_CURRENT_TO_TORQUE = 60.0
#: Encoder resolution (counts per joint revolution) of the demonstration log: 2**14 per motor turn times 120.
DEMO_COUNTS_PER_REV = 2**14 * 120


# --------------------------------------------------------------------------- plots

#: Velocity units the figures can be drawn in: name -> (factor from rad/s, label).
AXIS_UNITS = {"rad": (1.0, "rad/s"), "deg": (180.0 / math.pi, "deg/s")}


def _velocity_unit(units: str) -> tuple[float, str]:
    """``(factor from rad/s, label)`` of ``units`` (:data:`AXIS_UNITS`); ParameterError otherwise."""
    try:
        return AXIS_UNITS[units]
    except (KeyError, TypeError):
        raise ParameterError(f"units must be one of {sorted(AXIS_UNITS)}, got {units!r}") from None



def plot_velocity_fit(t, w, w_model, *, model_label: str, measured_label: str = "measured", title: str = "",
                      w_model2=None, model2_label: str = "", fit_percent: float | None = None,
                      fit2_percent: float | None = None, units: str = "rad") -> Figure:
    """Measured (or simulated) velocity against a model's velocity over time (paper Figs. 4, 5, 9, 11).

    Parameters
    ----------
    t : array_like, shape (N,)
        Time (s).
    w : array_like, shape (N,)
        Measured velocity (rad/s).
    w_model : array_like, shape (N,)
        Model velocity (rad/s), e.g. LS one-step or free-run, RLS a-priori prediction.
    model_label, measured_label, title : str, keyword-only
        Legend entries and title.
    w_model2 : array_like, shape (N,), keyword-only, optional
        A second model curve (dotted), with ``model2_label``.
    fit_percent, fit2_percent : float, keyword-only, optional
        NRMSE fits (%) appended to the legend entries.
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
        ``w_model`` of another shape, unknown ``units``.
    """
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


def joint_motion(w, *, stuck_below: float = math.radians(0.2)) -> dict:
    """How a joint moved: share of time stuck, speed range and motion reversals.

    Parameters
    ----------
    w : array_like, shape (N,)
        Joint velocity (rad/s) on a uniform time grid.
    stuck_below : float, keyword-only
        Speed (rad/s) below which the joint counts as stuck, > 0; default 0.2 deg/s.

    Returns
    -------
    dict
        ``stuck_fraction`` (share of samples with ``|w| < stuck_below``),
        ``speed_p05``, ``speed_p95``, ``speed_max`` (percentiles and maximum of
        ``|w|`` while moving, rad/s) and ``reversals`` (sign changes between
        samples moving faster than ``stuck_below``, so noise while stuck does
        not count).

    Raises
    ------
    SignalError
        ``w`` empty or not finite.
    """
    w = check_signal("w", w)
    thr = check_positive("stuck_below", stuck_below)
    a = np.abs(w)
    moving = a >= thr
    sgn = np.sign(w[moving])
    sp = a[moving] if moving.any() else np.zeros(1)
    return {"stuck_fraction": float(np.mean(~moving)), "speed_p05": float(np.percentile(sp, 5)),
            "speed_p95": float(np.percentile(sp, 95)), "speed_max": float(sp.max()),
            "reversals": int(np.count_nonzero(sgn[1:] != sgn[:-1]))}


# --------------------------------------------------------------------------- RLS pass


def rls_pass(model: RegressionModel, u, w, *, lam: float = 1.0, P0: float = 1e4):
    """Run RLS (eqs. 10-13) from ``theta = 0`` over a record and keep its a-priori predictions.

    Parameters
    ----------
    model : RegressionModel
        Regression structure (eq. 4).
    u, w : array_like, shape (N,)
        Input torque (N·m) and velocity (rad/s), sampled in order.
    lam : float, keyword-only
        Forgetting factor in (0, 1].
    P0 : float, keyword-only
        Initial covariance ``P0*I``, > 0 ("large", as in the paper).

    Returns
    -------
    w_pred : ndarray, shape (N,)
        A-priori prediction ``phi(k) @ theta(k-1)`` (rad/s); the first two
        entries are the measured ``w[0], w[1]``.
    theta : ndarray, shape (N - 2, p)
        Estimate after each update.

    Raises
    ------
    SignalError
        Bad ``u``, ``w``.
    ParameterError
        Bad ``lam`` or ``P0``.

    Notes
    -----
    :class:`adaptive_ff.identification.rls.RecursiveLeastSquares` over the rows of
    ``model.regressors(u, w)``; Ruderman, Sec. IV-B.
    """
    X, y = model.regressors(u, w)
    rls = RecursiveLeastSquares(model.n_params, lam=lam, P0=P0)
    w_pred = np.asarray(w, dtype=float).reshape(-1).copy()
    hist = np.empty((X.shape[0], model.n_params))
    for i in range(X.shape[0]):
        e = rls.update(X[i], y[i])
        w_pred[i + 2] = y[i] - e
        hist[i] = rls.theta
    return w_pred, hist


# --------------------------------------------------------------------------- the paper's figures


@dataclass(frozen=True, kw_only=True)
class PaperFigureOptions:
    """Settings of the experiments behind :func:`paper_figures` (keyword-only, validated).

    Parameters
    ----------
    seed : int
        Seed of all random draws (excitation, reference, sample times, noise), >= 0.
    sim_duration : float
        Length (s) of the open-loop simulation experiment (Figs. 4, 5), >= 2.
    exp_duration : float
        Length (s) of the closed-loop "robot" experiment (Figs. 9-12), >= 2.
    n_speeds : int
        Quasi-static speeds per direction (Fig. 8), >= 3, log-spaced from
        ``0.2*Vs`` to 0.4 rad/s.
    noise_std : float
        Velocity measurement noise (rad/s), >= 0, of the quasi-static runs and the
        closed-loop experiment (the open-loop simulation is noise-free, as in Sec. IV).
    quantization : float
        Torque quantisation step (N·m), >= 0, of the closed-loop experiment's readout (Fig. 7).
    lam_sim, lam_exp : float
        RLS forgetting factors in (0, 1] of Fig. 5 and of Figs. 11-12 (paper: 0.85).
    P0 : float
        RLS initial covariance scale, > 0.
    crossover : float
        Gain crossover (rad/s) of the PI velocity loop of the closed-loop experiment, > 0; default 200,
        a stiff loop like an industrial robot's, so the joint moves like the paper's (1-20 deg/s, frequent
        reversals, rarely stuck; a 20 rad/s loop leaves the joint stuck about 40 % of the time).
    units : {"rad", "deg"}
        Velocity unit on the figures' axes: rad/s (SI, default) or deg/s as in the paper. The numbers
        (:attr:`PaperFigures.numbers`) stay SI.

    Raises
    ------
    ParameterError
        A setting out of range (the message names it).
    TypeError
        ``seed`` or ``n_speeds`` not an integer, another setting not a real number.
    """

    seed: int = 0
    sim_duration: float = 30.0
    exp_duration: float = 60.0
    n_speeds: int = 10
    noise_std: float = 1e-3
    quantization: float = 0.6
    lam_sim: float = 0.995
    lam_exp: float = 0.85
    P0: float = 1e4
    crossover: float = 200.0
    units: str = "rad"

    def __post_init__(self):
        for name in ("seed", "n_speeds"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise TypeError(f"{name} must be an integer, got {v!r} ({type(v).__name__})")
        if self.seed < 0:
            raise ParameterError(f"seed must be >= 0, got {self.seed!r}")
        if self.n_speeds < 3:
            raise ParameterError(f"n_speeds must be an integer >= 3, got {self.n_speeds!r}")
        for name in ("sim_duration", "exp_duration"):
            if check_positive(name, getattr(self, name)) < 2.0:
                raise ParameterError(f"{name} must be >= 2 s, got {getattr(self, name)!r}")
        check_nonnegative("noise_std", self.noise_std)
        check_nonnegative("quantization", self.quantization)
        for name in ("lam_sim", "lam_exp"):
            if not 0.0 < check_positive(name, getattr(self, name)) <= 1.0:
                raise ParameterError(f"{name} must be in (0, 1], got {getattr(self, name)!r}")
        check_positive("P0", self.P0)
        check_positive("crossover", self.crossover)
        _velocity_unit(self.units)
        for name in ("seed", "n_speeds"):
            object.__setattr__(self, name, int(getattr(self, name)))
        for name in ("sim_duration", "exp_duration", "noise_std", "quantization", "lam_sim", "lam_exp", "P0",
                     "crossover"):
            object.__setattr__(self, name, float(getattr(self, name)))

    def to_dict(self) -> dict:
        """The settings as strict JSON (SI units)."""
        return json_safe(asdict(self))


@dataclass(frozen=True)
class PaperFigures:
    """Result of :func:`paper_figures`.

    Attributes
    ----------
    out_dir : Path
        Where the files are.
    figures : dict
        ``{stem: Path}`` of the PNG files (stems as in :data:`FIGURE_CAPTIONS`).
    captions : dict
        ``{stem: caption}``.
    numbers : dict
        Numbers behind the figures (SI units): fits (%), estimates, Stribeck
        parameters, sample-time statistics, settings.
    data_files : dict
        ``{name: Path}`` of the demonstration logs (with ``save_data=True``).
    """

    out_dir: Path
    figures: dict
    captions: dict
    numbers: dict
    data_files: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """Strict JSON: ``{"summary": numbers, "figures": {stem: path}, "data_files": {name: path}}``."""
        return json_safe({"summary": self.numbers, "figures": self.figures, "data_files": self.data_files})

    #: Same as :meth:`to_dict` (the older name).
    to_json_dict = to_dict

    def summary(self) -> str:
        """A few lines: the Stribeck fit and the LS/RLS fits of both experiments, and where the files are."""
        st, sim, ex = self.numbers["stribeck"], self.numbers["simulation"], self.numbers["experiment"]
        return "\n".join([
            f"Fig. 8  Stribeck fit: Fc={st['Fc']:.4g} N·m, Fs={st['Fs']:.4g} N·m, Vs={st['Vs']:.4g} rad/s, "
            f"delta={st['delta']:.4g}, sigma={st['sigma']:.4g} N·m·s/rad ({st['n_points']} runs)",
            f"Figs. 4, 5  simulation: LS fit one-step {sim['ls_fit_one_step']:.2f} %, free run "
            f"{sim['ls_fit_free_run']:.2f} %; RLS a-priori {sim['rls_fit']:.2f} %",
            f"Figs. 9-12  experiment (mean Ts {ex['Ts_mean'] * 1e3:.2f} ms): "
            f"LS one-step {ex['ls_fit_one_step']:.2f} %, free run {ex['ls_fit_free_run']:.2f} %; RLS a-priori {ex['rls_fit']:.2f} %",
            f"{len(self.figures)} figures in {self.out_dir}",
        ])


def _estimate_dict(est) -> dict:
    return {k: float(getattr(est, k)) for k in ("J", "tau", "sigma", "Fc", "Fs")}


def _fig8_stribeck(p: JointParams, opt: PaperFigureOptions, qs_ss) -> tuple:
    """Sec. V-C: quasi-static runs and the LM Stribeck fit; returns ``(velocities, model, figure, numbers)``."""
    vel = bidirectional_velocities(0.2 * p.Vs, 0.4, opt.n_speeds)
    qs = quasi_static_runs(p, vel, noise_std=opt.noise_std, rng=np.random.default_rng(qs_ss))
    sfit = fit_stribeck(qs.w_mean, qs.u_mean)
    fig = plot_stribeck_figure(sfit, qs.w_mean, qs.u_mean, F_std=qs.u_std, title=FIGURE_CAPTIONS["fig08_stribeck"],
                               units=opt.units)
    numbers = {**sfit.params(), "stderr": dict(sfit.stderr), "n_points": sfit.n_points}
    return vel, RegressionModel(sfit.Vs, sfit.delta, lag=True), fig, numbers


def _figs45_simulation(p: JointParams, opt: PaperFigureOptions, model: RegressionModel, sim_ss, Tc: float,
                       peak: float) -> tuple[dict, dict]:
    """Sec. IV: open-loop band-limited-noise run sampled at 10 ms, LS and RLS; returns ``(figures, numbers)``."""
    Ts_sim = 0.01
    _, u_id = bandlimited_noise(opt.sim_duration, dt=Tc, cutoff=1.0,
                                std=1.2 * (max(p.Fs, p.Fc) + p.sigma * peak), rng=np.random.default_rng(sim_ss))
    meas_sim = sample(simulate(p, u_id, dt=Tc), Ts=Ts_sim)
    ls_sim = fit_ls(model, meas_sim.u, meas_sim.w, Ts=Ts_sim)
    figs = {"fig04_ls_simulation": plot_velocity_fit(
        meas_sim.t, meas_sim.w, ls_sim.w_free_run, model_label="LS model, free run", fit_percent=ls_sim.fit_free_run,
        w_model2=ls_sim.w_one_step, model2_label="LS model, one-step prediction", fit2_percent=ls_sim.fit_one_step,
        measured_label="simulated (1 kHz RK4, sampled at 10 ms)", title=FIGURE_CAPTIONS["fig04_ls_simulation"], units=opt.units)}
    w_rls_sim, th_sim = rls_pass(model, meas_sim.u, meas_sim.w, lam=opt.lam_sim, P0=opt.P0)
    fit_rls_sim = nrmse_fit(meas_sim.w[2:], w_rls_sim[2:])
    figs["fig05_rls_simulation"] = plot_velocity_fit(
        meas_sim.t, meas_sim.w, w_rls_sim, model_label=f"RLS a-priori prediction (λ = {opt.lam_sim:g})",
        fit_percent=fit_rls_sim, measured_label="simulated", title=FIGURE_CAPTIONS["fig05_rls_simulation"], units=opt.units)
    numbers = {"duration": opt.sim_duration, "Ts": Ts_sim, "n_samples": int(meas_sim.t.shape[0]),
               "ls_fit_one_step": ls_sim.fit_one_step, "ls_fit_free_run": ls_sim.fit_free_run,
               "ls_estimate": _estimate_dict(ls_sim.estimate), "rls_fit": fit_rls_sim, "rls_lam": opt.lam_sim,
               "rls_estimate": _estimate_dict(model.to_physical(th_sim[-1], Ts_sim))}
    return figs, numbers


def _figs9_12_experiment(p: JointParams, opt: PaperFigureOptions, model: RegressionModel, design, meas) -> tuple:
    """Sec. V-D/E: LS and RLS on the irregular samples as they are; returns ``(figures, numbers)``."""
    Ts_exp = meas.Ts
    ls_exp = fit_ls(model, meas.u, meas.w, Ts=Ts_exp)
    figs = {"fig09_ls_experiment": plot_velocity_fit(
        meas.t, meas.w, ls_exp.w_one_step, model_label="LS model, one-step prediction",
        fit_percent=ls_exp.fit_one_step, w_model2=ls_exp.w_free_run, model2_label="LS model, free run",
        fit2_percent=ls_exp.fit_free_run, measured_label="measured (irregular readout, noise, quantised torque)",
        title=FIGURE_CAPTIONS["fig09_ls_experiment"], units=opt.units)}
    figs["fig10_sample_time"] = plot_sample_times(meas.t)
    figs["fig07_input_torque"] = plot_input_torque(meas.t, meas.u, title=FIGURE_CAPTIONS["fig07_input_torque"])
    w_rls, th = rls_pass(model, meas.u, meas.w, lam=opt.lam_exp, P0=opt.P0)
    fit_rls = nrmse_fit(meas.w[2:], w_rls[2:])
    figs["fig11_rls_experiment"] = plot_velocity_fit(
        meas.t, meas.w, w_rls, model_label=f"RLS a-priori prediction (λ = {opt.lam_exp:g})", fit_percent=fit_rls,
        title=FIGURE_CAPTIONS["fig11_rls_experiment"], units=opt.units)
    figs["fig12_rls_parameters"] = plot_parameter_convergence(
        meas.t[2:], th, model.names, true=model.theta_from_physical(p, Ts_exp),
        title=f"{FIGURE_CAPTIONS['fig12_rls_parameters']} (λ = {opt.lam_exp:g}; dashed: true plant at mean Ts)",
        units=opt.units)
    d = np.diff(meas.t)
    numbers = {
        "duration": opt.exp_duration, "n_samples": int(meas.t.shape[0]), "Ts_mean": float(d.mean()),
        "Ts_min": float(d.min()), "Ts_max": float(d.max()), "noise_std": opt.noise_std,
        "quantization": opt.quantization,
        "controller": {"Kp": design.Kp, "Ki": design.Ki, "Tc": design.Tc, "phase_margin": design.phase_margin},
        "ls_fit_one_step": ls_exp.fit_one_step, "ls_fit_free_run": ls_exp.fit_free_run,
        "ls_estimate": _estimate_dict(ls_exp.estimate), "rls_fit": fit_rls, "rls_lam": opt.lam_exp,
        "rls_estimate": _estimate_dict(model.to_physical(th[-1], Ts_exp))}
    return figs, numbers


def _write_demo_logs(out: Path, p: JointParams, vel, opt: PaperFigureOptions, experiment, rng) -> dict:
    """``quasi_static_log.csv``, ``robot_log.csv``, ``controller_log.csv``, ``controller.json`` and ``plant.json``
    (see :func:`paper_figures`) of the ``experiment`` (a
    :class:`controllers.experiments.synthetic_logs.ClosedLoopReadout`); ``{name: Path}``."""
    run, meas = experiment.run, experiment.measurement
    resp = run.response
    data_files = {}
    qlog = quasi_static_log(p, vel, hold=1.5, settle=1.5, noise_std=opt.noise_std, rng=rng)
    data_files["quasi_static_log"] = write_log_csv(
        out / "quasi_static_log.csv", {"t": qlog.t, "u": qlog.u, "w": qlog.w},
        header_comment="simulated bidirectional constant-velocity runs: t (s), u (N·m), w (rad/s)")
    counts = encoder_counts(resp, meas.t, counts_per_rev=DEMO_COUNTS_PER_REV)
    data_files["robot_log"] = write_log_csv(
        out / "robot_log.csv",
        {"time_ms": np.round(meas.t * 1e3, 6), "current_A": meas.u / DEMO_CURRENT_TO_TORQUE,
         "velocity_deg_s": np.rad2deg(meas.w), "encoder_counts": counts, "reference_deg_s": np.rad2deg(experiment.w_ref)},
        header_comment=(f"simulated robot-joint log: u = {DEMO_CURRENT_TO_TORQUE:g} N·m/A * current_A, "
                        f"{DEMO_COUNTS_PER_REV} counts/rev, irregular readout; reference_deg_s: the commanded "
                        "velocity; the PI velocity loop (1 kHz) is in controller.json"))
    data_files["controller_log"] = write_controller_log(out / "controller_log.csv", run,
                                                        current_to_torque=DEMO_CURRENT_TO_TORQUE)
    ctl_json = out / "controller.json"
    ctl_json.write_text(json.dumps(experiment.controller(), indent=2) + "\n")
    data_files["controller"] = ctl_json
    plant_json = out / "plant.json"
    plant_json.write_text(json.dumps(p.to_dict(), indent=2) + "\n")
    data_files["plant"] = plant_json
    return data_files


def paper_figures(out_dir, *, p: JointParams | None = None, options: PaperFigureOptions | None = None,
                  save_data: bool = False, progress: bool | None = None, dpi: int = 110) -> PaperFigures:
    """Regenerate the paper's Figs. 4, 5, 7, 8, 9, 10, 11, 12 from the simulated joint and write them as PNG.

    Parameters
    ----------
    out_dir : str or os.PathLike
        Output directory (created).
    p : JointParams, keyword-only
        Plant; default the ``paper`` preset.
    options : PaperFigureOptions, keyword-only
        Seed, run lengths, speeds, noise, quantisation and RLS settings; default
        ``PaperFigureOptions()`` (30 s simulation, 60 s experiment, 10 speeds,
        1e-3 rad/s noise, 0.6 N·m quantum, lambda 0.995 and 0.85, P0 = 1e4).
    save_data : bool, keyword-only
        Also write demonstration logs: ``quasi_static_log.csv`` (``t, u, w``)
        for ``adaptive-ff stribeck`` and ``robot_log.csv`` (``time_ms``,
        ``current_A`` with ``u = 60 A·current``, ``velocity_deg_s``,
        ``encoder_counts`` with :data:`DEMO_COUNTS_PER_REV`; irregular time
        stamps) for ``adaptive-ff identify``, ``controller_log.csv`` (the same run as the PI
        recorded it at 1 kHz: ``time_ms``, ``current_A``, ``velocity_deg_s``,
        ``reference_deg_s``; :func:`controllers.experiments.synthetic_logs.write_controller_log`),
        plus ``plant.json`` and ``controller.json`` (the PI of the loop: ``Kp`` N·m·s/rad, ``Ki`` N·m/rad,
        ``Tc`` s, ``u_max`` N·m, as :class:`controllers.experiments.closed_loop_id.ControllerSpec` reads it);
        ``robot_log.csv`` also has ``reference_deg_s`` (the commanded velocity at the stamps) for
        ``identify --method closed_loop``.
    progress : bool or None, keyword-only
        tqdm progress bar over the stages (None: when stderr is a terminal).
    dpi : int, keyword-only
        PNG resolution.

    Returns
    -------
    PaperFigures

    Raises
    ------
    TypeError
        ``p`` not a JointParams or ``options`` not a PaperFigureOptions.
    ExcitationError
        A fit fails for lack of excitation (too short runs).

    Notes
    -----
    The experiments of the module docstring (Ruderman, Secs. IV and V), in the
    order Fig. 8 (its ``Vs``, ``delta`` fix the regression model of the others),
    Figs. 4-5, Figs. 9-12. One ``numpy.random.SeedSequence(options.seed)`` is
    spawned into independent streams for the stages.
    """
    from tqdm.auto import tqdm

    p = preset("paper") if p is None else p
    if not isinstance(p, JointParams):
        raise TypeError(f"p must be a JointParams, got {type(p).__name__}")
    opt = PaperFigureOptions() if options is None else options
    if not isinstance(opt, PaperFigureOptions):
        raise TypeError(f"options must be a PaperFigureOptions, got {type(opt).__name__}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ss = np.random.SeedSequence(opt.seed)
    qs_ss, sim_ss, ref_ss, times_ss, meas_ss, loop_ss = ss.spawn(6)
    Tc = 1e-3
    peak = math.radians(20.0)
    numbers: dict = {"plant": p.to_dict(), "seed": opt.seed}
    bar = tqdm(total=5, desc="paper-figures", disable=(None if progress is None else not progress), leave=False)

    bar.set_postfix_str("quasi-static runs (Fig. 8)")
    vel, model, fig8, numbers["stribeck"] = _fig8_stribeck(p, opt, qs_ss)
    figs = {"fig08_stribeck": fig8}
    bar.update()
    bar.set_postfix_str("simulation LS/RLS (Figs. 4, 5)")
    sim_figs, numbers["simulation"] = _figs45_simulation(p, opt, model, sim_ss, Tc, peak)
    figs.update(sim_figs)
    bar.update()
    bar.set_postfix_str("closed-loop experiment (Figs. 9-12)")
    exp = closed_loop_readout(p, opt.exp_duration, seeds=(ref_ss, loop_ss, times_ss, meas_ss),
                              crossover=opt.crossover, peak=peak, noise_std=opt.noise_std,
                              quantization=opt.quantization, Tc=Tc)
    design, run, meas = exp.design, exp.run, exp.measurement
    bar.update()
    bar.set_postfix_str("LS/RLS on the irregular samples")
    exp_figs, numbers["experiment"] = _figs9_12_experiment(p, opt, model, design, meas)
    numbers["experiment"]["motion"] = joint_motion(run.response.w)
    figs.update(exp_figs)
    bar.update()

    bar.set_postfix_str("writing")
    paths = save_figures({stem: figs[stem] for stem in FIGURE_CAPTIONS}, out, dpi=dpi)
    data_files = {}
    if save_data:
        data_files = _write_demo_logs(out, p, vel, opt, exp, np.random.default_rng(ss.spawn(1)[0]))
    bar.update()
    bar.close()
    return PaperFigures(out_dir=out, figures=dict(zip(FIGURE_CAPTIONS, paths)), captions=dict(FIGURE_CAPTIONS),
                        numbers=numbers, data_files=data_files)


# --------------------------------------------------------------------------- user data


def identification_figures(report, data) -> dict:
    """The paper's kinds of figures for an identified measured log (for ``identify --plot/--report``).

    Parameters
    ----------
    report : adaptive_ff.identification.identify.IdentificationReport
        Result of :func:`adaptive_ff.identification.identify.identify` on ``data``.
    data : adaptive_ff.io.data.MeasuredData
        The record as loaded (time stamps may be non-uniform).

    Returns
    -------
    dict
        ``{"ls_fit": Figure, "rls_fit": Figure, "rls_parameters": Figure,
        "sample_time": Figure}``: measured vs LS (one-step and free-run)
        velocity (Fig. 9 kind), measured vs RLS a-priori velocity (Fig. 11),
        RLS parameter convergence (Fig. 12), sample-time plot (Fig. 10).

    Notes
    -----
    :func:`adaptive_ff.identification.identify.identify` fits on a uniform grid
    (:func:`adaptive_ff.io.data.to_uniform`); the model curves are drawn on that
    grid, and the RLS pass is repeated with the report's ``lam`` and ``P0`` to
    get its a-priori predictions.
    """
    from adaptive_ff.io.data import to_uniform

    uni = to_uniform(data)
    ls = report.ls
    model = ls.model
    figs = {"ls_fit": plot_velocity_fit(
        uni.t, uni.w, ls.w_one_step, model_label="LS model, one-step prediction", fit_percent=ls.fit_one_step,
        w_model2=ls.w_free_run, model2_label="LS model, free run", fit2_percent=ls.fit_free_run,
        title=f"measured and offline (LS) identified velocity: {data.source}")}
    w_rls, th = rls_pass(model, uni.u, uni.w, lam=report.lam, P0=report.P0)
    figs["rls_fit"] = plot_velocity_fit(
        uni.t, uni.w, w_rls, model_label=f"RLS a-priori prediction (λ = {report.lam:g})",
        fit_percent=nrmse_fit(uni.w[2:], w_rls[2:]), title="measured and online (RLS) identified velocity")
    figs["rls_parameters"] = plot_parameter_convergence(uni.t[2:], th, model.names)
    figs["sample_time"] = plot_sample_times(data.t)
    return figs


def save_figures(figures: dict, out_dir, *, dpi: int = 110) -> list:
    """Write ``{stem: Figure}`` as ``out_dir/<stem>.png`` (directory created), e.g. for ``identify --plot DIR``.

    Parameters
    ----------
    figures : dict
        ``{file stem: matplotlib.figure.Figure}``, e.g. from :func:`identification_figures`.
    out_dir : str or os.PathLike
        Directory.
    dpi : int, keyword-only
        Resolution.

    Returns
    -------
    list of Path
        The files written, in the order of ``figures``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for stem, fig in figures.items():
        path = out / f"{stem}.png"
        fig.savefig(path, dpi=dpi)
        paths.append(path)
    return paths
