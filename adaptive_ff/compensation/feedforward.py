"""Fixed friction feedforward (a friction estimate, fed forward through the estimated lag) and the estimate projection.

:class:`FrictionFeedforward` is a compensator component (``KIND`` 2): its configuration and its state are the
float64 arrays ``params`` and ``state`` (layout: :mod:`adaptive_ff.compensation.ff_layout`), advanced by compiled
kernels, the one implementation, called by the class's methods and by the closed-loop engine:
:func:`ff_set_estimate` (put an estimate into use), :func:`ff_static` (the static map, eq. 3), :func:`ff_step`
(stick detection, the lag of eq. 1, the clip), :func:`ff_at` (the map at the measurement or at the reference) and
the closed-loop protocol :func:`ff_compensate` / :func:`ff_observe`. Near standstill its velocity input comes from
the loop model and the sign observer of :mod:`adaptive_ff.compensation.velocity_input`.

:func:`project_estimate` (compiled: :func:`project_levels`) projects a raw estimate onto the physically admissible
set or rejects it.

The adaptive feedforwards compose this one: the recommended
:class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward` (online sliding-regime RLS,
the paper's future work) and the paper's eq. 4 RLS feedforward, kept as a baseline, in
:mod:`adaptive_ff.compensation.eq4_feedforward`.
"""
from __future__ import annotations

import math

import numpy as np

from adaptive_ff.compensation.ff_layout import (FF_NPAR, FF_NSTATE, P_DT, P_FFMAX, P_LAG, P_REF, P_SBAND, P_SSAMP,
                                                P_SW, P_WMAX, S_ALPHA, S_DELTA, S_DF, S_FC, S_FNREJ, S_HAS, S_HASVS,
                                                S_NIB, S_SIGMA, S_TAU, S_UFF, S_UOUT, S_VS)
from adaptive_ff.compensation.velocity_input import (LoopModel, SignObserver, loop_model_step, sign_observer_step,
                                                    signed_measurement)
from adaptive_ff.identification.regression import FrictionEstimate
from plant.component import Component
from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.jit import kernel
from plant.stribeck_map import stribeck_scalar

__all__ = ["FrictionFeedforward", "project_estimate", "project_levels", "ff_set_estimate", "ff_step", "ff_at",
           "ff_compensate"]


@kernel
def project_levels(J, tau, sigma, Fc, Fs, offset, tau_max, F_max):
    """Compiled projection of a physical estimate onto the admissible set (the one implementation of :func:`project_estimate`).

    Parameters
    ----------
    J, tau, sigma, Fc, Fs, offset : float
        Raw estimate from the inverse map of eq. 4 (kg·m², s, N·m·s/rad, N·m, N·m, N·m).
    tau_max : float
        Largest admissible lag (s).
    F_max : float
        Largest admissible Coulomb or static level (N·m).

    Returns
    -------
    tuple (bool, float, float, float, float)
        ``(ok, tau, sigma, Fc, Fs)``: ``ok`` False if a value is non-finite, ``J <= 0`` or
        ``Fc``/``Fs`` exceeds ``F_max``; otherwise ``tau`` clipped to ``[0, tau_max]`` and ``sigma``,
        ``Fc``, ``Fs`` to ``>= 0`` (Ioannou & Sun, *Robust Adaptive Control*, 1996, Sec. 4.11.3;
        used by :func:`project_estimate` and by the compiled eq. 4 feedforward).
    """
    fin = (math.isfinite(J) and math.isfinite(tau) and math.isfinite(sigma) and math.isfinite(Fc)
           and math.isfinite(Fs) and math.isfinite(offset))
    if not fin or J <= 0.0 or Fc > F_max or Fs > F_max:
        return False, tau, sigma, Fc, Fs
    t = 0.0 if 0.0 > tau else tau  # Python's max(tau, 0.0), then min(., tau_max)
    t = tau_max if tau_max < t else t
    return (True, t, 0.0 if 0.0 > sigma else sigma, 0.0 if 0.0 > Fc else Fc, 0.0 if 0.0 > Fs else Fs)


def project_estimate(est: FrictionEstimate, *, tau_max: float = 1.0,
                     F_max: float = math.inf) -> FrictionEstimate | None:
    """Project a raw estimate onto the physically admissible set, or reject it.

    Parameters
    ----------
    est : FrictionEstimate
        Raw estimate from :meth:`RegressionModel.to_physical`.
    tau_max : float, keyword-only
        Largest admissible lag (s).
    F_max : float, keyword-only
        Largest admissible Coulomb or static friction level (N·m), e.g. the
        feedforward bound; default inf.

    Returns
    -------
    FrictionEstimate or None
        ``None`` if a value is non-finite, ``J <= 0`` (the input gain
        ``b0 - b1`` has the wrong sign: nothing physical can be read from it),
        or ``Fc`` or ``Fs`` exceeds ``F_max`` (an unconverged estimate);
        otherwise a copy with ``Fc, Fs, sigma`` clipped to ``>= 0`` and ``tau``
        clipped to ``[0, tau_max]``.

    Notes
    -----
    Projection onto a box of physical bounds, the standard safeguard of
    adaptive control (Ioannou & Sun, *Robust Adaptive Control*, 1996, Sec. 4.11.3),
    applied here to the physical parameters rather than to ``theta``.
    """
    ok, tau, sigma, Fc, Fs = project_levels(est.J, est.tau, est.sigma, est.Fc, est.Fs, est.offset, tau_max, F_max)
    if not ok:
        return None
    return FrictionEstimate(J=est.J, tau=tau, sigma=sigma, Fc=Fc, Fs=Fs, offset=est.offset, Vs=est.Vs,
                            delta=est.delta, J_alt=est.J_alt)


@kernel
def ff_set_estimate(par, st, Fc, Fs, Vs, delta, sigma, tau, has_vs):
    """Put a friction estimate into use (levels N·m, ``Vs`` rad/s, ``sigma`` N·m·s/rad, lag ``tau`` s).

    The lag filter gain is ``1 - exp(-dt/tau)`` (exact discretisation of eq. 1 for a held input) when the
    feedforward filters through the lag and ``tau > 0``, else 1 (no filter). ``has_vs`` 0 drops the Stribeck
    term (Coulomb level only).
    """
    st[S_HAS] = 1.0
    st[S_FC] = Fc
    st[S_DF] = Fs - Fc
    st[S_VS] = Vs
    st[S_DELTA] = delta
    st[S_SIGMA] = sigma
    st[S_TAU] = tau
    st[S_HASVS] = has_vs
    st[S_ALPHA] = 1.0 - math.exp(-par[P_DT] / tau) if (par[P_LAG] > 0.0 and tau > 0.0) else 1.0


@kernel(inline="always")
def ff_static(par, st, w):
    """Static friction estimate ``F_hat(w)`` (N·m): eq. 3 with the estimate in use, sign ramp of width
    ``sign_width`` near zero, no offset; 0 without an estimate."""
    if w == 0.0 or st[S_HAS] == 0.0:
        return 0.0
    aw = abs(w)
    if st[S_HASVS] > 0.0:  # the Stribeck level: eq. 3 at |w| without the viscous term
        mag = stribeck_scalar(aw, st[S_FC], st[S_DF], st[S_VS], st[S_DELTA], 0.0, math.inf)
    else:
        mag = st[S_FC]
    sw = par[P_SW]
    if sw > 0.0 and aw < sw:
        return mag * (w / sw) + st[S_SIGMA] * w
    return math.copysign(mag, w) + st[S_SIGMA] * w


@kernel(inline="always")
def ff_step(par, st, w, w_ref, has_ref):
    """One period: stick detection (with ``has_ref``), lag filter, clip; return the feedforward (N·m).

    While the first velocity ``w`` stays inside ``±stick_band`` for ``stick_samples`` calls the
    second, ``w_ref``, is used (see :class:`FrictionFeedforward`). A non-finite velocity (``w``, or
    ``w_ref`` when given), one above ``w_max`` in magnitude, or a non-finite friction map at it is
    rejected: the held output is returned and only the rejection counter changes.
    """
    wmax = par[P_WMAX]
    if not (math.isfinite(w) and -wmax <= w <= wmax) or (has_ref and not (math.isfinite(w_ref)
                                                                         and -wmax <= w_ref <= wmax)):
        st[S_FNREJ] += 1.0
        return min(max(st[S_UFF], -par[P_FFMAX]), par[P_FFMAX])
    x = w
    nib = st[S_NIB]
    if has_ref:
        if -par[P_SBAND] < w < par[P_SBAND]:
            nib += 1.0
            if nib >= par[P_SSAMP]:
                x = w_ref
        else:
            nib = 0.0
    fx = ff_static(par, st, x)
    if not math.isfinite(fx):
        st[S_FNREJ] += 1.0
        return min(max(st[S_UFF], -par[P_FFMAX]), par[P_FFMAX])
    st[S_NIB] = nib
    st[S_UFF] += st[S_ALPHA] * (fx - st[S_UFF])
    return min(max(st[S_UFF], -par[P_FFMAX]), par[P_FFMAX])


@kernel(inline="always")
def ff_at(par, st, w_ctrl, w_stuck, w_ref):
    """The feedforward of this period at the reference (``ff_input`` reference) or at the measurement (with the
    sign observer's sign inside the stick band, if any) with stick detection against ``w_stuck`` (the loop model's
    velocity, or the reference without a model)."""
    if par[P_REF] > 0.0:
        return ff_step(par, st, w_ref, w_ref, False)
    return ff_step(par, st, signed_measurement(par, st, w_ctrl), w_stuck, True)


@kernel(inline="always")
def ff_compensate(par, st, w_ctrl, w_meas, w_ref):
    """Compensator protocol (``KIND`` 2): the fixed feedforward at the controller's measurement (with stick
    detection against the loop model's velocity, or the reference without a model) or at the reference."""
    out = ff_at(par, st, w_ctrl, loop_model_step(par, st, w_ctrl, w_ref), w_ref)
    st[S_UOUT] = out
    return out


@kernel
def ff_observe(par, st, u, w_meas, theta_out):
    """Compensator protocol: the fixed feedforward learns nothing; its sign observer (if any) takes the applied
    torque ``u`` (:func:`sign_observer_step`)."""
    sign_observer_step(par, st, u)
    return False


class FrictionFeedforward(Component):
    """Friction feedforward torque from a fixed estimate, with the estimated lag.

    Parameters
    ----------
    estimate : FrictionEstimate or None
        Friction parameters; ``None`` gives zero feedforward.
    dt : float, keyword-only
        Call period of :meth:`step` (s), e.g. the controller period.
    lag : bool, keyword-only
        Filter the static map through the estimated lag ``tau`` (eq. 1), default True.
    ff_max : float, keyword-only
        Bound on |feedforward| (N·m), default inf.
    sign_width : float, keyword-only
        Treatment of the sign near zero velocity (rad/s): 0 (default) uses
        ``sgn(w)``; ``> 0`` the linear ramp ``clip(w/sign_width, -1, 1)``, which
        stops measurement noise from flipping the full Coulomb torque.
    stick_band : float, keyword-only
        Velocity band (rad/s) for the stick detection: once the first velocity
        given to :meth:`step` (the measurement) has stayed inside
        ``±stick_band`` for ``stick_samples`` consecutive calls, the joint is
        taken as stuck and the second velocity (the reference: the intended
        direction of motion) is used instead, until the measurement leaves the
        band. A stuck joint's measured velocity is noise; its sign says
        nothing. Default 0 (off).
    stick_samples : int, keyword-only
        Consecutive in-band samples that declare sticking, >= 1; default 10.
    ff_input : {"measured", "reference"}, keyword-only
        Velocity the closed-loop engine evaluates the feedforward at (:meth:`compensate`): the
        controller's measurement with stick detection (default), or the reference itself.
    w_max : float, keyword-only
        Largest plausible speed (rad/s), > 0: a velocity above it is rejected like a
        non-finite one (see Notes); default inf.
    loop_model : LoopModel or None, keyword-only
        The nominal velocity loop. Given, :meth:`compensate` uses its velocity (driven by the
        reference) instead of the reference while the joint is detected as stuck (see Notes); default
        None: the reference.
    sign_observer : SignObserver or None, keyword-only
        Given, :meth:`compensate` takes the sign of the friction map from this velocity observer while the
        measurement is inside ``±stick_band`` (before the joint is detected as stuck; see Notes); default None:
        the measurement's sign.

    Attributes
    ----------
    params, state : ndarray
        The component's arrays (see :class:`plant.component.Component`); :func:`ff_step` and
        :func:`ff_compensate` advance them.
    n_step_rejected : int
        Calls of :meth:`step` whose input was rejected (non-finite or above ``w_max``,
        or a non-finite friction map); they returned the held output.

    Raises
    ------
    ParameterError
        ``dt <= 0``, ``ff_max < 0``, ``sign_width < 0``, ``stick_band < 0``, ``stick_samples < 1`` or an
        unknown ``ff_input``.

    Notes
    -----
    ``u_ff`` follows ``tau*du_ff/dt + u_ff = F_hat(w)`` (eq. 1 with the estimate),
    discretised exactly for a held input: ``u_ff += (1 - exp(-dt/tau))*(F_hat(w) - u_ff)``.
    The constant ``offset`` of the estimate is not fed forward (it is a sensor
    or drive bias, not friction; the PI integrator removes it).

    **Input rejection.** A call with a non-finite velocity (or reference, when
    given), a velocity above ``w_max`` in magnitude, or a friction map that is
    not finite there (e.g. ``sigma*w`` overflowing) changes nothing but
    :attr:`n_step_rejected` and returns the last output (held, clipped): one
    bad sample cannot poison the lag filter. Finite spikes within ``w_max`` are
    the job of the measurement's gate (:class:`adaptive_ff.compensation.gate.OutlierGate`).

    **Stick-detection fallback.** Inside the stick band the measured velocity is noise and its sign
    says nothing; a friction map fed back from it turns every wrong-signed sample into a ``2*Fs``
    torque error, and near a slow zero crossing those kicks push the joint the way the noise said
    (the joint then follows the wrong sign). The reference gives the intended direction but leads
    the joint at reversals by the loop's lag (the feedforward flips early and kicks the joint). The
    loop model's velocity (:class:`LoopModel`, :func:`loop_model_step`) is the noise-free trajectory of
    the compensated joint, with the loop's lag: at a reversal it crosses zero when the joint should.
    Outside the band the measurement is used (it cancels the Stribeck dip's negative damping, which a
    map at any other velocity would not). Measured on ``paper`` (docs/benchmarks/variants.md).

    **Sign inside the band.** Before the joint counts as stuck (a reversal crosses the band in a few
    periods), the measured sign near zero flips with the noise, and each wrong-signed sample is a ``2*Fs``
    step into the lag filter. With a :class:`SignObserver` the map is evaluated at the measured speed with the
    observer's sign there (:func:`sign_observer_step`): a noise-filtered estimate that follows the joint's
    acceleration through the applied torque and crosses zero with the joint (docs/benchmarks/compensation.md).
    """

    KIND = 2
    MODE = "fixed"
    n_theta = 0

    def __init__(self, estimate: FrictionEstimate | None, *, dt: float, lag: bool = True,
                 ff_max: float = math.inf, sign_width: float = 0.0, stick_band: float = 0.0,
                 stick_samples: int = 10, ff_input: str = "measured", w_max: float = math.inf,
                 loop_model: LoopModel | None = None, sign_observer: SignObserver | None = None):
        dt = check_positive("dt", dt)
        if loop_model is not None and not isinstance(loop_model, LoopModel):
            raise ParameterError(f"loop_model must be a LoopModel or None, got {type(loop_model).__name__}")
        if sign_observer is not None and not isinstance(sign_observer, SignObserver):
            raise ParameterError(f"sign_observer must be a SignObserver or None, got {type(sign_observer).__name__}")
        w_max = float(w_max) if w_max == math.inf else check_positive("w_max", w_max)
        ff_max = float(ff_max) if ff_max == math.inf else check_nonnegative("ff_max", ff_max)
        sign_width = check_nonnegative("sign_width", sign_width)
        stick_band = check_nonnegative("stick_band", stick_band)
        if isinstance(stick_samples, bool) or not isinstance(stick_samples, (int, np.integer)) or stick_samples < 1:
            raise ParameterError(f"stick_samples must be an integer >= 1, got {stick_samples!r}")
        if ff_input not in ("measured", "reference"):
            raise ParameterError(f"ff_input must be 'measured' or 'reference', got {ff_input!r}")
        self._init_arrays(FF_NPAR, FF_NSTATE)
        lm = (0.0, 0.0, 0.0, 0.0, 0.0) if loop_model is None else (
            1.0, float(loop_model.Kp), float(loop_model.Ki) * dt, dt / float(loop_model.J),
            1.0 - math.exp(-loop_model.bandwidth * dt))
        ob = (0.0, 0.0, 0.0, 0.0) if sign_observer is None else (1.0, dt / float(sign_observer.J)) + \
            sign_observer.gains(dt)
        self.params[:] = (dt, float(bool(lag)), ff_max, sign_width, stick_band, float(stick_samples),
                          float(ff_input == "reference"), w_max) + lm + ob
        self.loop_model = loop_model
        self.sign_observer = sign_observer
        self.state[S_ALPHA] = 1.0
        self.estimate = None
        self._set(estimate)

    dt = property(lambda self: float(self.params[P_DT]), doc="Call period of :meth:`step` (s).")
    lag = property(lambda self: bool(self.params[P_LAG]), doc="Filter through the estimated lag.")
    ff_max = property(lambda self: float(self.params[P_FFMAX]), doc="Bound on |feedforward| (N·m).")
    sign_width = property(lambda self: float(self.params[P_SW]), doc="Sign ramp half-width (rad/s).")
    stick_band = property(lambda self: float(self.params[P_SBAND]), doc="Stick-detection band (rad/s).")
    stick_samples = property(lambda self: int(self.params[P_SSAMP]), doc="In-band samples that declare sticking.")
    ff_input = property(lambda self: "reference" if self.params[P_REF] else "measured",
                        doc="Velocity the engine evaluates the feedforward at (``compensate``).")
    u_ff = property(lambda self: float(self.state[S_UFF]), doc="Feedforward before the clip (N·m).")
    w_max = property(lambda self: float(self.params[P_WMAX]), doc="Largest plausible speed (rad/s).")
    n_step_rejected = property(lambda self: int(self.state[S_FNREJ]),
                               doc="Calls of step() whose input was rejected (the output was held).")

    def _set(self, est: FrictionEstimate | None) -> None:
        self.estimate = est
        if est is not None:
            has = est.Vs is not None
            ff_set_estimate(self.params, self.state, est.Fc, est.Fs, est.Vs if has else 1.0,
                            est.delta if has else 1.0, est.sigma, est.tau, float(has))

    def static(self, w: float) -> float:
        """Static friction estimate ``F_hat(w)`` (N·m), eq. 3 with the estimate (no offset)."""
        return float(ff_static(self.params, self.state, float(w)))

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m).

        Parameters
        ----------
        w : float
            Velocity the friction map is evaluated at (rad/s), e.g. the measurement.
        w_ref : float, optional
            Used instead of ``w`` while the joint is detected as stuck (see
            ``stick_band``), e.g. the reference velocity.

        Returns
        -------
        float
            The feedforward (N·m), within ``±ff_max``; the held output if the input was
            rejected (class Notes, counted in :attr:`n_step_rejected`).
        """
        has = w_ref is not None
        return float(ff_step(self.params, self.state, float(w), float(w_ref) if has else 0.0, has))

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensator protocol: the feedforward for this period at the measured velocity (with stick detection)
        or at the reference, as ``ff_input`` says (N·m)."""
        return float(ff_compensate(self.params, self.state, float(w_meas), float(w_meas), float(w_ref)))

    def observe(self, u: float, w: float) -> bool:
        """Compensator protocol: nothing to learn (returns False); the sign observer (if any) takes the applied
        torque ``u`` (N·m) of this period."""
        sign_observer_step(self.params, self.state, float(u))
        return False
