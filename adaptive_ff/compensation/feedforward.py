"""Friction feedforward: fixed (from an offline estimate) and adaptive (online RLS, the paper's future work).

Three classes: :class:`FrictionFeedforward` (a fixed estimate through the
estimated lag), :class:`AdaptiveFrictionFeedforward` (the paper's eq. 4 RLS at
Ts, the first prototype, kept as a baseline) and
:class:`RobustAdaptiveFeedforward` (the recommended one: sliding-regime
inverse-dynamics RLS with directional forgetting, projection, outlier and
plausibility gates, see :mod:`adaptive_ff.compensation.sliding_estimator`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator
from plant.errors import ParameterError, check_nonnegative, check_positive

__all__ = ["FrictionFeedforward", "AdaptiveFrictionFeedforward", "RobustAdaptiveFeedforward", "project_estimate"]


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
    vals = (est.J, est.tau, est.sigma, est.Fc, est.Fs, est.offset)
    if not all(math.isfinite(v) for v in vals) or est.J <= 0 or est.Fc > F_max or est.Fs > F_max:
        return None
    return FrictionEstimate(J=est.J, tau=min(max(est.tau, 0.0), tau_max), sigma=max(est.sigma, 0.0),
                            Fc=max(est.Fc, 0.0), Fs=max(est.Fs, 0.0), offset=est.offset, Vs=est.Vs,
                            delta=est.delta, J_alt=est.J_alt)


class FrictionFeedforward:
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

    Raises
    ------
    ParameterError
        ``dt <= 0``, ``ff_max < 0``, ``sign_width < 0``, ``stick_band < 0`` or ``stick_samples < 1``.

    Notes
    -----
    ``u_ff`` follows ``tau*du_ff/dt + u_ff = F_hat(w)`` (eq. 1 with the estimate),
    discretised exactly for a held input: ``u_ff += (1 - exp(-dt/tau))*(F_hat(w) - u_ff)``.
    The constant ``offset`` of the estimate is not fed forward (it is a sensor
    or drive bias, not friction; the PI integrator removes it).
    """

    def __init__(self, estimate: FrictionEstimate | None, *, dt: float, lag: bool = True,
                 ff_max: float = math.inf, sign_width: float = 0.0, stick_band: float = 0.0,
                 stick_samples: int = 10):
        self.dt = check_positive("dt", dt)
        self.ff_max = float(ff_max) if ff_max == math.inf else check_nonnegative("ff_max", ff_max)
        self.lag = bool(lag)
        self.sign_width = check_nonnegative("sign_width", sign_width)
        self.stick_band = check_nonnegative("stick_band", stick_band)
        if isinstance(stick_samples, bool) or not isinstance(stick_samples, (int, np.integer)) or stick_samples < 1:
            raise ParameterError(f"stick_samples must be an integer >= 1, got {stick_samples!r}")
        self.stick_samples = int(stick_samples)
        self._n_in_band = 0
        self.u_ff = 0.0
        self._set(estimate)

    def _set(self, est: FrictionEstimate | None) -> None:
        self.estimate = est
        if est is None:
            self._alpha = 1.0
            return
        self._alpha = 1.0 - math.exp(-self.dt / est.tau) if (self.lag and est.tau > 0) else 1.0
        self._Fc, self._dF, self._sigma = est.Fc, est.Fs - est.Fc, est.sigma
        self._Vs, self._delta = est.Vs, est.delta

    def static(self, w: float) -> float:
        """Static friction estimate ``F_hat(w)`` (N·m), eq. 3 with the estimate (no offset)."""
        est = self.estimate
        if est is None or w == 0.0:
            return 0.0
        aw = abs(w)
        if self._Vs is None:
            mag = self._Fc
        else:
            mag = self._Fc + self._dF * math.exp(-((aw / self._Vs) ** self._delta))
        sw = self.sign_width
        if sw > 0.0 and aw < sw:
            return mag * (w / sw) + self._sigma * w
        return math.copysign(mag, w) + self._sigma * w

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m).

        Parameters
        ----------
        w : float
            Velocity the friction map is evaluated at (rad/s), e.g. the measurement.
        w_ref : float, optional
            Used instead of ``w`` while the joint is detected as stuck (see
            ``stick_band``), e.g. the reference velocity.
        """
        if w_ref is not None:
            if -self.stick_band < w < self.stick_band:
                self._n_in_band += 1
                if self._n_in_band >= self.stick_samples:
                    w = w_ref
            else:
                self._n_in_band = 0
        self.u_ff += self._alpha * (self.static(w) - self.u_ff)
        return min(max(self.u_ff, -self.ff_max), self.ff_max)


class AdaptiveFrictionFeedforward(FrictionFeedforward):
    """Adaptive friction feedforward: RLS (eqs. 10-13) on the sampled (u, w) stream drives the feedforward.

    Parameters
    ----------
    model : RegressionModel
        Regression structure, with Vs, delta from the pre-fit (Sec. V-C).
    Ts : float, keyword-only
        Sample time of the (u, w) stream fed to :meth:`observe` (s).
    dt : float, keyword-only
        Call period of :meth:`step` (s).
    lam : float, keyword-only
        RLS forgetting factor in (0, 1]; default 0.995 (memory ``Ts/(1-lam)``,
        2 s at Ts = 10 ms). The paper's 0.85 suits offline replay of noisy data,
        not a loop that must hold its estimate through slow phases.
    P0 : float, keyword-only
        Initial RLS covariance scale, default 1e4.
    warmup : int, keyword-only
        Accepted samples before the feedforward is switched on, default 300
        (the paper's RLS transient lasts about 4 s).
    lag, ff_max : see :class:`FrictionFeedforward`; estimates with ``Fc`` or
        ``Fs`` above ``ff_max`` are treated as implausible.
    tau_max : float, keyword-only
        Upper projection bound of ``tau`` (s), default 1.

    Attributes
    ----------
    rls : RecursiveLeastSquares
        The estimator (public ``theta``, ``P``).
    n_rejected : int
        Samples refused (non-finite ``u`` or ``w``); they leave the state unchanged.
    n_implausible : int
        RLS updates whose estimate could not be projected (held the previous one).

    Raises
    ------
    ParameterError
        Invalid hyperparameters (message quotes the value).

    Notes
    -----
    At each sample ``k``: ``phi(k)`` from eq. 4 with the stored ``u(k-1)``,
    ``w(k-1)``, ``w(k-2)``; RLS update; ``theta`` mapped to physical
    parameters (inverse map in :mod:`adaptive_ff.identification.regression`), projected by
    :func:`project_estimate`; the feedforward uses the last admissible estimate.
    """

    def __init__(self, model: RegressionModel, *, Ts: float, dt: float, lam: float = 0.995, P0: float = 1e4,
                 warmup: int = 300, lag: bool = True, ff_max: float = math.inf, tau_max: float = 1.0):
        super().__init__(None, dt=dt, lag=lag, ff_max=ff_max)
        self.model = model
        self.Ts = check_positive("Ts", Ts)
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
            raise ParameterError(f"warmup must be an integer >= 0, got {warmup!r}")
        self.warmup = int(warmup)
        self.tau_max = check_positive("tau_max", tau_max)
        self.rls = RecursiveLeastSquares(model.n_params, lam=lam, P0=P0)
        self._past: list[float] | None = None  # [u(k-1), w(k-1), w(k-2)]
        self.n_rejected = 0
        self.n_implausible = 0

    @property
    def theta(self) -> np.ndarray:
        """Current RLS parameter vector, shape (p,)."""
        return self.rls.theta

    def observe(self, u: float, w: float) -> bool:
        """Feed one sample ``(u(k), w(k))`` taken ``Ts`` after the previous one.

        Parameters
        ----------
        u : float
            Torque applied just before the sample (N·m).
        w : float
            Measured velocity (rad/s).

        Returns
        -------
        bool
            True if the sample was used, False if rejected (non-finite); a
            rejected sample changes no state except ``n_rejected``.
        """
        u = float(u)
        w = float(w)
        if not (math.isfinite(u) and math.isfinite(w)):
            self.n_rejected += 1
            return False
        past = self._past
        if past is None:
            self._past = [u, w, w]
            return True
        u1, w1, w2 = past
        self.rls.update(self.model.phi(u, u1, w1, w2), w)
        self._past = [u, w, w1]
        if self.rls.n_updates >= self.warmup:
            est = project_estimate(self.model.to_physical(self.rls.theta, self.Ts), tau_max=self.tau_max,
                                   F_max=self.ff_max)
            if est is None:
                self.n_implausible += 1
            else:
                self._set(est)
        return True


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
        default True. Measured on the ``paper`` preset with the true
        parameters at the measured velocity: eta 0.99 with the lag, -0.37
        without (a static map jumps by ``2*Fs`` at every reversal while the
        real friction takes ``tau`` to follow).
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
    stick_band, stick_samples : keyword-only
        Stick detection, see :class:`FrictionFeedforward`.

    Attributes
    ----------
    estimator : SlidingFrictionEstimator
    n_implausible : int
        Estimates (after warm-up) that failed the plausibility test; the
        feedforward kept the previous one.
    n_lag_held : int
        Estimates whose friction levels were used with the previous lag
        (the two lag estimates disagreed), see :meth:`observe`.
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
    ``Fc, Fs <= ff_max``, the two lag estimates consistent), otherwise the
    last plausible one is held (an inconsistent lag alone keeps the previous
    ``tau`` and takes the new friction levels); (6) the output fades in after
    switch-on and is clipped to ``±ff_max``. Which velocity the feedforward is
    evaluated at (reference or measured) is the caller's choice; measured on
    the ``paper`` preset the measured velocity is the better one (the joint
    lags the reference at reversals; 0.993 against 0.712, 10 seeds), see
    ``benchmarks/compensation.py``.
    """

    def __init__(self, estimator: SlidingFrictionEstimator, *, dt: float, lag: bool = True,
                 ff_max: float = math.inf, sign_width: float = 0.0, stick_band: float = 0.0, stick_samples: int = 10,
                 warmup: int = 200, fade_in: float = 1.0, J_range: tuple = (0.0, math.inf), tau_max: float = 1.0,
                 consistency: float = 0.5):
        super().__init__(None, dt=dt, lag=lag, ff_max=ff_max, sign_width=sign_width, stick_band=stick_band,
                         stick_samples=stick_samples)
        if not isinstance(estimator, SlidingFrictionEstimator):
            raise TypeError(f"estimator must be a SlidingFrictionEstimator, got {type(estimator).__name__}")
        self.estimator = estimator
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
            raise ParameterError(f"warmup must be an integer >= 0, got {warmup!r}")
        self.warmup = int(warmup)
        try:
            J_lo, J_hi = (float(x) for x in J_range)
        except (TypeError, ValueError):
            raise ParameterError(f"J_range must be a pair (low, high), got {J_range!r}") from None
        if not (0.0 <= J_lo < J_hi):
            raise ParameterError(f"J_range must satisfy 0 <= low < high, got {J_range!r}")
        self.J_range = (J_lo, J_hi)
        self.tau_max = check_positive("tau_max", tau_max)
        self.consistency = check_positive("consistency", consistency)
        fade_in = check_nonnegative("fade_in", fade_in)
        self._fade_step = 1.0 if fade_in == 0.0 else self.dt / fade_in
        self._gain = 0.0
        self.n_implausible = 0
        self.n_lag_held = 0

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m), 0 before switch-on.

        See :meth:`FrictionFeedforward.step`; after switch-on the output fades in over ``fade_in``.
        """
        if self.estimate is None:
            return 0.0
        out = FrictionFeedforward.step(self, w, w_ref)
        if self._gain < 1.0:
            self._gain = min(self._gain + self._fade_step, 1.0)
            return out * self._gain
        return out

    @property
    def active(self) -> bool:
        """True once a plausible estimate is in use."""
        return self.estimate is not None

    @property
    def theta(self) -> np.ndarray:
        """The estimator's current parameter vector."""
        return self.estimator.theta

    @property
    def n_rejected(self) -> int:
        """Samples rejected by the estimator (non-finite or outliers)."""
        return self.estimator.n_rejected

    def plausible(self, est: FrictionEstimate) -> bool:
        """The plausibility test of the class Notes, item (5): range checks and lag consistency."""
        return self._levels_plausible(est) and self._lag_consistent(est)

    def _levels_plausible(self, est: FrictionEstimate) -> bool:
        vals = (est.J, est.tau, est.sigma, est.Fc, est.Fs)
        return (all(math.isfinite(v) for v in vals) and self.J_range[0] < est.J < self.J_range[1]
                and 0.0 <= est.tau <= self.tau_max and est.sigma >= 0.0 and 0.0 <= est.Fc <= self.ff_max
                and 0.0 <= est.Fs <= self.ff_max)

    def _lag_consistent(self, est: FrictionEstimate) -> bool:
        # The lag is identified twice, as tau and inside J*tau. They must agree within the larger of a
        # relative tolerance and 3 standard deviations of J*tau - J*tau_hat (delta method on the estimator's
        # covariance): a weakly excited J*tau column widens the test instead of vetoing every estimate.
        if not (est.tau >= 2.0 * self.dt and math.isfinite(est.J_alt)):
            return True
        diff = abs(est.J_alt * est.tau - est.J * est.tau)  # |J*tau (column) - J*tau (product)|
        if diff <= self.consistency * est.J * est.tau:
            return True
        e = self.estimator
        if e.lag and e.names[:3] == ("J", "J_tau", "tau"):
            g = np.array([-est.tau, 1.0, -est.J])
            var = float(g @ e.theta_cov[:3, :3] @ g)
            return diff <= 3.0 * math.sqrt(max(var, 0.0))
        return False

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
        ok = self.estimator.observe(u, w)
        if self.estimator.updated and self.estimator.n_updates >= self.warmup:
            est = self.estimator.estimate
            if not self._levels_plausible(est):
                self.n_implausible += 1
            elif self._lag_consistent(est):
                self._set(est)
            elif self.estimate is not None:
                self.n_lag_held += 1
                self._set(replace(est, tau=self.estimate.tau, J_alt=float("nan")))
            else:
                self.n_implausible += 1
        return ok
