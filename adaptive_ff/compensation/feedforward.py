"""Friction feedforward: fixed (from an offline estimate) and adaptive (online RLS, the paper's future work).

Two components: :class:`FrictionFeedforward` (a fixed estimate through the
estimated lag) and :class:`RobustAdaptiveFeedforward` (the recommended one: sliding-regime
inverse-dynamics RLS with directional forgetting, projection, outlier and
plausibility gates, see :mod:`adaptive_ff.compensation.sliding_estimator`; optionally with a
provisional start map, :class:`FeedforwardStart`, until its first trusted estimate). The
paper's eq. 4 RLS feedforward, kept as a baseline, composes the first in
:mod:`adaptive_ff.compensation.eq4_feedforward`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from adaptive_ff.compensation.ff_layout import (ALPHA, DELTA, DF, DT, FC, FF_NPAR, FF_NSTATE, FFMAX, FNREJ, HAS,
                                               HASVS, LAG, NIB, REF, SBAND, SIGMA, SSAMP, SW, TAU, UFF, UOUT, VS,
                                               WMAX)
from adaptive_ff.compensation.sliding_estimator import (SlidingFrictionEstimator, estimate_from_theta,
                                                       sliding_config, sliding_mse, sliding_observe, sliding_rls,
                                                       sliding_sizes, sliding_updated)
from adaptive_ff.compensation.velocity_input import (LoopModel, SignObserver, loop_model_step, sign_observer_step,
                                                    signed_measurement)
from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.identification.rls import rls_P, rls_n_updates, rls_theta
from plant.component import Component
from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.jit import kernel
from plant.stribeck import stribeck_scalar

__all__ = ["FrictionFeedforward", "RobustAdaptiveFeedforward", "FeedforwardStart", "project_estimate",
           "project_levels", "ff_set_estimate", "ff_step", "ff_compensate", "robust_compensate", "robust_observe"]


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
    st[HAS] = 1.0
    st[FC] = Fc
    st[DF] = Fs - Fc
    st[VS] = Vs
    st[DELTA] = delta
    st[SIGMA] = sigma
    st[TAU] = tau
    st[HASVS] = has_vs
    st[ALPHA] = 1.0 - math.exp(-par[DT] / tau) if (par[LAG] > 0.0 and tau > 0.0) else 1.0


@kernel(inline="always")
def ff_static(par, st, w):
    """Static friction estimate ``F_hat(w)`` (N·m): eq. 3 with the estimate in use, sign ramp of width
    ``sign_width`` near zero, no offset; 0 without an estimate."""
    if w == 0.0 or st[HAS] == 0.0:
        return 0.0
    aw = abs(w)
    if st[HASVS] > 0.0:  # the Stribeck level: eq. 3 at |w| without the viscous term
        mag = stribeck_scalar(aw, st[FC], st[DF], st[VS], st[DELTA], 0.0, math.inf)
    else:
        mag = st[FC]
    sw = par[SW]
    if sw > 0.0 and aw < sw:
        return mag * (w / sw) + st[SIGMA] * w
    return math.copysign(mag, w) + st[SIGMA] * w


@kernel(inline="always")
def ff_step(par, st, w, w_ref, has_ref):
    """One period: stick detection (with ``has_ref``), lag filter, clip; return the feedforward (N·m).

    While the first velocity ``w`` stays inside ``±stick_band`` for ``stick_samples`` calls the
    second, ``w_ref``, is used (see :class:`FrictionFeedforward`). A non-finite velocity (``w``, or
    ``w_ref`` when given), one above ``w_max`` in magnitude, or a non-finite friction map at it is
    rejected: the held output is returned and only the rejection counter changes.
    """
    wmax = par[WMAX]
    if not (math.isfinite(w) and -wmax <= w <= wmax) or (has_ref and not (math.isfinite(w_ref)
                                                                         and -wmax <= w_ref <= wmax)):
        st[FNREJ] += 1.0
        return min(max(st[UFF], -par[FFMAX]), par[FFMAX])
    x = w
    nib = st[NIB]
    if has_ref:
        if -par[SBAND] < w < par[SBAND]:
            nib += 1.0
            if nib >= par[SSAMP]:
                x = w_ref
        else:
            nib = 0.0
    fx = ff_static(par, st, x)
    if not math.isfinite(fx):
        st[FNREJ] += 1.0
        return min(max(st[UFF], -par[FFMAX]), par[FFMAX])
    st[NIB] = nib
    st[UFF] += st[ALPHA] * (fx - st[UFF])
    return min(max(st[UFF], -par[FFMAX]), par[FFMAX])


@kernel(inline="always")
def ff_at(par, st, w_ctrl, w_stuck, w_ref):
    """The feedforward of this period at the reference (``ff_input`` reference) or at the measurement (with the
    sign observer's sign inside the stick band, if any) with stick detection against ``w_stuck`` (the loop model's
    velocity, or the reference without a model)."""
    if par[REF] > 0.0:
        return ff_step(par, st, w_ref, w_ref, False)
    return ff_step(par, st, signed_measurement(par, st, w_ctrl), w_stuck, True)


@kernel(inline="always")
def ff_compensate(par, st, w_ctrl, w_meas, w_ref):
    """Compensator protocol (``KIND`` 2): the fixed feedforward at the controller's measurement (with stick
    detection against the loop model's velocity, or the reference without a model) or at the reference."""
    out = ff_at(par, st, w_ctrl, loop_model_step(par, st, w_ctrl, w_ref), w_ref)
    st[UOUT] = out
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
        self.state[ALPHA] = 1.0
        self.estimate = None
        self._set(estimate)

    dt = property(lambda self: float(self.params[DT]), doc="Call period of :meth:`step` (s).")
    lag = property(lambda self: bool(self.params[LAG]), doc="Filter through the estimated lag.")
    ff_max = property(lambda self: float(self.params[FFMAX]), doc="Bound on |feedforward| (N·m).")
    sign_width = property(lambda self: float(self.params[SW]), doc="Sign ramp half-width (rad/s).")
    stick_band = property(lambda self: float(self.params[SBAND]), doc="Stick-detection band (rad/s).")
    stick_samples = property(lambda self: int(self.params[SSAMP]), doc="In-band samples that declare sticking.")
    ff_input = property(lambda self: "reference" if self.params[REF] else "measured",
                        doc="Velocity the engine evaluates the feedforward at (``compensate``).")
    u_ff = property(lambda self: float(self.state[UFF]), doc="Feedforward before the clip (N·m).")
    w_max = property(lambda self: float(self.params[WMAX]), doc="Largest plausible speed (rad/s).")
    n_step_rejected = property(lambda self: int(self.state[FNREJ]),
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


# RobustAdaptiveFeedforward arrays. params: the feedforward's, own settings, offsets, the estimator's;
# state: the feedforward's, own slots, the parameter vector in use (p), the estimator's.
# (start gain and start input: the provisional start, see FeedforwardStart; the state flag _PROV is 1 while it
# is in use)
(_WARMUP, _FADE, _JLO, _JHI, _TAUMAX, _CONSIST, _P, _PO_EST, _SO_FTH, _SO_EST, _SGAIN, _SREF, _LAGZ, _RELSD,
 _LAGCAP) = range(FF_NPAR, FF_NPAR + 15)
_GAIN, _NIMPL, _NLAG, _HELD, _PROV, _NUND = range(FF_NSTATE, FF_NSTATE + 6)
_RB_NPAR, _RB_NSTATE = FF_NPAR + 15, FF_NSTATE + 6


@kernel(inline="always")
def robust_compensate(par, st, w_ctrl, w_meas, w_ref):
    """Compensator protocol (``KIND`` 3): the feedforward of the estimate in use, faded in; 0 before switch-on.

    During the provisional start (:class:`FeedforwardStart`) the start map times the start gain, evaluated
    at the reference (start input ``reference``) or as ``ff_input`` says. The loop model (if any) advances
    every period, also before switch-on."""
    out = _robust_output(par, st, w_ctrl, w_ref)
    st[UOUT] = out
    return out


@kernel(inline="always")
def _robust_output(par, st, w_ctrl, w_ref):
    """The torque of :func:`robust_compensate` (N·m)."""
    w_stuck = loop_model_step(par, st, w_ctrl, w_ref)
    if st[HAS] == 0.0:
        signed_measurement(par, st, w_ctrl)  # the sign observer follows the joint before switch-on too
        return 0.0
    if st[_PROV] > 0.0:
        if par[_SREF] > 0.0:
            signed_measurement(par, st, w_ctrl)
            return ff_step(par, st, w_ref, w_ref, False) * par[_SGAIN]
        return ff_at(par, st, w_ctrl, w_stuck, w_ref) * par[_SGAIN]
    out = ff_at(par, st, w_ctrl, w_stuck, w_ref)
    if st[_GAIN] < 1.0:
        st[_GAIN] = min(st[_GAIN] + par[_FADE], 1.0)
        out = out * st[_GAIN]
    return out


@kernel
def _levels_plausible(par, eJ, etau, eFc, eFs, esig):
    """Range checks of an estimate (class Notes, item 5)."""
    ffmax = par[FFMAX]
    return (math.isfinite(eJ) and math.isfinite(etau) and math.isfinite(esig) and math.isfinite(eFc)
            and math.isfinite(eFs) and par[_JLO] < eJ < par[_JHI] and 0.0 <= etau <= par[_TAUMAX]
            and esig >= 0.0 and 0.0 <= eFc <= ffmax and 0.0 <= eFs <= ffmax)


@kernel
def robust_plausible(par, st, eJ, etau, eJalt, eFc, eFs, esig):
    """The plausibility test of an estimate against the estimator in ``(par, st)``: ranges and lag consistency."""
    if not _levels_plausible(par, eJ, etau, eFc, eFs, esig):
        return False
    ep = par[np.int64(par[_PO_EST]):]
    es = st[np.int64(par[_SO_EST]):]
    return _lag_consistent(par, sliding_rls(ep, es), eJ, etau, eJalt, sliding_mse(es), par[DT],
                           sliding_config(ep)[2])


@kernel
def _lag_consistent(par, rls, eJ, etau, eJalt, e2, dt, has_lag):
    """The two lag estimates (``tau`` and the ``J*tau`` column) agree (see RobustAdaptiveFeedforward Notes)."""
    if not (etau >= 2.0 * dt and math.isfinite(eJalt)):
        return True
    diff = abs(eJalt * etau - eJ * etau)
    if diff <= par[_CONSIST] * eJ * etau:
        return True
    if not has_lag:
        return False
    # delta method on theta_cov[:3, :3] = e2 * P[:3, :3] with the gradient (-tau, 1, -J)
    g0 = -etau
    g2 = -eJ
    v0 = g0 * (e2 * rls_P(rls, 0, 0)) + 1.0 * (e2 * rls_P(rls, 1, 0)) + g2 * (e2 * rls_P(rls, 2, 0))
    v1 = g0 * (e2 * rls_P(rls, 0, 1)) + 1.0 * (e2 * rls_P(rls, 1, 1)) + g2 * (e2 * rls_P(rls, 2, 1))
    v2 = g0 * (e2 * rls_P(rls, 0, 2)) + 1.0 * (e2 * rls_P(rls, 1, 2)) + g2 * (e2 * rls_P(rls, 2, 2))
    var = v0 * g0 + v1 * 1.0 + v2 * g2
    return diff <= 3.0 * math.sqrt(max(var, 0.0))


@kernel
def robust_observe(par, st, u, w_meas, theta_out):
    """Compensator protocol (``KIND`` 3): one sample into the estimator, then the plausibility tests and the
    estimate in use (see :class:`RobustAdaptiveFeedforward`). Returns True after an RLS update (theta written
    into ``theta_out``). The sign observer (if any) takes the applied torque first."""
    sign_observer_step(par, st, u)
    p = np.int64(par[_P])
    ep = par[np.int64(par[_PO_EST]):]
    es = st[np.int64(par[_SO_EST]):]
    sliding_observe(ep, es, u, w_meas)
    if not sliding_updated(es):
        return False
    rls = sliding_rls(ep, es)
    for i in range(p):
        theta_out[i] = rls_theta(rls, i)
    if rls_n_updates(rls) < par[_WARMUP]:
        return True
    eVs, edelta, lag = sliding_config(ep)
    eJ = rls_theta(rls, 0)
    if lag:
        etau = rls_theta(rls, 2)
        eJalt = rls_theta(rls, 1) / etau if etau > 0.0 else np.nan
        iFc = 3
    else:
        etau = 0.0
        eJalt = np.nan
        iFc = 1
    eFc = rls_theta(rls, iFc)
    eFs = rls_theta(rls, iFc + 1)
    esig = rls_theta(rls, iFc + 2)
    if not _levels_plausible(par, eJ, etau, eFc, eFs, esig):
        st[_NIMPL] += 1.0
        return True
    e2 = sliding_mse(es)
    if not math.sqrt(max(e2 * rls_P(rls, iFc, iFc), 0.0)) <= par[_RELSD] * max(eFc, eFs):
        st[_NUND] += 1.0  # Fc not determined yet (e.g. one direction of motion only: Fc and the offset agree)
        return True
    if _lag_consistent(par, rls, eJ, etau, eJalt, e2, par[DT], lag):
        st[_HELD] = 0.0
        if lag:  # the upper confidence bound of the lag, at most lag_margin_max*tau above it (class Notes)
            m = min(par[_LAGZ] * math.sqrt(max(e2 * rls_P(rls, 2, 2), 0.0)), par[_LAGCAP] * etau)
            etau = min(etau + m, par[_TAUMAX])
    elif st[HAS] > 0.0 and st[_PROV] == 0.0:
        st[_NLAG] += 1.0
        etau = st[TAU]
        st[_HELD] = 1.0
    else:
        st[_NIMPL] += 1.0
        return True
    if st[_PROV] > 0.0:  # hand-over from the provisional start: fade from the start gain to 1
        st[_PROV] = 0.0
        st[_GAIN] = par[_SGAIN]
    ff_set_estimate(par, st, eFc, eFs, eVs, edelta, esig, etau, 1.0)
    o = np.int64(par[_SO_FTH])
    for i in range(p):
        st[o + i] = rls_theta(rls, i)
    return True


@dataclass(frozen=True)
class FeedforwardStart:
    """Provisional start of :class:`RobustAdaptiveFeedforward`: a prior friction map in use from the first
    period until the estimator's first trusted estimate.

    Parameters
    ----------
    estimate : FrictionEstimate
        The prior map: ``Fc``, ``Fs`` (N·m), ``sigma`` (N·m·s/rad), ``Vs`` (rad/s) and ``delta`` of eq. 3 (e.g.
        the quasi-static Stribeck pre-fit, Sec. V-C), and the lag ``tau`` (s) its output is filtered
        through (eq. 1). ``Vs``/``delta`` None: the estimator's. ``J`` and ``offset`` are not used.
    gain : float
        Factor on the start map, in (0, 1], default 1. At the hand-over the output fades from ``gain`` to
        1 over the feedforward's ``fade_in``.
    ff_input : {"reference", "measured"}
        Velocity the start map is evaluated at: the reference (default) or as the feedforward's
        ``ff_input`` says. At the reference the start map is an exogenous input, not a feedback: a wrong
        lag or level cannot form a stick-slip cycle with the joint (a friction map fed back from the
        measured velocity through a lag shorter than the joint's kicks the joint by about ``2*Fs*dtau/J``
        at every reversal).

    Raises
    ------
    ParameterError
        ``gain`` outside (0, 1], unknown ``ff_input``, or a non-finite or negative level or lag.
    """

    estimate: FrictionEstimate
    gain: float = 1.0
    ff_input: str = "reference"

    def __post_init__(self):
        if not isinstance(self.estimate, FrictionEstimate):
            raise ParameterError(f"estimate must be a FrictionEstimate, got {type(self.estimate).__name__}")
        e = self.estimate
        for name in ("Fc", "Fs", "sigma", "tau"):
            v = getattr(e, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ParameterError(f"start estimate: {name} must be finite and >= 0, got {v!r}")
        if not (0.0 < self.gain <= 1.0):
            raise ParameterError(f"start gain must be in (0, 1], got {self.gain!r}")
        if self.ff_input not in ("reference", "measured"):
            raise ParameterError(f"start ff_input must be 'reference' or 'measured', got {self.ff_input!r}")


class RobustAdaptiveFeedforward(FrictionFeedforward):
    """Adaptive friction feedforward for a running machine: safe online estimation plus the lagged feedforward.

    Parameters
    ----------
    estimator : SlidingFrictionEstimator
        The online estimator (sliding-regime inverse-dynamics RLS with
        directional forgetting, parameter projection and an outlier gate);
        :meth:`observe` feeds it.
    dt : float, keyword-only
        Call period of :meth:`step` (s), normally the estimator's ``Tc``.
    lag : bool, keyword-only
        Filter the feedforward through the estimated lag ``tau`` (eq. 1);
        default True. Without the lag a static map at the measured velocity
        jumps by ``2*Fs`` at every reversal while the real friction takes
        ``tau`` to follow (measured: docs/benchmarks/compensation.md).
    ff_max : float, keyword-only
        Bound on |feedforward| (N·m); estimates with ``Fc`` or ``Fs`` above it
        are implausible. Default inf.
    sign_width : float, keyword-only
        Sign treatment near zero velocity, see :class:`FrictionFeedforward`.
    warmup : int, keyword-only
        RLS updates in the sliding regime before the feedforward is switched
        on (excitation gate), default 200 (2 s of sliding at Ts = 10 ms).
    fade_in : float, keyword-only
        After switch-on the output is ramped from 0 to full over this time
        (s), so that the PI integrator, which carried the friction so far,
        unloads smoothly (bumpless transfer); default 1 s, 0 = step.
    J_range : tuple of float, keyword-only
        Plausible inertia interval (kg·m²); an estimate outside it is not
        used. Default ``(0, inf)``.
    tau_max : float, keyword-only
        Largest plausible lag (s), default 1.
    consistency : float, keyword-only
        The lag is identified twice (``tau`` and ``J*tau``): the lag of an
        estimate whose two values differ by more than ``consistency*J*tau``
        and by more than three standard deviations (delta method on
        :attr:`SlidingFrictionEstimator.theta_cov`) is not used (for
        ``tau >= 2*dt``); default 0.5.
    lag_margin : float, keyword-only
        The lag in use is the estimated ``tau`` plus this many of its
        standard errors (``sqrt`` of the ``tau`` diagonal element of
        :attr:`SlidingFrictionEstimator.theta_cov`), at most
        ``lag_margin_max*tau`` more, clipped to ``tau_max``: a one-sided
        upper confidence bound (see Notes). Default 1; 0: the estimate
        itself.
    lag_margin_max : float, keyword-only
        Largest margin as a fraction of the estimated lag (inf: no cap),
        default 0.05: the cost of a lag error is lopsided only for small
        errors (a lag far too long under-compensates every reversal), and
        ``theta_cov`` of a weakly excited lag can exceed the lag itself.
    max_rel_stderr : float, keyword-only
        An estimate is used only once ``Fc`` is determined: its standard
        error (from :attr:`SlidingFrictionEstimator.theta_cov`) at most this
        fraction of ``max(Fc, Fs)``. Default 0.05; inf: no test.
    stick_band, stick_samples : keyword-only
        Stick detection, see :class:`FrictionFeedforward`.
    ff_input, w_max, loop_model, sign_observer : keyword-only
        See :class:`FrictionFeedforward`.
    start : FeedforwardStart or None, keyword-only
        Provisional start: the prior map acts from the first period (times its gain) until the first
        estimate that passes warm-up and the plausibility tests, then that estimate takes over and the
        output fades from the start gain to 1 over ``fade_in``. Default None: no feedforward before
        switch-on.

    Attributes
    ----------
    estimator : SlidingFrictionEstimator
    n_implausible : int
        Estimates (after warm-up) that failed the plausibility test; the
        feedforward kept the previous one.
    n_lag_held : int
        Estimates whose friction levels were used with the previous lag
        (the two lag estimates disagreed), see :meth:`observe`.
    n_undetermined : int
        Plausible estimates not used because ``Fc`` was not determined yet
        (``max_rel_stderr``).
    active : bool
        Whether the feedforward is switched on.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Safety chain: (1) samples with non-finite values or velocity outliers are
    rejected by the estimator and leave it unchanged; (2) rows outside the
    sliding regime are not used (excitation/validity gate); (3) the
    covariance bound (or directional forgetting) of the estimator's RLS keeps
    ``P`` bounded when the motion does not excite (windup protection);
    (4) ``theta`` is projected onto physical bounds after every update;
    (5) the estimate is used only after ``warmup`` updates and only if
    plausible (finite, ``J`` in ``J_range``, ``tau <= tau_max``,
    ``Fc, Fs <= ff_max``), determined (the standard error of ``Fc`` at most
    ``max_rel_stderr*max(Fc, Fs)``) and with consistent lag estimates,
    otherwise the last usable one is held (an inconsistent lag alone keeps
    the previous ``tau`` and takes the new friction levels); (6) the output
    fades in after switch-on and is clipped to ``±ff_max``.

    The determinacy test of (5) matters after motion in one direction only:
    there the Coulomb column ``sgn(w)`` equals the offset column, the RLS
    fits ``Fc + offset`` and not ``Fc``, and the map (which has no offset)
    would over-compensate the first motion in the other direction by the
    offset; the covariance says so (the standard error of ``Fc`` stays large
    until both directions are seen).

    The lag in use is an upper confidence bound, not the point estimate
    (a cautious rather than a certainty-equivalence use of the estimate:
    Åström & Wittenmark, *Adaptive Control*, 2nd ed., 1995, Ch. 7), because
    the two signs of a small lag error do not cost the same. A feedforward
    at the measured velocity through a lag shorter than the joint's reverses
    before the friction does and over-compensates at every reversal, which
    pushes the joint on in the new direction and is fed back through the
    measurement (over-compensation of friction drives the loop towards
    hunting: Armstrong-Hélouvry, Dupont & Canudas de Wit, *Automatica*
    30(7), 1994); a slightly longer lag under-compensates for a moment, a
    disturbance the PI removes. A lag far too long under-compensates every
    reversal and costs as well, hence ``lag_margin_max``. The measured cost
    of both signs is on docs/benchmarks/compensation.md.

    Which velocity the feedforward is evaluated at (reference or measured) is the caller's choice; measured on
    the ``paper`` preset the measured velocity is the better one (the joint
    lags the reference at reversals), see ``benchmarks/compensation.py`` and
    docs/benchmarks/compensation.md.
    """

    KIND = 3
    MODE = "adaptive"

    def __init__(self, estimator: SlidingFrictionEstimator, *, dt: float, lag: bool = True,
                 ff_max: float = math.inf, sign_width: float = 0.0, stick_band: float = 0.0, stick_samples: int = 10,
                 warmup: int = 200, fade_in: float = 1.0, J_range: tuple = (0.0, math.inf), tau_max: float = 1.0,
                 consistency: float = 0.5, lag_margin: float = 1.0, lag_margin_max: float = 0.05,
                 max_rel_stderr: float = 0.05,
                 ff_input: str = "measured", w_max: float = math.inf, start: FeedforwardStart | None = None,
                 loop_model: LoopModel | None = None, sign_observer: SignObserver | None = None):
        if not isinstance(estimator, SlidingFrictionEstimator):
            raise TypeError(f"estimator must be a SlidingFrictionEstimator, got {type(estimator).__name__}")
        ff = FrictionFeedforward(None, dt=dt, lag=lag, ff_max=ff_max, sign_width=sign_width,
                                 stick_band=stick_band, stick_samples=stick_samples, ff_input=ff_input, w_max=w_max,
                                 loop_model=loop_model, sign_observer=sign_observer)
        self.loop_model = loop_model
        self.sign_observer = sign_observer
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
            raise ParameterError(f"warmup must be an integer >= 0, got {warmup!r}")
        try:
            J_lo, J_hi = (float(x) for x in J_range)
        except (TypeError, ValueError):
            raise ParameterError(f"J_range must be a pair (low, high), got {J_range!r}") from None
        if not (0.0 <= J_lo < J_hi):
            raise ParameterError(f"J_range must satisfy 0 <= low < high, got {J_range!r}")
        tau_max = check_positive("tau_max", tau_max)
        consistency = check_positive("consistency", consistency)
        lag_margin = check_nonnegative("lag_margin", lag_margin)
        lag_margin_max = (math.inf if isinstance(lag_margin_max, (int, float)) and lag_margin_max == math.inf
                          else check_nonnegative("lag_margin_max", lag_margin_max))  # inf: no cap
        try:
            rel = math.nan if isinstance(max_rel_stderr, bool) else float(max_rel_stderr)
        except (TypeError, ValueError):
            rel = math.nan
        if not rel > 0.0:  # inf allowed: no determinacy test
            raise ParameterError(f"max_rel_stderr must be > 0 (inf: no test), got {max_rel_stderr!r}")
        max_rel_stderr = rel
        fade_in = check_nonnegative("fade_in", fade_in)
        self.estimator = estimator
        p = len(estimator.names)
        self.n_theta = p
        enp, ens = sliding_sizes(p)
        so_fth = _RB_NSTATE
        so_est = so_fth + p
        self.params = np.zeros(_RB_NPAR + enp)
        self.state = np.zeros(so_est + ens)
        self.params[:FF_NPAR] = ff.params
        self.state[:FF_NSTATE] = ff.state
        if start is not None and not isinstance(start, FeedforwardStart):
            raise ParameterError(f"start must be a FeedforwardStart or None, got {type(start).__name__}")
        self.params[FF_NPAR:_RB_NPAR] = (float(warmup), 1.0 if fade_in == 0.0 else dt / fade_in, J_lo, J_hi,
                                         tau_max, consistency, float(p), float(_RB_NPAR), float(so_fth),
                                         float(so_est), 1.0 if start is None else start.gain,
                                         float(start is not None and start.ff_input == "reference"), lag_margin,
                                         max_rel_stderr, lag_margin_max)
        self.state[so_fth:so_est] = np.nan
        self.estimate = None
        self.start = start
        if start is not None:
            e = start.estimate
            ff_set_estimate(self.params, self.state, e.Fc, e.Fs, estimator.Vs if e.Vs is None else e.Vs,
                            estimator.delta if e.delta is None else e.delta, e.sigma, e.tau, 1.0)
            self.state[_PROV] = 1.0
            self.state[_GAIN] = 1.0
        self._attached()

    def _attached(self) -> None:
        po, so = int(self.params[_PO_EST]), int(self.params[_SO_EST])
        self.estimator.attach(self.params[po:], self.state[so:])

    warmup = property(lambda self: int(self.params[_WARMUP]), doc="RLS updates before switch-on.")
    J_range = property(lambda self: (float(self.params[_JLO]), float(self.params[_JHI])),
                       doc="Plausible inertia interval (kg·m²).")
    tau_max = property(lambda self: float(self.params[_TAUMAX]), doc="Largest plausible lag (s).")
    consistency = property(lambda self: float(self.params[_CONSIST]), doc="Relative lag-consistency tolerance.")
    n_implausible = property(lambda self: int(self.state[_NIMPL]), doc="Estimates that failed the plausibility test.")
    n_lag_held = property(lambda self: int(self.state[_NLAG]), doc="Estimates used with the previous lag.")
    n_undetermined = property(lambda self: int(self.state[_NUND]),
                              doc="Plausible estimates not used because ``Fc`` was not determined yet.")
    lag_margin = property(lambda self: float(self.params[_LAGZ]),
                          doc="Standard errors added to the estimated lag in use.")
    lag_margin_max = property(lambda self: float(self.params[_LAGCAP]),
                              doc="Largest lag margin, as a fraction of the estimated lag.")
    max_rel_stderr = property(lambda self: float(self.params[_RELSD]),
                              doc="Largest standard error of ``Fc`` in use, relative to ``max(Fc, Fs)``.")

    provisional = property(lambda self: bool(self.state[_PROV]),
                           doc="Whether the provisional start map (``start``) is in use.")

    @property
    def estimate(self) -> FrictionEstimate | None:
        """The estimator's estimate in use (None before switch-on and during the provisional start), with the lag
        in use: the estimated lag plus ``lag_margin`` standard errors, or the previous lag where the lag estimates
        disagreed (then ``J_alt`` is NaN)."""
        if not self.state[HAS] or self.state[_PROV]:
            return None
        o = int(self.params[_SO_FTH])
        e = estimate_from_theta(self.estimator.names, self.state[o:o + self.n_theta], self.estimator.Vs,
                                self.estimator.delta)
        return replace(e, tau=float(self.state[TAU]), J_alt=float("nan") if self.state[_HELD] else e.J_alt)

    @estimate.setter
    def estimate(self, value) -> None:
        if value is not None:
            raise ParameterError("the estimate of a RobustAdaptiveFeedforward is set by its estimator only")

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m), 0 before switch-on.

        See :meth:`FrictionFeedforward.step`; after switch-on the output fades in over ``fade_in``. During the
        provisional start the start map times its gain, at ``w_ref`` (when given) for a start at the reference.
        """
        if not self.state[HAS]:
            return 0.0
        if self.state[_PROV]:  # the start map, at the reference when the start says so (as in compensate)
            if self.params[_SREF] and w_ref is not None:
                return FrictionFeedforward.step(self, w_ref) * float(self.params[_SGAIN])
            return FrictionFeedforward.step(self, w, w_ref) * float(self.params[_SGAIN])
        out = FrictionFeedforward.step(self, w, w_ref)
        if self.state[_GAIN] < 1.0:
            self.state[_GAIN] = min(self.state[_GAIN] + self.params[_FADE], 1.0)
            return out * float(self.state[_GAIN])
        return out

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensator protocol: the faded-in feedforward for this period (N·m), see :func:`robust_compensate`."""
        return float(robust_compensate(self.params, self.state, float(w_meas), float(w_meas), float(w_ref)))

    def plausible(self, est: FrictionEstimate) -> bool:
        """The plausibility test of the class Notes, item (5): range checks and lag consistency."""
        return bool(robust_plausible(self.params, self.state, est.J, est.tau, est.J_alt, est.Fc, est.Fs,
                                     est.sigma))

    @property
    def active(self) -> bool:
        """True once the feedforward acts: a plausible estimate, or the provisional start map, is in use."""
        return bool(self.state[HAS])

    @property
    def theta(self) -> np.ndarray:
        """The estimator's current parameter vector."""
        return self.estimator.theta

    @property
    def n_rejected(self) -> int:
        """Samples rejected by the estimator (non-finite or outliers)."""
        return self.estimator.n_rejected

    def info(self) -> dict:
        """Counters and settings of the estimator and the plausibility tests (for run reports)."""
        e = self.estimator
        return {"estimator": "sliding", "n_rejected": e.n_rejected, "n_implausible": self.n_implausible,
                "n_undetermined": self.n_undetermined, "n_lag_held": self.n_lag_held, "n_updates": e.n_updates,
                "n_gated": e.n_gated,
                "n_projected": e.rls.n_projected, "lam": e.rls.lam, "names": list(e.names),
                "raw_estimate": e.estimate.to_dict(), "noise_estimate": e.noise_std}

    def observe(self, u: float, w: float) -> bool:
        """Feed one controller-period sample to the estimator; refresh the estimate in use.

        Parameters
        ----------
        u : float
            Torque applied in this period (N·m).
        w : float
            Measured velocity (rad/s).

        Returns
        -------
        bool
            False if the sample was rejected (state unchanged, counted).

        Notes
        -----
        An estimate that passes the range checks but whose two lag estimates
        disagree updates the friction levels (``Fc, Fs, sigma``) and keeps the
        lag ``tau`` in use (counted in ``n_lag_held``); one that fails the range
        checks is not used at all (``n_implausible``).
        """
        n_rej = self.estimator.n_rejected
        robust_observe(self.params, self.state, float(u), float(w), self._theta_scratch())
        return self.estimator.n_rejected == n_rej

    def _theta_scratch(self) -> np.ndarray:
        t = getattr(self, "_scratch", None)
        if t is None:
            t = self._scratch = np.empty(self.n_theta)
        return t
