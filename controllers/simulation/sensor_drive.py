"""The loop's sensor and drive as they are: an encoder's quantised position, a measurement delay, a torque slew limit.

Thin classes over the C structs ``ctl_sensor`` and ``ctl_drive`` (``controllers/csrc/ctl_sensor.h``,
``ctl_drive.h``), which the closed-loop engine holds per scenario
(:meth:`controllers.simulation.engine.EngineRun.set_sensor`, ``set_drive``):

* :class:`Sensor`: the velocity the loop measures. With ``counts_per_rev`` it is an encoder: the true position
  (integrated by the trapezoidal rule over each period) is read in whole counts and the velocity is their
  backward difference over the period, ``(qm[k] - qm[k-1])/Tc`` (a 2^17-count encoder at 1 kHz: steps of
  0.048 rad/s); the noise of the run, if any, is added to it. ``delay`` periods of measurement delay (0-32).
* :class:`Drive`: the torque the joint receives, after the controller's saturation ``u_max`` (the drive's
  torque limit): at most ``slew_rate`` N·m/s of change. The compensators observe the applied torque.

Without either the loop measures ``w + noise`` and applies the command (the engine's default, unchanged).
"""

from __future__ import annotations

import math

from controllers._cctl import ffi, lib
from plant.component import Component
from plant.errors import ParameterError, check_positive

__all__ = ["Sensor", "Drive", "DELAY_MAX"]

#: Largest measurement delay (periods), ``CTL_DELAY_MAX`` of ctl_sensor.h.
DELAY_MAX = len(ffi.new("ctl_sensor *").buf) - 1


class Sensor(Component):
    """The loop's velocity sensor: an encoder (quantised position, backward difference) and/or a delay.

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s), > 0.
    counts_per_rev : int or None, keyword-only
        Encoder counts per joint revolution (e.g. ``2**17``), >= 1; None (default): a velocity sensor
        (``w + noise``).
    delay : int, keyword-only
        Measurement delay in periods, ``0 <= delay <=`` :data:`DELAY_MAX`; default 0.

    Attributes
    ----------
    cdata : cffi ``ctl_sensor *``
        Fields ``res`` (rad per count, 0 without an encoder), ``Tc``, ``delay`` and the state.
    resolution : float
        Encoder resolution (rad per count), 0 for a velocity sensor.

    Raises
    ------
    ParameterError
        ``Tc`` not > 0, ``counts_per_rev`` not an integer >= 1, ``delay`` outside ``0..DELAY_MAX``.
    """

    _ffi = ffi
    _ctype = "ctl_sensor"

    def __init__(self, *, Tc: float, counts_per_rev: int | None = None, delay: int = 0):
        Tc = check_positive("Tc", Tc)
        if counts_per_rev is not None and (isinstance(counts_per_rev, bool) or int(counts_per_rev) != counts_per_rev
                                           or counts_per_rev < 1):
            raise ParameterError(f"counts_per_rev must be an integer >= 1 (encoder counts per joint revolution) or "
                                 f"None, got {counts_per_rev!r}")
        if isinstance(delay, bool) or int(delay) != delay or not 0 <= delay <= DELAY_MAX:
            raise ParameterError(f"delay must be an integer number of periods in 0..{DELAY_MAX}, got {delay!r}")
        self.counts_per_rev = None if counts_per_rev is None else int(counts_per_rev)
        self._new_struct()
        res = 0.0 if counts_per_rev is None else 2.0 * math.pi / int(counts_per_rev)
        lib.ctl_sensor_init(self._c, res, Tc, int(delay))

    @property
    def resolution(self) -> float:
        """Encoder resolution (rad per count); 0 for a velocity sensor."""
        return float(self._c.res)

    @property
    def delay(self) -> int:
        """Measurement delay (periods)."""
        return int(self._c.delay)

    def measure(self, w: float, noise: float = 0.0) -> float:
        """One period: the measurement (rad/s) for the true velocity ``w`` and the noise sample (rad/s)
        (C ``ctl_sensor_measure``; the engine calls the same function)."""
        return float(lib.ctl_sensor_measure(self._c, float(w), float(noise)))

    def __repr__(self) -> str:
        return f"Sensor(counts_per_rev={self.counts_per_rev!r}, delay={self.delay})"


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
        if not slew_rate > 0:
            raise ParameterError(f"slew_rate must be > 0 (N·m/s; math.inf for none), got {slew_rate!r}")
        self._new_struct()
        lib.ctl_drive_init(self._c, float(slew_rate), Tc)

    @property
    def slew_rate(self) -> float:
        """Torque slew-rate limit (N·m/s)."""
        return float(self._c.slew)

    def apply(self, u: float) -> float:
        """One period: the torque applied (N·m) for the command ``u`` (C ``ctl_drive_apply``)."""
        return float(lib.ctl_drive_apply(self._c, float(u)))

    def __repr__(self) -> str:
        return f"Drive(slew_rate={self.slew_rate!r})"
