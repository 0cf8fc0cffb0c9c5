"""Figures of a comparison run (PNG): tracking, error, friction estimate, RLS convergence (cf. paper Fig. 12)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # annotations only: matplotlib is imported by the functions when they run
    from matplotlib.figure import Figure

__all__ = ["plot_comparison", "plot_tracking", "plot_error", "plot_friction", "plot_rls_convergence"]

_STRIDE = 10  # plot every 10th controller sample (100 Hz): lighter files, same picture


def plot_tracking(comp) -> Figure:
    """Reference vs actual velocity (deg/s) over time (s), one panel per mode."""
    modes = list(comp.results)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 1.9 * len(modes)), layout="constrained")
    axes = fig.subplots(len(modes), 1, sharex=True, squeeze=False)[:, 0]
    for ax, mode in zip(axes, modes):
        r = comp.results[mode]
        s = slice(None, None, _STRIDE)
        ax.plot(r.t[s], np.rad2deg(r.w_ref[s]), "k--", lw=0.8, label="reference")
        ax.plot(r.t[s], np.rad2deg(r.w[s]), lw=0.8, label="velocity")
        ax.set_ylabel("w [deg/s]")
        ax.set_title(f"{mode}: RMS error {np.rad2deg(r.metrics.rms_second_half):.3f} deg/s (2nd half)",
                     fontsize=9, loc="left")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    return fig


def plot_error(comp) -> Figure:
    """Tracking error (deg/s) over time (s), all modes overlaid, with a zoom on the second half."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 6), layout="constrained")
    ax1, ax2 = fig.subplots(2, 1)
    for mode, r in comp.results.items():
        s = slice(None, None, _STRIDE)
        e = np.rad2deg(r.w_ref - r.w)
        ax1.plot(r.t[s], e[s], lw=0.7, label=mode)
        half = r.t >= 0.5 * r.t[-1]
        ax2.plot(r.t[half][::_STRIDE], e[half][::_STRIDE], lw=0.7, label=mode)
    ax1.set_ylabel("error [deg/s]")
    ax1.set_title("tracking error w_ref - w", fontsize=9, loc="left")
    ax1.legend(fontsize=8, ncol=5, loc="upper right")
    ax2.set_ylabel("error [deg/s]")
    ax2.set_xlabel("time [s]")
    ax2.set_title("second half (metrics window)", fontsize=9, loc="left")
    return fig


def plot_friction(comp) -> Figure:
    """True friction torque vs the feedforward of the fixed and adaptive modes (N·m) over time (s)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 4.5), layout="constrained")
    ax = fig.subplots()
    ref = comp.results.get("adaptive") or comp.results["none"]
    s = slice(None, None, _STRIDE)
    ax.plot(ref.t[s], ref.f[s], "k", lw=1.0, label="true friction f (adaptive run)")
    for mode, style in (("fixed", "C1"), ("adaptive", "C2"), ("canudas", "C3"), ("dob", "C4")):
        if mode in comp.results:
            r = comp.results[mode]
            what = "disturbance estimate" if mode == "dob" else "feedforward"
            ax.plot(r.t[s], r.u_ff[s], style, lw=0.8, label=f"{what} ({mode})")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("torque [N·m]")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title("estimated vs true friction", fontsize=9, loc="left")
    return fig


def _true_sliding(plant, names, t):
    """True values of the sliding estimator's parameters at times ``t`` (NaN where the plant has no such parameter)."""
    out = np.full((len(t), len(names)), np.nan)
    for j, ti in enumerate(t):
        p = plant.at(ti) if hasattr(plant, "at") else plant
        tau = getattr(p, "tau", None)
        vals = {"J": p.J, "Fc": p.Fc, "Fs": p.Fs, "sigma": p.sigma, "offset": 0.0}
        if tau is not None:
            vals.update(tau=tau, J_tau=p.J * tau)
        if hasattr(p, "Fc_pos"):  # asymmetric: the offset carries half the level difference
            vals["offset"] = 0.5 * (p.Fc_pos - p.Fc_neg)
        out[j] = [vals.get(n, np.nan) for n in names]
    return out


def plot_rls_convergence(comp) -> Figure | None:
    """Parameter trajectories of the adaptive run (like paper Fig. 12), with the true values dashed.

    For the sliding estimator the parameters are physical (J in kg·m², J*tau
    in kg·m²·s, tau in s, Fc, Fs, offset in N·m, sigma in N·m·s/rad); for the
    eq. 4 estimator they are the regression coefficients of eq. 4.
    """
    r = comp.results.get("adaptive")
    if r is None or r.theta.size == 0:
        return None
    names = r.info["names"]
    if r.info.get("estimator") == "sliding":
        stride = max(len(r.t_theta) // 2000, 1)
        tt, th = r.t_theta[::stride], r.theta[::stride]
        true = _true_sliding(comp.plant, names, tt)
        title = "sliding estimator: physical parameters (SI units)"
    else:
        tt, th = r.t_theta, r.theta
        p0 = comp.plant.at(0.0) if hasattr(comp.plant, "at") else comp.plant
        true = np.tile(comp.model.theta_from_physical(p0, r.info["Ts"]), (len(tt), 1))
        title = "RLS parameter convergence, eq. 4 coefficients (units: rad/s per unit of regressor)"
    n = len(names)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 1.6 * n), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for i, (ax, name) in enumerate(zip(axes, names)):
        ax.plot(tt, th[:, i], lw=0.8)
        ax.plot(tt, true[:, i], color="k", ls="--", lw=0.8, label="true plant")
        ax.set_ylabel(name)
        lo, hi = np.percentile(th[len(th) // 10:, i], [1, 99])
        tv = true[:, i][np.isfinite(true[:, i])]
        if tv.size:
            lo, hi = min(lo, tv.min()), max(hi, tv.max())
        pad = 0.5 * (hi - lo) + 1e-12
        ax.set_ylim(lo - pad, hi + pad)
    axes[0].legend(fontsize=8, loc="upper right")
    axes[0].set_title(title, fontsize=9, loc="left")
    axes[-1].set_xlabel("time [s]")
    return fig


def plot_comparison(comp, out_dir) -> list[Path]:
    """Write the comparison figures as PNG files into ``out_dir`` (created if needed).

    Parameters
    ----------
    comp : controllers.experiments.compare.Comparison
    out_dir : str or Path

    Returns
    -------
    list of Path
        ``tracking.png``, ``error.png``, ``friction.png`` and (adaptive mode)
        ``rls_convergence.png``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fn in (("tracking", plot_tracking), ("error", plot_error), ("friction", plot_friction),
                     ("rls_convergence", plot_rls_convergence)):
        fig = fn(comp)
        if fig is None:
            continue
        path = out / f"{name}.png"
        fig.savefig(path, dpi=110)
        paths.append(path)
    return paths
