"""A first inertia without a controller: a breakaway ramp, then an open-loop noise torque, identified.

Before a velocity loop can be designed its inertia must be known, and before the friction can be measured (the
quasi-static runs of :mod:`controllers.experiments.quasi_static` run under a PI) a loop must exist.
:func:`inertia_experiment` breaks that circle with the drive in torque mode and no model of the joint:

1. **Breakaway ramp.** The torque grows exponentially from a tiny value (a factor ``e`` every ``growth_time``) until
   the measured velocity reaches the switching speed ``w_switch`` (``compare``: 1.2 times the reference's peak
   speed), and the drive stops it there (or at its torque limit ``u_max``, held five growth times, where the joint
   then moves faster than ``w_switch/10``). The torque then reached, ``u_ramp``, is a torque that moves the joint
   through the speed range it is to run in: friction, stiction and inertia together, as measured. Scale-free: the
   ramp needs no guess of the friction level (from 1e-6 N·m it breaks 1 N·m loose after 2.8 s, 1000 N·m after
   4.1 s).
2. **Noise torque.** The paper's identification excitation (Sec. IV-A: 1 Hz low-pass band-limited white noise,
   :func:`plant.excitation.bandlimited_noise`) open loop, standard deviation ``level*u_ramp``, for ``duration`` s,
   from rest; the torque is clipped to the drive's limit ``u_max``.
3. **Sliding identification.** The package's sliding-regime inverse-dynamics regression
   (:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`, with the lag and an offset) of the record gives
   the inertia. The friction map's shape is not known yet (the pre-fit comes later): a Stribeck term with
   ``Vs = w_switch/10``, ``delta = 1`` stands in for it; the inertia rests on the accelerations.

Why not a relay on the velocity (bang-bang between ``±w_switch``): its torque is constant between switches, and
then the friction lag's ``-tau*sigma*dw/dt`` is collinear with ``J*dw/dt``: the relay gave ``J - tau*sigma``
(-20 % on the ``paper`` preset, whose ``tau*sigma`` is 0.8 kg·m²), and on a light joint (``small-inertia``) the
cycles between the two speeds lasted a few samples. The noise torque varies continuously (its ``-tau*du/dt``
separates the lag). The regression's discrete filters make its inertia 1.025 times the joint's at 1 kHz
(:attr:`InertiaExperiment.J` divides that gain out). A lagged viscous-only joint stays biased (its lagged
``sigma*w`` is nearly collinear with ``J*dw/dt``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from adaptive_ff.compensation.sliding_estimator import SlidingFit, SlidingFrictionEstimatorConfig, fit_sliding
from plant.dynamics import plant_params, plant_state, plant_step
from plant.errors import (ExcitationError, ParameterError, check_multiple, check_nonnegative, check_positive,
                          check_positive_or_inf)
from plant.excitation import bandlimited_noise
from plant.joint import simulate
from plant.results import json_safe

__all__ = ["InertiaDesign", "InertiaExperiment", "inertia_experiment"]


@dataclass(frozen=True)
class InertiaDesign:
    """Settings of :func:`inertia_experiment` (keyword-only, validated; SI units).

    Parameters
    ----------
    u_start : float
        Torque (N·m) the ramp starts from, > 0; default 1e-6, below any friction level of interest.
    growth_time : float
        The ramp's torque grows by a factor ``e`` every ``growth_time`` s, > 0; default 0.2.
    max_ramp : float
        Longest ramp (s), > 0; default 30.
    duration : float
        Length of the noise-torque run (s), > 0; default 20.
    level : float
        Standard deviation of the noise torque as a multiple of the ramp's torque, > 0; default 1.2 (``compare``'s
        identification run uses 1.2 times the measured friction level).
    cutoff : float
        The noise torque's low-pass cut-off (Hz), > 0; default 1 (the paper's).
    u_max : float
        The drive's torque limit (N·m), default inf: the ramp stops and the noise is clipped there.
    Ts, T_filter : float
        Row spacing (s, a multiple of the sample period) and state-variable filter time constant (s) of the
        regression; defaults 0.01 and 0.02 (``compare``'s).

    Raises
    ------
    ParameterError
        A value out of range (named, with its value).
    """

    u_start: float = 1e-6
    growth_time: float = 0.2
    max_ramp: float = 30.0
    duration: float = 20.0
    level: float = 1.2
    cutoff: float = 1.0
    u_max: float = math.inf
    Ts: float = 0.01
    T_filter: float = 0.02

    def __post_init__(self):
        for name in ("u_start", "growth_time", "max_ramp", "duration", "level", "cutoff", "Ts", "T_filter"):
            check_positive(name, getattr(self, name))
        check_positive_or_inf("u_max", self.u_max)


@dataclass(frozen=True)
class InertiaExperiment:
    """Result of :func:`inertia_experiment`.

    Attributes
    ----------
    u_ramp : float
        The ramp's torque (N·m) when the measured velocity reached ``w_switch``.
    t_ramp : float
        Length of the ramp (s).
    w_switch : float
        The speed the ramp ran to (rad/s).
    u_std : float
        Standard deviation of the noise torque (N·m), ``level*u_ramp``.
    duration : float
        Length of the noise-torque run (s).
    fit : SlidingFit
        The sliding-regime regression of the noise-torque run.
    """

    u_ramp: float
    t_ramp: float
    w_switch: float
    u_std: float
    duration: float
    fit: SlidingFit

    @property
    def J(self) -> float:
        """The inertia identified (kg·m²): the sliding-regime regression's (``fit.estimate.J``)."""
        return float(self.fit.estimate.J)

    def to_dict(self) -> dict:
        """J, u_ramp, t_ramp, w_switch, u_std, duration and the fit's rows and residual, strict JSON."""
        return json_safe({"J": self.J, "u_ramp": self.u_ramp, "t_ramp": self.t_ramp, "w_switch": self.w_switch,
                          "u_std": self.u_std, "duration": self.duration, "n_rows": self.fit.n_rows,
                          "residual_rms": self.fit.residual_rms})

    def summary(self) -> str:
        """One line: the inertia and the two runs that gave it."""
        return (f"first inertia J = {self.J:.4g} kg·m²: a ramp to {self.u_ramp:.4g} N·m reached {self.w_switch:.4g} "
                f"rad/s in {self.t_ramp:.3g} s; {self.duration:g} s of noise torque of {self.u_std:.4g} N·m, "
                f"sliding-regime regression")


def inertia_experiment(p, *, w_switch: float, Tc: float = 1e-3, noise_std: float = 0.0, rng=None,
                       options: InertiaDesign | None = None) -> InertiaExperiment:
    """The joint's inertia from a breakaway ramp and an open-loop noise torque (module docstring).

    Parameters
    ----------
    p : plant model
        The joint (any frozen model of :mod:`plant.models`); only its simulated response is used (the plant step).
    w_switch : float, keyword-only
        The speed the ramp runs to (rad/s), > 0: ``compare`` takes 1.2 times the reference's peak speed (the speed
        range the joint is to run in), at least ten times the measurement noise.
    Tc : float, keyword-only
        Sample period and integration step (s), > 0.
    noise_std : float, keyword-only
        White noise (rad/s) on the measured velocity, >= 0; the ramp stops on the measurement.
    rng : numpy.random.Generator, keyword-only
        Source of the measurement noise and of the noise torque.
    options : InertiaDesign, keyword-only
        Default ``InertiaDesign()``.

    Returns
    -------
    InertiaExperiment

    Raises
    ------
    ParameterError
        An argument out of range, ``rng`` missing, or ``options.Ts`` not a multiple of ``Tc``.
    ExcitationError
        The ramp did not bring the joint to ``w_switch`` within ``max_ramp`` s and ``u_max``, or the regression
        could not be made.

    Notes
    -----
    The torque is held over each period (the drive's zero-order hold) and decided from the velocity measured at
    the start of the period, as a drive would decide it. Only the torque, the measured velocity and the drive's
    limit enter; the noise run starts from rest.
    """
    o = InertiaDesign() if options is None else options
    if not isinstance(o, InertiaDesign):
        raise TypeError(f"options must be an InertiaDesign, got {type(o).__name__}")
    w_switch, Tc = check_positive("w_switch", w_switch), check_positive("Tc", Tc)
    noise_std = check_nonnegative("noise_std", noise_std)
    check_multiple("Ts", o.Ts, "Tc", Tc)
    if rng is None:
        raise ParameterError("rng is needed (the noise torque): rng=np.random.default_rng(seed)")
    u_ramp, k_ramp = _ramp(p, w_switch, Tc, noise_std, rng, o)
    _, u = bandlimited_noise(o.duration, dt=Tc, cutoff=o.cutoff, std=o.level * u_ramp, rng=rng)
    np.clip(u, -o.u_max, o.u_max, out=u)
    w = simulate(p, u, dt=Tc).w[:-1]
    if noise_std > 0.0:
        w = w + rng.normal(0.0, noise_std, size=w.shape[0])
    try:
        fit = fit_sliding(u, w, Tc=Tc, Vs=0.1 * w_switch, delta=1.0,
                          config=SlidingFrictionEstimatorConfig(Ts=o.Ts, T_filter=o.T_filter, lag=True, offset=True))
    except ExcitationError as exc:
        raise ExcitationError(f"first inertia: the noise-torque run of {o.level:g} x {u_ramp:.4g} N·m: {exc}") from None
    return InertiaExperiment(u_ramp=u_ramp, t_ramp=k_ramp * Tc, w_switch=w_switch, u_std=o.level * u_ramp,
                             duration=u.shape[0] * Tc, fit=fit)


def _ramp(p, w_switch: float, Tc: float, noise_std: float, rng, o: InertiaDesign) -> tuple:
    """The breakaway ramp: ``(torque when the measured velocity first reached w_switch, its sample index)``; at the
    torque limit, ``(u_max, index)`` once the limit has been held for five growth times with the joint moving faster
    than ``w_switch/10`` (a drive that cannot reach the speed range still moves the joint through part of it)."""
    par, st = plant_params(p), plant_state(p, 0.0)
    n_max = int(round(o.max_ramp / Tc))
    noise = noise_std * rng.standard_normal(n_max) if noise_std > 0.0 else np.zeros(n_max)
    grow, u = math.exp(Tc / o.growth_time), min(o.u_start, o.u_max)
    n_limit, at_limit = int(round(5.0 * o.growth_time / Tc)), 0
    for k in range(n_max):
        wm = st.w + noise[k]
        if wm >= w_switch or (at_limit >= n_limit and wm > 0.1 * w_switch):
            return float(u), k
        plant_step(par, st, u, Tc)
        if not math.isfinite(st.w):
            break
        u = min(u * grow, o.u_max)
        at_limit = at_limit + 1 if u == o.u_max else 0
    raise ExcitationError(f"first inertia: a torque ramp to {u:.4g} N·m (u_max = {o.u_max:g} N·m) did not bring the "
                          f"joint to {w_switch:.4g} rad/s within max_ramp = {o.max_ramp:g} s")
