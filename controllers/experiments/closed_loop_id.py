r"""Identification on a closed-loop log read out slower than the loop: an output-error fit that simulates the
known PI controller.

Why
---
A robot joint in a PI velocity loop at 1 kHz whose current and velocity are
read out every 20-40 ms (irregular, paper Sec. V-B and Fig. 10) does not tell
what torque drove the joint between two readouts: the PI reacts to the
tracking error at every controller period, so the torque varies within a
readout interval. The open-loop output-error fit
(:func:`adaptive_ff.identification.physical_id.fit_physical`, method
``"output_error"``) reconstructs the input between readouts by interpolation
and is biased there (J -15 %, tau -90 % on the ``paper-figures --save-data``
robot log), the eq. 4 regression far more. The loop itself is known: a user
knows their controller (gains ``Kp``, ``Ki``, period ``Tc``, torque limit
``u_max``) and, nearly always, the commanded velocity (robot controllers log
it). So the whole loop is simulated.

Method
------
1. The reference, logged at the readout stamps, is interpolated onto the
   controller grid ``t0 + k*Tc`` by a shape-preserving cubic (PCHIP,
   :class:`scipy.interpolate.PchipInterpolator`; the reference is smooth).
2. For candidate parameters ``(J, Fc, Fs, sigma, tau)`` of eqs. 1-3 (``Vs``,
   ``delta`` given, as for ``output_error``) the PI loop (eq. of
   :func:`controllers.design.pi.pi_step`, anti-windup clamping) and the plant
   (RK4, :func:`plant.dynamics.plant_step`) run on the package's compiled
   closed-loop engine (:mod:`controllers.simulation.engine`), many candidates
   in one call (the forward-difference Jacobian: the ``p`` shifted plants at once).
3. The simulated velocity at the log's own stamps and the simulated torque
   that drove the joint to each stamp (the command of the period before it)
   are compared with the logged ``w`` and ``u``; each channel is weighted by
   the inverse RMS of its own residual (iteratively re-weighted once), and
   ``scipy.optimize.least_squares`` (trust-region reflective) minimises the
   sum of squares in ``(log J, Fc, Fs, sigma, log tau)`` (Ljung, *System
   Identification*, 2nd ed., Secs. 7.2 and 9.3; output error in closed loop
   with a known controller: Forssell & Ljung, Automatica 35(7), 1999, the
   "direct approach" with the loop simulated).
4. Start values: for each ``tau`` of a grid, the linear LS regression of the
   logged torque on the reference's acceleration and the lagged friction
   regressors of the reference (eqs. 1-3 with ``w = w_ref``: J, Fc, Fs - Fc
   and sigma enter linearly once ``tau`` is fixed), and the eq. 4 LS estimate
   where it is physical; the candidate of lowest closed-loop cost (one batched
   engine call) is improved by rounds of the same regression on the simulated
   velocity of the current best (a fixed-point iteration towards the loop's
   own trajectory, every ``tau`` of the grid again), keeping the lowest cost.
   The cost is the Gaussian likelihood with each channel's variance
   concentrated out. Two least-squares passes follow, with wide and then finer
   difference steps (the cost is rough at breakaway: the free-run output
   jitters with the reversal instants).

Noise
-----
The real loop's PI reacts to its sensor noise (``Kp`` times the noise enters
the torque at every period, and the joint's motion through breakaway
follows). A loop simulated noise-free is a wrong noise model for this direct
closed-loop fit (Forssell & Ljung, Automatica 35(7), 1999): measured on the
benchmark's records it put J 2-9 % high (mean +4.5 %, six seeds) and its cost
is rough in J (the simulated breakaway instants jump with the parameters).
The loop is therefore simulated *with* white sensor noise of the log's level
(``options.sensor_noise``; by default the robust white-noise level of the
logged velocity, :func:`adaptive_ff.identification.diagnostics.velocity_noise_std_irregular`)
in ``options.n_noise`` realisations (default 8), the same realisations for
every candidate (common random numbers: the cost stays a deterministic
function of the parameters), and the prediction is their mean: the
output-error predictor of the noisy loop, a Monte-Carlo estimate of
``E[w(t) | w_ref]`` (Ljung, *System Identification*, 2nd ed., Sec. 5.7;
simulated-likelihood with common random numbers: Gouriéroux & Monfort,
*Simulation-Based Econometric Methods*, 1996, Ch. 1). The averaging also
smooths the cost. Measured on six seeds (30 s records): J -6.2 .. +3.1 %
(mean -0.3 %) against +2.1 .. +8.8 % noise-free; the cost is eight
simulations per candidate (batched in one engine call).

Standard errors
---------------
The cost is rough at breakaway: the fit stops somewhere in a valley of local
minima whose width, not the noise, sets its error, and asymptotic errors do
not see it. The Newey-West (HAC) sandwich
(:func:`adaptive_ff.identification.covariance.hac_covariance`) around the
forward-difference Jacobian, the two channels interleaved in time order, the
bandwidth twice the larger Andrews AR(1) bandwidth of the two channels
(``info["stderr_hac"]``), was 2-10 times too small. ``stderr`` is therefore
(``options.n_bootstrap > 0``, default 10) the package's parametric
moving-block bootstrap
(:func:`adaptive_ff.identification.covariance.parametric_block_bootstrap`, as
for the output-error fit), built so that each replicate is made as the log
was and fitted as the log was:

* The loop's own noise is drawn afresh: each replicate is one simulation of
  the loop at the estimate with a new white sensor-noise realisation of the
  log's level (the PI reacts to it, the joint's motion through breakaway
  follows), not the mean prediction. The fit absorbs much of that noise's
  effect into its parameters (it shifts the breakaway instants as Fs and tau
  do), so it is missing from the residuals and a residual bootstrap cannot
  see it: on one 15 s record (seed 3; same reference and stamps) the fits of
  six logs that differ only in the loop's noise scatter Fs by 0.69 % (standard
  deviation), of six that differ only in the readout noise by 0.21 %.
* The rest of the residuals (readout noise, quantisation, model error) is
  added, resampled in common blocks of ``3 (L + 1)`` readouts (``L`` the
  larger Andrews bandwidth of the two channels) and scaled per channel by
  ``sqrt(1 - v_loop / mean(r**2))``, ``v_loop`` the variance of the loop
  noise's part (across the ``n_noise`` realisations at the estimate), which
  would otherwise be counted twice (``info["bootstrap"]["residual_scale"]``;
  about 0.4 for the torque, whose residual is mostly ``Kp`` times the noise).
* Each refit uses the fit's noise model (its sensor-noise level and its
  ``n_noise`` common random numbers). The fit's estimate also depends on which
  realisations the simulated predictor averages (a simulated likelihood's own
  error, Gouriéroux & Monfort, 1996, Ch. 1), but refits that drew their own
  level and realisations covered the truth less often over 40 simulated
  records (``docs/benchmarks/output_error.md``, "Closed-loop fit: coverage of the bootstrap intervals"), so the
  refits keep the fit's.
* Each replicate is refitted by the whole estimator: the start search of
  step 4 on the replicate, then the two trust-region passes (Efron &
  Tibshirani, *An Introduction to the Bootstrap*, 1993, Sec. 6.4: the
  bootstrap repeats the whole procedure). Where the fit lands in the flat,
  rough valley depends on the path from its start (seed 3: the passes from
  the true values stop at J -2 %, the fit from its start search at J -7.6 %,
  0.19 apart in the negative log-likelihood); refits started near the
  estimate did not see that spread. With ``options.start`` given, the refits
  start there as the fit does.

The standard error is the root-mean-square deviation of the refits from the
estimate; the nominal 95 % interval (``info["bootstrap"]["interval95"]``) is
``estimate ± t stderr`` with the Student-t quantile of ``n_valid`` degrees of
freedom (:func:`adaptive_ff.identification.covariance.bootstrap_t_quantile`:
2.23 for 10 refits: a standard error from a few refits is itself uncertain,
and ``± 1.96 stderr`` would cover about 92 % at best).
``info["stderr_white"]`` keeps the Gauss-Newton errors that assume white
residuals. Coverage of the nominal 95 % intervals:
``benchmarks/coverage.py --method closed_loop``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from adaptive_ff.identification.covariance import (BootstrapSettings, andrews_bandwidth, bootstrap_t_quantile,
                                                    hac_covariance, parametric_block_bootstrap)
from adaptive_ff.identification.diagnostics import velocity_noise_std_irregular
from adaptive_ff.identification.physical_id import PhysicalFit
from adaptive_ff.identification.plausibility import IdentificationWarning, check_physical
from adaptive_ff.identification.regression import nrmse_fit
from adaptive_ff.io.data import MeasuredData
from controllers.design.pi import PIController
from controllers.simulation.engine import EngineMetrics, EngineRecord, EngineRun
from controllers.simulation.metrics import reversal_times
from plant.dynamics import check_integrable, plant_params, plant_state
from plant.errors import ExcitationError, ParameterError, SignalError, check_finite_scalar, check_optional_number, \
    check_positive, check_signal, check_time
from plant.friction import JointParams
from plant.stiff import check_oscillation

__all__ = ["ControllerSpec", "ClosedLoopIdOptions", "fit_closed_loop", "identify_closed_loop", "CLOSED_LOOP_NAMES"]

#: Parameters the closed-loop fit identifies, in the order of ``PhysicalFit.params``.
CLOSED_LOOP_NAMES = ("J", "Fc", "Fs", "sigma", "tau")

#: Fewest readouts accepted.
MIN_READOUTS = 20
#: Friction-lag values (s) of the start search (module docstring, step 4).
_TAU_GRID = (0.001, 0.002, 0.005, 0.01, 0.02, 0.03, 0.05, 0.1)
#: Rounds of the simulated-regressor start iteration.
_N_START = 4
#: Forward-difference steps (relative) of the two least-squares passes: wide first (smooths the breakaway
#: jitter of the cost), then finer.
_PASS_STEPS = (30.0, 10.0)
#: Relative standard error of a parameter above which an identifiability warning is given.
_REL_STD_WARN = 0.1
#: Seed of the simulated sensor noise (common random numbers: the same realisations for every candidate).
_NOISE_SEED = 20261122
#: Bootstrap (module docstring, "Standard errors"): block length in units of (Andrews bandwidth + 1).
_BOOT_BLOCK = 3


@dataclass(frozen=True)
class ControllerSpec:
    """The user's velocity controller: a discrete PI with saturation (what a drive's parameter list gives).

    Parameters
    ----------
    Kp : float, keyword-only
        Proportional gain (N·m·s/rad), >= 0.
    Ki : float, keyword-only
        Integral gain (N·m/rad), >= 0 (``C(z) = Kp + Ki*Tc*z/(z-1)``, :class:`controllers.design.pi.PIController`).
    Tc : float, keyword-only
        Controller period (s), > 0.
    u_max : float, keyword-only
        Symmetric torque limit (N·m), > 0; ``math.inf`` (default) = none.

    Raises
    ------
    ParameterError
        A value out of range or not a number (the message names it).
    """

    Kp: float
    Ki: float
    Tc: float
    u_max: float = math.inf

    def __post_init__(self):
        for name in ("Kp", "Ki"):
            v = check_finite_scalar(name, getattr(self, name))
            if v < 0:
                raise ParameterError(f"{name} must be >= 0, got {v!r}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "Tc", check_positive("Tc", self.Tc))
        u_max = self.u_max
        try:
            u_max = float(u_max)
        except (TypeError, ValueError):
            raise ParameterError(f"u_max must be a number > 0 (inf = no limit), got {self.u_max!r}") from None
        if not u_max > 0:
            raise ParameterError(f"u_max must be > 0 (inf = no limit), got {self.u_max!r}")
        object.__setattr__(self, "u_max", u_max)
        if self.Kp == 0 and self.Ki == 0:
            raise ParameterError("Kp and Ki are both 0: no controller to simulate")

    def controller(self, integral0: float = 0.0) -> PIController:
        """A fresh :class:`controllers.design.pi.PIController` with these settings and integrator ``integral0`` (N·m)."""
        return PIController(Kp=self.Kp, Ki=self.Ki, Tc=self.Tc, u_max=self.u_max, integral0=integral0)

    def to_dict(self) -> dict:
        """``{"Kp", "Ki", "Tc", "u_max"}`` (SI units; an unlimited ``u_max`` as None: strict JSON)."""
        return {"Kp": self.Kp, "Ki": self.Ki, "Tc": self.Tc, "u_max": self.u_max if math.isfinite(self.u_max) else None}

    @classmethod
    def from_dict(cls, d, *, where: str = "controller") -> "ControllerSpec":
        """Build from ``{"Kp", "Ki", "Tc"[, "u_max"]}`` (SI units; ``u_max`` None or absent = no limit).

        Raises
        ------
        ParameterError
            Not a mapping, a key missing or unknown, or a value out of range; ``where`` names the source.
        """
        if not isinstance(d, dict):
            raise ParameterError(f"{where}: expected a JSON object with Kp, Ki, Tc, u_max, got {type(d).__name__}")
        unknown = sorted(set(d) - {"Kp", "Ki", "Tc", "u_max"})
        missing = [k for k in ("Kp", "Ki", "Tc") if k not in d]
        if unknown or missing:
            raise ParameterError(f"{where}: keys are Kp, Ki, Tc, u_max; missing {missing}, unknown {unknown}")
        try:
            return cls(Kp=d["Kp"], Ki=d["Ki"], Tc=d["Tc"], u_max=math.inf if d.get("u_max") is None else d["u_max"])
        except (ParameterError, TypeError) as exc:
            raise ParameterError(f"{where}: {exc}") from None

    @classmethod
    def from_json(cls, path) -> "ControllerSpec":
        """Read a JSON file written by :meth:`to_dict` (e.g. ``controller.json`` of ``paper-figures --save-data``).

        Raises
        ------
        ParameterError
            Missing, unreadable or invalid file (the message names it).
        """
        path = Path(path)
        try:
            d = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise ParameterError(f"--controller {path}: cannot read a JSON controller file ({exc})") from None
        return cls.from_dict(d, where=str(path))


@dataclass(frozen=True)
class ClosedLoopIdOptions:
    """Settings of :func:`fit_closed_loop` (keyword-only, validated).

    Parameters
    ----------
    burn : float
        Time (s) at the start of the log left out of the cost while the simulated loop settles from its
        initial state, >= 0. Default 0.3.
    u_delay : int
        Controller periods between the command and its readout: the logged torque at a stamp is the command
        of ``u_delay`` periods before (1, default: the torque that drove the joint to the logged velocity;
        0: the command computed at the stamp). 0 or 1.
    max_nfev : int
        Most residual evaluations of each ``least_squares`` pass, >= 2. Default 40.
    diff_step : float
        Forward-difference step in the fit variables ``(log J, Fc, Fs, sigma, log tau)`` relative to
        ``max(1, |x|)``, > 0. Default 1e-3.
    start : dict or None
        Start values ``{"J", "Fc", "Fs", "sigma", "tau"}`` (SI units); None (default): module docstring, step 4.
    sensor_noise : float or None
        Standard deviation (rad/s) of the white velocity noise the PI reacts to, simulated in the loop (module
        docstring, "Noise"), >= 0; None (default): estimated from the logged velocity
        (:func:`adaptive_ff.identification.diagnostics.velocity_noise_std_irregular`); 0: the loop simulated
        noise-free (biased: J 2-9 % high on the benchmark's records).
    n_noise : int
        Noise realisations (common random numbers, the same for every candidate) whose simulated outputs are
        averaged, >= 1. Default 8. The fit's cost grows in proportion.
    n_bootstrap : int
        Refits of the parametric block bootstrap that gives ``stderr`` (module docstring, "Standard errors"),
        >= 0; 0: the HAC standard errors instead (asymptotic, too small on this rough cost). Default 10 (each
        refit simulates the loop once with fresh noise and repeats the start search and the passes: about the
        fit's cost; ``benchmarks/coverage.py --method closed_loop``).
    bootstrap_seed : int
        Seed of the bootstrap's resampling and start draws, >= 0. Default 0.
    """

    burn: float = 0.3
    u_delay: int = 1
    max_nfev: int = 40
    diff_step: float = 1e-3
    start: dict | None = field(default=None)
    sensor_noise: float | None = None
    n_noise: int = 8
    n_bootstrap: int = 10
    bootstrap_seed: int = 0

    def __post_init__(self):
        b = check_finite_scalar("burn", self.burn)
        if b < 0:
            raise ParameterError(f"burn must be >= 0 s, got {self.burn!r}")
        object.__setattr__(self, "burn", b)
        if self.u_delay not in (0, 1) or isinstance(self.u_delay, bool):
            raise ParameterError(f"u_delay must be 0 or 1, got {self.u_delay!r}")
        if isinstance(self.max_nfev, bool) or not isinstance(self.max_nfev, (int, np.integer)) or self.max_nfev < 2:
            raise ParameterError(f"max_nfev must be an integer >= 2, got {self.max_nfev!r}")
        object.__setattr__(self, "diff_step", check_positive("diff_step", self.diff_step))
        for name, lo in (("n_bootstrap", 0), ("bootstrap_seed", 0), ("n_noise", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")
            object.__setattr__(self, name, int(v))
        object.__setattr__(self, "sensor_noise", check_optional_number("sensor_noise", self.sensor_noise, low=0.0,
                                                                       unit="rad/s", none="from the log"))
        if self.start is not None:
            s = dict(self.start)
            missing = [k for k in CLOSED_LOOP_NAMES if k not in s]
            if missing:
                raise ParameterError(f"start must give {list(CLOSED_LOOP_NAMES)}, missing {missing}")
            for k in ("J", "tau"):
                check_positive(f"start[{k!r}]", s[k])
            object.__setattr__(self, "start", {k: float(s[k]) for k in CLOSED_LOOP_NAMES})


class _LoopSimulator:
    """The known PI loop around candidate plants on the compiled engine, sampled at the log's stamps."""

    def __init__(self, t, w_ref, w, u, spec: ControllerSpec, Vs: float, delta: float, opts: ClosedLoopIdOptions):
        from scipy.interpolate import PchipInterpolator

        self.spec, self.Vs, self.delta = spec, Vs, delta
        Tc = spec.Tc
        n = int(math.floor((t[-1] - t[0]) / Tc + 1e-9)) + 1
        self.tg = t[0] + Tc * np.arange(n)
        self.wr = np.ascontiguousarray(PchipInterpolator(t, w_ref)(self.tg))
        pos = (t - t[0]) / Tc
        self.k = np.minimum(np.floor(pos + 1e-9).astype(np.int64), n - 1)  # grid sample at or before each stamp
        self.frac = np.clip(pos - self.k, 0.0, 1.0)
        self.ku = np.maximum(self.k - opts.u_delay, 0)
        self.keep = t - t[0] >= opts.burn
        if np.count_nonzero(self.keep) < MIN_READOUTS:
            raise SignalError(f"only {np.count_nonzero(self.keep)} readouts after the burn-in of {opts.burn:g} s; "
                              f"need >= {MIN_READOUTS}")
        self.w0 = float(w[0])
        # integrator preset so that the first command equals the first logged torque (steady start)
        self.integral0 = float(u[0]) - spec.Kp * (float(w_ref[0]) - float(w[0]))
        self.revs = reversal_times(self.tg, self.wr)
        self.n_sim = 0
        # the PI's sensor noise (module docstring, "Noise"): K realisations, the same for every candidate
        self.noise_std = (velocity_noise_std_irregular(t, w) if opts.sensor_noise is None
                          else opts.sensor_noise)
        K = opts.n_noise if self.noise_std > 0 else 1
        self.noise = self.noise_std * np.random.default_rng(_NOISE_SEED).standard_normal((K, n))

    def plant(self, x) -> JointParams:
        """The plant of fit variables ``x = (log J, Fc, Fs, sigma, log tau)``."""
        J, tau = math.exp(x[0]), math.exp(x[4])
        return JointParams(J=J, Fc=x[1], Fs=x[2], Vs=self.Vs, delta=self.delta, sigma=x[3], tau=tau)

    def run(self, X, *, fine: bool = False, noise=None) -> tuple:
        """Simulated ``(w, u)`` at the stamps, shape (B, M) each, for the rows of ``X`` (B, 5) (``fine``: on the
        whole controller grid, shape (B, N)); NaN rows where a candidate is not a valid plant
        (:func:`plant.dynamics.check_integrable`), has a lag-inertia oscillation too fast for the controller
        period (:func:`plant.stiff.check_oscillation`: it would take hours) or its loop diverged.
        Each is the mean over the sensor-noise realisations ``noise`` (K, N) (rad/s; default the common ones)."""
        X = np.atleast_2d(X)
        noise = self.noise if noise is None else np.atleast_2d(noise)
        C, n, K = X.shape[0], self.tg.shape[0], noise.shape[0]
        B = C * K  # each candidate in K noise realisations
        rows, ok = [], np.ones(C, dtype=bool)
        for b in range(C):
            try:
                p = self.plant(X[b])
                row = plant_params(p)
                check_integrable(row, self.spec.Tc)
                check_oscillation(row, self.spec.Tc)
            except (ParameterError, TypeError, OverflowError, ValueError):
                ok[b] = False
                p = self.plant(np.array([0.0, 1.0, 1.0, 1.0, math.log(0.01)]))
                row = plant_params(p)
            rows += [(row, plant_state(p, self.w0))] * K
        ctrl = self.spec.controller(self.integral0)
        lim = 100.0 * float(np.max(np.abs(self.wr))) + 1.0
        x = EngineRun(t=self.tg, w_ref=self.wr, dt=float(self.spec.Tc), n_scenarios=B,
                      metrics=EngineMetrics(revs=self.revs), record=EngineRecord(decimate=1))
        x.set_noise_table(np.tile(noise, (C, 1)) if self.noise_std > 0 else None)
        for b, (row, st) in enumerate(rows):
            x.set_plant(b, row, 1, 0, st, lim)
            if self.noise_std > 0:
                x.set_noise_row(b, b)
            x.set_pi(b, ctrl)
        x.run()
        self.n_sim += B
        _, diverged, _ = x.outcome()
        W, U = x.rec[:, 0, :].reshape(C, K, n).mean(axis=1), x.rec[:, 2, :].reshape(C, K, n).mean(axis=1)
        diverged = np.asarray(diverged, dtype=bool).reshape(C, K).any(axis=1)
        if fine:
            ws, us = W, U
        else:
            k1 = np.minimum(self.k + 1, n - 1)
            ws = W[:, self.k] * (1.0 - self.frac) + W[:, k1] * self.frac
            us = U[:, self.ku]
        bad = ~ok | diverged
        ws[bad] = np.nan
        us[bad] = np.nan
        return ws, us


def _lagged(Wg, Vs: float, delta: float, tau: float, Tc: float) -> np.ndarray:
    """Friction regressors ``sgn w``, ``sgn w * s(w)``, ``w`` on the controller grid through the lag of eq. 2.

    The first-order lag ``tau dF/dt + F = F_ss(w)`` of each regressor, discretised exactly for inputs held
    over ``Tc`` (Ruderman eq. 2; ``F`` is linear in ``Fc``, ``Fs - Fc`` and ``sigma`` for a given ``tau``).
    Shape (N, 3).
    """
    from scipy.signal import lfilter

    from plant.stribeck_map import stribeck_shape

    sg = np.sign(Wg)
    base = np.column_stack([sg, sg * stribeck_shape(Wg, Vs, delta), Wg])
    a = math.exp(-Tc / tau)
    return lfilter([1.0 - a], [1.0, -a], base, axis=0, zi=(base[0] * a)[None, :])[0]


def _regress(sim: _LoopSimulator, u, Wg, tau: float, acc=None) -> np.ndarray:
    """Fit variables from the LS regression of the logged torque on regressors of a velocity ``Wg`` on the grid.

    ``u(k) = J (w(k+1) - w(k))/Tc + Fc L[sgn w](k) + (Fs - Fc) L[sgn w s(w)](k) + sigma L[w](k)`` at the
    commands ``k`` read out (eqs. 1-3 over one period, ``L`` the lag of eq. 2 for the given ``tau``); ``acc``
    replaces the difference quotient when given. The friction values are clipped into the physical range; a
    regression with ``J <= 0`` gives a NaN ``log J`` (no candidate: :meth:`_LoopSimulator.run` refuses it).
    """
    Tc = sim.spec.Tc
    k = sim.ku
    if acc is None:
        k1 = np.minimum(k + 1, Wg.shape[0] - 1)
        acc = (Wg[k1] - Wg[k]) / Tc
    X = np.column_stack([acc, _lagged(Wg, sim.Vs, sim.delta, tau, Tc)[k]])[sim.keep]
    th, *_ = np.linalg.lstsq(X, u[sim.keep], rcond=None)
    J = math.log(th[0]) if th[0] > 0 else math.nan  # no inertia: not a candidate (NaN: refused by the simulator)
    return np.array([J, max(th[1], 0.0), max(th[1] + th[2], 0.0), max(th[3], 0.0), math.log(tau)])


class _Problem:
    """Weighted residuals of the two channels (velocity, torque) after the burn-in, and their Jacobian."""

    def __init__(self, sim: _LoopSimulator, w, u):
        self.sim, self.wm, self.um = sim, w[sim.keep], u[sim.keep]
        self.sw = self.su = 1.0
        self._last = None

    def raw(self, X) -> tuple:
        """Raw residuals ``(w_sim - w, u_sim - u)`` for the rows of ``X``, shape (B, M) each (NaN: invalid)."""
        ws, us = self.sim.run(X)
        return ws[:, self.sim.keep] - self.wm, us[:, self.sim.keep] - self.um

    @staticmethod
    def ml_cost(rw, ru) -> np.ndarray:
        """Gaussian negative log-likelihood with each channel's variance concentrated out; inf where invalid."""
        n = rw.shape[-1]
        with np.errstate(invalid="ignore", divide="ignore"):
            c = 0.5 * n * (np.log(np.mean(rw**2, axis=-1)) + np.log(np.mean(ru**2, axis=-1)))
        return np.where(np.isfinite(c), c, np.inf)

    def _stack(self, rw, ru) -> np.ndarray:
        r = np.concatenate([rw / self.sw, ru / self.su], axis=-1)
        return np.where(np.isfinite(r), r, 1e3)

    def res(self, x) -> np.ndarray:
        """Weighted residual vector at ``x`` (velocity block, then torque block)."""
        rw, ru = self.raw(x[None, :])
        r = self._stack(rw[0], ru[0])
        self._last = (x.copy(), r)
        return r

    def jac(self, x, ds: float) -> np.ndarray:
        """Forward-difference Jacobian of :meth:`res`: the ``p`` shifted plants in one engine call."""
        if self._last is None or not np.array_equal(self._last[0], x):
            self.res(x)
        r0 = self._last[1]
        h = ds * np.maximum(1.0, np.abs(x))
        rw, ru = self.raw(x[None, :] + np.diag(h))
        return ((self._stack(rw, ru) - r0[None, :]) / h[:, None]).T

    def reweight(self, x) -> None:
        """Set each channel's weight to the inverse RMS of its residual at ``x``."""
        rw, ru = self.raw(x[None, :])
        self.sw = max(float(np.sqrt(np.mean(rw[0] ** 2))), 1e-300)
        self.su = max(float(np.sqrt(np.mean(ru[0] ** 2))), 1e-300)


def _start(sim: _LoopSimulator, pb: _Problem, t, u, w, w_ref, paper_start) -> tuple:
    """Start values (module docstring, step 4): the best of the reference-based regressions over the lag grid
    (and the eq. 4 estimate, if physical) by the closed-loop cost, then rounds of the regression on the
    simulated velocity of the current best. Returns ``(x, candidates tried)``."""
    from scipy.interpolate import PchipInterpolator

    acc = PchipInterpolator(t, w_ref).derivative()(sim.tg[sim.ku])
    cand = [_regress(sim, u, sim.wr, tau, acc) for tau in _TAU_GRID]
    if paper_start is not None:
        cand.append(np.array([math.log(paper_start["J"]), paper_start["Fc"], paper_start["Fs"], paper_start["sigma"],
                              math.log(max(paper_start["tau"], _TAU_GRID[0]))]))
    C = np.array(cand)
    c = pb.ml_cost(*pb.raw(C))
    x, best, tried = C[int(np.argmin(c))], float(np.min(c)), len(C)
    for _ in range(_N_START):
        Xt = np.array([np.r_[x[:4], math.log(tau)] for tau in _TAU_GRID])
        W, _ = sim.run(Xt, fine=True)
        C = np.array([_regress(sim, u, W[b], _TAU_GRID[b]) for b in range(len(_TAU_GRID)) if np.all(np.isfinite(W[b]))])
        if not C.size:
            break
        c = pb.ml_cost(*pb.raw(C))
        tried += 2 * len(_TAU_GRID)
        if float(np.min(c)) < best:
            x, best = C[int(np.argmin(c))], float(np.min(c))
    if not math.isfinite(best):
        raise ExcitationError("no start value gives a stable simulated loop: check the controller (Kp, Ki, Tc, "
                              "u_max), the units of u and w, and Vs, delta")
    return x, tried


def _stderr(pb: _Problem, x, ds: float) -> tuple:
    """HAC and white standard errors of ``(J, Fc, Fs, sigma, tau)`` and the scaled-Jacobian condition number.

    The two channels are interleaved in time order for the Newey-West sum (module docstring); the chain rule
    maps log J and log tau back.
    """
    r = pb.res(x)
    G = pb.jac(x, ds)
    m = r.shape[0] // 2
    ri = np.empty_like(r)
    ri[0::2], ri[1::2] = r[:m], r[m:]
    Gi = np.empty_like(G)
    Gi[0::2], Gi[1::2] = G[:m], G[m:]
    sc = np.linalg.norm(Gi, axis=0)
    if np.any(sc == 0):
        name = CLOSED_LOOP_NAMES[int(np.flatnonzero(sc == 0)[0])]
        raise ExcitationError(f"the simulated loop does not depend on {name!r}: the log does not excite it")
    Gs = Gi / sc
    sv = np.linalg.svd(Gs, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    chain = np.array([math.exp(x[0]), 1.0, 1.0, 1.0, math.exp(x[4])])
    lags = 2 * max(andrews_bandwidth(r[:m]), andrews_bandwidth(r[m:])) + 1
    try:
        s2 = float(r @ r) / max(r.shape[0] - x.shape[0], 1)
        white = np.sqrt(np.clip(np.diag(s2 * np.linalg.inv(Gs.T @ Gs)), 0.0, None)) / sc * chain
        cov, lags = hac_covariance(Gs, ri, lags=lags)
        hac = np.sqrt(np.clip(np.diag(cov), 0.0, None)) / sc * chain
    except np.linalg.LinAlgError:
        white = hac = np.full(x.shape[0], np.nan)
    return (dict(zip(CLOSED_LOOP_NAMES, map(float, hac))), dict(zip(CLOSED_LOOP_NAMES, map(float, white))), cond,
            int(lags))


def _passes(pb: _Problem, x, opts: ClosedLoopIdOptions) -> tuple:
    """The two trust-region passes of the fit (module docstring, step 4): each re-weights the channels, then
    fits with its difference step. Returns ``(x, status of the last pass)``."""
    from scipy.optimize import least_squares

    status = 1
    for f in _PASS_STEPS:
        pb.reweight(x)
        ds = f * opts.diff_step
        sol = least_squares(pb.res, x, jac=lambda z, ds=ds: pb.jac(z, ds), method="trf", x_scale="jac",
                            max_nfev=opts.max_nfev, xtol=1e-10, ftol=1e-10)
        x, status = sol.x, sol.status
    return x, status


def _bootstrap(sim: _LoopSimulator, pb: _Problem, x, fixed_start, ctx: tuple, opts: ClosedLoopIdOptions) -> tuple:
    """Parametric moving-block bootstrap of the closed-loop fit (module docstring, "Standard errors") by
    :func:`adaptive_ff.identification.covariance.parametric_block_bootstrap`.

    Replicates: one simulation of the loop at ``x`` with fresh sensor noise (velocity and torque at the
    stamps; the mean prediction when the loop is simulated noise-free) plus the two channels' residuals
    resampled in common blocks, scaled by the share not explained by the loop noise; each is refitted by the
    whole estimator: the start search of step 4 on the replicate (or the user's ``fixed_start``) and the two
    passes. ``ctx = (t, w_ref, paper_start)``. Returns ``(stderr dict, details dict)``.
    """
    t, w_ref, paper_start = ctx
    n_sim0 = sim.n_sim
    ws, us = sim.run(x[None, :])
    pred = np.column_stack([ws[0, sim.keep], us[0, sim.keep]])
    res = np.column_stack([pb.wm, pb.um]) - pred
    block = _BOOT_BLOCK * (max(andrews_bandwidth(res[:, 0]), andrews_bandwidth(res[:, 1])) + 1)
    est = np.array([math.exp(x[0]), x[1], x[2], x[3], math.exp(x[4])])
    w_full, u_full = ws[0].copy(), us[0].copy()
    simulate, scale = None, np.ones(2)
    if sim.noise_std > 0:  # the loop's own noise, drawn afresh per replicate; the residuals keep the rest
        rows = sim.noise if sim.noise.shape[0] >= 2 else sim.noise_std * np.random.default_rng(
            _NOISE_SEED + 1).standard_normal((8, sim.tg.shape[0]))  # >= 2 realisations for their variance
        each = [sim.run(x[None, :], noise=row[None, :]) for row in rows]
        var_loop = np.array([np.mean(np.var(np.stack([e[c][0, sim.keep] for e in each]), axis=0, ddof=1))
                             for c in (0, 1)])
        scale = np.sqrt(np.clip(1.0 - var_loop / np.mean(res**2, axis=0), 0.0, 1.0))

        def fresh(rng):
            wn, un = sim.run(x[None, :], noise=sim.noise_std * rng.standard_normal((1, sim.tg.shape[0])))
            return np.column_stack([wn[0, sim.keep], un[0, sim.keep]])

        simulate = fresh

    def refit(y, rng):
        w_full[sim.keep], u_full[sim.keep] = y[:, 0], y[:, 1]
        pr = _Problem(sim, w_full, u_full)
        z0 = fixed_start if fixed_start is not None else _start(sim, pr, t, u_full, w_full, w_ref, paper_start)[0]
        z, _ = _passes(pr, z0, opts)
        return np.array([math.exp(z[0]), z[1], z[2], z[3], math.exp(z[4])])

    b = parametric_block_bootstrap(refit, pred, res * scale, est, simulate=simulate,
                                   settings=BootstrapSettings(n=opts.n_bootstrap, block=block,
                                                              seed=opts.bootstrap_seed, scheme="moving"))
    hw = b.half_width(0.95)
    details = {"n": opts.n_bootstrap, "n_valid": b.n_valid, "block": int(b.block), "seed": opts.bootstrap_seed,
               "loop_noise": "fresh realisation per replicate" if simulate is not None else "none (noise-free loop)",
               "residual_scale": {"w": float(scale[0]), "u": float(scale[1])},
               "noise_model": "the fit's (its sensor-noise level and common random numbers)",
               "refit": "whole estimator (start search and passes)" if fixed_start is None else
               "the passes from options.start", "n_simulations": int(sim.n_sim - n_sim0),
               "bias": dict(zip(CLOSED_LOOP_NAMES, map(float, b.bias))),
               "t_quantile": bootstrap_t_quantile(b.n_valid) if b.n_valid >= 1 else None,
               "interval95": {k: [float(v - h), float(v + h)] for k, v, h in zip(CLOSED_LOOP_NAMES, est, hw)},
               "replicates": [dict(zip(CLOSED_LOOP_NAMES, map(float, r))) for r in b.replicates]}
    return dict(zip(CLOSED_LOOP_NAMES, map(float, b.stderr))), details


def _check(t, u, w, w_ref, controller, Vs, delta):
    t = check_time("t", t, min_len=MIN_READOUTS)
    u = check_signal("u", u, n=t.shape[0])
    w = check_signal("w", w, n=t.shape[0])
    w_ref = check_signal("w_ref", w_ref, n=t.shape[0])
    if not isinstance(controller, ControllerSpec):
        raise ParameterError(f"controller must be a ControllerSpec, got {type(controller).__name__}")
    Vs = check_positive("Vs", Vs)
    delta = check_finite_scalar("delta", delta)
    if delta == 0.0:
        raise ParameterError("delta must be non-zero, got 0.0")
    if float(np.min(np.diff(t))) < controller.Tc * (1.0 - 1e-6):
        raise ParameterError(f"the log is read out faster ({1e3 * float(np.min(np.diff(t))):.4g} ms) than the "
                             f"controller period Tc = {1e3 * controller.Tc:.4g} ms: wrong Tc or time unit?")
    sgn = np.sign(w_ref[np.abs(w_ref) > 0])
    if sgn.size == 0 or np.all(sgn == sgn[0]):
        raise ExcitationError("the reference never changes sign: no reversals, Fc and Fs (and tau) are not "
                              "identifiable; excite both directions of motion")
    return t, u, w, w_ref, Vs, delta


def _warnings(params: dict, stderr: dict, cond: float, sol_status: int, kind: str) -> list:
    """Plausibility (eqs. 1-3) and identifiability warnings of a closed-loop fit, ``{code, parameter, message}``."""
    out = check_physical(params, source="closed_loop (fit_closed_loop)")
    for k in CLOSED_LOOP_NAMES:
        v, s = params[k], stderr.get(k, math.nan)
        if v != 0 and math.isfinite(s) and s > _REL_STD_WARN * abs(v):
            out.append(IdentificationWarning(
                "identifiability", k, f"closed_loop: {k} = {v:.4g} ± {s:.3g} ({kind} standard error, "
                f"{100 * s / abs(v):.3g} % > {100 * _REL_STD_WARN:g} %): the log does not determine {k}"))
    if not math.isfinite(cond) or cond > 1e6:
        out.append(IdentificationWarning("conditioning", "all", f"closed_loop: Jacobian condition number {cond:.3g} "
                                         "> 1e6: the estimates are sensitive to noise"))
    if sol_status == 0:
        out.append(IdentificationWarning("method", "all", "closed_loop: the last least-squares pass stopped at its "
                                         "evaluation limit (options max_nfev) on the rough cost; compare the fit "
                                         "with another start (options start) before relying on it"))
    return out


def fit_closed_loop(data: MeasuredData, w_ref, *, controller: ControllerSpec, Vs: float, delta: float,
                    options: ClosedLoopIdOptions | None = None, paper_start: dict | None = None) -> PhysicalFit:
    """Identify J, Fc, Fs, sigma, tau of eqs. 1-3 from a closed-loop log read out slower than the loop.

    Parameters
    ----------
    data : adaptive_ff.io.data.MeasuredData
        The log, ``M`` readouts: stamps ``t`` (s, strictly increasing, any spacing >= ``controller.Tc``; kept as
        read), torque ``u`` (N·m) at ``t`` (the command of ``options.u_delay`` controller periods before the
        stamp), measured velocity ``w`` (rad/s) at ``t``.
    w_ref : array_like, shape (M,)
        Commanded velocity (rad/s) at ``t``, smooth (interpolated onto the controller grid by PCHIP).
    controller : ControllerSpec, keyword-only
        The PI of the loop (``Kp``, ``Ki``, ``Tc``, ``u_max``), known to the user.
    Vs : float, keyword-only
        Stribeck velocity (rad/s), > 0, pre-estimated (Sec. V-C; held fixed).
    delta : float, keyword-only
        Stribeck shape factor, non-zero (held fixed).
    options : ClosedLoopIdOptions, keyword-only, optional
        Burn-in, torque alignment, evaluation limit, difference step, start values, simulated sensor noise,
        bootstrap refits.
    paper_start : dict, keyword-only, optional
        An eq. 4 estimate ``{"J", "Fc", "Fs", "sigma", "tau"}`` tried as one more start candidate when J, Fc,
        Fs and sigma are > 0 (tau at least 1 ms), as :func:`identify_closed_loop` does with the report's LS
        estimate.

    Returns
    -------
    PhysicalFit
        ``method="closed_loop"``, ``params`` and ``stderr`` of ``J, Fc, Fs, sigma, tau`` (the bootstrap's, or
        HAC with ``options.n_bootstrap = 0``: ``info["stderr_kind"]`` says which); ``nrmse`` the free-run fit
        (%) of the logged velocity by the simulated loop (``info["fit_u_percent"]`` of the torque); ``warnings``
        (plausibility and identifiability, ``{code, parameter, message}``); ``info`` with the controller,
        ``stderr_hac``, ``stderr_white``, ``hac_lags``, ``bootstrap`` (None, or ``n``, ``n_valid``, ``block``,
        ``seed``, ``loop_noise``, ``residual_scale``, ``noise_model``, ``refit``, ``n_simulations``, ``bias``,
        ``replicates`` (the valid refits), ``t_quantile`` and ``interval95``: ``{name: [low, high]}``, the nominal 95 % interval
        ``value ± t_quantile stderr``), ``sensor_noise`` and ``n_noise`` of the
        simulated loop, channel RMS, start, simulations run (each noise realisation counted).

    Raises
    ------
    TypeError
        ``data`` not a :class:`adaptive_ff.io.data.MeasuredData`.
    SignalError
        Non-finite or mismatched signals, fewer than 20 readouts (after the burn-in).
    ParameterError
        Bad controller, ``Vs``, ``delta`` or options, or readouts faster than ``Tc``.
    ExcitationError
        No reversals in the reference, no stable start, or a parameter the loop does not depend on.

    Notes
    -----
    Module docstring: the loop is simulated with sensor noise of the log's level (mean of ``n_noise``
    realisations); standard errors by a parametric moving-block bootstrap whose replicates draw the loop's
    noise afresh and whose refits repeat the whole estimator, start search included (the cost is rough; HAC
    ones are too small), intervals with Student-t quantiles. Sources: Ruderman eqs. 1-3; Ljung, *System Identification*, 2nd ed.,
    Secs. 7.2, 9.3; Forssell & Ljung, Automatica 35(7), 1999; Newey & West, Econometrica 55(3), 1987; Künsch,
    Ann. Statist. 17(3), 1989.
    """
    opts = ClosedLoopIdOptions() if options is None else options
    if not isinstance(opts, ClosedLoopIdOptions):
        raise ParameterError(f"options must be a ClosedLoopIdOptions, got {type(opts).__name__}")
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    t, u, w, w_ref, Vs, delta = _check(data.t, data.u, data.w, w_ref, controller, Vs, delta)
    sim = _LoopSimulator(t, w_ref, w, u, controller, Vs, delta, opts)
    pb = _Problem(sim, w, u)
    ok = paper_start is not None and all(float(paper_start.get(k, -1.0)) > 0 for k in ("J", "Fc", "Fs", "sigma"))
    paper_start = paper_start if ok else None
    fixed = None
    if opts.start is not None:
        s = opts.start
        fixed = np.array([math.log(s["J"]), s["Fc"], s["Fs"], s["sigma"], math.log(s["tau"])])
        x, tried = fixed.copy(), 0
    else:
        x, tried = _start(sim, pb, t, u, w, w_ref, paper_start)
    x0 = x.copy()
    x, status = _passes(pb, x, opts)
    pb.reweight(x)
    hac, white, cond, lags = _stderr(pb, x, _PASS_STEPS[-1] * opts.diff_step)
    stderr, boot = hac, None
    if opts.n_bootstrap > 0:
        stderr, boot = _bootstrap(sim, pb, x, fixed, (t, w_ref, paper_start), opts)
    J, Fc, Fs, sigma, tau = math.exp(x[0]), float(x[1]), float(x[2]), float(x[3]), math.exp(x[4])
    params = {"J": J, "Fc": Fc, "Fs": Fs, "sigma": sigma, "tau": tau}
    ws, us = (a[0, sim.keep] for a in sim.run(x[None, :]))
    info = {"controller": controller.to_dict(), "stderr_kind": "bootstrap" if boot is not None else "hac",
            "stderr_hac": hac, "stderr_white": white, "hac_lags": lags, "bootstrap": boot,
            "residual_rms_w": pb.sw, "residual_rms_u": pb.su, "fit_u_percent": float(nrmse_fit(pb.um, us)),
            "start": dict(zip(CLOSED_LOOP_NAMES, (math.exp(x0[0]), *map(float, x0[1:4]), math.exp(x0[4])))),
            "n_simulations": int(sim.n_sim), "n_start_candidates": int(tried), "burn": opts.burn,
            "u_delay": opts.u_delay, "Ts_mean": float(np.mean(np.diff(t))), "Ts_max": float(np.max(np.diff(t))),
            "sensor_noise": float(sim.noise_std), "n_noise": int(sim.noise.shape[0]),
            "noise_model": (f"loop simulated with white sensor noise {sim.noise_std:.3g} rad/s, mean of "
                            f"{sim.noise.shape[0]} realisations" if sim.noise_std > 0 else "loop simulated noise-free")}
    return PhysicalFit(method="closed_loop", params=params, stderr=stderr, cond=cond,
                       nrmse=float(nrmse_fit(pb.wm, ws)), n_samples=int(t.shape[0]),
                       nrmse_kind="closed-loop simulation", info=info,
                       warnings=tuple(_warnings(params, stderr, cond, status, info["stderr_kind"])))


def identify_closed_loop(data, w_ref, *, controller: ControllerSpec, Vs: float, delta: float, method: str = "auto",
                         options: ClosedLoopIdOptions | None = None, **identify_options):
    """:func:`adaptive_ff.identification.identify.identify` for a closed-loop log whose reference and controller
    are known: the eq. 4 baseline, and :func:`fit_closed_loop` as the answer where it applies.

    Parameters
    ----------
    data : adaptive_ff.io.data.MeasuredData
        The log: ``t`` (s, kept as read), ``u`` (N·m), ``w`` (rad/s).
    w_ref : array_like, shape (N,)
        Commanded velocity (rad/s) at ``data.t``.
    controller : ControllerSpec, keyword-only
        The PI of the loop.
    Vs, delta : float, keyword-only
        Stribeck velocity (rad/s) and shape factor, pre-estimated (Sec. V-C).
    method : {"auto", "closed_loop"}, keyword-only
        ``"auto"`` (default): :func:`adaptive_ff.identification.identify.choose_method` with the controller
        period (``"closed_loop"`` for a log read out slower than the loop, else ``"sliding"`` or ``"paper"``,
        run by ``identify`` itself); ``"closed_loop"``: always this fit.
    options : ClosedLoopIdOptions, keyword-only, optional
        Settings of :func:`fit_closed_loop`.
    **identify_options
        ``lag``, ``offset``, ``lam``, ``P0``, ``n_history`` of ``identify`` (the eq. 4 baseline).

    Returns
    -------
    adaptive_ff.identification.identification_report.IdentificationReport
        With ``physical`` the closed-loop fit (``method "closed_loop"``), the choice named in ``notes``.

    Raises
    ------
    ParameterError, SignalError, ExcitationError
        From ``identify`` and :func:`fit_closed_loop`; ``method`` not one of the two; ``w_ref`` of another
        length than the log.
    """
    from adaptive_ff.identification.identify import attach_physical, choose_method, identify, stderr_note

    if method not in ("auto", "closed_loop"):
        raise ParameterError(f"method must be 'auto' or 'closed_loop', got {method!r}")
    w_ref = check_signal("w_ref", w_ref, n=data.t.shape[0])
    reason = None
    if method == "auto":
        chosen, reason = choose_method(data, Vs=Vs, controller_Tc=controller.Tc)
        if chosen != "closed_loop":
            return identify(data, Vs=Vs, delta=delta, method="auto", **identify_options)
    report = identify(data, Vs=Vs, delta=delta, method="paper", **identify_options)
    e = report.estimate
    start = {"J": e.J, "Fc": e.Fc, "Fs": e.Fs, "sigma": e.sigma, "tau": e.tau}
    fit = fit_closed_loop(data, w_ref, controller=controller, Vs=Vs, delta=delta, options=options, paper_start=start)
    c = controller
    note = (f"physical parameters by 'closed_loop': the PI loop (Kp = {c.Kp:.6g}, Ki = {c.Ki:.6g}, Tc = "
            f"{c.Tc * 1e3:.4g} ms, u_max = {c.u_max:.6g}) simulated on the reference and fitted to w and u at the "
            f"{fit.n_samples} stamps as read ({fit.info['n_simulations']} simulations); {stderr_note(fit)}")
    return attach_physical(report, fit, note=note, auto_reason=reason, data=data)
