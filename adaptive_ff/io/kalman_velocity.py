r"""Velocity from a position record by a Kalman filter and smoother (non-uniform time stamps).

:func:`velocity_from_position` is what :func:`adaptive_ff.io.logs.load_log` uses when a log maps the
position ``q`` instead of a velocity (re-exported there).

Velocity from position: Kalman filter
-------------------------------------
Position ``q`` (rad) is turned into velocity by a linear Kalman filter
(``filterpy.kalman.KalmanFilter``) on a kinematic model, followed by the
Rauch-Tung-Striebel smoother (zero phase lag, as an offline identification
wants; ``smooth=False`` keeps the causal filter). Time stamps may be
non-uniform: the transition and process-noise matrices are built for each
interval ``h = t[k] - t[k-1]``:

* ``"cv"`` (constant velocity, state ``[q, w]``): white acceleration noise of
  spectral density ``S`` (rad²/s³), ``F = [[1, h], [0, 1]]``,
  ``Q = S*[[h³/3, h²/2], [h²/2, h]]``;
* ``"ca"`` (constant acceleration, state ``[q, w, a]``): white jerk noise,
  ``Q = S*[[h⁵/20, h⁴/8, h³/6], [h⁴/8, h³/3, h²/2], [h³/6, h²/2, h]]``

(Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and
Navigation*, 2001, Sec. 6.2-6.3). Measurement ``z = q + v``, ``var v = r``.

Tuning is by one number, the **bandwidth** ``fb`` (Hz) of the estimator. For
the model of order ``n`` (2 for cv, 3 for ca) the steady-state Kalman filter
has its poles on a Butterworth circle of radius ``wb = (S/(r*T))**(1/(2n))``
(spectral factorisation of ``1 + S/(r T) |1/s**n|²``, with ``r*T`` the
measurement noise density at the nominal interval ``T = median(diff(t))``),
so ``S = (2*pi*fb)**(2n) * r * T`` sets the bandwidth directly. The causal
filter's velocity estimate then responds to the true velocity as
``H(s) = wb²/(s² + sqrt(2) wb s + wb²)`` for cv (a 2nd-order Butterworth
low-pass, -3 dB at ``fb``) and ``H(s) = (2 wb² s + wb³)/((s + wb)(s² + wb s + wb²))``
for ca (no lag at low frequency to second order, but a resonance of 1.68
(4.5 dB) at ``0.83 fb`` and -3 dB at ``1.7 fb``); the RTS smoother applies
the filter forward and backward (``|H|²``, zero phase). Choose ``fb``
above the motion content you want to keep (the friction lag ``1/(2*pi*tau)``
included) and below where position noise dominates; the default is a tenth of
the sampling rate. The noise ``r`` is ``position_noise**2``; by default the
quantisation noise ``Δ²/12`` of the encoder step ``Δ = 2*pi/counts_per_rev``
for counts, and for rad/deg the larger of a robust estimate from third
differences (``var(Δ³q) = 20 r`` for white noise, median absolute deviation)
and the smallest position step over ``sqrt(12)`` (the apparent quantum).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from adaptive_ff.io.units import KALMAN_MODELS
from plant.errors import ParameterError, check_positive, check_signal, check_time
from plant.results import axes_or_new, json_safe

__all__ = ["VelocityEstimate", "SteadyStateKalman", "estimate_position_noise", "kinematic_matrices",
           "process_noise_density", "steady_state_kalman", "velocity_from_position"]


@dataclass(frozen=True)
class VelocityEstimate:
    """Velocity estimated from position by :func:`velocity_from_position`.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time stamps (s).
    w : ndarray, shape (N,)
        Velocity estimate (rad/s).
    w_std : ndarray, shape (N,)
        Its standard deviation from the filter/smoother covariance (rad/s).
    q : ndarray, shape (N,)
        Filtered position (rad).
    model : str
        ``"cv"`` or ``"ca"``.
    bandwidth : float
        Estimator bandwidth ``fb`` (Hz).
    position_noise : float
        Measurement noise standard deviation ``sqrt(r)`` (rad).
    process_noise : float
        Spectral density ``S`` of the white acceleration (cv, rad²/s³) or jerk
        (ca, rad²/s⁵) noise.
    smoothed : bool
        True if the Rauch-Tung-Striebel smoother was applied.
    """

    t: np.ndarray
    w: np.ndarray
    w_std: np.ndarray
    q: np.ndarray
    model: str
    bandwidth: float
    position_noise: float
    process_noise: float
    smoothed: bool

    def to_dict(self, *, arrays: bool = False) -> dict:
        """Settings and velocity statistics as strict JSON; with ``arrays=True`` also ``t``, ``w``, ``w_std``, ``q``.

        Keys: ``model``, ``bandwidth`` (Hz), ``position_noise`` (rad),
        ``process_noise``, ``smoothed``, ``n_samples``, ``w_std_median`` (rad/s).
        """
        d = {"model": self.model, "bandwidth": self.bandwidth, "position_noise": self.position_noise,
             "process_noise": self.process_noise, "smoothed": self.smoothed, "n_samples": int(self.t.shape[0]),
             "w_std_median": float(np.median(self.w_std))}
        if arrays:
            d.update(t=self.t, w=self.w, w_std=self.w_std, q=self.q)
        return json_safe(d)

    def summary(self) -> str:
        """One line: estimator, bandwidth, noise and the typical velocity uncertainty."""
        kind = "filter + RTS smoother" if self.smoothed else "causal filter"
        return (f"Kalman {kind} ({self.model}), {self.t.shape[0]} samples, bandwidth {self.bandwidth:.4g} Hz, "
                f"position noise {self.position_noise:.3g} rad; velocity std median "
                f"{float(np.median(self.w_std)):.3g} rad/s")

    def plot(self, ax=None):
        """Velocity estimate (rad/s) over time (s) with its ±2 std band.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
        """
        ax = axes_or_new(ax)
        ax.fill_between(self.t, self.w - 2 * self.w_std, self.w + 2 * self.w_std, color="C0", alpha=0.25, lw=0,
                        label="±2 std")
        ax.plot(self.t, self.w, color="C0", lw=0.9, label=f"Kalman velocity ({self.model}, {self.bandwidth:.3g} Hz)")
        ax.set_xlabel("time t (s)")
        ax.set_ylabel("velocity w (rad/s)")
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
        return ax


def estimate_position_noise(q) -> float:
    """Measurement-noise standard deviation (rad) of a position record, for the Kalman filter's ``r``.

    Parameters
    ----------
    q : array_like, shape (N,), N >= 4
        Position samples (rad).

    Returns
    -------
    float
        ``max(sigma_3, dq_min/sqrt(12))``: ``sigma_3 = 1.4826*MAD(diff(q, 3))/sqrt(20)``
        (third differences of white noise have variance ``20*r``; smooth motion
        sampled fast hardly contributes; MAD makes it robust) and ``dq_min``
        the smallest non-zero position step, whose uniform quantisation noise
        has variance ``dq_min**2/12``. If both are 0 (noise-free polynomial
        motion), ``1e-9`` times the position range (or 1e-12 rad).

    Raises
    ------
    SignalError
        Fewer than 4 samples or non-finite values.
    """
    q = check_signal("q", q, min_len=4)
    d3 = np.diff(q, 3)
    sigma3 = 1.4826 * float(np.median(np.abs(d3 - np.median(d3)))) / math.sqrt(20.0)
    steps = np.abs(np.diff(q))
    steps = steps[steps > 0]
    quantum = float(steps.min()) / math.sqrt(12.0) if steps.size else 0.0
    out = max(sigma3, quantum)
    if out == 0.0:
        span = float(np.ptp(q))
        out = 1e-9 * span if span > 0 else 1e-12
    return out


def kinematic_matrices(model: str, h: float, S: float) -> tuple[np.ndarray, np.ndarray]:
    """Transition and process-noise matrices of the kinematic model over one interval (module docstring).

    Parameters
    ----------
    model : {"cv", "ca"}
        Constant velocity (state ``[q, w]``, white acceleration noise) or constant acceleration (state
        ``[q, w, a]``, white jerk noise).
    h : float
        Interval (s).
    S : float
        Spectral density of the white noise (rad²/s³ for cv, rad²/s⁵ for ca), e.g. from
        :func:`process_noise_density`.

    Returns
    -------
    F, Q : ndarray, shape (n, n)
        ``x[k] = F x[k-1] + noise`` with ``cov(noise) = Q``; n = 2 (cv) or 3 (ca).

    Raises
    ------
    ParameterError
        Unknown ``model``.

    Notes
    -----
    Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and Navigation*, 2001, Sec. 6.2-6.3.
    """
    if model == "cv":
        F = np.array([[1.0, h], [0.0, 1.0]])
        Q = S * np.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
        return F, Q
    if model == "ca":
        F = np.array([[1.0, h, h * h / 2], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
        Q = S * np.array([[h**5 / 20, h**4 / 8, h**3 / 6],
                          [h**4 / 8, h**3 / 3, h**2 / 2],
                          [h**3 / 6, h**2 / 2, h]])
        return F, Q
    raise ParameterError(f"model must be one of {list(KALMAN_MODELS)}, got {model!r}")


def process_noise_density(model: str, bandwidth: float, position_noise: float, T: float) -> float:
    """The tuning rule: the process-noise density that gives the steady-state filter the bandwidth ``fb``.

    Parameters
    ----------
    model : {"cv", "ca"}
        Kinematic model (order n = 2 or 3).
    bandwidth : float
        Estimator bandwidth ``fb`` (Hz), > 0.
    position_noise : float
        Measurement noise standard deviation ``sqrt(r)`` (rad), > 0 (an encoder: its step over ``sqrt(12)``).
    T : float
        Nominal sampling interval (s), > 0.

    Returns
    -------
    float
        ``S = (2*pi*fb)**(2n) * r * T`` (rad²/s³ for cv, rad²/s⁵ for ca): the filter's poles on a Butterworth
        circle of radius ``2*pi*fb`` (module docstring).

    Raises
    ------
    ParameterError
        Unknown ``model``; ``bandwidth``, ``position_noise`` or ``T`` not > 0 (or NaN).
    """
    if model not in KALMAN_MODELS:
        raise ParameterError(f"model must be one of {list(KALMAN_MODELS)}, got {model!r}")
    fb = check_positive("bandwidth", bandwidth)
    sd = check_positive("position_noise", position_noise)
    T = check_positive("T", T)
    n = KALMAN_MODELS[model]
    r = sd * sd
    return (2.0 * math.pi * fb) ** (2 * n) * r * T


#: Most Riccati iterations that polish scipy's steady-state covariance (:func:`steady_state_kalman`).
_POLISH_MAX = 20000


@dataclass(frozen=True)
class SteadyStateKalman:
    """The steady-state Kalman filter of a kinematic model on a uniform grid (:func:`steady_state_kalman`).

    Per interval: predict ``x = F x``, correct ``x = x + K*(z - x[0])`` with the constant gain ``K``.

    Attributes
    ----------
    model : str
        ``"cv"`` or ``"ca"``.
    bandwidth : float
        Estimator bandwidth ``fb`` (Hz).
    T : float
        Sampling interval (s).
    position_noise : float
        Measurement noise standard deviation ``sqrt(r)`` (rad).
    process_noise : float
        Spectral density ``S`` (:func:`process_noise_density`).
    F, Q : ndarray, shape (n, n)
        Transition and process-noise matrices (:func:`kinematic_matrices`).
    K : ndarray, shape (n,)
        Steady-state gain: rad/rad, (rad/s)/rad, and for ca (rad/s²)/rad.
    P_prior, P : ndarray, shape (n, n)
        Steady-state covariance before and after the correction (rad, rad/s, rad/s² units).
    """

    model: str
    bandwidth: float
    T: float
    position_noise: float
    process_noise: float
    F: np.ndarray
    Q: np.ndarray
    K: np.ndarray
    P_prior: np.ndarray
    P: np.ndarray


def steady_state_kalman(model: str, *, bandwidth: float, position_noise: float, T: float) -> SteadyStateKalman:
    """The steady-state (constant-gain) Kalman filter of :func:`velocity_from_position`'s model and tuning.

    Parameters
    ----------
    model : {"cv", "ca"}
        Kinematic model.
    bandwidth : float, keyword-only
        Estimator bandwidth ``fb`` (Hz), > 0 and below the Nyquist frequency ``0.5/T``.
    position_noise : float, keyword-only
        Measurement noise standard deviation (rad), > 0; an encoder of step ``res``: ``res/sqrt(12)``.
    T : float, keyword-only
        Sampling interval (s), > 0.

    Returns
    -------
    SteadyStateKalman

    Raises
    ------
    ParameterError
        Unknown ``model``; ``bandwidth``, ``position_noise`` or ``T`` not > 0 (or NaN); the bandwidth at or
        above the Nyquist frequency.

    Notes
    -----
    The prior covariance solves the filter's discrete algebraic Riccati equation
    ``P = F P F' - F P H' (H P H' + r)^-1 H P F' + Q`` (``scipy.linalg.solve_discrete_are`` with ``a = F'``,
    ``b = H'``), ``H = [1, 0, (0)]``; the gain is ``K = P H' / (H P H' + r)`` and the posterior
    ``(I - K H) P`` (Anderson & Moore, *Optimal Filtering*, 1979, Sec. 4.4). scipy's solution is then polished by
    the Riccati recursion ``P <- F (P - K H P) F' + Q`` until the geometric tail of the gain's changes is below rounding (at most 20000 steps; a
    few hundred at 1 kHz and 30 Hz): scipy's answer on these badly scaled matrices is accurate to 1e-12..1e-9
    relative, the recursion's fixed point to rounding. The covariance recursion of :func:`velocity_from_position`
    on a uniform grid converges to it.
    """
    from scipy.linalg import solve_discrete_are

    S = process_noise_density(model, bandwidth, position_noise, T)
    if bandwidth >= 0.5 / T:
        raise ParameterError(f"bandwidth must be below the Nyquist frequency {0.5 / T:.6g} Hz of the interval "
                             f"{T:.6g} s, got {bandwidth!r} Hz")
    n = KALMAN_MODELS[model]
    r = float(position_noise) ** 2
    F, Q = kinematic_matrices(model, float(T), S)
    H = np.zeros((1, n))
    H[0, 0] = 1.0
    P_prior = solve_discrete_are(F.T, H.T, Q, np.array([[r]]))
    P_prior = 0.5 * (P_prior + P_prior.T)
    K = P_prior[:, 0] / (P_prior[0, 0] + r)
    # polish by the Riccati recursion (a contraction at its fixed point): scipy's solution of these ill-scaled
    # matrices (r ~ 1e-10 rad², a few 1e4 rad²/s⁴) is accurate to 1e-12..1e-9 relative, the recursion's fixed
    # point to rounding
    eps, d_prev = np.finfo(float).eps, math.inf
    for _ in range(_POLISH_MAX):
        P_next = F @ (P_prior - np.outer(K, P_prior[0, :])) @ F.T + Q
        P_prior = 0.5 * (P_next + P_next.T)
        K_next = P_prior[:, 0] / (P_prior[0, 0] + r)
        d = float(np.max(np.abs(K_next - K) / np.abs(K_next)))
        K = K_next
        rate = d / d_prev if 0.0 < d_prev < math.inf else math.nan  # nan: not known yet, go on
        # done when the change's geometric tail is below rounding, or the change is rounding noise
        if d == 0.0 or (rate < 1.0 and d * rate / (1.0 - rate) <= eps) or (d <= 4.0 * eps and rate >= 1.0):
            break
        d_prev = d
    P = (np.eye(n) - np.outer(K, H[0])) @ P_prior
    return SteadyStateKalman(model=model, bandwidth=float(bandwidth), T=float(T), position_noise=float(position_noise),
                             process_noise=float(S), F=F, Q=Q, K=K, P_prior=P_prior, P=0.5 * (P + P.T))


def _kalman_pass(t: np.ndarray, q: np.ndarray, n: int, r: float, S: float, sd: float, smooth: bool, progress):
    """Kalman filter (and RTS smoother) over ``q``; state means ``(N, n, 1)`` and covariances ``(N, n, n)``."""
    from filterpy.kalman import KalmanFilter
    from tqdm.auto import tqdm

    T = float(np.median(np.diff(t)))
    model = "cv" if n == 2 else "ca"
    kf = KalmanFilter(dim_x=n, dim_z=1)
    kf.H = np.zeros((1, n))
    kf.H[0, 0] = 1.0
    kf.R = np.array([[r]])
    v0 = (q[1] - q[0]) / (t[1] - t[0])
    kf.x = np.zeros((n, 1))
    kf.x[0, 0], kf.x[1, 0] = q[0], v0
    vscale = max(float(np.max(np.abs(np.diff(q) / np.diff(t)))), sd / T)
    kf.P = np.diag([r, vscale**2, (vscale / T) ** 2][:n])
    N = t.shape[0]
    xs = np.empty((N, n, 1))
    Ps = np.empty((N, n, n))
    Fs = [np.eye(n)] * N
    Qs = [np.zeros((n, n))] * N
    kf.update(q[0])
    xs[0], Ps[0] = kf.x, kf.P
    h_all = np.diff(t).tolist()
    q_list = q.tolist()
    for k in tqdm(range(1, N), desc="Kalman velocity", disable=(None if progress is None else not progress),
                  leave=False, mininterval=0.5):
        F, Q = kinematic_matrices(model, h_all[k - 1], S)
        kf.predict(F=F, Q=Q)
        kf.update(q_list[k])
        xs[k], Ps[k] = kf.x, kf.P
        Fs[k], Qs[k] = F, Q
    if smooth:
        # rts_smoother uses Fs[k+1], Qs[k+1] to go from k to k+1: the list is aligned that way
        xs, Ps, _, _ = kf.rts_smoother(xs, Ps, Fs=Fs, Qs=Qs)
    return xs, Ps


def velocity_from_position(t, q, *, model: str = "cv", bandwidth: float | None = None,
                           position_noise: float | None = None, smooth: bool = True,
                           progress: bool | None = False) -> VelocityEstimate:
    """Estimate velocity from (possibly irregularly) sampled position by a Kalman filter and RTS smoother.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time stamps (s), strictly increasing, need not be uniform; N >= 4.
    q : array_like, shape (N,)
        Position (rad).
    model : {"cv", "ca"}, keyword-only
        Kinematic model: constant velocity (white acceleration noise) or
        constant acceleration (white jerk noise). ``"ca"`` follows fast
        velocity changes (reversals) with less lag at the same bandwidth but
        amplifies motion and noise around ``0.83*fb`` by up to 1.68 (module docstring).
    bandwidth : float, keyword-only, optional
        Estimator bandwidth ``fb`` (Hz), > 0 and below the Nyquist frequency
        ``0.5/T`` of the median interval ``T``. Default ``0.1/T``.
    position_noise : float, keyword-only, optional
        Position measurement noise standard deviation (rad), > 0. Default
        :func:`estimate_position_noise` of ``q``.
    smooth : bool, keyword-only
        Apply the Rauch-Tung-Striebel smoother (default; zero lag, for offline
        identification). False: the causal Kalman filter (lags by about
        ``1/(2*pi*fb)``).
    progress : bool or None, keyword-only
        tqdm progress bar over the samples (None: when on a terminal; default off).

    Returns
    -------
    VelocityEstimate

    Raises
    ------
    SignalError
        Bad ``t``/``q`` (lengths, non-finite, time not strictly increasing).
    ParameterError
        Unknown ``model``; ``bandwidth`` or ``position_noise`` not > 0, or the
        bandwidth at or above the Nyquist frequency.

    Notes
    -----
    See the module docstring for the model matrices and the tuning rule
    ``S = (2*pi*fb)**(2n) * r * T`` (n = 2 for cv, 3 for ca), which puts the
    poles of the steady-state filter on a Butterworth circle of radius
    ``2*pi*fb``. Filter: ``filterpy.kalman.KalmanFilter`` (``predict`` with the
    per-interval ``F``, ``Q``; ``update``); smoother:
    ``KalmanFilter.rts_smoother`` (Rauch, Tung, Striebel 1965). Initial state:
    the first position, the first finite-difference velocity, zero
    acceleration, with a covariance wide enough to be forgotten within a few
    samples.
    """
    if model not in KALMAN_MODELS:
        raise ParameterError(f"model must be one of {list(KALMAN_MODELS)}, got {model!r}")
    t = check_time("t", t, min_len=4)
    q = check_signal("q", q, n=t.shape[0])
    T = float(np.median(np.diff(t)))
    fb = 0.1 / T if bandwidth is None else check_positive("bandwidth", bandwidth)
    if fb >= 0.5 / T:
        raise ParameterError(f"bandwidth must be below the Nyquist frequency {0.5 / T:.6g} Hz of the median "
                             f"interval {T:.6g} s, got {fb!r} Hz")
    sd = estimate_position_noise(q) if position_noise is None else check_positive("position_noise", position_noise)
    n = KALMAN_MODELS[model]
    r = sd * sd
    S = process_noise_density(model, fb, sd, T)
    xs, Ps = _kalman_pass(t, q, n, r, S, sd, smooth, progress)
    return VelocityEstimate(t=t.copy(), w=xs[:, 1, 0].copy(), w_std=np.sqrt(np.maximum(Ps[:, 1, 1], 0.0)),
                            q=xs[:, 0, 0].copy(), model=model, bandwidth=float(fb), position_noise=float(sd),
                            process_noise=float(S), smoothed=bool(smooth))
