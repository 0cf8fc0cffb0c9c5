"""Test oracles of the friction feedforward (fixed, and eq. 4 adaptive) and of the two peers, from their equations.

Each oracle is written from the documented model of its component, not from the component's code, and runs over
whole recorded signals (the torque, the velocities), so that a test can drive the package's component in its
calling sequence and then check every output against the oracle fed with the same signals:

* :func:`friction_map` (eq. 3 with the sign ramp, vectorised) and :class:`Feedforward`, the fixed feedforward
  of :class:`adaptive_ff.compensation.feedforward.FrictionFeedforward` (stick detection, eq. 1's lag in its
  exact solution for a held input, the bound), stepped;
* :func:`eq4_path`, the eq. 4 adaptive feedforward of :mod:`adaptive_ff.compensation.eq4_feedforward`: eq. 4's
  regressor and its inverse map as derived in :mod:`adaptive_ff.identification.regression`'s docstring, the
  projection of :func:`adaptive_ff.compensation.feedforward.project_estimate`;
* :func:`canudas_path`, Canudas de Wit et al.'s compensator (:mod:`controllers.peers.canudas`): the sample
  intervals of ``Ts`` over the accepted samples, the rows of the sampled motor model, the direction-dependent
  Coulomb + viscous map;
* :func:`dob_path`, the disturbance observer (:mod:`controllers.peers.dob`): the raw disturbance samples
  filtered by the binomial Q-filter from tests/lti_oracle.py (:func:`scipy.signal.lfilter`);
* :class:`Range`, the range rule of :class:`adaptive_ff.compensation.gate.RangeGate`.

The estimators' RLS is the package's :class:`~adaptive_ff.identification.rls.RecursiveLeastSquares`, which
tests/adaptive_ff_layer/test_rls.py and tests/controllers_layer/test_properties.py check against tests/rls_oracle.py (closed form, information form):
here it is a trusted part, and the oracles check what the components feed it and make of its estimates. Not
part of the package.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.identification.rls import RecursiveLeastSquares
from lti_oracle import lag, power
from plant.errors import SignalError

__all__ = ["Range", "rls_try", "friction_map", "Feedforward", "eq4_columns", "eq4_physical", "admissible",
           "Eq4Estimator", "eq4_path", "canudas_path", "dob_path"]


class Range:
    """The range rule of adaptive_ff.compensation.gate.RangeGate, written again (independent code).

    Out of range: not finite, |x| > x_max, or |x| > factor*max(env, floor) while that reference is > 0 and fewer
    than max_consecutive samples were rejected in a row. Accepted samples raise the envelope at once
    (env = max(|x|, exp(-1/memory)*env)).
    """

    def __init__(self, x_max=math.inf, factor=100.0, floor=0.0, memory=10000.0, max_consecutive=20):
        self.x_max, self.factor, self.floor = x_max, factor, floor
        self.decay, self.max_consecutive = math.exp(-1.0 / memory), max_consecutive
        self.env, self.held, self.n_rejected = 0.0, 0, 0

    def ok(self, x: float) -> bool:
        if not math.isfinite(x) or abs(x) > self.x_max:
            return False
        ref = max(self.env, self.floor)
        return ref == 0.0 or self.held >= self.max_consecutive or abs(x) <= self.factor * ref

    def commit(self, x: float, ok: bool) -> None:
        if ok:
            self.env = max(abs(x), self.decay * self.env)
            self.held = 0
        else:
            self.held += 1
            self.n_rejected += 1


def rls_try(rls, phi, y):
    """The package RLS update, with a refused sample (an update that would overflow) as None."""
    try:
        return rls.update(phi, y)
    except SignalError:
        return None


# ------------------------------------------------------------------------------------------- fixed feedforward
def friction_map(w, Fc, Fs, Vs, delta, sigma, sign_width=0.0):
    """Eq. 3 without offset, ``sgn(w)*(Fc + (Fs - Fc)*exp(-|w/Vs|**delta)) + sigma*w`` (N·m), any shape.

    ``Vs`` None: the Coulomb level ``Fc`` alone. ``sign_width > 0``: ``sgn`` is the ramp
    ``clip(w/sign_width, -1, 1)``.
    """
    w = np.asarray(w, dtype=float)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        level = Fc + 0.0 * w if Vs is None else Fc + (Fs - Fc) * np.exp(-((np.abs(w) / Vs) ** delta))
        sgn = np.sign(w) if sign_width <= 0.0 else np.clip(w / sign_width, -1.0, 1.0)
        out = np.where(w == 0.0, 0.0, sgn * level + sigma * w)
    return float(out) if out.ndim == 0 else out


class Feedforward:
    """The feedforward of the estimate in use (:meth:`use`), one period per :meth:`step`.

    Per period: the velocity to evaluate (the second one, ``w_ref``, once the first has stayed inside
    ``±stick_band`` for ``stick_samples`` calls), the map of eq. 3 there, the lag of eq. 1 solved exactly over
    the period, ``u <- exp(-dt/tau)*u + (1 - exp(-dt/tau))*F``, the output clipped to ``±ff_max``. A non-finite
    velocity (or ``w_ref`` when given) or map leaves everything but ``n_rejected`` and returns the held output.
    """

    def __init__(self, *, dt, lag=True, ff_max=math.inf, sign_width=0.0, stick_band=0.0, stick_samples=10):
        self.dt, self.lag, self.ff_max, self.sign_width = dt, lag, ff_max, sign_width
        self.stick_band, self.stick_samples = stick_band, stick_samples
        self.estimate = None
        self.keep = 0.0  # exp(-dt/tau): the part of the last output the lag keeps
        self.u_ff = 0.0
        self.in_band = 0
        self.n_rejected = 0

    def use(self, est) -> None:
        """Put ``est`` (a FrictionEstimate or None) into use; the lag's output carries over."""
        self.estimate = est
        self.keep = math.exp(-self.dt / est.tau) if (est is not None and self.lag and est.tau > 0.0) else 0.0

    def static(self, w):
        e = self.estimate
        if e is None:
            return 0.0 * np.asarray(w, dtype=float)
        return friction_map(w, e.Fc, e.Fs, e.Vs, e.delta, e.sigma, self.sign_width)

    def output(self) -> float:
        return min(max(self.u_ff, -self.ff_max), self.ff_max)

    def step(self, w, w_ref=None) -> float:
        if not math.isfinite(w) or (w_ref is not None and not math.isfinite(w_ref)):
            self.n_rejected += 1
            return self.output()
        in_band = self.in_band
        x = w
        if w_ref is not None:
            in_band = in_band + 1 if abs(w) < self.stick_band else 0
            if in_band >= self.stick_samples:
                x = w_ref
        F = float(self.static(x))
        if not math.isfinite(F):
            self.n_rejected += 1
            return self.output()
        self.in_band = in_band
        self.u_ff = self.keep * self.u_ff + (1.0 - self.keep) * F
        return self.output()


# ------------------------------------------------------------------------------------------ eq. 4 feedforward
def eq4_columns(u, u1, w1, w2, model) -> np.ndarray:
    """Eq. 4's regressor ``(w(k-1), -w(k-2), u(k), -u(k-1), -g(w(k-1)), -h(w(k-1)), -1)`` for the structure of
    ``model`` (without the lag: no ``w(k-2)``, ``u(k-1)``; without Stribeck: ``-sgn`` for ``-g, -h``)."""
    s = float(np.sign(w1))
    cols = [w1] + ([-w2] if model.lag else []) + [u] + ([-u1] if model.lag else [])
    if model.stribeck:
        with np.errstate(over="ignore"):
            e = float(np.exp(-((abs(w1) / model.Vs) ** model.delta))) if w1 != 0.0 else 1.0
        cols += [-s * (1.0 - e), -s * e]  # -g, -h (eqs. 5, 6)
    else:
        cols += [-s]
    if model.offset:
        cols.append(-1.0)
    return np.array(cols)


def eq4_physical(theta, model, Ts):
    """The inverse map of eq. 4 (the regression module's docstring): ``(J, tau, sigma, Fc, Fs, offset, J_alt)``."""
    it = iter(np.asarray(theta, dtype=float).tolist())
    a1 = next(it)
    a2 = next(it) if model.lag else 0.0
    b0 = next(it)
    b1 = next(it) if model.lag else 0.0
    c1 = next(it)
    d1 = next(it) if model.stribeck else c1
    o1 = next(it) if model.offset else 0.0
    gain = b0 - b1  # = Ts**2/D
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.float64(1.0) / np.float64(gain)
        J_alt = Ts * a2 / b1 if b1 != 0.0 else math.nan
    return (float(Ts * (a1 - 2.0 * a2) * q), float(Ts * b1 * q), float((1.0 - a1 + a2) * q), float(c1 * q),
            float(d1 * q), float(o1 * q), float(J_alt))


def admissible(phys, *, tau_max, F_max, Vs=None, delta=None):
    """project_estimate's rule for ``phys = (J, tau, sigma, Fc, Fs, offset, J_alt)``: None unless finite, J > 0
    and Fc, Fs <= F_max; then the lag clipped to [0, tau_max] and sigma, Fc, Fs to >= 0."""
    J, tau, sigma, Fc, Fs, offset, J_alt = phys
    if not all(math.isfinite(v) for v in (J, tau, sigma, Fc, Fs, offset)) or J <= 0.0 or max(Fc, Fs) > F_max:
        return None
    return FrictionEstimate(J=J, tau=float(np.clip(tau, 0.0, tau_max)), sigma=max(sigma, 0.0), Fc=max(Fc, 0.0),
                            Fs=max(Fs, 0.0), offset=offset, Vs=Vs, delta=delta, J_alt=J_alt)


class Eq4Estimator:
    """The eq. 4 RLS on the ``(u, w)`` stream at ``Ts`` and the estimate it puts into use (the feedforward's)."""

    def __init__(self, model, *, Ts, lam=0.995, P0=1e4, warmup=300, ff_max=math.inf, tau_max=1.0):
        self.model, self.Ts, self.warmup, self.ff_max, self.tau_max = model, Ts, warmup, ff_max, tau_max
        self.rls = RecursiveLeastSquares(model.n_params, lam=lam, P0=P0)
        self.u_range = Range()
        self.w_range = Range(floor=model.Vs if model.stribeck else 0.0)
        self.past = None  # (u(k-1), w(k-1), w(k-2))
        self.n_rejected = self.n_implausible = 0
        self.estimate = None

    def sample(self, u: float, w: float) -> bool:
        """One sample; False if refused (only the counters change)."""
        ok_u, ok_w = self.u_range.ok(u), self.w_range.ok(w)
        phi = None
        if ok_u and ok_w and self.past is not None:
            phi = eq4_columns(u, *self.past, self.model)
            refused = not np.all(np.isfinite(phi)) or rls_try(self.rls, phi, w) is None
        else:
            refused = not (ok_u and ok_w)
        if refused:
            for gate, x, ok in ((self.u_range, u, ok_u), (self.w_range, w, ok_w)):
                if not ok:
                    gate.commit(x, False)
            self.n_rejected += 1
            return False
        self.u_range.commit(u, True)
        self.w_range.commit(w, True)
        self.past = (u, w, w if self.past is None else self.past[1])
        if phi is not None and self.rls.n_updates >= self.warmup:
            est = admissible(eq4_physical(self.rls.theta, self.model, self.Ts), tau_max=self.tau_max,
                             F_max=self.ff_max, Vs=self.model.Vs, delta=self.model.delta)
            if est is None:
                self.n_implausible += 1
            else:
                self.estimate = est
        return True


def eq4_path(u_prev, w_meas, w_ctrl, w_ref, model, *, Ts, dt, lam=0.995, P0=1e4, warmup=300, lag=True,
             ff_max=math.inf, tau_max=1.0, measured=True) -> dict:
    """The eq. 4 feedforward over a recorded run at the controller period ``dt``.

    Parameters
    ----------
    u_prev : array_like, shape (N,)
        Torque applied in the period before each one (N·m).
    w_meas, w_ctrl, w_ref : array_like, shape (N,)
        Raw measurement (the stream's sample), the controller's velocity and the reference (rad/s).
    model : RegressionModel
        The structure (``lag``, ``stribeck``, ``offset``, ``Vs``, ``delta``); only its settings are read.
    measured : bool
        Evaluate at ``w_ctrl`` with stick detection against ``w_ref`` (True) or at ``w_ref``.

    Returns
    -------
    dict
        ``u_ff`` (N,), ``sampled`` (N,) bool, ``theta`` (one row per sample, after it), the estimator
        (``est``: counters, ``rls``, ``estimate``) and the feedforward (``ff``).

    Notes
    -----
    In period ``k > 0`` with ``k % (Ts/dt) == 0`` the stream takes ``(u_prev[k], w_meas[k])`` before the
    feedforward's step, whose estimate is then the newest.
    """
    m = int(round(Ts / dt))
    est = Eq4Estimator(model, Ts=Ts, lam=lam, P0=P0, warmup=warmup, ff_max=ff_max, tau_max=tau_max)
    ff = Feedforward(dt=dt, lag=lag, ff_max=ff_max)
    n = len(w_ref)
    out, sampled, theta = np.empty(n), np.zeros(n, dtype=bool), []
    for k in range(n):
        if k > 0 and k % m == 0:
            est.sample(float(u_prev[k]), float(w_meas[k]))
            sampled[k] = True
            theta.append(est.rls.theta.copy())
            if est.estimate is not ff.estimate:
                ff.use(est.estimate)
        out[k] = ff.step(float(w_ctrl[k]), float(w_ref[k])) if measured else ff.step(float(w_ref[k]))
    return {"u_ff": out, "sampled": sampled, "theta": np.array(theta).reshape(len(theta), model.n_params),
            "est": est, "ff": ff}


# ------------------------------------------------------------------------------------------------------ peers
def _range_flags(x, gate: Range) -> np.ndarray:
    """Acceptance of each sample of ``x`` by ``gate`` (recorded as it goes)."""
    ok = np.empty(len(x), dtype=bool)
    for k, v in enumerate(np.asarray(x, dtype=float).tolist()):
        ok[k] = gate.ok(v)
        gate.commit(v, ok[k])
    return ok


def canudas_path(u, w_meas, w_ctrl, w_ref, *, Tc, Ts=0.01, lam=0.999, forgetting="directional", P0=1e4,
                 J_guess=1.0, w_dead=5e-3, warmup=300, ff_max=math.inf, ff_input="measured") -> dict:
    """Canudas de Wit's compensator over a recorded run (its :meth:`compensate` before its :meth:`observe` in
    each period).

    Parameters
    ----------
    u : array_like, shape (N,)
        Torque applied in each period (N·m), what :meth:`observe` got.
    w_meas : array_like, shape (N,)
        Velocity measured at the start of each period (rad/s), what :meth:`observe` got.
    w_ctrl, w_ref : array_like, shape (N,)
        The velocities :meth:`compensate` got (the map is evaluated at ``w_ctrl`` for ``ff_input`` measured,
        else at ``w_ref``).

    Returns
    -------
    dict
        ``c`` (N,) compensation, ``update_at`` sample index of each RLS update, ``theta`` (after each update),
        ``coef`` ``(Fc_pos, Fc_neg, sigma_pos, sigma_neg)`` at the end or None, ``n_rejected``, ``rls``.

    Notes
    -----
    The model ``w(k+1) - w(k) = b*u_bar - b*sigma_d*w(k) - b*Fc_d*sgn(w(k))``, ``b = Ts/J``, over intervals of
    ``m = Ts/Tc`` accepted samples (a rejected sample, torque or velocity out of range, spoils its interval);
    an interval is a row when both its end velocities lie beyond ``±w_dead`` with one sign. After ``warmup``
    updates the coefficients ``theta[3]/theta[0]``, ``theta[4]/theta[0]``, ``theta[1]/theta[0]``,
    ``theta[2]/theta[0]`` are the map's, from the next period on.
    """
    u, w = np.asarray(u, dtype=float), np.asarray(w_meas, dtype=float)
    n = u.shape[0]
    m = int(round(Ts / Tc))
    Ts = m * Tc
    gu, gw = Range(), Range(floor=w_dead)
    acc = np.empty(n, dtype=bool)
    for k in range(n):  # a sample passes both range gates; a failing gate alone records its rejection
        ok_u, ok_w = gu.ok(u[k]), gw.ok(w[k])
        acc[k] = ok_u and ok_w
        for gate, x, ok in ((gu, u[k], ok_u), (gw, w[k], ok_w)):
            if acc[k] or not ok:
                gate.commit(x, ok)
    idx = np.flatnonzero(acc)
    ends = idx[::m]  # interval boundaries: every m-th accepted sample
    n_int = ends.size - 1
    rejected_before = np.cumsum(~acc)
    clean = rejected_before[ends[1:]] == rejected_before[ends[:-1]]
    # the interval means, summed in time order: on a stream whose estimate runs away (the RLS covariance reaching
    # condition 1e21) even the last bit of another summation order shows in the compensation
    ubar = np.cumsum(u[idx[:n_int * m]].reshape(n_int, m), axis=1)[:, -1] / m if n_int > 0 else np.empty(0)
    w0, w1 = w[ends[:-1]], w[ends[1:]]
    pos, neg = (w0 > w_dead) & (w1 > w_dead), (w0 < -w_dead) & (w1 < -w_dead)
    rows = np.flatnonzero(clean & (pos | neg))
    Phi = np.column_stack([ubar, -w0 * pos, -w0 * neg, -1.0 * pos, 1.0 * neg])
    rls = RecursiveLeastSquares(5, lam=lam, P0=P0, forgetting=forgetting, theta0=[Ts / J_guess, 0, 0, 0, 0],
                                bounds=([1e-12, 0, 0, 0, 0], [math.inf] * 5))
    coef_from = np.full((n + 1, 4), np.nan)  # coefficients in use from each period on
    n_rejected = int(np.count_nonzero(~acc))
    update_at, theta = [], []
    for i in rows.tolist():
        if rls_try(rls, Phi[i], w1[i] - w0[i]) is None:
            n_rejected += 1
            continue
        update_at.append(int(ends[i + 1]))
        theta.append(rls.theta.copy())
        if rls.n_updates >= warmup:
            coef_from[ends[i + 1] + 1] = rls.theta[[3, 4, 1, 2]] / rls.theta[0]
    # forward-fill the coefficients in use
    have = ~np.isnan(coef_from[:, 0])
    last = np.maximum.accumulate(np.where(have, np.arange(n + 1), -1))
    coef = np.where((last >= 0)[:, None], coef_from[np.maximum(last, 0)], np.nan)[:n]
    x = np.asarray(w_ctrl if ff_input == "measured" else w_ref, dtype=float)
    with np.errstate(invalid="ignore", over="ignore"):
        c = np.where(x > 0.0, coef[:, 0] + coef[:, 2] * x, np.where(x < 0.0, -coef[:, 1] + coef[:, 3] * x, 0.0))
        c = np.where(np.isfinite(c), np.clip(c, -ff_max, ff_max), 0.0)
    c = np.where(np.isnan(coef[:, 0]), 0.0, c)
    final = None if np.isnan(coef_from[have][-1:, 0]).all() else tuple(coef_from[have][-1].tolist())
    return {"c": c, "update_at": np.array(update_at, dtype=int), "theta": np.array(theta).reshape(-1, 5),
            "coef": final, "n_rejected": n_rejected, "rls": rls}


def dob_path(w_ctrl, u, *, J_n, omega_q=500.0, Tc, order=2, d_max=math.inf) -> dict:
    """The disturbance observer over a recorded run (``compensate(w_ctrl[k])`` before ``observe(u[k])``).

    Returns
    -------
    dict
        ``d_hat`` (N,) and ``n_rejected``.

    Notes
    -----
    ``J*dw/dt = u - d`` with the torque held over each period: the mean disturbance over the last period is
    ``v(k) = u(k-1) - J_n*(w(k) - w(k-1))/Tc`` (last accepted torque, last accepted velocity), and
    ``d_hat = clip(Q[v], ±d_max)``, ``Q = (omega_q/(s + omega_q))**order`` in the package's discretisation
    (tests/lti_oracle.py), run over the sequence of ``v`` by :func:`scipy.signal.lfilter`. A rejected velocity
    (non-finite or out of range) holds the estimate; the first accepted one only starts the differences.
    """
    w = np.asarray(w_ctrl, dtype=float)
    u = np.asarray(u, dtype=float)
    n = w.shape[0]
    ok_w, ok_u = _range_flags(w, Range()), _range_flags(u, Range())
    # the torque of the previous period as the observer holds it: the last accepted one before k (0 at first)
    last_u = np.concatenate([[0.0], np.where(ok_u, u, np.nan)])[:n]
    held = np.maximum.accumulate(np.where(np.isfinite(last_u), np.arange(n), 0))
    u_before = last_u[held]
    kw = np.flatnonzero(ok_w)
    v = u_before[kw[1:]] - J_n * np.diff(w[kw]) / Tc
    d = np.clip(signal.lfilter(*power(lag(omega_q, Tc), order), v), -d_max, d_max)
    out = np.zeros(n)
    at = np.zeros(n, dtype=int)
    at[kw[1:]] = np.arange(1, v.size + 1)
    at = np.maximum.accumulate(at)
    out = np.concatenate([[0.0], d])[at]
    return {"d_hat": out, "n_rejected": int(np.count_nonzero(~ok_w) + np.count_nonzero(~ok_u))}
