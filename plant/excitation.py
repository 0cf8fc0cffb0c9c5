"""Excitation signals: band-limited noise torque (Sec. IV-A) and a multi-sine velocity reference (Sec. V-B)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plant.errors import ParameterError, check_positive

__all__ = ["bandlimited_noise", "Reference", "multisine_reference"]


def _grid(duration: float, dt: float) -> np.ndarray:
    duration = check_positive("duration", duration)
    dt = check_positive("dt", dt)
    n = int(round(duration / dt))
    if n < 2:
        raise ParameterError(f"duration = {duration!r} s is shorter than two steps of dt = {dt!r} s")
    return np.arange(n) * dt


def bandlimited_noise(duration: float, *, dt: float = 1e-3, cutoff: float = 2.0, std: float = 1.0,
                      order: int = 2, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Low-pass filtered band-limited white noise, the paper's identification torque (Sec. IV-A).

    Parameters
    ----------
    duration : float
        Length (s).
    dt : float, optional
        Sample step (s), default 1 ms.
    cutoff : float, optional
        Butterworth low-pass cut-off (Hz), default 2 Hz; must be below the Nyquist
        frequency ``0.5/dt``.
    std : float, optional
        Standard deviation of the result (N·m), default 1.
    order : int, optional
        Butterworth filter order, default 2.
    rng : numpy.random.Generator
        Noise source.

    Returns
    -------
    t : ndarray, shape (N,)
        Time (s).
    u : ndarray, shape (N,)
        Torque (N·m), zero mean, standard deviation ``std``.

    Raises
    ------
    ParameterError
        Non-positive sizes or ``cutoff`` at or above Nyquist.

    Notes
    -----
    White Gaussian samples filtered forward by ``scipy.signal.butter`` in
    second-order sections (causal, as an analogue filter would be), then
    scaled to the requested standard deviation.
    """
    t = _grid(duration, dt)
    cutoff = check_positive("cutoff", cutoff)
    std = check_positive("std", std)
    if cutoff >= 0.5 / dt:
        raise ParameterError(f"cutoff = {cutoff!r} Hz must be below the Nyquist frequency {0.5 / dt!r} Hz")
    from scipy import signal  # lazy: ~0.3 s of import, needed only here (not by multisine_reference)

    sos = signal.butter(int(order), cutoff, fs=1.0 / dt, output="sos")
    x = signal.sosfilt(sos, rng.standard_normal(t.shape[0]))
    x -= x.mean()
    return t, x * (std / x.std())


@dataclass(frozen=True)
class Reference:
    """A velocity reference.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time (s).
    w : ndarray, shape (N,)
        Reference velocity (rad/s).
    dw : ndarray, shape (N,)
        Its time derivative (rad/s²), analytic.
    """

    t: np.ndarray
    w: np.ndarray
    dw: np.ndarray

    def reversals(self) -> np.ndarray:
        """Times (s) where the reference velocity changes sign: ``t[k]`` where ``sgn(w[k-1])*sgn(w[k]) < 0``, or
        where ``w[k] == 0`` between samples of opposite signs (a zero crossing on a sample)."""
        s = np.sign(self.w)
        direct = s[1:] * s[:-1] < 0
        on_zero = np.zeros_like(direct)
        on_zero[:-1] = (s[1:-1] == 0) & (s[2:] * s[:-2] < 0)
        return self.t[np.flatnonzero(direct | on_zero) + 1]

    def stops(self) -> np.ndarray:
        """Times (s) where the reference comes to rest: the first sample of each run of ``w == 0`` that follows
        motion and lasts at least two samples or to the end (a point-to-point move's end,
        :func:`plant.motion.point_to_point_reference`; a single zero sample between motion is no stop, e.g. a
        zero crossing on a sample, :meth:`reversals`)."""
        rest = self.w == 0.0
        run2 = rest.copy()
        run2[:-1] = rest[:-1] & rest[1:]
        i = np.flatnonzero(run2[1:] & ~rest[:-1])
        return self.t[i + 1]


#: Samples per block when building a multi-sine (bounds the temporaries).
_BLOCK = 1 << 16


def multisine_reference(duration: float, *, dt: float = 1e-3, f_min: float = 0.01, f_max: float = 1.0,
                        n_components: int = 8, peak: float = np.deg2rad(20.0), ramp: float = 1.0,
                        rng: np.random.Generator) -> Reference:
    """Smooth multi-sine velocity reference with frequent reversals (paper Sec. V-B).

    Parameters
    ----------
    duration : float
        Length (s).
    dt : float, optional
        Step (s), default 1 ms.
    f_min, f_max : float, optional
        Frequency band (Hz) of the components, default 0.01-1 Hz as in the paper;
        the components are log-spaced.
    n_components : int, optional
        Number of sines, default 8.
    peak : float, optional
        Largest |velocity| (rad/s), default 20 deg/s.
    ramp : float, optional
        Raised-cosine fade-in (s) so the reference starts at rest, default 1 s.
    rng : numpy.random.Generator
        Draws the phases.

    Returns
    -------
    Reference

    Raises
    ------
    ParameterError
        Bad band (``0 < f_min <= f_max < 0.5/dt``), ``n_components < 1``, or
        non-positive sizes.

    Notes
    -----
    ``w(t) = s(t) * A * sum_i sin(2*pi*f_i*t + phi_i)`` with random phases
    ``phi_i``, equal component amplitudes (so the faster components produce
    frequent reversals), the fade-in ``s(t)``, and ``A`` scaling ``max|w|``
    to ``peak``. ``dw`` is the exact derivative.
    """
    t = _grid(duration, dt)
    f_min = check_positive("f_min", f_min)
    f_max = check_positive("f_max", f_max)
    peak = check_positive("peak", peak)
    if not f_min <= f_max < 0.5 / dt:
        raise ParameterError(f"need 0 < f_min <= f_max < Nyquist; got f_min = {f_min!r}, f_max = {f_max!r} Hz")
    if int(n_components) != n_components or n_components < 1:
        raise ParameterError(f"n_components must be an integer >= 1, got {n_components!r}")
    freqs = np.geomspace(f_min, f_max, int(n_components))
    phases = rng.uniform(0.0, 2.0 * np.pi, size=freqs.shape)
    # Blocks of time, one component at a time: memory is t, w, dw plus small
    # temporaries (a one-hour reference at 1 kHz peaks at about 90 MB, not 8x that).
    # The same floating-point operations, in the same order, as summing the dense
    # (n_components, N) matrix over axis 0, with s = 1, ds = 0 after the ramp.
    n = t.shape[0]
    x = np.zeros(n)
    dx = np.zeros(n)
    for i0 in range(0, n, _BLOCK):
        tb = t[i0:i0 + _BLOCK]
        xb = x[i0:i0 + _BLOCK]
        dxb = dx[i0:i0 + _BLOCK]
        for fk, pk in zip(freqs, phases):
            arg = 2.0 * np.pi * fk * tb + pk
            xb += np.sin(arg)
            dxb += 2.0 * np.pi * fk * np.cos(arg)
    # fade-in s(t) = 0.5 - 0.5*cos(pi*t/ramp) over t < ramp, 1 afterwards (exactly: cos(pi) = -1)
    if ramp > 0:
        nr = int(np.searchsorted(t, ramp, side="left"))
        r = t[:nr] / ramp
        s_r = 0.5 - 0.5 * np.cos(np.pi * r)
        ds_r = 0.5 * np.pi / ramp * np.sin(np.pi * r)
        dx[:nr] = ds_r * x[:nr] + s_r * dx[:nr]  # d(s*x)/dt; after the ramp simply dx
        x[:nr] *= s_r
    scale = peak / np.max(np.abs(x))
    x *= scale
    dx *= scale
    return Reference(t=t, w=x, dw=dx)
