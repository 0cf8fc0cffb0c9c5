"""Friction feedforward: fixed (from an offline estimate) and adaptive (online RLS, the paper's future work)."""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.regression import FrictionEstimate, RegressionModel
from adaptive_ff.rls import RecursiveLeastSquares
from plant.errors import ParameterError, check_finite_scalar, check_nonnegative, check_positive

__all__ = ["FrictionFeedforward", "AdaptiveFrictionFeedforward", "project_estimate"]


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

    Raises
    ------
    ParameterError
        ``dt <= 0`` or ``ff_max < 0``.

    Notes
    -----
    ``u_ff`` follows ``tau*du_ff/dt + u_ff = F_hat(w)`` (eq. 1 with the estimate),
    discretised exactly for a held input: ``u_ff += (1 - exp(-dt/tau))*(F_hat(w) - u_ff)``.
    The constant ``offset`` of the estimate is not fed forward (it is a sensor
    or drive bias, not friction).
    """

    def __init__(self, estimate: FrictionEstimate | None, *, dt: float, lag: bool = True,
                 ff_max: float = math.inf):
        self.dt = check_positive("dt", dt)
        self.ff_max = float(ff_max) if ff_max == math.inf else check_nonnegative("ff_max", ff_max)
        self.lag = bool(lag)
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
        return math.copysign(mag, w) + self._sigma * w

    def step(self, w: float) -> float:
        """Advance one period with velocity ``w`` (rad/s); return the bounded feedforward (N·m)."""
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
    parameters (inverse map in :mod:`adaptive_ff.regression`), projected by
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
