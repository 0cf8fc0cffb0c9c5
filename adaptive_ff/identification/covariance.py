r"""Parameter covariance under correlated residuals: the Newey-West (HAC) sandwich for least squares.

The Gauss-Newton covariance ``s**2 (G^T G)^-1`` of a least-squares fit
(Ljung, *System Identification*, 2nd ed., Sec. 9.3) assumes white residuals.
Free-run (output-error) residuals are not white: a parameter error, the input
reconstruction between samples and the breakaway jitter make them wander
slowly, and the white-noise formula then understates the uncertainty many
times over. The heteroscedasticity- and autocorrelation-consistent (HAC)
covariance keeps the least-squares estimate and replaces the middle of the
sandwich by a Bartlett-weighted sum of the score autocovariances:

.. math::

    \operatorname{cov}(\hat x) = (G^T G)^{-1} \Big(\sum_{|l| \le L} (1 - \tfrac{|l|}{L+1})
        \sum_t g_t r_t\, r_{t-l} g_{t-l}^T\Big) (G^T G)^{-1}

(Newey & West, *Econometrica* 55(3), 1987), with the bandwidth ``L`` by
Andrews' AR(1) plug-in rule ``L = 1.1447 (alpha n)^{1/3}``,
``alpha = 4 rho^2/(1-rho)^4`` from the lag-one autocorrelation ``rho`` of the
residuals (Andrews, *Econometrica* 59(3), 1991, eqs. 6.2 and 6.4).

Neither sees the error of a fit whose cost is rough (the free-run output at
breakaway): :func:`moving_block_resample` draws the residual series of a
residual bootstrap (Künsch, *Ann. Statist.* 17(3), 1989), used by
:func:`adaptive_ff.identification.physical_id.fit_physical` to refit
re-simulated records.
"""

from __future__ import annotations

import math

import numpy as np

from plant.errors import ParameterError, SignalError

__all__ = ["hac_covariance", "andrews_bandwidth", "moving_block_resample"]


def andrews_bandwidth(r) -> int:
    """Bartlett-kernel bandwidth (lags) by Andrews' AR(1) plug-in rule.

    Parameters
    ----------
    r : array_like, shape (n,)
        Residuals (any unit), n >= 3.

    Returns
    -------
    int
        ``L = ceil(1.1447 (alpha n)^(1/3))`` with ``alpha = 4 rho^2 / (1 - rho)^4``, ``rho`` the lag-one
        autocorrelation of ``r`` clipped to [0, 0.99]; at most ``n - 1``.

    Raises
    ------
    SignalError
        Fewer than 3 values, or non-finite values.

    Notes
    -----
    Andrews (1991), *Econometrica* 59(3), 817-858, eqs. 6.2 and 6.4 (Bartlett kernel).
    """
    r = np.asarray(r, dtype=float).reshape(-1)
    if r.shape[0] < 3 or not np.all(np.isfinite(r)):
        raise SignalError(f"residuals must be >= 3 finite values, got shape {r.shape}")
    rc = r - r.mean()
    den = float(rc @ rc)
    rho = float(rc[1:] @ rc[:-1]) / den if den > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    alpha = 4.0 * rho**2 / (1.0 - rho) ** 4
    return int(min(max(math.ceil(1.1447 * (alpha * r.shape[0]) ** (1.0 / 3.0)), 0), r.shape[0] - 1))


def hac_covariance(G, r, *, lags: int | None = None) -> tuple[np.ndarray, int]:
    """Newey-West covariance of least-squares parameters with residuals ``r`` and Jacobian ``G``.

    Parameters
    ----------
    G : array_like, shape (n, p)
        Jacobian of the residuals with respect to the parameters at the optimum.
    r : array_like, shape (n,)
        Residuals at the optimum, in time order.
    lags : int or None, keyword-only
        Bartlett bandwidth ``L`` (>= 0); default :func:`andrews_bandwidth` of ``r``.

    Returns
    -------
    cov : ndarray, shape (p, p)
        ``(G^T G)^-1 S (G^T G)^-1`` with ``S`` the Bartlett-weighted score autocovariance sum
        (module docstring), times ``n/(n - p)`` (small-sample degrees of freedom).
    lags : int
        The bandwidth used.

    Raises
    ------
    SignalError
        Shapes do not match or values are not finite.
    ParameterError
        ``lags`` not an integer >= 0.
    numpy.linalg.LinAlgError
        ``G^T G`` is singular.

    Notes
    -----
    Newey & West (1987), *Econometrica* 55(3), 703-708; with ``lags = 0`` it is White's
    heteroscedasticity-consistent covariance (White, *Econometrica* 48(4), 1980).
    """
    G = np.asarray(G, dtype=float)
    r = np.asarray(r, dtype=float).reshape(-1)
    if G.ndim != 2 or G.shape[0] != r.shape[0] or not (np.all(np.isfinite(G)) and np.all(np.isfinite(r))):
        raise SignalError(f"G must be finite (n, p) and r finite (n,), got {G.shape} and {r.shape}")
    n, p = G.shape
    if lags is None:
        lags = andrews_bandwidth(r)
    if isinstance(lags, bool) or not isinstance(lags, (int, np.integer)) or lags < 0:
        raise ParameterError(f"lags must be an integer >= 0, got {lags!r}")
    lags = int(min(lags, n - 1))
    score = G * r[:, None]
    S = score.T @ score
    for lag in range(1, lags + 1):
        g = score[lag:].T @ score[:-lag]
        S += (1.0 - lag / (lags + 1.0)) * (g + g.T)
    A = np.linalg.inv(G.T @ G)
    return A @ S @ A * (n / max(n - p, 1)), lags


def moving_block_resample(r, n_out: int, *, block: int, rng: np.random.Generator) -> np.ndarray:
    """A moving-block bootstrap series: blocks of ``block`` consecutive residuals, drawn with replacement.

    Parameters
    ----------
    r : array_like, shape (n,)
        Residuals in time order (any unit), finite, ``n >= 1``.
    n_out : int
        Length of the series returned, >= 1.
    block : int, keyword-only
        Block length, ``1 <= block``; clipped to ``n`` (``1``: the i.i.d. residual bootstrap).
    rng : numpy.random.Generator, keyword-only
        Source of the block starts (seed it for a reproducible series).

    Returns
    -------
    ndarray, shape (n_out,)
        ``ceil(n_out/block)`` blocks ``r[s:s+block]``, each start ``s`` uniform on ``0 .. n - block``,
        concatenated and cut to ``n_out``: the series keeps the correlation of ``r`` within a block.

    Raises
    ------
    SignalError
        ``r`` empty or not finite.
    ParameterError
        ``n_out`` or ``block`` not an integer >= 1, or ``rng`` not a numpy Generator.

    Notes
    -----
    Künsch (1989), *Ann. Statist.* 17(3), 1217-1241; Lahiri, *Resampling Methods for Dependent Data*
    (Springer, 2003), Sec. 2.5.
    """
    r = np.asarray(r, dtype=float).reshape(-1)
    if r.shape[0] < 1 or not np.all(np.isfinite(r)):
        raise SignalError(f"residuals must be >= 1 finite values, got shape {r.shape}")
    for name, v in (("n_out", n_out), ("block", block)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ParameterError(f"{name} must be an integer >= 1, got {v!r}")
    if not isinstance(rng, np.random.Generator):
        raise ParameterError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    n, block = r.shape[0], int(min(block, r.shape[0]))
    starts = rng.integers(0, n - block + 1, size=-(-int(n_out) // block))
    return r[(starts[:, None] + np.arange(block)[None, :]).reshape(-1)[:n_out]]
