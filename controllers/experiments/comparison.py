"""The result of :func:`controllers.experiments.compare.compare`: :class:`Comparison`, its efficiency eta and
its notes.

eta is the compensation efficiency ``(RMS_none - RMS_mode)/(RMS_none - RMS_frictionless)`` of the second half of
the run (1: the frictionless limit, 0: no better than no compensation); :data:`WORSE_THAN_NONE` marks a mode that
tracked worse than none. :func:`run_notes` and :func:`worse_than_none_notes` say in words what the adaptive modes
decided during their runs and where a mode hurt.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from controllers.simulation.metrics import deviation_rms, first_active_time
from plant.models import plant_to_dict
from plant.results import axes_or_new, json_safe

if TYPE_CHECKING:  # annotations only
    from adaptive_ff.compensation.sliding_estimator import SlidingFit
    from adaptive_ff.identification.ls import LSResult
    from adaptive_ff.identification.regression import RegressionModel
    from adaptive_ff.identification.stribeck_fit import StribeckFit
    from controllers.design.pi import PIDesign
    from controllers.experiments.first_inertia import InertiaExperiment
    from controllers.experiments.quasi_static import StribeckExperiment

__all__ = ["Comparison", "options_with_changes", "WORSE_THAN_NONE", "diverged_notes", "eta", "eta_or_none", "mode_width", "number_text",
           "run_notes", "settling_text", "whole_run_metrics", "worse_than_none_notes", "beyond_frictionless_notes"]

#: eta below this is "worse than none" (:func:`worse_than_none_notes`, the zoo's
#: :meth:`controllers.experiments.zoo.ZooResult.worse_than_none`): a compensation that raises the tracking error above
#: the uncompensated loop's by more than 2 % of what friction costs it.
WORSE_THAN_NONE = -0.02



def eta(rms_none: float, rms_mode: float, rms_frictionless: float) -> float:
    """Compensation efficiency ``(RMS_none - RMS_mode) / (RMS_none - RMS_frictionless)``.

    1 means the mode reaches the frictionless limit, 0 no improvement, < 0 worse
    than no compensation. NaN (the numeric form, for arrays: the zoo) where it is
    undefined: friction does not degrade the loop at all (``RMS_none <=
    RMS_frictionless``, e.g. a joint without friction, where it is 0/0) or an RMS
    is NaN (a diverged run); :class:`Comparison` reports it as None.
    """
    den = rms_none - rms_frictionless
    return float((rms_none - rms_mode) / den) if den > 0 else float("nan")


def settling_text(settling_max: float, n_unsettled: int) -> str:
    """A table cell for the longest settling time (s): ``"0.123"``, ``"no (k)"`` when k stops did not settle into
    their band, ``"-"`` without stops in the second half (NaN)."""
    if math.isinf(settling_max):
        return f"no ({n_unsettled})"
    return "-" if math.isnan(settling_max) else f"{settling_max:.3f}"


def eta_or_none(rms_none: float, rms_mode: float, rms_frictionless: float) -> float | None:
    """:func:`eta`, None where it is undefined (not finite)."""
    e = eta(rms_none, rms_mode, rms_frictionless)
    return e if np.isfinite(e) else None


def whole_run_metrics(results: dict) -> dict:
    """The whole-run fields of a :class:`Comparison` from its recorded runs ``results`` (``{mode:
    ClosedLoopResult}``, ``"none"`` and ``"frictionless"`` among them): ``{"eta_full": {mode: eta over the whole
    run or None}, "rms_dev": {mode: RMS deviation from the frictionless run's velocity (rad/s)}, "t_ff_on": {mode:
    first time its feedforward acts (s), None for none and frictionless}}``."""
    rn, rf = results["none"].metrics.rms, results["frictionless"].metrics.rms
    w_lim = results["frictionless"].w
    out = {"eta_full": {}, "rms_dev": {}, "t_ff_on": {}}
    for mode, r in results.items():
        out["eta_full"][mode] = eta_or_none(rn, r.metrics.rms, rf)
        out["rms_dev"][mode] = deviation_rms(r.w, w_lim)
        out["t_ff_on"][mode] = None if mode in ("none", "frictionless") else first_active_time(r.t, r.u_ff)
    return out


@dataclass(frozen=True)
class Comparison:
    """All modes on one scenario.

    Attributes
    ----------
    plant : JointParams or another plant model
        True plant (see :mod:`plant.models`).
    design : PIDesign
        The PI design used in every mode.
    results : dict[str, ClosedLoopResult]
        One run per mode, same reference and noise.
    eta : dict[str, float or None]
        Compensation efficiency per mode (second half of the run, :func:`eta`); None where it is undefined:
        friction does not degrade the loop (a joint without friction: 0/0) or a run diverged.
    eta_full : dict[str, float or None]
        The same over the whole run (start-up included).
    rms_dev : dict[str, float]
        RMS of ``w - w_frictionless`` over the whole run (rad/s): the distance of the mode's trajectory from
        the frictionless run with the same reference and noise (does not saturate near the limit as eta does).
    t_ff_on : dict[str, float or None]
        Time (s) at which the mode's compensation first acts (non-zero torque); None for ``none`` and
        ``frictionless`` and for a compensator that never switched on.
    prefit : StribeckFit or None
        Stribeck pre-fit (Sec. V-C) that gave Vs, delta to the regression model.
    offline : SlidingFit or LSResult or None
        The offline identification behind the ``fixed`` mode.
    model : RegressionModel
        Regression structure of eq. 4 with the pre-fitted Vs, delta (used by
        the ``eq4`` alternatives).
    experiment : StribeckExperiment or None
        The quasi-static runs (designed from the joint's response) behind the
        pre-fit and the measured torque scale; None when neither was needed.
    J_design : float or None
        Design inertia used (kg·m²).
    inertia : InertiaExperiment or None
        The experiment that identified the design inertia
        (:func:`controllers.experiments.first_inertia.inertia_experiment`); None where it was given.
    notes : tuple of str
        What the pre-fit could not do as asked (e.g. the Coulomb + viscous
        fallback of a joint without Stribeck effect, runs that did not hold),
        and the fallback of ``fixed`` when its offline fit was rejected (a
        note starting with ``"fixed:"``).
    """

    plant: object
    design: PIDesign
    results: dict
    eta: dict
    prefit: StribeckFit | None
    offline: SlidingFit | LSResult | None
    model: RegressionModel
    experiment: StribeckExperiment | None = None
    J_design: float | None = None
    notes: tuple = ()
    eta_full: dict = field(default_factory=dict)
    rms_dev: dict = field(default_factory=dict)
    t_ff_on: dict = field(default_factory=dict)
    inertia: InertiaExperiment | None = None

    @property
    def has_stops(self) -> bool:
        """Whether the reference comes to rest (point-to-point moves): :meth:`rows`, :meth:`table` and
        :meth:`to_dict` then carry the motion metrics (:class:`controllers.simulation.metrics.MotionMetrics`)."""
        return any(getattr(r, "has_stops", False) for r in self.results.values())

    def rows(self) -> list[dict]:
        """One dict per mode: mode, rms, max, rms_reversal (second half, rad/s), u_rms (N·m), eta, eta_full,
        rms_dev (whole run, rad/s) and t_ff_on (s or None); when the reference has stops (:attr:`has_stops`) also
        rms_motion (RMS error in motion, second half, rad/s), settling_max (longest settling time of the
        second-half stops, s; inf when one did not settle), n_unsettled (those stops) and max_reversal (largest
        error at the second-half reversals, rad/s; NaN without reversals)."""
        out = []
        nan = float("nan")
        stops = self.has_stops
        for mode, r in self.results.items():
            m = r.metrics
            row = {"mode": mode, "rms": m.rms_second_half, "max": m.max_second_half,
                   "rms_reversal": m.rms_reversal, "u_rms": m.u_rms, "eta": self.eta[mode],
                   "eta_full": self.eta_full.get(mode), "rms_dev": self.rms_dev.get(mode, nan),
                   "t_ff_on": self.t_ff_on.get(mode)}
            if stops:
                mm = r.motion
                row.update(rms_motion=mm.rms_motion, settling_max=mm.settling_max, n_unsettled=mm.n_unsettled,
                           max_reversal=mm.max_reversal)
            out.append(row)
        return out

    def table(self) -> str:
        """The comparison as a fixed-width text table (velocities in deg/s; eta full, deviation and switch-on
        time over the whole run; an undefined eta and a compensation that never acts print as ``-``; a run that
        diverged prints ``diverged`` and ``-``). With stops in the reference three more columns: the RMS error in
        motion, the longest settling time (``no (k)``: k stops did not settle into the band) and the largest
        error at a reversal (second half). Every column keeps its width for any value (:func:`number_text`)."""
        stops = self.has_stops
        research = self.research_rows()
        names = {m: m + ("*" if m in research else "") for m in self.results}
        wm = mode_width(names.values())
        head = (f"{'mode':<{wm}}{'RMS [deg/s]':>12}{'max [deg/s]':>13}{'reversal RMS':>14}{'u RMS [N·m]':>13}"
                f"{'eta':>8}{'eta full':>9}{'dev [deg/s]':>12}{'t_on [s]':>9}")
        widths = [12, 13, 14, 13, 8, 9, 12, 9]
        if stops:
            head += f"{'motion RMS':>12}{'settle max [s]':>16}{'rev. max':>10}"
            widths += [12, 16, 10]
        lines = [head, "-" * len(head)]
        d = np.rad2deg
        for row in self.rows():
            name = names[row["mode"]]
            if self.results[row["mode"]].info.get("diverged"):
                lines.append(f"{name:<{wm}}" + "".join(f"{'diverged' if i == 0 else '-':>{w}}"
                                                              for i, w in enumerate(widths)))
                continue
            line = (f"{name:<{wm}}{number_text(d(row['rms']), 12)}{number_text(d(row['max']), 13)}"
                    f"{number_text(d(row['rms_reversal']), 14)}{number_text(row['u_rms'], 13, 2)}"
                    f"{number_text(row['eta'], 8, 3, missing='-')}{number_text(row['eta_full'], 9, 3, missing='-')}"
                    f"{number_text(d(row['rms_dev']), 12)}{number_text(row['t_ff_on'], 9, 3, missing='-')}")
            if stops:
                line += (f"{number_text(d(row['rms_motion']), 12)}"
                         f"{settling_text(row['settling_max'], row['n_unsettled']):>16}"
                         f"{number_text(d(row['max_reversal']), 10)}")
            lines.append(line)
        if research:
            by = {}
            for m, e in research.items():
                by.setdefault(e, []).append(m)
            lines.append("* " + "; ".join(f"estimator {e!r} ({', '.join(ms)})" for e, ms in by.items())
                         + ": research variants; export-c writes mode adaptive with the sliding estimator")
        return "\n".join(lines)

    def research_rows(self) -> dict:
        """``{mode: estimator}`` of the adaptive rows whose estimator is not the one ``export-c`` writes for a drive
        (``sliding``): the table marks them with ``*`` and a footnote, as no drive runs them."""
        out = {}
        for m, r in self.results.items():
            e = (r.info or {}).get("estimator")
            if (m.startswith("adaptive")) and e is not None and e != "sliding":
                out[m] = e
        return out

    def to_dict(self) -> dict:
        """:meth:`to_json_dict` as strict JSON (an undefined eta is None, ``null``; any NaN becomes None)."""
        return json_safe(self.to_json_dict())

    def summary(self) -> str:
        """The comparison table (:meth:`table`), then the notes of the pre-fit, one per line."""
        return "\n".join([self.table()] + [f"note: {n}" for n in self.notes])

    def plot(self, ax=None):
        """Bar chart of eta per mode on ``ax`` (a new figure when None; an undefined eta an empty bar); returns
        the Axes."""
        ax = axes_or_new(ax, figsize=(6.0, 3.0))
        modes = list(self.eta)
        vals = [self.eta[m] for m in modes]
        ax.bar(modes, [0.0 if v is None else v for v in vals], color="C0")
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
        ax.set_ylabel("eta [-] (1 = frictionless)")
        ax.set_xlabel("compensation mode")
        return ax

    def to_json_dict(self) -> dict:
        """``{"modes": {mode: {"rms", "max", "rms_reversal", "u_rms", "eta", "eta_full", "rms_dev", "t_ff_on"}},
        ...}`` in SI units (rad/s, N·m, s; ``t_ff_on`` None where no compensation acts, ``eta`` and ``eta_full``
        None where undefined); ``J_design`` and ``inertia`` (where it was identified:
        :meth:`controllers.experiments.first_inertia.InertiaExperiment.to_dict`);
        ``no_friction`` (when quasi-static runs were made: True where they measured no
        friction, ``StribeckExperiment.no_friction``); ``offline_ls`` (when
        ``fixed`` ran): its offline fit's J, tau, sigma, Fc, Fs with ``accepted`` (False when the fit was rejected
        and ``fixed`` used a fallback) and ``reason`` (the ``"fixed:"`` note, or None). When the reference has stops
        (:attr:`has_stops`) each mode's row also holds ``rms_motion``, ``settling_max`` (None when a stop did not
        settle: ``n_unsettled`` > 0, or without second-half stops), ``n_unsettled`` and ``max_reversal``, and
        ``motion`` holds each mode's :meth:`controllers.simulation.metrics.MotionMetrics.to_dict` (every stop and
        reversal)."""
        modes = {r["mode"]: {k: (None if v is None else (v if k == "n_unsettled" else float(v)))
                             for k, v in r.items() if k != "mode"} for r in self.rows()}
        out = {"modes": modes, "plant": plant_to_dict(self.plant),
               "controller": {"Kp": self.design.Kp, "Ki": self.design.Ki, "Tc": self.design.Tc,
                              "phase_margin_deg": self.design.phase_margin,
                              "gain_margin": self.design.gain_margin}}
        if self.prefit is not None:
            out["prefit"] = {k: float(getattr(self.prefit, k)) for k in ("Fc", "Fs", "Vs", "delta", "sigma")}
            out["prefit"]["fallback"] = self.prefit.fallback
        if self.J_design is not None:
            out["J_design"] = float(self.J_design)
        if self.inertia is not None:
            out["inertia"] = self.inertia.to_dict()
        if self.experiment is not None:
            out["no_friction"] = bool(self.experiment.no_friction)
        out["notes"] = list(self.notes)
        if self.offline is not None:
            e = self.offline.estimate
            out["offline_ls"] = {k: float(getattr(e, k)) for k in ("J", "tau", "sigma", "Fc", "Fs")}
            rejected = [n for n in self.notes if n.startswith("fixed: the offline fit")]
            out["offline_ls"].update(accepted=not rejected, reason=rejected[0] if rejected else None)
        for mode, r in self.results.items():
            if r.info.get("diverged"):
                out["modes"][mode]["diverged"] = True
        if self.has_stops:
            out["motion"] = {mode: r.motion.to_dict() for mode, r in self.results.items()}
        adaptive = self.results.get("adaptive")
        if adaptive is not None and adaptive.estimate is not None:
            e = adaptive.estimate
            out["adaptive_final"] = {k: float(getattr(e, k)) for k in ("J", "tau", "sigma", "Fc", "Fs")}
        return out


def beyond_frictionless_notes(etas: dict, results: dict) -> tuple:
    """One note per mode whose eta, as the table prints it (three decimals), is above 1: why a compensation can track
    better than the frictionless loop.

    The frictionless loop is the PI alone on the reference; its error is the PI's own (the reference's
    acceleration against the loop's bandwidth, and the sensor's noise). A compensator evaluated at the measured
    velocity, and an observer, are feedback too: they change that loop (a map's slope adds to or takes from the
    loop's damping, an observer rejects the loop's own model error as a disturbance), and eta then counts what
    they do to the loop's own error beside the friction.

    Parameters
    ----------
    etas : dict of str to float or None
        eta (second half) by mode, None where undefined.
    results : dict of str to ClosedLoopResult
        The runs by mode (``"frictionless"`` among them).

    Returns
    -------
    tuple of str
    """
    notes = []
    rf = results["frictionless"].metrics.rms_second_half
    for mode, e in etas.items():
        if mode == "frictionless" or e is None or not round(e, 3) > 1.0:
            continue
        rm = results[mode].metrics.rms_second_half
        notes.append(f"{mode}: eta {e:.3f} > 1: it tracks better than the frictionless loop (second-half RMS "
                     f"{rm:.4g} against {rf:.4g} rad/s), whose error is the PI's own on the reference: a "
                     f"compensator evaluated at the measured velocity, or an observer, is feedback too and changes "
                     f"that loop, and eta counts that beside the friction")
    return tuple(notes)


def worse_than_none_notes(etas: dict, results: dict) -> tuple:
    """One note per mode whose eta is below :data:`WORSE_THAN_NONE`: it tracked worse than no compensation; for mode
    ``adaptive`` (and its estimator rows) run as the feedforward alone (``switch_in=False``: no ``t_switch_in`` in its
    ``info``) the note says that the residual switch-in, the default, is what guards against it.

    Parameters
    ----------
    etas : dict of str to float or None
        eta (second half) by mode, None where undefined.
    results : dict of str to ClosedLoopResult
        The runs by mode.

    Returns
    -------
    tuple of str
    """
    notes = []
    for mode, e in etas.items():
        if e is None or not e < WORSE_THAN_NONE:
            continue
        text = f"{mode}: worse than no compensation (eta {e:.2f} over the second half)"
        info = results[mode].info or {}
        if (mode == "adaptive" or mode.startswith("adaptive[")) and "t_switch_in" not in info:
            text += (f"; it ran as the feedforward alone (switch_in=False, --no-switch-in), with estimator "
                     f"{info.get('estimator')!r}: the residual switch-in, the default, hands over to the observer "
                     f"where the feedforward misses")
        notes.append(text)
    return tuple(notes)


def run_notes(results: dict) -> tuple:
    """What the adaptive modes decided by themselves during their runs, one note per event kind and mode: the
    residual switch-in of ``adaptive`` (:class:`controllers.peers.adaptive_dob.ResidualSwitchIn`, ``info``
    ``t_switch_in``, ``residual_ratio``), its trial's switch-out (``t_switch_out``, ``trial_ratio``) and the
    supervisor's back-offs (``n_backoff``, ``n_restore``, ``t_off``;
    :class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor`).

    Parameters
    ----------
    results : dict of str to ClosedLoopResult
        The runs by mode.

    Returns
    -------
    tuple of str
    """
    notes = []
    for mode, r in results.items():
        info = r.info or {}
        t_in = info.get("t_switch_in")
        if t_in is not None:
            ratio, share = info.get("residual_ratio"), info.get("residual_share")
            why = "" if ratio is None else (f"; what the feedforward leaves raised the loop's mean-square error, as "
                                            f"its model predicts, by {ratio:.2f} times the frictionless loop's"
                                            + ("" if share is None else
                                               f" and {share:.2g} times what the friction would raise it by"))
            notes.append(f"{mode}: the residual observer (as in adaptive-dob) switched in at {t_in:.2f} s{why}")
            t_out = info.get("t_switch_out")
            if t_out is not None:
                rise = info.get("trial_ratio")
                rise = "" if rise is None else f" {100.0 * (rise - 1.0):.1f} % higher in mean square"
                notes.append(f"{mode}: the switch-in's trial took the residual observer out again at {t_out:.2f} s: "
                             f"with it the loop's measured error, relative to the frictionless loop's, was{rise} "
                             f"than with the feedforward alone before the switch-in; the feedforward alone from then "
                             f"on")
        n_off = info.get("n_backoff") or 0
        if n_off:
            notes.append(f"{mode}: the supervisor backed the compensation off {n_off} time(s), restored it "
                         f"{info.get('n_restore') or 0} time(s); {info.get('t_off', 0.0):.2f} s without it")
    return tuple(notes)


def mode_width(names) -> int:
    """Width of a comparison table's mode column: 13 characters, or one more than the longest of ``names``
    (an estimator row ``adaptive[eq4-rls]``, a long name of your own compensator)."""
    return max([13] + [len(n) + 1 for n in names])


def number_text(x: float, width: int, digits: int = 4, *, missing: str = "n/a") -> str:
    """``x`` right-aligned in ``width`` characters with ``digits`` decimals, ``missing`` where it is NaN or None
    (e.g. the reversal RMS of a run without a reversal in its second half). A value whose fixed-point form would
    not leave one blank before it (eta <= -100, a huge RMS) prints in fewer significant digits or in exponent
    form instead: a table's columns keep their widths for any value."""
    if x is None or x != x:
        return f"{missing:>{width}}"
    text = f"{x:.{digits}f}"
    for sig in range(max(digits, 1) + 2, 0, -1):
        if len(text) < width:
            break
        text = f"{x:.{sig}g}"
    return f"{text:>{width}}"


def diverged_notes(results: dict) -> tuple:
    """One note per run that diverged (its velocity left the engine's bound, ``info["diverged"]``): when, and that
    its metrics are undefined.

    Parameters
    ----------
    results : dict of str to ClosedLoopResult
        The runs by mode.

    Returns
    -------
    tuple of str
    """
    notes = []
    for mode, r in results.items():
        if not (r.info or {}).get("diverged"):
            continue
        lost = np.flatnonzero(~np.isfinite(r.w))
        when = f" at t = {float(r.t[lost[0]]):.4g} s" if lost.size else ""
        notes.append(f"{mode}: diverged{when}: its velocity left the run's bound w_limit (by default 100 times the "
                     f"reference's peak plus 1 rad/s); its metrics are undefined")
    return tuple(notes)


def options_with_changes(options, changes: dict, *, where: str):
    """``options`` (a frozen options dataclass) with the fields ``changes`` replaced: the ``**changes`` of
    :func:`controllers.experiments.compare.compare` and :func:`controllers.experiments.compare_arm.compare_arm`.

    Raises
    ------
    ParameterError
        A name that is no field of ``options`` (``where`` names the caller), or the options' own check of a value.
    """
    from plant.errors import ParameterError

    if not changes:
        return options
    try:
        return options.replace(**changes) if hasattr(options, "replace") else replace(options, **changes)
    except TypeError as exc:
        raise ParameterError(f"{where}: {exc}") from None
