"""Recursive least squares with exponential forgetting (eqs. 10-13)."""

from __future__ import annotations

import math

import numpy as np

from plant.errors import ParameterError, SignalError, check_finite_scalar

__all__ = ["RecursiveLeastSquares"]


class RecursiveLeastSquares:
    """Recursive least-squares estimator with forgetting factor ``lam``, eqs. 10-13.

    Parameters
    ----------
    n_params : int
        Number of parameters ``p`` (>= 1).
    lam : float, keyword-only
        Forgetting factor in (0, 1]; 1 = no forgetting. The paper uses 0.85 on
        its noisy robot data; 0.98-0.999 is usual for slow drift.
    P0 : float or array_like, shape (p, p), keyword-only
        Initial covariance; a scalar means ``P0*I``. Default 1e4 ("large", as in
        the paper). Must be symmetric positive definite.
    theta0 : array_like, shape (p,), keyword-only
        Initial estimate, default zeros (as in the paper).

    Attributes
    ----------
    theta : ndarray, shape (p,)
        Current estimate (public, read it any time).
    P : ndarray, shape (p, p)
        Current covariance (exactly symmetric).
    lam : float
        Forgetting factor.
    n_updates : int
        Accepted updates.

    Raises
    ------
    ParameterError
        ``lam`` outside (0, 1], bad ``n_params``, or ``P0``/``theta0`` of the wrong
        shape, non-finite, or (``P0``) not symmetric positive definite.

    Notes
    -----
    With ``phi`` the regressor and ``y`` the output (paper: X and w)::

        e     = y - phi @ theta                      (a-priori error, eq. 10)
        s     = lam + phi @ P @ phi
        gamma = P @ phi / s                          (eq. 12)
        theta = theta + gamma * e                    (eq. 11)
        P     = (P - (P @ phi)(P @ phi)^T / s) / lam (eq. 13)

    Eq. 13 is written ``(I - gamma phi^T) P / lam``; that product is not
    symmetric in floating point and drifts over long runs. The form above,
    algebraically identical, subtracts a symmetric rank-one term and so keeps
    ``P`` exactly symmetric (Ljung & Söderström, *Theory and Practice of
    Recursive Identification*, 1983, Sec. 2.2; Haykin, *Adaptive Filter
    Theory*, Ch. 10). With ``lam = 1``, ``P0 = I/r`` and ``theta0 = 0`` the
    estimate after N updates equals the ridge-regularised batch solution
    ``argmin ||X theta - y||**2 + r*||theta||**2`` (see
    :func:`adaptive_ff.fit_ls` with ``ridge=r``).
    """

    def __init__(self, n_params: int, *, lam: float = 1.0, P0=1e4, theta0=None):
        if isinstance(n_params, bool) or not isinstance(n_params, (int, np.integer)) or n_params < 1:
            raise ParameterError(f"n_params must be an integer >= 1, got {n_params!r}")
        p = int(n_params)
        lam = check_finite_scalar("lam", lam)
        if not 0.0 < lam <= 1.0:
            raise ParameterError(f"lam must be in (0, 1], got {lam!r}")
        if np.ndim(P0) == 0:
            p0 = check_finite_scalar("P0", P0)
            if p0 <= 0:
                raise ParameterError(f"P0 must be > 0, got {P0!r}")
            P = p0 * np.eye(p)
        else:
            P = np.array(P0, dtype=float)
            if P.shape != (p, p):
                raise ParameterError(f"P0 must have shape ({p}, {p}), got {P.shape}")
            if not np.all(np.isfinite(P)) or not np.allclose(P, P.T, rtol=1e-12, atol=0.0):
                raise ParameterError("P0 must be finite and symmetric")
            P = 0.5 * (P + P.T)
            if np.linalg.eigvalsh(P)[0] <= 0:
                raise ParameterError("P0 must be positive definite")
        if theta0 is None:
            theta = np.zeros(p)
        else:
            theta = np.array(theta0, dtype=float).reshape(-1)
            if theta.shape != (p,) or not np.all(np.isfinite(theta)):
                raise ParameterError(f"theta0 must be {p} finite values, got {theta0!r}")
        self.n_params = p
        self.lam = lam
        self.theta = theta
        self.P = P
        self.n_updates = 0

    def __repr__(self) -> str:
        return f"RecursiveLeastSquares(n_params={self.n_params}, lam={self.lam!r}, n_updates={self.n_updates})"

    def _check(self, phi, y) -> tuple[np.ndarray, float]:
        phi = np.asarray(phi, dtype=float)
        if phi.shape != (self.n_params,):
            raise SignalError(f"phi must have shape ({self.n_params},), got {phi.shape}")
        if not np.all(np.isfinite(phi)):
            raise SignalError(f"phi has a non-finite entry: {phi!r}")
        y = float(y)
        if not math.isfinite(y):
            raise SignalError(f"y must be finite, got {y!r}")
        return phi, y

    def predict(self, phi) -> float:
        """A-priori prediction ``phi @ theta`` (same unit as y)."""
        phi, _ = self._check(phi, 0.0)
        return float(phi @ self.theta)

    def update(self, phi, y) -> float:
        """Process one sample; return the a-priori error ``y - phi @ theta``.

        Parameters
        ----------
        phi : array_like, shape (p,)
            Regressor.
        y : float
            Measured output.

        Returns
        -------
        float
            A-priori prediction error (eq. 10).

        Raises
        ------
        SignalError
            Wrong shape, or a NaN/inf in ``phi`` or ``y``; the state is left unchanged.
        """
        phi, y = self._check(phi, y)
        e = y - float(phi @ self.theta)
        Pphi = self.P @ phi
        s = self.lam + float(phi @ Pphi)
        self.theta = self.theta + Pphi * (e / s)
        self.P = (self.P - np.outer(Pphi, Pphi) / s) / self.lam
        self.n_updates += 1
        return e
