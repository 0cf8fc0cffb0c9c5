"""Test oracle: the package's discrete linear filters as transfer functions from scipy, stepped in state space.

The package realises its first-order lags as ``x += a*(input - x)`` with ``a = 1 - exp(-dt*bandwidth)`` (the
feedforward's lag, the disturbance observer's Q-filter, the state-variable filters of the sliding estimator, the
loop model's deviation tracker). Here each is derived instead: the zero-order-hold discretisation of
``bandwidth/(s + bandwidth)`` from :func:`scipy.signal.cont2discrete` (numerator ``[0, 1 - p]``, pole
``p = exp(-dt*bandwidth)``), advanced by one sample (the package applies this period's input at once, so the
numerator is ``[1 - p, 0]``); cascades and combinations are polynomial products, and a filter runs either on a
whole signal (:func:`scipy.signal.lfilter`) or sample by sample (:class:`StepLTI`, a realisation from
:func:`scipy.signal.tf2ss`). Not part of the package.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

__all__ = ["lag", "power", "combine", "StepLTI"]


def lag(bandwidth: float, dt: float) -> tuple:
    """``(b, a)`` in ``z^-1`` of the first-order lag of ``bandwidth`` (rad/s) at period ``dt`` (s), input applied
    in the period it arrives (unit gain at zero frequency)."""
    num, den, _ = signal.cont2discrete(([bandwidth], [1.0, bandwidth]), dt, method="zoh")
    num = np.trim_zeros(np.atleast_1d(np.squeeze(num)), "f")  # [1 - p]: the one-sample advance
    return np.append(num, np.zeros(len(den) - len(num))), np.asarray(den, dtype=float)


def power(ba: tuple, n: int) -> tuple:
    """``n`` equal filters in cascade."""
    b, a = np.array([1.0]), np.array([1.0])
    for _ in range(n):
        b, a = np.polymul(b, ba[0]), np.polymul(a, ba[1])
    return b, a


def combine(terms, den) -> tuple:
    """``sum c_i * N_i / den`` for ``terms = [(c_i, N_i), ...]`` over one denominator (numerators padded)."""
    size = max(len(n) for _, n in terms)
    b = np.zeros(size)
    for c, n in terms:
        b[:len(n)] += c * np.asarray(n, dtype=float)
    return b, np.asarray(den, dtype=float)


class StepLTI:
    """A SISO discrete transfer function ``(b, a)`` (in ``z^-1``) stepped one sample at a time, from rest.

    ``x' = A x + B u``, ``y = C x + D u`` with the controllable canonical realisation of
    :func:`scipy.signal.tf2ss`.
    """

    def __init__(self, ba: tuple):
        b, a = (np.asarray(v, dtype=float) for v in ba)
        n = max(len(b), len(a))
        b, a = np.pad(b, (0, n - len(b))), np.pad(a, (0, n - len(a)))
        self.A, self.B, self.C, self.D = signal.tf2ss(b, a)
        self.D = float(self.D[0, 0])
        self.x = np.zeros(self.A.shape[0])

    def step(self, u: float) -> float:
        """Advance by one input sample; return the output of this sample."""
        y = float(self.C[0] @ self.x) + self.D * u
        self.x = self.A @ self.x + self.B[:, 0] * u
        return y
