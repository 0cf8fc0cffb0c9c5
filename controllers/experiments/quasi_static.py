"""Bidirectional constant-velocity ("quasi-static") drive experiments, the paper's Sec. V-C / Fig. 8.

For each velocity setpoint the joint is driven by the discrete PI velocity
loop from rest; after a settling time the velocity and the torque are averaged.
At constant velocity the lag state has settled, ``f = F(w)``, and ``J dw/dt = 0``
gives ``u = f = F(w)`` (eqs. 1-3): the mean torques are support points of the
Stribeck curve, to which the paper fits ``Vs`` and ``delta``.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, replace

import numpy as np

from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers._cctl import ffi, lib
from controllers.design.pi import PIController, PIDesign, design_pi
from plant.errors import ExcitationError, ParameterError, SignalError, check_nonnegative, check_positive, check_signal
from plant.friction import JointParams
from plant.results import axes_or_new, json_safe
from plant.rows import plant_params

__all__ = ["QuasiStaticData", "quasi_static_runs", "bidirectional_velocities", "QS_CROSSOVER", "QS_TC",
           "StribeckDesign", "StribeckExperiment", "stribeck_experiment", "prefit_stribeck"]

#: Default crossover (rad/s) of the velocity loop used for the runs: stiff enough that
#: the PI dominates the negative slope of the Stribeck curve (see quasi_static_runs).
QS_CROSSOVER = 150.0
#: Default controller period (s) of the runs' loop (the paper's 1 kHz): the period of the default design.
QS_TC = 1e-3


@dataclass(frozen=True)
class QuasiStaticData:
    """Per-setpoint statistics of constant-velocity runs, see :func:`quasi_static_runs`.

    Attributes
    ----------
    setpoints : ndarray, shape (n,)
        Velocity references (rad/s), in the order given.
    w_mean : ndarray, shape (n,)
        Mean measured velocity over the hold window (rad/s).
    w_std : ndarray, shape (n,)
        Standard deviation of the measured velocity over the window (rad/s).
    u_mean : ndarray, shape (n,)
        Mean torque command over the window (N·m); ``F(w_mean)`` in steady state.
    u_std : ndarray, shape (n,)
        Standard deviation of the torque over the window (N·m): the spread of Fig. 8.
    hold : float
        Length of the averaging window (s).
    settle : float
        Discarded settling time at the start of each run (s).
    Tc : float
        Controller period = integration step (s).
    noise_std : float
        Velocity measurement noise standard deviation (rad/s).
    design : PIDesign
        The velocity-loop design used.
    """

    setpoints: np.ndarray
    w_mean: np.ndarray
    w_std: np.ndarray
    u_mean: np.ndarray
    u_std: np.ndarray
    hold: float
    settle: float
    Tc: float
    noise_std: float
    design: PIDesign

    def to_dict(self) -> dict:
        """Arrays as lists (rad/s, N·m), window settings (s, rad/s) and the loop design, strict JSON."""
        return json_safe({
            "setpoints": self.setpoints, "w_mean": self.w_mean, "w_std": self.w_std, "u_mean": self.u_mean,
            "u_std": self.u_std, "hold": self.hold, "settle": self.settle, "Tc": self.Tc,
            "noise_std": self.noise_std, "design": self.design.to_dict(),
        })

    def summary(self) -> str:
        """Two lines: the runs and the range of the measured support points."""
        n = int(self.setpoints.shape[0])
        return (f"{n} constant-velocity runs, |w_ref| {float(np.min(np.abs(self.setpoints))):.4g} to "
                f"{float(np.max(np.abs(self.setpoints))):.4g} rad/s; settle {self.settle:g} s, hold {self.hold:g} s, "
                f"Tc {self.Tc:g} s, noise {self.noise_std:g} rad/s\n"
                f"mean torque {float(np.min(self.u_mean)):.4g} to {float(np.max(self.u_mean)):.4g} N·m, "
                f"largest spread {float(np.max(self.u_std)):.3g} N·m")

    def plot(self, ax=None):
        """Mean torque over mean velocity with the torque spread as error bars (the points of paper Fig. 8).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
            Velocity (rad/s) on a symmetric-log axis, torque (N·m).
        """
        ax = axes_or_new(ax)
        ax.errorbar(self.w_mean, self.u_mean, yerr=self.u_std, fmt="o", ms=3, color="C0", lw=0.8,
                    label="mean ± std over the hold window")
        ax.set_xscale("symlog", linthresh=max(float(np.min(np.abs(self.w_mean))), 1e-12))
        ax.set_xlabel("velocity w (rad/s)")
        ax.set_ylabel("torque u (N·m)")
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
        return ax


def bidirectional_velocities(w_min: float, w_max: float, n: int) -> np.ndarray:
    """Log-spaced velocity setpoints in both directions.

    Parameters
    ----------
    w_min, w_max : float
        Smallest and largest speed (rad/s), ``0 < w_min < w_max``.
    n : int
        Number of speeds per direction, >= 2.

    Returns
    -------
    ndarray, shape (2*n,)
        ``[-w_max, ..., -w_min, w_min, ..., w_max]`` (ascending), speeds
        ``numpy.geomspace(w_min, w_max, n)``.

    Raises
    ------
    ParameterError
        ``w_min``/``w_max`` not positive or not ordered, or ``n < 2``.
    TypeError
        ``n`` not an integer.

    Notes
    -----
    Log spacing puts half of the points below ``sqrt(w_min*w_max)``, where the
    Stribeck decay (eq. 3) happens; the paper's Fig. 8 samples both directions.
    """
    w_min = check_positive("w_min", w_min)
    w_max = check_positive("w_max", w_max)
    if not w_max > w_min:
        raise ParameterError(f"w_max must be > w_min = {w_min!r}, got {w_max!r}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"n must be an integer, got {n!r} ({type(n).__name__})")
    if n < 2:
        raise ParameterError(f"n must be >= 2, got {n!r}")
    s = np.geomspace(w_min, w_max, int(n))
    return np.concatenate([-s[::-1], s])


def quasi_static_runs(
    p: JointParams,
    velocities,
    *,
    hold: float = 2.0,
    settle: float = 2.0,
    noise_std: float = 0.0,
    rng: np.random.Generator | None = None,
    design: PIDesign | None = None,
    u_max: float = math.inf,
) -> QuasiStaticData:
    """Simulate the bidirectional constant-velocity experiments and average each run.

    Parameters
    ----------
    p : JointParams
        True plant parameters.
    velocities : array_like, shape (n,)
        Velocity setpoints (rad/s), non-zero; pass both signs for a
        bidirectional curve (see :func:`bidirectional_velocities`).
    hold : float, keyword-only
        Averaging window (s) after the settling time, >= the controller period ``design.Tc``.
    settle : float, keyword-only
        Discarded settling time (s), >= 0.
    noise_std : float, keyword-only
        Standard deviation (rad/s) of white Gaussian noise on the measured
        velocity, >= 0. The controller sees it and ``w_mean``/``w_std`` are of
        the measured velocity, as in the experiment.
    rng : numpy.random.Generator, keyword-only
        Noise source; required for reproducibility when ``noise_std > 0``
        (a fresh unseeded generator otherwise).
    design : PIDesign, keyword-only
        Velocity-loop design; its period ``design.Tc`` (s) is the controller period and the RK4 step. Default
        ``design_pi(p.J, sigma=0, crossover=QS_CROSSOVER, phase_margin=60, Tc=QS_TC)`` (1 ms, as the paper):
        the designer knows the inertia only.
    u_max : float, keyword-only
        Torque limit (N·m) of the controller, default none.

    Returns
    -------
    QuasiStaticData
        Arrays of shape (n,) in the order of ``velocities``.

    Raises
    ------
    SignalError
        ``velocities`` not a finite 1-D array.
    ParameterError
        A setpoint is 0, or ``hold``/``settle``/``noise_std``/``u_max`` out of range.
    TypeError
        ``design`` not a :class:`controllers.design.pi.PIDesign`.

    Notes
    -----
    Each run starts at rest (``w = f = 0``, integrator 0) with a step to its
    setpoint. At sample ``k`` the controller reads ``w_k`` (+ noise) and its
    command is held over ``[t_k, t_k + Tc)`` for the RK4 plant
    (:func:`plant.joint.make_rk4_step`); the loop is C
    (``controllers/csrc/ctl_quasi_static.c``, ``ctl_quasi_static_run``: ``ctl_pi_step`` and
    ``plant_step``). Noise-free and settled, ``u = F(w)`` of eq. 3 to rounding.

    Breakaway: from rest the joint creeps and chatters around ``w = 0`` until
    the integrator has built up about ``Fs``; with the error about ``|w_ref|``
    that takes ``t_b ~ Fs/(Ki |w_ref|)`` (0.45 s at 0.002 rad/s for the
    ``paper`` preset and the default loop, 0.9 s at 0.001 rad/s). ``settle``
    must exceed ``t_b`` plus a few closed-loop time constants; the default 2 s
    covers the preset down to about 0.001 rad/s (``Vs/20``).

    Below ``Vs`` the Stribeck curve (``delta > 0``) has a negative slope, down
    to ``sigma - (Fs - Fc)/Vs`` (-460 N·m·s/rad for the ``paper`` preset), which
    acts as negative damping. With the lag of eq. 1 linearised around the
    setpoint (slope ``-k``) the loop polynomial is
    ``J tau s^3 + (J + Kp tau) s^2 + (Kp + Ki tau - k) s + Ki``, so the run holds
    its setpoint when ``Kp + Ki*tau > k`` (and the Routh condition
    ``(J + Kp tau)(Kp + Ki tau - k) > J tau Ki``). A soft loop (e.g. 20 rad/s
    crossover for the preset) fails that at the lowest speeds and ends in a
    stick-slip-like limit cycle (the velocity collapses towards 0, the mean
    torque falls off the curve and ``u_std`` grows to several N·m). A 100 rad/s
    loop satisfies it for the preset but is lightly damped at 0.002 rad/s
    (closed-loop pair decaying as ``exp(-7.7 t)``, seconds to settle); the
    default 150 rad/s loop decays as ``exp(-29 t)`` there. Source of the
    experiment: Ruderman, Sec. V-C, Fig. 8.
    """
    v = check_signal("velocities", velocities)
    if np.any(v == 0.0):
        i = int(np.flatnonzero(v == 0.0)[0])
        raise ParameterError(
            f"velocities must be non-zero (sliding regime, F(0) is not a sliding friction), "
            f"got 0 at index {i}"
        )
    if design is None:
        design = design_pi(p.J, sigma=0.0, crossover=QS_CROSSOVER, phase_margin=60.0, Tc=QS_TC)
    elif not isinstance(design, PIDesign):
        raise TypeError(f"design must be a PIDesign, got {type(design).__name__}")
    Tc = float(design.Tc)
    hold = check_positive("hold", hold)
    settle = check_nonnegative("settle", settle)
    noise_std = check_nonnegative("noise_std", noise_std)
    n_hold = int(round(hold / Tc))
    if n_hold < 1:
        raise ParameterError(f"hold must be >= Tc = {Tc!r} s, got {hold!r}")
    n_settle = int(round(settle / Tc))
    ctrl = PIController.from_design(design, u_max=u_max)
    if noise_std > 0.0 and rng is None:
        rng = np.random.default_rng()
    par = plant_params(p)  # the plant step of p.make_step(Tc)
    n_tot = n_settle + n_hold

    n = v.shape[0]
    w_mean, w_std, u_mean, u_std = (np.empty(n) for _ in range(4))
    W = np.empty(n_hold)
    U = np.empty(n_hold)
    Wp, Up = ffi.from_buffer("double[]", W), ffi.from_buffer("double[]", U)
    for j, wr in enumerate(v.tolist()):
        noise = noise_std * rng.standard_normal(n_tot) if noise_std > 0.0 else np.zeros(n_tot)
        ctrl.reset()
        lib.ctl_quasi_static_run(ctrl.cdata, par, float(wr), ffi.from_buffer("double[]", noise), n_settle, n_hold,
                                 Wp, Up, float(Tc))
        w_mean[j], w_std[j] = W.mean(), W.std()
        u_mean[j], u_std[j] = U.mean(), U.std()
    return QuasiStaticData(setpoints=v.copy(), w_mean=w_mean, w_std=w_std, u_mean=u_mean,
                           u_std=u_std, hold=n_hold * Tc, settle=n_settle * Tc, Tc=Tc,
                           noise_std=noise_std, design=design)


# --------------------------------------------------------------------------- experiment design that adapts


@dataclass(frozen=True)
class StribeckDesign:
    """Settings of :func:`stribeck_experiment` (keyword-only, validated; SI units).

    Parameters
    ----------
    w_min, w_max : float
        Speed range (rad/s) of the coarse log-spaced sweep, ``0 < w_min < w_max``; default 1e-4 to 1. Speeds
        below half the measurement noise (``noise_std/2``) are skipped: the loop then follows the noise
        through zero and no run can hold them.
    per_decade : int
        Speeds per decade of the coarse sweep (per direction), >= 1; default 3.
    n_refine : int
        Speeds added per direction in each refinement round around the detected transition, >= 1; default 4.
    max_rounds : int
        Refinement rounds at most, >= 0; default 3.
    crossover, crossover_max : float
        Crossover (rad/s) of the quasi-static velocity loop, and the stiffer one a run that does not hold
        its setpoint is repeated with; defaults :data:`QS_CROSSOVER` and 300 (at ``Tc = 1`` ms).
    settle, hold : float
        Settling time and averaging window (s) per run; the settling time of a slow run is lengthened to
        three breakaway times (see :func:`stribeck_experiment`), up to ``settle_max``.
    settle_max : float
        Longest settling time (s), >= ``settle``; default 8.

    Raises
    ------
    ParameterError
        A value out of range (named, with its value).
    """

    w_min: float = 1e-4
    w_max: float = 1.0
    per_decade: int = 3
    n_refine: int = 4
    max_rounds: int = 3
    crossover: float = QS_CROSSOVER
    crossover_max: float = 300.0
    settle: float = 2.0
    hold: float = 2.0
    settle_max: float = 8.0

    def __post_init__(self):
        check_positive("w_min", self.w_min)
        check_positive("w_max", self.w_max)
        if not self.w_max > self.w_min:
            raise ParameterError(f"w_max must be > w_min = {self.w_min!r}, got {self.w_max!r}")
        for name, low in (("per_decade", 1), ("n_refine", 1), ("max_rounds", 0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise ParameterError(f"{name} must be an integer >= {low}, got {v!r}")
        check_positive("crossover", self.crossover)
        if not self.crossover_max >= self.crossover:
            raise ParameterError(f"crossover_max must be >= crossover = {self.crossover!r}, got {self.crossover_max!r}")
        check_positive("hold", self.hold)
        check_nonnegative("settle", self.settle)
        if not self.settle_max >= self.settle:
            raise ParameterError(f"settle_max must be >= settle = {self.settle!r}, got {self.settle_max!r}")


@dataclass(frozen=True)
class StribeckExperiment:
    """Result of :func:`stribeck_experiment`: every run it designed, which of them held, and the fit.

    Attributes
    ----------
    setpoints, w_mean, w_std, u_mean, u_std : ndarray, shape (n,)
        Per run, as in :class:`QuasiStaticData` (rad/s, N·m), in the order run.
    crossover : ndarray, shape (n,)
        Crossover (rad/s) of the velocity loop of each run.
    held : ndarray of bool, shape (n,)
        Whether the run held its setpoint (a support point of the Stribeck curve, used by the fit); a run that
        ends in stick-slip or follows the noise through zero does not.
    fit : StribeckFit or None
        Stribeck pre-fit of the held runs (:func:`prefit_stribeck`, ``fallback=True``: a Coulomb + viscous result
        when the joint shows no Stribeck effect, see ``fit.fallback``); None for ``stribeck_experiment(...,
        fit=False)`` and for a joint whose runs measured no friction (``no_friction``).
    rounds : int
        Refinement rounds run.
    notes : tuple of str
        What the design did (runs repeated with the stiffer loop, runs not held, the fit's fallback), or that
        the runs measured no friction.
    no_friction : bool
        The runs measured no friction: the mean torque of every run lies within the resolution of its mean
        (:func:`stribeck_experiment`, Notes); then there is no refinement and no fit.
    """

    setpoints: np.ndarray
    w_mean: np.ndarray
    w_std: np.ndarray
    u_mean: np.ndarray
    u_std: np.ndarray
    crossover: np.ndarray
    held: np.ndarray
    fit: object
    rounds: int
    notes: tuple
    no_friction: bool = False

    @property
    def torque_scale(self) -> float:
        """Largest measured mean torque ``max |u_mean|`` (N·m): the friction level a user has measured."""
        return float(np.max(np.abs(self.u_mean)))

    def to_dict(self) -> dict:
        """Runs (lists), held flags, the fit (:meth:`StribeckFit.to_dict`), rounds and notes, strict JSON."""
        return json_safe({
            "setpoints": self.setpoints, "w_mean": self.w_mean, "w_std": self.w_std, "u_mean": self.u_mean,
            "u_std": self.u_std, "crossover": self.crossover, "held": [bool(h) for h in self.held],
            "fit": None if self.fit is None else self.fit.to_dict(), "rounds": self.rounds, "notes": list(self.notes),
            "no_friction": bool(self.no_friction)})

    def summary(self) -> str:
        """A few lines: runs, held runs, speed range, fitted Vs and delta, notes."""
        aw = np.abs(self.setpoints[self.held]) if np.any(self.held) else np.abs(self.setpoints)
        line = (f"{self.setpoints.shape[0]} constant-velocity runs ({int(self.held.sum())} held, "
                f"|w| {float(aw.min()):.3g} to {float(aw.max()):.3g} rad/s), {self.rounds} refinement round(s)")
        if self.fit is not None:
            line += f"; Vs = {self.fit.Vs:.4g} rad/s, delta = {self.fit.delta:.4g}"
        return "\n".join([line] + [f"note: {n}" for n in self.notes])

    def plot(self, ax=None):
        """Held runs (mean torque over mean velocity) with the fitted curve, not-held runs as crosses.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
        """
        h = self.held
        if self.fit is None:
            ax = axes_or_new(ax)
            ax.errorbar(self.w_mean[h], self.u_mean[h], yerr=self.u_std[h], fmt="o", ms=3, label="held runs")
            ax.set_xlabel("velocity w (rad/s)")
            ax.set_ylabel("torque u (N·m)")
        else:
            ax = self.fit.plot(ax, w=self.w_mean[h], F=self.u_mean[h], F_std=self.u_std[h])
        bad = ~h
        if np.any(bad):
            ax.plot(self.w_mean[bad], self.u_mean[bad], "x", color="C3", label="not held (not used)")
            ax.legend(fontsize=8)
        return ax


def prefit_stribeck(qs, *, fallback: bool = False):
    """Stribeck pre-fit (Sec. V-C) of quasi-static runs, robust to stick-slip runs, outlying slow runs and
    asymmetric friction.

    Parameters
    ----------
    qs : QuasiStaticData or StribeckExperiment
        Bidirectional constant-velocity runs (of a :class:`StribeckExperiment`: its held runs only).
    fallback : bool, keyword-only
        Return a reduced fit with a note instead of raising when the data do not determine the five
        parameters (see :func:`adaptive_ff.identification.stribeck_fit.fit_stribeck`).

    Returns
    -------
    StribeckFit
        The first determined fit of: all runs (the joint fit of both directions or, if that cannot resolve
        the Stribeck effect, e.g. direction-dependent levels, the fit of the positive direction with ``Vs``
        and ``delta`` replaced by the geometric and arithmetic means of the per-direction fits); then the
        joint fit without the slowest speed, without the two slowest (both directions of a speed, at least 5
        speeds kept; a note names what was left out). With ``fallback`` and none determined, the fallback
        of the joint fit of all runs (Coulomb + viscous, ``delta`` held at 1, or an undersampled transition,
        with a note).

    Raises
    ------
    ExcitationError
        No fit is determined (``fallback=False``), or fewer than 6 usable runs.

    Notes
    -----
    Of a :class:`QuasiStaticData`, runs whose velocity spread exceeds twice
    the median spread are dropped first: at the lowest speeds a joint that
    really sticks (or a soft loop on the negative Stribeck slope) ends in a
    stick-slip limit cycle, whose mean torque is not a point of the curve (the
    :func:`quasi_static_runs` Notes). The slowest runs are also the first to
    leave the sliding regime unnoticed (a joint that stops between two samples
    at a speed below ``F*Tc/J``, whose mean speed still matches the setpoint),
    so a fit that their torques make undetermined or implausible (a step-like
    ``delta``, a negative level: :func:`fit_stribeck`) is repeated without them
    (trimmed estimation, as in robust regression: Rousseeuw & Leroy,
    *Robust Regression and Outlier Detection*, 1987, Ch. 1).
    """
    w, u, ws = np.asarray(qs.w_mean), np.asarray(qs.u_mean), np.asarray(qs.w_std)
    keep = np.asarray(qs.held, dtype=bool) if hasattr(qs, "held") else ws <= 2.0 * np.median(ws)
    w, u = w[keep], u[keep]
    fit, error = _determined_fit(w, u)
    if fit is not None:
        return fit
    if fallback:
        return fit_stribeck(w, u, F_std=None, fallback=True)
    raise error


#: Slowest speed levels :func:`prefit_stribeck` may leave out (both directions of a speed are one level).
_MAX_TRIMMED_LEVELS = 2


def _speed_levels(aw) -> np.ndarray:
    """The distinct speeds of ``aw`` (> 0), ascending, with speeds within 5 % of each other as one level (the
    two directions of one setpoint); each level is given by its smallest speed."""
    levels = []
    for x in np.sort(aw[aw > 0.0]):
        if not levels or x > 1.05 * levels[-1]:
            levels.append(float(x))
    return np.array(levels)


def _determined_fit(w, u) -> tuple:
    """``(fit, None)``: the first determined strict fit of all points (both directions,
    :func:`_both_directions`), then of the joint fit without the slowest one, two speed levels (at least 5
    kept); ``(None, error)`` with the error of all points when none is determined."""
    levels = _speed_levels(np.abs(w))
    error = None
    for k in range(min(_MAX_TRIMMED_LEVELS, max(levels.size - 5, 0)) + 1):
        sel = np.abs(w) >= levels[k] if k else np.ones(w.shape, bool)
        try:
            fit = _both_directions(w[sel], u[sel]) if k == 0 else fit_stribeck(w[sel], u[sel], F_std=None)
        except (ExcitationError, SignalError) as exc:
            error = exc if error is None else error
            continue
        if k == 0:
            return fit, None
        note = (f"the {k} slowest speed(s) (|w| <= {levels[k - 1] * 1.05:.3g} rad/s) were left out of the fit: "
                f"with them it was not determined ({error})")
        return replace(fit, notes=tuple(fit.notes) + (note,)), None
    return None, error


def _both_directions(w, u):
    """The strict joint fit of both directions; if it fails, the per-direction fits combined (raises if none)."""
    try:
        return fit_stribeck(w, u, F_std=None)
    except ExcitationError as joint_error:
        fits = []
        for sgn in (1.0, -1.0):
            sel = sgn * w > 0
            try:
                fits.append(fit_stribeck(sgn * w[sel], sgn * u[sel], F_std=None))
            except (ExcitationError, SignalError):
                continue
        if not fits:
            raise joint_error
        Vs = float(statistics.geometric_mean([f.Vs for f in fits]))
        delta = float(np.mean([f.delta for f in fits]))
        return replace(fits[0], Vs=Vs, delta=delta)


def _held(w_ref, w_std, u_mean, u_std, noise_std: float, u_base: float) -> np.ndarray:
    """Runs that held their setpoint: true-velocity spread <= 30 % of |w_ref|, torque spread <= 3x the loop's,
    and a mean torque in the direction of motion.

    The measured spread is the noise and the joint's own velocity spread; ``w_std**2 - noise_std**2`` estimates
    the latter. ``u_base`` is the torque spread of the fast runs of the same loop (its noise response). Friction
    is dissipative, ``F(w)*w > 0`` in sliding, so a run whose mean torque does not drive the motion is not a
    point of the curve (e.g. a joint held at rest between two samples, whose mean speed says nothing).
    """
    excess = np.sqrt(np.maximum(w_std**2 - noise_std**2, 0.0))
    return (excess <= 0.3 * np.abs(w_ref)) & (u_std <= 3.0 * u_base) & (np.sign(w_ref) * u_mean > 0.0)


def _settles(speeds, design: PIDesign, o: StribeckDesign, u_level: float) -> np.ndarray:
    """Settling time per speed: >= three breakaway times ``u_level/(Ki |w|)`` (Notes of quasi_static_runs)."""
    t_b = u_level / (design.Ki * np.abs(speeds)) if u_level > 0 else np.zeros(len(speeds))
    return np.clip(3.0 * t_b, o.settle, o.settle_max)


class _Runner:
    """The runs of :func:`stribeck_experiment`: one list per statistic, appended as runs are made."""

    def __init__(self, p, J_design: float, o: StribeckDesign, Tc: float, noise_std: float, rng):
        self.p, self.o, self.Tc, self.noise_std, self.rng = p, o, Tc, noise_std, rng
        self.J_design = J_design
        self._designs = [None, None]
        self.cols = {k: [] for k in ("setpoints", "w_mean", "w_std", "u_mean", "u_std", "crossover", "held")}
        self.u_base = [None, None]
        self.n_retried = 0

    def design(self, level: int) -> PIDesign:
        """The loop of ``level`` (0: ``crossover``, 1: ``crossover_max``), designed when first needed."""
        if self._designs[level] is None:
            c = (self.o.crossover, self.o.crossover_max)[level]
            self._designs[level] = design_pi(self.J_design, sigma=0.0, crossover=c, phase_margin=60.0, Tc=self.Tc)
        return self._designs[level]

    def _run(self, speeds, level: int) -> tuple:
        d = self.design(level)
        u_level = max([abs(x) for x in self.cols["u_mean"]] or [0.0])
        by_settle = {}
        for s, st in zip(speeds, _settles(speeds, d, self.o, u_level)):
            by_settle.setdefault(float(st), []).append(s)
        out = []
        for st, sp in by_settle.items():
            q = quasi_static_runs(self.p, np.array(sp), hold=self.o.hold, settle=st, noise_std=self.noise_std,
                                  rng=self.rng, design=d)
            out += list(zip(q.setpoints, q.w_mean, q.w_std, q.u_mean, q.u_std))
        out.sort(key=lambda r: -abs(r[0]))
        a = np.array(out)
        if self.u_base[level] is None:  # the loop's noise response: torque spread of the fastest third
            self.u_base[level] = float(np.median(a[: max(len(a) // 3, 2), 4])) + 1e-12
        return a, _held(a[:, 0], a[:, 2], a[:, 3], a[:, 4], self.noise_std, self.u_base[level])

    def measure(self, speeds) -> None:
        """Run ``speeds`` (fastest first) with the default loop; repeat the runs that did not hold stiffer."""
        a, ok = self._run(np.array(sorted(speeds, key=lambda s: -abs(s))), 0)
        if not np.all(ok) and self.o.crossover_max > self.o.crossover:
            if self.u_base[1] is None:
                self.u_base[1] = self.u_base[0] * self.design(1).Kp / self.design(0).Kp
            b, ok_b = self._run(a[~ok, 0], 1)
            self.n_retried += int(b.shape[0])
            self._append(a[ok], np.ones(int(ok.sum()), bool), 0)
            self._append(b, ok_b, 1)
        else:
            self._append(a, ok, 0)

    def _append(self, a, ok, level: int) -> None:
        for row, h in zip(a.tolist(), ok.tolist()):
            for k, v in zip(("setpoints", "w_mean", "w_std", "u_mean", "u_std"), row):
                self.cols[k].append(v)
            self.cols["crossover"].append(self.design(level).crossover)
            self.cols["held"].append(bool(h))

    def arrays(self) -> dict:
        return {k: np.array(v, dtype=bool if k == "held" else float) for k, v in self.cols.items()}


def _no_friction(a: dict, J_design: float, n_hold: int) -> tuple:
    """``(no_friction, note)`` of the runs ``a`` (:meth:`_Runner.arrays`): every mean torque within the resolution
    of its mean (Notes of :func:`stribeck_experiment`)."""
    resolution = a["u_std"] / math.sqrt(n_hold) + 1e-9 * J_design * a["crossover"] * np.abs(a["setpoints"])
    ratio = np.abs(a["u_mean"]) / resolution
    if not np.all(ratio <= 1.0):
        return False, ""
    return True, (f"no friction measured: the mean torque of each of the {ratio.size} constant-velocity runs lies "
                  f"within the resolution of its mean (u_std/sqrt({n_hold}); at most {float(np.max(ratio)):.2g} of "
                  f"it, largest |mean torque| {float(np.max(np.abs(a['u_mean']))):.3g} N·m): no friction to identify")


def _refinement(w, u, held, n_refine: int) -> np.ndarray:
    """New speeds (both signs) between the lowest held speed still at the full Stribeck excess and the first
    speed above it where the excess over the Coulomb + viscous line of the fast runs has died out."""
    aw, m = np.abs(w[held]), np.sign(w[held]) * u[held]
    if aw.size < 4:
        return np.empty(0)
    hi = aw >= np.median(aw)
    A = np.column_stack([np.ones(int(hi.sum())), aw[hi]])
    (c, sig), *_ = np.linalg.lstsq(A, m[hi], rcond=None)
    e = np.abs(m - (c + sig * aw))
    E = float(np.max(e))
    if E <= 0.02 * abs(c):
        return np.empty(0)  # no Stribeck effect to refine
    order = np.argsort(aw)
    aw, e = aw[order], e[order]
    full = np.flatnonzero(e >= 0.95 * E)
    lo = float(aw[full[-1]]) if full.size else float(aw[0])
    small = np.flatnonzero((aw > lo) & (e <= 0.05 * E))
    top = float(aw[small[0]]) if small.size else float(aw[-1])
    new = np.geomspace(lo, top, n_refine + 2)[1:-1]
    known = np.unique(np.abs(w))
    new = np.array([s for s in new if np.min(np.abs(np.log(known / s))) > 0.02])
    return np.concatenate([-new[::-1], new]) if new.size else new


def stribeck_experiment(p, *, J_design: float, noise_std: float = 0.0, Tc: float = 1e-3, rng=None,
                        options: StribeckDesign | None = None, fit: bool = True) -> StribeckExperiment:
    """Quasi-static runs whose speeds are chosen from the joint's own response, and the Stribeck pre-fit.

    Parameters
    ----------
    p : plant model
        The joint (any model of :mod:`plant.models`); only its simulated response is used (the plant step).
    J_design : float, keyword-only
        Design inertia (kg·m²) of the quasi-static velocity loops, > 0 (a data-sheet value).
    noise_std : float, keyword-only
        Velocity measurement noise (rad/s), >= 0: simulated on the measurement and used as the user's noise
        estimate (which runs can hold, the lowest speed).
    Tc : float, keyword-only
        Controller period and integration step (s).
    rng : numpy.random.Generator, keyword-only
        Noise source (needed when ``noise_std > 0``).
    options : StribeckDesign, keyword-only
        Speed range, refinement and loop settings; default ``StribeckDesign()``.
    fit : bool, keyword-only
        False: the coarse sweep only, no refinement and no fit (``result.fit`` is None; e.g. to measure the
        torque scale), which cannot fail.

    Returns
    -------
    StribeckExperiment

    Raises
    ------
    ParameterError
        ``J_design``, ``noise_std``, ``Tc`` out of range, or ``noise_std > 0`` without ``rng``.
    ExcitationError
        With ``fit``: fewer than 6 runs held their setpoint (the data of the joint cannot give any friction
        map).

    Notes
    -----
    1. Coarse sweep: ``per_decade`` log-spaced speeds per decade from ``max(w_min, noise_std/2)`` to
       ``w_max``, both directions, fastest first, with the PI designed for ``J_design`` at ``crossover``.
       A run holds its setpoint when the joint's own velocity spread (``sqrt(w_std**2 - noise_std**2)``) is
       at most 30 % of the speed, its torque spread at most 3 times that of the fast runs and its mean torque
       drives the motion (friction is dissipative: a run whose mean torque is against the motion, e.g. a joint
       that stops within each sample, is not a point of the curve); one that does not (stick-slip on the negative slope of the Stribeck curve, Notes of :func:`quasi_static_runs`) is
       repeated with the stiffer loop at ``crossover_max`` (``Kp`` beats a steeper slope). Slow runs settle
       for three breakaway times ``|u|/(Ki |w|)`` with ``|u|`` the largest torque measured so far.
    2. Refinement: the excess of the held runs over the Coulomb + viscous line of the fast half locates the
       transition; ``n_refine`` speeds per direction are added between the slowest held speed still at the
       full excess and the first speed where it has died out (the same two criteria as the fit's transition
       window, 95 % and 5 %). Repeated while the strict fit (:func:`prefit_stribeck`) says the data do not
       determine it, at most ``max_rounds`` times. The strict fit leaves out the slowest one or two speeds
       when the fit with them is not determined (:func:`prefit_stribeck`).
    3. The fit of the held runs with ``fallback=True``: never rejects the data it designed. No Stribeck
       effect gives the Coulomb + viscous model with a note (``fit.fallback``).

    A joint whose coarse sweep measured no friction has nothing to fit (``no_friction``, with a note; no
    refinement, ``fit`` None), instead of a Stribeck curve fitted to the noise of the means: the mean torque
    ``u_mean`` of every run lies within what the mean of its ``n = hold/Tc`` samples resolves, the standard
    error ``u_std/sqrt(n)`` of the mean of ``n`` independent samples (a bound: the loop's noise torque is
    high-pass, ``J*s`` times the low-passed noise, so its mean is smaller still), plus ``1e-9`` of the torque
    of the loop's step to the setpoint (``J_design*crossover*|w_ref|``, rounding of a noise-free run). Friction
    is the mean torque at constant velocity: a joint without friction gives at most 0.2 of that resolution (the
    runs of ``compare`` with seeds 0-19 at 1e-3 rad/s noise; the ratio does not depend on ``J``), the
    ``paper`` preset at least 580 times it; a zoo joint (friction at least 5 % of its peak torque demand,
    ``u_std`` about ``J*crossover*noise_std``) is estimated at 15 times or more.

    Source: the experiment of Ruderman, Sec. V-C, Fig. 8; the design loop (a coarse sweep, then points
    placed where the response changes) is sequential experiment design as in Pronzato & Pázman,
    *Design of Experiments in Nonlinear Models* (2013), Ch. 8.
    """
    o = StribeckDesign() if options is None else options
    if not isinstance(o, StribeckDesign):
        raise TypeError(f"options must be a StribeckDesign, got {type(o).__name__}")
    J_design = check_positive("J_design", J_design)
    noise_std = check_nonnegative("noise_std", noise_std)
    Tc = check_positive("Tc", Tc)
    if noise_std > 0.0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    w_lo = max(o.w_min, 0.5 * noise_std)
    if not w_lo < o.w_max:
        raise ParameterError(f"noise_std/2 = {0.5 * noise_std!r} rad/s leaves no speeds below w_max = {o.w_max!r}")
    n = max(int(math.ceil(math.log10(o.w_max / w_lo) * o.per_decade)) + 1, 2)
    runner = _Runner(p, J_design, o, Tc, noise_std, rng)
    runner.measure(bidirectional_velocities(w_lo, o.w_max, n))
    no_friction, note = _no_friction(runner.arrays(), J_design, int(round(o.hold / Tc)))
    if no_friction:
        return StribeckExperiment(rounds=0, fit=None, notes=(note,), no_friction=True, **runner.arrays())
    rounds, outcome = 0, None
    while fit and rounds < o.max_rounds:
        a = runner.arrays()
        outcome = _determined_fit(a["w_mean"][a["held"]], a["u_mean"][a["held"]])
        if outcome[0] is not None:
            break
        new = _refinement(a["w_mean"], a["u_mean"], a["held"], o.n_refine)
        if not new.size:
            break
        runner.measure(new)
        rounds, outcome = rounds + 1, None
    a = runner.arrays()
    n_held = int(a["held"].sum())
    if not fit:
        return StribeckExperiment(rounds=0, fit=None, notes=(), **a)
    if n_held < 6:
        raise ExcitationError(f"only {n_held} of {a['held'].size} quasi-static runs held their setpoint; "
                              f"the joint's friction map cannot be measured with these loops")
    w, u = a["w_mean"][a["held"]], a["u_mean"][a["held"]]
    if outcome is None:  # runs were added after the last fit
        outcome = _determined_fit(w, u)
    sfit = outcome[0] if outcome[0] is not None else fit_stribeck(w, u, F_std=None, fallback=True)
    notes = []
    if runner.n_retried:
        notes.append(f"{runner.n_retried} run(s) did not hold with the {o.crossover:g} rad/s loop and were "
                     f"repeated at {o.crossover_max:g} rad/s")
    if n_held < a["held"].size:
        bad = np.abs(a["setpoints"][~a["held"]])
        notes.append(f"{a['held'].size - n_held} run(s) did not hold their setpoint (|w| {bad.min():.3g} to "
                     f"{bad.max():.3g} rad/s: stick-slip, noise-dominated or a mean torque against the motion) and were not used")
    notes += list(sfit.notes)
    return StribeckExperiment(rounds=rounds, fit=sfit, notes=tuple(notes), **a)

