"""The loop's sensor and drive as they are: an encoder's quantised position, a measurement delay, a torque slew limit.

Thin classes over the C structs ``ctl_sensor`` and ``ctl_drive`` (``controllers/csrc/ctl_sensor.h``,
``ctl_drive.h``), which the closed-loop engine holds per scenario
(:meth:`controllers.simulation.engine.EngineRun.set_sensor`, ``set_drive``):

* :class:`Sensor`: the velocity the loop measures. With ``counts_per_rev`` it is an encoder: the true position
  (integrated by the trapezoidal rule over each period) is read in whole counts and the velocity is their
  backward difference over the period, ``(qm[k] - qm[k-1])/Tc`` (a 2^17-count encoder at 1 kHz: steps of
  0.048 rad/s), or (``velocity="kalman"``) the velocity of a causal steady-state Kalman filter on the counts
  (the kinematic models and bandwidth tuning of :mod:`adaptive_ff.io.kalman_velocity`); the noise of the run, if
  any, is added to it. ``delay`` periods of measurement delay (0-32).
* :class:`Drive`: the torque the joint receives, after the controller's saturation ``u_max`` (the drive's
  torque limit): at most ``slew_rate`` N·m/s of change. The compensators observe the applied torque.

Without either the loop measures ``w + noise`` and applies the command (the engine's default, unchanged).
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.io.kalman_velocity import SteadyStateKalman, steady_state_kalman
from adaptive_ff.io.units import KALMAN_MODELS
from controllers._cctl import ffi, lib
from plant.component import Component, struct_field
from plant.errors import ParameterError, check_positive

__all__ = ["Sensor", "Drive", "DELAY_MAX", "VELOCITIES", "default_velocity_bandwidth"]

#: Largest measurement delay (periods), ``CTL_DELAY_MAX`` of ctl_sensor.h.
DELAY_MAX = len(ffi.new("ctl_sensor *").buf) - 1

#: How an encoder's velocity is formed: the backward difference of the counts, or a steady-state Kalman filter.
VELOCITIES = ("difference", "kalman")


def default_velocity_bandwidth(Tc: float) -> float:
    """The default bandwidth (Hz) of the encoder's Kalman velocity: a tenth of the sampling rate, ``0.1/Tc``.

    Parameters
    ----------
    Tc : float
        Controller period (s), > 0.

    Returns
    -------
    float
        ``0.1/Tc`` (100 Hz at 1 kHz): the default of :func:`adaptive_ff.io.kalman_velocity.velocity_from_position`.
        Its lag stays out of the loop (cv: about ``sqrt(2)/(2*pi*fb)`` = 2.3 ms, 2.6 degrees of phase at a
        20 rad/s crossover), its velocity noise from the counts is 0.21 of the backward difference's RMS for white
        quantisation noise (cv; 0.15 on a constant-velocity ramp, tests/controllers_layer/test_kalman_loop.py). Measured on the
        ``paper`` preset with a 17-bit encoder (benchmarks/encoder_velocity.py, means over 8 noise
        seeds): ``adaptive`` eta 0.91 at 100 Hz (0.92 at 80, 0.89 at 120, 0.73 at 150 Hz; 0.00 with the difference); ``adaptive-dob``
        0.96 at 80-120 Hz and below zero at 50 Hz, where the filter's lag reaches its residual observer
        (``omega_r`` 1000 rad/s): keep the bandwidth above about 80 Hz there.

    Raises
    ------
    ParameterError
        ``Tc`` not > 0.
    """
    return 0.1 / check_positive("Tc", Tc)


def _whole(v, lo: int, hi: float = math.inf) -> bool:
    """``v`` is an integer (int, numpy integer or a float of integral value, not a bool) in ``lo..hi``."""
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        return False
    return math.isfinite(v) and int(v) == v and lo <= v <= hi


class Sensor(Component):
    """The loop's velocity sensor: an encoder (quantised position; backward difference or Kalman velocity) and/or
    a delay.

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s), > 0.
    counts_per_rev : int or None, keyword-only
        Encoder counts per joint revolution (e.g. ``2**17``), >= 1; None (default): a velocity sensor
        (``w + noise``).
    delay : int, keyword-only
        Measurement delay in periods, ``0 <= delay <=`` :data:`DELAY_MAX`; default 0.
    velocity : {"difference", "kalman"}, keyword-only
        The encoder's velocity: the backward difference of the counts (default), or the velocity estimate of
        a causal steady-state Kalman filter on the counts (needs ``counts_per_rev``).
    bandwidth : float or None, keyword-only
        Bandwidth ``fb`` (Hz) of the Kalman velocity, > 0 and below the Nyquist frequency ``0.5/Tc``; default
        None: :func:`default_velocity_bandwidth` (``0.1/Tc``). Only with ``velocity="kalman"``.
    model : {"cv", "ca"}, keyword-only
        Kinematic model of the Kalman velocity (constant velocity or constant acceleration; see
        :mod:`adaptive_ff.io.kalman_velocity`); default "cv".

    Attributes
    ----------
    cdata : cffi ``ctl_sensor *``
        Fields ``res`` (rad per count, 0 without an encoder), ``Tc``, ``delay``, ``kalman``, ``n_x``, ``K``
        and the state.
    resolution : float
        Encoder resolution (rad per count), 0 for a velocity sensor.
    filter : SteadyStateKalman or None
        The Kalman velocity's filter (model, bandwidth, gain, steady-state covariance), None for the difference.

    Raises
    ------
    ParameterError
        ``Tc`` not > 0, ``counts_per_rev`` not an integer >= 1, ``delay`` outside ``0..DELAY_MAX``, ``velocity``
        or ``model`` unknown, ``velocity="kalman"`` without ``counts_per_rev``, ``bandwidth`` not > 0 (or NaN),
        at or above the Nyquist frequency, or given with ``velocity="difference"``.

    Notes
    -----
    The Kalman velocity (C ``ctl_sensor_measure``): the measurement is the position read,
    ``qm = res*floor(q/res)``, with the quantisation noise variance ``r = res**2/12``; the process noise
    density follows the bandwidth by :func:`adaptive_ff.io.kalman_velocity.process_noise_density` (the
    filter's poles on a Butterworth circle of radius ``2*pi*fb``) and the constant gain is the steady state of
    the Riccati equation (:func:`adaptive_ff.io.kalman_velocity.steady_state_kalman`). Each period: predict
    ``x = F x``, correct ``x += K*(qm - x[0])``; the loop receives ``x[1]`` plus the run's velocity noise (the
    same white velocity-measurement noise as with the difference, so both choices see the same ``noise_std``).
    The first period gives the true velocity (as the difference does) and starts the filter at ``[qm, w, 0]``.
    """

    _ffi = ffi
    _ctype = "ctl_sensor"

    def __init__(self, *, Tc: float, counts_per_rev: int | None = None, delay: int = 0,
                 velocity: str = "difference", bandwidth: float | None = None, model: str = "cv"):
        Tc = check_positive("Tc", Tc)
        if counts_per_rev is not None and not _whole(counts_per_rev, 1):
            raise ParameterError(f"counts_per_rev must be an integer >= 1 (encoder counts per joint revolution) or "
                                 f"None, got {counts_per_rev!r}")
        if not _whole(delay, 0, DELAY_MAX):
            raise ParameterError(f"delay must be an integer number of periods in 0..{DELAY_MAX}, got {delay!r}")
        if velocity not in VELOCITIES:
            raise ParameterError(f"velocity must be one of {list(VELOCITIES)}, got {velocity!r}")
        if model not in KALMAN_MODELS:
            raise ParameterError(f"model must be one of {list(KALMAN_MODELS)} (the Kalman velocity's kinematic "
                                 f"model), got {model!r}")
        if bandwidth is not None:
            bandwidth = check_positive("bandwidth", bandwidth)
            if velocity != "kalman":
                raise ParameterError(f"bandwidth is the Kalman velocity's (Hz): give it with velocity='kalman', "
                                     f"got bandwidth={bandwidth!r} with velocity={velocity!r}")
        if velocity == "kalman" and counts_per_rev is None:
            raise ParameterError("velocity='kalman' filters an encoder's counts: give counts_per_rev too "
                                 "(LoopConfig: sensor.encoder_counts)")
        self.counts_per_rev = None if counts_per_rev is None else int(counts_per_rev)
        self._new_struct()
        res = 0.0 if counts_per_rev is None else 2.0 * math.pi / int(counts_per_rev)
        lib.ctl_sensor_init(self._c, res, Tc, int(delay))
        self.filter: SteadyStateKalman | None = None
        if velocity == "kalman":
            fb = default_velocity_bandwidth(Tc) if bandwidth is None else bandwidth
            self.filter = steady_state_kalman(model, bandwidth=fb, position_noise=res / math.sqrt(12.0), T=Tc)
            K = [float(k) for k in self.filter.K] + [0.0]
            lib.ctl_sensor_set_kalman(self._c, KALMAN_MODELS[model], K[0], K[1], K[2])

    velocity = struct_field("kalman", doc='How the encoder\'s velocity is formed: ``"difference"`` or ``"kalman"``.',
                            choices={0: "difference", 1: "kalman"})

    @property
    def bandwidth(self) -> float | None:
        """Bandwidth of the Kalman velocity (Hz); None for the difference."""
        return None if self.filter is None else self.filter.bandwidth

    gain = struct_field("K", doc="The Kalman velocity's constant gain, shape (n,) (a copy of the struct's ``K``); None for "
                        "the difference.", size="n_x", flag="kalman")

    resolution = struct_field("res", float, "Encoder resolution (rad per count); 0 for a velocity sensor.")

    delay = struct_field("delay", int, "Measurement delay (periods).")

    def measure(self, w: float, noise: float = 0.0) -> float:
        """One period: the measurement (rad/s) for the true velocity ``w`` and the noise sample (rad/s)
        (C ``ctl_sensor_measure``; the engine calls the same function)."""
        return float(lib.ctl_sensor_measure(self._c, float(w), float(noise)))

    def __repr__(self) -> str:
        if self.filter is None:
            return f"Sensor(counts_per_rev={self.counts_per_rev!r}, delay={self.delay})"
        return (f"Sensor(counts_per_rev={self.counts_per_rev!r}, delay={self.delay}, velocity='kalman', "
                f"bandwidth={self.filter.bandwidth!r}, model={self.filter.model!r})")


class Drive(Component):
    """The drive's torque slew-rate limit (after the controller's saturation, the drive's torque limit).

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s), > 0.
    slew_rate : float, keyword-only
        Largest change of the applied torque (N·m/s), > 0; ``math.inf`` = none.

    Raises
    ------
    ParameterError
        ``Tc`` or ``slew_rate`` not > 0 (or NaN).
    """

    _ffi = ffi
    _ctype = "ctl_drive"

    def __init__(self, *, Tc: float, slew_rate: float):
        Tc = check_positive("Tc", Tc)
        if isinstance(slew_rate, bool) or not isinstance(slew_rate, (int, float, np.integer, np.floating)) \
                or not slew_rate > 0:
            raise ParameterError(f"slew_rate must be > 0 (N·m/s; math.inf for none), got {slew_rate!r}")
        self._new_struct()
        lib.ctl_drive_init(self._c, float(slew_rate), Tc)

    slew_rate = struct_field("slew", float, "Torque slew-rate limit (N·m/s).")

    def apply(self, u: float) -> float:
        """One period: the torque applied (N·m) for the command ``u`` (C ``ctl_drive_apply``)."""
        return float(lib.ctl_drive_apply(self._c, float(u)))

    def __repr__(self) -> str:
        return f"Drive(slew_rate={self.slew_rate!r})"
