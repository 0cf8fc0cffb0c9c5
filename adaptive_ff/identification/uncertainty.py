r"""Uncertainty of an identification from the log's own residuals: block bootstrap, intervals, friction band.

Why a residual block bootstrap
------------------------------
The delta-method errors of the paper's eq. 4 LS (``s**2 (X^T X)^-1`` mapped to the
physical parameters, Ljung, *System Identification*, 2nd ed., Sec. 9.2) assume white
equation error. On a real log it is neither white nor only noise: a friction law that is
not the joint's, a filtered velocity, a drive's unmodelled compliance all leave slow,
structured residuals. On the EMPS record (``DATA_EMPS.mat``, 1 kHz, lag-one residual
autocorrelation 0.96) the delta-method error of Fc was 0.041 N and the published IDIM-LS
value lay six of them away (sigma seven, J ten; docs/benchmarks/emps.md).

The standard errors of :func:`adaptive_ff.identification.identify.identify` are therefore
a **fixed-design residual block bootstrap** (Efron & Tibshirani, *An Introduction to the
Bootstrap*, 1993, Sec. 9.5; Künsch, *Ann. Statist.* 17(3), 1989): the fitted values are
kept, the fit's *own* residuals are resampled in circular blocks (Politis & Romano 1992;
:func:`adaptive_ff.identification.covariance.circular_block_resample`) of the automatic
Politis-White length (:func:`adaptive_ff.identification.covariance.politis_white_block`), the
record is rebuilt and refitted, ``n_bootstrap`` times (default 200; eq. 4 is linear in its
parameters, so a refit is one product with the pseudo-inverse and 200 cost well under a
second on 25 000 rows).

Chosen over the alternatives because:

* it needs no model of the noise: whatever colour, non-normality or model error the residuals
  carry is carried into the replicates (the parametric bootstrap re-simulates an assumed noise;
  HAC/Newey-West needs a bandwidth and is asymptotic);
* a profile likelihood needs a likelihood, i.e. a noise model (white Gaussian or an AR model)
  that a real log does not have; its intervals are as narrow as that model is wrong;
* eq. 4 is linear in theta, so the refits are exact and cheap, and the physical parameters
  are smooth functions of theta: the bootstrap distribution of the physical parameters comes
  without the delta method's linearisation.

What it does **not** see: a bias that is the same in every replicate (errors in the
regressors, the discretisation of eq. 4 at a coarse ``Ts``, a model form that is not the
joint's). Such bias is a distance between the estimate and the truth that no resampling of
the residuals reproduces; the calibration on simulated joints (``benchmarks/coverage_zoo.py``,
documentation page of the identification benchmarks) measures how far it matters.

Intervals and band
------------------
The ``level`` interval of a parameter is ``estimate ± t stderr`` with the Student-t quantile
of the number of valid replicates (:func:`adaptive_ff.identification.covariance.bootstrap_t_quantile`;
1.97 for 200), ``stderr`` the RMS deviation of the replicates from the estimate. The band of
the static friction curve ``F(w)`` (eq. 3, offset excluded) is pointwise the same:
``F_hat(w) ± t s_F(w)``, ``s_F(w)`` the RMS deviation of the replicates' curves from the
fitted one; it contains the fitted curve by construction and is consistent with the
parameter intervals (a percentile band from 200 replicates would rest on 5 points per tail).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from adaptive_ff.identification.covariance import (DEFAULT_N_BOOTSTRAP, BootstrapSettings, bootstrap_t_quantile,
                                                    residual_block_bootstrap)
from plant.errors import ParameterError, SignalError
from plant.results import axes_or_new, json_safe
from plant.stribeck_map import stribeck

__all__ = ["FrictionBand", "ParameterUncertainty", "friction_curves", "friction_band", "eq4_block_bootstrap",
           "regression_block_bootstrap", "BAND_POINTS", "DEFAULT_N_BOOTSTRAP", "BootstrapSettings"]

#: Points of the velocity grid of a friction band (odd: ``w = 0`` is one of them).
BAND_POINTS = 101


def friction_curves(P, w, *, Vs: float | None, delta: float | None) -> np.ndarray:
    """The static friction curves ``F(w)`` (eq. 3, no offset) of several parameter sets.

    Parameters
    ----------
    P : array_like, shape (r, 3)
        Rows ``(Fc, Fs, sigma)`` in N·m, N·m, N·m·s/rad.
    w : array_like, shape (m,)
        Velocities (rad/s).
    Vs, delta : float or None, keyword-only
        Stribeck velocity (rad/s) and shape factor; None: Coulomb + viscous (``Fs`` ignored, ``Fs = Fc``).

    Returns
    -------
    ndarray, shape (r, m)
        ``F`` (N·m) per row of ``P``: :func:`plant.stribeck_map.stribeck`.

    Raises
    ------
    ParameterError
        Non-finite parameters, ``Vs <= 0``, ``delta == 0``, or only one of ``Vs``/``delta``.
    """
    P = np.asarray(P, dtype=float).reshape(-1, 3)
    w = np.asarray(w, dtype=float).reshape(-1)
    if (Vs is None) != (delta is None):
        raise ParameterError(f"give both Vs and delta or neither, got Vs = {Vs!r}, delta = {delta!r}")
    out = np.empty((P.shape[0], w.shape[0]))
    for i, (Fc, Fs, sigma) in enumerate(P):
        if Vs is None:
            out[i] = stribeck(w, Fc=Fc, Fs=Fc, Vs=1.0, delta=1.0, sigma=sigma)
        else:
            out[i] = stribeck(w, Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma)
    return out


@dataclass(frozen=True)
class FrictionBand:
    """Pointwise band of the identified static friction curve ``F(w)`` (eq. 3, offset excluded).

    Attributes
    ----------
    w : ndarray, shape (m,)
        Velocity grid (rad/s or m/s), symmetric over the record's speed range.
    F : ndarray, shape (m,)
        The fitted curve (N·m or N).
    lower, upper : ndarray, shape (m,)
        The band ``F ± t s_F`` (module docstring).
    level : float
        Nominal pointwise coverage (e.g. 0.95).
    n_replicates : int
        Bootstrap replicates the band rests on.
    """

    w: np.ndarray
    F: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    level: float
    n_replicates: int

    def to_dict(self) -> dict:
        """Strict-JSON dict: ``w``, ``F``, ``lower``, ``upper`` (lists), ``level``, ``n_replicates``."""
        return json_safe({"w": self.w.tolist(), "F": self.F.tolist(), "lower": self.lower.tolist(),
                          "upper": self.upper.tolist(), "level": self.level, "n_replicates": self.n_replicates})

    @property
    def width(self) -> np.ndarray:
        """``upper - lower`` per grid point, shape (m,)."""
        return self.upper - self.lower

    def plot(self, ax=None):
        """Draw the fitted curve and the shaded band.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
            Velocity against friction, the fitted curve (one line, label ``"F(w) fitted"``) and the band
            (a filled area, label ``"<level> % band"``).
        """
        ax = axes_or_new(ax)
        ax.fill_between(self.w, self.lower, self.upper, color="C0", alpha=0.25, lw=0,
                        label=f"{100 * self.level:g} % band ({self.n_replicates} bootstrap refits)")
        ax.plot(self.w, self.F, color="C0", lw=1.2, label="F(w) fitted")
        ax.set_xlabel("velocity w (rad/s; m/s for a linear axis)")
        ax.set_ylabel("friction F(w) (N·m; N for a linear axis)")
        ax.set_title("identified friction curve (eq. 3, offset excluded)")
        ax.legend(loc="best")
        ax.grid(True, alpha=0.3)
        return ax


def friction_band(estimate, replicates, *, w_max: float, Vs: float | None, delta: float | None,
                  level: float = 0.95, points: int = BAND_POINTS) -> FrictionBand:
    """The pointwise ``level`` band of ``F(w)`` from bootstrap replicates of ``(Fc, Fs, sigma)``.

    Parameters
    ----------
    estimate : array_like, shape (3,)
        The fit's ``(Fc, Fs, sigma)``.
    replicates : array_like, shape (r, 3)
        The bootstrap refits' ``(Fc, Fs, sigma)``, ``r >= 1``.
    w_max : float, keyword-only
        Half-width of the velocity grid (> 0), e.g. the record's largest ``|w|``.
    Vs, delta : float or None, keyword-only
        As in :func:`friction_curves`.
    level : float, keyword-only
        Nominal pointwise coverage in (0, 1). Default 0.95.
    points : int, keyword-only
        Grid points (>= 3). Default :data:`BAND_POINTS`.

    Returns
    -------
    FrictionBand

    Raises
    ------
    ParameterError
        ``w_max`` not > 0 or finite, ``points < 3``, ``level`` not in (0, 1), or bad curve parameters.
    SignalError
        No replicates.
    """
    if not (isinstance(w_max, (int, float, np.floating)) and math.isfinite(w_max) and w_max > 0):
        raise ParameterError(f"w_max must be a finite number > 0, got {w_max!r}")
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 3:
        raise ParameterError(f"points must be an integer >= 3, got {points!r}")
    R = np.asarray(replicates, dtype=float).reshape(-1, 3)
    if R.shape[0] < 1:
        raise SignalError("a friction band needs at least one bootstrap replicate, got none")
    w = np.linspace(-float(w_max), float(w_max), int(points))
    F = friction_curves(estimate, w, Vs=Vs, delta=delta)[0]
    C = friction_curves(R, w, Vs=Vs, delta=delta)
    half = bootstrap_t_quantile(R.shape[0], level) * np.sqrt(np.mean((C - F) ** 2, axis=0))
    return FrictionBand(w=w, F=F, lower=F - half, upper=F + half, level=float(level), n_replicates=int(R.shape[0]))


@dataclass(frozen=True)
class ParameterUncertainty:
    """Standard errors, intervals and the friction band of a fit, from a residual block bootstrap.

    Attributes
    ----------
    kind : str
        What the errors are, e.g. ``"residual block bootstrap"``.
    stderr : dict
        Per fitted parameter the RMS deviation of the refits from the estimate (units of the parameter).
    interval : dict
        Per parameter ``(low, high)``: ``estimate ± t stderr`` at ``level``.
    level : float
        Nominal coverage of ``interval`` and of the band.
    n, n_valid : int
        Replicates tried and kept.
    block : int
        Block length (samples) of the circular residual resampling.
    seed : int
        Seed of the resampling.
    band : FrictionBand or None
        The band of the static friction curve.
    model_error : ModelErrorCheck or None
        The model-error check that widened ``interval`` (and ``stderr``, its half-width over the Student-t
        quantile) where it found model error (:mod:`adaptive_ff.identification.model_error`); None: the
        bootstrap's own.
    """

    kind: str
    stderr: dict
    interval: dict
    level: float
    n: int
    n_valid: int
    block: int
    seed: int
    band: FrictionBand | None = None
    model_error: object = None

    def to_dict(self) -> dict:
        """Strict-JSON dict of every attribute (the band as :meth:`FrictionBand.to_dict`, the model-error check as
        :meth:`adaptive_ff.identification.model_error.ModelErrorCheck.to_dict`; NaN as None)."""
        return json_safe({"kind": self.kind, "stderr": self.stderr,
                          "interval": {k: list(v) for k, v in self.interval.items()}, "level": self.level,
                          "n": self.n, "n_valid": self.n_valid, "block": self.block, "seed": self.seed,
                          "band": None if self.band is None else self.band.to_dict(),
                          "model_error": None if self.model_error is None else self.model_error.to_dict()})

    def note(self) -> str:
        """One clause for a report's notes: what the errors are and how they were made."""
        return (f"standard errors and {100 * self.level:g} % intervals by a {self.kind} ({self.n_valid} refits of "
                f"the record rebuilt from the fitted values and the fit's own residuals, circular blocks of "
                f"{self.block} samples, seed {self.seed}): they keep the residuals' colour and model error, not a "
                "bias common to every refit")


def _check_count(name: str, v, lo: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")
    return int(v)


def regression_block_bootstrap(X, y, theta, physical, names, *, w_max: float,
                               settings: BootstrapSettings = BootstrapSettings(),
                               level: float = 0.95) -> ParameterUncertainty:
    """Residual block bootstrap of a linear regression ``y = X theta`` whose parameters map to physical ones.

    Parameters
    ----------
    X : array_like, shape (m, p)
        Regressors, rows in time order.
    y : array_like, shape (m,)
        Regressand.
    theta : array_like, shape (p,)
        The LS estimate.
    physical : callable
        ``physical(theta) -> FrictionEstimate``
        (:class:`adaptive_ff.identification.regression.FrictionEstimate`): the attributes ``names`` and ``Fc``,
        ``Fs``, ``sigma``, and the fixed Stribeck velocity ``Vs`` (rad/s) and shape ``delta`` of the band's
        curve (None: Coulomb + viscous).
    names : sequence of str
        Physical parameters reported.
    w_max : float, keyword-only
        Half-width of the band's velocity grid (rad/s, the record's largest ``|w|``); no band if not > 0.
    settings : BootstrapSettings, keyword-only
        Replicates ``n`` (>= 2 here), ``seed``, ``block`` length (default Politis-White of the residuals),
        resampling ``scheme`` (default circular blocks).
    level : float, keyword-only
        Nominal coverage of the intervals and the band, in (0, 1); default 0.95.

    Returns
    -------
    ParameterUncertainty

    Raises
    ------
    ParameterError
        ``settings.n`` below 2, ``settings`` not a :class:`BootstrapSettings`, or ``level`` invalid.
    SignalError
        Fewer than 8 rows, shapes that do not match, or non-finite data.
    """
    if not isinstance(settings, BootstrapSettings):
        raise ParameterError(f"settings must be a BootstrapSettings, got {type(settings).__name__}")
    n, seed = _check_count("n", settings.n, 2), settings.seed
    X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float).reshape(-1)
    theta = np.asarray(theta, dtype=float).reshape(-1)
    if X.ndim != 2 or X.shape != (y.shape[0], theta.shape[0]):
        raise SignalError(f"X must be (m, p) with y (m,) and theta (p,), got {X.shape}, {y.shape}, {theta.shape}")
    names = tuple(names)
    fitted = X @ theta
    pinv = np.linalg.pinv(X)

    def vec(th) -> np.ndarray:
        e = physical(th)
        return np.array([getattr(e, k) for k in names + ("Fc", "Fs", "sigma")], dtype=float)

    est = vec(theta)
    shape = physical(theta)
    b = residual_block_bootstrap(lambda ys: vec(pinv @ ys), fitted, y - fitted, est, settings=settings)
    k = len(names)
    t = bootstrap_t_quantile(max(b.n_valid, 1), level)
    stderr = {nm: float(s) for nm, s in zip(names, b.stderr[:k])}
    interval = {nm: (float(v - t * s), float(v + t * s)) for nm, v, s in zip(names, est[:k], b.stderr[:k])}
    band = None
    if b.n_valid >= 2 and math.isfinite(w_max) and w_max > 0:
        band = friction_band(est[k:], b.replicates[:, k:], w_max=float(w_max), Vs=shape.Vs, delta=shape.delta,
                             level=level)
    return ParameterUncertainty(kind="residual block bootstrap", stderr=stderr, interval=interval, level=float(level),
                                n=n, n_valid=b.n_valid, block=int(b.block), seed=seed, band=band)


def eq4_block_bootstrap(model, u, w, theta, Ts: float, names, *, settings: BootstrapSettings = BootstrapSettings(),
                        level: float = 0.95) -> ParameterUncertainty:
    """Residual block bootstrap of the paper's eq. 4 LS fit (module docstring).

    Parameters
    ----------
    model : adaptive_ff.identification.regression.RegressionModel
        The fitted structure.
    u, w : array_like, shape (N,)
        The uniform record the LS was fitted on (input N·m, velocity rad/s).
    theta : array_like, shape (p,)
        The LS estimate (``model.names``).
    Ts : float
        Sample time (s).
    names : sequence of str
        Physical parameters reported (attributes of
        :class:`adaptive_ff.identification.regression.FrictionEstimate`, e.g. ``("J", "sigma", "Fc", "offset")``).
    settings, level : keyword-only
        As in :func:`regression_block_bootstrap` (:class:`BootstrapSettings`; coverage in (0, 1)).

    Returns
    -------
    ParameterUncertainty
        With the band of ``F(w)`` over ``|w| <= max|w|`` of the record.

    Raises
    ------
    ParameterError
        ``settings.n`` below 2, ``settings`` not a :class:`BootstrapSettings`, or ``level`` invalid.
    SignalError
        Fewer than 8 regression rows, or non-finite data.
    """
    X, y = model.regressors(u, w)
    return regression_block_bootstrap(X, y, theta, lambda th: model.to_physical(th, Ts), names,
                                      w_max=float(np.max(np.abs(np.asarray(w, dtype=float)))), settings=settings,
                                      level=level)
