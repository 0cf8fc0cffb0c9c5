"""The velocity input of the friction feedforward near standstill: the loop model and the sign observer.

Inside the stick band the measured velocity is noise and its sign says nothing; a friction map fed from it turns
every wrong-signed sample into a ``2*Fs`` torque error (see
:class:`adaptive_ff.compensation.feedforward.FrictionFeedforward`, Notes). Two optional components give the map a
better input there:

* :class:`LoopModel`, the nominal (frictionless) velocity loop driven by the reference: the velocity used once the
  joint is detected as stuck;
* :class:`SignObserver`, a velocity observer driven by the applied torque: the sign of the map inside the stick
  band before the joint counts as stuck.

The classes hold the settings (the C ``aff_loop_model_config``, ``aff_sign_observer_config``). Their configuration
and state are C structs embedded in the feedforward's (``adaptive_ff/csrc/aff_velocity_input.h``: ``aff_loop_model``,
``aff_sign_observer``, configured by ``aff_loop_model_init``, ``aff_sign_observer_init``), advanced once per
controller period by C (``aff_loop_model_step``, ``aff_sign_observer_signed``, ``aff_sign_observer_step``) inside
the feedforwards' compensate/observe (``adaptive_ff/csrc/aff_feedforward.c`` and the adaptive feedforwards).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from plant.errors import ParameterError, check_nonnegative, check_positive

__all__ = ["LoopModel", "SignObserver"]


@dataclass(frozen=True)
class LoopModel:
    """The nominal (frictionless) velocity loop a feedforward uses as its stick-detection fallback.

    Parameters
    ----------
    Kp : float
        Proportional gain of the loop's PI (N·m·s/rad), >= 0.
    Ki : float
        Integral gain of the loop's PI (N·m/rad), >= 0.
    J : float
        Design inertia (kg·m²), > 0: what the user knows (a data sheet), never the true plant's.
    track : float or None
        Bandwidth (rad/s, >= 0) at which the fallback follows the measured deviation of the joint from the
        model (see Notes); default None: ``Kp/J``, the rate at which the loop itself removes a deviation
        (about its crossover); 0: the model velocity alone.

    Raises
    ------
    ParameterError
        A gain negative or not finite, ``J`` not > 0, both gains 0, or ``track`` negative or not finite.

    Notes
    -----
    With the controller's PI ``C(z) = Kp + Ki*Tc*z/(z - 1)`` (backward-Euler integrator) and the frictionless joint
    ``1/(J s)`` sampled with a zero-order hold (exact: ``Tc/(J (z - 1))``), the model velocity follows the closed
    loop ``w_m = C P/(1 + C P) w_ref`` driven by the reference: the trajectory the joint would take if the friction
    were cancelled exactly, without measurement noise. This is the reference model of model-reference adaptive
    control (Åström & Wittenmark, *Adaptive Control*, 2nd ed., 1995, Sec. 5.1); see
    :class:`~adaptive_ff.compensation.feedforward.FrictionFeedforward` for its use. The fallback velocity is
    ``w_m + d``, with ``d`` the measured deviation ``w_meas - w_m`` through a first-order low-pass of bandwidth
    ``track`` (``d += (1 - exp(-track*dt))*(w_meas - w_m - d)``): the model's noise-free shape, shifted to where the
    joint really is (a joint that sticks, or lags the nominal loop, is not assumed to move as the model does).
    Measured (120 s, seeds 0-2, eta of ``adaptive`` with ``track`` 0 -> ``Kp/J``): karnopp 0.65 -> 0.75, paper,
    long-lag and small-inertia within +-0.01 (docs/benchmarks/variants.md).
    """

    Kp: float
    Ki: float
    J: float
    track: float | None = None

    def __post_init__(self):
        for name in ("Kp", "Ki"):
            v = getattr(self, name)
            try:
                ok = math.isfinite(float(v)) and float(v) >= 0.0
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ParameterError(f"loop model: {name} must be finite and >= 0, got {v!r}")
        check_positive("J", self.J)
        if self.Kp == 0.0 and self.Ki == 0.0:
            raise ParameterError("loop model: Kp and Ki are both 0 (no loop)")
        if self.track is not None and not (isinstance(self.track, (int, float)) and math.isfinite(self.track)
                                           and self.track >= 0.0):
            raise ParameterError(f"loop model: track must be finite and >= 0 (rad/s) or None, got {self.track!r}")

    @property
    def bandwidth(self) -> float:
        """The tracking bandwidth in use (rad/s): ``track``, or ``Kp/J`` when it is None."""
        return float(self.Kp) / float(self.J) if self.track is None else float(self.track)

    def config_fields(self) -> dict:
        """The fields of the C settings ``aff_loop_model_config`` (``aff_loop_model_init`` computes from them and the
        period ``dt`` the gains ``Ki*dt``, ``dt/J`` and ``1 - exp(-bandwidth*dt)``; one period: ``e = w_ref - w_m``,
        ``I += Ki*dt*e``, ``w_m += dt/J*(Kp*e + I)``, the deviation tracked with the last gain, class Notes):
        ``Kp``, ``Ki``, ``J`` and ``track`` (-1 for None: ``Kp/J``)."""
        return {"Kp": float(self.Kp), "Ki": float(self.Ki), "J": float(self.J),
                "track": -1.0 if self.track is None else float(self.track)}


@dataclass(frozen=True)
class SignObserver:
    """Velocity observer that gives the friction map its sign inside the stick band.

    Its use: :class:`~adaptive_ff.compensation.feedforward.FrictionFeedforward` (Notes).

    Parameters
    ----------
    J : float
        Design inertia (kg·m²), > 0: what the user knows (a data sheet), never the true plant's.
    bandwidth : float
        Observer bandwidth (rad/s), > 0: the rate at which the estimate is pulled to the measurement.
    residual_bandwidth : float or None
        Bandwidth (rad/s, >= 0) of the estimate of a constant friction residual (see Notes); default None:
        ``0.1*bandwidth``; 0: no residual state.

    Raises
    ------
    ParameterError
        ``J`` or ``bandwidth`` not finite and > 0, ``residual_bandwidth`` negative or not finite.

    Notes
    -----
    The compensated joint is the model ``J dw/dt = u - u_c - d`` with the applied torque ``u``, the compensator's
    own torque ``u_c`` (its friction estimate) and a constant residual ``d`` (the part of the friction the
    estimate misses, e.g. an asymmetry), sampled with a zero-order hold; ``z = d*Tc/J``. Per period ``Tc`` the
    a-priori estimate ``w_hat`` is used, then corrected by the controller's measurement ``w_c`` and predicted
    (C: ``aff_sign_observer_step``)::

        e = w_c - w_hat;   w_hat += l1*e;   z_hat -= l2*e
        w_hat += Tc/J*(u - u_c) - z_hat

    with ``l1 = 1 - p1*p2``, ``l2 = (1 - p1)*(1 - p2)``, ``p1 = exp(-bandwidth*Tc)``, ``p2 =
    exp(-residual_bandwidth*Tc)``: the poles of the error dynamics (a Luenberger observer with a
    constant-disturbance state: Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed., 1998,
    Secs. 8.2 and 8.5; poles a few times faster than the loop's, ibid. Sec. 8.3). The residual's pole is the
    slower one, so that the fast friction transients of a reversal are not taken for a lasting residual. The estimate follows the joint's acceleration through the torque, not through differences of the
    noisy measurement: near a reversal its sign is that of the joint, where the measurement's sign flips with
    the noise (each wrong-signed sample is a ``2*Fs`` torque error into the lag filter). A constant residual
    leaves no bias; a changing one (at a reversal, where the estimate in use is least exact) does, so the
    observer's sign is used only inside the stick band, where the measured sign says nothing anyway.
    """

    J: float
    bandwidth: float
    residual_bandwidth: float | None = None

    def __post_init__(self):
        check_positive("J", self.J)
        check_positive("bandwidth", self.bandwidth)
        if self.residual_bandwidth is not None:
            check_nonnegative("residual_bandwidth", self.residual_bandwidth)

    def config_fields(self) -> dict:
        """The fields of the C settings ``aff_sign_observer_config`` (``aff_sign_observer_init`` computes from them
        and the period the gains ``l1``, ``l2`` of the class Notes and ``Tc/J``): ``J``, ``bandwidth`` and
        ``residual_bandwidth`` (-1 for None: ``0.1*bandwidth``)."""
        return {"J": float(self.J), "bandwidth": float(self.bandwidth),
                "residual_bandwidth": -1.0 if self.residual_bandwidth is None else float(self.residual_bandwidth)}
