r"""Online estimation of all friction parameters, the Stribeck factors included, by an unscented Kalman filter.

The paper's online estimator (recursive least squares on eq. 4, eqs. 10-13)
is linear in its parameters, so the exponential Stribeck factors ``Vs`` and
``delta`` must be known beforehand (Sec. V-C); its footnote leaves their
online estimation out of scope. This module estimates all six friction
parameters ``(Fc, Fs, Vs, delta, sigma, tau)`` online, from the same sampled
``(u, w)`` stream, by joint state and parameter estimation with an unscented
Kalman filter (UKF) on an augmented state.

Augmented state (order :data:`STATE_NAMES`)::

    x = (w, f, Fc, Fs, log Vs, log|delta|, sigma, log tau)

* ``w`` (rad/s) and ``f`` (N·m): the joint's velocity and lagged friction
  torque (eqs. 1-2).
* ``Fc, Fs, sigma``: linear scale, so the filter can cross zero without
  trouble (nothing in the model becomes non-finite for any sign).
* ``log Vs`` and ``log tau``: positivity by parametrisation; a sigma point
  can never produce a non-positive Stribeck velocity or lag.
* ``log|delta|`` with the sign of ``delta`` fixed by the initial guess. The
  paper (Sec. II-B) allows both signs; they are two different curves
  (``delta > 0``: friction falls from ``Fs`` at standstill towards ``Fc``;
  ``delta < 0``: it rises from ``Fc`` towards ``Fs`` at high speed, see
  :mod:`adaptive_ff.identification.stribeck_fit`), a structural choice, not a small
  correction: near ``delta = 0`` the shape ``exp(-|w/Vs|**delta)`` tends to
  the constant ``exp(-1)``, ``Fs`` and ``Fc`` become indistinguishable and a
  Gaussian filter whose sigma points straddle 0 averages two unrelated
  models. In our first runs with ``delta`` on a linear scale the filter
  drifted to ``delta ~ 0.2`` (a Stribeck term that mimics Coulomb plus
  viscous friction) and locked there. So the filter estimates ``|delta|`` in
  a box (default 0.25 to 5) and the sign comes from ``theta0`` (the quasi-
  static pre-fit tells it, :func:`adaptive_ff.identification.stribeck_fit.fit_stribeck`).

The inertia ``J`` is *known* (a constructor argument), not estimated: the
task is the six friction parameters; ``J`` of a robot joint is
normally known from CAD data and the motor/gear data sheet (and is the
best-determined parameter of the paper's regression), and with ``J``
estimated too the product structure ``J*w' = u - f`` leaves the filter one
more weakly observable direction (a common scaling of ``J`` and the friction
levels during slow motion). Pass the design or LS value.

Process model: eqs. 1-2 (``J*dw/dt = u - f``, ``tau*df/dt + f = F(w)``,
``F`` of eq. 3) integrated over the sample interval ``dt`` with
``n_substeps`` classical RK4 steps, the input ``u`` held constant over the
interval (the convention of :func:`plant.sampling.sample`: ``u[k]`` is the
torque that drove the joint from ``t[k-1]`` to ``t[k]``). The step and eq. 3
are the plant's own, in C (``plant_rk4`` and ``plant_stribeck_eval`` of ``plant/csrc``, called by
``aff_ukf_propagate`` of ``adaptive_ff/csrc/aff_online_ukf.c``), so the filter predicts with the
arithmetic of the simulated joint; for sigma points with negative levels
eq. 3 keeps its form ``sgn(w)*(Fc + (Fs - Fc)*s(w)) + sigma*w``. Parameters follow
a random walk (small process noise). Measurement: the sampled velocity
``w[k]`` only; the friction torque is not measured in a robot joint (it is
what the estimator infers from ``u`` and the motion).

Guards (so that no sigma point gives NaN/inf): ``F(0) = 0`` exactly
(``sgn(0) = 0``), ``exp(-|w/Vs|**delta)`` is finite and in ``[0, 1]`` for
any ``delta`` (for ``delta < 0`` and tiny ``|w|`` the power overflows to
``inf`` and the factor is its limit 0), ``log Vs``, ``log|delta|``
and ``log tau`` are clipped to admissible boxes inside the process model and
after each update, and ``tau >= h/2`` (``h`` the RK4 sub-step) keeps the
integration stable (``h/tau <= 2 < 2.78``, the RK4 stability limit on the
negative real axis). A sample whose update still produces a non-finite
state is rolled back (:class:`FilterDivergedError`).

What made the filter work, and its limits
------------------------------------------
The sign switch of eq. 3 at every reversal is the hard part for a Gaussian
filter: sigma points on either side of ``w = 0`` feel friction of opposite
sign. Three choices, each measured on the closed-loop stream of
``benchmarks/online_identification.py`` (paper preset, Ts = 10 ms, 1e-3 rad/s
noise): (1) ``log|delta|`` with a fixed sign (above); (2) a moderate prior
(default ``std0``) instead of a "large" one; (3) the crossing gate (samples
with a reversal inside the sigma-point span update only ``w`` and ``f``).
Without (2) and (3) the filter drifted away even from a start at the truth.
With them
the levels and the lag are found well, ``Vs`` and ``delta`` less well: starts
on opposite sides end on opposite sides of the truth along the
``Fs``-``Vs``-``delta`` ridge, and the filter's own ``theta_std`` for ``Vs``,
``delta`` is then too small: read it as a lower bound, not a confidence
interval. The measured errors are on the documentation's online
identification benchmark page (``benchmarks/online_identification.py``).

Sources: Julier & Uhlmann, "A new extension of the Kalman filter to
nonlinear systems", SPIE AeroSense 1997, and "Unscented filtering and
nonlinear estimation", Proc. IEEE 92(3), 2004; Wan & van der Merwe, "The
unscented Kalman filter for nonlinear estimation", IEEE AS-SPCC 2000 (joint
state-parameter estimation, scaled sigma points); D. Simon, *Optimal State
Estimation*, Wiley 2006, Ch. 14 (UKF) and Sec. 13.4 (parameter estimation by
state augmentation); the filter itself is :class:`filterpy.kalman.UnscentedKalmanFilter`
with :class:`filterpy.kalman.MerweScaledSigmaPoints` (R. Labbe, filterpy).
Model: Ruderman, eqs. 1-3.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np
import scipy.linalg
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from adaptive_ff._caff import ffi, lib
from adaptive_ff.identification.log_scale import from_log
from plant.errors import FrictionError, ParameterError, SignalError, check_finite_scalar, check_positive, \
    check_signal, check_time
from plant.dynamics import lagged_params
from plant.results import axes_or_new, json_safe

__all__ = [
    "STATE_NAMES",
    "PARAM_NAMES",
    "FilterDivergedError",
    "UKFOptions",
    "OnlineUKF",
    "OnlineUKFResult",
    "run_online_ukf",
    "convergence_time",
]

#: Order of the augmented state vector ``OnlineUKF.x``.
STATE_NAMES = ("w", "f", "Fc", "Fs", "log_Vs", "log_abs_delta", "sigma", "log_tau")
#: Physical friction parameters estimated online (keys of ``OnlineUKF.theta``).
PARAM_NAMES = ("Fc", "Fs", "Vs", "delta", "sigma", "tau")

# default admissible boxes (physical units)
_VS_BOX = (1e-5, 1e2)  # rad/s
_ABS_DELTA_BOX = (0.25, 5.0)
_TAU_MAX = 10.0  # s
_LOG_TAU_MIN = math.log(1e-6)  # s; the process model further floors tau at half an RK4 sub-step

# prior 1-sigma: relative (fraction of the initial guess) for f, Fc, Fs, sigma; absolute on the log scales;
# w in units of the noise std
_DEFAULT_STD0_REL = {"w": 10.0, "f": 0.2, "Fc": 0.2, "Fs": 0.2, "log_Vs": 0.3, "log_abs_delta": 0.2, "sigma": 0.2,
                     "log_tau": 0.5}
# random-walk intensities (state units per sqrt(s))
_DEFAULT_Q = {"w": 1e-3, "f": 0.1, "Fc": 1e-3, "Fs": 1e-3, "log_Vs": 1e-4, "log_abs_delta": 1e-4, "sigma": 1e-3,
              "log_tau": 1e-4}


class FilterDivergedError(FrictionError, ArithmeticError):
    """The filter produced a non-finite state or covariance; the sample was rolled back."""


def _propagate(par, w: float, f: float, u: float, h: float, n: int) -> tuple:
    """Eqs. 1-2 with eq. 3 over ``n`` RK4 steps of ``h`` (s), ``u`` held: ``(w, f)`` at the end.

    ``par``: the lagged-Stribeck parameters of :func:`plant.dynamics.lagged_params` (cffi ``plant_params *``).
    C (``aff_online_ukf.c``, ``aff_ukf_propagate``): the plant's own step (``plant_rk4`` of
    ``plant/csrc/plant_dynamics.c``), so the filter predicts with exactly the arithmetic of the simulated
    joint; any sign of ``Fc``, ``Fs``, ``sigma`` is allowed (sigma points may leave the physical set).
    """
    wf = ffi.new("double[2]", (w, f))
    lib.aff_ukf_propagate(par, wf, wf + 1, u, h, n)
    return wf[0], wf[1]


def _robust_sqrt(P: np.ndarray) -> np.ndarray:
    """Matrix square root ``U`` with ``U.T @ U = P`` for the sigma points (upper Cholesky factor).

    Falls back to an eigen-decomposition with negative eigenvalues clipped to
    a tiny positive floor when rounding has made ``P`` indefinite.
    """
    P = 0.5 * (P + P.T)
    try:
        return scipy.linalg.cholesky(P, lower=False)
    except np.linalg.LinAlgError:
        lam, V = np.linalg.eigh(P)
        floor = 1e-12 * max(float(np.max(np.abs(lam))), 1e-300)
        return (V * np.sqrt(np.clip(lam, floor, None))).T


def _check_box(name: str, box) -> tuple[float, float]:
    """``(low, high)`` as floats with ``0 < low < high``, or ParameterError naming ``name``."""
    try:
        lo, hi = box
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a pair (low, high), got {box!r}") from None
    lo = check_finite_scalar(f"{name}[0]", lo)
    hi = check_finite_scalar(f"{name}[1]", hi)
    if not lo < hi or lo <= 0.0:
        raise ParameterError(f"{name} must satisfy 0 < low < high, got {box!r}")
    return lo, hi


def _check_per_state(name: str, values, *, positive: bool) -> dict:
    """``{state name: float}`` of a partial per-state mapping, values > 0 (``positive``) or >= 0."""
    values = {} if values is None else values
    if not isinstance(values, Mapping):
        raise TypeError(f"{name} must be a mapping keyed by {list(STATE_NAMES)}, got {values!r}")
    unknown = [k for k in values if k not in STATE_NAMES]
    if unknown:
        raise ParameterError(f"{name} has unknown key(s) {unknown}; allowed {list(STATE_NAMES)}")
    out = {}
    for k in STATE_NAMES:
        if k in values:
            v = check_finite_scalar(f"{name}[{k!r}]", values[k])
            if v < 0.0 or (positive and v == 0.0):
                raise ParameterError(f"{name}[{k!r}] must be {'> 0' if positive else '>= 0'}, got {v!r}")
            out[k] = v
    return out


@dataclass(frozen=True)
class UKFOptions:
    """Tuning of :class:`OnlineUKF` (validated on construction; every field keyword-only with a default).

    Parameters
    ----------
    std0 : mapping, keyword-only
        Prior 1-sigma of any of :data:`STATE_NAMES` (state units; on the log
        scales a relative spread), > 0; ``P0 = diag(std0**2)``. Missing keys
        use the defaults: w ``10*noise_std``; f, Fc, Fs ``0.2*max(|Fc0|, |Fs0|)``,
        ``0.2*|Fc0|``, ``0.2*|Fs0|``; sigma ``0.2*|sigma0|``; log_Vs 0.3
        (``Vs`` about ±35 %); log_abs_delta 0.2; log_tau 0.5 (all from
        ``theta0``; a zero guess gets the floor ``1e-3*max(|Fc0|, |Fs0|, 1)``).
        A wide prior is harmful here, not conservative: with ``log_Vs``
        1 and ``log_abs_delta`` 0.5 the sigma points span Stribeck curves
        that differ by a factor 17 in ``Vs``, the unscented transform of the
        switching friction averages unrelated trajectories, and in our runs
        the filter left even a start at the truth by 20-70 % in ``Vs``.
    q : mapping, keyword-only
        Random-walk intensity (state units per sqrt(s)), >= 0, of any of
        :data:`STATE_NAMES`; the process noise of an interval ``dt`` is
        ``Q = diag(q**2)*dt``. Defaults: w 1e-3, f 0.1 (model error of the
        friction lag), Fc/Fs/sigma 1e-3, log_Vs/log_abs_delta/log_tau 1e-4.
        A larger ``f`` intensity (1 N·m/sqrt(s) and more) lets the friction
        state absorb what the Stribeck factors should explain and biased
        ``Vs``/``delta`` by 30-70 % in our runs; larger parameter intensities
        (1e-3 for ``log_Vs``/``log_abs_delta``) track faster but wander along the
        ``Fs``-``Vs``-``delta`` ridge (see the benchmark).
    n_substeps : int, keyword-only
        RK4 steps per sample interval, >= 1 (default 10: 1 ms at Ts = 10 ms,
        the plant's integration step; the sign switch of eq. 3 at reversals
        makes a coarser integration a model error that biased ``Vs``, ``delta``
        and ``tau`` by 10-40 % in our runs).
    alpha, beta, kappa : float, keyword-only
        Scaled sigma-point parameters (van der Merwe): ``0 < alpha <= 1``,
        ``beta >= 0``, ``kappa`` with ``n + kappa > 0`` (``n = 8``). Default 1, 2, 0
        (central weight 0: no negative weights, sigma points at
        ``sqrt(n)`` standard deviations).
    Vs_box, abs_delta_box : tuple of float, keyword-only
        Admissible ``Vs`` (rad/s) and ``|delta|`` ranges ``0 < low < high``;
        default (1e-5, 100) and (0.25, 5). The sign of ``delta`` is that of
        ``theta0['delta']`` and is not estimated (module docstring).
    tau_max : float, keyword-only
        Largest admissible lag (s), > 0, default 10.
    crossing_gate : bool, keyword-only
        Default True: samples whose sigma points straddle ``w = 0`` (a reversal
        within the interval, or a velocity within about ``sqrt(n)`` standard
        deviations of 0) update only ``w`` and ``f``, not the parameters
        (a Schmidt-Kalman "consider" update, :meth:`OnlineUKF.update`). At a reversal
        the sign switch of eq. 3 makes the sigma points on either side of 0
        feel friction of opposite sign (``±Fc``): their mean and cross-
        covariance are no longer a usable approximation, and the spurious
        correlations pulled ``Vs`` and ``delta`` off by 5-15 % even from a
        start at the truth. The low-speed information before and after the
        reversal is kept.
    r_anneal : tuple (factor, T), keyword-only
        Measurement-noise annealing: ``R(t) = noise_std**2*(1 + factor*exp(-t/T))``
        (``factor >= 0``, ``T`` s > 0), slows the first updates. Default
        ``(0, 1)``: off (it did not make the filter more robust in our runs).

    Raises
    ------
    ParameterError
        A value out of range or an unknown key in ``std0``/``q`` (the message quotes it).
    TypeError
        A value is not a real number, or ``std0``/``q`` not a mapping.

    Notes
    -----
    Sources: Wan & van der Merwe (2000) for the scaled sigma points; Simon,
    *Optimal State Estimation* (2006), Sec. 13.4 for the random-walk parameters.
    """

    std0: Mapping | None = None
    q: Mapping | None = None
    n_substeps: int = 10
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    Vs_box: tuple = _VS_BOX
    abs_delta_box: tuple = _ABS_DELTA_BOX
    tau_max: float = _TAU_MAX
    crossing_gate: bool = True
    r_anneal: tuple = (0.0, 1.0)

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        n = self.n_substeps
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ParameterError(f"n_substeps must be an integer >= 1, got {n!r}")
        put("n_substeps", int(n))
        put("alpha", check_finite_scalar("alpha", self.alpha))
        if not 0.0 < self.alpha <= 1.0:
            raise ParameterError(f"alpha must be in (0, 1], got {self.alpha!r}")
        put("beta", check_finite_scalar("beta", self.beta))
        if self.beta < 0.0:
            raise ParameterError(f"beta must be >= 0, got {self.beta!r}")
        put("kappa", check_finite_scalar("kappa", self.kappa))
        if len(STATE_NAMES) + self.kappa <= 0.0:
            raise ParameterError(f"kappa must be > -{len(STATE_NAMES)} (n + kappa > 0), got {self.kappa!r}")
        put("Vs_box", _check_box("Vs_box", self.Vs_box))
        put("abs_delta_box", _check_box("abs_delta_box", self.abs_delta_box))
        put("tau_max", check_positive("tau_max", self.tau_max))
        put("std0", _check_per_state("std0", self.std0, positive=True))
        put("q", _check_per_state("q", self.q, positive=False))
        put("crossing_gate", bool(self.crossing_gate))
        try:
            a_fac, a_T = self.r_anneal
        except (TypeError, ValueError):
            raise ParameterError(f"r_anneal must be a pair (factor, time constant), got {self.r_anneal!r}") from None
        anneal = (check_finite_scalar("r_anneal[0]", a_fac), check_positive("r_anneal[1]", a_T))
        if anneal[0] < 0.0:
            raise ParameterError(f"r_anneal[0] must be >= 0, got {a_fac!r}")
        put("r_anneal", anneal)

    @classmethod
    def coerce(cls, options) -> "UKFOptions":
        """``options`` as UKFOptions: an instance as is, None as the defaults, a mapping by its keys.

        Raises
        ------
        ParameterError
            An unknown key or a bad value.
        TypeError
            ``options`` of another type.
        """
        if options is None:
            return cls()
        if isinstance(options, cls):
            return options
        if not isinstance(options, Mapping):
            raise TypeError(f"options must be a UKFOptions or a mapping, got {type(options).__name__}")
        unknown = sorted(set(options) - {f.name for f in fields(cls)})
        if unknown:
            raise ParameterError(f"unknown UKF option(s) {unknown}; allowed {[f.name for f in fields(cls)]}")
        return cls(**options)


class OnlineUKF:
    """Joint state and friction-parameter estimator: unscented Kalman filter on the augmented state.

    Parameters
    ----------
    J : float, keyword-only
        Known inertia (kg·m²), > 0 (see the module docstring for why it is not estimated).
    theta0 : mapping, keyword-only
        Initial guess ``{Fc, Fs, Vs, delta, sigma, tau}`` (N·m, N·m, rad/s, 1,
        N·m·s/rad, s); ``Vs > 0``, ``tau > 0``, ``delta != 0``.
    noise_std : float, keyword-only
        Standard deviation of the velocity measurement noise (rad/s), > 0:
        ``R = noise_std**2``.
    w0, f0 : float, keyword-only
        Initial velocity (rad/s) and friction torque (N·m); default 0.
    options : UKFOptions or mapping, keyword-only, optional
        Prior, process noise, integration, sigma points, admissible boxes,
        crossing gate and annealing (:class:`UKFOptions`; a mapping is passed
        to it by keyword). Default: ``UKFOptions()``.

    Attributes
    ----------
    x : ndarray, shape (8,)
        Current state estimate (order :data:`STATE_NAMES`); a copy is returned.
    P : ndarray, shape (8, 8)
        Current covariance; a copy is returned.
    theta : dict
        Physical parameters ``{Fc, Fs, Vs, delta, sigma, tau}`` of the current estimate.
    theta_std : dict
        Their 1-sigma uncertainty (``Vs``, ``delta``, ``tau`` by the delta method from the log scale).
    n_updates, n_rejected : int
        Accepted samples and samples rejected by :meth:`update`.
    n_gated : int
        Accepted samples whose parameter update the crossing gate suppressed.

    Raises
    ------
    ParameterError
        A hyperparameter out of range (the message quotes it); unknown keys in
        ``theta0`` or the options; ``theta0`` outside the boxes of the options.
    TypeError
        A value is not a real number.

    Notes
    -----
    See the module docstring for the model and guards. Sources: Julier &
    Uhlmann (1997, 2004); Wan & van der Merwe (2000); Simon, *Optimal State
    Estimation* (2006), Ch. 14 and Sec. 13.4; filterpy's
    ``UnscentedKalmanFilter`` and ``MerweScaledSigmaPoints``; Ruderman, eqs. 1-3.
    """

    def __init__(self, *, J: float, theta0: Mapping, noise_std: float, w0: float = 0.0, f0: float = 0.0,
                 options: UKFOptions | Mapping | None = None):
        self.J = check_positive("J", J)
        self.noise_std = check_positive("noise_std", noise_std)
        opts = UKFOptions.coerce(options)
        self.options = opts
        self.n_substeps = opts.n_substeps
        self.tau_max = opts.tau_max
        self._logVs_box = (math.log(opts.Vs_box[0]), math.log(opts.Vs_box[1]))
        self._logdelta_box = (math.log(opts.abs_delta_box[0]), math.log(opts.abs_delta_box[1]))
        th = self._check_theta0(theta0, opts)
        self.delta_sign = 1.0 if th["delta"] > 0 else -1.0
        w0 = check_finite_scalar("w0", w0)
        f0 = check_finite_scalar("f0", f0)
        n = len(STATE_NAMES)
        self._std0 = np.array([opts.std0.get(k, v) for k, v in self._default_std0(th).items()])
        self._q = np.array([opts.q.get(k, _DEFAULT_Q[k]) for k in STATE_NAMES])
        points = MerweScaledSigmaPoints(n, alpha=opts.alpha, beta=opts.beta, kappa=opts.kappa,
                                        sqrt_method=_robust_sqrt)
        ukf = UnscentedKalmanFilter(dim_x=n, dim_z=1, dt=1.0, hx=self._hx, fx=self._fx, points=points,
                                    sqrt_fn=_robust_sqrt)
        ukf.x = np.array([w0, f0, th["Fc"], th["Fs"], math.log(th["Vs"]), math.log(abs(th["delta"])), th["sigma"],
                          math.log(th["tau"])])
        ukf.P = np.diag(self._std0**2)
        ukf.R = np.array([[self.noise_std**2]])
        self._ukf = ukf
        self._spread = opts.alpha * math.sqrt(n + opts.kappa)  # sqrt(n + lambda), lambda = alpha**2*(n + kappa) - n
        self.crossing_gate = opts.crossing_gate
        self._anneal = opts.r_anneal
        self.t_elapsed = 0.0
        self.n_gated = 0
        self.n_updates = 0
        self.n_rejected = 0

    # ------------------------------------------------------------------ validation helpers

    @staticmethod
    def _check_theta0(theta0, opts: UKFOptions) -> dict:
        if not isinstance(theta0, Mapping):
            raise TypeError(f"theta0 must be a mapping with keys {list(PARAM_NAMES)}, got {theta0!r}")
        if set(theta0) != set(PARAM_NAMES):
            raise ParameterError(f"theta0 must have exactly the keys {list(PARAM_NAMES)}, got {sorted(theta0)}")
        th = {k: check_finite_scalar(f"theta0[{k!r}]", theta0[k]) for k in PARAM_NAMES}
        for k in ("Vs", "tau"):
            if th[k] <= 0.0:
                raise ParameterError(f"theta0[{k!r}] must be > 0, got {th[k]!r}")
        if th["delta"] == 0.0:
            raise ParameterError("theta0['delta'] must be non-zero (|w/Vs|**0 is constant), got 0.0")
        if not opts.abs_delta_box[0] <= abs(th["delta"]) <= opts.abs_delta_box[1]:
            raise ParameterError(f"|theta0['delta']| = {abs(th['delta'])!r} is outside abs_delta_box "
                                 f"{opts.abs_delta_box!r}")
        if not opts.Vs_box[0] <= th["Vs"] <= opts.Vs_box[1]:
            raise ParameterError(f"theta0['Vs'] = {th['Vs']!r} is outside Vs_box {opts.Vs_box!r}")
        if th["tau"] > opts.tau_max:
            raise ParameterError(f"theta0['tau'] = {th['tau']!r} exceeds tau_max = {opts.tau_max!r}")
        return th

    def _default_std0(self, th: dict) -> dict:
        """Prior 1-sigma per state from ``theta0`` (:class:`UKFOptions`, ``std0``), in STATE_NAMES order."""
        scale = max(abs(th["Fc"]), abs(th["Fs"]))
        floor = 1e-3 * max(scale, 1.0)
        r = _DEFAULT_STD0_REL
        return {"w": r["w"] * self.noise_std, "f": max(r["f"] * scale, floor),
                "Fc": max(r["Fc"] * abs(th["Fc"]), floor), "Fs": max(r["Fs"] * abs(th["Fs"]), floor),
                "log_Vs": r["log_Vs"], "log_abs_delta": r["log_abs_delta"],
                "sigma": max(r["sigma"] * abs(th["sigma"]), floor), "log_tau": r["log_tau"]}

    # ------------------------------------------------------------------ model

    def _clip_params(self, x: np.ndarray) -> None:
        """Clip ``log Vs``, ``log|delta|`` and ``log tau`` to their boxes, in place."""
        x[4] = min(max(x[4], self._logVs_box[0]), self._logVs_box[1])
        x[5] = min(max(x[5], self._logdelta_box[0]), self._logdelta_box[1])
        x[7] = min(max(x[7], _LOG_TAU_MIN), math.log(self.tau_max))

    def _tau_bounds(self, dt: float) -> tuple[float, float]:
        return dt / self.n_substeps / 2.0, self.tau_max

    def _fx(self, x, dt, u=0.0):
        """Process model: eqs. 1-2 over ``dt`` by ``n_substeps`` RK4 steps, ``u`` held; parameters constant."""
        w, f, Fc, Fs, logVs, logdelta, sigma, logtau = (float(v) for v in x)
        Vs = from_log(logVs, *self._logVs_box)
        delta = self.delta_sign * from_log(logdelta, *self._logdelta_box)
        tmin, tmax = self._tau_bounds(dt)
        tau = min(max(from_log(logtau, high=50.0), tmin), tmax)
        par = lagged_params(self.J, Fc, Fs, Vs, delta, sigma, tau)
        w, f = _propagate(par, w, f, float(u), dt / self.n_substeps, self.n_substeps)
        out = np.array(x, dtype=float)
        out[0], out[1] = w, f
        return out

    def _w_range(self, x, P) -> tuple[float, float]:
        """Velocity span ``w -/+ sqrt(n + lambda)*std(w)`` covered by the sigma points of ``(x, P)``."""
        r = self._spread * math.sqrt(max(float(P[0, 0]), 0.0))
        return float(x[0]) - r, float(x[0]) + r

    def _state_only_update(self, ukf, w: float, R: float) -> tuple[np.ndarray, np.ndarray]:
        """Measurement update with the parameter rows of the gain set to 0 (Joseph form, any gain).

        The measurement ``w = H x`` is linear (``H = e_1``), so with the
        filterpy gain ``K`` of this step the update ``x+ = x- + K' y``,
        ``P+ = (I - K' H) P- (I - K' H)^T + K' R K'^T`` is exact for the
        modified gain ``K'`` (parameter rows zeroed): velocity and friction
        state are corrected, the parameters keep their value and covariance
        and their cross-covariance with the states follows from the Joseph
        form (Schmidt's "consider" filter, S. F. Schmidt, "Application of
        state-space methods to navigation problems", Advances in Control
        Systems 3, 1966; Simon 2006, Ch. 5 for the Joseph form and Ch. 10 for
        reduced-order/consider filtering).
        """
        K = np.array(ukf.K, dtype=float).reshape(-1, 1)
        K[2:] = 0.0
        n = K.shape[0]
        A = np.eye(n)
        A[:, 0] -= K[:, 0]
        x = ukf.x_prior + K[:, 0] * (w - ukf.x_prior[0])
        P = A @ ukf.P_prior @ A.T + (K @ K.T) * R
        return np.array(x, dtype=float).reshape(-1), P

    @staticmethod
    def _hx(x):
        """Measurement model: the sampled velocity ``w``."""
        return x[:1]

    # ------------------------------------------------------------------ public state

    @property
    def x(self) -> np.ndarray:
        """Augmented state estimate, shape (8,), order :data:`STATE_NAMES` (a copy)."""
        return self._ukf.x.copy()

    @property
    def P(self) -> np.ndarray:
        """State covariance, shape (8, 8) (a copy)."""
        return self._ukf.P.copy()

    @property
    def theta(self) -> dict:
        """Physical friction parameters ``{Fc, Fs, Vs, delta, sigma, tau}`` (SI units) of the estimate."""
        x = self._ukf.x
        return {"Fc": float(x[2]), "Fs": float(x[3]), "Vs": from_log(x[4]), "delta": self.delta_sign * from_log(x[5]),
                "sigma": float(x[6]), "tau": from_log(x[7])}

    @property
    def theta_std(self) -> dict:
        """1-sigma of :attr:`theta` from ``P`` (``Vs``, ``delta``, ``tau``: delta method, e.g. ``std(log Vs)*Vs``)."""
        sd = np.sqrt(np.clip(np.diag(self._ukf.P), 0.0, None))
        th = self.theta
        return {"Fc": float(sd[2]), "Fs": float(sd[3]), "Vs": float(sd[4] * th["Vs"]), "delta": float(sd[5] * abs(th["delta"])),
                "sigma": float(sd[6]), "tau": float(sd[7] * th["tau"])}

    def __repr__(self) -> str:
        th = ", ".join(f"{k}={v:.4g}" for k, v in self.theta.items())
        return f"OnlineUKF(J={self.J!r}, {th}, n_updates={self.n_updates})"

    # ------------------------------------------------------------------ update

    def update(self, u: float, w: float, dt: float) -> float:
        """Process one sample: predict over ``dt`` with ``u`` held, correct with the measured ``w``.

        Parameters
        ----------
        u : float
            Input torque (N·m) applied over the interval that ends at this
            sample (the :func:`plant.sampling.sample` convention).
        w : float
            Measured velocity (rad/s) at the end of the interval.
        dt : float
            Length of the interval (s), > 0; may vary from sample to sample
            (irregular sampling, paper Fig. 10).

        Returns
        -------
        float
            Innovation ``w - w_predicted`` (rad/s).

        Raises
        ------
        SignalError
            ``u`` or ``w`` NaN/inf or not a real number; the state is left unchanged.
        ParameterError
            ``dt`` not finite and > 0; the state is left unchanged.
        FilterDivergedError
            The update produced a non-finite state or covariance; the state is
            rolled back to its value before the call.

        Notes
        -----
        ``filterpy.kalman.UnscentedKalmanFilter.predict`` then ``update``
        (Wan & van der Merwe 2000; Simon 2006, Sec. 14.3), with
        ``Q = diag(q**2)*dt`` and ``R = noise_std**2`` (annealed if
        ``r_anneal`` is set). With ``crossing_gate`` a sample whose
        sigma-point velocity span (before or after the prediction) or
        measurement straddles 0 replaces the filterpy correction by
        :meth:`_state_only_update`. Afterwards ``log Vs``, ``log|delta|``,
        ``log tau`` are clipped to their boxes and ``P`` symmetrised.
        """
        try:
            u = check_finite_scalar("u", u)
            w = check_finite_scalar("w", w)
        except (ParameterError, TypeError) as exc:
            self.n_rejected += 1
            raise SignalError(f"rejected sample: {exc}") from None
        try:
            dt = check_positive("dt", dt)
        except (ParameterError, TypeError) as exc:
            self.n_rejected += 1
            raise ParameterError(f"rejected sample: {exc}") from None
        ukf = self._ukf
        x_old, P_old = ukf.x.copy(), ukf.P.copy()
        try:
            ukf.Q = np.diag(self._q**2 * dt)
            fac, T = self._anneal
            R = self.noise_std**2 * (1.0 + fac * math.exp(-(self.t_elapsed + dt) / T))
            w_lo, w_hi = self._w_range(ukf.x, ukf.P)
            ukf.predict(dt=dt, u=u)
            p_lo, p_hi = self._w_range(ukf.x, ukf.P)
            ukf.update(np.array([w]), R=R)
            x = np.array(ukf.x, dtype=float).reshape(-1)
            gated = self.crossing_gate and min(w_lo, p_lo, w) <= 0.0 <= max(w_hi, p_hi, w)
            if gated:
                x, P = self._state_only_update(ukf, w, R)
                self.n_gated += 1
            else:
                P = ukf.P
            self._clip_params(x)
            P = 0.5 * (P + P.T)
            ok = bool(np.all(np.isfinite(x)) and np.all(np.isfinite(P)))
        except (np.linalg.LinAlgError, FloatingPointError, OverflowError, ValueError):
            ok = False
        if not ok:
            ukf.x, ukf.P = x_old, P_old
            self.n_rejected += 1
            raise FilterDivergedError(f"the UKF update with u={u!r}, w={w!r}, dt={dt!r} gave a non-finite "
                                      "state or covariance; state rolled back")
        innovation = float(ukf.y[0])
        ukf.x, ukf.P = x, P
        self.t_elapsed += dt
        self.n_updates += 1
        return innovation


@dataclass(frozen=True)
class OnlineUKFResult:
    """Result of :func:`run_online_ukf`: the estimate over time.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times (s).
    theta : dict of ndarray, each shape (N,)
        History of the physical parameters ``{Fc, Fs, Vs, delta, sigma, tau}``
        (SI units); entry ``k`` is the estimate after sample ``k`` (entry 0:
        the initial guess).
    theta_std : dict of ndarray, each shape (N,)
        Their 1-sigma from the filter covariance.
    w_hat : ndarray, shape (N,)
        Filtered velocity (rad/s).
    f_hat : ndarray, shape (N,)
        Filtered friction torque (N·m).
    innovation : ndarray, shape (N,)
        Innovations ``w - w_pred`` (rad/s); 0 at sample 0.
    final : dict
        The final estimate ``{Fc, Fs, Vs, delta, sigma, tau}``.
    x : ndarray, shape (8,)
        Final augmented state.
    P : ndarray, shape (8, 8)
        Final covariance.
    """

    t: np.ndarray
    theta: dict
    theta_std: dict
    w_hat: np.ndarray
    f_hat: np.ndarray
    innovation: np.ndarray
    final: dict
    x: np.ndarray
    P: np.ndarray

    def to_dict(self) -> dict:
        """Strict-JSON dict of the final estimate (the histories are left out; NaN/inf as None).

        Returns
        -------
        dict
            ``final`` and ``final_std`` (``{Fc, Fs, Vs, delta, sigma, tau}``),
            ``n_samples``, ``t_start``, ``t_end`` (s), ``innovation_rms``
            (rad/s, samples 1 on), ``x`` (8) and ``P`` (8 x 8 lists).
        """
        n = self.t.shape[0]
        innov = self.innovation[1:]
        return json_safe({"final": self.final, "final_std": {k: v[-1] for k, v in self.theta_std.items()},
                          "n_samples": n, "t_start": self.t[0], "t_end": self.t[-1],
                          "innovation_rms": float(np.sqrt(np.mean(innov**2))) if innov.size else None,
                          "x": self.x, "P": self.P})

    def summary(self) -> str:
        """A few lines: the final parameters with their 1-sigma."""
        units = {"Fc": "N·m", "Fs": "N·m", "Vs": "rad/s", "delta": "", "sigma": "N·m·s/rad", "tau": "s"}
        lines = [f"online UKF estimate after {self.t.shape[0]} samples ({self.t[-1] - self.t[0]:.4g} s)"]
        lines += [f"  {k:<6}{self.final[k]:>12.6g} ± {self.theta_std[k][-1]:<10.3g}{units[k]}" for k in PARAM_NAMES]
        return "\n".join(lines)

    def plot(self, ax=None):
        """Convergence: each parameter's history relative to its final value.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
            Time (s) against ``theta(t)/theta_final`` (parameters whose final value is 0 are left out).
        """
        ax = axes_or_new(ax)
        for k in PARAM_NAMES:
            if self.final[k] != 0.0:
                ax.plot(self.t, self.theta[k] / self.final[k], lw=0.9, label=k)
        ax.axhline(1.0, color="0.5", lw=0.6, ls="--")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("estimate / final estimate (-)")
        ax.legend(loc="best", ncol=3)
        ax.grid(True, alpha=0.3)
        return ax


def run_online_ukf(t, u, w, *, J: float, theta0: Mapping, noise_std: float, f0: float = 0.0,
                   options: UKFOptions | Mapping | None = None) -> OnlineUKFResult:
    """Run :class:`OnlineUKF` over a sampled ``(u, w)`` stream and return the parameter history.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times (s), strictly increasing (irregular intervals allowed).
    u : array_like, shape (N,)
        Input torque (N·m); ``u[k]`` drove the joint over ``(t[k-1], t[k]]``
        (:func:`plant.sampling.sample` convention; ``u[0]`` is unused).
    w : array_like, shape (N,)
        Measured velocity (rad/s).
    J : float, keyword-only
        Known inertia (kg·m²).
    theta0 : mapping, keyword-only
        Initial guess ``{Fc, Fs, Vs, delta, sigma, tau}``.
    noise_std : float, keyword-only
        Velocity noise standard deviation (rad/s), > 0.
    f0 : float, keyword-only
        Initial friction torque (N·m); the initial velocity is ``w[0]``.
    options : UKFOptions or mapping, keyword-only, optional
        Tuning of the filter (:class:`UKFOptions`: ``std0``, ``q``,
        ``n_substeps``, ``alpha``, ``beta``, ``kappa``, boxes, gate, annealing).

    Returns
    -------
    OnlineUKFResult

    Raises
    ------
    SignalError
        ``t``, ``u``, ``w`` not finite 1-D arrays of equal length (>= 2), or
        ``t`` not strictly increasing.
    ParameterError, TypeError
        Invalid hyperparameters (see :class:`OnlineUKF`).
    FilterDivergedError
        The filter diverged (non-finite state) at some sample.

    Notes
    -----
    Sources as :class:`OnlineUKF` (Wan & van der Merwe 2000; Simon 2006, Ch. 14; filterpy).
    """
    t = check_time("t", t)
    u = check_signal("u", u, n=t.shape[0])
    w = check_signal("w", w, n=t.shape[0])
    est = OnlineUKF(J=J, theta0=theta0, noise_std=noise_std, w0=float(w[0]), f0=f0, options=options)
    n = t.shape[0]
    hist = np.empty((n, len(PARAM_NAMES)))
    hstd = np.empty((n, len(PARAM_NAMES)))
    w_hat, f_hat, innov = np.empty(n), np.empty(n), np.zeros(n)

    def record(k):
        hist[k] = list(est.theta.values())
        hstd[k] = list(est.theta_std.values())
        x = est._ukf.x
        w_hat[k], f_hat[k] = x[0], x[1]

    record(0)
    dts = np.diff(t)
    for k in range(1, n):
        innov[k] = est.update(float(u[k]), float(w[k]), float(dts[k - 1]))
        record(k)
    theta = {k: hist[:, i].copy() for i, k in enumerate(PARAM_NAMES)}
    theta_std = {k: hstd[:, i].copy() for i, k in enumerate(PARAM_NAMES)}
    return OnlineUKFResult(t=t, theta=theta, theta_std=theta_std, w_hat=w_hat, f_hat=f_hat, innovation=innov,
                           final=est.theta, x=est.x, P=est.P)


def convergence_time(t, history, true_value: float, *, rel_tol: float = 0.05) -> float:
    """First time after which an estimate stays within ``rel_tol`` of the truth.

    Parameters
    ----------
    t : array_like, shape (N,)
        Time (s).
    history : array_like, shape (N,)
        Estimate over time.
    true_value : float
        The truth, non-zero.
    rel_tol : float, keyword-only
        Relative band, > 0 (default 5 %).

    Returns
    -------
    float
        ``t[k]`` of the first sample from which on ``|history - true| <= rel_tol*|true|``
        holds to the end; ``inf`` if the last sample is outside the band.

    Raises
    ------
    SignalError
        Shapes differ or non-finite values.
    ParameterError
        ``true_value == 0`` or ``rel_tol`` not > 0.
    """
    t = check_signal("t", t)
    h = check_signal("history", history, n=t.shape[0])
    true_value = check_finite_scalar("true_value", true_value)
    if true_value == 0.0:
        raise ParameterError("true_value must be non-zero for a relative band, got 0.0")
    rel_tol = check_positive("rel_tol", rel_tol)
    outside = np.abs(h - true_value) > rel_tol * abs(true_value)
    if outside[-1]:
        return math.inf
    idx = np.flatnonzero(outside)
    return float(t[0] if idx.size == 0 else t[idx[-1] + 1])
