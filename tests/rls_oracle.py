"""Test oracle of the RLS with forgetting (eqs. 10-13), in forms the package does not use.

:class:`adaptive_ff.identification.rls.RecursiveLeastSquares` propagates the covariance ``P`` with rank-one
downdates. The oracle reaches the same estimates by two other routes:

* :func:`weighted_ls_path`: the closed form. With exponential forgetting and no covariance bound the estimate after
  ``k`` samples is the minimiser of the exponentially weighted sum of squares plus the forgotten prior,
  ``sum_j lam**(k-j) (y_j - phi_j theta)**2 + lam**k (theta - theta0)^T P0^-1 (theta - theta0)``, solved here
  for every ``k`` by :func:`numpy.linalg.lstsq` on the whole weighted window (Ljung & Söderström, *Theory and
  Practice of Recursive Identification*, 1983, Sec. 2.2).
* :class:`InformationRLS`: the recursion in information form. It carries ``R = P^-1`` and ``theta``; every
  forgetting scheme of the package's class Notes is a statement about ``R`` (exponential: ``R <- lam R + phi
  phi^T``; vector: ``R <- S R S + phi phi^T``, ``S = diag(lam)**1/2``; directional: ``R <- R + beta phi phi^T``),
  the estimate moves by ``R_new^-1 phi e`` (a linear solve), the covariance bound is tested on
  ``trace(R_new^-1)``, and the projection onto the box solves the equality-constrained least-distance problem
  in the metric ``R`` through its KKT system.

Used by tests/adaptive_ff_layer/test_rls.py, tests/controllers_layer/test_properties.py and benchmarks/rls.py (as ``NumpyRLS``). Not part of the
package.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["InformationRLS", "NumpyRLS", "weighted_ls_path"]


def weighted_ls_path(Phi, Y, *, lam: float, P0: float, theta0=None) -> tuple:
    """Exponentially weighted least squares after every sample, each solved on its whole window.

    Parameters
    ----------
    Phi : array_like, shape (N, p)
        Regressors.
    Y : array_like, shape (N,)
        Outputs.
    lam : float
        Forgetting factor in (0, 1].
    P0 : float
        Prior covariance scale (prior information ``I/P0``).
    theta0 : array_like, shape (p,), optional
        Prior estimate, default zeros.

    Returns
    -------
    theta : ndarray, shape (N, p)
        Row ``k``: the estimate after samples ``0..k``.
    P : ndarray, shape (p, p)
        Inverse of the weighted information matrix after all ``N`` samples.
    e : ndarray, shape (N,)
        A-priori errors ``y_k - phi_k theta_(k-1)`` (``theta0`` before the first sample).
    """
    Phi = np.asarray(Phi, dtype=float)
    Y = np.asarray(Y, dtype=float)
    n, p = Phi.shape
    theta0 = np.zeros(p) if theta0 is None else np.asarray(theta0, dtype=float)
    out = np.empty((n, p))
    for k in range(n):
        age = k - np.arange(k + 1)  # samples since each row
        sw = np.sqrt(lam ** age.astype(float))
        prior = math.sqrt(lam ** (k + 1) / P0)
        A = np.vstack([Phi[:k + 1] * sw[:, None], prior * np.eye(p)])
        b = np.concatenate([Y[:k + 1] * sw, prior * theta0])
        out[k] = np.linalg.lstsq(A, b, rcond=None)[0]
    weights = lam ** (n - 1 - np.arange(n)).astype(float)
    info = (Phi * weights[:, None]).T @ Phi + lam ** n / P0 * np.eye(p)
    before = np.vstack([theta0, out[:-1]])
    return out, np.linalg.inv(info), Y - np.einsum("ij,ij->i", Phi, before)


class InformationRLS:
    """RLS with the package's forgetting schemes, covariance bound and projection, carried in information form.

    Parameters
    ----------
    n_params : int
        Number of parameters ``p``.
    lam : float or array_like, shape (p,), keyword-only
        Forgetting factor(s); an array is vector forgetting.
    P0 : float or array_like, shape (p, p), keyword-only
        Initial covariance (a scalar means ``P0*I``).
    theta0 : array_like, shape (p,), keyword-only
        Initial estimate, default zeros.
    forgetting : {"exponential", "directional"}, keyword-only
    P_max : float, keyword-only
        Bound on ``trace(P)``; default ``trace(P0)``.
    bounds : tuple (lower, upper), keyword-only
        Projection box, default none.

    Notes
    -----
    No input checks: the package's class validates, the oracle only computes. ``P`` is ``inv(R)``, formed when
    asked for.
    """

    def __init__(self, n_params: int, *, lam=1.0, P0=1e4, theta0=None, forgetting: str = "exponential",
                 P_max: float | None = None, bounds=None):
        p = int(n_params)
        P0 = np.asarray(P0, dtype=float)
        P0 = P0 * np.eye(p) if P0.ndim == 0 else P0
        self.R = np.linalg.inv(P0)
        self.theta = np.zeros(p) if theta0 is None else np.array(theta0, dtype=float)
        self.lam = lam
        self.vector = np.ndim(lam) > 0
        self.forgetting = forgetting
        self.P_max = float(np.trace(P0)) if P_max is None else float(P_max)
        self.box = None if bounds is None else tuple(np.broadcast_to(np.asarray(b, dtype=float), (p,))
                                                     for b in bounds)
        self.n_updates = 0
        self.n_projected = 0

    @property
    def P(self) -> np.ndarray:
        """The covariance ``R^-1``, shape (p, p)."""
        return np.linalg.inv(self.R)

    def _trace_P(self, R: np.ndarray) -> float:
        return float(np.trace(np.linalg.inv(R)))

    def _forget(self, phi: np.ndarray) -> np.ndarray:
        """The information matrix after this sample (the forgetting scheme, with the covariance bound)."""
        R, lam, news = self.R, self.lam, np.outer(phi, phi)
        plain = R + news  # ordinary RLS: nothing forgotten
        if self.vector:
            s = np.sqrt(np.asarray(lam, dtype=float))
            faded = R * np.outer(s, s)  # S R S: P inflated to D P D
            return faded + news if self._trace_P(faded) <= self.P_max else plain
        if self.forgetting == "exponential":
            if lam == 1.0:
                return plain
            cand = lam * R + news
            return cand if self._trace_P(cand) <= self.P_max else plain
        r = float(phi @ np.linalg.solve(R, phi))  # phi^T P phi
        beta = lam - (1.0 - lam) / r if r > 0.0 else 1.0
        cand = R + beta * news
        return plain if (beta < 0.0 and self._trace_P(cand) > self.P_max) else cand

    def update(self, phi, y) -> float:
        """One sample; return the a-priori error ``y - phi @ theta``."""
        phi = np.asarray(phi, dtype=float)
        e = float(y) - float(phi @ self.theta)
        R_new = self._forget(phi)
        theta = self.theta + np.linalg.solve(R_new, phi) * e
        self.R = R_new
        if self.box is not None:
            theta = self._project(theta)
        self.theta = theta
        self.n_updates += 1
        return e

    def _project(self, theta: np.ndarray) -> np.ndarray:
        """One active bound at a time, the most violated (in standard deviations) first, then a final clip."""
        lo, hi = self.box
        target = np.clip(theta, lo, hi)
        if np.array_equal(target, theta):
            return theta
        self.n_projected += 1
        p = theta.size
        sd = np.sqrt(np.diag(self.P))
        for _ in range(p):
            miss = np.abs(np.clip(theta, lo, hi) - theta)
            if not miss.any():
                break
            i = int(np.argmax(miss / sd))
            # least R-distance from theta with coordinate i on its bound: KKT system of
            # min (t - theta)^T R (t - theta) s.t. t_i = b
            K = np.zeros((p + 1, p + 1))
            K[:p, :p] = self.R
            K[i, p] = K[p, i] = 1.0
            b = min(max(theta[i], lo[i]), hi[i])
            theta = np.linalg.solve(K, np.append(self.R @ theta, b))[:p]
            theta[i] = b
        return np.clip(theta, lo, hi)


#: The name benchmarks/rls.py times the oracle under (a plain numpy RLS, for comparison with the compiled one).
NumpyRLS = InformationRLS
