"""The velocity input of the friction feedforward near standstill: the loop model and the sign observer.

Inside the stick band the measured velocity is noise and its sign says nothing; a friction map fed from it turns
every wrong-signed sample into a ``2*Fs`` torque error (see
:class:`adaptive_ff.compensation.feedforward.FrictionFeedforward`, Notes). Two optional components give the map a
better input there:

* :class:`LoopModel`, the nominal (frictionless) velocity loop driven by the reference, and its kernel
  :func:`loop_model_step`: the velocity used once the joint is detected as stuck;
* :class:`SignObserver`, a velocity observer driven by the applied torque, and its kernels
  :func:`signed_measurement` (the measurement with the observer's sign inside the stick band) and
  :func:`sign_observer_step` (correction by the measurement, prediction with the torque): the sign of the map
  before the joint counts as stuck.

The classes hold the settings; their configuration and state are slots of the feedforward's arrays
(:mod:`adaptive_ff.compensation.ff_layout`), which the compiled kernels advance once per controller period, inside
the fixed feedforward's (:mod:`adaptive_ff.compensation.feedforward`) and the adaptive feedforward's
(:mod:`adaptive_ff.compensation.adaptive_feedforward`) kernels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from adaptive_ff.compensation.ff_layout import (P_BJ, P_KITC, P_KP, P_LM, P_LMA, P_OB, P_OBJ, P_OBL, P_OBZ, P_SBAND,
                                                S_DW, S_IM, S_NM, S_OBN, S_UOUT, S_WCS, S_WH, S_WM, S_ZH)
from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.jit import kernel

__all__ = ["LoopModel", "SignObserver", "loop_model_step", "signed_measurement", "sign_observer_step"]


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
    (:func:`sign_observer_step`)::

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

    def gains(self, dt: float) -> tuple:
        """``(l1, l2)`` of the observer at the period ``dt`` (s): error poles at ``exp(-bandwidth*dt)`` and
        ``exp(-residual_bandwidth*dt)`` (class Notes)."""
        p1 = math.exp(-float(self.bandwidth) * dt)
        rb = 0.1 * float(self.bandwidth) if self.residual_bandwidth is None else float(self.residual_bandwidth)
        p2 = math.exp(-rb * dt)
        return 1.0 - p1 * p2, (1.0 - p1) * (1.0 - p2)


@kernel(inline="always")
def loop_model_step(par, st, w0, w_ref):
    """One period of the :class:`LoopModel` in ``(par, st)``: return the model velocity of this period (rad/s).

    ``e = w_ref - w_m``, ``I += Ki*dt*e``, then ``w_m += dt/J*(Kp*e + I)`` (the PI of the loop on the
    zero-order-hold joint ``1/(J s)``); the returned velocity is ``w_m + d`` with the tracked deviation
    ``d += a*(w0 - w_m - d)`` (``a`` from the model's ``track``; a non-finite ``w0`` leaves ``d``). The model
    starts at ``w0`` (the controller's measurement of this period; at the first call the model velocity, 0 if
    not finite) with an empty integrator. Without a model (``par`` says none) ``w_ref`` is returned and nothing
    changes.
    """
    if par[P_LM] == 0.0:
        return w_ref
    if st[S_NM] == 0.0:
        st[S_WM] = w0 if math.isfinite(w0) else 0.0
        st[S_IM] = 0.0
        st[S_NM] = 1.0
    wm = st[S_WM]
    e = w_ref - wm
    st[S_IM] += par[P_KITC] * e
    st[S_WM] = wm + par[P_BJ] * (par[P_KP] * e + st[S_IM])
    if par[P_LMA] > 0.0 and math.isfinite(w0):
        st[S_DW] += par[P_LMA] * (w0 - wm - st[S_DW])
    return wm + st[S_DW]


@kernel(inline="always")
def signed_measurement(par, st, w_ctrl):
    """The measurement with the :class:`SignObserver`'s sign inside the stick band (unchanged without an observer,
    outside the band or when not finite); records ``w_ctrl`` for :func:`sign_observer_step` and starts the observer
    at the first measurement."""
    if par[P_OB] == 0.0:
        return w_ctrl
    st[S_WCS] = w_ctrl
    if st[S_OBN] == 0.0:
        st[S_WH] = w_ctrl if math.isfinite(w_ctrl) else 0.0
        st[S_OBN] = 1.0
    if math.isfinite(w_ctrl) and -par[P_SBAND] < w_ctrl < par[P_SBAND]:
        return math.copysign(abs(w_ctrl), st[S_WH])
    return w_ctrl


@kernel(inline="always")
def sign_observer_step(par, st, u):
    """Correct the :class:`SignObserver` estimate with this period's measurement and predict the next period with
    the applied torque ``u`` (N·m) less the compensator's output of this period (nothing without an observer or
    before its first measurement; a non-finite measurement or torque skips its part)."""
    if par[P_OB] == 0.0 or st[S_OBN] == 0.0:
        return
    wc = st[S_WCS]
    if math.isfinite(wc):
        e = wc - st[S_WH]
        st[S_WH] += par[P_OBL] * e
        st[S_ZH] -= par[P_OBZ] * e
    du = u - st[S_UOUT]
    if math.isfinite(du):
        st[S_WH] += par[P_OBJ] * du - st[S_ZH]
