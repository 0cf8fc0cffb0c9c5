"""The observers' design in a comparison: their nominal inertia and the residual observer's cut-off.

:func:`controllers.experiments.compare.prepare_comparison` gives every observer (the ``dob`` peer, the residual
observer and switch-in of ``adaptive`` and ``adaptive-dob``, the supervisor) the nominal inertia
:func:`observer_inertia`, and the residual observer the Q-filter cut-off :func:`residual_cutoff` of the friction
level the quasi-static runs measured (:func:`friction_level`), with the share :func:`residual_share` of whether
they found the joint sticking, at most :func:`observer_max`. Only what a user has
enters: the design inertia, the identification run's estimate, the design's noise level and the measured curve.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["J_CONTRADICTED", "RESIDUAL_SHARE", "STICK_SHARE", "friction_level", "observer_inertia", "observer_max",
           "residual_cutoff", "residual_share", "stick_speed"]

#: The residual observer's noise torque as a share of the measured friction level (:func:`residual_cutoff`) on a
#: joint that slides through its quasi-static runs (:func:`residual_share`).
RESIDUAL_SHARE = 0.5

#: The same share on a joint that sticks in them (:func:`residual_share`).
STICK_SHARE = 0.35

#: The design inertia is trusted unless the identification run's inertia differs from it by more than this factor
#: (either way); then every observer takes the identified one (:func:`observer_inertia`).
J_CONTRADICTED = 1.2


def observer_inertia(J_design: float, identified) -> float | None:
    """The observers' nominal inertia (kg·m²) where the identification run contradicts the design inertia, else None
    (they keep ``J_design``).

    An observer enforces its nominal inertia: with twice the joint's it adds the missing inertia as a virtual one
    and makes the loop worse than no compensation (docs/benchmarks/compensation.md, "A design inertia off by a
    factor"). The identification run's inertia (the offline fit of ``compare``'s preparation) does not depend on
    the design inertia and lies within about 11 % of the joint's on nearly every joint of the zoo
    (docs/benchmarks/zoo.md), so a design inertia more than :data:`J_CONTRADICTED` times off it (either way) is
    taken as contradicted. The fit's inertia is used even where its friction levels are rejected (a Stribeck term
    the pre-fit cannot separate, a negative lag): it rests on the accelerations, not on the friction map.

    Parameters
    ----------
    J_design : float
        The design inertia (kg·m², > 0).
    identified : FrictionEstimate or None
        The estimate of the identification run, accepted or not (None: no run; ``J_design`` stays).

    Returns
    -------
    float or None
        ``identified.J`` where ``max(J_design/J, J/J_design) > J_CONTRADICTED`` and ``J`` is finite and > 0, else None.
    """
    if identified is None:
        return None
    J = float(identified.J)
    if not (math.isfinite(J) and J > 0.0):
        return None
    return J if max(J_design / J, J / J_design) > J_CONTRADICTED else None



def observer_max(*, Tc: float, encoder_counts, velocity: str, velocity_bandwidth) -> float:
    """Fastest residual observer (rad/s) the loop's velocity supports: 1000, or with the encoder's Kalman velocity
    its bandwidth ``2*pi*fb`` (the filter's lag, about ``sqrt(2)/(2*pi*fb)`` for cv, turns the observer's
    ``J*s*w`` into a phase error above it).

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s), > 0.
    encoder_counts, velocity, velocity_bandwidth : keyword-only
        The loop's velocity measurement, as in :class:`controllers.experiments.compare.CompareOptions`: the encoder's
        counts per revolution (None: no encoder), the velocity estimate (``"kalman"`` or another) and the Kalman
        filter's bandwidth (Hz; None: :func:`controllers.simulation.sensor_drive.default_velocity_bandwidth` of
        ``Tc``).

    Returns
    -------
    float
        The cut-off bound (rad/s).

    Notes
    -----
    Measured on the open bench (2^17 encoder, Kalman cv 100 Hz, one period of delay, point-to-point moves):
    ``adaptive-dob`` on ``small-inertia`` 0.68 at 1000 rad/s, 1.00 at 600; ``long-lag``, ``paper``,
    ``karnopp`` 0.99 -> 1.03-1.04 (docs/benchmarks/scenarios.md).
    """
    if encoder_counts is None or velocity != "kalman":
        return 1000.0
    from controllers.simulation.sensor_drive import default_velocity_bandwidth

    bw = velocity_bandwidth if velocity_bandwidth is not None else default_velocity_bandwidth(Tc)
    return min(1000.0, 2.0 * math.pi * bw)


def residual_cutoff(J: float, noise_std: float, Tc: float, F_level: float, *, share: float = RESIDUAL_SHARE,
                    omega_max: float = 1000.0) -> float:
    """Q-filter cut-off (rad/s) of the residual observer of ``adaptive`` and ``adaptive-dob``: ``omega_max``, or
    lower where its noise torque would exceed the measured friction level (times ``share``).

    Parameters
    ----------
    J : float
        Design inertia (kg·m²), > 0 (the observer's nominal inertia).
    noise_std : float
        Velocity measurement noise (rad/s, white at ``Tc``), >= 0.
    Tc : float
        Controller period (s), > 0.
    F_level : float
        Friction level the user measured (N·m), e.g. :attr:`StribeckExperiment.torque_scale`.
    share, omega_max : float, keyword-only
        Largest noise torque (standard deviation) as a share of ``F_level`` (default :data:`RESIDUAL_SHARE`, 0.5:
        beside the feedforward the observer cancels the residual ``f - u_ff``, a part of the friction, so its noise
        torque must stay below the friction level; Notes; ``compare`` passes :func:`residual_share`) and the
        cut-off without that bound (rad/s, default 1000, :class:`controllers.simulation.loop_config.LoopConfig` ``observer.omega_r``).

    Returns
    -------
    float
        ``min(omega_max, (4*(share*F_level)**2/(J**2*noise_std**2*Tc))**(1/3))`` (``omega_max`` without noise).

    Notes
    -----
    The observer's estimate ``Q(s)*(u - J*s*w_meas)`` with the binomial ``Q = 1/(1 + s/w)**2`` passes white
    measurement noise (two-sided density ``noise_std**2*Tc``) through ``J*s*Q(s)``; its variance is
    ``J**2*noise_std**2*Tc/(2*pi) * integral of x**2*w**4/(w**2 + x**2)**2 dx = J**2*noise_std**2*Tc*w**3/4``
    (Papoulis & Pillai, *Probability, Random Variables and Stochastic Processes*, 4th ed., 2002, Sec. 9-3). A
    residual observer whose noise torque is larger than the friction it cancels does harm (light joints with
    little friction: light Karnopp joints of the zoo, docs/benchmarks/zoo.md). At the friction level itself
    (``share`` 1) it still did harm on heavy Karnopp joints, whose friction in the stick band is
    the reaction to the applied torque; the shares measured, on three zoos and both estimators, are on
    docs/benchmarks/compensation.md, "The residual observer's noise at half the friction level". On a joint whose
    quasi-static runs stick (:func:`residual_share`) half the level still broke it loose at random (a joint of
    the zoo of seed 2), hence :data:`STICK_SHARE` there.
    """
    density = J * J * noise_std * noise_std * Tc  # 0 also where a tiny noise_std**2 underflows
    if noise_std <= 0.0 or not (density > 0.0) or not (F_level > 0.0):
        return float(omega_max)
    w = (4.0 * (share * F_level) ** 2 / density) ** (1.0 / 3.0)
    return float(min(omega_max, w))


def stick_speed(exp) -> float:
    """The largest speed at which a quasi-static run did not hold its setpoint (rad/s): the joint's stick-slip as the
    user measured it; 0 where every run held or there are no runs.

    Parameters
    ----------
    exp : controllers.experiments.quasi_static.StribeckExperiment or None
        The quasi-static runs (their ``setpoints``, rad/s, and ``held`` flags).

    Returns
    -------
    float
        ``max |setpoint|`` over the runs that did not hold (rad/s, >= 0).
    """
    if exp is None:
        return 0.0
    bad = ~np.asarray(exp.held, dtype=bool)
    return float(np.max(np.abs(np.asarray(exp.setpoints, dtype=float)[bad]))) if np.any(bad) else 0.0


def residual_share(exp, band: float) -> float:
    """The share of the friction level the residual observer's noise torque may take (:func:`residual_cutoff`):
    :data:`STICK_SHARE` on a joint that sticks, :data:`RESIDUAL_SHARE` on one that slides.

    A joint sticks where a quasi-static run did not hold its setpoint at a speed beyond ``band`` (:func:`stick_speed`
    above the band): at that speed the run is not lost in the sensor's noise, it stuck and slipped. In a stick band
    the friction is the reaction to the applied torque up to the breakaway level, and the observer's noise torque
    decides when the joint breaks loose: there it is held at about a third of the level, against half on a joint
    that slides (docs/benchmarks/compensation.md, "The residual observer on a joint that sticks").

    Parameters
    ----------
    exp : controllers.experiments.quasi_static.StribeckExperiment or None
        The quasi-static runs (None: no runs, the joint is taken as sliding).
    band : float
        The velocity below which a run may fail by the sensor's noise alone (rad/s, >= 0): ``compare``'s stick band,
        three times the velocity noise by default.

    Returns
    -------
    float
        :data:`STICK_SHARE` or :data:`RESIDUAL_SHARE`.
    """
    return STICK_SHARE if stick_speed(exp) > band else RESIDUAL_SHARE


def friction_level(exp, default: float) -> float:
    """The friction level on the measured curve (N·m): the largest mean torque of the quasi-static runs that held
    their setpoint (a run in stick-slip is not a point of the curve); ``default`` without such runs.

    Parameters
    ----------
    exp : controllers.experiments.quasi_static.StribeckExperiment or None
        The quasi-static runs (their ``held`` flags and mean torques ``u_mean``, N·m), None without them.
    default : float
        The level to use where no run held (N·m).

    Returns
    -------
    float
        ``max |u_mean|`` over the runs that held, else ``default`` (N·m).
    """
    if exp is None or not np.any(exp.held):
        return float(default)
    return float(np.max(np.abs(exp.u_mean[exp.held])))
