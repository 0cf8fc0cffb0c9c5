"""Test oracles of the robust adaptive feedforward: the outlier gate, the sliding-regime estimator, the plausibility
tests and the estimate in use, and the adaptive-DOB composite, written from their documented equations.

* :class:`OutlierGate`: the innovation gate of :class:`adaptive_ff.compensation.gate.OutlierGate` (its Notes).
* :func:`sliding_path`: :class:`adaptive_ff.compensation.sliding_estimator.SlidingFrictionEstimator` over a whole
  record. After the sample-by-sample input gates, everything is a whole-signal computation on the accepted
  samples: the noise scale of the second differences, the near-zero indicator, and the regressors as transfer
  functions of the state-variable filter ``L = 1/(1 + T s)**3`` in the package's discretisation
  (``L``, ``L s = (L2 - L3)/T``, ``L s^2 = (L1 - 2 L2 + L3)/T^2`` from the module docstring, built from
  tests/lti_oracle.py and run by :func:`scipy.signal.sosfilt` in second-order sections); then the RLS over the
  rows that pass the sliding-regime gate, unconstrained (the class's Notes: a projection of its state onto the
  physical box diverges after one-sided motion); the box bounds only the reported estimate
  (:func:`reported_estimate`).
* :func:`robust_decisions`: the safety chain of
  :class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward` (warm-up, range checks,
  determinacy of ``Fc``, lag consistency by the delta method, the weighted lag in closed form
  ``sum(l**(n-k) x_k/sd_k**2)/sum(l**(n-k)/sd_k**2)``, its margin), and :class:`RobustOutput`, the output (the
  start map, the fade-in) on the fixed feedforward of tests/peers_oracle.py.

The RLS is the package's (checked against tests/rls_oracle.py by tests/adaptive_ff_layer/test_rls.py and tests/controllers_layer/test_properties.py).
Not part of the package.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import signal

from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.identification.rls import RecursiveLeastSquares
from lti_oracle import lag, power
from peers_oracle import Feedforward, Range, rls_try

__all__ = ["OutlierGate", "sliding_path", "reported_estimate", "robust_decisions", "RobustOutput", "SLIDING_NAMES"]

SLIDING_NAMES = ("J", "J_tau", "tau", "Fc", "Fs", "sigma", "offset")


class OutlierGate:
    """A finite sample ``x`` is an outlier if ``|x - last| > (max_step + n_sigma*scale)*(1 + n_held)`` (while
    fewer than ``max_consecutive`` were rejected in a row); ``scale`` is the running mean (rate ``alpha``) of the
    accepted changes within that bound; a non-finite sample is rejected and counted as held."""

    def __init__(self, *, max_step=math.inf, n_sigma=8.0, alpha=0.01, max_consecutive=20):
        self.max_step, self.n_sigma, self.alpha, self.max_consecutive = max_step, n_sigma, alpha, max_consecutive
        self.last = None
        self.scale = 0.0
        self.n_held = self.n_rejected = 0

    def check(self, x: float) -> bool:
        if not math.isfinite(x):
            self.n_held += 1
            self.n_rejected += 1
            return False
        if self.last is not None:
            jump = abs(x - self.last)
            within = jump <= (self.max_step + self.n_sigma * self.scale) * (1 + self.n_held)
            if not within and self.n_held < self.max_consecutive:
                self.n_held += 1
                self.n_rejected += 1
                return False
            if within:
                self.scale = (1.0 - self.alpha) * self.scale + self.alpha * jump
        self.last, self.n_held = x, 0
        return True


def _svf(T: float, dt: float) -> dict:
    """``(b, a)`` in powers of ``z^-1`` of ``L``, of its first and second backward differences ``(1 - z^-1)/dt``
    (the derivatives ``L s``, ``L s^2``) and of ``L`` half a period back, ``(1 + z^-1)/2`` (the regressand)."""
    b, a = lag(1.0 / T, dt)  # one stage, the input of this period applied at once
    b3, a3 = power((b, a), 3)
    a3 = np.concatenate((a3, [0.0, 0.0]))  # room for the difference's two extra numerator powers
    diff = np.array([1.0, -1.0]) / dt
    return {"L": (b3, a3[:-2]), "Ls": (np.polymul(b3, diff), a3[:-1]),
            "Ls2": (np.polymul(np.polymul(b3, diff), diff), a3), "Lhalf": (np.polymul(b3, [0.5, 0.5]), a3[:-1])}


def sliding_path(u, w, *, Vs, delta, Tc, Ts=0.01, T_filter=0.02, lam=0.995, forgetting="exponential", P0=1e4,
                 P_max=None, initial=None, J_guess=1.0, J_max=math.inf, tau_max=1.0, lag=True, offset=True,
                 w_band_min=None, dwell_max=0.01, gate=None) -> dict:
    """The sliding-regime estimator over a record of ``(u, w)`` (one ``observe`` per sample).

    Parameters
    ----------
    u, w : array_like, shape (N,)
        Torque of each period (N·m) and velocity measured at its start (rad/s).
    Vs, delta, Tc, Ts, T_filter, lam, forgetting, P0, P_max, initial, J_guess, J_max, tau_max, lag, offset,
    w_band_min, dwell_max
        As in :class:`SlidingFrictionEstimator`.
    gate : OutlierGate, optional
        The velocity gate (default: non-finite samples only).

    Returns
    -------
    dict
        ``names``; ``accepted`` (N,) bool; ``update_at`` (M,) sample index of each RLS update; ``theta``
        (M, p), ``P`` (M, p, p) and ``e2`` (M,) after each update; ``rls``; the counters ``n_samples``,
        ``n_rejected``, ``n_gated``; ``box``: the physical box (name -> (lower, upper)) of the reported
        estimate.
    """
    u, w = np.asarray(u, dtype=float), np.asarray(w, dtype=float)
    n = u.shape[0]
    names = tuple(x for x in SLIDING_NAMES if (lag or x not in ("J_tau", "tau")) and (offset or x != "offset"))
    gate = OutlierGate() if gate is None else gate
    gu, gw = Range(), Range(floor=Vs)
    acc = np.zeros(n, dtype=bool)
    for k in range(n):  # torque range, velocity range (finite velocities), the velocity gate; then record both
        if not gu.ok(u[k]):
            gu.commit(u[k], False)
        elif math.isfinite(w[k]) and not gw.ok(w[k]):
            gw.commit(w[k], False)
        elif gate.check(w[k]):
            gu.commit(u[k], True)
            gw.commit(w[k], True)
            acc[k] = True
    idx = np.flatnonzero(acc)
    ua, wa = u[idx], w[idx]
    # noise scale: running mean (rate 0.01) of |second difference| from the third accepted sample on; for white
    # noise E|w(k) - 2w(k-1) + w(k-2)| = sqrt(6)*sqrt(2/pi)*sigma_n
    d2 = np.zeros_like(wa)
    d2[2:] = np.abs(wa[2:] - 2.0 * wa[1:-1] + wa[:-2])
    noise = signal.lfilter([0.01], [1.0, -0.99], d2) / (math.sqrt(6.0) * math.sqrt(2.0 / math.pi))
    band = np.maximum(0.1 * Vs if w_band_min is None else w_band_min, 4.0 * noise)
    with np.errstate(over="ignore"):
        shape = np.exp(-((np.abs(wa) / Vs) ** delta))  # eq. 3's Stribeck shape
    sgn = np.sign(wa)
    svf = _svf(T_filter, Tc)
    sos = {key: signal.tf2sos(*ba) for key, ba in svf.items()}  # second-order sections: no triple pole in one
    L = lambda key, x: signal.sosfilt(sos[key], x)  # noqa: E731
    cols = [L("Ls", wa)]
    if lag:
        cols += [L("Ls2", wa), -L("Ls", ua)]
    cols += [L("L", sgn * (1.0 - shape)), L("L", sgn * shape), L("L", wa)]  # L[g], L[h], L[w] (eqs. 5, 6)
    if offset:
        cols.append(np.ones_like(wa))
    X, y = np.column_stack(cols), L("Lhalf", ua)
    dwell = L("L", (np.abs(wa) < band).astype(float))
    m = int(round(Ts / Tc))
    count = np.arange(1, idx.size + 1)  # accepted samples so far
    due = (count % m == 0) & (count >= math.ceil(8.0 * T_filter / Tc))  # after the filters' transient
    gated = due & (dwell > dwell_max) if dwell_max < 1.0 else np.zeros_like(due)
    # the physical box: the start is clipped to it, the RLS runs without it (it bounds the report only)
    J_max = float(J_max)
    lo = {"J": 1e-9, "J_tau": 0.0, "tau": 0.0, "Fc": 0.0, "Fs": 0.0, "sigma": 0.0, "offset": -math.inf}
    hi = {"J": J_max, "J_tau": J_max * tau_max, "tau": tau_max, "Fc": math.inf, "Fs": math.inf,
          "sigma": math.inf, "offset": math.inf}
    if initial is None:
        start = dict(J=J_guess, J_tau=0.0, tau=0.0, Fc=0.0, Fs=0.0, sigma=0.0, offset=0.0)
    else:
        tau0 = float(np.clip(initial.tau, 0.0, tau_max)) if lag else 0.0
        J0 = float(np.clip(initial.J, 1e-9, J_max))
        start = dict(J=J0, J_tau=J0 * tau0, tau=tau0, Fc=max(initial.Fc, 0.0), Fs=max(initial.Fs, 0.0),
                     sigma=max(initial.sigma, 0.0), offset=initial.offset)
    p = len(names)
    rls = RecursiveLeastSquares(p, lam=lam, P0=P0, forgetting=forgetting, P_max=p * P0 if P_max is None else P_max,
                                theta0=[start[x] for x in names])
    rate = 1.0 - float(np.min(lam)) if float(np.min(lam)) < 1.0 else 0.01
    e2 = 0.0
    at, th, Ps, E2 = [], [], [], []
    for j in np.flatnonzero(due & ~gated).tolist():
        Pb = rls.P.copy()  # before the update: the a-priori error's variance is e2 * (1 + phi' P phi)
        e = rls_try(rls, X[j], y[j])  # a non-finite row is refused (and counted) by the RLS
        if e is None:
            continue
        xj = np.asarray(X[j], dtype=float)
        e2 += rate * (e * e / (1.0 + max(float(xj @ Pb @ xj), 0.0)) - e2)
        at.append(int(idx[j]))
        th.append(rls.theta.copy())
        Ps.append(rls.P.copy())
        E2.append(e2)
    return {"names": names, "accepted": acc, "update_at": np.array(at, dtype=int),
            "theta": np.array(th).reshape(len(th), p), "P": np.array(Ps).reshape(len(Ps), p, p),
            "e2": np.array(E2), "rls": rls, "n_samples": int(idx.size), "n_rejected": int(n - idx.size),
            "n_gated": int(np.count_nonzero(gated)), "Vs": Vs, "delta": delta, "lag": lag, "Ts": m * Tc,
            "P_prior": rls.P_max / p, "box": {x: (lo[x], hi[x]) for x in names}}


def reported_estimate(path: dict, theta) -> FrictionEstimate:
    """The estimate the estimator reports for ``theta``: each parameter clipped to the physical box of ``path``
    (:func:`sliding_path`), ``J_alt`` from the clipped ``J_tau`` and ``tau``."""
    clipped = [min(max(float(v), path["box"][x][0]), path["box"][x][1]) for x, v in zip(path["names"], theta)]
    return _estimate(path["names"], clipped, path["Vs"], path["delta"])


def _estimate(names, theta, Vs, delta) -> FrictionEstimate:
    v = dict(zip(names, np.asarray(theta, dtype=float).tolist()))
    tau = v.get("tau", 0.0)
    return FrictionEstimate(J=v["J"], tau=tau, sigma=v["sigma"], Fc=v["Fc"], Fs=v["Fs"], offset=v.get("offset", 0.0),
                            Vs=Vs, delta=delta, J_alt=v["J_tau"] / tau if ("J_tau" in v and tau > 0.0) else math.nan)


def box_projection(P, theta, lo, hi) -> np.ndarray:
    """``argmin (x - theta)' P^-1 (x - theta)`` subject to ``lo <= x <= hi``: the active bounds from scipy's BVLS
    on the Cholesky factor of ``P^-1``, then the minimiser with those bounds held, in closed form (the conditional
    mean ``theta + P[:, W] P[W, W]^-1 (b_W - theta_W)``), so that the result is exact to rounding."""
    from scipy.optimize import lsq_linear

    theta = np.asarray(theta, dtype=float)
    if np.all((theta >= lo) & (theta <= hi)):
        return theta.copy()
    R = np.linalg.cholesky(np.linalg.inv(P)).T
    sol = lsq_linear(R, R @ theta, bounds=(lo, hi), method="bvls", tol=1e-15)
    W = np.flatnonzero(sol.active_mask != 0)
    b = np.where(sol.active_mask[W] < 0, lo[W], hi[W])
    x = theta + P[:, W] @ np.linalg.solve(P[np.ix_(W, W)], b - theta[W])
    x[W] = b
    return x


def robust_decisions(path: dict, *, dt, warmup=200, ff_max=math.inf, J_range=(0.0, math.inf), tau_max=1.0,
                     consistency=0.5, lag_margin=1.0, lag_margin_max=0.05, max_rel_stderr=0.05, lag_memory=10.0,
                     lag_zero=3.0, project=True, start=None) -> dict:
    """The estimates the robust feedforward puts into use, from the estimator's updates (:func:`sliding_path`).

    A lag estimate below 0 by at most ``max(lag_zero*sd, 2*dt)`` is lag 0, a lower one is refused; with
    ``project`` the tests and the feedforward take :func:`box_projection` of ``theta`` onto the plausible box
    (``J*tau >= 0``, ``0 <= tau <= tau_max``, ``0 <= Fc, Fs <= ff_max``, ``sigma >= 0``).

    Returns
    -------
    dict
        ``changes``: list of ``(k, estimate, handover)``, the estimate in use from period ``k + 1`` on
        (``handover`` True where the provisional start ends); ``n_implausible``, ``n_undetermined``,
        ``n_lag_held``; ``estimate`` at the end (None before switch-on).
    """
    names, lag_cols = path["names"], path["lag"]
    i_fc = names.index("Fc")
    forget = math.exp(-path["Ts"] / lag_memory) if lag_memory > 0.0 else 0.0
    taken = []  # (lag estimate, weight 1/sd**2) of every estimate whose lag entered the weighted mean
    in_use, provisional = None, start is not None
    counts = dict(n_implausible=0, n_undetermined=0, n_lag_held=0)
    changes = []
    for j, k in enumerate(path["update_at"].tolist()):
        if j + 1 < warmup:
            continue
        theta = np.array(path["theta"][j], dtype=float)
        cov = path["e2"][j] * path["P"][j]
        if lag_cols and theta[2] < 0.0 and lag_zero > 0.0:
            if theta[2] < -max(lag_zero * math.sqrt(max(cov[2, 2], 0.0)), 2.0 * dt):
                counts["n_implausible"] += 1
                continue
            if not project:
                theta[2] = 0.0
                theta[1] = max(theta[1], 0.0)
        if project:
            lo = np.array([{"J_tau": 0.0, "tau": 0.0 if lag_zero > 0.0 else -math.inf, "Fc": 0.0, "Fs": 0.0,
                            "sigma": 0.0}.get(x, -math.inf) for x in names])
            hi = np.array([{"tau": tau_max, "Fc": ff_max, "Fs": ff_max}.get(x, math.inf) for x in names])
            theta = box_projection(path["P"][j], theta, lo, hi)
        est = _estimate(names, theta, path["Vs"], path["delta"])
        vals = (est.J, est.tau, est.sigma, est.Fc, est.Fs)
        if not (all(math.isfinite(v) for v in vals) and J_range[0] < est.J < J_range[1] and 0.0 <= est.tau <= tau_max
                and est.sigma >= 0.0 and 0.0 <= est.Fc <= ff_max and 0.0 <= est.Fs <= ff_max):
            counts["n_implausible"] += 1
            continue
        # Fc determined: standard error within max_rel_stderr of the level, and the data took its P entry to 1 %
        # of the prior (docs/theory.md; inf switches the test off)
        if max_rel_stderr < math.inf and not (
                math.sqrt(max(cov[i_fc, i_fc], 0.0)) <= max_rel_stderr * max(est.Fc, est.Fs)
                and path["P"][j][i_fc, i_fc] <= 0.01 * path["P_prior"]):
            counts["n_undetermined"] += 1
            continue
        consistent = True
        if est.tau >= 2.0 * dt and math.isfinite(est.J_alt):
            gap = abs(est.J_alt - est.J) * est.tau  # |J*tau from its column - J*tau from the product|
            if gap > consistency * est.J * est.tau:
                grad = np.array([-est.tau, 1.0, -est.J])  # d(J_tau - J*tau)/d(J, J_tau, tau)
                consistent = lag_cols and gap <= 3.0 * math.sqrt(max(float(grad @ cov[:3, :3] @ grad), 0.0))
        handover = False
        if consistent:
            tau = est.tau
            if lag_cols:
                sd = math.sqrt(max(cov[2, 2], 0.0))
                if forget > 0.0 and sd > 0.0:
                    taken.append((tau, 1.0 / sd**2))
                    x, wt = np.array(taken).T
                    decay = forget ** np.arange(len(taken) - 1, -1, -1.0)
                    tau = float(np.sum(decay * wt * x) / np.sum(decay * wt))
                tau = min(tau + min(lag_margin * sd, lag_margin_max * tau), tau_max)
            in_use = replace(est, tau=tau)
            handover, provisional = provisional, False
        elif in_use is not None and not provisional:
            counts["n_lag_held"] += 1
            in_use = replace(est, tau=in_use.tau, J_alt=math.nan)
        else:
            counts["n_implausible"] += 1
            continue
        changes.append((k, in_use, handover))
    return dict(counts, changes=changes, estimate=in_use)


class RobustOutput:
    """The robust feedforward's output, one period per :meth:`step`, with the estimates of
    :func:`robust_decisions` coming into use as they were decided.

    Before the first estimate: 0, or the start map times its gain (at the reference when the start says so);
    after it the output fades in from 0 (from the start gain after a start) by ``dt/fade_in`` per period.
    """

    def __init__(self, decisions: dict, *, dt, lag=True, ff_max=math.inf, sign_width=0.0, stick_band=0.0,
                 stick_samples=10, fade_in=1.0, start=None, Vs=None, delta=None):
        self.ff = Feedforward(dt=dt, lag=lag, ff_max=ff_max, sign_width=sign_width, stick_band=stick_band,
                              stick_samples=stick_samples)
        self.fade = 1.0 if fade_in == 0.0 else dt / fade_in
        self.gain = 0.0
        self.pending = {k: (est, h) for k, est, h in decisions["changes"]}
        self.start = start
        self.provisional = start is not None
        if start is not None:
            e = start.estimate
            self.ff.use(replace(e, Vs=Vs if e.Vs is None else e.Vs, delta=delta if e.delta is None else e.delta))
        self.active = start is not None
        self.k = 0

    def step(self, w, w_stuck, w_ref, measured=True) -> float:
        """The output of period ``k`` (then the estimate decided in period ``k``, if any, comes into use)."""
        out = self._output(w, w_stuck, w_ref, measured)
        change = self.pending.get(self.k)
        if change is not None:
            est, handover = change
            self.ff.use(est)
            self.active = True
            if handover:
                self.provisional = False
                self.gain = self.start.gain
        self.k += 1
        return out

    def _output(self, w, w_stuck, w_ref, measured):
        if not self.active:
            return 0.0
        if self.provisional:
            if self.start.ff_input == "reference" or not measured:
                return self.ff.step(w_ref) * self.start.gain
            return self.ff.step(w, w_stuck) * self.start.gain
        out = self.ff.step(w, w_stuck) if measured else self.ff.step(w_ref)
        if self.gain < 1.0:
            self.gain = min(self.gain + self.fade, 1.0)
            out *= self.gain
        return out
