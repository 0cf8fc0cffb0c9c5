"""Analysis of a PI velocity-loop design: closed-loop bandwidth, sensitivity peak, step metrics, Bode and step plots.

Builds on :func:`controllers.design.pi.design_pi` (gains and margins from
``control.stability_margins``) and :func:`controllers.design.pi.closed_loop_step`.
Frequency responses are evaluated on the unit circle ``z = exp(j w Tc)`` by
``control.frequency_response``; step metrics by ``control.step_info``.
python-control and matplotlib are imported by the functions that use them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from controllers.design.pi import ClosedLoopStep, PIDesign, closed_loop_step
from plant.errors import check_positive
from plant.results import json_safe

__all__ = ["LoopAnalysis", "analyse_design", "plot_bode", "plot_step", "default_step_duration"]


def default_step_duration(design: PIDesign) -> float:
    """Step-response length (s) that shows the settling: ``15/crossover``, at least ``20*Tc``."""
    return max(15.0 / design.crossover, 20.0 * design.Tc)


@dataclass(frozen=True)
class LoopAnalysis:
    """Closed-loop figures of merit of a :class:`controllers.design.pi.PIDesign`.

    Attributes
    ----------
    design : PIDesign
        The design analysed.
    step : ClosedLoopStep
        Unit velocity-reference step (1 rad/s): velocity and torque.
    bandwidth : float
        Closed-loop bandwidth (rad/s): lowest frequency where
        ``|T| = |L/(1+L)|`` falls below ``1/sqrt(2)`` (-3 dB); NaN if it does
        not below the Nyquist frequency.
    sensitivity_peak : float
        ``Ms = max |1/(1 + L)|`` over ``(0, pi/Tc]`` (1/stability margin).
    complementary_peak : float
        ``Mt = max |T|``.
    rise_time, settling_time : float
        10-90 % rise time and 2 % settling time (s) of the velocity step.
    overshoot : float
        Overshoot of the velocity step (%).
    peak_torque : float
        Largest |torque| (N·m) per 1 rad/s of step (the proportional kick ``Kp + Ki*Tc``).
    """

    design: PIDesign
    step: ClosedLoopStep
    bandwidth: float
    sensitivity_peak: float
    complementary_peak: float
    rise_time: float
    settling_time: float
    overshoot: float
    peak_torque: float

    def to_dict(self) -> dict:
        """Design and closed-loop figures as strict JSON (SI units; gain margin also in dB; inf/NaN as None).

        Keys: those of :meth:`controllers.design.pi.PIDesign.to_dict`, plus
        ``sensitivity_peak``, ``complementary_peak``, ``bandwidth`` and ``step``
        (``rise_time``, ``settling_time``, ``overshoot_percent``,
        ``peak_torque_per_rad_s``, ``duration``).
        """
        return json_safe({
            **self.design.to_dict(),
            "sensitivity_peak": self.sensitivity_peak, "complementary_peak": self.complementary_peak,
            "bandwidth": self.bandwidth,
            "step": {"rise_time": self.rise_time, "settling_time": self.settling_time,
                     "overshoot_percent": self.overshoot, "peak_torque_per_rad_s": self.peak_torque,
                     "duration": float(self.step.t[-1])},
        })

    #: Same as :meth:`to_dict` (the older name).
    to_json_dict = to_dict

    def plot(self, ax=None):
        """Velocity step response (rad/s over s) with the ±2 % band; see :func:`plot_step` for the full figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
        """
        ax = self.step.plot(ax)
        ax.axhspan(0.98, 1.02, color="0.85", alpha=0.6, label="±2 %")
        ax.set_title(f"rise {self.rise_time * 1e3:.1f} ms, overshoot {self.overshoot:.1f} %, "
                     f"settling {self.settling_time * 1e3:.1f} ms", fontsize=9, loc="left")
        return ax

    def summary(self) -> str:
        """Human-readable lines: plant, gains, margins, closed loop."""
        d = self.design
        gm = d.gain_margin
        gm_txt = (f"{gm:.4g} ({20 * math.log10(gm):.1f} dB) at {d.phase_crossover:.5g} rad/s"
                  if math.isfinite(gm) else "inf (no phase crossover below Nyquist)")
        return "\n".join([
            f"plant: P(s) = 1/(J s + sigma), J = {d.J:g} kg·m², sigma = {d.sigma:g} N·m·s/rad; "
            f"ZOH at Tc = {d.Tc:g} s",
            f"PI: Kp = {d.Kp:.6g} N·m·s/rad, Ki = {d.Ki:.6g} N·m/rad   (C(z) = Kp + Ki*Tc*z/(z-1))",
            f"margins: crossover {d.crossover:.5g} rad/s, phase margin {d.phase_margin:.2f} deg, "
            f"gain margin {gm_txt}",
            f"robustness: stability margin {d.stability_margin:.3f} (Ms = {self.sensitivity_peak:.3f}), "
            f"Mt = {self.complementary_peak:.3f}",
            f"closed loop: bandwidth (-3 dB) {self.bandwidth:.5g} rad/s; step: rise {self.rise_time * 1e3:.1f} ms, "
            f"overshoot {self.overshoot:.1f} %, settling (2 %) {self.settling_time * 1e3:.1f} ms, "
            f"peak torque {self.peak_torque:.4g} N·m per rad/s",
        ])


def _frequency_grid(design: PIDesign, n: int = 2000) -> np.ndarray:
    w_nyq = math.pi / design.Tc
    lo = min(design.crossover, design.Ki / max(design.Kp, 1e-300)) / 100.0
    return np.geomspace(lo, w_nyq * (1 - 1e-9), n)


def _mag(sys, omega) -> np.ndarray:
    import control

    return np.abs(np.asarray(control.frequency_response(sys, omega).complex).reshape(-1))


def analyse_design(design: PIDesign, *, t_end: float | None = None) -> LoopAnalysis:
    """Closed-loop bandwidth, sensitivity peaks and step metrics of a PI design.

    Parameters
    ----------
    design : PIDesign
        From :func:`controllers.design.pi.design_pi`.
    t_end : float, keyword-only, optional
        Step-response length (s), default :func:`default_step_duration`.

    Returns
    -------
    LoopAnalysis

    Raises
    ------
    TypeError
        ``design`` is not a :class:`PIDesign`.
    ParameterError
        ``t_end`` not > 0.

    Notes
    -----
    ``T = L/(1+L)``, ``S = 1/(1+L)`` on 2000 log-spaced frequencies up to the
    Nyquist frequency; the -3 dB crossing of ``|T|`` is refined by
    ``scipy.optimize.brentq``. Step metrics: ``control.step_info`` of the
    velocity step of :func:`controllers.design.pi.closed_loop_step` (10-90 % rise,
    2 % settling). Definitions: Åström & Murray, *Feedback Systems*, 2nd ed.,
    Secs. 12.1 (Ms, Mt) and 5.3 (step metrics).
    """
    import control
    from scipy.optimize import brentq

    if not isinstance(design, PIDesign):
        raise TypeError(f"design must be a PIDesign, got {type(design).__name__}")
    t_end = default_step_duration(design) if t_end is None else check_positive("t_end", t_end)
    step = closed_loop_step(design, t_end=t_end)
    T = control.feedback(design.loop, 1)
    S = control.feedback(1, design.loop)
    om = _frequency_grid(design)
    mT = _mag(T, om)
    mS = _mag(S, om)
    below = np.flatnonzero(mT < 1 / math.sqrt(2))
    if below.size and below[0] > 0:
        i = int(below[0])
        f = lambda lw: float(_mag(T, [math.exp(lw)])[0]) - 1 / math.sqrt(2)  # noqa: E731
        bw = math.exp(brentq(f, math.log(om[i - 1]), math.log(om[i]), xtol=1e-12))
    else:
        bw = math.nan
    info = control.step_info(step.w, T=step.t, SettlingTimeThreshold=0.02, RiseTimeLimits=(0.1, 0.9))
    return LoopAnalysis(design=design, step=step, bandwidth=bw, sensitivity_peak=float(mS.max()),
                        complementary_peak=float(mT.max()), rise_time=float(info["RiseTime"]),
                        settling_time=float(info["SettlingTime"]), overshoot=float(info["Overshoot"]),
                        peak_torque=float(np.max(np.abs(step.u))))


def plot_bode(design: PIDesign):
    """Bode plot of the open loop ``L(z) = C(z) P(z)`` with its margins, and ``|S|``, ``|T|``.

    Parameters
    ----------
    design : PIDesign

    Returns
    -------
    matplotlib.figure.Figure
        Magnitude (dB) and phase (deg) over frequency (rad/s) up to the
        Nyquist frequency ``pi/Tc``; the gain crossover with the phase margin
        and the phase crossover with the gain margin are marked (values from
        the design, i.e. ``control.stability_margins`` with the corrections of
        :func:`controllers.design.pi.design_pi`).
    """
    import control
    from matplotlib.figure import Figure

    d = design
    om = _frequency_grid(d)
    resp = np.asarray(control.frequency_response(d.loop, om).complex).reshape(-1)
    mag_db = 20 * np.log10(np.abs(resp))
    phase = np.degrees(np.unwrap(np.angle(resp)))
    # put the phase near -90..-180 deg (unwrap may start a multiple of 360 away)
    phase -= 360.0 * np.round((phase[len(phase) // 2] + 135.0) / 360.0)
    mS = 20 * np.log10(_mag(control.feedback(1, d.loop), om))
    mT = 20 * np.log10(_mag(control.feedback(d.loop, 1), om))
    fig = Figure(figsize=(9.0, 6.5), layout="constrained")
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.semilogx(om, mag_db, color="C0", lw=1.5, label="|L| open loop")
    ax1.semilogx(om, mS, color="C2", lw=0.9, ls="--", label="|S| = |1/(1+L)|")
    ax1.semilogx(om, mT, color="C3", lw=0.9, ls=":", label="|T| = |L/(1+L)|")
    ax1.axhline(0.0, color="k", lw=0.6)
    ax1.axvline(d.crossover, color="C1", lw=0.8)
    ax1.set_ylabel("magnitude (dB)")
    ax1.set_title(f"open loop L(z) = C(z)P(z): Kp = {d.Kp:.4g} N·m·s/rad, Ki = {d.Ki:.4g} N·m/rad, "
                  f"Tc = {d.Tc:g} s", fontsize=10, loc="left")
    ax2.semilogx(om, phase, color="C0", lw=1.5)
    ax2.axhline(-180.0, color="k", lw=0.6)
    ax2.axvline(d.crossover, color="C1", lw=0.8)
    ax2.plot([d.crossover, d.crossover], [-180.0, -180.0 + d.phase_margin], color="C1", lw=3,
             label=f"phase margin {d.phase_margin:.1f}° at {d.crossover:.4g} rad/s")
    if math.isfinite(d.gain_margin):
        wpc = min(d.phase_crossover, om[-1])
        Lpc = float(_mag(d.loop, [wpc])[0])
        ax1.plot([wpc, wpc], [20 * math.log10(Lpc), 0.0], color="C4", lw=3,
                 label=f"gain margin {20 * math.log10(d.gain_margin):.1f} dB at {d.phase_crossover:.4g} rad/s")
    ax1.axvline(math.pi / d.Tc, color="0.5", lw=0.6, ls="-.")
    ax2.axvline(math.pi / d.Tc, color="0.5", lw=0.6, ls="-.", label="Nyquist π/Tc")
    ax1.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside the plot, never over a curve
    ax2.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax2.set_ylabel("phase (deg)")
    ax2.set_xlabel("frequency ω (rad/s)")
    for ax in (ax1, ax2):
        ax.grid(True, which="both", alpha=0.3)
    return fig


def plot_step(analysis: LoopAnalysis):
    """Closed-loop response to a 1 rad/s velocity-reference step: velocity and torque over time.

    Parameters
    ----------
    analysis : LoopAnalysis

    Returns
    -------
    matplotlib.figure.Figure
        Top: velocity (rad/s) with the ±2 % band and the metrics; bottom:
        controller torque (N·m) per 1 rad/s (steady state ``sigma``).
    """
    from matplotlib.figure import Figure

    s = analysis.step
    fig = Figure(figsize=(9.0, 5.5), layout="constrained")
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.step(s.t, s.w, where="post", color="C0", lw=1.2, label="velocity w")
    ax1.axhline(1.0, color="k", lw=0.6, ls="--", label="reference (1 rad/s)")
    ax1.axhspan(0.98, 1.02, color="0.85", alpha=0.6, label="±2 %")
    ax1.set_ylabel("velocity w (rad/s)")
    ax1.set_title(f"closed-loop step (no friction, no saturation): rise {analysis.rise_time * 1e3:.1f} ms, "
                  f"overshoot {analysis.overshoot:.1f} %, settling {analysis.settling_time * 1e3:.1f} ms",
                  fontsize=10, loc="left")
    ax1.legend(fontsize=8, loc="lower right")
    ax2.step(s.t, s.u, where="post", color="C1", lw=1.2)
    ax2.set_ylabel("torque u (N·m)")
    ax2.set_xlabel("time t (s)")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    return fig
