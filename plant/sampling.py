"""Turn the 1 kHz simulated truth into measurements, as a robot controller delivers them.

Covers what the paper names as its data's defects: measurement noise, input
quantization (Fig. 7) and non-deterministic sample times (Fig. 10: mean about
22 ms with periodic outliers up to twice the mean).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant.errors import ParameterError, SignalError, check_multiple, check_nonnegative, check_positive, check_time
from plant.joint import PlantResponse

__all__ = ["Measurement", "sample", "irregular_sample_times"]


@dataclass(frozen=True)
class Measurement:
    """Sampled measurements of input torque and velocity.

    Attributes
    ----------
    t : ndarray, shape (M,)
        Sample times (s), strictly increasing.
    u : ndarray, shape (M,)
        Measured (quantized) input torque (N·m): ``u[i]`` is the torque applied
        over the last integration step before ``t[i]`` (what drove ``w[i]``).
    w : ndarray, shape (M,)
        Measured (noisy) velocity (rad/s).
    u_true, w_true : ndarray, shape (M,)
        The noise-free values at the same instants.
    Ts : float
        Nominal sample time (s); the mean interval for irregular sampling.
    """

    t: np.ndarray
    u: np.ndarray
    w: np.ndarray
    u_true: np.ndarray
    w_true: np.ndarray
    Ts: float

    @property
    def uniform(self) -> bool:
        """True if all intervals equal ``Ts`` to 1e-9 relative."""
        return bool(np.allclose(np.diff(self.t), self.Ts, rtol=1e-9, atol=0.0))


def irregular_sample_times(duration: float, *, base: float = 0.02, outlier: float = 0.04,
                           outlier_every: int = 10, jitter: float = 0.001, dt: float = 1e-3,
                           rng: np.random.Generator) -> np.ndarray:
    """Non-uniform sample times like the paper's Fig. 10, on the integration grid.

    Intervals are ``base`` (s) with a uniform ``±jitter`` (s), and every
    ``outlier_every``-th interval is ``outlier`` (s): with the defaults the mean
    interval is about 22 ms and the outliers are up to about twice the mean.

    Parameters
    ----------
    duration : float
        Length (s) to cover.
    base, outlier, jitter : float
        Interval sizes (s); rounded to multiples of ``dt``.
    outlier_every : int
        Period of the outlier pattern (intervals), >= 1.
    dt : float
        Integration grid (s): every time is a multiple of it.
    rng : numpy.random.Generator
        Source of the jitter.

    Returns
    -------
    ndarray, shape (M,)
        Strictly increasing times in ``[0, duration]``, starting at 0.

    Raises
    ------
    ParameterError
        Non-positive sizes, ``jitter >= base``, or ``outlier_every < 1``.
    """
    duration = check_positive("duration", duration)
    base = check_positive("base", base)
    outlier = check_positive("outlier", outlier)
    jitter = check_nonnegative("jitter", jitter)
    dt = check_positive("dt", dt)
    if jitter >= base:
        raise ParameterError(f"jitter must be < base = {base!r}, got {jitter!r}")
    if int(outlier_every) != outlier_every or outlier_every < 1:
        raise ParameterError(f"outlier_every must be an integer >= 1, got {outlier_every!r}")
    n = int(duration / base) + 2
    steps = np.full(n, round(base / dt), dtype=np.int64)
    steps[outlier_every - 1::outlier_every] = round(outlier / dt)
    jit = np.rint(rng.uniform(-jitter, jitter, size=n) / dt).astype(np.int64)
    steps = np.maximum(steps + jit, 1)
    k = np.concatenate([[0], np.cumsum(steps)])
    k = k[k * dt <= duration + 1e-12]
    return k * dt


def sample(resp: PlantResponse, *, Ts: float = 0.01, times=None, noise_std: float = 0.0,
           quantization: float = 0.0, rng: np.random.Generator | None = None) -> Measurement:
    """Sample a simulated response at ``Ts`` (or at given ``times``) with measurement defects.

    Parameters
    ----------
    resp : PlantResponse
        Simulated truth at the integration rate ``resp.dt``.
    Ts : float, optional
        Sample time (s), a multiple of ``resp.dt``; default 10 ms (paper Sec. IV-A).
        Ignored when ``times`` is given.
    times : array_like, shape (M,), optional
        Explicit strictly increasing sample times (s) on the ``resp.dt`` grid,
        e.g. from :func:`irregular_sample_times`.
    noise_std : float, optional
        Standard deviation (rad/s) of white Gaussian velocity noise; default 0.
    quantization : float, optional
        Quantization step (N·m) of the measured input (Fig. 7); 0 = none.
    rng : numpy.random.Generator, optional
        Needed when ``noise_std > 0``.

    Returns
    -------
    Measurement

    Raises
    ------
    ParameterError
        ``Ts`` not a positive multiple of ``resp.dt``; negative noise or
        quantization; noise without ``rng``.
    SignalError
        ``times`` not strictly increasing, off the grid, or beyond the response.
    """
    dt = resp.dt
    noise_std = check_nonnegative("noise_std", noise_std)
    quantization = check_nonnegative("quantization", quantization)
    if noise_std > 0 and rng is None:
        raise ParameterError("noise_std > 0 needs rng=np.random.default_rng(seed)")
    if times is None:
        idx = np.arange(0, resp.t.shape[0], check_multiple("Ts", Ts, "the integration step dt", dt))
    else:
        times = check_time("times", times)
        idx = np.rint(times / dt).astype(np.int64)
        if np.any(np.abs(idx * dt - times) > 1e-6 * dt) or idx[-1] >= resp.t.shape[0] or idx[0] < 0:
            raise SignalError("times must lie on the integration grid within the simulated span")
        Ts = float(np.mean(np.diff(times)))
    # u(k): the torque applied over the integration step that ends at t(k), i.e. the
    # input that moved the joint to w(k) (causal alignment for eq. 4's b0*u(k)).
    u_true = resp.u[np.maximum(idx - 1, 0)]
    w_true = resp.w[idx]
    w = w_true + (rng.normal(0.0, noise_std, size=w_true.shape) if noise_std > 0 else 0.0)
    u = np.round(u_true / quantization) * quantization if quantization > 0 else u_true.copy()
    return Measurement(t=resp.t[idx], u=u, w=w, u_true=u_true, w_true=w_true, Ts=float(Ts))
