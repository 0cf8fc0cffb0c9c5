r"""Model-form selection on the user's log: which friction model does the record support?

A friction engineer facing a log tries several forms of eqs. 1-3 and keeps the simplest one that predicts
as well as the others. :func:`select_form` does that on the record itself:

* ``coulomb_viscous``: ``F = Fc sgn(w) + sigma w`` (``Fs = Fc``), ``tau = 0``; parameters J, Fc, sigma
  (and the offset);
* ``coulomb_viscous_lag``: the same through the lag of eq. 1; + tau;
* ``stribeck``: eq. 3 with the given ``Vs``, ``delta``, ``tau = 0``; J, Fc, Fs, sigma (offset);
* ``stribeck_lag``: eq. 3 with the given ``Vs``, ``delta``, lag of eq. 1; + tau;
* ``stribeck_free``: eq. 3 with ``Vs`` and ``delta`` fitted too, ``tau = 0``; J, Fc, Fs, sigma, Vs,
  delta (offset);
* ``stribeck_free_lag``: eq. 3 with ``Vs``, ``delta`` fitted, lag of eq. 1; + tau.

The Stribeck forms with given ``Vs``, ``delta`` need them (a pre-fit, Sec. V-C); the free ones need
low-speed data: at least :data:`MIN_LOW_SPEED` samples with ``3*noise < |w| < 3*Vs`` (``Vs`` the given one,
else the free fit's own), otherwise they are listed as not identifiable from the log, with the count.

Fit and error
-------------
Every form is fitted by output error (simulation error, Ljung, *System Identification*, 2nd ed., Secs. 3.2,
7.2): the continuous-time model is integrated between the record's own time stamps
(:func:`adaptive_ff.identification.simulator.simulate_on_grid`; ``tau = 0`` integrates the static map) and
the velocity prediction errors are minimised by ``scipy.optimize.least_squares`` (soft-L1 loss, first at a
wide robust scale, then at the noise level, as in
:func:`adaptive_ff.identification.physical_id.fit_physical`), from starts built from the simpler nested forms
(the eq. 4 LS for Coulomb + viscous; profiles over ``log tau``, ``Fs`` and ``log Vs`` for the forms that add
them). The predictor (``predictor="auto"``) is the one ``fit_physical`` chooses from the noise level: free
run (output error, consistent under white noise) unless the record is nearly noise-free, then the one-step
predictor with the velocity reset to the measurement after each sample.

The input is taken ``input_delay`` before its stamps; where that delay is not given it is profiled as in
``fit_physical`` (:mod:`adaptive_ff.identification.delay_profile`): after the whole-record searches at delay 0 the
candidate of lowest whole-record cost among the identifiable ones is refitted at each sub-sample delay, and every
search, the held-out ones too, then runs at the delay of lowest cost (``FormSelection.input_delay``).

For these fits the out-of-sample error is that same prediction's error, because it is the error the fit minimises and the
one the model is used for (predicting the joint's motion from its torque); a regression error (the eq. 4 or
sliding-regime equation error) would judge a different, noise-biased predictor.

The sliding-regime regression (``method="sliding"``)
----------------------------------------------------
For a controller-rate log in closed loop (:func:`adaptive_ff.identification.identify.choose_method`), the
forms can instead be fitted by the torque regression of
:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding` (linear least squares on the filtered rows
that pass its sliding-regime gate; Coulomb + viscous sums the ``g`` and ``h`` columns, the free forms take
the ``(Vs, delta)`` of smallest training residual on a grid of 12 velocities times ``delta`` 0.5, 1, 2). Its
error is the regression's equation error on the filtered torque ``L[u]`` (N·m), one step, because that is
what the regression minimises and what the closed-loop log determines without bias (the torque is known
exactly, the velocity enters filtered); it is not comparable with the output-error table. ``k`` counts the
regression's parameters (the lag adds two: ``J*tau`` and ``tau``). Held-out rows are those whose sample lies
in the block; training rows leave out the block and the 11 filter time constants after it, whose filtered
regressors still remember the block (h-block cross-validation, Burman, Chow & Nolan, *Biometrika* 81(2),
1994).

Blocked cross-validation
------------------------
The record is cut into ``folds`` contiguous blocks (:func:`cv_blocks`; each sample is held out exactly once).
For each block the form is refitted on the other blocks: the model is simulated through the whole record on
the measured input, and only the residuals outside the held-out block enter the cost (the held-out velocity
is not read with the free-run predictor; with the one-step predictor only through the velocity reset at the
first training sample after the block). The held-out error is the mean
squared prediction error on the block (samples of the initial burn-in, 0.5 s, are not scored). Blocks rather
than random samples, because the residuals of neighbouring samples are correlated (Burman, Chow & Nolan,
*Biometrika* 81(2), 1994; Bergmeir & Benítez, *Inf. Sci.* 191, 2012). Each fold runs the whole search again
(the eq. 4 LS start on the rows outside the held-out block, the profiles, the fits) and one more fit started at
the whole-record estimate, and keeps the one of lower cost on its training blocks (the held-out block never
enters a cost; the starts do not either, except the whole-record estimate). The second start is needed: on the rough free-run cost the search alone stopped up to 15 %
above the training cost that the whole-record estimate attains (measured on a simulated Coulomb + viscous
record, 2 of 5 folds), which inflated the held-out errors by 5-10 % at random and let a lag-free record
choose a lag; the first keeps a fold free to leave the whole-record valley when its own data prefer another.

``cv_mse`` is the pooled held-out mean squared error, ``cv_se`` its standard error
``std(mse_k)/sqrt(K)`` over the ``K`` folds (Hastie, Tibshirani & Friedman, *The Elements of Statistical
Learning*, 2nd ed., Sec. 7.10).

Selection rule
--------------
``criterion="cv"`` (default): the **one-standard-error rule** (ESL Sec. 7.10.1): among the forms whose
``cv_mse`` is within one standard error of the smallest (``cv_mse <= min + cv_se(argmin)``), the one with
the fewest parameters (ties: the smaller ``cv_mse``). ``criterion="aic"`` or ``"bic"``: the smallest
information criterion on the whole-record residuals, assuming white Gaussian errors::

    AIC = n ln(RSS/n) + 2 k,        BIC = n ln(RSS/n) + k ln n

(``n`` scored samples, ``k`` parameters, ``RSS`` the plain sum of squared prediction errors). Both are
printed for every form; on real logs the residuals are coloured, so ``n`` overstates the information and AIC
and BIC favour the larger forms: the default is the cross-validated rule.

Intervals
---------
``stderr`` of a form is the delete-a-block jackknife over the cross-validation refits,
``sqrt((K-1)/K * sum_k (theta_k - mean theta)^2)`` (Künsch, *Ann. Statist.* 17(3), 1989; Shao & Tu, *The
Jackknife and Bootstrap*, 1995, Sec. 9.3) over the folds' own searches (not the warm-started fits: a fit
started at the estimate stays in its valley of the rough cost, and the spread of those understated the
error 2-3 times on simulated records); it costs nothing beyond the selection. With ``K = 5`` it has four
degrees of freedom: a rough figure, not the calibrated bootstrap of
:func:`adaptive_ff.identification.physical_id.fit_physical`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from adaptive_ff.identification.delay_profile import delay_profile_search
from adaptive_ff.identification.diagnostics import velocity_noise_std_irregular
from adaptive_ff.identification.log_scale import from_log
from adaptive_ff.identification.regression import RegressionModel, nrmse_fit
from adaptive_ff.identification.simulator import H_MAX_DEFAULT, input_grid, simulate_on_grid
from adaptive_ff.io.data import MeasuredData, to_uniform
from plant.dynamics import lagged_params
from plant.errors import (ExcitationError, ParameterError, check_finite_scalar, check_optional, check_optional_number,
                          check_positive)
from adaptive_ff.identification.form_results import FORMS, FormCandidate, FormSelection

__all__ = ["FORMS", "CRITERIA", "SELECTION_METHODS", "MIN_LOW_SPEED", "FormCandidate", "FormSelection",
           "select_form", "cv_blocks", "one_standard_error_choice"]


#: Selection criteria of :func:`select_form`.
CRITERIA = ("cv", "aic", "bic")

#: Fit methods of :func:`select_form` (the prediction whose error is judged).
SELECTION_METHODS = ("output_error", "sliding")

#: Fewest resolved low-speed samples (``3*noise < |w| < 3*Vs``) for fitting ``Vs`` and ``delta``.
MIN_LOW_SPEED = 200

_BURN = 0.5  # s at the start not scored (the initial state is a guess)
_ONE_STEP_NOISE = 3e-4  # as physical_id: below this noise (fraction of peak |w|) the one-step predictor
_MAX_NFEV = 100
#: Shape factors the free Stribeck forms may take (trial points outside get a large residual); eq. 3 fits
#: report 0.5-2 (Ruderman; Armstrong-Hélouvry, Automatica 30(7), 1994).
_DELTA_RANGE = (0.2, 5.0)


def cv_blocks(n: int, folds: int) -> list:
    """Contiguous cross-validation blocks that partition ``range(n)``.

    Parameters
    ----------
    n : int
        Number of samples, ``>= folds``.
    folds : int
        Number of blocks, ``>= 2``.

    Returns
    -------
    list of (int, int)
        ``(start, stop)`` of each block (half-open), in order, sizes differing by at most one
        (``numpy.array_split``).

    Raises
    ------
    ParameterError
        ``folds`` not an integer >= 2, or more blocks than samples.
    """
    folds = _check_folds(folds)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < folds:
        raise ParameterError(f"n must be an integer >= folds = {folds}, got {n!r}")
    edges = np.cumsum([0] + [len(a) for a in np.array_split(np.arange(int(n)), folds)])
    return [(int(edges[i]), int(edges[i + 1])) for i in range(folds)]


def one_standard_error_choice(rows) -> tuple[str, str]:
    """The one-standard-error rule (ESL Sec. 7.10.1) on a table of ``(name, n_params, cv_mse, cv_se)``.

    Parameters
    ----------
    rows : iterable of (str, int, float, float)
        Candidates; rows with a non-finite ``cv_mse`` are ignored.

    Returns
    -------
    name : str
        Among the rows with ``cv_mse <= min cv_mse + cv_se`` (of the row with the smallest ``cv_mse``), the one
        with the fewest parameters; ties by the smaller ``cv_mse``.
    rule : str
        The rule with its numbers, for the report.

    Raises
    ------
    ExcitationError
        No row with a finite ``cv_mse``.
    """
    rows = [(str(n), int(k), float(m), float(s)) for n, k, m, s in rows if math.isfinite(m)]
    if not rows:
        raise ExcitationError("no candidate form could be fitted and cross-validated on this record")
    best = min(rows, key=lambda r: r[2])
    se = best[3] if math.isfinite(best[3]) else 0.0
    limit = best[2] + se
    within = [r for r in rows if r[2] <= limit]
    pick = min(within, key=lambda r: (r[1], r[2]))
    return pick[0], (f"one-standard-error rule (ESL 7.10.1): smallest CV MSE {best[2]:.4g} ({best[0]}) + its "
                     f"standard error {se:.2g} = {limit:.4g}; fewest parameters among the {len(within)} form(s) "
                     f"within it: {pick[0]} (k = {pick[1]})")


def _check_folds(folds) -> int:
    if isinstance(folds, bool) or not isinstance(folds, (int, np.integer)) or folds < 2:
        raise ParameterError(f"folds must be an integer >= 2, got {folds!r}")
    return int(folds)


class _Problem:
    """The prediction errors of every form on one record; parameter vectors by form (see ``_layout``)."""

    def __init__(self, data: MeasuredData, Vs, delta, offset: bool, h_max: float, input_delay: float,
                 predictor: str = "auto"):
        t, u, w = data.t, data.u, data.w
        self.t, self.u, self.w = t, u, w
        self.grid = input_grid(t, u, h_max=h_max, input_delay=input_delay)
        self.h_max, self.input_delay, self.n_sim = h_max, float(input_delay), 0
        self.i0 = int(np.searchsorted(t, t[0] + _BURN))
        self.Vs, self.delta, self.offset = Vs, delta, offset
        self.noise = float(velocity_noise_std_irregular(t, w))
        self.peak = float(np.max(np.abs(w)))
        self.predictor = predictor if predictor != "auto" else (
            "one-step" if self.noise < _ONE_STEP_NOISE * self.peak else "free-run")
        self.gain = (1.0, 0.0) if self.predictor == "one-step" else (0.0, 0.0)
        self.f_scale = max(3.0 * self.noise, 1e-3 * self.peak)
        self.f_wide = max(self.f_scale, 1e-2 * self.peak)
        self.big = 10.0 * (self.peak + 1.0)
        self.w0, self.f0 = float(w[0]), float(u[0])
        self.Ts = float(np.median(np.diff(t)))
        self.torque = 1.0

    def set_delay(self, d: float) -> None:
        """Take each input sample ``d`` s before its stamp from now on (the input grid rebuilt)."""
        if d != self.input_delay:
            self.grid = input_grid(self.t, self.u, h_max=self.h_max, input_delay=d)
            self.input_delay = float(d)

    @staticmethod
    def layout(name: str, offset: bool) -> tuple:
        _, stribeck, lag = FORMS[name]
        return (("logJ", "Fc", "sigma") + (("Fs",) if stribeck != "none" else ()) + (("logtau",) if lag else ())
                + (("logVs", "delta") if stribeck == "free" else ()) + (("off",) if offset else ()))

    def unpack(self, name: str, x) -> dict:
        """``{J, Fc, Fs, sigma, tau, offset, Vs, delta}`` of the vector ``x`` of form ``name``."""
        lay = self.layout(name, self.offset)
        v = dict(zip(lay, (float(a) for a in x)))
        _, stribeck, _ = FORMS[name]
        Fc = v["Fc"]
        Vs, delta = (self.Vs, self.delta) if stribeck == "fixed" else (
            (from_log(v["logVs"]), v["delta"]) if stribeck == "free" else (self.Vs or 1.0, self.delta or 1.0))
        return {"J": from_log(v["logJ"]), "Fc": Fc, "Fs": v.get("Fs", Fc), "sigma": v["sigma"],
                "tau": from_log(v["logtau"]) if "logtau" in v else 0.0,
                "offset": v.get("off", 0.0) * self.torque, "Vs": float(Vs), "delta": float(delta)}

    def pack(self, name: str, p: dict) -> np.ndarray:
        out = []
        for k in self.layout(name, self.offset):
            out.append({"logJ": lambda: math.log(p["J"]), "logtau": lambda: math.log(max(p["tau"], 1e-6)),
                        "logVs": lambda: math.log(p["Vs"]), "off": lambda: p["offset"] / self.torque}.get(
                k, lambda kk=k: p[kk])())
        return np.array(out, dtype=float)

    def typical(self, name: str, x) -> np.ndarray:
        """Typical changes: 2 % of J, 1 % of the torques, 3 % of tau and Vs, 0.05 of delta, 1 % of Fc (offset)."""
        p = self.unpack(name, x)
        scale = {"logJ": 0.02, "Fc": 0.01 * abs(p["Fc"]) + 1e-9, "Fs": 0.01 * abs(p["Fs"]) + 1e-9,
                 "sigma": 0.01 * abs(p["sigma"]) + 1e-3 * abs(p["Fc"]) / max(self.peak, 1e-12) + 1e-12,
                 "logtau": 0.03, "logVs": 0.03, "delta": 0.05, "off": 0.01}
        return np.array([scale[k] for k in self.layout(name, self.offset)])

    def simulate(self, name: str, x) -> np.ndarray:
        p = self.unpack(name, x)
        if not (p["Vs"] > 0 and p["delta"] != 0 and math.isfinite(p["J"]) and p["J"] > 0):
            return np.full(self.w.shape[0], np.nan)
        free = FORMS[name][1] == "free"
        if (p["tau"] > 0 and p["tau"] < 0.4 * self.h_max) or (
                free and not _DELTA_RANGE[0] <= p["delta"] <= _DELTA_RANGE[1]):
            return np.full(self.w.shape[0], np.nan)
        try:
            par = lagged_params(p["J"], p["Fc"], p["Fs"], p["Vs"], p["delta"], p["sigma"], p["tau"])
        except (OverflowError, ValueError, ZeroDivisionError, ParameterError):
            return np.full(self.w.shape[0], np.nan)  # a trial point outside the model's range: a large residual
        self.n_sim += 1
        return simulate_on_grid(par, self.grid, w0=self.w0, f0=self.f0, offset=p["offset"], gain=self.gain,
                                w_meas=self.w)

    def residuals(self, name: str, x, mask) -> np.ndarray:
        """Prediction errors (rad/s) on the samples of ``mask``; a large constant where the simulation diverged."""
        r = self.simulate(name, x)[mask] - self.w[mask]
        return np.where(np.isfinite(r), r, self.big)

    def cost(self, name, x, mask, fsc) -> float:
        r = self.residuals(name, x, mask)
        return float(np.sum(np.sqrt(1.0 + (r / fsc) ** 2) - 1.0))

    def refine(self, name: str, x, mask, fsc, ds=1e-2, max_nfev=_MAX_NFEV) -> np.ndarray:
        sol = least_squares(lambda z: self.residuals(name, z, mask), x, diff_step=ds, x_scale=self.typical(name, x),
                            method="trf", xtol=1e-8, ftol=1e-10, max_nfev=max_nfev, loss="soft_l1", f_scale=fsc)
        return sol.x

    def fit(self, name: str, x0, mask) -> np.ndarray:
        """Wide-scale then noise-level trust-region fit from ``x0``; the lower-cost of start and result."""
        x = self.refine(name, x0, mask, self.f_wide)
        x = self.refine(name, x, mask, self.f_scale, ds=1e-2 / 3.0)
        return x if self.cost(name, x, mask, self.f_scale) <= self.cost(name, x0, mask, self.f_scale) else x0

    def profile(self, name: str, x, key: str, grid, mask) -> np.ndarray:
        """``x`` with coordinate ``key`` set to the best of ``grid`` at the wide robust scale."""
        j = self.layout(name, self.offset).index(key)
        best = None
        for v in grid:
            xx = np.array(x, dtype=float)
            xx[j] = v
            c = self.cost(name, xx, mask, self.f_wide)
            if best is None or c < best[0]:
                best = (c, xx)
        return best[1]


def _ls_start(uni: MeasuredData, offset: bool, held=None) -> dict:
    """Start values from the eq. 4 LS of the Coulomb + viscous structure on the uniform record ``uni``, with the
    rows that touch the time window ``held = (t_start, t_stop)`` left out; fallbacks by scale."""
    model = RegressionModel(None, None, lag=False, stribeck=False, offset=offset)
    J = Fc = sigma = math.nan
    off = 0.0
    try:
        X, y = model.regressors(uni.u, uni.w)
        keep = np.ones(y.shape[0], dtype=bool)
        if held is not None:
            tk = uni.t[2:]
            keep = (tk < held[0]) | (tk > held[1] + 2.0 * uni.Ts)
        sc = np.linalg.norm(X[keep], axis=0)
        sc = np.where(sc > 0, sc, 1.0)
        theta = np.linalg.lstsq(X[keep] / sc, y[keep], rcond=None)[0] / sc
        est = model.to_physical(theta, uni.Ts)
        J, Fc, sigma, off = est.J, est.Fc, est.sigma, (est.offset if offset else 0.0)
    except (ExcitationError, ParameterError, np.linalg.LinAlgError):
        pass
    if not (math.isfinite(J) and J > 0):
        J = float(np.std(uni.u) / max(np.std(np.gradient(uni.w, uni.t)), 1e-12))
    if not (math.isfinite(Fc) and Fc > 0):
        Fc = 0.1 * float(np.std(uni.u))
    if not (math.isfinite(sigma) and sigma >= 0):
        sigma = 0.0
    return {"J": J, "Fc": Fc, "Fs": Fc, "sigma": sigma, "tau": 0.0, "offset": off if math.isfinite(off) else 0.0}


def _full_fits(pb: _Problem, names, start: dict, mask, warm: dict | None = None, cold: dict | None = None) -> dict:
    """Whole-record fits of the forms ``names`` (and of the simpler nested forms they start from).

    Coulomb + viscous starts at the eq. 4 LS; a lag is added by a profile over ``log tau`` (9 points,
    ``max(Ts/2, 1.2 h_max)`` to ``20 Ts``), a Stribeck peak by a profile over ``Fs`` (13 points, ``Fc`` to
    ``2.5 Fc``), free ``Vs`` by a profile over ``log Vs`` (9 points, ``3*noise`` to ``0.3*peak |w|``) with
    ``delta = 1``; ``warm`` (``{name: x}``, the whole-record fits) adds one more start per form. Each form
    keeps the fit of lowest cost on ``mask``; ``cold`` (a dict, filled) receives the best fit without the warm
    start.
    """
    fits: dict = {}
    tau_grid = np.log(np.geomspace(max(0.5 * pb.Ts, 1.2 * pb.h_max), 20.0 * pb.Ts, 9))
    vs_grid = np.log(np.geomspace(max(3.0 * pb.noise, 1e-3 * pb.peak), 0.3 * pb.peak, 9))
    lagged = any(FORMS[f][2] for f in names)
    fixed = pb.Vs is not None and any(FORMS[f][1] != "none" for f in names)

    def run(name, starts):
        best = None
        for s in starts:
            x = pb.fit(name, s, mask)
            c = pb.cost(name, x, mask, pb.f_scale)
            if best is None or c < best[0]:
                best = (c, x)
        if cold is not None:
            cold[name] = best[1]
        if warm is not None and name in warm:
            x = pb.fit(name, warm[name], mask)
            c = pb.cost(name, x, mask, pb.f_scale)
            if c < best[0]:
                best = (c, x)
        fits[name] = best[1]

    def params(name):
        return pb.unpack(name, fits[name])

    def with_lag(name, p):
        return pb.profile(name, pb.pack(name, dict(p, tau=math.exp(tau_grid[0]))), "logtau", tau_grid, mask)

    def with_fs(name, x):
        Fc = pb.unpack(name, x)["Fc"]
        return pb.profile(name, x, "Fs", np.linspace(Fc, 2.5 * Fc, 13), mask)

    run("coulomb_viscous", [pb.pack("coulomb_viscous", start)])
    if lagged:
        run("coulomb_viscous_lag", [with_lag("coulomb_viscous_lag", params("coulomb_viscous"))])
    if fixed:
        run("stribeck", [with_fs("stribeck", pb.pack("stribeck", params("coulomb_viscous")))])
        if lagged:
            run("stribeck_lag", [with_lag("stribeck_lag", params("stribeck")),
                                 with_fs("stribeck_lag", pb.pack("stribeck_lag", params("coulomb_viscous_lag")))])
    for name, lag in (("stribeck_free", False), ("stribeck_free_lag", True)):
        if name not in names:
            continue
        cv = params("coulomb_viscous_lag" if lag else "coulomb_viscous")
        x = pb.pack(name, dict(cv, Fs=1.5 * cv["Fc"], delta=1.0, Vs=from_log(vs_grid[4])))
        starts = [with_fs(name, pb.profile(name, x, "logVs", vs_grid, mask))]
        if fixed:
            starts.append(pb.pack(name, params("stribeck_lag" if lag else "stribeck")))
        run(name, starts)
    return fits


def _low_speed_count(pb: _Problem, Vs: float) -> int:
    aw = np.abs(pb.w)
    return int(np.count_nonzero((aw > 3.0 * pb.noise) & (aw < 3.0 * Vs)))


def _candidate(pb: _Problem, name: str, x, fold_fits, fold_cold, blocks, scored) -> FormCandidate:
    """The candidate ``name`` with its whole-record fit ``x``, the fold fits ``fold_fits[k][name]`` (held-out
    errors) and the fold fits of the own search alone ``fold_cold[k][name]`` (jackknife)."""
    label, stribeck, lag = FORMS[name]
    lay = pb.layout(name, pb.offset)
    w_hat = pb.simulate(name, x)
    r = (w_hat - pb.w)[scored]
    n = int(r.shape[0])
    rss = float(r @ r) if np.all(np.isfinite(r)) else math.inf
    k = len(lay)
    fold_mse, thetas, ns = [], [], []
    for (a, b), ff, fc in zip(blocks, fold_fits, fold_cold):
        xk = ff[name]
        thetas.append(fc[name])
        held = np.zeros(pb.w.shape[0], dtype=bool)
        held[a:b] = True
        rk = (pb.simulate(name, xk) - pb.w)[held & scored]
        ns.append(rk.size)
        fold_mse.append(float(np.mean(rk**2)) if rk.size and np.all(np.isfinite(rk)) else
                        (math.inf if rk.size else math.nan))
    use = [i for i, m in enumerate(fold_mse) if not math.isnan(m)]
    fm, nn = np.array([fold_mse[i] for i in use]), np.array([ns[i] for i in use], dtype=float)
    cv_mse = float(np.sum(fm * nn) / np.sum(nn)) if nn.sum() else math.nan
    cv_se = float(np.std(fm, ddof=1) / math.sqrt(fm.shape[0])) if fm.shape[0] > 1 else math.nan
    params = pb.unpack(name, x)
    if stribeck == "none":  # Fs = Fc: Vs and delta have no effect
        del params["Vs"], params["delta"]
    fitted = tuple({"logJ": "J", "logtau": "tau", "logVs": "Vs", "off": "offset"}.get(s, s) for s in lay)
    P = np.array([[pb.unpack(name, th)[f] for f in fitted] for th in thetas])
    K = P.shape[0]
    jack = np.sqrt((K - 1) / K * np.sum((P - P.mean(axis=0)) ** 2, axis=0))
    stderr = {f: float(v) for f, v in zip(fitted, jack)}
    finite = rss > 0 and math.isfinite(rss) and n > 0
    aic = n * math.log(rss / n) + 2 * k if finite else math.nan
    bic = n * math.log(rss / n) + k * math.log(n) if finite else math.nan
    return FormCandidate(name=name, label=label, stribeck=stribeck, lag=lag, status="fitted", n_params=k,
                         params=params, stderr=stderr, fitted=fitted, rms=math.sqrt(rss / n) if n else math.nan,
                         fit_percent=float(nrmse_fit(pb.w[scored], w_hat[scored])), cv_mse=cv_mse, cv_se=cv_se,
                         cv_fold_mse=tuple(fold_mse), aic=aic, bic=bic, n_scored=n)


def _not_fitted(name: str, status: str, offset: bool, k: int | None = None) -> FormCandidate:
    label, stribeck, lag = FORMS[name]
    return FormCandidate(name=name, label=label, stribeck=stribeck, lag=lag, status=status,
                         n_params=len(_Problem.layout(name, offset)) if k is None else k)


def _select_output_error(data, Vs, delta, offset: bool, folds: int, names, h_max, input_delay, predictor,
                         progress=False):
    """The candidates of :func:`select_form` by output error: ``(candidates, blocks, predictor, noise, n)``;
    ``progress``: a tqdm bar on stderr over the whole-record search, the input-delay profile (``input_delay``
    None) and the ``folds`` held-out searches."""
    from tqdm.auto import tqdm

    pb = _Problem(data, Vs, delta, offset, h_max, 0.0 if input_delay is None else input_delay, predictor)
    n = data.t.shape[0]
    scored = np.zeros(n, dtype=bool)
    scored[pb.i0:] = True
    if np.count_nonzero(scored) < max(2 * folds, 20):
        raise ParameterError(f"the record ({data.t[-1] - data.t[0]:.4g} s) is too short: the first {_BURN} s "
                             "are not scored")
    blocks = cv_blocks(n, folds)
    uni = to_uniform(data)
    start = _ls_start(uni, offset)
    pb.torque = max(abs(start["Fc"]), 1e-3 * float(np.std(data.u)))
    status = {}
    run = []
    for f in names:
        if FORMS[f][1] == "fixed" and Vs is None:
            status[f] = "not run: needs Vs and delta (the Stribeck pre-fit, adaptive-ff stribeck)"
        else:
            run.append(f)
    bar = tqdm(total=1 + folds + (input_delay is None), desc="form fits", unit="search", leave=False,
               disable=None if progress is None else not progress)
    fits = _full_fits(pb, run, start, scored)
    bar.update(1)
    profile = None
    if input_delay is None:  # not given: profiled on the whole record, every search then at the delay chosen
        fits, profile = _delay_fits(pb, run, _identifiable(pb, run, fits, Vs)[0], start, scored, fits)
        bar.update(1)
    keep, unfit = _identifiable(pb, run, fits, Vs)
    status.update(unfit)
    fold_fits, fold_cold = [], []
    for a, b in blocks:  # each block held out: the whole search again on the other blocks, from their own start
        train = scored.copy()
        train[a:b] = False
        cold: dict = {}
        fold_fits.append(_full_fits(pb, keep, _ls_start(uni, offset, (data.t[a], data.t[b - 1])), train,
                                    warm=fits, cold=cold))
        fold_cold.append(cold)
        bar.update(1)
    bar.close()
    cands = []
    for f in names:
        if f in status:
            cands.append(_not_fitted(f, status[f], pb.offset))
            continue
        cands.append(_candidate(pb, f, fits[f], fold_fits, fold_cold, blocks, scored))
    return cands, blocks, pb.predictor, pb.noise, n, (pb.input_delay, profile)


def _identifiable(pb: _Problem, run, fits: dict, Vs) -> tuple[list, dict]:
    """The forms of ``run`` the log identifies, and ``{name: status}`` of the free Stribeck forms it does not
    (fewer than :data:`MIN_LOW_SPEED` samples in ``3*noise < |w| < 3*Vs``, ``Vs`` the given one or the fit's)."""
    keep, status = [], {}
    for f in run:
        if FORMS[f][1] == "free":
            vs_ref = Vs if Vs is not None else pb.unpack(f, fits[f])["Vs"]
            low = _low_speed_count(pb, vs_ref)
            if low < MIN_LOW_SPEED:
                status[f] = (f"not identifiable from this log: {low} samples with {3 * pb.noise:.3g} < |w| < "
                             f"3*Vs = {3 * vs_ref:.3g} (need {MIN_LOW_SPEED})")
                continue
        keep.append(f)
    return keep, status


def _delay_fits(pb: _Problem, run, ok, start: dict, scored, fits: dict) -> tuple[dict, dict]:
    """The input delay profiled on the whole record, as in ``fit_physical``
    (:func:`adaptive_ff.identification.delay_profile.delay_profile_search`): the form of lowest whole-record cost
    among the identifiable forms ``ok`` (their searches at delay 0, ``fits``) refitted from its estimate at each
    sub-sample delay (:meth:`_Problem.fit`), the delay of lowest cost kept; then the whole-record searches of the
    forms ``run`` again at that delay with the fits at delay 0 as one more start each (:func:`_full_fits`).
    Returns ``(fits, details)``: the fits at the delay chosen (``pb`` left there) and the profile's details with
    the form it was run on (``form``)."""
    costs = {f: pb.cost(f, fits[f], scored, pb.f_scale) for f in (ok or run)}
    ref = min(costs, key=costs.get)

    def refit(x):
        z = pb.fit(ref, x, scored)
        return pb.cost(ref, z, scored, pb.f_scale), z

    _, details = delay_profile_search(pb, (costs[ref], fits[ref]), refit)
    details["form"] = ref
    if pb.input_delay != 0.0:
        fits = _full_fits(pb, run, start, scored, warm=fits)
    return fits, details


#: Stribeck shape factors and number of Stribeck velocities of the grid search of the free forms (sliding).
_SLIDING_DELTAS = (0.5, 1.0, 2.0)
_SLIDING_N_VS = 12
#: Rows after a held-out block left out of the training rows, in filter time constants (the cascade of three
#: first-order lags of the sliding regressors forgets a sample to 1e-3 after about 11 time constants).
_SLIDING_GAP = 11.0


def _sliding_k(name: str, offset: bool) -> int:
    """Regression parameters of a form in the sliding regression: J, Fc, sigma (+ Fs, + J*tau and tau with the
    lag, + Vs and delta when fitted, + offset)."""
    _, stribeck, lag = FORMS[name]
    return 3 + (stribeck != "none") + 2 * lag + 2 * (stribeck == "free") + offset


def _sliding_rows(uni, name, Vs, delta, offset, band):
    """``(X, y, index, names)`` of the sliding regression for a form; Coulomb + viscous sums the ``Fc`` and ``Fs``
    columns (``Fs = Fc``). ``band``: the gate's ``w_band_min`` (rad/s), the same for every form and ``Vs``, so
    that all fits see the same rows."""
    from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig, sliding_regressors

    lag = FORMS[name][2]
    X, y, idx, _, names = sliding_regressors(uni.u, uni.w, Tc=uni.Ts, Vs=Vs, delta=delta,
                                             config=SlidingFrictionEstimatorConfig(Ts=uni.Ts, lag=lag, offset=offset,
                                                                                   w_band_min=band))
    names = list(names)
    if FORMS[name][1] == "none":
        i, j = names.index("Fc"), names.index("Fs")
        X = X.copy()
        X[:, i] += X[:, j]  # g(w) + h(w) = sgn(w): Fc*g + Fs*h with Fs = Fc
        X = np.delete(X, j, axis=1)
        names.pop(j)
    return X, y, idx, tuple(names)


def _lstsq(X, y):
    sc = np.linalg.norm(X, axis=0)
    sc = np.where(sc > 0, sc, 1.0)
    return np.linalg.lstsq(X / sc, y, rcond=None)[0] / sc


def _sliding_fit(uni, name, Vs, delta, offset, train_of, grid, band) -> dict:
    """The least-squares fit of a form on the rows ``train_of(index)`` selects: ``theta``, ``names``, ``Vs``,
    ``delta`` (for the free forms the grid point of smallest training residual)."""
    pts = grid if FORMS[name][1] == "free" else [(Vs if Vs is not None else 1.0, delta if delta is not None else 1.0)]
    best = None
    for vs, de in pts:
        X, y, idx, names = _sliding_rows(uni, name, vs, de, offset, band)
        m = train_of(idx)
        if np.count_nonzero(m) < 2 * X.shape[1]:
            continue
        th = _lstsq(X[m], y[m])
        r = y[m] - X[m] @ th
        c = float(r @ r)
        if best is None or c < best[0]:
            best = (c, {"theta": th, "names": names, "Vs": vs, "delta": de})
    if best is None:
        raise ExcitationError(f"form {name!r}: too few sliding-regime rows to fit")
    return best[1]


def _sliding_params(name, fit, offset) -> dict:
    from adaptive_ff.compensation.sliding_estimator import estimate_from_theta

    d = dict(zip(fit["names"], (float(x) for x in fit["theta"])))
    if "Fs" not in d:
        d["Fs"] = d["Fc"]
    names = tuple(d)
    e = estimate_from_theta(names, [d[k] for k in names], fit["Vs"], fit["delta"])
    p = {"J": e.J, "Fc": e.Fc, "Fs": e.Fs, "sigma": e.sigma, "tau": e.tau, "offset": e.offset if offset else 0.0}
    if FORMS[name][1] != "none":
        p.update(Vs=float(fit["Vs"]), delta=float(fit["delta"]))
    return p


def _select_sliding(data, Vs, delta, offset: bool, folds: int, names):
    """The candidates of :func:`select_form` by the sliding regression: ``(candidates, blocks, kind, noise, n)``.

    Blocks are contiguous on the uniform grid; a row is held out when its sample lies in the block, and the
    training rows leave out the block and the :data:`_SLIDING_GAP` filter time constants after it (rows whose
    filtered regressors still remember held-out samples: h-block cross-validation, Burman, Chow & Nolan 1994).
    """
    from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimator, SlidingFrictionEstimatorConfig

    uni = to_uniform(data)
    n = uni.n_samples
    noise = float(velocity_noise_std_irregular(uni.t, uni.w))
    peak = float(np.max(np.abs(uni.w)))
    blocks = cv_blocks(n, folds)
    T = SlidingFrictionEstimator(1.0, 1.0, Tc=uni.Ts, config=SlidingFrictionEstimatorConfig(Ts=uni.Ts)).T
    gap = int(math.ceil(_SLIDING_GAP * T / uni.Ts))
    # the gate's least band: fit_sliding's 0.1*Vs of the pre-fit, else the noise's 4 sigma (its adaptive band)
    band = 0.1 * Vs if Vs is not None else max(4.0 * noise, 1e-6 * peak, 1e-12)
    grid = [(float(v), d) for v in np.geomspace(max(3.0 * noise, 1e-3 * peak), 0.3 * peak, _SLIDING_N_VS)
            for d in _SLIDING_DELTAS]
    cands = []
    for f in names:
        k = _sliding_k(f, offset)
        if FORMS[f][1] == "fixed" and Vs is None:
            cands.append(_not_fitted(f, "not run: needs Vs and delta (the Stribeck pre-fit, adaptive-ff stribeck)",
                                     offset, k))
            continue
        full = _sliding_fit(uni, f, Vs, delta, offset, lambda idx: np.ones(idx.shape[0], dtype=bool), grid, band)
        if FORMS[f][1] == "free":
            aw = np.abs(uni.w)
            low = int(np.count_nonzero((aw > 3.0 * noise) & (aw < 3.0 * full["Vs"])))
            if low < MIN_LOW_SPEED:
                cands.append(_not_fitted(f, f"not identifiable from this log: {low} samples with {3 * noise:.3g} "
                                            f"< |w| < 3*Vs = {3 * full['Vs']:.3g} (need {MIN_LOW_SPEED})", offset, k))
                continue
        X, y, idx, _ = _sliding_rows(uni, f, full["Vs"], full["delta"], offset, band)
        r = y - X @ full["theta"]
        fold_mse, ests, ns = [], [], []
        for a, b in blocks:
            fk = _sliding_fit(uni, f, Vs, delta, offset, lambda i, a=a, b=b: (i < a) | (i >= b + gap), grid, band)
            Xk, yk, ik, _ = _sliding_rows(uni, f, fk["Vs"], fk["delta"], offset, band)
            held = (ik >= a) & (ik < b)
            rk = yk[held] - Xk[held] @ fk["theta"]
            ns.append(int(rk.size))
            fold_mse.append(float(np.mean(rk**2)) if rk.size else math.nan)
            ests.append(_sliding_params(f, fk, offset))
        cands.append(_sliding_candidate(f, k, full, r, y, X, fold_mse, ns, ests, offset))
    return cands, blocks, "regression (filtered torque L[u])", noise, n


def _sliding_candidate(name, k, full, r, y, X, fold_mse, ns, ests, offset) -> FormCandidate:
    label, stribeck, lag = FORMS[name]
    use = [i for i, m in enumerate(fold_mse) if math.isfinite(m)]
    fm, nn = np.array([fold_mse[i] for i in use]), np.array([ns[i] for i in use], dtype=float)
    cv_mse = float(np.sum(fm * nn) / np.sum(nn)) if nn.sum() else math.nan
    cv_se = float(np.std(fm, ddof=1) / math.sqrt(fm.shape[0])) if fm.shape[0] > 1 else math.nan
    params = _sliding_params(name, full, offset)
    fitted = tuple(["J", "Fc"] + (["Fs"] if stribeck != "none" else []) + ["sigma"] + (["tau"] if lag else [])
                   + (["Vs", "delta"] if stribeck == "free" else []) + (["offset"] if offset else []))
    P = np.array([[e[q] for q in fitted] for e in ests])
    K = P.shape[0]
    jack = np.sqrt((K - 1) / K * np.sum((P - P.mean(axis=0)) ** 2, axis=0))
    n = int(r.shape[0])
    rss = float(r @ r)
    finite = rss > 0 and n > 0
    return FormCandidate(name=name, label=label, stribeck=stribeck, lag=lag, status="fitted", n_params=k,
                         params=params, stderr={q: float(v) for q, v in zip(fitted, jack)}, fitted=fitted,
                         rms=math.sqrt(rss / n) if n else math.nan, fit_percent=float(nrmse_fit(y, X @ full["theta"])),
                         cv_mse=cv_mse, cv_se=cv_se, cv_fold_mse=tuple(fold_mse),
                         aic=n * math.log(rss / n) + 2 * k if finite else math.nan,
                         bic=n * math.log(rss / n) + k * math.log(n) if finite else math.nan, n_scored=n)


def select_form(data: MeasuredData, *, Vs: float | None = None, delta: float | None = None,
                method: str = "output_error", folds: int = 5, criterion: str = "cv", offset: bool = True,
                forms=None, h_max: float = H_MAX_DEFAULT, input_delay: float | None = None,
                predictor: str = "auto", progress: bool | None = False) -> FormSelection:
    """Fit the candidate friction forms to a record and choose one by blocked cross-validation (or AIC/BIC).

    Parameters
    ----------
    data : MeasuredData
        The record: ``t`` (s, increasing; any spacing), input ``u`` (N·m or N), velocity ``w`` (rad/s or m/s),
        shape (N,). Both directions of motion are needed (Fc is told from the offset by the reversals).
    Vs, delta : float, keyword-only, optional
        Pre-fitted Stribeck velocity (rad/s, > 0) and shape factor (non-zero), both or neither: the forms
        ``stribeck`` and ``stribeck_lag`` need them (listed as not run otherwise); the free forms start there.
    method : str, keyword-only
        One of :data:`SELECTION_METHODS`: ``"output_error"`` (default; the simulation error, module
        docstring) or ``"sliding"`` (the sliding-regime torque regression on the uniform grid, for
        controller-rate closed-loop logs; its equation error; ``h_max``, ``input_delay`` and ``predictor``
        do not apply).
    folds : int, keyword-only
        Contiguous cross-validation blocks, >= 2 (default 5).
    criterion : str, keyword-only
        ``"cv"`` (default: one-standard-error rule on the blocked-CV error), ``"aic"`` or ``"bic"``.
    offset : bool, keyword-only
        Fit a constant torque bias in every form (default True).
    forms : iterable of str or None, keyword-only
        Names of :data:`FORMS` to try (default all).
    h_max : float, keyword-only
        Largest RK4 sub-step of the simulation (s), default 1 ms.
    input_delay : float or None, keyword-only
        Time (s) by which each input sample precedes its time stamp, >= 0 (as in
        :class:`adaptive_ff.identification.physical_id.OutputErrorOptions`). None (default): not known, profiled
        as the output-error fit profiles it (:func:`adaptive_ff.identification.delay_profile.delay_profile_search`
        on the whole record, with the form of lowest whole-record cost refitted at each sub-sample delay); every
        search, the held-out ones too, then runs at the delay chosen (``FormSelection.input_delay``,
        ``input_delay_profile``).
    predictor : {"auto", "free-run", "one-step"}, keyword-only
        The prediction fitted and judged: ``"auto"`` (default) chooses as ``fit_physical`` does (one-step
        below a velocity noise of 0.03 % of the peak ``|w|``, else free run).

    progress : bool or None, keyword-only
        A tqdm bar on stderr over the output-error searches (the whole record, then each held-out block):
        True, False (default) or None (only when stderr is a terminal; the CLI's choice unless ``--quiet``).
        The result does not depend on it.

    Returns
    -------
    FormSelection
        Every candidate (fitted or why not), the chosen form and the rule.

    Raises
    ------
    TypeError
        ``data`` is not a :class:`MeasuredData`.
    ParameterError
        ``folds`` not an integer >= 2, an unknown ``criterion``, ``method`` or form name, only one of
        ``Vs``/``delta``, an invalid ``Vs``/``delta``/``h_max``, or more blocks than samples.
    ExcitationError
        No velocity reversal (Fc is not identifiable), constant input, or no candidate could be fitted.

    Notes
    -----
    The out-of-sample error is the output-error (simulation) prediction error on each held-out block, the
    error the fit minimises; the rule is the one-standard-error rule of Hastie, Tibshirani & Friedman (ESL,
    2nd ed., Sec. 7.10.1) towards fewer parameters. Module docstring: forms, fit, blocks, criteria, intervals.

    Examples
    --------
    >>> sel = select_form(data, Vs=0.02, delta=1.0)          # doctest: +SKIP
    >>> print(sel.summary()); sel.best.params                 # doctest: +SKIP
    """
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    folds = _check_folds(folds)
    if criterion not in CRITERIA:
        raise ParameterError(f"criterion must be one of {CRITERIA}, got {criterion!r}")
    if method not in SELECTION_METHODS:
        raise ParameterError(f"method must be one of {SELECTION_METHODS}, got {method!r}")
    if (Vs is None) != (delta is None):
        raise ParameterError(f"give both Vs and delta, or neither; got Vs = {Vs!r}, delta = {delta!r}")
    if Vs is not None:
        Vs = check_positive("Vs", Vs)
        delta = check_finite_scalar("delta", delta)
        if delta == 0.0:
            raise ParameterError("delta must be non-zero, got 0.0")
    h_max = check_positive("h_max", h_max)
    input_delay = check_optional_number("input_delay", input_delay, low=0.0, unit="s", none="profiled")
    if predictor not in ("auto", "free-run", "one-step"):
        raise ParameterError(f"predictor must be one of ['auto', 'free-run', 'one-step'], got {predictor!r}")
    names = list(FORMS) if forms is None else [forms] if isinstance(forms, str) else list(forms)
    bad = [f for f in names if f not in FORMS]
    if bad or not names:
        raise ParameterError(f"forms must be names among {list(FORMS)}, got {forms!r}")
    names = [f for f in FORMS if f in names]
    if data.t.shape[0] < max(2 * folds, 20):
        raise ParameterError(f"folds = {folds} needs at least {max(2 * folds, 20)} samples, the record has "
                             f"{data.t.shape[0]}")
    sg = np.sign(data.w[np.abs(data.w) > 0])
    if sg.size == 0 or np.all(sg == sg[0]):
        raise ExcitationError("w never changes sign: no reversals, Fc cannot be told from the offset; excite "
                              "both directions of motion")
    if np.ptp(data.u) == 0.0:
        raise ExcitationError("u is constant: the input does not excite J (nor any parameter)")
    profile = None
    if method == "sliding":
        cands, blocks, pred, noise, n = _select_sliding(data, Vs, delta, bool(offset), folds, names)
        input_delay = None
    else:
        check_optional("progress", progress, (bool, np.bool_), what="True, False")
        with threadpool_limits(limits=1, user_api="blas"):  # as the output-error fit (physical_id.fit_physical)
            cands, blocks, pred, noise, n, (input_delay, profile) = _select_output_error(
                data, Vs, delta, bool(offset), folds, names, h_max, input_delay, predictor, progress)
    ok = [c for c in cands if c.ok]
    if not ok:
        raise ExcitationError("no candidate form could be fitted and cross-validated on this record: "
                              + "; ".join(f"{c.name}: {c.status}" for c in cands))
    if criterion == "cv":
        chosen, rule = one_standard_error_choice((c.name, c.n_params, c.cv_mse, c.cv_se) for c in ok)
    else:
        pool = [c for c in ok if math.isfinite(getattr(c, criterion))]
        if not pool:
            raise ExcitationError("no candidate form could be fitted on this record")
        best = min(pool, key=lambda c: getattr(c, criterion))
        chosen, rule = best.name, f"smallest {criterion.upper()} ({getattr(best, criterion):.6g})"
    return FormSelection(candidates=tuple(cands), chosen=chosen, criterion=criterion, rule=rule, folds=folds,
                         blocks=tuple(blocks), method=method, predictor=pred, noise_std=noise,
                         n_samples=int(n), w_range=(float(np.min(data.w)), float(np.max(data.w))),
                         source=data.source, input_delay=input_delay, input_delay_profile=profile)
