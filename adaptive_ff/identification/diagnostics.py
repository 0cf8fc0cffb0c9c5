"""Data-quality diagnostics for identification: noise level and excitation of every parameter.

Used by :func:`adaptive_ff.identification.identify.identify`: its warnings name the parameter a
record does not excite and why (no velocity reversals, too few low-speed
samples, a single speed, no accelerations above the noise), and an
``ExcitationError`` from the least squares is extended by these causes. Sources:
persistence of excitation (Ljung, *System Identification*, 2nd ed., Sec. 13.2)
and the robust noise scale of Hampel (1974).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adaptive_ff.identification.plausibility import IdentificationWarning
from adaptive_ff.io.units import VELOCITY_LABEL
from plant.errors import ParameterError, check_optional_number, check_positive, check_signal, check_time
from plant.results import json_safe

__all__ = ["velocity_noise_std", "velocity_noise_std_irregular", "noise_fit_weights", "feedback_correlation",
           "FEEDBACK_MIN", "input_quantum", "ExcitationReport", "excitation_report"]


def velocity_noise_std(w) -> float:
    """Robust estimate of the white measurement-noise standard deviation of a velocity record.

    Parameters
    ----------
    w : array_like, shape (N,)
        Velocity samples (rad/s, or m/s for a prismatic axis), N >= 8.

    Returns
    -------
    float
        ``1.4826 * MAD(diff(w, 3)) / sqrt(20)`` (unit of ``w``). On a
        low-pass filtered record (such as :func:`adaptive_ff.io.data.load_emps`
        returns) it measures what is left of the noise after the filter.

    Raises
    ------
    SignalError
        Fewer than 8 samples or non-finite values.

    Notes
    -----
    For white noise of variance ``s**2`` the third difference has variance
    ``20*s**2`` (binomial coefficients 1, 3, 3, 1), while a smooth signal
    sampled fast enough contributes only ``w''' * Ts**3``; the median absolute
    deviation (scaled by 1.4826 for Gaussian noise) ignores the few samples at
    velocity reversals where the signal is not smooth (Hampel, 1974,
    "The influence curve and its role in robust estimation").
    """
    w = check_signal("w", w, min_len=8)
    d3 = np.diff(w, 3)
    return float(1.4826 * np.median(np.abs(d3 - np.median(d3))) / np.sqrt(20.0))


#: Magnitude of :func:`feedback_correlation` above which a record is taken as logged inside a feedback loop.
FEEDBACK_MIN = 0.5


def feedback_correlation(u, w) -> float:
    """Correlation of the torque's and the velocity's third differences at the same sample: feedback in the log.

    In a log a velocity controller wrote at its own rate, the torque of each period is computed from the
    velocity measured at its start, so the sensor noise, which dominates the velocity's third differences,
    reappears at once in the torque's (times ``-Kp``): the correlation is near -1. In an open-loop record the
    torque does not see the velocity noise: near 0 (about ``1/sqrt(N)``). Third differences remove a smooth
    signal up to a quadratic trend, as :func:`velocity_noise_std` does.

    Parameters
    ----------
    u : array_like, shape (N,)
        Torque (N·m or N) at the samples, N >= 10.
    w : array_like, shape (N,)
        Velocity (rad/s or m/s) at the same samples.

    Returns
    -------
    float
        In [-1, 1]; 0.0 when either third difference is constant (no noise to follow). Measured: -1.000 on the
        1 kHz PI logs of ``tests/adaptive_ff_layer/test_closed_loop_logs.py`` (noise 1e-3 and 3e-3 rad/s),
        -0.006..0.001 on open-loop 1 kHz records of the Sec. IV-A experiment.

    Raises
    ------
    SignalError
        ``u`` or ``w`` not finite, of other lengths or shorter than 10 samples.
    """
    u = check_signal("u", u, min_len=10)
    w = check_signal("w", w, n=u.shape[0])
    du, dw = np.diff(u, 3), np.diff(w, 3)
    du, dw = du - du.mean(), dw - dw.mean()
    den = float(np.sqrt(np.dot(du, du) * np.dot(dw, dw)))
    return float(np.dot(du, dw) / den) if den > 0 else 0.0


def input_quantum(u) -> float:
    """The quantum of a logged input: the step of the lattice ``a + k q`` every sample lies on, or 0 if none.

    A drive that logs its torque through a converter or as an integer count writes each sample rounded to a
    multiple of its resolution ``q``; the true input differs from the logged one by an error spread uniformly over
    ``[-q/2, q/2]`` (variance ``q**2 / 12``) wherever the signal crosses many levels between samples (Widrow &
    Kollár, *Quantization Noise*, Cambridge University Press, 2008, Ch. 5). The output-error bootstrap can draw
    that error into the input of its replicate records (``bootstrap_input_quantum="auto"`` of
    :class:`adaptive_ff.identification.oe_options.OutputErrorOptions`).

    Parameters
    ----------
    u : array_like, shape (N,)
        Input samples (N·m or N), N >= 3.

    Returns
    -------
    float
        ``q`` (unit of ``u``) > 0 when at least three distinct values occur, the smallest gap between distinct
        values is ``q``, every sample lies within ``1e-3 q`` of the lattice ``min(u) + k q`` and the range holds
        no more levels than there are samples (a lattice is told from a continuous input by samples that repeat
        its levels: a continuous input written with ten digits lies on a lattice of its last digit, of far more
        levels than samples); else 0.0 (a continuous input, or too few levels to tell).

    Raises
    ------
    SignalError
        Fewer than 3 samples or non-finite values.
    """
    u = check_signal("u", u, min_len=3)
    v = np.unique(u)
    if v.shape[0] < 3:
        return 0.0
    q = float(np.min(np.diff(v)))
    k = (v - v[0]) / q
    if not (q > 0 and k[-1] <= u.shape[0] and np.max(np.abs(k - np.rint(k))) <= 1e-3):
        return 0.0
    return q


def velocity_noise_std_irregular(t, w, *, weights: tuple | None = None) -> float:
    """Robust white-noise standard deviation of a velocity record sampled at any times ``t``.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times (s), strictly increasing, any spacing; N >= 5.
    w : array_like, shape (N,)
        Velocity samples (rad/s) at ``t``.
    weights : tuple or None, keyword-only
        :func:`noise_fit_weights` of ``t``, computed once for many records on the same stamps (the output-error
        bootstrap's replicates): the same number as without them. Default None: computed here.

    Returns
    -------
    float
        Noise standard deviation (unit of ``w``), >= 0.

    Raises
    ------
    SignalError
        Fewer than 5 samples, non-finite values, lengths differ, or ``t`` not
        strictly increasing.

    Notes
    -----
    Each sample is compared with the least-squares quadratic through its
    5-point neighbourhood on its own time stamps (so irregular sampling does
    not count as noise); the residual, divided by ``sqrt(1 - h)`` (``h`` the
    leverage of the centre point, Cook & Weisberg, *Residuals and Influence in
    Regression*, 1982, Sec. 2.1), has the noise variance; robust scale
    ``1.4826*MAD`` (Hampel, 1974). A smooth signal leaves a residual of order
    ``Ts**3`` times its third derivative: at 10 ms a noise-free record reads
    1-2e-4 of its peak velocity.
    """
    t = check_time("t", t, min_len=5)
    w = check_signal("w", w, n=t.shape[0])
    row, scale = noise_fit_weights(t) if weights is None else weights
    if row.shape != (t.shape[0] - 4, 5) or scale.shape != (t.shape[0] - 4,):
        raise ParameterError(f"weights must be noise_fit_weights(t) of these {t.shape[0]} stamps, got shapes "
                             f"{row.shape}, {scale.shape}")
    idx = _neighbourhoods(t.shape[0])
    r = w[idx[:, 2]] - np.einsum("mj,mj->m", row, w[idx])
    r = r / scale
    return float(1.4826 * np.median(np.abs(r - np.median(r))))


def _neighbourhoods(n: int) -> np.ndarray:
    """Indices of the 5-point neighbourhood of each sample 2 .. n-3, shape (n-4, 5)."""
    return np.arange(2, n - 2)[:, None] + np.arange(-2, 3)[None, :]


def noise_fit_weights(t) -> tuple[np.ndarray, np.ndarray]:
    """The local quadratic fits of :func:`velocity_noise_std_irregular` on the stamps ``t`` (they depend on ``t``
    only).

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times (s), strictly increasing, any spacing; N >= 5.

    Returns
    -------
    row : ndarray, shape (N-4, 5)
        The centre row of the hat matrix of the least-squares quadratic through each 5-point neighbourhood (the
        fitted value at the centre sample as weights of the five samples).
    scale : ndarray, shape (N-4,)
        ``sqrt(1 - h)``, ``h`` the centre point's leverage (floored at 1e-12 under the root).

    Raises
    ------
    SignalError
        Fewer than 5 samples, non-finite stamps, or ``t`` not strictly increasing.
    """
    t = check_time("t", t, min_len=5)
    idx = _neighbourhoods(t.shape[0])
    dt = t[idx] - t[idx[:, 2:3]]
    x = dt / np.abs(dt).max(axis=1, keepdims=True)
    A = np.stack([np.ones_like(x), x, x * x], axis=2)  # (M, 5, 3)
    H = A @ np.linalg.pinv(A)  # hat matrices (M, 5, 5)
    return H[:, 2, :], np.sqrt(np.maximum(1.0 - H[:, 2, 2], 1e-12))


@dataclass(frozen=True)
class ExcitationReport:
    """How well a record excites the friction model (see :func:`excitation_report`).

    Attributes
    ----------
    n_samples : int
        Samples in the record.
    n_reversals : int
        Sign changes of the velocity among samples with ``|w|`` above the noise threshold.
    low_speed_fraction : float
        Fraction of samples with ``noise_threshold < |w| < 3*Vs`` (the Stribeck transition).
    noise_std : float
        Estimated velocity noise (rad/s), :func:`velocity_noise_std`.
    warnings : tuple of IdentificationWarning
        One ``"identifiability"`` warning (a str with ``code`` and ``parameter``,
        :mod:`adaptive_ff.identification.plausibility`) per parameter that the record
        does not excite, naming the cause.
    """

    n_samples: int
    n_reversals: int
    low_speed_fraction: float
    noise_std: float
    warnings: tuple[str, ...]

    def to_dict(self) -> dict:
        """Strict-JSON dict of the fields (``low_speed_fraction`` None when no ``Vs`` was given); ``warnings``
        as a list of ``{"code", "parameter", "message"}``."""
        return json_safe({"n_samples": self.n_samples, "n_reversals": self.n_reversals,
                          "low_speed_fraction": self.low_speed_fraction, "noise_std": self.noise_std,
                          "warnings": [w.to_dict() for w in self.warnings]})

    def summary(self) -> str:
        """One line of figures, then one line per warning (or "every parameter excited")."""
        low = ("" if not np.isfinite(self.low_speed_fraction)
               else f", {100 * self.low_speed_fraction:.2f} % of the samples in the Stribeck transition")
        lines = [f"excitation: {self.n_samples} samples, {self.n_reversals} velocity reversals, velocity noise "
                 f"{self.noise_std:.3g}{low}"]
        lines += [f"  WARNING: {w}" for w in self.warnings] or ["  every parameter excited"]
        return "\n".join(lines)


def excitation_report(u, w, *, Vs: float | None = None, min_reversals: int = 4,
                      min_low_speed: float = 0.01) -> ExcitationReport:
    """Check whether a record can identify the friction parameters, naming the cause when not.

    Parameters
    ----------
    u : array_like, shape (N,)
        Input torque (N·m) or force (N).
    w : array_like, shape (N,)
        Velocity (rad/s) or (m/s).
    Vs : float, keyword-only, optional
        Stribeck velocity (rad/s) of the structure to be fitted; if given, the
        low-speed region ``|w| < 3*Vs`` must hold at least ``min_low_speed`` of
        the samples for ``Fs`` (and ``Vs``) to be identifiable.
    min_reversals : int, keyword-only
        Fewest velocity reversals for ``Fc`` to be separable from a constant
        torque offset (>= 1). Default 4.
    min_low_speed : float, keyword-only
        Smallest fraction of samples in the Stribeck transition, in (0, 1). Default 1 %.

    Returns
    -------
    ExcitationReport

    Raises
    ------
    SignalError
        Bad shapes or values.
    ParameterError
        Bad ``Vs``, ``min_reversals`` or ``min_low_speed``.

    Notes
    -----
    Persistence of excitation (Ljung, *System Identification*, 2nd ed.,
    Sec. 13.2) for this model means: velocity reversals (the Coulomb
    regressor ``sgn(w)`` changes sign, otherwise it is collinear with a
    constant offset), samples in the Stribeck transition (otherwise
    ``g ~ sgn(w)`` and ``h ~ 0`` and ``Fs`` multiplies a zero column), a
    spread of speeds (``sigma``) and of accelerations (``J``), and an input that
    varies (``u`` constant: nothing is excited). A speed counts as known only
    above three times the estimated noise level.
    """
    u = check_signal("u", u, min_len=8)
    w = check_signal("w", w, n=u.shape[0])
    Vs = check_optional_number("Vs", Vs, low=0.0, strict=True)
    if isinstance(min_reversals, bool) or not isinstance(min_reversals, (int, np.integer)) or min_reversals < 1:
        raise ParameterError(f"min_reversals must be an integer >= 1, got {min_reversals!r}")
    min_low_speed = check_positive("min_low_speed", min_low_speed)
    if min_low_speed >= 1.0:
        raise ParameterError(f"min_low_speed must be in (0, 1), got {min_low_speed!r}")
    sn = velocity_noise_std(w)
    thr = 3.0 * sn
    moving = np.abs(w) > thr
    s = np.sign(w[moving])
    n_rev = int(np.sum(s[1:] != s[:-1])) if s.size > 1 else 0
    low = float(np.mean(moving & (np.abs(w) < 3.0 * Vs))) if Vs is not None else float("nan")
    warn = []
    if np.ptp(u) == 0.0:
        warn.append(IdentificationWarning("identifiability", "all", "the input u is constant: no parameter is excited"))
    if n_rev < min_reversals:
        warn.append(IdentificationWarning(
            "identifiability", "Fc", f"only {n_rev} velocity reversal(s) above the noise level (need {min_reversals}): "
                                     "Fc is not separable from a constant torque offset; drive in both directions"))
    if Vs is not None and not low >= min_low_speed:
        if 3.0 * Vs <= thr:
            cause = (f"the Stribeck transition |w| < 3*Vs = {3 * Vs:.3g} {VELOCITY_LABEL} lies below three times "
                     f"the velocity noise ({thr:.3g} {VELOCITY_LABEL})")
        else:
            cause = (f"only {100 * low:.2f} % of the samples lie in the Stribeck transition "
                     f"{thr:.3g} < |w| < 3*Vs = {3 * Vs:.3g} {VELOCITY_LABEL} (need {100 * min_low_speed:g} %)")
        warn.append(IdentificationWarning("identifiability", "Fs",
                                          f"too few low-speed samples: Fs and Vs are not identifiable ({cause})"))
    if not moving.any() or np.ptp(np.abs(w[moving])) < 0.1 * np.max(np.abs(w)):
        warn.append(IdentificationWarning("identifiability", "sigma", "the speed hardly varies: sigma is not "
                                                                      "separable from Fc; use several speed levels"))
    dw = np.diff(w)
    if dw.size and np.std(dw) <= 3.0 * np.sqrt(2.0) * sn:
        warn.append(IdentificationWarning("identifiability", "J", "the velocity changes no more than its noise from "
                                          "sample to sample: J (and tau) are not identifiable; excite accelerations"))
    return ExcitationReport(n_samples=int(w.shape[0]), n_reversals=n_rev, low_speed_fraction=low,
                            noise_std=sn, warnings=tuple(warn))
