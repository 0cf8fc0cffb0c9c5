r"""Pre-estimation of the static Stribeck curve (eq. 3) from quasi-static runs, paper Sec. V-C.

The exponential Stribeck factors ``Vs`` and ``delta`` enter eq. 3 nonlinearly,
so the linear regression of eq. 4 has to take them as known constants. The
paper determines them beforehand by fitting eq. 3 with Levenberg-Marquardt to
the averaged steady-state (velocity, torque) support points of bidirectional
quasi-static drive experiments (Sec. V-C, Fig. 8). This module does that.

Model and parameterisation
--------------------------
Symmetric map, both motion directions fitted jointly::

    F(w) = sgn(w)*(Fc + (Fs - Fc)*s(w)) + sigma*w,   s(w) = exp(-|w/Vs|**delta)

The optimiser works on ``x = (Fc, Fs, log Vs, delta, sigma)`` so ``Vs = exp(x[2])``
is positive by construction. For fixed ``(Vs, delta)`` the model is linear in
``(Fc, Fs, sigma)``; the initial guesses use this (a grid over ``Vs`` with the
linear parameters solved by least squares, the idea of separable least squares,
Golub & Pereyra 1973), then MINPACK's Levenberg-Marquardt (``lmder``, Moré 1978,
through :func:`scipy.optimize.leastsq`: the iterations of
``scipy.optimize.least_squares(method="lm")`` with less overhead per evaluation)
refines all five parameters with an analytic Jacobian in C (``aff_stribeck_fit.c``).

Sign of the shape factor
------------------------
The paper allows ``delta`` of either sign ("the shape factor can be positive
or negative", Sec. II-B). With ``p = |w/Vs|**delta``:

* ``delta > 0``: ``p -> 0`` as ``w -> 0`` and ``p -> inf`` as ``|w| -> inf``, so
  ``s -> 1`` at standstill and ``s -> 0`` at speed: the classic Stribeck curve,
  ``|F| -> Fs`` for ``w -> 0±`` and ``F -> sgn(w)*Fc + sigma*w`` at speed
  (falling from ``Fs`` to ``Fc`` when ``Fs > Fc``).
* ``delta < 0``: the other way round, ``s -> 0`` at standstill and ``s -> 1``
  at speed: ``|F| -> Fc`` for ``w -> 0±`` and ``F -> sgn(w)*Fs + sigma*w`` at
  speed, a curve that *rises* from ``Fc`` towards ``Fs`` (with ``Fs > Fc``),
  e.g. a lubricated contact without a stiction peak. ``Vs`` is still the speed
  at which the excess reaches ``exp(-1)`` of ``Fs - Fc`` (measured from the
  standstill end for ``delta < 0``: ``s(Vs) = exp(-1)`` either way).
* ``(Fs, Fc, delta)`` and ``(Fc, Fs, -delta)`` are *not* the same curve
  (``exp(-1/p) != 1 - exp(-p)``), so the sign is identifiable from data that
  cover the transition.
* ``w = 0``: ``sgn(0) = 0`` gives ``F(0) = 0`` for either sign; the limit of
  ``s`` (1 or 0) is finite. Eq. 3 itself is evaluated by the package's one
  implementation, C ``plant_stribeck_eval`` (``plant/csrc/plant_stribeck.c``; the power overflows
  to ``inf`` for ``delta < 0`` and tiny ``|w|``, and ``exp(-inf) = 0``), here and
  in the online filter (:mod:`adaptive_ff.identification.online_ukf`); the
  Jacobian and the start values use the log-domain shape terms of this module.
  Neither gives NaN or warnings. ``delta = 0`` is excluded (``s = exp(-1)``
  constant: ``Fc``, ``Fs`` not separable).

Points with ``w == 0`` are dropped: ``sgn(0) = 0`` makes ``F(0) = 0`` in the
model, so a measured torque at standstill (stiction, anywhere in ``[-Fs, Fs]``)
carries no information about eq. 3.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
from scipy.optimize import leastsq, nnls

from adaptive_ff._caff import ffi, lib
from adaptive_ff.identification.log_scale import from_log
from plant.errors import ExcitationError, ParameterError, SignalError, check_finite_scalar, check_signal
from plant.friction import stribeck
from plant.results import axes_or_new, json_safe

__all__ = ["PARAM_NAMES", "MIN_POINTS", "DELTA_MAX", "StribeckFit", "fit_stribeck", "plot_stribeck_fit",
           "placeholder_shape"]

#: Order of the fitted parameters (natural scale) in ``StribeckFit.cov``.
PARAM_NAMES = ("Fc", "Fs", "Vs", "delta", "sigma")

#: Minimum number of samples with ``|w| > 0`` (five parameters plus one degree of freedom for ``s**2``).
MIN_POINTS = 6

# Transition window of the Stribeck term: the excess (Fs - Fc)*s(w) is between
# exp(-3) (5 %) and 95 % of its full size, i.e. |w/Vs|**delta in [-ln 0.95, 3].
_P_LOW = -np.log(0.95)
_P_HIGH = 3.0
#: Minimum number of distinct speeds |w| inside the transition window.
_MIN_TRANSITION_SPEEDS = 3
# With fallback: an undersampled transition whose excess |Fs - Fc| is below this fraction of the friction level
# is taken as no Stribeck effect (Coulomb + viscous).
_MIN_UNDERSAMPLED_EXCESS = 0.02
#: Largest plausible ``|delta|``: at ``|delta| = 10`` the excess falls from 95 % to 5 % between ``0.74*Vs`` and
#: ``1.12*Vs`` (a factor 1.5 in speed), a step rather than a Stribeck transition; measured shape factors lie
#: between about 0.5 and 2 (Armstrong-Hélouvry et al. 1994, Sec. 2.1; Ruderman, Sec. II-B). A fit beyond it
#: fits a jump in the data (an outlier), not the curve.
DELTA_MAX = 10.0
# Scaled-Jacobian condition number above which the fit is declared singular.
_COND_LIMIT = 1e10
# Grid of Stribeck velocities for the initial guess (points per decade).
_GRID_PER_DECADE = 12
# log(p) is clipped here so exp(log p) cannot overflow (exp(700) ~ 1e304).
_LOGP_MAX = 700.0
# Floor of the residual standard deviation in units of eps*max|F/F_std| (numerical resolution of the fit).
_RES_FLOOR_EPS = 1e3


@dataclass(frozen=True)
class StribeckFit:
    """Result of :func:`fit_stribeck`: the Stribeck parameters of eq. 3 and their uncertainty.

    Attributes
    ----------
    Fc : float
        Coulomb friction (N·m).
    Fs : float
        Static friction (N·m).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Stribeck shape factor (1), non-zero.
    sigma : float
        Viscous coefficient (N·m·s/rad).
    stderr : dict
        ``{name: standard error}`` in the units above, from the linearisation at
        the solution (see ``cov``).
    cov : ndarray, shape (5, 5)
        Covariance of ``(Fc, Fs, Vs, delta, sigma)`` (order :data:`PARAM_NAMES`),
        ``s**2 * inv(J^T J)`` with the weighted Jacobian ``J`` in
        ``(Fc, Fs, log Vs, delta, sigma)``, mapped to ``Vs`` by the delta method
        (``dVs/dlog Vs = Vs``). ``s**2`` is the weighted residual variance
        (sum of squares / (n_points - 5)), so weights act as relative weights;
        it is floored at ``(1e3*eps*max|F/F_std|)**2`` (about 1e-11 relative),
        the numerical resolution of the fit, so that noise-free data give
        tiny intervals that still contain the truth. Read-only.
    residual_rms : float
        RMS of the unweighted residuals ``F(w_i) - F_i`` over the fitted points (N·m).
    n_points : int
        Number of points fitted (samples with ``w != 0``).
    converged : bool
        True if the Levenberg-Marquardt run of the best start met a tolerance
        (MINPACK status 1-4); False if it stopped at the evaluation limit.
    fallback : str or None
        None for the full five-parameter fit; otherwise which reduced result
        ``fit_stribeck(..., fallback=True)`` returned instead of raising:
        ``"coulomb-viscous"`` (no resolvable Stribeck effect: ``Fs = Fc``, the
        ``Vs``/``delta`` given are placeholders without effect on the map),
        ``"delta-fixed"`` (the five-parameter Jacobian was singular; ``delta``
        held at 1, its variance 0) or ``"transition-undersampled"`` (the full
        fit, but fewer than 3 speeds in the fitted transition).
    notes : tuple of str
        Human-readable reasons for ``fallback`` (empty for the full fit).

    Notes
    -----
    Source: Ruderman, Sec. V-C and eq. 3. Covariance of nonlinear least
    squares estimates: Bates & Watts (1988), *Nonlinear Regression Analysis and
    Its Applications*, Sec. 2.3; Seber & Wild (1989), *Nonlinear Regression*,
    Sec. 5.1.
    """

    Fc: float
    Fs: float
    Vs: float
    delta: float
    sigma: float
    stderr: dict
    cov: np.ndarray
    residual_rms: float
    n_points: int
    converged: bool
    fallback: str | None = None
    notes: tuple = ()

    @property
    def dof(self) -> int:
        """Residual degrees of freedom, ``n_points - 5``."""
        return self.n_points - len(PARAM_NAMES)

    def params(self) -> dict:
        """``{name: value}`` of the five fitted parameters (SI units)."""
        return {k: getattr(self, k) for k in PARAM_NAMES}

    def friction(self, w):
        """Fitted static friction map ``F(w)`` of eq. 3.

        Parameters
        ----------
        w : float or ndarray, any shape
            Velocity (rad/s).

        Returns
        -------
        float or ndarray, same shape as ``w``
            Friction torque (N·m); ``F(0) = 0``. See :func:`plant.friction.stribeck`.
        """
        return stribeck(w, **self.params())

    def confidence_intervals(self, level: float = 0.95) -> dict:
        """Two-sided confidence intervals of the five parameters from the t distribution.

        Parameters
        ----------
        level : float
            Confidence level, ``0 < level < 1``.

        Returns
        -------
        dict
            ``{name: (low, high)}``. For ``Fc, Fs, delta, sigma``:
            ``value -/+ t_q * stderr`` with ``t_q`` the ``(1 + level)/2``
            quantile of Student's t with ``n_points - 5`` degrees of freedom.
            For ``Vs`` the interval is built on ``log Vs`` (the scale the fit
            was linearised in) and mapped back, ``Vs * exp(-/+ t_q * stderr_Vs/Vs)``,
            so it stays positive.

        Raises
        ------
        ParameterError
            ``level`` not in (0, 1).

        Notes
        -----
        Linearisation (Wald) intervals, Seber & Wild (1989), Sec. 5.1;
        Bates & Watts (1988), Sec. 2.3.
        """
        level = check_finite_scalar("level", level)
        if not 0.0 < level < 1.0:
            raise ParameterError(f"level must be in (0, 1), got {level!r}")
        from scipy.stats import t as student_t  # lazy: scipy.stats costs ~0.3 s of import, needed only here

        tq = float(student_t.ppf(0.5 * (1.0 + level), self.dof))
        out = {}
        for k in PARAM_NAMES:
            v, se = getattr(self, k), self.stderr[k]
            if k == "Vs":
                h = tq * se / v
                out[k] = (v * float(np.exp(-h)), v * float(np.exp(h)))
            else:
                out[k] = (v - tq * se, v + tq * se)
        return out

    def to_dict(self) -> dict:
        """Strict-JSON dict of the result (SI units; ``cov`` as nested lists; NaN/inf as None).

        Returns
        -------
        dict
            ``Fc, Fs, Vs, delta, sigma``, ``stderr`` (dict), ``cov`` (5 x 5
            lists, order :data:`PARAM_NAMES`), ``residual_rms``, ``n_points``,
            ``converged``, ``fallback`` (str or None), ``notes`` (list of str).
        """
        d = self.params()
        d.update(
            stderr=dict(self.stderr),
            cov=self.cov,
            residual_rms=self.residual_rms,
            n_points=self.n_points,
            converged=self.converged,
            fallback=self.fallback,
            notes=list(self.notes),
        )
        return json_safe(d)

    def summary(self) -> str:
        """A few lines: the five parameters with standard errors, residual RMS, points, convergence."""
        units = {"Fc": "N·m", "Fs": "N·m", "Vs": "rad/s", "delta": "", "sigma": "N·m·s/rad"}
        lines = [f"Stribeck fit of eq. 3 ({self.n_points} points, residual RMS {self.residual_rms:.4g} N·m"
                 f"{'' if self.converged else ', NOT converged'})"]
        lines += [f"  {k:<6}{getattr(self, k):>12.6g} ± {self.stderr[k]:<10.3g}{units[k]}" for k in PARAM_NAMES]
        lines += [f"  note ({self.fallback or 'full fit'}): {n}" for n in self.notes]
        return "\n".join(lines)

    def plot(self, ax=None, *, w=None, F=None, F_std=None):
        """The fitted curve, over the support points if given (paper Fig. 8).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.
        w, F : array_like, shape (N,), keyword-only, optional
            Support points (rad/s, N·m) drawn with the curve, see
            :func:`plot_stribeck_fit`. Without them the curve is drawn for
            ``0 < |w| <= 20*Vs`` in both directions.
        F_std : array_like, shape (N,), keyword-only, optional
            Spread of ``F`` (N·m), drawn as error bars.

        Returns
        -------
        matplotlib.axes.Axes

        Raises
        ------
        ParameterError
            Only one of ``w`` and ``F`` given.
        SignalError
            Bad ``w``, ``F`` or ``F_std``.
        """
        if (w is None) != (F is None):
            raise ParameterError("give both w and F (the support points), or neither")
        if w is not None:
            return plot_stribeck_fit(self, w, F, F_std=F_std, ax=ax)
        ax = axes_or_new(ax, figsize=(6.0, 4.0))
        _draw_fitted_curve(ax, self, top=20.0 * self.Vs, bottom=self.Vs / 100.0, signs=(-1.0, 1.0))
        _label_stribeck_axes(ax)
        return ax


# --------------------------------------------------------------------------- model


def _shape_terms(logaw: np.ndarray, logVs: float, delta: float):
    """Return ``s = exp(-p)``, ``s*p`` and ``log(|w|/Vs)`` with ``p = (|w|/Vs)**delta``, overflow-free.

    Works in the log domain so that no exponent overflows whatever the
    optimiser tries (huge/tiny ``Vs``, large ``|delta|``); requires ``w != 0``.
    """
    logx = logaw - logVs
    with np.errstate(over="ignore", invalid="ignore"):
        logp = np.clip(delta * logx, -np.inf, _LOGP_MAX)
    p = np.exp(logp)
    s = np.exp(-p)
    sp = np.exp(logp - p)  # s*p without inf*0
    return s, sp, logx


def _eq3_values(w, Fc, dF, Vs, delta, sigma, out):
    """Eq. 3 at every ``w`` into ``out`` by the one implementation, C (``aff_stribeck_fit.c``,
    ``aff_stribeck_fit_values``: plant's ``plant_stribeck_eval`` per element).

    ``w``, ``out``: C-contiguous float64 of one length. No argument checks (the optimiser may try any
    ``delta``) and no speed shortcut.
    """
    lib.aff_stribeck_fit_values(ffi.from_buffer("double[]", w), ffi.from_buffer("double[]", out), w.shape[0],
                                Fc, dF, Vs, delta, sigma)
    return out


def _model(x, w):
    """Eq. 3 with the optimiser's parameters ``x = (Fc, Fs, log Vs, delta, sigma)`` at the speeds ``w``."""
    Fc, Fs, logVs, delta, sigma = np.asarray(x, dtype=float).tolist()
    Vs = from_log(logVs, -_LOGP_MAX, _LOGP_MAX)  # finite and > 0 whatever the optimiser tries
    w = np.ascontiguousarray(w, dtype=float)
    return _eq3_values(w, Fc, Fs - Fc, Vs, delta, sigma, np.empty_like(w))


def _eq3_jacobian(w, logaw, Fc, Fs, logVs, delta, out):
    """d F / d (Fc, Fs, log Vs, delta, sigma) of eq. 3 at every ``w`` into ``out`` (n, 5), in C
    (``aff_stribeck_fit.c``, ``aff_stribeck_fit_jacobian``).

    With ``p = (|w|/Vs)**delta`` in the log domain as :func:`_shape_terms` (``log p`` clipped at ``_LOGP_MAX``,
    ``s*p = exp(log p - p)`` without ``inf*0``): ``ds/dlog Vs = s*p*delta``, ``ds/ddelta = -s*p*log(|w|/Vs)``.
    ``w``, ``logaw``: C-contiguous float64 (n,); ``out``: C-contiguous float64 (n, 5).
    """
    lib.aff_stribeck_fit_jacobian(ffi.from_buffer("double[]", w), ffi.from_buffer("double[]", logaw),
                                  ffi.from_buffer("double[]", out), w.shape[0], Fc, Fs, logVs, delta)
    return out


def _jacobian(x, sg, w, logaw):
    """d F / d (Fc, Fs, log Vs, delta, sigma), shape (n, 5) (:func:`_eq3_jacobian`; ``sg = sign(w)``)."""
    Fc, Fs, logVs, delta, _ = np.asarray(x, dtype=float).tolist()
    w, logaw = np.ascontiguousarray(w, dtype=float), np.ascontiguousarray(logaw, dtype=float)
    return _eq3_jacobian(w, logaw, Fc, Fs, logVs, delta, np.empty((w.shape[0], 5)))


# --------------------------------------------------------------------------- inputs


def _check_p0(p0) -> np.ndarray:
    """Validate ``p0`` (mapping or sequence) and return ``x0`` in the optimiser's parameters."""
    if isinstance(p0, Mapping):
        keys = set(p0)
        if keys != set(PARAM_NAMES):
            raise ParameterError(
                f"p0 must have exactly the keys {list(PARAM_NAMES)}, got {sorted(keys)}")
        vals = [p0[k] for k in PARAM_NAMES]
    elif isinstance(p0, Sequence) or isinstance(p0, np.ndarray):
        if len(p0) != len(PARAM_NAMES):
            raise ParameterError(f"p0 must have 5 values {PARAM_NAMES}, got {len(p0)}: {p0!r}")
        vals = list(p0)
    else:
        raise TypeError(f"p0 must be a mapping or a sequence of 5 numbers {PARAM_NAMES}, got {p0!r}")
    Fc, Fs, Vs, delta, sigma = (check_finite_scalar(f"p0[{k!r}]", v) for k, v in zip(PARAM_NAMES, vals))
    if Vs <= 0.0:
        raise ParameterError(f"p0['Vs'] must be > 0, got {Vs!r}")
    if delta == 0.0:
        raise ParameterError("p0['delta'] must be non-zero (|w/Vs|**0 is constant), got 0.0")
    return np.array([Fc, Fs, np.log(Vs), delta, sigma])


def _check_delta_starts(delta_starts) -> list[float]:
    if not isinstance(delta_starts, (Sequence, np.ndarray)) or isinstance(delta_starts, str) \
            or len(delta_starts) == 0:
        raise ParameterError(f"delta_starts must be a non-empty sequence of non-zero numbers, got {delta_starts!r}")
    out = []
    for i, d in enumerate(delta_starts):
        d = check_finite_scalar(f"delta_starts[{i}]", d)
        if d == 0.0:
            raise ParameterError(f"delta_starts[{i}] must be non-zero, got 0.0")
        if d not in out:
            out.append(d)
    return out


# --------------------------------------------------------------------------- initial guess


def _linear_part(A: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = A @ coef - y
    return coef, float(r @ r)


def _initial_guesses(sg, w, aw, logaw, F, wt, delta_starts) -> list[np.ndarray]:
    """Starting points ``x0`` (one per start value of delta) from the data.

    1. Coulomb + viscous line ``c*sgn(w) + sigma*w`` fitted by weighted linear
       least squares to the higher-speed half of the points.
    2. Excess over the line at the lowest-speed quarter of the points: positive
       means friction rising towards standstill (classic Stribeck, ``delta > 0``
       with ``Fs > Fc``); negative means friction rising with speed from ``Fc``
       towards ``Fs`` (``delta < 0``), and the negated ``delta_starts`` are added.
    3. For each start ``delta``: ``Vs`` on a log grid spanning the data; for each
       grid value ``(Fc, Fs, sigma)`` by linear least squares; keep the best.
    """
    hi = aw >= np.median(aw)
    (c, sig), _ = _linear_part(np.column_stack([sg[hi], w[hi]]) * wt[hi, None], F[hi] * wt[hi])
    excess = sg * (F - (c * sg + sig * w))
    low = aw <= np.quantile(aw, 0.25)
    deltas = list(delta_starts)
    if np.average(excess[low], weights=wt[low] ** 2) < 0.0:
        deltas += [-d for d in delta_starts if -d not in deltas]

    lo, hi_ = np.log(aw.min() / 10.0), np.log(aw.max() * 10.0)
    n_grid = max(int(np.ceil((hi_ - lo) / np.log(10.0) * _GRID_PER_DECADE)), 2) + 1
    grid = np.linspace(lo, hi_, n_grid)
    y = F * wt
    starts = []
    for d in deltas:
        best = None
        for logVs in grid:
            s, _, _ = _shape_terms(logaw, logVs, d)
            A = np.column_stack([sg * (1.0 - s), sg * s, w]) * wt[:, None]
            (Fc, Fs, sigma), cost = _linear_part(A, y)
            if best is None or cost < best[0]:
                best = (cost, np.array([Fc, Fs, logVs, d, sigma]))
        starts.append(best[1])
    return starts


# --------------------------------------------------------------------------- fit


def fit_stribeck(w, F, *, F_std=None, p0=None, delta_starts=(0.5, 1.0, 2.0), fallback: bool = False) -> StribeckFit:
    """Fit the static Stribeck map of eq. 3 to steady-state (velocity, torque) pairs by Levenberg-Marquardt.

    Parameters
    ----------
    w : array_like, shape (N,)
        Steady-state velocities (rad/s) of bidirectional quasi-static runs
        (both signs may appear; the symmetric model fits them jointly).
        Samples with ``w == 0`` are ignored (``sgn(0) = 0``: no information).
    F : array_like, shape (N,)
        Steady-state friction torque at ``w`` (N·m), e.g. the mean drive torque
        of each constant-velocity run.
    F_std : array_like, shape (N,), optional, keyword-only
        Spread (standard deviation, N·m, > 0) of each ``F``; residuals are
        weighted by ``1/F_std``. Default: equal weights.
    p0 : mapping or sequence of 5 floats, optional, keyword-only
        Initial guess ``{Fc, Fs, Vs, delta, sigma}`` (or in that order). If
        given it is the only start and ``delta_starts`` is ignored. Default:
        guesses from the data (see Notes).
    delta_starts : sequence of float, keyword-only
        Start values of ``delta`` (non-zero), one Levenberg-Marquardt run each;
        the lowest-cost solution is kept. The negated values are added when the
        data show friction rising with speed (see Notes).
    fallback : bool, keyword-only
        False (default): raise :class:`ExcitationError` when the data do not
        determine the five parameters. True: return a reduced result with
        ``fallback`` and ``notes`` set instead (a pipeline that designed its
        own runs uses this after refining them): no resolvable Stribeck effect
        gives the Coulomb + viscous line (``Fs = Fc``, ``Vs`` = the lowest
        measured speed, ``delta = 1``: placeholders, the map does not depend
        on them; ``Fc, sigma >= 0``); a best fit that is not a friction
        curve (``Fc <= 0``, ``Fs <= 0`` or ``|delta| >`` :data:`DELTA_MAX`)
        gives the Coulomb + viscous line; a singular Jacobian gives the fit
        with ``delta`` held at 1 (or the Coulomb + viscous line if that is
        singular or implausible too); too few speeds in the transition keep
        the full fit with a note, unless its excess ``|Fs - Fc|`` is below
        2 % of the friction level (then the Coulomb + viscous line).

    Returns
    -------
    StribeckFit
        Parameters, standard errors, covariance, residual RMS (and the
        fallback taken, if any).

    Raises
    ------
    SignalError
        ``w``, ``F`` or ``F_std`` not 1-D, of different lengths, fewer than
        6 samples, non-finite, or ``F_std`` not > 0 (the argument is named).
    ParameterError, TypeError
        Invalid ``p0`` or ``delta_starts``.
    ExcitationError
        Fewer than 6 samples with ``w != 0`` or fewer than 5 distinct speeds
        ``|w|``; the Jacobian at the solution is singular; fewer than 3
        distinct speeds lie in the Stribeck transition of the fitted curve
        (for ``delta = 1``: roughly ``0.05*Vs <= |w| <= 3*Vs``), so ``Fs`` and
        ``Vs`` are not identified; ``Fs - Fc`` is not resolved from zero
        (no Stribeck effect in the data); or the best fit is not a friction
        curve (``Fc <= 0``, ``Fs <= 0`` or ``|delta| > DELTA_MAX``, e.g. it
        fits a jump of one outlying run). With ``fallback=True`` only the
        first two (too few samples or speeds).

    Notes
    -----
    Model: ``F(w) = sgn(w)*(Fc + (Fs - Fc)*exp(-|w/Vs|**delta)) + sigma*w``
    (Ruderman, eq. 3), fitted as in the paper's Sec. V-C (Levenberg-Marquardt
    on the averaged support points of bidirectional quasi-static runs, Fig. 8).
    Optimiser: MINPACK's ``lmder`` through :func:`scipy.optimize.leastsq`
    (Moré 1978, "The Levenberg-Marquardt algorithm: implementation and
    theory"; the iterations of ``least_squares(method="lm")``), analytic
    Jacobian, parameters ``(Fc, Fs, log Vs, delta, sigma)`` so that ``Vs > 0``.

    Initial guess (``p0=None``): a Coulomb + viscous line by linear least
    squares on the higher-speed half of the points gives the sign of the
    low-speed excess and so the sign(s) of ``delta`` to start from; for each
    start ``delta``, ``Vs`` is taken from a log-spaced grid (decades
    ``min|w|/10 .. 10*max|w|``) with ``(Fc, Fs, sigma)`` solved linearly for
    each grid value (separable least squares). Data from a plant with
    ``delta < 0`` and ``Fs < Fc`` (friction falling with speed) look like the
    classic case; pass ``delta_starts=(-1.0,)`` to fit that branch.

    Covariance: ``s**2 * inv(J^T J)`` at the solution (Bates & Watts 1988,
    Sec. 2.3; Seber & Wild 1989, Sec. 5.1), Vs by the delta method.
    """
    w, F, std = _check_data(w, F, F_std)
    x0_user = None if p0 is None else _check_p0(p0)
    starts_delta = _check_delta_starts(delta_starts)
    w, F, wt = _usable_points(w, F, std)
    sg, aw = np.sign(w), np.abs(w)
    logaw = np.log(aw)
    args = (sg, w, logaw)

    def resid(x):
        return (_model(x, w) - F) * wt

    def jac(x):
        return _jacobian(x, *args) * wt[:, None]

    starts = [x0_user] if x0_user is not None else _initial_guesses(sg, w, aw, logaw, F, wt, starts_delta)
    best = _best_lm_run(resid, jac, starts)
    x = best.x
    Fc, Fs, logVs, delta, sigma = (float(v) for v in x)
    Vs = from_log(logVs)
    try:
        _check_plausible(Fc, Fs, Vs, delta)
    except ExcitationError as exc:
        if not fallback:
            raise
        return _coulomb_viscous_fit(w, F, wt, str(exc))
    try:
        cov = _covariance(jac(x), resid(x), F * wt, x)
    except ExcitationError as exc:
        if not fallback:
            raise
        return _delta_fixed_fit(w, F, wt, str(exc))
    checks = []
    for check in (lambda: _check_transition(aw, Vs, delta), lambda: _check_stribeck_effect(cov, Fc, Fs, F)):
        try:
            check()
        except ExcitationError as exc:
            if not fallback:
                raise
            checks.append(str(exc))
    no_effect = [c for c in checks if "no resolvable" in c]
    if checks and not no_effect and abs(Fs - Fc) < _MIN_UNDERSAMPLED_EXCESS * max(abs(Fc), abs(Fs)):
        no_effect = [f"a Stribeck excess Fs - Fc = {Fs - Fc:.3g} N·m below {_MIN_UNDERSAMPLED_EXCESS:.0%} of the "
                     f"friction level, in an undersampled transition ({checks[0]})"]
    if no_effect:
        return _coulomb_viscous_fit(w, F, wt, no_effect[0])
    return _result(x, w, F, cov, bool(best.status > 0),
                   ("transition-undersampled", tuple(checks)) if checks else (None, ()))


def _result(x, w, F, cov, converged: bool, fb) -> StribeckFit:
    """The :class:`StribeckFit` of optimiser parameters ``x`` with covariance ``cov`` (natural scale)."""
    Fc, Fs, logVs, delta, sigma = (float(v) for v in x)
    stderr = dict(zip(PARAM_NAMES, np.sqrt(np.clip(np.diag(cov), 0.0, None)).tolist()))
    cov = np.array(cov, dtype=float)
    cov.setflags(write=False)
    return StribeckFit(
        Fc=Fc, Fs=Fs, Vs=from_log(logVs), delta=delta, sigma=sigma,
        stderr=stderr,
        cov=cov,
        residual_rms=float(np.sqrt(np.mean((_model(x, w) - F) ** 2))),
        n_points=int(w.shape[0]),
        converged=converged,
        fallback=fb[0],
        notes=tuple(fb[1]),
    )


def placeholder_shape(speeds) -> tuple[float, float]:
    """The Stribeck shape ``(Vs, delta)`` of a friction without a Stribeck term (``Fs = Fc``): placeholders.

    ``Vs`` is the lowest measured speed (any Stribeck effect lies below it), ``delta`` 1. The static map does not
    depend on them while ``Fs = Fc``; an adaptive estimator started there learns any ``Fs - Fc`` with that shape.
    One rule for the Coulomb + viscous fallback of :func:`fit_stribeck`, ``compare``'s joint without friction and
    a compensator from an identification without a Stribeck term
    (:func:`controllers.experiments.compensator_file.compensator_from_file`).

    Parameters
    ----------
    speeds : array_like
        The measured speeds or velocities (rad/s; signs ignored), at least one non-zero finite value.

    Returns
    -------
    Vs : float
        The smallest non-zero ``|speed|`` (rad/s).
    delta : float
        1.0.

    Raises
    ------
    ParameterError
        No non-zero finite speed.
    """
    s = np.abs(np.asarray(speeds, dtype=float).ravel())
    s = s[np.isfinite(s) & (s > 0.0)]
    if s.size == 0:
        raise ParameterError(f"placeholder_shape: no non-zero finite speed in {speeds!r}: no placeholder Vs")
    return float(np.min(s)), 1.0


def _coulomb_viscous_fit(w, F, wt, reason: str) -> StribeckFit:
    """No resolvable Stribeck effect: weighted LS line ``Fc*sgn(w) + sigma*w``, ``Fs = Fc`` (placeholders Vs, delta).

    ``Fc`` and ``sigma`` are constrained to >= 0 (non-negative least squares, Lawson & Hanson 1974, Ch. 23) when
    the unconstrained line has a negative one: friction is dissipative.

    ``Vs`` is set to the lowest measured speed (any Stribeck effect lies below it) and ``delta`` to 1; the map
    does not depend on them since ``Fs - Fc = 0``. Covariance: ``s**2 inv(A^T A)`` of the line (Seber & Wild
    1989, Sec. 2.1), ``Fs`` perfectly correlated with ``Fc``, zero variance for the placeholders.
    """
    sg = np.sign(w)
    A = np.column_stack([sg, w]) * wt[:, None]
    (c, sig), _ = _linear_part(A, F * wt)
    if c < 0.0 or sig < 0.0:  # friction is dissipative: Fc, sigma >= 0 (non-negative least squares)
        (c, sig), _ = nnls(A, F * wt)
        c, sig = float(c), float(sig)
    r = A @ np.array([c, sig]) - F * wt
    dof = max(r.shape[0] - 2, 1)
    s2 = max(float(r @ r) / dof, (_RES_FLOOR_EPS * np.finfo(float).eps * float(np.max(np.abs(F * wt)))) ** 2)
    c2 = s2 * np.linalg.pinv(A.T @ A)
    cov = np.zeros((5, 5))
    idx = (0, 1, 4)  # Fc, Fs (= Fc), sigma
    src = (0, 0, 1)
    for i, a in zip(idx, src):
        for j, b in zip(idx, src):
            cov[i, j] = c2[a, b]
    Vs, delta = placeholder_shape(w)
    x = np.array([c, c, math.log(Vs), delta, sig])
    note = (f"no Stribeck effect resolved from the data, Coulomb + viscous model used (Fs = Fc = {c:.4g} N·m, "
            f"sigma = {sig:.4g} N·m·s/rad; Vs, delta are placeholders). Reason: {reason}")
    return _result(x, w, F, cov, True, ("coulomb-viscous", (note,)))


def _delta_fixed_fit(w, F, wt, reason: str) -> StribeckFit:
    """Singular five-parameter Jacobian: refit with ``delta = 1`` held (Fc, Fs, log Vs, sigma free).

    Falls back to :func:`_coulomb_viscous_fit` when this fit is singular too or shows no Stribeck effect.
    """
    sg, aw = np.sign(w), np.abs(w)
    logaw = np.log(aw)
    free = [0, 1, 2, 4]

    def full(x4):
        return np.array([x4[0], x4[1], x4[2], 1.0, x4[3]])

    def resid(x4):
        return (_model(full(x4), w) - F) * wt

    def jac(x4):
        return (_jacobian(full(x4), sg, w, logaw) * wt[:, None])[:, free]

    x0 = _initial_guesses(sg, w, aw, logaw, F, wt, [1.0])[0]
    best = _best_lm_run(resid, jac, [x0[free]])
    x = full(best.x)
    Jw = jac(best.x)
    col = np.linalg.norm(Jw, axis=0)
    if np.any(col == 0.0):
        return _coulomb_viscous_fit(w, F, wt, reason)
    _, sv, Vt = np.linalg.svd(Jw / col, full_matrices=False)
    if sv[-1] <= sv[0] / _COND_LIMIT:
        return _coulomb_viscous_fit(w, F, wt, reason)
    r = resid(best.x)
    s2 = max(float(r @ r) / max(r.shape[0] - 4, 1),
             (_RES_FLOOR_EPS * np.finfo(float).eps * float(np.max(np.abs(F * wt)))) ** 2)
    c4 = s2 * ((Vt.T / sv**2) @ Vt) / np.outer(col, col)
    T = np.diag([1.0, 1.0, math.exp(float(x[2])), 1.0])  # delta method for Vs
    c4 = T @ c4 @ T
    cov = np.zeros((5, 5))
    cov[np.ix_(free, free)] = 0.5 * (c4 + c4.T)
    try:
        _check_plausible(float(x[0]), float(x[1]), math.exp(float(x[2])), 1.0)
        _check_stribeck_effect(cov, float(x[0]), float(x[1]), F)
    except ExcitationError as exc:
        return _coulomb_viscous_fit(w, F, wt, str(exc))
    note = f"delta held at 1 (the five-parameter fit was singular: {reason})"
    return _result(x, w, F, cov, bool(best.status > 0), ("delta-fixed", (note,)))


def _check_data(w, F, F_std):
    """Validated ``w``, ``F`` and the spreads ``F_std`` (ones if None)."""
    w = check_signal("w", w, min_len=MIN_POINTS)
    F = check_signal("F", F, n=w.shape[0])
    if F_std is None:
        return w, F, np.ones_like(w)
    std = check_signal("F_std", F_std, n=w.shape[0])
    bad = std <= 0.0
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise SignalError(f"F_std must be > 0 everywhere, got F_std[{i}] = {std[i]!r}")
    return w, F, std


def _usable_points(w, F, std):
    """The points with ``w != 0`` and their weights ``1/F_std``; raise if too few points or speeds."""
    keep = w != 0.0
    n = int(keep.sum())
    if n < MIN_POINTS:
        raise ExcitationError(
            f"w has only {n} samples with w != 0 (of {w.shape[0]}); fit_stribeck needs at least "
            f"{MIN_POINTS} for the 5 parameters (Fc, Fs, Vs, delta, sigma)")
    w, F, wt = w[keep], F[keep], 1.0 / std[keep]
    n_speeds = np.unique(np.abs(w)).size
    if n_speeds < len(PARAM_NAMES):
        raise ExcitationError(
            f"w has only {n_speeds} distinct speeds |w| > 0; the symmetric Stribeck map needs at "
            f"least {len(PARAM_NAMES)} to identify (Fc, Fs, Vs, delta, sigma)")
    return w, F, wt


def _lm_run(resid, jac, x0) -> SimpleNamespace:
    """MINPACK's ``lmder`` (Levenberg-Marquardt, Moré 1978) from ``x0``: ``x``, ``cost`` (half the sum of squared
    residuals), ``status`` (> 0 converged, 0 stopped at the evaluation limit), ``nfev``.

    Called through :func:`scipy.optimize.leastsq`, the thin wrapper of ``lmder``: the same iterations as
    ``least_squares(method="lm", x_scale="jac")`` (``diag`` from the Jacobian's column norms, ``factor`` 100),
    without that wrapper's per-evaluation bookkeeping, which cost more than the residuals themselves here.
    """
    with np.errstate(over="ignore", invalid="ignore"):  # leastsq's own cov_x (unused here) overflows on a
        x, _, info, _, ier = leastsq(resid, x0, Dfun=jac, full_output=True, ftol=1e-12, xtol=1e-12,  # flat cost
                                     gtol=1e-12, maxfev=2000)
    f = info["fvec"]
    return SimpleNamespace(x=x, cost=0.5 * float(f @ f), status=int(ier) if ier in (1, 2, 3, 4) else 0,
                           nfev=int(info["nfev"]))


def _best_lm_run(resid, jac, starts):
    """MINPACK Levenberg-Marquardt from every start; the finite solution of lowest cost."""
    best = None
    for x0 in starts:
        res = _lm_run(resid, jac, np.asarray(x0, dtype=float))
        if np.all(np.isfinite(res.x)) and (best is None or res.cost < best.cost):
            best = res
    if best is None:  # pragma: no cover - MINPACK keeps x finite from a finite start
        raise ExcitationError("the data cannot identify Fs/Vs: every Levenberg-Marquardt start diverged")
    return best


def _covariance(Jw, r, Fw, x) -> np.ndarray:
    """Covariance of ``(Fc, Fs, Vs, delta, sigma)`` (Bates & Watts 1988, Sec. 2.3); raise if singular.

    ``Jw``: weighted Jacobian in ``(Fc, Fs, log Vs, delta, sigma)`` at ``x``, ``r``: weighted residuals,
    ``Fw``: weighted data (for the numerical resolution floor of ``s**2``).
    """
    Fc, Fs, logVs, delta, _ = (float(v) for v in x)
    Vs = from_log(logVs)
    dof = r.shape[0] - len(PARAM_NAMES)
    # numerical resolution floor: rounding in the residuals (a few eps*|F| per point) leaves exact data with
    # parameter errors of ~1e-15 relative that a purely residual-based s**2 (~1e-30) would call significant
    s2 = max(float(r @ r) / dof, (_RES_FLOOR_EPS * np.finfo(float).eps * float(np.max(np.abs(Fw)))) ** 2)
    col = np.linalg.norm(Jw, axis=0)
    names_x = ("Fc", "Fs", "log Vs", "delta", "sigma")
    if np.any(col == 0.0) or delta == 0.0:
        zero = [names_x[j] for j in np.flatnonzero(col == 0.0)] or ["delta"]
        raise ExcitationError(
            f"the data cannot identify Fs/Vs: the fitted Stribeck map does not depend on {zero} at "
            f"the solution (Fs={Fs:.6g} N·m, Fc={Fc:.6g} N·m, Vs={Vs:.6g} rad/s, delta={delta:.6g})")
    _, sv, Vt = np.linalg.svd(Jw / col, full_matrices=False)
    if sv[-1] <= sv[0] / _COND_LIMIT:
        weak = [names_x[j] for j in np.flatnonzero(np.abs(Vt[-1]) > 0.3)]
        raise ExcitationError(
            f"the data cannot identify Fs/Vs: the Jacobian at the solution is singular (scaled "
            f"condition number {sv[0] / max(sv[-1], np.finfo(float).tiny):.3g}), the combination of "
            f"{weak} is undetermined. Fitted Fs={Fs:.6g} N·m, Fc={Fc:.6g} N·m, Vs={Vs:.6g} rad/s, "
            f"delta={delta:.6g}; is there a Stribeck effect, and runs at speeds around Vs?")
    inv_scaled = (Vt.T / sv**2) @ Vt
    cov_x = s2 * inv_scaled / np.outer(col, col)
    T = np.diag([1.0, 1.0, Vs, 1.0, 1.0])  # delta method: dVs/dlogVs = Vs
    cov = T @ cov_x @ T
    return 0.5 * (cov + cov.T)


def _check_transition(aw, Vs: float, delta: float) -> None:
    """Raise unless 3 distinct speeds lie where ``(Fs - Fc)*s(w)`` is between 5 % and 95 % of its size."""
    a, b = sorted((_P_LOW ** (1.0 / delta), _P_HIGH ** (1.0 / delta)))
    w_lo, w_hi = Vs * a, Vs * b
    n_trans = np.unique(aw[(aw >= w_lo) & (aw <= w_hi)]).size
    if n_trans < _MIN_TRANSITION_SPEEDS:
        raise ExcitationError(
            f"the data cannot identify Fs/Vs: only {n_trans} distinct speed(s) lie in the Stribeck "
            f"transition {w_lo:.3g} <= |w| <= {w_hi:.3g} rad/s of the fitted curve (Vs={Vs:.6g} rad/s, "
            f"delta={delta:.6g}), need at least {_MIN_TRANSITION_SPEEDS}; add quasi-static runs at "
            f"speeds around Vs (for delta > 0: |w| below about 3*Vs)")


def _check_plausible(Fc: float, Fs: float, Vs: float, delta: float) -> None:
    """Raise unless the fit is a friction curve: ``Fc > 0``, ``Fs > 0`` and ``|delta| <= DELTA_MAX``.

    Friction opposes the motion (dissipative), so both levels of eq. 3 are positive; a negative level or a
    step-like ``delta`` means the optimiser has fitted a jump in the data (e.g. one run whose mean torque is
    not a point of the curve) instead of the curve.
    """
    if not (Fc > 0.0 and Fs > 0.0 and abs(delta) <= DELTA_MAX):
        raise ExcitationError(
            f"the data cannot identify Fs/Vs: the best fit is not a friction curve (Fc={Fc:.4g} N·m, "
            f"Fs={Fs:.4g} N·m, Vs={Vs:.4g} rad/s, delta={delta:.4g}; friction levels must be > 0 and "
            f"|delta| <= {DELTA_MAX:g}); a run whose mean torque is off the curve, or no Stribeck effect")


def _check_stribeck_effect(cov, Fc: float, Fs: float, F) -> None:
    """Raise unless ``Fs - Fc`` is resolved from zero (two standard errors and the rounding floor)."""
    d = Fs - Fc
    se_d = float(np.sqrt(max(cov[0, 0] + cov[1, 1] - 2.0 * cov[0, 1], 0.0)))
    floor = np.sqrt(np.finfo(float).eps) * float(np.max(np.abs(F)))
    if abs(d) <= max(2.0 * se_d, floor):
        raise ExcitationError(
            f"the data cannot identify Fs/Vs: no resolvable Stribeck effect, Fs - Fc = {d:.3g} N·m "
            f"(standard error {se_d:.3g} N·m), so Vs and delta are undetermined; fit a Coulomb + "
            f"viscous model instead")


# --------------------------------------------------------------------------- figure


def plot_stribeck_fit(fit: StribeckFit, w, F, *, F_std=None, ax=None):
    """Plot the fitted Stribeck curve over the measured support points (paper Fig. 8).

    Parameters
    ----------
    fit : StribeckFit
        Result of :func:`fit_stribeck`.
    w : array_like, shape (N,)
        Measured velocities (rad/s).
    F : array_like, shape (N,)
        Measured mean torques (N·m).
    F_std : array_like, shape (N,), optional, keyword-only
        Spread of ``F`` (N·m), drawn as error bars.
    ax : matplotlib.axes.Axes, optional, keyword-only
        Axes to draw into; default: a new :class:`matplotlib.figure.Figure`
        (no pyplot, so it works with any backend, including Agg).

    Returns
    -------
    matplotlib.axes.Axes
        The axes, x labelled in rad/s and y in N·m (the same as
        ``fit.plot(ax, w=w, F=F, F_std=F_std)``).

    Raises
    ------
    TypeError
        ``fit`` is not a :class:`StribeckFit`.
    SignalError
        Bad ``w``, ``F`` or ``F_std`` (see :func:`plant.errors.check_signal`).

    Notes
    -----
    Source: Ruderman, Sec. V-C, Fig. 8 (curve over mean values with spread).
    """
    if not isinstance(fit, StribeckFit):
        raise TypeError(f"fit must be a StribeckFit, got {type(fit).__name__}")
    w = check_signal("w", w)
    F = check_signal("F", F, n=w.shape[0])
    yerr = None if F_std is None else check_signal("F_std", F_std, n=w.shape[0])
    ax = axes_or_new(ax, figsize=(6.0, 4.0))
    ax.errorbar(w, F, yerr=yerr, fmt="o", ms=4, capsize=2, color="C0", label="measured (mean ± spread)")
    aw = np.abs(w[w != 0.0])
    top = float(aw.max()) if aw.size else 1.0
    bottom = float(aw.min()) if aw.size else top * 1e-3
    signs = [s for s in (-1.0, 1.0) if np.any(np.sign(w) == s)] or [1.0]
    _draw_fitted_curve(ax, fit, top=top, bottom=bottom, signs=signs)
    _label_stribeck_axes(ax)
    return ax


def _draw_fitted_curve(ax, fit: StribeckFit, *, top: float, bottom: float, signs) -> None:
    """One branch of the fitted curve per direction in ``signs``, dense near ``bottom`` and ``Vs``."""
    branch = np.unique(np.concatenate([np.linspace(0.0, top, 400)[1:],
                                       np.geomspace(min(bottom, fit.Vs) / 2.0, top, 400)]))
    for i, sgn in enumerate(signs):
        wb = sgn * branch
        ax.plot(wb, fit.friction(wb), "-", color="C1",
                label=(f"Stribeck fit (Vs = {fit.Vs:.3g} rad/s, δ = {fit.delta:.3g})" if i == 0 else None))


def _label_stribeck_axes(ax) -> None:
    ax.axhline(0.0, color="0.7", lw=0.5)
    ax.axvline(0.0, color="0.7", lw=0.5)
    ax.set_xlabel("velocity w (rad/s)")
    ax.set_ylabel("friction torque F (N·m)")
    ax.set_title("Stribeck curve from quasi-static runs")
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
