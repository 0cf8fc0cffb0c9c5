r"""Intervals that carry model error, and the ``model_form`` warnings that name what it affects.

Why the residual bootstrap alone is not enough
----------------------------------------------
The residual block bootstrap of a linear fit (:mod:`adaptive_ff.identification.uncertainty`) keeps the fitted
values and resamples the fit's residuals: it reproduces the residuals' size and colour, so it carries the *noise*
of a log. A model that is not the joint's (a friction lag, a Stribeck dip, a position-dependent torque, a
compliance the fit does not have) leaves an error that is largely the *same* in every replicate: a bias no
resampling of the residuals reproduces. On a simulated Coulomb + viscous joint with a 20 ms friction lag, fitted
without lag at 1 kHz, the bootstrap alone gives sigma [8.797, 9.615] and Fc [3.888, 4.300] for a true 8 and 5
(``tests/adaptive_ff_layer/test_model_error.py``); with the check below they are [7.25, 11.16] and [2.56, 5.63], and both are named.

What :func:`assess_model_error` adds
------------------------------------
Three measurements on the fit's own rows, each turned into a wider interval only where it finds something:

* **HAC sandwich** (Newey & West, *Econometrica* 55(3), 1987; Andrews' AR(1) bandwidth, *Econometrica* 59(3),
  1991, at least the residual bootstrap's block): ``(X^T X)^-1 S (X^T X)^-1`` with ``S`` the Bartlett-weighted
  autocovariance sum of the scores ``x_t r_t``. Unlike the fixed-design bootstrap it keeps where the residuals
  are large *with respect to the regressors* (a model error concentrated at reversals or at high acceleration).
  The base interval is the wider of the bootstrap's and ``estimate ± z se_HAC``.
* **Stability over the log** (delete-a-block jackknife, Künsch, *Ann. Statist.* 17(3), 1989): the fit is
  repeated with each of ``blocks`` contiguous parts of the log left out. Under the model the spread of these
  refits estimates the same variance as the base interval; a model error whose size depends on the excitation
  (which differs between parts of a real log) makes them disagree. Where the jackknife variance exceeds the base
  one by more than the 99 % point of ``chi2_{blocks-1}/(blocks-1)``, the parameter is named and its interval
  becomes ``estimate ± t_{blocks-1} se_jackknife``.
* **Richer structures the log supports** (a specification test in the spirit of the RESET and omitted-variable
  tests: Ramsey, *J. R. Stat. Soc. B* 31(2), 1969): the fit is repeated with terms the model leaves out (for the
  eq. 4 regression: the friction lag, a Stribeck-shaped low-speed term, a torque linear in position). Where the
  added terms are significant by a HAC Wald test at 1 % and move a parameter by more than its interval's
  half-width, the parameter is named and its half-width becomes that move: the interval then holds the
  estimates of every such structure.

The residuals' whiteness is measured (lag-one autocorrelation, Ljung-Box statistic over
:data:`LJUNG_BOX_LAGS` lags: Ljung & Box, *Biometrika* 65(2), 1978) and compared *per parameter* with what white
residuals of the same size would give: the ratio of the final standard error to the white-noise one. Where the
residuals are far from white (Ljung-Box p < 0.001) and that ratio exceeds :data:`COLOUR_RATIO`, the parameter is
named as well (its interval already carries the colour; the warning says that the white-noise errors, and any
tool that uses them, are too small for it by that factor). A regression of filtered signals (the sliding
regression) has coloured residuals by construction, and every parameter's ratio carries that colour (3.5-8.2 on
a well-specified 1 kHz PI log, lag-one autocorrelation 0.89); there the ratio is judged against the median of
the fit's own ratios (``colour_reference="shared"``), so that only a parameter the colour affects more than the
others is named.

What it does not see: a bias that every part of the log shares and that none of the tried structures explains.
The steady-state check (:mod:`adaptive_ff.identification.steady_state_check`) judges the friction levels against
the log's constant-velocity points independently of all three.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from plant.errors import ParameterError, SignalError
from plant.results import json_safe

__all__ = ["ModelErrorCheck", "ModelErrorSettings", "Alternative", "assess_model_error", "hac_covariance_fft", "ljung_box",
           "JACKKNIFE_BLOCKS", "WALD_LEVEL", "COLOUR_RATIO", "LJUNG_BOX_LAGS"]

#: Contiguous parts of the log of the delete-a-block jackknife.
JACKKNIFE_BLOCKS = 10
#: Significance level of the stability (chi-square) and the richer-structure (Wald) tests.
WALD_LEVEL = 0.01
#: Final-to-white standard error ratio above which far-from-white residuals name a parameter.
COLOUR_RATIO = 3.0
#: Lags of the Ljung-Box statistic.
LJUNG_BOX_LAGS = 20
#: Two-sided 95 % normal quantile.
_Z95 = 1.959963984540054


@dataclass(frozen=True)
class Alternative:
    """A richer structure tried by :func:`assess_model_error`.

    Attributes
    ----------
    name : str
        What it adds, e.g. ``"friction lag"``.
    X, y : ndarray
        Its regression rows (``y = X theta``), in time order.
    extra : tuple of int
        Columns of ``X`` that the base model does not have (tested by the Wald test).
    physical : callable
        ``physical(theta) -> ndarray`` of the reported parameters (the base model's names, same order).
    """

    name: str
    X: np.ndarray = field(repr=False)
    y: np.ndarray = field(repr=False)
    extra: tuple
    physical: object = field(repr=False)


@dataclass(frozen=True)
class ModelErrorCheck:
    """The result of :func:`assess_model_error` (module docstring).

    Attributes
    ----------
    names : tuple of str
        Parameters judged.
    estimate : dict
        The fit's values.
    stderr_white, stderr_hac, stderr_jackknife : dict
        White-noise (delta-method), HAC and delete-a-block jackknife standard errors.
    hac_lags : int
        Bartlett bandwidth of the HAC covariance.
    blocks : int
        Parts of the log of the jackknife.
    instability : dict
        Per parameter the ratio of the jackknife variance to the base variance.
    alternatives : tuple of dict
        Per richer structure ``name``, ``wald``, ``df``, ``p``, ``shift`` (per parameter, its value minus the fit's).
    whiteness : dict
        ``rho1`` (lag-one autocorrelation), ``ljung_box``, ``lags``, ``p``.
    half_width : dict
        Final half-width of the ``level`` interval per parameter.
    base_half_width : dict
        The half-width before the model-error tests (wider of bootstrap and HAC).
    affected : dict
        Per named parameter the reasons (list of str); a parameter not named is not a key.
    level : float
        Nominal coverage.
    """

    names: tuple
    estimate: dict
    stderr_white: dict
    stderr_hac: dict
    stderr_jackknife: dict
    hac_lags: int
    blocks: int
    instability: dict
    alternatives: tuple
    whiteness: dict
    half_width: dict
    base_half_width: dict
    affected: dict
    level: float = 0.95

    @property
    def interval(self) -> dict:
        """``{name: (low, high)}``: ``estimate ± half_width``."""
        return {k: (self.estimate[k] - self.half_width[k], self.estimate[k] + self.half_width[k])
                for k in self.names}

    def to_dict(self) -> dict:
        """Strict JSON of every attribute, ``interval`` and ``note`` (:meth:`note`; NaN as None)."""
        return json_safe({"names": list(self.names), "estimate": self.estimate, "stderr_white": self.stderr_white,
                          "stderr_hac": self.stderr_hac, "stderr_jackknife": self.stderr_jackknife,
                          "hac_lags": self.hac_lags, "blocks": self.blocks, "instability": self.instability,
                          "alternatives": list(self.alternatives), "whiteness": self.whiteness,
                          "half_width": self.half_width, "base_half_width": self.base_half_width,
                          "affected": self.affected, "level": self.level, "note": self.note(),
                          "interval": {k: list(v) for k, v in self.interval.items()}})

    def note(self) -> str:
        """One line for the report's notes."""
        wh = self.whiteness
        alt = "; ".join(f"{a['name']} (Wald p = {a['p']:.2g})" for a in self.alternatives) or "none"
        return (f"model error: intervals are the wider of the bootstrap's and the HAC sandwich's (Newey-West, "
                f"{self.hac_lags} lags), widened where a delete-a-block jackknife ({self.blocks} parts) or a richer "
                f"structure ({alt}) moves a parameter beyond them; residual lag-one autocorrelation "
                f"{wh['rho1']:.3g}, Ljung-Box p = {wh['p']:.2g} over {wh['lags']} lags"
                + (f"; named: {', '.join(self.affected)}" if self.affected else "; no parameter named"))

    def warnings(self, source: str) -> list:
        """One ``"model_form"`` :class:`adaptive_ff.identification.plausibility.IdentificationWarning` per named
        parameter, its text the reasons; ``source`` names the fit."""
        from adaptive_ff.identification.plausibility import IdentificationWarning

        out = []
        for k, why in self.affected.items():
            iv = f"[{self.interval[k][0]:.6g}, {self.interval[k][1]:.6g}]"
            tail = (f"its {100 * self.level:g} % interval is widened to {iv}"
                    if self.half_width[k] > self.base_half_width[k] else
                    f"its {100 * self.level:g} % interval {iv} (the bootstrap's or the HAC one) carries the colour")
            out.append(IdentificationWarning("model_form", k, f"{k} of {source}: " + "; ".join(why) + "; " + tail))
        return out


def hac_covariance_fft(X, r, lags: int) -> np.ndarray:
    """Newey-West covariance ``(X^T X)^-1 S (X^T X)^-1 n/(n-p)`` with ``S`` by FFT (any bandwidth at one cost).

    Parameters
    ----------
    X : array_like, shape (n, p)
        Regressors (or the residuals' Jacobian), rows in time order.
    r : array_like, shape (n,)
        Residuals.
    lags : int
        Bartlett bandwidth ``L >= 0``.

    Returns
    -------
    ndarray, shape (p, p)
        The same matrix as :func:`adaptive_ff.identification.covariance.hac_covariance` with ``lags=L``.

    Raises
    ------
    SignalError
        Shapes do not match or values not finite.
    ParameterError
        ``lags`` not an integer >= 0.
    """
    X = np.asarray(X, dtype=float)
    r = np.asarray(r, dtype=float).reshape(-1)
    if X.ndim != 2 or X.shape[0] != r.shape[0] or not (np.all(np.isfinite(X)) and np.all(np.isfinite(r))):
        raise SignalError(f"X must be finite (n, p) and r finite (n,), got {X.shape} and {r.shape}")
    if isinstance(lags, bool) or not isinstance(lags, (int, np.integer)) or lags < 0:
        raise ParameterError(f"lags must be an integer >= 0, got {lags!r}")
    n, p = X.shape
    L = int(min(lags, n - 1))
    scale = np.linalg.norm(X, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    X = X / scale  # unit columns: the sandwich of columns of very different size stays accurate
    s = X * r[:, None]
    m = 1 << int(math.ceil(math.log2(2 * n)))
    F = np.fft.rfft(s, m, axis=0)
    S = np.zeros((p, p))
    wts = 1.0 - np.arange(1, L + 1) / (L + 1.0)
    for i in range(p):
        for j in range(i, p):
            c = np.fft.irfft(F[:, i] * np.conj(F[:, j]), m)  # c[l] = sum_t s_i[t+l] s_j[t]
            g0 = c[0]
            pos = c[1:L + 1]           # sum_t s_i[t+l] s_j[t], l = 1..L
            neg = c[m - L:][::-1] if L else c[:0]  # sum_t s_i[t] s_j[t+l]
            v = g0 + float(wts @ (pos + neg))
            S[i, j] = S[j, i] = v
    A = np.linalg.pinv(X.T @ X)
    return A @ S @ A * (n / max(n - p, 1)) / np.outer(scale, scale)


def ljung_box(r, lags: int = LJUNG_BOX_LAGS) -> dict:
    """Ljung-Box statistic of a residual series.

    Parameters
    ----------
    r : array_like, shape (n,)
        Residuals, ``n > lags + 1``.
    lags : int
        Autocorrelations summed (>= 1).

    Returns
    -------
    dict
        ``rho1`` (lag-one autocorrelation), ``ljung_box`` ``Q = n (n+2) sum_k rho_k^2/(n-k)``, ``lags``, ``p``
        (chi-square upper tail with ``lags`` degrees of freedom).
    """
    from scipy.stats import chi2

    r = np.asarray(r, dtype=float).reshape(-1)
    n = r.shape[0]
    rc = r - r.mean()
    den = float(rc @ rc)
    if n <= lags + 1 or den == 0.0:
        return {"rho1": 0.0, "ljung_box": 0.0, "lags": int(lags), "p": 1.0}
    rho = np.array([float(rc[k:] @ rc[:-k]) / den for k in range(1, lags + 1)])
    q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, lags + 1))))
    return {"rho1": float(rho[0]), "ljung_box": q, "lags": int(lags), "p": float(chi2.sf(q, lags))}


def _jacobian(physical, theta: np.ndarray) -> np.ndarray:
    est = np.asarray(physical(theta), dtype=float)
    G = np.empty((est.shape[0], theta.shape[0]))
    for j in range(theta.shape[0]):
        h = 1e-6 * max(abs(theta[j]), 1e-12)
        a, b = theta.copy(), theta.copy()
        a[j] += h
        b[j] -= h
        G[:, j] = (np.asarray(physical(a), float) - np.asarray(physical(b), float)) / (2 * h)
    return G


def _lstsq(X, y):
    scale = np.linalg.norm(X, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    return np.linalg.lstsq(X / scale, y, rcond=None)[0] / scale


@dataclass(frozen=True, kw_only=True)
class ModelErrorSettings:
    """How :func:`assess_model_error` judges a fit (keyword-only, validated).

    Parameters
    ----------
    blocks : int
        Parts of the jackknife (>= 3, default :data:`JACKKNIFE_BLOCKS`); fewer on a short fit (parts of at least
        ``max(4, 2p)`` rows), none below 3.
    level : float
        Nominal coverage in (0, 1), default 0.95; the interval quantiles are normal (HAC), Student-t with
        ``blocks - 1`` degrees of freedom (jackknife). Give the base interval's own level.
    colour_reference : {"white", "shared"}
        What far-from-white residuals judge each parameter's error against (module docstring). ``"white"``
        (default): the white-noise error; a parameter is named where its error exceeds it :data:`COLOUR_RATIO`
        times. ``"shared"``: the colour the fit's parameters share, the median over them of that ratio; a
        parameter is named where its ratio exceeds the median :data:`COLOUR_RATIO` times. For a regression
        whose rows are filtered by construction (the sliding regression: its residuals are coloured by its own
        filters, every interval carries that colour), so that the check names the parameters the colour
        affects more than the others, not all of them.

    Raises
    ------
    ParameterError
        ``blocks`` not an integer >= 3, ``level`` not a float in (0, 1), unknown ``colour_reference``.
    """

    blocks: int = JACKKNIFE_BLOCKS
    level: float = 0.95
    colour_reference: str = "white"

    def __post_init__(self):
        if isinstance(self.blocks, bool) or not isinstance(self.blocks, (int, np.integer)) or self.blocks < 3:
            raise ParameterError(f"blocks must be an integer >= 3, got {self.blocks!r}")
        if not (isinstance(self.level, float) and 0.0 < self.level < 1.0):
            raise ParameterError(f"level must be a float in (0, 1), got {self.level!r}")
        if self.colour_reference not in ("white", "shared"):
            raise ParameterError(f"colour_reference must be 'white' or 'shared', got {self.colour_reference!r}")
        object.__setattr__(self, "blocks", int(self.blocks))


def assess_model_error(X, y, theta, physical, names, *, base=None, alternatives=(),
                       settings: ModelErrorSettings = ModelErrorSettings()) -> ModelErrorCheck:
    """Judge a linear fit ``y = X theta`` for model error and widen its intervals where it finds some.

    Parameters
    ----------
    X : array_like, shape (m, p)
        The fit's regression rows, in time order.
    y : array_like, shape (m,)
        Regressand.
    theta : array_like, shape (p,)
        The LS estimate.
    physical : callable
        ``physical(theta) -> array_like (k,)``: the reported parameters ``names``.
    names : sequence of str
        Their names (``k`` of them).
    base : ParameterUncertainty or None, keyword-only
        An interval already computed (:class:`adaptive_ff.identification.uncertainty.ParameterUncertainty`, e.g.
        the residual block bootstrap's): the base half-width is the wider of its half-width and the HAC one, and
        its ``block`` length (samples) is the least HAC bandwidth (the bandwidth is the larger of it and
        Andrews'). None (default): the HAC interval, Andrews' bandwidth.
    alternatives : sequence of Alternative, keyword-only
        Richer structures to try (module docstring); a singular one is skipped.
    settings : ModelErrorSettings, keyword-only
        Jackknife ``blocks``, coverage ``level``, ``colour_reference``.

    Returns
    -------
    ModelErrorCheck

    Raises
    ------
    SignalError
        Shapes that do not match, non-finite values, or fewer than ``2p + 2`` rows.
    ParameterError
        ``settings`` not a :class:`ModelErrorSettings`.
    """
    from scipy.stats import chi2, norm, t as student_t

    from adaptive_ff.identification.covariance import andrews_bandwidth

    X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float).reshape(-1)
    theta = np.asarray(theta, dtype=float).reshape(-1)
    if X.ndim != 2 or X.shape != (y.shape[0], theta.shape[0]) or not np.all(np.isfinite(X)):
        raise SignalError(f"X must be finite (m, p) with y (m,) and theta (p,), got {X.shape}, {y.shape}, "
                          f"{theta.shape}")
    if not isinstance(settings, ModelErrorSettings):
        raise ParameterError(f"settings must be a ModelErrorSettings, got {type(settings).__name__}")
    blocks, level = settings.blocks, settings.level
    m, p = X.shape
    if m < 2 * p + 2:
        raise SignalError(f"{m} rows are too few to judge {p} parameters")
    blocks = int(min(blocks, m // max(4, 2 * p)))  # parts of at least 2p rows; fewer than 3: no jackknife
    names = tuple(names)
    est = np.asarray(physical(theta), dtype=float)
    r = y - X @ theta
    G = _jacobian(physical, theta)
    s2 = float(r @ r) / max(m - p, 1)
    white = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", G, s2 * np.linalg.pinv(X.T @ X), G), 0.0))
    lags = int(max(andrews_bandwidth(r), 0 if base is None else int(base.block)))
    C = hac_covariance_fft(X, r, lags)
    se_hac = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", G, C, G), 0.0))
    z = float(norm.ppf(0.5 + 0.5 * level))
    hw_base = z * se_hac
    if base is not None:
        hw_base = np.maximum(hw_base, np.array([0.5 * (base.interval[k][1] - base.interval[k][0])
                                                if k in base.interval else 0.0 for k in names]))
    hw = hw_base.copy()
    affected: dict = {}
    # delete-a-block jackknife
    se_jack = np.full(len(names), math.nan)
    if blocks >= 3:
        edges = np.linspace(0, m, blocks + 1).astype(int)
        reps = []
        for k in range(blocks):
            keep = np.r_[0:edges[k], edges[k + 1]:m]
            reps.append(np.asarray(physical(_lstsq(X[keep], y[keep])), dtype=float))
        reps = np.array(reps)
        se_jack = np.sqrt((blocks - 1) / blocks * np.sum((reps - reps.mean(axis=0)) ** 2, axis=0))
    base_var = (hw_base / z) ** 2
    ratio = np.where(base_var > 0, se_jack**2 / np.where(base_var > 0, base_var, 1.0), math.inf)
    crit = float(chi2.ppf(1.0 - WALD_LEVEL, max(blocks - 1, 1)) / max(blocks - 1, 1))
    tj = float(student_t.ppf(0.5 + 0.5 * level, max(blocks - 1, 1)))
    for i, k in enumerate(names):
        if blocks >= 3 and np.isfinite(ratio[i]) and ratio[i] > crit:
            hw[i] = max(hw[i], tj * se_jack[i])
            affected.setdefault(k, []).append(
                f"its estimates with each of {blocks} parts of the log left out spread {math.sqrt(ratio[i]):.3g} "
                f"times as much as the noise explains (chi-square test at {100 * WALD_LEVEL:g} %): the model "
                "does not hold alike over the log")
    # richer structures
    alts = []
    for a in alternatives:
        X2, y2 = np.asarray(a.X, float), np.asarray(a.y, float)
        try:
            th2 = _lstsq(X2, y2)
            r2 = y2 - X2 @ th2
            C2 = hac_covariance_fft(X2, r2, lags)
            ex = list(a.extra)
            b = th2[ex]
            wald = float(b @ np.linalg.solve(C2[np.ix_(ex, ex)], b))
            shift = np.asarray(a.physical(th2), dtype=float) - est
        except (np.linalg.LinAlgError, SignalError, ParameterError):
            continue
        if not (math.isfinite(wald) and np.all(np.isfinite(shift))):
            continue
        pval = float(chi2.sf(wald, len(ex)))
        alts.append({"name": a.name, "wald": wald, "df": len(ex), "p": pval,
                     "shift": {k: float(s) for k, s in zip(names, shift)}})
        if pval < WALD_LEVEL:
            for i, k in enumerate(names):
                if abs(shift[i]) > hw[i]:
                    affected.setdefault(k, []).append(
                        f"the log supports a {a.name} (Wald p = {pval:.2g}), which moves it by {shift[i]:+.4g}, "
                        f"beyond its interval")
                    hw[i] = abs(shift[i])
    wh = ljung_box(r)
    _name_colour(affected, wh, hw / z, white, names, settings.colour_reference)
    d = lambda v: {k: float(x) for k, x in zip(names, v)}  # noqa: E731
    return ModelErrorCheck(names=names, estimate=d(est), stderr_white=d(white), stderr_hac=d(se_hac),
                           stderr_jackknife=d(se_jack), hac_lags=lags, blocks=int(blocks), instability=d(ratio),
                           alternatives=tuple(alts), whiteness=wh, half_width=d(hw), base_half_width=d(hw_base),
                           affected=affected, level=float(level))


def _name_colour(affected: dict, wh: dict, se, white, names, reference: str) -> None:
    """Add the far-from-white reason to ``affected`` for each parameter whose error ``se`` exceeds its white-noise
    one ``white`` :data:`COLOUR_RATIO` times (``reference`` ``"white"``), or whose ratio exceeds the median ratio of
    the parameters :data:`COLOUR_RATIO` times (``"shared"``)."""
    if not wh["p"] < 1e-3:
        return
    ok = np.asarray(white) > 0
    ratio = np.where(ok, np.asarray(se) / np.where(ok, white, 1.0), np.nan)
    shared = float(np.nanmedian(ratio)) if reference == "shared" and np.any(ok) else 1.0
    head = (f"the residuals are far from white (lag-one autocorrelation {wh['rho1']:.3g}, Ljung-Box p = "
            f"{wh['p']:.2g}): its error is ")
    for i, k in enumerate(names):
        if not (ok[i] and ratio[i] > COLOUR_RATIO * shared):
            continue
        if reference == "white":
            affected.setdefault(k, []).append(f"{head}{ratio[i]:.3g} times what white residuals of the same size give")
        else:
            affected.setdefault(k, []).append(
                f"{head}{ratio[i]:.3g} times what white residuals of the same size give, {ratio[i] / shared:.3g} "
                f"times the {shared:.3g} of the fit's parameters (the colour they share: the regression's own "
                "filters and the noise)")


#: Stribeck velocity of the low-speed alternative, as a fraction of the log's top speed.
STRIBECK_FRACTION = 0.1


def position_column(w, Ts: float, m: int) -> np.ndarray:
    """The position ``q`` (integral of ``w``, mean removed) at the last ``m`` samples but one, shape (m,): the
    column of a torque linear in position (a spring, a gravity slope) in a regression whose rows are ``k = N-m ..
    N-1`` and whose friction terms are taken at ``k-1``."""
    w = np.asarray(w, dtype=float)
    q = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * Ts)])
    q = q - q.mean()
    return q[w.shape[0] - 1 - m: w.shape[0] - 1]


def eq4_alternatives(model, u, w, Ts: float, names) -> list:
    """The richer structures tried for the paper's eq. 4 LS (:func:`assess_model_error`).

    Parameters
    ----------
    model : adaptive_ff.identification.regression.RegressionModel
        The fitted structure.
    u, w : array_like, shape (N,)
        The uniform record (N·m or N; rad/s or m/s).
    Ts : float
        Sample time (s).
    names : sequence of str
        The reported parameters (attributes of the estimate).

    Returns
    -------
    list of Alternative
        ``"friction lag"`` (eq. 2's ``tau``; when ``model`` has none), ``"Stribeck low-speed term"`` (a column
        ``-h(w(k-1))`` of eq. 6 with ``Vs`` = :data:`STRIBECK_FRACTION` of the top speed and ``delta = 1``: the
        excess ``Fs - Fc`` of eq. 3, so that ``Fc`` stays the Coulomb level; when ``model`` is Coulomb + viscous) and ``"torque linear in position"`` (a column ``-q(k-1)``, ``q`` the integral of ``w``).
    """
    from adaptive_ff.identification.regression import RegressionModel, h_regressor

    names = tuple(names)
    out = []
    X, y = model.regressors(u, w)

    def mapper(mod, p):
        return lambda th: np.array([getattr(mod.to_physical(th[:p], Ts), k) for k in names])

    if not model.lag:
        m2 = RegressionModel(model.Vs, model.delta, lag=True, stribeck=model.stribeck, offset=model.offset)
        X2, y2 = m2.regressors(u, w)
        out.append(Alternative("friction lag", X2, y2, tuple(i for i, n in enumerate(m2.names) if n in ("a2", "b1")),
                               mapper(m2, m2.n_params)))
    wmax = float(np.max(np.abs(w)))
    if not model.stribeck and wmax > 0:
        h = -h_regressor(np.asarray(w, dtype=float)[1:-1], STRIBECK_FRACTION * wmax, 1.0)  # (Fs - Fc) * h(w)
        out.append(Alternative("Stribeck low-speed term", np.column_stack([X, h]), y, (X.shape[1],),
                               mapper(model, model.n_params)))
    Xq = np.column_stack([X, -Ts**2 * position_column(w, Ts, X.shape[0])])
    out.append(Alternative("torque linear in position", Xq, y, (X.shape[1],), mapper(model, model.n_params)))
    return out


def widened(unc, check: ModelErrorCheck):
    """A :class:`adaptive_ff.identification.uncertainty.ParameterUncertainty` with the intervals of ``check``.

    Parameters
    ----------
    unc : ParameterUncertainty
        The residual block bootstrap's errors and intervals.
    check : ModelErrorCheck
        :func:`assess_model_error` of the same fit, with ``unc``'s half-widths as its base.

    Returns
    -------
    ParameterUncertainty
        ``interval`` the check's, ``stderr`` the half-width over the bootstrap's Student-t quantile (so that
        ``interval = estimate ± t stderr`` still holds), ``model_error`` the check; parameters the check does not
        judge keep the bootstrap's values.
    """
    from dataclasses import replace

    from adaptive_ff.identification.covariance import bootstrap_t_quantile

    t = bootstrap_t_quantile(max(unc.n_valid, 1), unc.level)
    iv, se = dict(unc.interval), dict(unc.stderr)
    for k in check.names:
        if k in iv:
            iv[k] = check.interval[k]
            se[k] = check.half_width[k] / t
    return replace(unc, interval=iv, stderr=se, model_error=check)


def eq4_model_error(model, u, w, theta, Ts: float, names, unc) -> ModelErrorCheck:
    """:func:`assess_model_error` of the paper's eq. 4 LS with :func:`eq4_alternatives`, its base the residual
    block bootstrap ``unc`` (its intervals and its block length as the least HAC bandwidth)."""
    names = tuple(names)
    X, y = model.regressors(u, w)
    return assess_model_error(X, y, theta, lambda th: np.array([getattr(model.to_physical(th, Ts), k) for k in names]),
                              names, base=unc, alternatives=eq4_alternatives(model, u, w, Ts, names),
                              settings=ModelErrorSettings(level=float(unc.level)))
