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
residual bootstrap (Künsch, *Ann. Statist.* 17(3), 1989), and
:func:`parametric_block_bootstrap` refits records re-simulated from the
estimate with those residuals added, used by
:func:`adaptive_ff.identification.physical_id.fit_physical` (output error) and
:func:`controllers.experiments.closed_loop_id.fit_closed_loop` (closed loop).
:func:`circular_block_resample` (Politis & Romano 1992) with the automatic block length of
:func:`politis_white_block` (Politis & White 2004, corrected by Patton, Politis & White 2009) drives
:func:`residual_block_bootstrap`, the bootstrap of a fit's own residuals behind the standard errors of
:func:`adaptive_ff.identification.identify.identify` (:mod:`adaptive_ff.identification.uncertainty`).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from plant.errors import FrictionError, ParameterError, SignalError, check_optional

__all__ = ["hac_covariance", "andrews_bandwidth", "moving_block_resample", "block_wild_resample",
           "parametric_block_bootstrap", "BootstrapSettings", "BOOTSTRAP_SCHEMES", "DEFAULT_N_BOOTSTRAP",
           "BootstrapResult", "bootstrap_t_quantile", "circular_block_resample", "politis_white_block",
           "residual_block_bootstrap", "BIAS_NEGLIGIBLE", "bias_corrected_interval"]


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
    r : array_like, shape (n,) or (n, c)
        Residuals in time order (any unit), finite, ``n >= 1``; with ``c`` channels (columns) the rows are
        resampled together (the same blocks for every channel: their cross-correlation is kept).
    n_out : int
        Length of the series returned, >= 1.
    block : int, keyword-only
        Block length, ``1 <= block``; clipped to ``n`` (``1``: the i.i.d. residual bootstrap).
    rng : numpy.random.Generator, keyword-only
        Source of the block starts (seed it for a reproducible series).

    Returns
    -------
    ndarray, shape (n_out,) or (n_out, c)
        ``ceil(n_out/block)`` blocks ``r[s:s+block]``, each start ``s`` uniform on ``0 .. n - block``,
        concatenated and cut to ``n_out``: the series keeps the correlation of ``r`` within a block.

    Raises
    ------
    SignalError
        ``r`` empty, not finite, or of more than two dimensions.
    ParameterError
        ``n_out`` or ``block`` not an integer >= 1, or ``rng`` not a numpy Generator.

    Notes
    -----
    Künsch (1989), *Ann. Statist.* 17(3), 1217-1241; Lahiri, *Resampling Methods for Dependent Data*
    (Springer, 2003), Sec. 2.5.
    """
    r, n, block = _resample_args(r, n_out, block, rng)
    starts = rng.integers(0, n - block + 1, size=-(-int(n_out) // block))
    return r[(starts[:, None] + np.arange(block)[None, :]).reshape(-1)[:n_out]]


def block_wild_resample(r, n_out: int, *, block: int, rng: np.random.Generator) -> np.ndarray:
    """A block wild bootstrap series: the residuals kept in place, each block of them multiplied by a random sign.

    Parameters
    ----------
    r : array_like, shape (n,) or (n, c)
        Residuals in time order (any unit), finite, ``n >= 1``; with ``c`` channels a row's channels share its sign.
    n_out : int
        Length of the series returned, ``1 <= n_out <= n`` (the first ``n_out`` residuals are used).
    block : int, keyword-only
        Block length, >= 1 (clipped to ``n``; ``1``: the wild bootstrap of independent residuals).
    rng : numpy.random.Generator, keyword-only
        Source of the phase and the signs (seed it for a reproducible series).

    Returns
    -------
    ndarray, shape (n_out,) or (n_out, c)
        ``eta_k r_t`` for ``t < n_out``, ``k = floor((t + phase) / block)``, the ``eta_k`` independent signs
        (+1 or -1 with probability 1/2 each, Rademacher) and ``phase`` uniform on ``0 .. block-1``. Each
        residual stays at its own instant with its own size (the series keeps where the residuals are large,
        e.g. a model's errors at breakaway, and their correlation within a block); its mean is zero.

    Raises
    ------
    SignalError
        ``r`` empty, not finite, or of more than two dimensions.
    ParameterError
        ``n_out`` or ``block`` not an integer >= 1, ``n_out > n``, or ``rng`` not a numpy Generator.

    Notes
    -----
    The wild bootstrap (Wu, *Ann. Statist.* 14(4), 1986; Liu, *Ann. Statist.* 16(4), 1988; Rademacher weights:
    Davidson & Flachaire, *J. Econometrics* 146(1), 2008) with weights constant over blocks for dependent
    residuals (the block-wise dependent wild bootstrap, Shao, *J. Amer. Statist. Assoc.* 105(489), 2010).
    With ``block = 1`` and a linear least-squares refit the covariance of the refits over the signs is
    White's ``(X^T X)^-1 X^T diag(r**2) X (X^T X)^-1``.
    """
    r, n, block = _resample_args(r, n_out, block, rng)
    if n_out > n:
        raise ParameterError(f"n_out must be <= the number of residuals ({n}), got {n_out!r}")
    phase = int(rng.integers(0, block))
    k = (np.arange(int(n_out)) + phase) // block
    eta = rng.choice(np.array([-1.0, 1.0]), size=int(k[-1]) + 1)[k]
    return r[:n_out] * (eta if r.ndim == 1 else eta[:, None])


def _resample_args(r, n_out, block, rng) -> tuple:
    """The checked arguments of a block resampling: ``r`` as a float array, its length ``n`` and the block length
    cut to ``n``; the errors of :func:`moving_block_resample`."""
    r = np.asarray(r, dtype=float)
    if r.ndim == 0 or r.ndim > 2 or r.shape[0] < 1 or r.size < 1 or not np.all(np.isfinite(r)):
        raise SignalError(f"residuals must be >= 1 finite values of shape (n,) or (n, c), got shape {r.shape}")
    for name, v in (("n_out", n_out), ("block", block)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ParameterError(f"{name} must be an integer >= 1, got {v!r}")
    if not isinstance(rng, np.random.Generator):
        raise ParameterError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return r, r.shape[0], int(min(block, r.shape[0]))


#: Replicates of a block bootstrap by default (:class:`BootstrapSettings`; the eq. 4 residual block bootstrap of
#: :func:`adaptive_ff.identification.identify.identify`).
DEFAULT_N_BOOTSTRAP = 200

#: How a block bootstrap resamples the residuals: circular blocks (:func:`circular_block_resample`), moving blocks
#: (:func:`moving_block_resample`) or blocks kept in place with a random sign (:func:`block_wild_resample`).
BOOTSTRAP_SCHEMES = ("circular", "moving", "wild")


def _is_count(v, lo: int) -> bool:
    return not isinstance(v, bool) and isinstance(v, (int, np.integer)) and v >= lo


@dataclass(frozen=True, kw_only=True)
class BootstrapSettings:
    """The settings of a block bootstrap (keyword-only, validated): replicates, block length, seed, scheme.

    Taken by :func:`residual_block_bootstrap`'s callers
    (:func:`adaptive_ff.identification.uncertainty.regression_block_bootstrap`,
    :func:`adaptive_ff.identification.uncertainty.eq4_block_bootstrap`) and by :func:`parametric_block_bootstrap`.

    Parameters
    ----------
    n : int
        Number of replicates, >= 1 (default :data:`DEFAULT_N_BOOTSTRAP`, 200; a function may ask for more, e.g.
        2 for intervals).
    block : int or None
        Block length (samples), >= 1; None (default): the Politis-White length of the residuals
        (:func:`politis_white_block`; :func:`parametric_block_bootstrap` needs it given).
    seed : int
        Seed (>= 0) of the ``numpy.random.default_rng`` every draw comes from; default 0.
    scheme : {"circular", "moving", "wild"}
        How the residuals are resampled (:data:`BOOTSTRAP_SCHEMES`); default ``"circular"``.

    Raises
    ------
    ParameterError
        ``n`` not an integer >= 1, ``block`` neither None nor an integer >= 1, ``seed`` not an integer >= 0,
        unknown ``scheme`` (the message names the field and the value).
    """

    n: int = DEFAULT_N_BOOTSTRAP
    block: int | None = None
    seed: int = 0
    scheme: str = "circular"

    def __post_init__(self):
        if not _is_count(self.n, 1):
            raise ParameterError(f"n must be an integer >= 1, got {self.n!r}")
        if not (self.block is None or _is_count(self.block, 1)):
            raise ParameterError(f"block must be None or an integer >= 1, got {self.block!r}")
        if not _is_count(self.seed, 0):
            raise ParameterError(f"seed must be an integer >= 0, got {self.seed!r}")
        if self.scheme not in BOOTSTRAP_SCHEMES:
            raise ParameterError(f"scheme must be one of {BOOTSTRAP_SCHEMES}, got {self.scheme!r}")
        object.__setattr__(self, "n", int(self.n))
        object.__setattr__(self, "block", None if self.block is None else int(self.block))
        object.__setattr__(self, "seed", int(self.seed))

    def rng(self) -> np.random.Generator:
        """A fresh ``numpy.random.default_rng(seed)``: the source of every draw of one bootstrap."""
        return np.random.default_rng(self.seed)

    def resample(self):
        """The resampling function of ``scheme`` (signature of :func:`circular_block_resample`)."""
        return {"circular": circular_block_resample, "moving": moving_block_resample,
                "wild": block_wild_resample}[self.scheme]


@dataclass(frozen=True)
class BootstrapResult:
    """Result of :func:`parametric_block_bootstrap`.

    Attributes
    ----------
    stderr : ndarray, shape (p,)
        Root-mean-square deviation of the refits from the estimate, per parameter (units of the estimate);
        NaN when fewer than 2 refits are valid.
    bias : ndarray, shape (p,)
        Mean deviation of the refits from the estimate (NaN as ``stderr``).
    replicates : ndarray, shape (n_valid, p)
        The valid refits.
    n : int
        Refits tried.
    block : int
        Block length (samples) of the residual resampling.
    failures : tuple of str
        Why each dropped refit was dropped (an error's message, ``"non-finite"``, or ``"non-finite simulation"``
        for a replicate whose ``simulate`` draw was not finite).
    """

    stderr: np.ndarray
    bias: np.ndarray
    replicates: np.ndarray
    n: int
    block: int
    failures: tuple = ()

    @property
    def n_valid(self) -> int:
        """Number of valid refits."""
        return int(self.replicates.shape[0])

    def half_width(self, level: float = 0.95) -> np.ndarray:
        """Half-width of the two-sided ``level`` interval ``estimate ± t stderr``, shape (p,).

        ``t = bootstrap_t_quantile(n_valid, level)``: ``stderr`` is the RMS of ``n_valid`` refit deviations, so
        ``(estimate - truth) / stderr`` is Student-t with ``n_valid`` degrees of freedom when the refits'
        deviations have the distribution of the estimate's error (the bootstrap principle); ``1.96 stderr``
        would cover less (e.g. 90 % with 6 refits). NaN where ``stderr`` is NaN.

        Raises
        ------
        ParameterError
            ``level`` not in (0, 1).
        """
        if self.n_valid < 1:
            return np.full(self.stderr.shape, math.nan)
        return bootstrap_t_quantile(self.n_valid, level) * self.stderr


def bootstrap_t_quantile(n: int, level: float = 0.95) -> float:
    """Two-sided Student-t quantile ``t_{n, (1 + level)/2}`` for an error estimated from ``n`` refits.

    Parameters
    ----------
    n : int
        Degrees of freedom: the number of refits whose RMS deviation from the estimate is the standard error
        (:class:`BootstrapResult`), >= 1.
    level : float
        Nominal coverage of ``estimate ± t stderr``, in (0, 1). Default 0.95.

    Returns
    -------
    float
        The quantile (1.96 for ``n -> inf``; 2.45 for 6, 2.23 for 10 refits).

    Raises
    ------
    ParameterError
        ``n`` not an integer >= 1, or ``level`` not in (0, 1).

    Notes
    -----
    The studentised interval with ``n`` degrees of freedom: ``s**2 = mean(d_i**2)`` over ``n`` independent
    normal deviations of variance ``sigma**2`` is ``sigma**2 chi2_n / n`` (Student, *Biometrika* 6(1), 1908;
    Efron & Tibshirani, *An Introduction to the Bootstrap*, 1993, Sec. 12.5 on the size of ``n``).
    """
    from scipy.stats import t as student_t

    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"n must be an integer >= 1, got {n!r}")
    lv = float(level) if isinstance(level, (int, float, np.floating)) and not isinstance(level, bool) else math.nan
    if not 0.0 < lv < 1.0:
        raise ParameterError(f"level must be in (0, 1), got {level!r}")
    return float(student_t.ppf(0.5 + 0.5 * lv, int(n)))


#: A refits' mean shift of at most this many standard errors leaves the interval centred on the estimate: the
#: shift's own Monte Carlo error at 20 refits is about 0.22 standard errors, and correcting by it adds variance
#: and removes no bias (Efron & Tibshirani, *An Introduction to the Bootstrap*, 1993, Sec. 10.6).
BIAS_NEGLIGIBLE = 0.25


def bias_corrected_interval(value: float, bias: float, rms: float, extra: float, n: int,
                            level: float = 0.95) -> tuple[float, float, float]:
    """One parameter's bootstrap interval ``centre ± t stderr``, centred on the estimate less the refits' mean shift
    where that shift is not negligible.

    Parameters
    ----------
    value : float
        The estimate (the parameter's unit).
    bias : float
        The refits' mean deviation from the estimate (:attr:`BootstrapResult.bias`; same unit).
    rms : float
        The refits' root-mean-square deviation from the estimate (:attr:`BootstrapResult.stderr`; same unit).
    extra : float
        A share of the error the refits do not hold, added in quadrature (same unit, >= 0; 0 for none: e.g. the
        profiled input delay's, :func:`adaptive_ff.identification.delay_profile.delay_spread`).
    n : int
        Number of valid refits, >= 2.
    level : float
        Nominal coverage, in (0, 1). Default 0.95.

    Returns
    -------
    tuple of float
        ``(centre, stderr, t)``; the interval is ``centre ± t stderr``.

    Raises
    ------
    ParameterError
        ``n`` not an integer >= 2, or ``level`` not in (0, 1).

    Notes
    -----
    Where ``|bias| <= BIAS_NEGLIGIBLE * hypot(rms, extra)`` the interval is ``value ± t_n hypot(rms, extra)``: the
    estimate's error is a draw from the distribution the refits' deviations sample, the shift part of it
    (:func:`bootstrap_t_quantile`). Otherwise the centre is ``value - bias`` (Efron & Tibshirani 1993, Sec. 10.2)
    and its error ``(value - truth - bias) - (bias_hat - bias)`` is a new draw from that distribution less the mean
    of ``n`` draws from it: variance ``s**2 (1 + 1/n)``, with ``s**2 = (rms**2 - bias**2) n / (n - 1)`` the refits'
    sample variance about their mean, Student-t with ``n - 1`` degrees of freedom: the prediction interval of a
    normal sample (Hahn & Meeker, *Statistical Intervals*, 1991, Sec. 4.7). The refits' root-mean-square deviation
    from the estimate would count the shift twice, once in the centre and once in the width.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ParameterError(f"n must be an integer >= 2 (valid refits), got {n!r}")
    se = math.hypot(rms, extra)
    if abs(bias) <= BIAS_NEGLIGIBLE * se:
        return float(value), float(se), bootstrap_t_quantile(int(n), level)
    s2 = max(rms * rms - bias * bias, 0.0) * n / (n - 1.0)
    return (float(value - bias), float(math.sqrt(s2 * (1.0 + 1.0 / n) + extra * extra)),
            bootstrap_t_quantile(int(n) - 1, level))


def parametric_block_bootstrap(refit, prediction, residuals, estimate, *, settings: BootstrapSettings,
                               simulate=None, workers: int = 1, progress: bool | None = False) -> BootstrapResult:
    """Standard errors of a fit by refitting re-simulated records: the parametric moving-block bootstrap.

    Each replicate record is ``prediction + resample(residuals)`` (the fitted model's own output on the same
    input and stamps, plus the fit's residuals resampled in blocks of ``settings.scheme``: their colour is kept),
    refitted by
    ``refit``; the standard error is the root-mean-square deviation of the refits from ``estimate`` (it includes
    their mean shift, the bias). With ``simulate``, the model's output is drawn afresh per replicate (a model
    with its own process noise, e.g. a loop whose controller reacts to sensor noise: the noise's effect through
    the dynamics is reproduced, not only its trace in the residuals) and ``residuals`` should then hold only the
    rest (the measurement errors).

    Parameters
    ----------
    refit : callable
        ``refit(y_star, rng) -> array_like (p,)``: the fit of one replicate ``y_star`` (shape of ``prediction``),
        in the units of ``estimate``; it may draw from ``rng``, a generator of its own per replicate (e.g. a start
        spread around the estimate). A
        :class:`plant.errors.FrictionError` or :class:`numpy.linalg.LinAlgError` it raises, or a non-finite
        result, drops the replicate (counted, with the reason).
    prediction : array_like, shape (m,) or (m, c)
        The fitted model's output at the records' samples that the fit's cost uses (``c`` channels).
    residuals : array_like, same shape as ``prediction``
        The fit's residuals (either sign, used as given), in time order, finite.
    estimate : array_like, shape (p,)
        The fit's parameters (any units, e.g. SI).
    settings : BootstrapSettings, keyword-only
        ``n`` replicates (>= 1); ``block`` (samples, given: e.g. a few times the Andrews bandwidth of the
        residuals plus one); ``scheme`` ``"moving"`` (:func:`moving_block_resample`), ``"wild"`` (kept in place
        with a random sign per block, :func:`block_wild_resample`: where the residuals are large stays where they
        are large) or ``"circular"`` (:func:`circular_block_resample`); ``seed`` of the one generator every draw
        comes from: per replicate in turn its blocks, then ``simulate``'s draws; after the last replicate, one
        seed per replicate for the generator its ``refit`` gets. Every replicate is drawn before any refit runs,
        so the result does not depend on ``workers``.
    simulate : callable or None, keyword-only
        ``simulate(rng) -> array_like``, shape of ``prediction``: one realisation of the fitted model's output
        with fresh process noise drawn from ``rng``, used instead of ``prediction`` (whose shape it must have and
        which then only sets the shape); None (default): ``prediction``.
    workers : int, keyword-only
        Refits run at once, >= 1, in threads (:class:`concurrent.futures.ThreadPoolExecutor`): worth it where
        ``refit`` spends its time in code that releases the GIL (the C simulations of the output-error fit), and
        only for a ``refit`` that is safe to run in several threads at once (no shared mutable state). Default 1
        (one after another, in this thread).
    progress : bool or None, keyword-only
        A tqdm bar over the refits on stderr: True, False (default: none) or None (only when stderr is a
        terminal). It does not change the result.

    Returns
    -------
    BootstrapResult
        ``stderr``, ``bias`` (shape (p,)), the valid refits, ``n``, ``block``, the failures.

    Raises
    ------
    SignalError
        ``prediction`` and ``residuals`` differ in shape, or are not finite; ``estimate`` not finite.
    ParameterError
        ``settings`` not a :class:`BootstrapSettings` or without ``block``, ``refit`` or ``simulate`` (when
        given) not callable, ``simulate`` returning another shape (a non-finite one drops the replicate),
        ``workers`` not an integer >= 1, or ``progress`` not True, False or None.

    Notes
    -----
    Künsch, *Ann. Statist.* 17(3), 1217-1241 (1989); Efron & Tibshirani, *An Introduction to the Bootstrap*
    (Chapman & Hall, 1993), Sec. 6.4 (the parametric bootstrap: samples drawn from the fitted model), Sec. 9.5
    (bootstrapping residuals of a regression) and Ch. 10 (bias); Lahiri,
    *Resampling Methods for Dependent Data* (Springer, 2003), Sec. 2.5.
    """
    pred = np.asarray(prediction, dtype=float)
    res = np.asarray(residuals, dtype=float)
    est = np.asarray(estimate, dtype=float).reshape(-1)
    if pred.shape != res.shape or pred.ndim not in (1, 2) or not np.all(np.isfinite(pred)):
        raise SignalError(f"prediction must be finite and of the shape of residuals, got {pred.shape} and "
                          f"{res.shape}")
    if not np.all(np.isfinite(est)):
        raise SignalError(f"estimate must be finite, got {est}")
    if not isinstance(settings, BootstrapSettings) or settings.block is None:
        raise ParameterError(f"settings must be a BootstrapSettings with a block length, got {settings!r}")
    if not callable(refit) or not (simulate is None or callable(simulate)):
        raise ParameterError(f"refit and simulate must be callable, got {type(refit).__name__} and "
                             f"{type(simulate).__name__}")
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    check_optional("progress", progress, (bool, np.bool_), what="True, False")
    n, block, rng, resample = settings.n, settings.block, settings.rng(), settings.resample()
    replicates = []  # (y_star, or None for a non-finite simulation), every draw before any refit
    for _ in range(int(n)):
        e_star = resample(res, pred.shape[0], block=block, rng=rng)
        base = pred if simulate is None else np.asarray(simulate(rng), dtype=float)
        if base.shape != pred.shape:
            raise ParameterError(f"simulate must return an array of shape {pred.shape}, got {base.shape}")
        replicates.append(base + e_star if np.all(np.isfinite(base)) else None)
    seeds = rng.integers(0, 2**63 - 1, size=int(n))

    def one(k):
        if replicates[k] is None:
            return None, "non-finite simulation"
        return _refit_one(lambda: refit(replicates[k], np.random.default_rng(seeds[k])), est)

    from tqdm.auto import tqdm

    with tqdm(total=int(n), desc="bootstrap refits", unit="refit", leave=False,
              disable=None if progress is None else not progress) as bar:
        def counted(k):
            out = one(k)
            bar.update(1)  # tqdm's update holds its own lock: safe from the refit threads
            return out

        if workers == 1 or n == 1:
            outcomes = [counted(k) for k in range(int(n))]
        else:
            with ThreadPoolExecutor(max_workers=min(int(workers), int(n))) as pool:
                outcomes = list(pool.map(counted, range(int(n))))  # in replicate order whatever finishes first
    reps = [v for v, _ in outcomes if v is not None]
    failures = [why for _, why in outcomes if why is not None]
    return _bootstrap_result(reps, est, n, block, failures)


def circular_block_resample(r, n_out: int, *, block: int, rng: np.random.Generator) -> np.ndarray:
    """A circular block bootstrap series: blocks of ``block`` consecutive residuals, wrapped around the end.

    Parameters
    ----------
    r : array_like, shape (n,) or (n, c)
        Residuals in time order (any unit), finite, ``n >= 1``; rows are resampled together.
    n_out : int
        Length of the series returned, >= 1.
    block : int, keyword-only
        Block length, >= 1 (clipped to ``n``).
    rng : numpy.random.Generator, keyword-only
        Source of the block starts.

    Returns
    -------
    ndarray, shape (n_out,) or (n_out, c)
        ``ceil(n_out/block)`` blocks ``r[(s + i) mod n]``, ``i = 0 .. block-1``, each start ``s`` uniform on
        ``0 .. n-1``, concatenated and cut to ``n_out``. Unlike the moving-block series every sample is drawn
        with the same probability (the ends are not under-represented), so the bootstrap mean of the series is
        the sample mean of ``r``.

    Raises
    ------
    SignalError
        ``r`` empty, not finite, or of more than two dimensions.
    ParameterError
        ``n_out`` or ``block`` not an integer >= 1, or ``rng`` not a numpy Generator.

    Notes
    -----
    Politis & Romano, "A circular block-resampling procedure for stationary data", in *Exploring the Limits
    of Bootstrap* (Wiley, 1992), 263-270; Lahiri (2003), Sec. 2.7.
    """
    r, n, block = _resample_args(r, n_out, block, rng)
    starts = rng.integers(0, n, size=-(-int(n_out) // block))
    return r[((starts[:, None] + np.arange(block)[None, :]) % n).reshape(-1)[:n_out]]


def _flat_top(x: np.ndarray) -> np.ndarray:
    """Politis & Romano's trapezoidal flat-top lag window: 1 on |x| <= 1/2, falling linearly to 0 at |x| = 1."""
    a = np.abs(x)
    return np.where(a <= 0.5, 1.0, np.where(a <= 1.0, 2.0 * (1.0 - a), 0.0))


def politis_white_block(r) -> int:
    """Block length of the circular block bootstrap by the Politis-White automatic rule.

    Parameters
    ----------
    r : array_like, shape (n,)
        Residuals in time order (any unit), ``n >= 8``, finite.

    Returns
    -------
    int
        ``b = ceil((2 G**2 / D)**(1/3) n**(1/3))``, clipped to ``1 .. min(3 sqrt(n), n/3)``, with
        ``G = sum_k lambda(k/M) |k| R(k)`` and ``D = (4/3) (sum_k lambda(k/M) R(k))**2`` (``R`` the sample
        autocovariance, ``lambda`` the flat-top window, ``M = 2 m`` where ``m`` is the first lag after which
        ``K = max(5, sqrt(log10 n))`` autocorrelations in a row stay below ``2 sqrt(log10(n)/n)``); 1 for white
        residuals.

    Raises
    ------
    SignalError
        Fewer than 8 values, or non-finite values.

    Notes
    -----
    Politis & White, *Econometric Reviews* 23(1), 53-70 (2004), with the circular bootstrap's constant
    ``D = 4/3 g(0)**2`` of the correction by Patton, Politis & White, *Econometric Reviews* 28(4), 372-375
    (2009). It minimises the mean square error of the bootstrap variance of a mean; used here for the
    variance of a fit, as the rule's authors suggest for smooth functions of means.
    """
    r = np.asarray(r, dtype=float).reshape(-1)
    n = r.shape[0]
    if n < 8 or not np.all(np.isfinite(r)):
        raise SignalError(f"residuals must be >= 8 finite values, got shape {r.shape}")
    rc = r - r.mean()
    den = float(rc @ rc)
    if den == 0.0:
        return 1
    kn = max(5, int(math.ceil(math.sqrt(math.log10(n)))))
    max_lag = min(int(math.ceil(math.sqrt(n))) + kn, n - 1)
    f = np.fft.rfft(rc, 2 * n)
    acov = np.fft.irfft(f * np.conj(f))[: max_lag + 1] / n
    rho = acov / acov[0]
    small = np.abs(rho[1:]) < 2.0 * math.sqrt(math.log10(n) / n)
    m = max_lag
    for k in range(max_lag - kn + 1):
        if np.all(small[k:k + kn]):
            m = k
            break
    M = min(2 * max(m, 1), max_lag)
    lags = np.arange(-M, M + 1)
    lam = _flat_top(lags / M)
    R = acov[np.abs(lags)]
    G = float(np.sum(lam * np.abs(lags) * R))
    D = 4.0 / 3.0 * float(np.sum(lam * R)) ** 2
    b = (2.0 * G**2 / D) ** (1.0 / 3.0) * n ** (1.0 / 3.0) if D > 0 else 1.0
    return int(min(max(math.ceil(b), 1), max(1, int(min(3.0 * math.sqrt(n), n / 3.0)))))


def residual_block_bootstrap(refit, fitted, residuals, estimate, *,
                             settings: BootstrapSettings = BootstrapSettings()) -> BootstrapResult:
    """Standard errors of a fit from its own residuals: the (circular) block bootstrap of the residuals.

    Each replicate record is ``fitted + resample(residuals)`` (the fitted values kept, the fit's own residuals
    resampled in blocks, by default circular ones, so their colour and any model error in them is kept), refitted
    by ``refit``; the standard error is the root-mean-square deviation of the refits from ``estimate``.

    Parameters
    ----------
    refit : callable
        ``refit(y_star) -> array_like (p,)``: the fit of one replicate ``y_star`` (shape of ``fitted``). A
        :class:`plant.errors.FrictionError` or :class:`numpy.linalg.LinAlgError`, or a non-finite result,
        drops the replicate (counted, with the reason).
    fitted : array_like, shape (m,)
        The fit's fitted values (what the fit's cost compares with the data).
    residuals : array_like, shape (m,)
        Data minus ``fitted``, in time order, finite.
    estimate : array_like, shape (p,)
        The fit's parameters (any units).
    settings : BootstrapSettings, keyword-only
        ``n`` replicates, ``block`` length (default :func:`politis_white_block` of ``residuals``), ``seed`` of
        the block starts, ``scheme`` (default ``"circular"``: :func:`circular_block_resample`).

    Returns
    -------
    BootstrapResult
        ``stderr``, ``bias``, the valid refits, ``n``, ``block``, the failures.

    Raises
    ------
    SignalError
        Shapes differ, non-finite values, or fewer than 8 residuals without ``block``.
    ParameterError
        ``settings`` not a :class:`BootstrapSettings`, ``refit`` not callable.

    Notes
    -----
    The fixed-design residual bootstrap of a regression (Efron & Tibshirani, *An Introduction to the
    Bootstrap*, 1993, Sec. 9.5) with the residuals resampled in circular blocks (Künsch 1989; Politis &
    Romano 1992) so that serially correlated residuals are reproduced; on white residuals with ``block = 1``
    and a linear least-squares ``refit`` the standard errors tend to the OLS ones ``s (X^T X)^-1/2`` (with
    ``s**2 = RSS/m`` instead of ``RSS/(m - p)``).
    """
    fit = np.asarray(fitted, dtype=float)
    res = np.asarray(residuals, dtype=float)
    if fit.shape != res.shape or fit.ndim != 1 or not (np.all(np.isfinite(fit)) and np.all(np.isfinite(res))):
        raise SignalError(f"fitted and residuals must be finite and of one shape (m,), got {fit.shape} and "
                          f"{res.shape}")
    if not isinstance(settings, BootstrapSettings):
        raise ParameterError(f"settings must be a BootstrapSettings, got {type(settings).__name__}")
    n, rng, resample = settings.n, settings.rng(), settings.resample()
    block = politis_white_block(res) if settings.block is None else settings.block
    reps, failures = [], []
    est = np.asarray(estimate, dtype=float).reshape(-1)
    if not np.all(np.isfinite(est)):
        raise SignalError(f"estimate must be finite, got {est}")
    if not callable(refit):
        raise ParameterError(f"refit must be callable, got {type(refit).__name__}")
    for _ in range(int(n)):
        y_star = fit + resample(res, fit.shape[0], block=block, rng=rng)
        _refit_into(lambda: refit(y_star), est, reps, failures)
    return _bootstrap_result(reps, est, n, block, failures)


def _refit_one(call, est: np.ndarray) -> tuple:
    """One bootstrap refit ``call()``: ``(parameter vector, None)`` if it has the shape of ``est`` and is finite,
    else ``(None, reason)`` (a friction or linear-algebra error, or "non-finite")."""
    try:
        v = np.asarray(call(), dtype=float).reshape(-1)
    except (FrictionError, np.linalg.LinAlgError) as exc:
        return None, f"{type(exc).__name__}: {exc}"
    if v.shape != est.shape or not np.all(np.isfinite(v)):
        return None, "non-finite"
    return v, None


def _refit_into(call, est: np.ndarray, reps: list, failures: list) -> None:
    """One bootstrap refit ``call()`` (:func:`_refit_one`): its parameter vector appended to ``reps``, or the
    reason to ``failures``."""
    v, why = _refit_one(call, est)
    if v is None:
        failures.append(why)
    else:
        reps.append(v)


def _bootstrap_result(reps: list, est: np.ndarray, n, block, failures: list) -> "BootstrapResult":
    """The :class:`BootstrapResult` of the refits ``reps`` around ``est``: RMS deviation (standard error) and mean
    deviation (bias) per parameter, NaN with fewer than two valid refits."""
    R = np.array(reps).reshape(len(reps), est.shape[0])
    if R.shape[0] < 2:
        nan = np.full(est.shape[0], math.nan)
        return BootstrapResult(stderr=nan, bias=nan.copy(), replicates=R, n=int(n), block=int(block),
                               failures=tuple(failures))
    d = R - est
    return BootstrapResult(stderr=np.sqrt(np.mean(d**2, axis=0)), bias=np.mean(d, axis=0), replicates=R, n=int(n),
                           block=int(block), failures=tuple(failures))
