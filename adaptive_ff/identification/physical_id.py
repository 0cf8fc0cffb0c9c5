r"""Identification of the *physical* joint parameters (J, tau, sigma, Fc, Fs) from a sampled record.

Why more than the paper's eq. 4
-------------------------------
The paper's regression (eq. 4, fitted by LS, eq. 9) replaces the derivatives of
eq. 2 by backward differences over one sample. At Ts = 10 ms with a friction
lag tau of the same order this is a coarse approximation of the sampled system,
and the friction regressors ``g(w(k-1))``, ``h(w(k-1))`` use one velocity
sample to stand for the whole interval — exactly where the Stribeck hump
(width ``Vs``, 0.02 rad/s on the ``paper`` preset) is crossed in about a
millisecond. Its LS estimate of the physical parameters is therefore biased
even on noise-free data (``benchmarks/identification.py`` prints the table:
at Ts = 10 ms, tau = 20 ms, Fs -63 %, tau -14 %, Fc +8 %; with the paper's
printed coefficient map sigma also takes the wrong sign). On the paper's data
two more error sources add to it: noise in the regressors ``w(k-1), w(k-2)``
(equation-error/ARX structure, biased under output noise: Ljung, *System
Identification*, 2nd ed., Sec. 8.3; Söderström & Stoica, *System
Identification*, Sec. 7.3) and the non-uniform sampling of Fig. 10, which a
constant-Ts model cannot represent (Sec. V-D).

Methods
-------
``"paper"``
    Eq. 4 by linear LS (eq. 9) with a constant ``Ts`` = median interval, as the
    paper does (kept as the reference). ``inverse="corrected"`` (default) maps
    theta to physical parameters with the package's derived coefficients
    (:mod:`adaptive_ff.identification.regression`); ``inverse="printed"`` with the paper's
    printed ones (dimensionally inconsistent; shown for the record).
``"output_error"``
    Prediction-error identification of the continuous-time model eqs. 1-3
    (Ljung, Secs. 3.2, 4.2, 7.2): the model is integrated by RK4 between the
    actual time stamps ``t(i)`` (sub-steps of at most 1 ms, the paper's own
    simulation rate) with the input reconstructed by first-order hold
    (:mod:`adaptive_ff.identification.simulator`), and the velocity prediction errors are
    minimised by ``scipy.optimize.least_squares`` (trust-region reflective,
    soft-L1 loss). Chosen because it removes the three error sources at once:

    * no discretisation error: the sampled system is reproduced up to the
      RK4 sub-step and the input reconstruction, whatever ``Ts``;
    * irregular sampling is handled by construction: each interval is
      integrated over its own length ``t(i) - t(i-1)`` (Sec. V-D);
    * with the free-run (output-error) predictor, white measurement noise
      enters only the prediction error, not the predictor, so the estimate is
      consistent (Ljung, Sec. 8.3), unlike LS on eq. 4 whose regressors carry
      the noise. This is why an instrumental-variable fix of eq. 4
      (Söderström & Stoica, Ch. 8) was not chosen: it removes the noise bias
      but neither the discretisation nor the sampling bias, and the
      backward-difference bias of eq. 4 is already -63 % on Fs without noise.

    Predictor (``predictor="auto"``, chosen by the noise level estimated from
    local quadratic fits of ``w`` on its own time stamps):

    * ``"free-run"`` (output error, gain 0) for noisy data (noise above 0.03 %
      of the peak velocity): consistent under white noise;
    * ``"one-step"`` for (nearly) noise-free data: after each sample the
      predicted velocity is reset to the measured one, the friction state
      stays simulated (gain ``(1, 0)``; ``injection_gain`` below 1 moves the
      velocity that share of the way instead). The free-run output is chaotic at
      breakaway (a Stribeck curve falls with speed, so creep is unstable) and
      the free-run cost is rough in Fs at the 2-3 % level even without noise;
      the one-step error is not, and on exact data it is unbiased. With
      noise the resets carry it into the predictor (errors in variables),
      hence the low threshold (measurements: the documentation's
      identification benchmark page).

    The cost is not convex in Fs (the stiction level only acts at breakaway)
    nor in tau from the eq. 4 start (tau -14 % to -90 %), so the search is
    staged: profiles (grid searches) over log tau and Fs from the eq. 4 LS
    start and a fit with a wide robust scale (1 % of the peak velocity:
    graduated non-convexity), a second wide Fs profile and fit; then fits at
    the noise-level scale with a local Fs profile, a coordinate search
    (+-3 typical steps per parameter) that frees parameters the trust region
    leaves stuck on the rough cost (measured: the offset), a profile search
    over tau (tau held at 0.5 .. 2 times the estimate, J on a grid there, the
    others refitted; :mod:`adaptive_ff.identification.lag_profile`: on joints
    with a lag near the sample time the search otherwise stopped in a local
    minimum of the valley where J trades against tau, tau 9-70 % off), where
    ``input_delay`` is not given a profile over the input delay (sub-sample
    delays, the local stage and a coordinate round at each;
    :mod:`adaptive_ff.identification.delay_profile`), and a
    profile likelihood over Fs (held at -8 .. +8 % in 2 % steps, the others
    refitted; lowest cost kept), since Fc and Fs trade against each other at
    breakaway and the profile itself is rough at the 1-2 % level (a 4 % grid
    left one seed of the Fig. 10 case in a local minimum with Fs +5.3 %,
    Fc -3.7 %, cost above that at the true parameters). Parametrisation
    ``(log J, Fc, Fs, sigma, log tau, offset/Fc0)`` keeps J, tau > 0 and
    gives every parameter a finite-difference step visible past the jitter.
    A fit runs several hundred simulations (C, ``aff_simulator.c``).

Jacobian
--------
The trust-region fits take forward differences (``jacobian="difference"``, default): one simulation per
parameter and iteration, a step of ``diff_step`` (1 %) relative (scipy's ``"2-point"`` rule). The perturbed
parameter vectors of one Jacobian are simulated in one C call (``aff_simulate_on_grid_batch``, side by side; with
scipy >= 1.16, through ``least_squares``' ``workers``), as are the points of the grid searches; the numbers are
those of one simulation at a time. ``jacobian="sensitivity"`` gives them the
exact Jacobian of the discrete simulation instead: the RK4 stages' tangents along ``(J, Fc, Fs, sigma, tau,
offset, Vs, delta)``, propagated in C with the simulation (``aff_simulate_on_grid_sens``; at about 2.5 times
the cost of one simulation). With the one-step predictor the prediction is smooth in the parameters over a
sample and the exact Jacobian is the better one (measured on the log of ``benchmarks/output_error_speed.py``
without its noise, 20 s at 1 kHz: a lower cost, 0.443 against 0.556, Fs +0.02 % against +0.49 %, 1186
simulations against 2070). The free-run output is not smooth: at standstill the RK4 steps chatter around
``w = 0`` and every sign change of a stage velocity is a jump of eq. 3, so the output is piecewise smooth in
the parameters with a jump wherever a parameter moves a sign change across a stage. The exact Jacobian is that
of the smooth pieces and misses the jumps, which the 1 % secant averages; on the same record with 1 % noise
(free run) it stopped at a higher cost (1097.8 against 1018.1, J -2 %) for the same CPU time. The default
therefore stays the difference Jacobian. Where a trust-region fit's sensitivities are not finite or exceed
:data:`SENS_MAX` (a tangent that grows through a stop's ringing until it overflows), that fit is taken again from
its start with forward differences (``info["sensitivity_fallbacks"]`` counts the point fit's).

Accuracy and cost against the paper's eq. 4 on simulated records are measured
by ``benchmarks/identification.py``; its tables are on the documentation's
benchmark pages (docs/benchmarks/).

Standard errors
---------------
The HAC and white standard errors, the parametric block wild bootstrap of the output-error fit and its
95 % intervals are described in :mod:`adaptive_ff.identification.oe_intervals` (its module docstring,
"Standard errors"), which computes the errors and intervals; the refits run here (:func:`fit_physical`).
"""

from __future__ import annotations

import copy
import inspect
import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from adaptive_ff.identification.covariance import BootstrapSettings, andrews_bandwidth, parametric_block_bootstrap
from adaptive_ff.identification.diagnostics import input_quantum, noise_fit_weights, velocity_noise_std_irregular
from adaptive_ff.identification.delay_profile import delay_profile_search
from adaptive_ff.identification.lag_profile import lag_profile_search
from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.oe_intervals import bootstrap_intervals, oe_band, oe_stderr
from adaptive_ff.identification.oe_options import BOOTSTRAP_REFITS, JACOBIANS, OutputErrorOptions
from adaptive_ff.identification.plausibility import check_physical
from adaptive_ff.identification.regression import RegressionModel, nrmse_fit
from adaptive_ff.identification.simulator import (BATCH_MAX, input_grid, simulate_on_grid, simulate_on_grid_batch,
                                                  simulate_on_grid_sens, stop_intervals)
from plant.dynamics import lagged_params
from plant.errors import (ExcitationError, ParameterError, SignalError, check_finite_scalar, check_positive,
                          check_signal, check_time)
from plant.results import json_safe

__all__ = ["PhysicalFit", "OutputErrorOptions", "fit_physical", "METHODS", "PHYSICAL_NAMES", "MIN_SAMPLES", "SENS_MAX",
           "BOOTSTRAP_REFITS", "JACOBIANS", "SHAPE_NAMES"]

#: Identification methods of :func:`fit_physical`.
METHODS = ("paper", "output_error")

#: Physical parameter names, in the order of ``PhysicalFit.params`` (``offset`` only when fitted).
PHYSICAL_NAMES = ("J", "Fc", "Fs", "sigma", "tau", "offset")

#: The Stribeck shape parameters the output-error fit adds where no pre-fit gives them (``Vs=None, delta=None``).
SHAPE_NAMES = ("Vs", "delta")
#: Points of the start profile over log Vs when Vs is fitted (``max(noise, 1e-3*peak)`` to ``0.3*peak`` |w|; at
#: each an Fs profile, at delta = 1).
_VS_GRID = 9
_DELTA_MIN = 0.05  # a fitted shape factor below this is not admitted (eq. 3's decay vanishes)

#: Fewest samples accepted (eq. 4 has up to 7 parameters and loses 2 rows).
MIN_SAMPLES = 20

#: Below this velocity noise (fraction of the peak |w|) ``predictor="auto"`` uses the one-step predictor
#: (measured: 0.05 % noise already biased its Fs by up to 8 %; noise-free records read 1-2e-4).
_ONE_STEP_NOISE = 3e-4
_TAU_MIN = 1e-4  # s; floor of the start value (the RK4 sub-step needs tau > 0.4*h)
# final-stage search of the output-error fit (module docstring): local Fs profile span (relative), rounds of
# the coordinate search, and the Fs values (relative) of the profile likelihood
_FS_SPAN = 0.1
_N_POLISH = 3
_FS_PROFILE = (-0.08, -0.06, -0.04, -0.02, 0.02, 0.04, 0.06, 0.08)
# bootstrap (:mod:`adaptive_ff.identification.oe_intervals`, "Standard errors"): block length in units of (Andrews bandwidth + 1), and the
# spread of the refits' start points in typical changes (_OutputErrorProblem.typical); measured on seeds 0-10
# of benchmarks/coverage.py: 1 typical change gave 0-67 % coverage of Fc and Fs, 2 gave 33-100 %, 4 gave
# 100 % with J twice too wide; 3 chosen, checked on seeds 40-79
_BOOT_BLOCK = 3
_BOOT_START = 3.0
# residual resampling of the bootstrap (:mod:`adaptive_ff.identification.oe_intervals`, "Standard errors"): "wild" keeps each residual at its
# instant (the large ones at breakaway, where Fs is identified), with a random sign per block of the block length
_BOOT_SCHEME = "wild"
# what each refit runs after its start (:mod:`adaptive_ff.identification.oe_intervals`, "Standard errors"; _oe_refit): the wide trust-region
# pass, the fit's local stage and this many rounds of its coordinate search (the fit runs up to _N_POLISH); the
# lag profile and the final Fs profile are left out (about 1000 simulations per refit)
_BOOT_POLISH = 1
_BOOT_REFIT = f"wide trust region, local stage, {_BOOT_POLISH} coordinate-search round(s)"
# residual vectors a problem keeps by their parameter vector (_OutputErrorProblem.res): the fit asks again for the
# cost at the point a trust-region pass returned, and at grid points it has been at
_MEMO = 8
# scipy >= 1.16: least_squares evaluates its finite differences through a map-like ``workers`` (the perturbed
# parameter vectors of one Jacobian, simulated together: _OutputErrorProblem.refine)
_LSQ_WORKERS = "workers" in inspect.signature(least_squares).parameters
#: Largest magnitude of a sensitivity (per unit of the fit's scaled coordinates) taken as the Jacobian of a trust-region
#: step (``jacobian="sensitivity"``): far beyond any velocity's, an overflowing tangent (e.g. a stop's ringing
#: followed through many sign changes), at which the fit's step is taken with forward differences instead
#: (:meth:`_OutputErrorProblem.refine`).
SENS_MAX = 1e50


class _SensitivityOverflow(ArithmeticError):
    """The sensitivities of a trust-region step are not finite or exceed :data:`SENS_MAX`."""


@dataclass(frozen=True)
class PhysicalFit:
    """Result of :func:`fit_physical`.

    Attributes
    ----------
    method : str
        ``"paper"`` or ``"output_error"``.
    params : dict
        ``{"J": kg·m², "Fc": N·m, "Fs": N·m, "sigma": N·m·s/rad, "tau": s}``
        plus ``"offset"`` (N·m) when fitted; floats.
    stderr : dict
        Standard errors of ``params`` (same keys and units); NaN if unavailable.
    cond : float
        2-norm condition number of the column-scaled regressor matrix
        (``"paper"``) or residual Jacobian (``"output_error"``).
    nrmse : float
        Fit in percent, ``100*(1 - ||w - w_hat|| / ||w - mean(w)||)``;
        ``nrmse_kind`` says which prediction ``w_hat`` is.
    nrmse_kind : str
        ``"one-step"`` (eq. 4 one-step prediction for ``"paper"``; for
        ``"output_error"`` the prediction with the velocity reset to the
        measurement after each sample) or ``"free-run"`` (simulation on the
        input only).
    n_samples : int
        Number of samples used.
    info : dict
        Method details (JSON-serialisable). ``"paper"``: ``Ts``, ``inverse``,
        ``theta``, ``fit_free_run``, ``residual_rms``. ``"output_error"``:
        ``predictor``, ``injection_gain`` (the velocity's output-injection gain of the predictor: 0 free-run),
        ``noise_std`` (rad/s), ``stderr_kind`` (``"bootstrap"``
        or ``"hac"``: what ``stderr`` is), ``stderr_hac`` (Newey-West),
        ``stderr_white`` (white-noise Gauss-Newton errors), ``hac_lags``
        (Bartlett bandwidth), ``bootstrap`` (None, or ``n``, ``n_valid``,
        ``block``, ``seed``, ``start_spread``, ``resampling``, ``refit`` (what each refit
        runs), ``lag_refits`` (``OutputErrorOptions.bootstrap_lag_refits`` where the refits run the profile over
        tau: at how many of its values they refit the others, None for all), ``input_delay`` (s: the fit's, which
        the full refits hold, :mod:`adaptive_ff.identification.delay_profile`), ``n_simulations``, ``bias``:
        mean deviation of the refits per parameter, ``stderr_refits`` (the refits' RMS deviation from the
        estimate) and ``stderr_delay`` where the delay was profiled (the delay's share,
        :func:`adaptive_ff.identification.delay_profile.delay_spread`; ``stderr`` is their root sum of squares
        where the interval is centred on the estimate), ``interval95``: per parameter ``[low, high]`` = centre ±
        t stderr, :func:`adaptive_ff.identification.covariance.bias_corrected_interval`), ``interval95`` (the
        same) and ``band`` (the 95 % band of F(w) from the refits, as
        :meth:`adaptive_ff.identification.uncertainty.FrictionBand.to_dict`), ``start``, ``cost``,
        ``lag_profile`` (None, or the profile over tau: ``tau``, ``cost``, ``n_simulations``, ``moved``),
        ``fitted`` (names of the fitted parameters; ``Vs``, ``delta`` among them where they were not given),
        ``fixed`` (``{"Vs", "delta"}`` as given, or empty),
        ``residual_rms``, ``n_simulations``, ``sensitivity_fallbacks`` (the point fit's trust-region fits whose
        sensitivities overflowed, :data:`SENS_MAX`, and which took forward differences; 0 with
        ``jacobian="difference"``), ``burn_samples``, ``loss``,
        ``f_scale``, ``h_max``, ``stop_band`` (rad/s or None) and ``refined_intervals`` (the sample intervals
        simulated at ``h_refine`` inside it), ``input_delay`` (s: the one given, or the one the profile chose),
        ``input_delay_profile`` (None where the delay was given, else ``delay``, ``cost``, ``chosen``,
        ``n_simulations``, ``params``: :func:`adaptive_ff.identification.delay_profile.delay_profile_search`),
        ``interp``,
        ``Ts_mean``, ``Ts_max``.
    """

    method: str
    params: dict
    stderr: dict
    cond: float
    nrmse: float
    n_samples: int
    nrmse_kind: str = "free-run"
    info: dict = field(default_factory=dict)
    warnings: tuple = ()

    def to_dict(self) -> dict:
        """Strict-JSON dict: ``method, params, stderr, cond, nrmse, nrmse_kind, n_samples, info`` (NaN/inf as
        None) and ``warnings`` (list of ``{"code", "parameter", "message"}``)."""
        return json_safe({"method": self.method, "params": self.params, "stderr": self.stderr, "cond": self.cond,
                          "nrmse": self.nrmse, "nrmse_kind": self.nrmse_kind, "n_samples": self.n_samples,
                          "info": self.info, "warnings": [w.to_dict() for w in self.warnings]})

    def to_json_dict(self) -> dict:
        """The same as :meth:`to_dict` (the name the CLI uses)."""
        return self.to_dict()

    def summary(self) -> str:
        """A few lines: method, each parameter with its standard error, fit and condition number."""
        units = {"J": "kg·m²", "Fc": "N·m", "Fs": "N·m", "sigma": "N·m·s/rad", "tau": "s", "offset": "N·m"}
        lines = [f"physical parameters by {self.method!r} ({self.n_samples} samples)"]
        lines += [f"  {k:<7}{v:>13.6g} ± {self.stderr.get(k, float('nan')):<10.3g}{units.get(k, '')}"
                  for k, v in self.params.items()]
        lines.append(f"  fit ({self.nrmse_kind}) {self.nrmse:.3f} %, cond {self.cond:.3g}")
        if self.info.get("stderr_kind"):
            boot = self.info.get("bootstrap") or {}
            lines.append(f"  ± is the {self.info['stderr_kind']} standard error"
                         + (f" ({boot.get('n_valid')} refits, seed {boot.get('seed')})" if boot else ""))
        return "\n".join(lines)


def _check_inputs(t, u, w, Vs, delta, method="paper"):
    t = check_time("t", t, min_len=MIN_SAMPLES)
    u = check_signal("u", u, n=t.shape[0])
    w = check_signal("w", w, n=t.shape[0])
    if (Vs is None) != (delta is None):
        raise ParameterError("give both Vs and delta (the Stribeck pre-fit), or neither (method 'output_error' "
                             f"then fits them), got Vs = {Vs!r}, delta = {delta!r}")
    if Vs is None and method != "output_error":
        raise ParameterError(f"method {method!r} needs Vs and delta (the Stribeck pre-fit, Sec. V-C); method "
                             "'output_error' fits them where they are not given")
    if Vs is not None:
        Vs = check_positive("Vs", Vs)
        delta = check_finite_scalar("delta", delta)
        if delta == 0.0:
            raise ParameterError("delta must be non-zero, got 0.0")
    if np.ptp(u) == 0.0:
        raise ExcitationError("u is constant: the input does not excite J (nor any parameter)")
    sgn = np.sign(w[np.abs(w) > 0])
    if sgn.size == 0 or np.all(sgn == sgn[0]):
        raise ExcitationError("w never changes sign: no reversals, Fc and Fs (and the lag tau) are not "
                              "identifiable; excite both directions of motion")
    return t, u, w, Vs, delta


def _names(offset: bool, shape: bool = False) -> tuple:
    """Names of the fitted parameters: ``PHYSICAL_NAMES`` (without the offset), then ``Vs, delta`` if fitted."""
    return (PHYSICAL_NAMES if offset else PHYSICAL_NAMES[:-1]) + (SHAPE_NAMES if shape else ())


def _printed_inverse(theta_full, Ts: float) -> dict:
    """Physical parameters from eq. 4's theta with the coefficient formulas *as printed* (Sec. III)."""
    a1, a2, b0, b1, c1, d1, o1 = theta_full
    g = b0 - b1  # printed: Ts**2/D, as in the corrected map
    with np.errstate(divide="ignore", invalid="ignore"):
        return {"J": float(Ts * (a1 - a2) / g), "Fc": float(c1 / g), "Fs": float(d1 / g),
                "sigma": float((1.0 - a1) / g), "tau": float(b1 / g), "offset": float(o1 / g)}


def _fit_paper(t, u, w, Vs, delta, offset, inverse):
    Ts = float(np.median(np.diff(t)))
    model = RegressionModel(Vs, delta, lag=True, stribeck=True, offset=offset)
    ls = fit_ls(model, u, w, Ts=Ts)
    names = _names(offset)
    if inverse == "printed":
        params = _printed_inverse(model.full_theta(ls.theta), Ts)
    else:
        est = ls.estimate
        params = {"J": est.J, "Fc": est.Fc, "Fs": est.Fs, "sigma": est.sigma, "tau": est.tau, "offset": est.offset}
    params = {k: float(params[k]) for k in names}
    # delta method through the (corrected) inverse map, by central differences on theta
    X, _ = model.regressors(u, w)
    sc = 1.0 / np.linalg.norm(X, axis=0)
    s2 = ls.residual_rms**2 * X.shape[0] / max(X.shape[0] - X.shape[1], 1)
    Xs = X * sc
    cov = s2 * np.linalg.pinv(Xs.T @ Xs) * np.outer(sc, sc)  # s**2 (X^T X)^-1 (Ljung Sec. 7.3)
    th = ls.theta
    Gm = np.empty((len(names), th.shape[0]))
    for j in range(th.shape[0]):
        dh = 1e-6 * max(abs(th[j]), 1e-12)
        tp, tm = th.copy(), th.copy()
        tp[j] += dh
        tm[j] -= dh
        if inverse == "printed":
            fp, fm = _printed_inverse(model.full_theta(tp), Ts), _printed_inverse(model.full_theta(tm), Ts)
        else:
            ep, em = model.to_physical(tp, Ts), model.to_physical(tm, Ts)
            fp = {k: getattr(ep, k) for k in names}
            fm = {k: getattr(em, k) for k in names}
        Gm[:, j] = [(fp[k] - fm[k]) / (2 * dh) for k in names]
    var = np.einsum("ij,jk,ik->i", Gm, cov, Gm)
    stderr = {k: float(np.sqrt(v)) if v >= 0 else float("nan") for k, v in zip(names, var)}
    return PhysicalFit(method="paper", params=params, stderr=stderr, cond=float(ls.cond), nrmse=float(ls.fit_one_step),
                       n_samples=int(t.shape[0]), nrmse_kind="one-step",
                       info={"Ts": Ts, "inverse": inverse, "theta": ls.theta_dict(),
                             "fit_free_run": float(ls.fit_free_run), "residual_rms": float(ls.residual_rms)})


def _start_from_paper(t, u, w, Vs, delta, offset):
    """Start values from the eq. 4 LS fit, clipped to the physical range."""
    Ts = float(np.median(np.diff(t)))
    model = RegressionModel(Vs, delta, lag=True, stribeck=True, offset=offset)
    try:
        est = fit_ls(model, u, w, Ts=Ts, free_run=False).estimate  # the estimate only: no free-run simulation
        J, Fc, sigma, tau = est.J, est.Fc, est.sigma, est.tau
        off = est.offset if offset else 0.0
    except ExcitationError:
        J, Fc, sigma, tau, off = float("nan"), float("nan"), float("nan"), float("nan"), 0.0
    # fallbacks by scale when the LS start is implausible
    acc = np.gradient(w, t)
    if not (math.isfinite(J) and J > 0):
        J = float(np.std(u) / max(np.std(acc), 1e-12))
    if not (math.isfinite(Fc) and Fc > 0):
        Fc = 0.1 * float(np.std(u))
    if not (math.isfinite(sigma) and sigma >= 0):
        sigma = 0.0
    if not (math.isfinite(tau) and tau > 0):
        tau = Ts
    tau = min(max(tau, max(_TAU_MIN, 0.5 * Ts)), 1.0)
    if not math.isfinite(off):
        off = 0.0
    return {"J": J, "Fc": Fc, "sigma": sigma, "tau": tau, "offset": off}


class _OutputErrorProblem:
    """The prediction errors of eqs. 1-3 on a record and the search tools over them (``fit_physical``).

    Parameter vector ``x = (log J, Fc, Fs, sigma, log tau[, offset/torque][, log Vs, delta])``.
    """

    free_shape = False  # Vs, delta fitted (set by __init__; a subclass with its own residual keeps them given)
    j_shape = 6

    def __init__(self, t, u, w, Vs, delta, offset, opts: OutputErrorOptions, noise_weights: tuple | None = None):
        # noise_weights: noise_fit_weights(t), passed by the bootstrap's refits (the same stamps: computed once)
        self.noise_weights = noise_fit_weights(t) if noise_weights is None else noise_weights
        self.noise = velocity_noise_std_irregular(t, w, weights=self.noise_weights)
        # input_delay None: profiled by the search (delay_profile_search), from 0
        self.input_delay = 0.0 if opts.input_delay is None else float(opts.input_delay)
        self.delay_profile = None
        # the intervals where the measured velocity stops or reverses, at sub-steps of h_refine (opts.stop_band)
        self.stop_mask = None if opts.stop_band is None else stop_intervals(w, opts.stop_band)
        self.t, self.opts = t, opts  # the grid's (input_grid)
        self.grid = self.input_grid(u, self.input_delay)
        self.i0 = int(np.searchsorted(t, t[0] + opts.burn))
        if t.shape[0] - self.i0 < MIN_SAMPLES:
            raise SignalError(f"the record ({t[-1] - t[0]:.4g} s) is too short for burn = {opts.burn!r} s; "
                              f"need at least {MIN_SAMPLES} samples after it")
        # Vs, delta None: fitted, as log Vs and delta after the other coordinates (j_shape); self.Vs, self.delta
        # are then their start values (the middle of the log Vs start profile, delta = 1)
        self.free_shape = Vs is None
        if self.free_shape:
            peak0 = float(np.max(np.abs(w)))
            self.vs_grid = np.geomspace(max(self.noise, 1e-3 * peak0), 0.3 * peak0, _VS_GRID)
            Vs, delta = float(self.vs_grid[_VS_GRID // 2]), 1.0
        self.j_shape = 5 + int(bool(offset))
        self.u, self.w, self.Vs, self.delta, self.offset = u, w, Vs, delta, offset
        self.wm = w[self.i0:]
        self.w0, self.f0 = float(w[0]), float(u[0])  # friction balances the input at the start (quasi-steady)
        self.n_sim = 0
        self.n_sens_fallback = 0  # trust-region fits whose sensitivities overflowed (refine)
        self.memo, self.fd_memo = {}, None  # residual vectors by parameter vector (res, refine)
        self.big = 10.0 * (np.max(np.abs(w)) + 1.0)
        peak = float(np.max(np.abs(w)))
        predictor = opts.predictor
        if predictor == "auto":
            predictor = "one-step" if self.noise < _ONE_STEP_NOISE * peak else "free-run"
        self.predictor = predictor
        self.gain = (opts.injection_gain, 0.0) if predictor == "one-step" else (0.0, 0.0)
        self.f_scale = max(3.0 * self.noise, 1e-3 * peak) if opts.f_scale is None else opts.f_scale
        # continuation (graduated non-convexity): the global stage uses a wide robust scale, which smooths
        # the cost over the breakaway jitter; the final stage the noise-level scale
        self.f_wide = max(self.f_scale, 1e-2 * peak)
        self.torque = 1.0  # offset scale, set by start_vector

    def input_grid(self, u, d: float):
        """The simulation grid of the input samples ``u`` (shape of ``self.u``) taken ``d`` s before their stamps:
        sub-steps of ``h_max``, of ``h_refine`` in the record's stop intervals (``opts.stop_band``)."""
        o = self.opts
        return input_grid(self.t, u, h_max=o.h_max, input_delay=d, interp=o.interp, refine=self.stop_mask,
                          h_refine=o.h_refine)

    def set_delay(self, d: float) -> None:
        """Take each input sample ``d`` s before its stamp from now on (the input grid rebuilt, the remembered
        residuals dropped)."""
        if d != self.input_delay:
            self.grid = self.input_grid(self.u, d)
            self.input_delay, self.memo, self.fd_memo = float(d), {}, None

    def start_vector(self, s0: dict) -> np.ndarray:
        """``x`` of the start values; fixes the offset scale ``torque``."""
        # offset in units of a torque scale, so that scipy's relative difference step ds*max(1, |x|) is about
        # ds*Fc (a step of 0.01 N·m would not be seen past the breakaway jitter of the free-run output)
        self.torque = max(abs(s0["Fc"]), 1e-3 * float(np.std(self.u)))
        return np.array([math.log(s0["J"]), s0["Fc"], s0.get("Fs", s0["Fc"]), s0["sigma"], math.log(s0["tau"])]
                        + ([s0.get("offset", 0.0) / self.torque] if self.offset else [])
                        + ([math.log(s0.get("Vs", self.Vs)), s0.get("delta", self.delta)] if self.free_shape
                           else []), dtype=float)

    def replicate(self, w_star: np.ndarray) -> "_OutputErrorProblem":
        """The same problem (input grid, predictor, robust scales, offset scale) on another velocity record."""
        pb = copy.copy(self)
        pb.w, pb.wm, pb.n_sim, pb.memo, pb.fd_memo = w_star, w_star[self.i0:], 0, {}, None
        return pb

    def unpack(self, x):
        """``(J, Fc, Fs, sigma, tau, offset)`` of ``x``."""
        return math.exp(x[0]), x[1], x[2], x[3], math.exp(x[4]), (x[5] * self.torque if self.offset else 0.0)

    def shape(self, x) -> tuple:
        """``(Vs, delta)`` at ``x``: the given ones, or the fitted ones."""
        if self.free_shape:
            return math.exp(x[self.j_shape]), float(x[self.j_shape + 1])
        return self.Vs, self.delta

    def values(self, x) -> dict:
        """Every fitted parameter at ``x`` in physical units, by name (:func:`_names`)."""
        vals = dict(zip(PHYSICAL_NAMES, self.unpack(x)))
        vals.update(zip(SHAPE_NAMES, self.shape(x)))
        return {k: float(vals[k]) for k in _names(self.offset, self.free_shape)}

    def admissible(self, x) -> bool:
        """The RK4 sub-step resolves the lag (tau > 0.4 h_max) and a fitted delta is >= ``_DELTA_MIN``."""
        return math.exp(x[4]) >= 0.4 * self.opts.h_max and not (self.free_shape and x[self.j_shape + 1] < _DELTA_MIN)

    def plant(self, x) -> tuple:
        """``(plant_params, offset)`` of ``x`` for the C simulation."""
        J, Fc, Fs, sigma, tau, off = self.unpack(x)
        Vs, delta = self.shape(x)
        return lagged_params(J, Fc, Fs, Vs, delta, sigma, tau), off

    def simulate(self, x) -> np.ndarray:
        """Predicted velocity at every sample (rad/s)."""
        par, off = self.plant(x)
        return simulate_on_grid(par, self.grid, w0=self.w0, f0=self.f0, offset=off, gain=self.gain, w_meas=self.w)

    def simulate_input(self, x, u) -> np.ndarray:
        """Predicted velocity at every sample (rad/s) driven by the input samples ``u`` (shape of ``self.u``) in
        place of the record's, at the problem's input delay; not counted in ``n_sim`` (safe in threads)."""
        grid = self.input_grid(u, self.input_delay)
        par, off = self.plant(x)
        return simulate_on_grid(par, grid, w0=self.w0, f0=self.f0, offset=off, gain=self.gain, w_meas=self.w)

    def res(self, x) -> np.ndarray:
        """Prediction errors after the burn-in (rad/s); a large constant where the model is not admissible.

        The last ``_MEMO`` vectors asked for are kept (:meth:`remember`): asking again for one of them returns a
        copy of the same numbers without a simulation."""
        x = np.asarray(x, dtype=float)
        r = self.memo.get(x.tobytes())
        if r is None:
            r = self.res_many(x[None, :])[0]
            self.remember(x, r)
        return r.copy()

    def remember(self, x, r) -> None:
        """Keep ``r`` as the residual vector at ``x`` (the oldest of more than ``_MEMO`` is dropped)."""
        self.memo[np.asarray(x, dtype=float).tobytes()] = r
        if len(self.memo) > _MEMO:
            del self.memo[next(iter(self.memo))]

    def res_many(self, X) -> np.ndarray:
        """:meth:`res` of each row of ``X`` (shape (K, len(x))), the admissible ones simulated together
        (:func:`adaptive_ff.identification.simulator.simulate_on_grid_batch`: the same numbers as one at a time);
        shape (K, samples after the burn-in)."""
        X = np.asarray(X, dtype=float)
        self.n_sim += X.shape[0]
        ok = [k for k in range(X.shape[0]) if self.admissible(X[k])]
        if not ok:
            return np.full((X.shape[0], self.wm.shape[0]), self.big)
        pars, offs = zip(*(self.plant(X[k]) for k in ok))
        r = simulate_on_grid_batch(list(pars), self.grid, w0=self.w0, f0=self.f0, offsets=offs, gain=self.gain,
                                   w_meas=self.w)[:, self.i0:] - self.wm
        if not np.isfinite(r).all():
            r = np.where(np.isfinite(r), r, self.big)
        if len(ok) == X.shape[0]:
            return r
        out = np.full((X.shape[0], self.wm.shape[0]), self.big)
        out[ok] = r
        return out

    def jac(self, x) -> np.ndarray:
        """Exact Jacobian of :meth:`res` at ``x`` (rows after the burn-in, columns of ``x``): the forward
        sensitivities of the discrete simulation (:func:`adaptive_ff.identification.simulator.simulate_on_grid_sens`)
        with the chain rule for log J, log tau and the offset scale; zero rows where :meth:`res` is its constant."""
        self.n_sim += 1
        ncol = x.shape[0]
        if not self.admissible(x):
            return np.zeros((self.wm.shape[0], ncol))
        J, Fc, Fs, sigma, tau, off = self.unpack(x)
        Vs, delta = self.shape(x)
        par = lagged_params(J, Fc, Fs, Vs, delta, sigma, tau)
        w, dw = simulate_on_grid_sens(par, self.grid, w0=self.w0, f0=self.f0, offset=off, gain=self.gain,
                                      w_meas=self.w)
        cols = [0, 1, 2, 3, 4] + ([5] if self.offset else []) + ([6, 7] if self.free_shape else [])
        G = dw[self.i0:, cols] * self.chain(x)
        G[~np.isfinite(w[self.i0:])] = 0.0
        return G

    def loss(self, r, fsc=None) -> float:
        """Loss of the residual vector ``r`` at robust scale ``fsc`` (default the noise-level scale)."""
        fsc = self.f_scale if fsc is None else fsc
        if self.opts.loss == "linear":
            return float(r @ r)
        return float(np.sum(np.sqrt(1.0 + (r / fsc) ** 2) - 1.0))

    def cost(self, x, fsc=None) -> float:
        """Loss of ``x`` at robust scale ``fsc`` (default the noise-level scale)."""
        return self.loss(self.res(x), fsc)

    def best_of(self, X, fsc=None) -> tuple[int, float]:
        """Index and cost of the first row of ``X`` of lowest :meth:`cost`, the rows simulated together
        (:meth:`res_many`); its residual vector is kept (:meth:`remember`: the search goes on from there)."""
        c, best = [], None
        for a in range(0, X.shape[0], BATCH_MAX):  # at most one C call's rows at a time (memory)
            for r in self.res_many(X[a:a + BATCH_MAX]):
                c.append(self.loss(r, fsc))
                if best is None or c[-1] < c[best[0]]:
                    best = (len(c) - 1, r.copy())
        self.remember(X[best[0]], best[1])
        return best[0], c[best[0]]

    def profile(self, x, lo, hi, n, j=2, fsc=None) -> np.ndarray:
        """``x`` with coordinate ``j`` set to the best of ``n`` values on ``[lo, hi]`` (grid search)."""
        g = np.linspace(lo, hi, n)
        X = np.repeat(np.asarray(x, dtype=float)[None, :], n, axis=0)
        X[:, j] = g
        return X[self.best_of(X, fsc)[0]].copy()

    def typical(self, x) -> np.ndarray:
        """Typical changes of ``x``: 2 % of J, 1 % of the torques, 3 % of tau, offset 1 % of Fc; a fitted Vs
        5 %, delta 0.02."""
        return np.array([0.02, 0.01 * abs(x[1]) + 1e-9, 0.01 * abs(x[2]) + 1e-9, 0.01 * abs(x[3]) + 1e-9, 0.03]
                        + ([0.01] if self.offset else []) + ([0.05, 0.02] if self.free_shape else []))

    def chain(self, x) -> np.ndarray:
        """d(physical parameter)/dx of each coordinate (log J, log tau, the offset scale, log Vs)."""
        J, _, _, _, tau, _ = self.unpack(x)
        return np.array([J, 1.0, 1.0, 1.0, tau] + ([self.torque] if self.offset else [])
                        + ([self.shape(x)[0], 1.0] if self.free_shape else []))

    def refine(self, x, ds, fsc=None, free=None):
        """Trust-region fit from ``x`` (``free``: indices fitted, the others held; default all)."""
        fsc = self.f_scale if fsc is None else fsc
        # explicit scales (typical changes) instead of x_scale="jac": the offset column, large in norm, was
        # otherwise held nearly fixed
        sens = self.opts.jacobian == "sensitivity"
        cols = slice(None) if free is None else free

        def full(z, xs=np.asarray(x, dtype=float)):
            xx = xs.copy()
            xx[cols] = z
            return xx

        def fun(z):
            return self.res(full(z))

        def jac(z):
            G = self.jac(full(z))[:, cols]
            if not np.isfinite(G).all() or np.max(np.abs(G), initial=0.0) > SENS_MAX:
                raise _SensitivityOverflow
            return G

        def batch(_, zs):  # the perturbed vectors of a finite-difference Jacobian, simulated together
            Z = np.array([full(z) for z in zs])
            key = Z.tobytes()
            if self.fd_memo is None or self.fd_memo[0] != key:  # the last one is kept: a pass may start where
                self.fd_memo = (key, self.res_many(Z))           # the one before stopped
            return list(self.fd_memo[1])

        z0, scale = (x, self.typical(x)) if free is None else (x[free], self.typical(x)[free])
        settings = dict(diff_step=ds, x_scale=scale, method="trf", xtol=1e-8, ftol=1e-10, max_nfev=self.opts.max_nfev,
                        loss=self.opts.loss, f_scale=fsc)
        sol = None
        if sens:
            try:
                sol = least_squares(fun, z0, jac=jac, **settings)
            except _SensitivityOverflow:  # this fit with forward differences, as jacobian="difference" takes it
                self.n_sens_fallback += 1
        if sol is None:
            sol = least_squares(fun, z0, jac="2-point", **settings, **({"workers": batch} if _LSQ_WORKERS else {}))
        self.remember(full(sol.x), sol.fun)  # the residual at the point returned, which the caller costs next
        return sol


def _oe_global_stage(pb: _OutputErrorProblem, x: np.ndarray, profiled: bool) -> np.ndarray:
    """Wide-scale stage: log-tau and Fs profiles (``profiled``), fit, a second wide Fs profile and fit."""
    o = pb.opts
    if profiled:
        Ts = float(np.median(np.diff(pb.t)))
        x = pb.profile(x, math.log(max(0.5 * Ts, 1.2 * o.h_max)), math.log(20.0 * Ts), 13, j=4, fsc=pb.f_wide)
        if pb.free_shape:  # Vs not given: a profile over log Vs at delta = 1, each point with its Fs profile
            pts = []
            for v in pb.vs_grid:
                xx = x.copy()
                xx[pb.j_shape] = math.log(v)
                xx = pb.profile(xx, xx[1], o.fs_max_ratio * xx[1], o.fs_grid, fsc=pb.f_wide)
                pts.append((pb.cost(xx, pb.f_wide), xx))
            x = min(pts, key=lambda p: p[0])[1]
        else:
            x = pb.profile(x, x[1], o.fs_max_ratio * x[1], o.fs_grid, fsc=pb.f_wide)
    sol = pb.refine(x, o.diff_step, pb.f_wide)
    best = (pb.cost(sol.x, pb.f_wide), sol)
    xb = best[1].x
    sol = pb.refine(pb.profile(xb, xb[1], o.fs_max_ratio * xb[1], o.fs_grid, fsc=pb.f_wide), o.diff_step, pb.f_wide)
    if pb.cost(sol.x, pb.f_wide) < best[0]:
        best = (pb.cost(sol.x, pb.f_wide), sol)
    return best[1].x


def _oe_delay_refit(pb: _OutputErrorProblem, x: np.ndarray) -> tuple[float, np.ndarray]:
    """The refit of the input-delay profile at each delay from the estimate ``x``: the local stage and one round
    of the coordinate search; ``(cost, x)``."""
    return _oe_coordinate_search(pb, _oe_local_stage(pb, x), rounds=1)


def _oe_local_stage(pb: _OutputErrorProblem, x: np.ndarray) -> tuple[float, np.ndarray]:
    """Noise-level stage: fit, local Fs profile (+-``_FS_SPAN``), fit; the better ``(cost, x)``."""
    ds = pb.opts.diff_step / 3.0
    sol = pb.refine(x, ds)
    best = (pb.cost(sol.x), sol.x)
    xb = best[1]
    sol = pb.refine(pb.profile(xb, (1.0 - _FS_SPAN) * xb[2], (1.0 + _FS_SPAN) * xb[2],
                               max(pb.opts.fs_grid // 2, 5) | 1), ds)
    c = pb.cost(sol.x)
    if c < best[0]:
        best = (c, sol.x)
    return best


def _oe_coordinate_search(pb: _OutputErrorProblem, best: tuple[float, np.ndarray],
                          rounds: int = _N_POLISH) -> tuple[float, np.ndarray]:
    """Each parameter on a grid of +-3 typical changes, best point refitted, up to ``rounds`` rounds.

    Frees parameters the trust region leaves stuck on the rough cost (seen for the offset).
    """
    ds = pb.opts.diff_step / 3.0
    for _ in range(rounds):
        x, c0 = best[1].copy(), best[0]
        for j in range(x.shape[0]):
            x, c0 = _oe_coordinate_moves(pb, x, c0, j)
        sol = pb.refine(x, ds)
        c = pb.cost(sol.x)
        x, c0 = (sol.x, c) if c < c0 else (x, c0)
        if c0 >= best[0]:
            break
        best = (c0, x)
    return best


def _oe_coordinate_moves(pb: _OutputErrorProblem, x: np.ndarray, c0: float, j: int) -> tuple[np.ndarray, float]:
    """Coordinate ``j`` moved by -3 .. 3 typical changes in turn, each move that lowers the cost taken before the
    next is tried (the later moves then start from it); returns ``(x, cost)``. The moves still to try are
    simulated together from the current point and tried in order; after a move is taken the rest are simulated
    again from the new point (the same points and costs as one at a time)."""
    ks = [-3, -2, -1, 1, 2, 3]
    while ks:
        step = pb.typical(x)[j]
        cand = []
        for k in ks:
            xx = x.copy()
            xx[j] += k * step
            cand.append(xx)
        R = pb.res_many(np.array(cand))
        taken = next((i for i, r in enumerate(R) if pb.loss(r) < c0), None)
        if taken is None:
            break
        x, c0 = cand[taken], pb.loss(R[taken])
        pb.remember(x, R[taken].copy())
        ks = ks[taken + 1:]
    return x, c0


def _oe_fs_profile(pb: _OutputErrorProblem, best: tuple[float, np.ndarray]) -> tuple[float, np.ndarray]:
    """Profile likelihood over Fs: Fs held at each of ``_FS_PROFILE`` (relative), the others refitted.

    Fc and Fs trade against each other at breakaway, a direction single-coordinate moves miss; the point
    of lowest cost, if below the current one, is refitted. The profile cost is rough at the 1-2 % level
    (the refits stop in different breakaway patterns): a 4 % grid missed a lower-cost valley 6 % away
    (Fig. 10 sampling as is, seed 6: cost 138.6 at Fs +5.3 %, Fc -3.7 %; 136.0 at Fs -1.0 %).
    """
    ds = pb.opts.diff_step / 3.0
    free = [j for j in range(best[1].shape[0]) if j != 2]
    xb, c0 = best[1], best[0]
    for fac in _FS_PROFILE:
        xs = xb.copy()
        xs[2] = xb[2] * (1.0 + fac)
        sol = pb.refine(xs, ds, free=free)
        xs[free] = sol.x
        c = pb.cost(xs)
        if c < c0:
            xb, c0 = xs, c
    if c0 < best[0]:
        sol = pb.refine(xb, ds)
        c = pb.cost(sol.x)
        best = (c, sol.x) if c < c0 else (c0, xb)
    return best


def _oe_refit(rp: _OutputErrorProblem, x0: np.ndarray) -> np.ndarray:
    """One bootstrap refit of the replicate problem ``rp`` from the start ``x0`` (module docstring, "Standard
    errors"): a trust-region pass at the wide robust scale (the last step of the fit's global stage), the fit's
    own local stage (:func:`_oe_local_stage`: trust region at the noise-level scale, local Fs profile, trust
    region; the better point kept) and ``_BOOT_POLISH`` round(s) of its coordinate search
    (:func:`_oe_coordinate_search`). Returns the refitted parameter vector."""
    z = rp.refine(x0, rp.opts.diff_step, rp.f_wide).x
    return _oe_coordinate_search(rp, _oe_local_stage(rp, z), rounds=_BOOT_POLISH)[1]


def _oe_bootstrap(pb: _OutputErrorProblem, x: np.ndarray, names: tuple, r: np.ndarray) -> tuple[dict, dict, dict]:
    """Parametric block wild bootstrap of the output-error fit (:mod:`adaptive_ff.identification.oe_intervals`, "Standard errors") by
    :func:`adaptive_ff.identification.covariance.parametric_block_bootstrap`.

    Returns ``(stderr, bias, details)``: per parameter the root-mean-square deviation of the refits from the
    estimate and their mean deviation (physical units), and the JSON-able settings (block length, count, seed,
    simulations). Refits that end non-finite are dropped (counted in ``details``).
    """
    o = pb.opts
    # the full refits hold the delay the fit's profile chose (module docstring of delay_profile): their profile has
    # that one point, the refit there from their search at delay 0 as in the fit
    held = pb.input_delay if o.input_delay is None else None
    w_hat = pb.simulate(x)
    quantum = (0.0 if o.bootstrap_input_quantum is None else input_quantum(pb.u)  # drawn into each world's input
               if o.bootstrap_input_quantum == "auto" else float(o.bootstrap_input_quantum))
    n_sim = []  # per refit; list.append is atomic, the refits may run in threads
    simulate, errors = None, o.bootstrap_input_errors
    shapes = o.bootstrap_shapes if o.bootstrap_refit == "partial" and not pb.free_shape else None
    if errors is not None:  # its shape checked by _fit_output_error
        drawn = iter(range(o.n_bootstrap))

        def simulate(_rng):  # world i: the estimate driven by the logged input less error draw i (in replicate order)
            return pb.simulate_input(x, pb.u - errors[next(drawn) % errors.shape[0]])[pb.i0:]

    def world(y_star, rng):  # the replicate record: the estimate driven by an input the log reads as pb.u
        w_star = w_hat.copy()
        w_star[pb.i0:] = y_star
        if quantum > 0.0:
            u_true = pb.u + rng.uniform(-0.5 * quantum, 0.5 * quantum, size=pb.u.shape)
            w_star += pb.simulate_input(x, u_true) - w_hat
        return w_star, int(quantum > 0.0)

    def refit(y_star, rng):  # safe in threads: every problem it runs is its own
        if o.bootstrap_refit == "full":  # the estimator itself: the replicate as a record of its own
            w_star, extra = world(y_star, rng)
            given = (None, None) if pb.free_shape else (pb.Vs, pb.delta)
            rp = _OutputErrorProblem(pb.t, pb.u, w_star, *given, pb.offset, o, noise_weights=pb.noise_weights)
            s0 = dict(o.start) if o.start is not None else _start_from_paper(pb.t, pb.u, w_star, rp.Vs, rp.delta,
                                                                              pb.offset)
            z = _oe_search(rp, s0, o.bootstrap_lag_refits, held_delay=held)[0][1]
        else:
            x0 = x + rng.normal(size=x.shape) * _BOOT_START * pb.typical(x)
            w_star, extra = world(y_star, rng)
            rp = pb.replicate(w_star)
            if shapes is not None:  # the refit holds a drawn shape; its world is the estimate at the given one
                rp.Vs, rp.delta = map(float, shapes[rng.integers(shapes.shape[0])])
            z = _oe_refit(rp, x0)
        n_sim.append(rp.n_sim + extra)
        v = rp.values(z)
        return np.array([v[k] for k in names])

    v = pb.values(x)
    est = np.array([v[k] for k in names])
    settings = BootstrapSettings(n=o.n_bootstrap, block=_BOOT_BLOCK * (andrews_bandwidth(r) + 1),
                                 seed=o.bootstrap_seed, scheme=_BOOT_SCHEME)
    b = parametric_block_bootstrap(refit, w_hat[pb.i0:], r, est, settings=settings, simulate=simulate,
                                   workers=o.workers(), progress=o.progress)
    details = {"n": o.n_bootstrap, "n_valid": b.n_valid, "block": int(b.block), "seed": o.bootstrap_seed,
               "start_spread": _BOOT_START, "resampling": _BOOT_SCHEME,
               "refit": (_BOOT_REFIT if o.bootstrap_refit == "partial"
                         else "the fit's own search from the replicate's start"),
               "lag_refits": (o.bootstrap_lag_refits if o.bootstrap_refit == "full" and o.lag_profile else None),
               "input_delay": float(pb.input_delay), "input_quantum": quantum,
               "input_errors": None if errors is None else int(errors.shape[0]),
               "shapes": None if shapes is None else int(shapes.shape[0]),
               "n_simulations": int(sum(n_sim)) + (0 if errors is None else o.n_bootstrap)}
    details.update(oe_band(pb, names, est, b))
    return dict(zip(names, map(float, b.stderr))), dict(zip(names, map(float, b.bias))), details


def _oe_search(pb: _OutputErrorProblem, s0: dict, lag_refits: int | None = None, held_delay: float | None = None
               ) -> tuple[tuple[float, np.ndarray], dict | None]:
    """The output-error fit's search from the start values ``s0`` (module docstring): global stage, local stage,
    coordinate search, the profile search over tau (``opts.lag_profile``; ``lag_refits``: its ``n_refit``, None
    in the fit itself), the profile over the input delay where it is not given (``held_delay``: a bootstrap
    refit's, the fit's delay its one point; None in the fit itself) and the final Fs profile. Returns
    ``((cost, x), lag profile details or None)``."""
    x = _oe_global_stage(pb, pb.start_vector(s0), profiled=pb.opts.start is None)
    best = _oe_coordinate_search(pb, _oe_local_stage(pb, x))
    lag_prof = None
    if pb.opts.lag_profile:
        best, lag_prof = lag_profile_search(pb, best, n_refit=lag_refits)
    if pb.opts.input_delay is None:  # not given: profiled (pb.delay_profile), pb left at the delay chosen;
        # a bootstrap refit (held_delay): the profile with the fit's delay as its one point
        best, pb.delay_profile = delay_profile_search(pb, best, lambda z: _oe_delay_refit(pb, z),
                                                      delays=None if held_delay is None else (held_delay,),
                                                      values=pb.values if held_delay is None else None)
    return _oe_fs_profile(pb, best), lag_prof


def _fit_output_error(t, u, w, Vs, delta, offset, opts: OutputErrorOptions) -> PhysicalFit:
    """The output-error fit of eqs. 1-3 (module docstring): staged search, then Gauss-Newton errors."""
    errors = opts.bootstrap_input_errors
    if errors is not None and errors.shape[1] != u.shape[0]:
        raise ParameterError(f"bootstrap_input_errors must have one column per sample ({u.shape[0]}), got shape "
                             f"{errors.shape}")
    pb = _OutputErrorProblem(t, u, w, Vs, delta, offset, opts)
    names = _names(offset, pb.free_shape)
    s0 = dict(opts.start) if opts.start is not None else _start_from_paper(t, u, w, pb.Vs, pb.delta, offset)
    best, lag_prof = _oe_search(pb, s0)
    x = best[1]
    params = pb.values(x)
    stderr_hac, stderr_white, cond, r, lags = oe_stderr(pb, x, names)
    stderr, boot = stderr_hac, None
    if opts.n_bootstrap > 0:
        stderr, bias, boot = _oe_bootstrap(pb, x, names, r)
        boot["bias"] = bias
        stderr = bootstrap_intervals(pb, params, stderr, boot)
    top = {k: boot.pop(k) for k in ("interval95", "band") if boot and k in boot}
    if "interval95" in top:
        boot["interval95"] = top["interval95"]
    fit = nrmse_fit(pb.wm, pb.simulate(x)[pb.i0:])
    return PhysicalFit(method="output_error", params=params, stderr=stderr, cond=cond, nrmse=float(fit),
                       n_samples=int(t.shape[0]), nrmse_kind=pb.predictor,
                       info={"predictor": pb.predictor, "injection_gain": float(pb.gain[0]), "noise_std": pb.noise,
                             "stderr_kind": "bootstrap" if boot is not None else "hac", "stderr_hac": stderr_hac,
                             "stderr_white": stderr_white, "hac_lags": int(lags), "bootstrap": boot,
                             "start": {k: float(v) for k, v in s0.items()}, "cost": float(best[0]),
                             "lag_profile": lag_prof, "fitted": list(names),
                             "fixed": {} if pb.free_shape else {"Vs": float(Vs), "delta": float(delta)},
                             "residual_rms": float(math.sqrt(float(r @ r) / r.shape[0])),
                             "n_simulations": int(pb.n_sim), "sensitivity_fallbacks": int(pb.n_sens_fallback),
                             "burn_samples": pb.i0, "loss": opts.loss,
                             "f_scale": float(pb.f_scale), "f_scale_global": float(pb.f_wide),
                             "h_max": opts.h_max, "stop_band": opts.stop_band,
                             "refined_intervals": 0 if pb.stop_mask is None else int(np.count_nonzero(pb.stop_mask)),
                             "input_delay": pb.input_delay,
                             "input_delay_profile": pb.delay_profile, "interp": opts.interp,
                             "Ts_mean": float(np.mean(np.diff(t))), "Ts_max": float(np.max(np.diff(t))), **top})



def fit_physical(t, u, w, *, Vs: float | None, delta: float | None, method: str = "output_error", offset: bool = True,
                 **options) -> PhysicalFit:
    """Identify J, tau, sigma, Fc, Fs (and a torque offset) of eqs. 1-3 from a sampled record.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times (s), strictly increasing, any spacing (Fig. 10's jitter
        is fine for ``"output_error"``; ``"paper"`` assumes the median interval).
    u : array_like, shape (N,)
        Input torque (N·m) at ``t``.
    w : array_like, shape (N,)
        Measured velocity (rad/s) at ``t``.
    Vs : float or None, keyword-only
        Stribeck velocity (rad/s), > 0, pre-estimated (Sec. V-C; held fixed). None (with ``delta`` None, method
        ``"output_error"`` only): fitted with the others, where the quasi-static pre-fit is absent or refused
        (a profile over log Vs at ``delta = 1`` in the global stage, then every stage with ``log Vs`` and
        ``delta`` free); ``params`` then hold ``Vs`` and ``delta``, and ``info["fitted"]``/``info["fixed"]``
        say which parameters were fitted and which held.
    delta : float or None, keyword-only
        Stribeck shape factor, non-zero, pre-estimated (held fixed); None with ``Vs`` None: fitted (>= 0.05).
    method : {"paper", "output_error"}, keyword-only
        See the module docstring. Default ``"output_error"``.
    offset : bool, keyword-only
        Also fit a constant torque offset (N·m). Default True.
    **options
        ``"paper"``: ``inverse`` ({"corrected", "printed"}, default
        "corrected"). ``"output_error"``: the fields of
        :class:`OutputErrorOptions` (``predictor``, ``injection_gain``, ``h_max``,
        ``input_delay``, ``interp``, ``burn``, ``fs_grid``, ``fs_max_ratio``,
        ``diff_step``, ``max_nfev``, ``loss``, ``f_scale``, ``start``,
        ``n_bootstrap``, ``bootstrap_seed``, ``bootstrap_refit``, ``bootstrap_lag_refits``, ``lag_profile``,
        ``jacobian``, ``bootstrap_input_quantum``, ``bootstrap_input_errors``, ``bootstrap_shapes``; units and
        defaults there),
        validated by it.

    Returns
    -------
    PhysicalFit
        With ``warnings`` naming every parameter outside the physical range
        of eqs. 1-3 (the fit itself is not bounded there: an implausible value
        is reported, not hidden).

    Raises
    ------
    SignalError
        NaN/inf in ``t``, ``u``, ``w``; lengths differ; ``t`` not strictly
        increasing; fewer than :data:`MIN_SAMPLES` samples (after ``burn``).
    ParameterError
        Unknown ``method`` or option, invalid ``Vs``, ``delta`` or option value.
    ExcitationError
        Constant input (J), no velocity reversals (Fc, Fs, tau), a parameter
        the output does not depend on, or (``"paper"``) a rank-deficient
        regressor; the message names the parameter.

    Notes
    -----
    Sources: Ruderman, eqs. 1-6 and 9 (model and the ``"paper"`` method);
    Ljung, *System Identification*, 2nd ed., Secs. 3.2, 4.2, 7.2, 8.3, 9.3
    (predictors, output-error consistency under white output noise, and the
    asymptotic covariance used for ``stderr``); Söderström & Stoica, *System
    Identification*, Ch. 8 (why instrumental variables alone would not do,
    module docstring).

    Examples
    --------
    >>> fit = fit_physical(m.t, m.u, m.w, Vs=0.02, delta=1.0)          # doctest: +SKIP
    >>> fit.params["Fs"], fit.stderr["Fs"]                              # doctest: +SKIP
    """
    if method not in METHODS:
        raise ParameterError(f"method must be one of {METHODS}, got {method!r}")
    offset = bool(offset)
    t, u, w, Vs, delta = _check_inputs(t, u, w, Vs, delta, method)
    if method == "paper":
        unknown = set(options) - {"inverse"}
        if unknown:
            raise ParameterError(f"unknown option(s) for method 'paper': {sorted(unknown)}")
        inverse = options.get("inverse", "corrected")
        if inverse not in ("corrected", "printed"):
            raise ParameterError(f"inverse must be 'corrected' or 'printed', got {inverse!r}")
        fit = _fit_paper(t, u, w, Vs, delta, offset, inverse)
    else:
        opts = OutputErrorOptions.from_options(options)
        # one BLAS thread: the trust-region steps multiply N x 6 matrices, which a multi-threaded BLAS splits
        # over threads that spin against the C simulation and the bootstrap's own threads (measured on a
        # 20 k-sample record: 7.9 s of CPU per fit with OpenBLAS's default threads, 2.7 s with one)
        with threadpool_limits(limits=1, user_api="blas"):
            fit = _fit_output_error(t, u, w, Vs, delta, offset, opts)
    return replace(fit, warnings=tuple(check_physical(fit.params, source=f"{method} (fit_physical)")))
