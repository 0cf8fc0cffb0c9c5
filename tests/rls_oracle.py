"""Test oracle: the original numpy implementation of RLS (eqs. 10-13), kept only to check the compiled kernel.

Verbatim the pure-numpy ``RecursiveLeastSquares`` that :mod:`adaptive_ff.identification.rls` replaced (issue 5);
used by tests/test_rls.py, tests/test_properties.py and benchmarks/rls.py. Not part of the package.
"""

from __future__ import annotations

import math

import numpy as np

from plant.errors import ParameterError, SignalError, check_finite_scalar

__all__ = ["NumpyRLS"]

FORGETTING = ("exponential", "directional")


class NumpyRLS:
    """Recursive least-squares estimator with forgetting factor ``lam``, eqs. 10-13.

    Parameters
    ----------
    n_params : int
        Number of parameters ``p`` (>= 1).
    lam : float or array_like, shape (p,), keyword-only
        Forgetting factor in (0, 1]; 1 = no forgetting. The paper uses 0.85 on
        its noisy robot data; 0.98-0.999 is usual for slow drift. An array
        gives each parameter its own factor (vector forgetting, exponential
        scheme only; see Notes).
    P0 : float or array_like, shape (p, p), keyword-only
        Initial covariance; a scalar means ``P0*I``. Default 1e4 ("large", as in
        the paper). Must be symmetric positive definite.
    theta0 : array_like, shape (p,), keyword-only
        Initial estimate, default zeros (as in the paper).
    forgetting : {"exponential", "directional"}, keyword-only
        ``"exponential"`` (default): eqs. 10-13, every direction of ``P`` is
        divided by ``lam`` at every update, so without excitation ``P`` grows
        like ``lam**-k`` (estimator windup). ``"directional"``: directional
        forgetting (see Notes); information is forgotten only along the current
        regressor, so ``P`` stays bounded without excitation.
    P_max : float, keyword-only
        Bound on ``trace(P)`` (covariance upper bound). When an update would
        exceed it, that update forgets nothing (``lam = 1`` for that step).
        Default: none for ``"exponential"`` (eqs. 10-13 unchanged),
        ``trace(P0)`` for ``"directional"`` (forgetting never makes the estimate
        less certain than the initial guess).
    bounds : tuple (lower, upper) of array_like, shape (p,), keyword-only
        Box of admissible parameters (``-inf``/``inf`` allowed). After each
        update ``theta`` is projected onto it (see Notes). Default: none.

    Attributes
    ----------
    theta : ndarray, shape (p,)
        Current estimate (public, read it any time).
    P : ndarray, shape (p, p)
        Current covariance (exactly symmetric).
    lam : float or ndarray, shape (p,)
        Forgetting factor(s).
    n_updates : int
        Accepted updates.
    n_projected : int
        Updates after which ``theta`` had to be projected onto ``bounds``.

    Raises
    ------
    ParameterError
        ``lam`` outside (0, 1], bad ``n_params``, ``P0``/``theta0`` of the wrong
        shape, non-finite, or (``P0``) not symmetric positive definite; unknown
        ``forgetting``; ``P_max`` not > 0; ``bounds`` of the wrong shape, NaN,
        lower > upper, or ``theta0`` outside them.

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

    **Vector forgetting** (``lam`` an array): before each measurement update
    the covariance is inflated as ``P <- D P D`` with ``D = diag(lam)**-1/2``,
    then updated with unit weight (``s = 1 + phi @ P @ phi``); for equal
    factors this is exactly eqs. 10-13 (the division by ``lam`` moved in front
    of the update). Parameters known to vary slowly (an inertia) can so keep a
    long memory while friction levels follow drift (Sælid & Foss, "Adaptive
    controllers with a vector variable forgetting factor", IEEE CDC 1983;
    Vahidi, Stefanopoulou, Peng, Vehicle System Dynamics 43(1), 2005).

    **Directional forgetting** (windup protection; Kulhavý, "Restricted
    exponential forgetting in real-time identification", Automatica 23(5),
    1987; in the form of Bittanti, Bolzern, Campi, "Convergence and exponential
    convergence of identification algorithms with directional forgetting
    factor", Automatica 26(5), 1990)::

        r     = phi @ P @ phi
        beta  = lam - (1 - lam)/r        (beta = 1 if r == 0)
        P     = P - beta*(P @ phi)(P @ phi)^T / (1 + beta*r)
        theta = theta + (P @ phi) * e    (with the updated P)

    The information matrix ``R = P^-1`` changes by ``beta*phi*phi^T`` only:
    along ``phi`` the quadratic form ``phi @ P @ phi`` converges to
    ``(1 - lam)/lam`` (the same memory as exponential forgetting, about
    ``1/(1 - lam)`` samples), and in every direction ``P``-orthogonal to
    ``phi`` it is left unchanged. With constant ``phi`` (constant velocity) or
    ``phi = 0`` (standstill) ``P`` therefore stays bounded, where exponential
    forgetting multiplies the unexcited part by ``1/lam`` per update. For
    ``lam = 1`` both schemes are the ordinary RLS. ``1 + beta*r`` equals
    ``lam*(1 + r) > 0``, so ``P`` stays positive definite. The trace bound
    ``P_max`` guards the one remaining growth path (a regressor that is
    tiny in some direction lets ``P`` grow like ``1/|phi|**2`` there): an update
    that would exceed it uses ``beta = 1`` (no forgetting).

    **Projection** onto ``bounds`` in the metric of ``P^-1`` (the metric in
    which RLS is a steepest-descent method; Goodwin & Sin, *Adaptive
    Filtering, Prediction and Control*, 1984, Sec. 3.3.7; Ioannou & Sun,
    *Robust Adaptive Control*, 1996, Sec. 4.11.3): for the most violated bound
    ``theta_i -> b_i``, ``theta <- theta - P[:, i]*(theta_i - b_i)/P[i, i]``
    (exact for one active bound), repeated at most ``p`` times, then a final
    clip. ``P`` is not changed.
    """

    def __init__(self, n_params: int, *, lam: float = 1.0, P0=1e4, theta0=None, forgetting: str = "exponential",
                 P_max: float | None = None, bounds=None):
        if isinstance(n_params, bool) or not isinstance(n_params, (int, np.integer)) or n_params < 1:
            raise ParameterError(f"n_params must be an integer >= 1, got {n_params!r}")
        p = int(n_params)
        if np.ndim(lam) == 0:
            lam = check_finite_scalar("lam", lam)
            if not 0.0 < lam <= 1.0:
                raise ParameterError(f"lam must be in (0, 1], got {lam!r}")
            self._d = None
        else:
            lam = np.array(lam, dtype=float).reshape(-1)
            if lam.shape != (p,) or not np.all((lam > 0.0) & (lam <= 1.0)):
                raise ParameterError(f"lam must be a number or {p} numbers in (0, 1], got {lam!r}")
            if forgetting != "exponential":
                raise ParameterError("a vector lam needs forgetting='exponential'")
            d = lam ** -0.5
            self._d = np.outer(d, d)  # exactly symmetric inflation factors
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
        if forgetting not in FORGETTING:
            raise ParameterError(f"forgetting must be one of {FORGETTING}, got {forgetting!r}")
        if P_max is None:  # issue 12: windup-safe default for both schemes (math.inf: the paper's plain update)
            P_max = float(np.trace(P))
        elif not (isinstance(P_max, (int, float, np.integer, np.floating)) and not isinstance(P_max, bool)
                  and P_max > 0):
            raise ParameterError(f"P_max must be a number > 0, got {P_max!r}")
        self._lower = self._upper = None
        if bounds is not None:
            try:
                lower, upper = bounds
            except (TypeError, ValueError):
                raise ParameterError(f"bounds must be a pair (lower, upper), got {bounds!r}") from None
            lower = np.broadcast_to(np.asarray(lower, dtype=float), (p,)).copy()
            upper = np.broadcast_to(np.asarray(upper, dtype=float), (p,)).copy()
            if np.isnan(lower).any() or np.isnan(upper).any() or np.any(lower > upper):
                raise ParameterError(f"bounds need lower <= upper without NaN, got {lower!r}, {upper!r}")
            if np.any(theta < lower) or np.any(theta > upper):
                raise ParameterError(f"theta0 = {theta!r} lies outside the bounds")
            self._lower, self._upper = lower, upper
        self.n_params = p
        self.lam = lam
        self.forgetting = forgetting
        self.P_max = float(P_max)
        self.n_rejected = 0
        self.theta = theta
        self.P = P
        self.n_updates = 0
        self.n_projected = 0

    def __repr__(self) -> str:
        return (f"NumpyRLS(n_params={self.n_params}, lam={self.lam!r}, forgetting={self.forgetting!r}, "
                f"n_updates={self.n_updates})")

    @property
    def bounds(self) -> tuple | None:
        """``(lower, upper)`` arrays of the projection box, or None."""
        return None if self._lower is None else (self._lower.copy(), self._upper.copy())

    def _check(self, phi, y) -> tuple[np.ndarray, float]:
        phi = np.asarray(phi, dtype=float)
        if phi.shape != (self.n_params,):
            raise SignalError(f"phi must have shape ({self.n_params},), got {phi.shape}")
        if not math.isfinite(float(phi.dot(phi))) and not np.all(np.isfinite(phi)):  # fast path first
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
        with np.errstate(over="ignore", invalid="ignore"):
            e = y - float(phi @ self.theta)
            Pphi = (self.P * self._d if self._d is not None else self.P) @ phi
            ok = math.isfinite(e * e) and math.isfinite(float(phi @ Pphi)) and math.isfinite(float(Pphi @ Pphi))
        if not ok:  # issue 12: an update that would overflow is refused, the state unchanged, and counted
            self.n_rejected += 1
            raise SignalError(f"sample refused: its update would overflow (y = {y!r})")
        P = self.P
        Pphi = P @ phi
        r = float(phi @ Pphi)
        lam = self.lam
        if self._d is not None:
            Pi = P * self._d  # inflate (vector forgetting), then a unit-weight update
            if float(np.trace(Pi)) > self.P_max:
                Pi = P  # covariance bound reached: no forgetting in this update
            Pphi = Pi @ phi
            s = 1.0 + float(phi @ Pphi)
            P = Pi - np.outer(Pphi, Pphi) / s
            theta = self.theta + Pphi * (e / s)
        elif self.forgetting == "exponential":
            s = lam + r
            P = P - np.outer(Pphi, Pphi) / s
            if lam < 1.0:
                if float(np.trace(P)) / lam <= self.P_max:
                    P = P / lam
                else:  # covariance bound reached: this update forgets nothing (ordinary RLS step)
                    s = 1.0 + r
                    P = self.P - np.outer(Pphi, Pphi) / s
            theta = self.theta + Pphi * (e / s)
        else:
            beta = lam - (1.0 - lam) / r if r > 0.0 else 1.0
            den = 1.0 + beta * r
            if beta < 0.0:
                # trace after the update: trace(P) - beta*|P phi|^2/den; over the bound -> no forgetting
                if float(np.trace(P)) - beta * float(Pphi @ Pphi) / den > self.P_max:
                    beta, den = 1.0, 1.0 + r
            P = P - np.outer(Pphi, Pphi) * (beta / den)
            theta = self.theta + Pphi * (e / den)  # = P_new @ phi * e
        if self._lower is not None:
            theta = self._project(theta, P)
        self.theta = theta
        self.P = P
        self.n_updates += 1
        return e

    def _project(self, theta: np.ndarray, P: np.ndarray) -> np.ndarray:
        lo, hi = self._lower, self._upper
        viol = np.maximum(lo - theta, 0.0) + np.maximum(theta - hi, 0.0)
        if not viol.any():
            return theta
        self.n_projected += 1
        theta = theta.copy()
        d = np.sqrt(np.diag(P))
        for _ in range(self.n_params):
            viol = np.maximum(lo - theta, 0.0) + np.maximum(theta - hi, 0.0)
            if not viol.any():
                break
            i = int(np.argmax(viol / d))
            b = lo[i] if theta[i] < lo[i] else hi[i]
            theta = theta - P[:, i] * ((theta[i] - b) / P[i, i])
            theta[i] = b
        return np.clip(theta, lo, hi)
