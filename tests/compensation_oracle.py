"""Test oracle: the pure-Python compensation components as they were before the compiled components (issue 10).

OutlierGate, SlidingFrictionEstimator and RobustAdaptiveFeedforward (on tests/peers_oracle.py's
FrictionFeedforward), verbatim from the
package before the refactor (their RLS is the package's RecursiveLeastSquares, tested on its own against
tests/rls_oracle.py). tests/loop_oracle.py composes them into the former Python closed loop.
"""

import math
from dataclasses import replace

import numpy as np

from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.identification.rls import RecursiveLeastSquares
from peers_oracle import FrictionFeedforward, Range, rls_try  # one copy of the oracle
from plant.errors import ParameterError, check_finite_scalar, check_multiple, check_nonnegative, check_positive

_NOISE_GAIN = math.sqrt(6.0) * math.sqrt(2.0 / math.pi)
_BAND_SIGMAS = 4.0
SLIDING_NAMES = ("J", "J_tau", "tau", "Fc", "Fs", "sigma", "offset")


class OutlierGate:
    """Reject non-finite samples and outlier spikes of a sampled signal (e.g. the measured velocity).

    Parameters
    ----------
    max_step : float, keyword-only
        Largest physically possible change between two consecutive samples, in
        the signal's unit (for a velocity: peak acceleration times the sample
        period, rad/s), >= 0. Default ``inf``: only non-finite samples are rejected.
    n_sigma : float, keyword-only
        Width of the noise allowance in units of the running mean absolute
        sample-to-sample change, > 0; default 8.
    alpha : float, keyword-only
        Smoothing factor of that running mean, in (0, 1]; default 0.01.
    max_consecutive : int, keyword-only
        After this many consecutive outlier rejections the next finite sample
        is accepted again (the signal really moved, e.g. after a re-start);
        default 20.

    Attributes
    ----------
    last : float or None
        Last accepted value.
    scale : float
        Running mean of ``|x(k) - x(k-1)|`` over accepted samples.
    n_rejected, n_nonfinite, n_outliers : int
        Rejections in total, of them non-finite and outlier spikes.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    A finite sample ``x`` is an outlier if
    ``|x - last| > (max_step + n_sigma*scale) * (1 + n_held)`` with ``n_held``
    the number of samples rejected since ``last`` (the bound grows with the
    time since the last accepted sample). This is a validation gate on the
    innovation (the "gating" of target tracking: Bar-Shalom, Li,
    Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
    Wiley 2001) with the innovation predicted by the last accepted sample, a
    physical bound on its size and a running noise scale (updated only by
    accepted samples, so a burst of spikes cannot widen the gate).
    """

    __slots__ = ("max_step", "n_sigma", "alpha", "max_consecutive", "last", "scale", "n_held",
                 "n_rejected", "n_nonfinite", "n_outliers")

    def __init__(self, *, max_step: float = math.inf, n_sigma: float = 8.0, alpha: float = 0.01,
                 max_consecutive: int = 20):
        if max_step != math.inf:
            max_step = check_nonnegative("max_step", max_step)
        self.max_step = float(max_step)
        self.n_sigma = check_positive("n_sigma", n_sigma)
        alpha = check_positive("alpha", alpha)
        if alpha > 1.0:
            raise ParameterError(f"alpha must be in (0, 1], got {alpha!r}")
        self.alpha = alpha
        if isinstance(max_consecutive, bool) or not isinstance(max_consecutive, int) or max_consecutive < 1:
            raise ParameterError(f"max_consecutive must be an integer >= 1, got {max_consecutive!r}")
        self.max_consecutive = max_consecutive
        self.last: float | None = None
        self.scale = 0.0
        self.n_held = 0
        self.n_rejected = 0
        self.n_nonfinite = 0
        self.n_outliers = 0

    def __repr__(self) -> str:
        return (f"OutlierGate(max_step={self.max_step!r}, n_sigma={self.n_sigma!r}, "
                f"n_rejected={self.n_rejected})")

    def check(self, x: float) -> bool:
        """Return True and accept ``x`` if it is plausible; False (counted) if it is rejected.

        Parameters
        ----------
        x : float
            The new sample.

        Returns
        -------
        bool
            Acceptance. A rejected sample changes only the counters.
        """
        x = float(x)
        if not math.isfinite(x):
            self.n_rejected += 1
            self.n_nonfinite += 1
            self.n_held += 1
            return False
        last = self.last
        if last is None:
            self.last = x
            return True
        d = x - last if x >= last else last - x
        bound = (self.max_step + self.n_sigma * self.scale) * (1 + self.n_held)
        if d > bound:
            if self.n_held < self.max_consecutive:
                self.n_rejected += 1
                self.n_outliers += 1
                self.n_held += 1
                return False
        else:
            self.scale += self.alpha * (d - self.scale)
        self.last = x
        self.n_held = 0
        return True


def _names(lag: bool, offset: bool) -> tuple:
    return tuple(n for n in SLIDING_NAMES if (lag or n not in ("J_tau", "tau")) and (offset or n != "offset"))


def _check_int(name, v, lo):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")
    return int(v)


def _to_estimate(names, theta, Vs, delta) -> FrictionEstimate:
    d = dict(zip(names, (float(x) for x in theta)))
    tau = d.get("tau", 0.0)
    J_alt = d["J_tau"] / tau if ("J_tau" in d and tau > 0) else float("nan")
    return FrictionEstimate(J=d["J"], tau=tau, sigma=d["sigma"], Fc=d["Fc"], Fs=d["Fs"], offset=d.get("offset", 0.0),
                            Vs=Vs, delta=delta, J_alt=J_alt)


class SlidingFrictionEstimator:
    """Online estimate of ``J, tau, Fc, Fs, sigma`` (and a torque offset) from the controller's ``(u, w)`` stream.

    Parameters
    ----------
    Vs, delta : float
        Stribeck velocity (rad/s) and shape factor, pre-estimated (Sec. V-C).
    Tc : float, keyword-only
        Period (s) at which :meth:`observe` is called (the controller period).
    Ts : float, keyword-only
        Period of the RLS updates (s), a multiple of ``Tc``; default 10 ms
        (the filtered signals have a bandwidth of a few Hz, so faster updates
        add cost, not information).
    T_filter : float, keyword-only
        Time constant ``T`` of each of the three filter stages (s); default 20 ms
        (about 8 Hz bandwidth for ``L``).
    lam : float or array_like, keyword-only
        Forgetting factor per RLS update, in (0, 1] (an array: one per
        parameter); default 0.995 (memory ``Ts/(1 - lam)`` = 2 s of sliding
        data at Ts = 10 ms). Measured in the drift benchmark (+50 % over
        60 s): eta 0.985 at 0.995, 0.731 at 0.999.
    forgetting : {"exponential", "directional"}, keyword-only
        RLS forgetting scheme (:class:`adaptive_ff.identification.rls.RecursiveLeastSquares`).
    P0 : float, keyword-only
        Initial covariance scale, default 1e4.
    P_max : float, keyword-only
        Covariance bound ``trace(P) <= P_max`` (windup protection, see
        :class:`adaptive_ff.identification.rls.RecursiveLeastSquares`); default ``trace(P0)``.
    initial : FrictionEstimate, keyword-only
        Starting point (e.g. the Stribeck pre-fit's Fc, Fs, sigma and the
        design inertia); default: ``J = J_guess``, all friction 0.
    J_guess : float, keyword-only
        Inertia (kg·m²) used when ``initial`` is None, default 1.
    J_max, tau_max : float, keyword-only
        Upper projection bounds of ``J`` (kg·m²) and ``tau`` (s); defaults inf, 1.
    lag : bool, keyword-only
        Estimate the friction lag (columns ``L[s^2 w]``, ``-L[s u]``), default True.
    offset : bool, keyword-only
        Estimate a constant torque offset (captures e.g. the mean of
        direction-dependent Coulomb levels), default True.
    w_band_min : float, keyword-only
        Smallest near-zero band (rad/s); default ``0.1*Vs``.
    dwell_max : float, keyword-only
        Largest admissible filtered near-zero indicator of a row, in [0, 1];
        default 0.01; 1 switches the sliding-regime gate off.
    gate : OutlierGate, keyword-only
        Plausibility gate of the velocity samples; default: non-finite only.

    Attributes
    ----------
    rls : RecursiveLeastSquares
        The estimator, with ``theta`` in :attr:`names` order and projection
        bounds ``J in [1e-9, J_max]``, ``tau in [0, tau_max]``, ``J*tau in [0,
        J_max*tau_max]``, ``Fc, Fs, sigma >= 0``.
    names : tuple of str
        Parameter names (a subset of :data:`SLIDING_NAMES`).
    n_samples, n_rejected, n_gated : int
        Samples accepted, rejected (non-finite ``u`` or ``w``, velocity
        outliers: they leave the estimator unchanged) and update instants
        skipped by the sliding-regime gate.
    updated : bool
        Whether the last :meth:`observe` call updated the RLS.
    noise_std : float
        Current estimate of the velocity noise (rad/s).

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    See the module docstring for the model, the filters and the gate.
    """

    def __init__(self, Vs: float, delta: float, *, Tc: float, Ts: float = 0.01, T_filter: float = 0.02,
                 lam: float = 0.995, forgetting: str = "exponential", P0: float = 1e4, P_max: float | None = None,
                 initial: FrictionEstimate | None = None, J_guess: float = 1.0, J_max: float = math.inf,
                 tau_max: float = 1.0, lag: bool = True, offset: bool = True, w_band_min: float | None = None,
                 dwell_max: float = 0.01, gate: OutlierGate | None = None):
        self.Vs = check_positive("Vs", Vs)
        self.delta = check_finite_scalar("delta", delta)
        if self.delta == 0.0:
            raise ParameterError("delta must be non-zero, got 0.0")
        self.Tc = check_positive("Tc", Tc)
        self.m = check_multiple("Ts", Ts, "Tc", self.Tc)
        self.Ts = self.m * self.Tc
        self.T = check_positive("T_filter", T_filter)
        if self.T < 2 * self.Tc:
            raise ParameterError(f"T_filter must be >= 2*Tc = {2 * self.Tc!r} s, got {T_filter!r}")
        self.lag = bool(lag)
        self.offset = bool(offset)
        self.names = _names(self.lag, self.offset)
        self.w_band_min = 0.1 * self.Vs if w_band_min is None else check_positive("w_band_min", w_band_min)
        dwell_max = check_finite_scalar("dwell_max", dwell_max)
        if not 0.0 <= dwell_max <= 1.0:
            raise ParameterError(f"dwell_max must be in [0, 1], got {dwell_max!r}")
        self.dwell_max = dwell_max
        J_max = math.inf if J_max == math.inf else check_positive("J_max", J_max)
        self.tau_max = check_positive("tau_max", tau_max)
        lower = {"J": 1e-9, "J_tau": 0.0, "tau": 0.0, "Fc": 0.0, "Fs": 0.0, "sigma": 0.0, "offset": -math.inf}
        upper = {"J": J_max, "J_tau": J_max * self.tau_max, "tau": self.tau_max, "Fc": math.inf, "Fs": math.inf,
                 "sigma": math.inf, "offset": math.inf}
        if initial is None:
            J0 = check_positive("J_guess", J_guess)
            start = {"J": J0, "J_tau": 0.0, "tau": 0.0, "Fc": 0.0, "Fs": 0.0, "sigma": 0.0, "offset": 0.0}
        else:
            tau0 = min(max(initial.tau, 0.0), self.tau_max) if self.lag else 0.0
            J0 = min(max(initial.J, 1e-9), J_max)
            start = {"J": J0, "J_tau": J0 * tau0, "tau": tau0, "Fc": max(initial.Fc, 0.0),
                     "Fs": max(initial.Fs, 0.0), "sigma": max(initial.sigma, 0.0), "offset": initial.offset}
            if not all(math.isfinite(v) for v in start.values()):
                raise ParameterError(f"initial estimate must be finite, got {initial!r}")
        P0 = check_positive("P0", P0)
        self.rls = RecursiveLeastSquares(len(self.names), lam=lam, P0=P0, forgetting=forgetting,
                                         P_max=len(self.names) * P0 if P_max is None else P_max,
                                         theta0=[start[n] for n in self.names],
                                         bounds=([lower[n] for n in self.names], [upper[n] for n in self.names]))
        self.gate = OutlierGate() if gate is None else gate
        self.u_range, self.w_range = Range(), Range(floor=self.Vs)  # issue 12
        self._a = 1.0 - math.exp(-self.Tc / self.T)
        self._settle = int(math.ceil(8.0 * self.T / self.Tc))  # filter transients (Erlang-3 tail < 1.5 %)
        self._s = [0.0] * 15  # three filter states for each of w, u, g, h, d
        self._w1 = self._w2 = None
        self._d2 = 0.0
        self._e2 = 0.0
        lam_min = float(np.min(self.rls.lam))
        self._e2_rate = 1.0 - lam_min if lam_min < 1.0 else 0.01  # running mean square error, same memory
        self.n_samples = 0
        self.n_rejected = 0
        self.n_gated = 0
        self.updated = False

    def __repr__(self) -> str:
        return (f"SlidingFrictionEstimator(Vs={self.Vs!r}, delta={self.delta!r}, Ts={self.Ts!r}, "
                f"T_filter={self.T!r}, n_updates={self.rls.n_updates})")

    @property
    def theta(self) -> np.ndarray:
        """Current parameter vector, shape (p,), names in :attr:`names`."""
        return self.rls.theta

    @property
    def n_updates(self) -> int:
        """Accepted RLS updates."""
        return self.rls.n_updates

    @property
    def noise_std(self) -> float:
        """Running estimate of the velocity noise standard deviation (rad/s)."""
        return self._d2 / _NOISE_GAIN

    @property
    def w_band(self) -> float:
        """Current near-zero band (rad/s): ``max(w_band_min, 4*noise_std)``."""
        return max(self.w_band_min, _BAND_SIGMAS * self._d2 / _NOISE_GAIN)

    @property
    def theta_cov(self) -> np.ndarray:
        """Approximate covariance of ``theta``, shape (p, p): ``P`` times the running mean square a-priori error.

        The filtered equation errors are correlated from row to row, so this
        understates the true uncertainty (by a factor of a few); use it for
        relative comparisons.
        """
        return self._e2 * self.rls.P

    @property
    def estimate(self) -> FrictionEstimate:
        """Physical parameters of the current ``theta`` (inside the projection bounds)."""
        return _to_estimate(self.names, self.rls.theta, self.Vs, self.delta)

    def observe(self, u: float, w: float) -> bool:
        """Feed one controller-period sample.

        Parameters
        ----------
        u : float
            Torque applied by the controller in this period (N·m), computed from ``w``.
        w : float
            Measured velocity at the start of the period (rad/s).

        Returns
        -------
        bool
            True if the sample was used; False if it was rejected (non-finite
            ``u`` or ``w``, or a velocity outlier of :attr:`gate`): a rejected
            sample changes nothing but the counters.
        """
        self.updated = False
        u = float(u)
        w = float(w)
        if not self.u_range.ok(u):  # issue 12: torque range, velocity range (finite ones), then the gate
            self.u_range.commit(u, False)
            self.n_rejected += 1
            return False
        if math.isfinite(w) and not self.w_range.ok(w):
            self.w_range.commit(w, False)
            self.n_rejected += 1
            return False
        if not self.gate.check(w):
            self.n_rejected += 1
            return False
        self.u_range.commit(u, True)
        self.w_range.commit(w, True)
        # noise scale from the second difference of accepted samples
        if self._w2 is not None:
            d2 = w - 2.0 * self._w1 + self._w2
            self._d2 += 0.01 * ((d2 if d2 >= 0.0 else -d2) - self._d2)
        self._w2, self._w1 = self._w1, w
        band = self.w_band_min
        nb = _BAND_SIGMAS * self._d2 / _NOISE_GAIN
        if nb > band:
            band = nb
        aw = w if w >= 0.0 else -w
        if aw > 0.0:
            e = math.exp(-((aw / self.Vs) ** self.delta))
            sg = 1.0 if w > 0.0 else -1.0
            g, h = sg * (1.0 - e), sg * e
        else:
            g = h = 0.0
        d = 1.0 if aw < band else 0.0
        s = self._s
        a = self._a
        x1 = s[0] + a * (w - s[0])  # filter stages of w
        x2 = s[1] + a * (x1 - s[1])
        s[2] += a * (x2 - s[2])
        s[0] = x1
        s[1] = x2
        x1 = s[3] + a * (u - s[3])  # filter stages of u
        x2 = s[4] + a * (x1 - s[4])
        s[5] += a * (x2 - s[5])
        s[3] = x1
        s[4] = x2
        x1 = s[6] + a * (g - s[6])  # filter stages of g
        x2 = s[7] + a * (x1 - s[7])
        s[8] += a * (x2 - s[8])
        s[6] = x1
        s[7] = x2
        x1 = s[9] + a * (h - s[9])  # filter stages of h
        x2 = s[10] + a * (x1 - s[10])
        s[11] += a * (x2 - s[11])
        s[9] = x1
        s[10] = x2
        x1 = s[12] + a * (d - s[12])  # filter stages of d
        x2 = s[13] + a * (x1 - s[13])
        s[14] += a * (x2 - s[14])
        s[12] = x1
        s[13] = x2
        self.n_samples += 1
        k = self.n_samples
        if k % self.m or k < self._settle:
            return True
        if s[14] > self.dwell_max:
            self.n_gated += 1
            return True
        with np.errstate(over="ignore", invalid="ignore"):
            phi = self._phi()
        e = rls_try(self.rls, phi, s[5]) if np.all(np.isfinite(phi)) else None
        if e is None:  # refused by the RLS (issue 12)
            return True
        self._e2 += self._e2_rate * (e * e - self._e2)
        self.updated = True
        return True

    def _phi(self) -> np.ndarray:
        s, T = self._s, self.T
        cols = [(s[1] - s[2]) / T]
        if self.lag:
            cols += [(s[0] - 2.0 * s[1] + s[2]) / (T * T), -(s[4] - s[5]) / T]
        cols += [s[8], s[11], s[2]]
        if self.offset:
            cols.append(1.0)
        return np.array(cols)




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
                 consistency: float = 0.5, lag_margin: float = 1.0, lag_margin_max: float = 0.05,
                 max_rel_stderr: float = 0.05, lag_memory: float = 10.0, start=None):
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
        self.lag_margin = check_nonnegative("lag_margin", lag_margin)
        self.lag_margin_max = float(lag_margin_max)
        self.max_rel_stderr = float(max_rel_stderr)
        # the lag in use: the inverse-variance weighted mean of the lag estimates, each weight forgotten by
        # exp(-Ts/lag_memory) per update (the recursion of the weighted mean, in the package's order of operations)
        self._lag_forget = math.exp(-estimator.Ts / lag_memory) if lag_memory > 0.0 else 0.0
        self._lag_mean = 0.0
        self._lag_info = 0.0
        fade_in = check_nonnegative("fade_in", fade_in)
        self._fade_step = 1.0 if fade_in == 0.0 else self.dt / fade_in
        self._gain = 0.0
        self.n_implausible = 0
        self.n_lag_held = 0
        self.n_undetermined = 0
        # provisional start (issue 11 item 5): ``start`` = (estimate, gain, at_reference); the start map acts
        # (times gain, at the reference velocity when at_reference) until the first estimate is taken
        self.provisional = start is not None
        if start is not None:
            est, self._start_gain, self._start_ref = start
            self._set(replace(est, Vs=estimator.Vs if est.Vs is None else est.Vs,
                              delta=estimator.delta if est.delta is None else est.delta))
            self._gain = 1.0

    def step(self, w: float, w_ref: float | None = None, w_start: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m), 0 before switch-on.

        See :meth:`FrictionFeedforward.step`; after switch-on the output fades in over ``fade_in``. ``w_ref``
        is the stick-detection fallback; a start at the reference uses ``w_start`` (default ``w_ref``).
        """
        if self.estimate is None:
            return 0.0
        if self.provisional:
            if self._start_ref:
                r = w_start if w_start is not None else (w if w_ref is None else w_ref)
                return FrictionFeedforward.step(self, r) * self._start_gain
            return FrictionFeedforward.step(self, w, w_ref) * self._start_gain
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
            cov = self.estimator.theta_cov
            names = list(self.estimator.names)
            i_fc = names.index("Fc")
            if not self._levels_plausible(est):
                self.n_implausible += 1
            elif not math.sqrt(max(cov[i_fc, i_fc], 0.0)) <= self.max_rel_stderr * max(est.Fc, est.Fs):
                self.n_undetermined += 1  # Fc not determined (e.g. confounded with the offset)
            elif self._lag_consistent(est):
                if self.estimator.lag:  # upper confidence bound of the weighted lag, at most lag_margin_max above it
                    i_tau = names.index("tau")
                    sd = math.sqrt(max(cov[i_tau, i_tau], 0.0))
                    tau = est.tau
                    if self._lag_forget > 0.0 and sd > 0.0:
                        w = 1.0 / (sd * sd)
                        info = self._lag_forget * self._lag_info + w
                        self._lag_mean = tau if self._lag_info == 0.0 else self._lag_mean + (w / info) * (
                            tau - self._lag_mean)
                        self._lag_info = info
                        tau = self._lag_mean
                    margin = min(self.lag_margin * sd, self.lag_margin_max * tau)
                    est = replace(est, tau=min(tau + margin, self.tau_max))
                self._take(est)
            elif self.estimate is not None and not self.provisional:
                self.n_lag_held += 1
                self._set(replace(est, tau=self.estimate.tau, J_alt=float("nan")))
            else:
                self.n_implausible += 1
        return ok

    def _take(self, est):
        """Put the estimator's estimate in use; at the hand-over from the start map fade from its gain to 1."""
        if self.provisional:
            self.provisional = False
            self._gain = self._start_gain
        self._set(est)


class AdaptiveDOBCompensator:
    """Oracle of the ``adaptive-dob`` composite (controllers/peers/adaptive_dob.py), written from its equations.

    Per period: ``u_ff`` of the adaptive feedforward (at the measurement with stick detection, or at the
    reference), ``d_hat`` of a disturbance observer (tests/peers_oracle.py) at the controller's measurement,
    output ``clip(u_ff + d_hat, ±u_max)``; the observer then records ``u - u_ff``, the feedforward ``(u, w)``.
    The counters and the estimator are those of the feedforward.
    """

    def __init__(self, ff, dob, *, u_max=math.inf, measured=True):
        self.ff, self.dob, self.u_max, self.measured = ff, dob, u_max, measured
        self.u_ff = 0.0

    def __getattr__(self, name):  # counters, estimator, estimate: the feedforward's
        return getattr(self.__dict__["ff"], name)

    def step(self, w, w_ref, w_stuck=None, w_ff=None):
        wst = w_ref if w_stuck is None else w_stuck
        wf = w if w_ff is None else w_ff  # the feedforward's velocity (signed by the sign observer, if any)
        self.u_ff = self.ff.step(wf, wst, w_ref) if self.measured else self.ff.step(w_ref)
        d = self.dob.compensate(w, w_ref)
        return min(max(self.u_ff + d, -self.u_max), self.u_max)

    def observe(self, u, w):
        self.dob.observe(u - self.u_ff, w)
        return self.ff.observe(u, w)
