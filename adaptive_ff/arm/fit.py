r"""The whole-arm identification: rigid body and every joint's friction from one log, by weighted least squares.

The inverse dynamic model of the arm, per sample ``k`` and joint ``j``,

.. math::

    \tau_{kj} = Y_b(q_k, \dot q_k, \ddot q_k)_j\, \beta + F_{c,j}\, g_j + F_{s,j}\, h_j + \sigma_j \dot q_{kj}
        + o_j + e_{kj},

with ``Y_b`` the joint-torque regressor (Pinocchio) reduced to the base parameters ``beta``
(:meth:`adaptive_ff.arm.robot.ArmModel.base_parameters`; armatures included) and the Stribeck regressors of eqs.
5-6, ``g = sgn(w) (1 - s(w))``, ``h = sgn(w) s(w)``, ``s(w) = exp(-|w/V_s|^delta)``, is linear in ``beta`` and the
friction for given ``V_s, delta``; those are profiled per joint on a grid (coordinate descent over the joints,
two sweeps), the best grid point refined in ``V_s`` by a bounded scalar search. A joint keeps the Stribeck term
only where it lowers the weighted residual beyond the 95 % likelihood-ratio bound (else ``Fs = Fc``).

The rows come from the zero-phase filtered, decimated log (:func:`adaptive_ff.arm.arm_log.filtered_states`): the
torque passes the filter of the positions (Gautier's parallel filtering), so that the rigid body sees the same
filter on both sides. Samples where a joint moves slower than 2 % of its 99th-percentile speed, or lie within one
cutoff period of one of its velocity reversals, are left out of that joint's rows (the sign of the velocity is not
known there, and the filter spreads the friction's jump at a reversal over that period). Each joint's rows are
weighted by the inverse of its residual standard deviation from an unweighted first fit (IDIM-WLS; Gautier &
Poignet, IFAC SYSID 2001). Two choices of rows and friction columns (``rows``, :data:`ROWS`):

In both the friction columns pass the torque's filter (:func:`adaptive_ff.arm.arm_log.parallel_filter`): ``g``
and ``h`` are built at the log's rate from the velocity low-passed at :data:`FRICTION_VELOCITY_FACTOR` times the
cutoff (the measured velocity where the log has one, else the positions' derivative; that light filter keeps the
noise from scattering the sign near rest), then filtered and decimated as the torque is, since the filtered torque
holds the filtered friction, not the friction of the filtered velocity (they differ where the map is curved, the
Stribeck hump, crossed in tens of milliseconds). And a joint's friction is the map of its velocity only while it
slides: where it is at rest, the friction is whatever holds it (a simulated joint without a lag chatters about zero
velocity there), which no friction column gives, and the torque's filter carries that into the rows around it: 2 %
of a torque step one cutoff period from it, 0.5 % at :data:`REST_WINDOW` (1.5) periods.

``rows="moving"`` (the default): those rows, each of them the filter of the moving samples' equation alone
(:func:`_moving_share`): the samples where the lightly filtered velocity is slower than the 2 % speed (at rest)
are left out of the torque, the rigid-body block (the regressor of the filtered states at the log's rate) and the
friction columns (viscous and offset too) before the filter, so that the rows next to a stick keep the hump's
information without the holding torque (with it in, the wrists' ``Fs`` read low and ``Vs`` high on the simulated
arms: ``docs/your_arm.md``, How).

``rows="sliding"``: the viscous and offset columns are the filtered velocity and one, and the rows within 1.5
cutoff periods of every log sample where the lightly filtered velocity is slower than the 2 % speed or changes sign
are left out as well (at one period the rest left in those rows drew the
Stribeck profile to a wrong shape: ``docs/your_arm.md``, "Intervals"). What either choice
measures (coverage over simulated arms, the Stäubli TX40, a lagged arm) and the alternatives measured are on
``docs/your_arm.md`` ("Rows", "Intervals", "Not yet").

Intervals: the circular block bootstrap of the samples (each sample's rows of all joints, regressor and torque,
resampled together in blocks of consecutive samples, the block by the Politis-White rule on the residuals,
:mod:`adaptive_ff.identification.covariance`; a resampling of cases, so that the model's error near reversals and at low
speed, which depends on the motion, counts as well as the noise), refitted at the profiled ``V_s, delta``; a parameter's
interval is its estimate ``± t`` times the bootstrap standard error (Student-t quantile of the number of refits). A
joint's intervals of ``J`` and the friction are widened to the profile likelihood's over the Stribeck shape: they
cover the estimates at every ``(V_s, delta)`` of the grid the profile accepts and, where accepted, of the model
without the Stribeck term (``Fs = Fc``), whether the joint keeps its Stribeck term or not, each with the bootstrap's
half-width times ``sqrt(1 - (rss - best) / allowance)`` (:func:`adaptive_ff.arm.intervals.band_share`: the whole
half-width at the best shape, none at the bound); accepted are the grid points whose profiled weighted residual sum
of squares ``rss`` is within the 95 % likelihood-ratio bound ``best + allowance``, the residuals' correlation counted
by the ratio of the bootstrap variance to the white-noise least-squares variance (the largest over the joints' ``Fc,
Fs, sigma``; :func:`_variance_ratio`; why: ``docs/your_arm.md``, "Intervals"). ``V_s``'s interval runs between the
profile's crossings of that bound, located between the grid's values by bisection
(:func:`adaptive_ff.arm.intervals.crossings`), and ``Fs``'s covers its estimates there; ``delta``'s holds the
accepted grid values (also where the term is dropped and ``V_s`` itself is NaN).

With ``rows="moving"`` every interval of ``J``, ``Fc``, ``sigma``, the offset and the base parameters then carries
the model error that a bootstrap of one rows choice cannot see (a bias common to all its refits, such as the rigid
body's share at the samples at rest, which the regressor of the filtered states approximates): its half-width on
either side is combined in quadrature with the distance of the estimate from the ``rows="sliding"`` fit's (a point
fit of the same log, without bootstrap), ``sqrt(h^2 + (x_moving - x_sliding)^2)``. Not those of ``Fs`` and ``Vs``:
the sliding rows leave out the slow samples that determine the Stribeck term, and their ``Fs`` and ``Vs`` measure
what those rows lack rather than an error of the default's. A joint that keeps the Stribeck term
and is at rest over more than :data:`REST_WARN` of the log carries a warning that its ``Fs`` and ``Vs`` may lie
outside their intervals (code ``method``: a note on the method, which ``design``, ``compare`` and ``export-c
--from`` do not refuse).

Then each joint's friction lag ``tau`` (eq. 1) by the package's output-error fit on its rigid-body-removed record,
where the log determines it, and each joint's velocity noise (:mod:`adaptive_ff.arm.lag`).

Lag
---
A lagged friction is not the static map of the columns above: where it changes with speed, its lag acts as an
inertia term, and the fit reads ``J`` low (``docs/your_arm.md``, How, The lags in the whole-arm fit). So the
whole-arm fit runs again with each reported lag in its joint's friction columns: each map ``g, h, w`` through
``1/(tau s + 1)`` at the log's rate, before the torque's filter (:func:`_lagger`), everything after (profile,
bootstrap, row sensitivity) as before; its results are reported, the lags those of the first pass (:func:`_lags`).
A joint whose residual the lagged columns raise beyond the 95 % likelihood-ratio bound (:func:`_lag_raises_residual`)
keeps its columns without the lag (the reported lag then models more than a delay of the friction map), and the fit runs
once more without it (:func:`_lagged_stage`).
The intervals of ``J``, the friction and the base parameters then carry the lags' uncertainty, which the bootstrap
at the estimated lags does not see: each half-width combined in quadrature, as the row sensitivity is, with the larger
distance of the estimate from the two point fits with every joint's columns at the lower and the upper end of its lag
range (:func:`adaptive_ff.arm.intervals.widen_lag`, :func:`adaptive_ff.arm.intervals.lag_ranges`): a lag in the columns
its interval; a null lag none up to the reporting floor or its fit's upper end, whichever is longer, since the log does
not tell such a lag from none, while it still acts as an inertia term; that end capped where it
raises the joint's residual beyond the bound of :func:`_lag_raises_residual`: halved toward the floor until the residual
accepts it, then the largest accepted end up to the last rejected one located by bisection (:func:`_capped_null_ranges`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from threadpoolctl import threadpool_limits

from plant.errors import ParameterError, SignalError
from plant.stribeck_map import static_friction, stribeck_shape

from adaptive_ff.arm.arm_log import DEFAULT_CUTOFF, ArmLog, filtered_states, parallel_filter
from adaptive_ff.arm.intervals import (accepted_shapes, lag_ranges, lag_shapes, lr_allowance, profile_interval,
                                       widen, widen_lag)
from adaptive_ff.arm.lag import (LAG_CUTOFF_FACTOR, JointLag, LagOptions, LagWorld, joint_lags, lag_floor,
                                 lag_records, refined_joints, stick_speeds, stop_bands, velocity_noise)
from adaptive_ff.arm.result import ArmIdentification, ArmJoint
from adaptive_ff.arm.robot import ArmModel
from adaptive_ff.arm.rows import DEFAULT_ROWS, REST_WINDOW, ROWS

__all__ = ["identify_arm", "DELTA_GRID", "N_VS", "FRICTION_VELOCITY_FACTOR", "ROWS", "DEFAULT_ROWS", "REST_WINDOW",
           "REST_WARN", "NULL_CAP_BISECTIONS"]

#: Stribeck shape factors of the profile grid.
DELTA_GRID = (0.5, 1.0, 2.0)
#: Stribeck velocities per joint in the profile grid (geometric, from the slowest kept speed to a third of the
#: median speed).
N_VS = 8
#: Cutoff of the velocity the friction columns are built from, before the torque's filter, as a multiple of the
#: identification's cutoff (at most 0.8 times the log's Nyquist frequency); also the velocity that marks rest.
FRICTION_VELOCITY_FACTOR = 5.0
#: Condition number of the column-scaled weighted regressor above which the result carries a conditioning warning.
COND_WARN = 1e3
#: Bisections that locate a null lag's capped upper end between the last end its residual accepts and the first it
#: rejects (:func:`_capped_null_ranges`): the cap then lies within 2**-4 of that bracket below the largest accepted end.
NULL_CAP_BISECTIONS = 4
#: Share of the log at rest (the velocity low-passed at FRICTION_VELOCITY_FACTOR times the cutoff slower than the
#: joint's slowest kept speed) above which a joint that keeps its Stribeck term gets a warning that its ``Fs`` and
#: ``Vs`` intervals may miss (``rows="moving"``): the misses of those intervals over simulated arms are joints at rest
#: over more of their logs than shoulders and elbows are (the measurements: ``docs/your_arm.md``, How, Intervals).
REST_WARN = 0.15
#: Friction columns per joint: Fc (g), Fs (h), sigma (w), offset (1).
_FRICTION = ("Fc", "Fs", "sigma", "offset")


class _FrictionColumns:
    """Each joint's friction columns ``(g, h, w, 1)`` (m, 4) at ``(Vs, delta)``: ``g`` and ``h`` built at the log's
    rate from its velocity low-passed at :data:`FRICTION_VELOCITY_FACTOR` times the cutoff (``w_fast``, (n, N)) and
    put through the torque's filter and decimation (``pf``); ``dq`` (m, N) the filtered velocity. With ``moving``
    ((n, N) bool, ``rows="moving"``) every column is the filtered product of ``moving`` and its map, ``w`` and ``1``
    too: the friction of the moving samples only (:func:`_moving_share`). With ``lag`` (a callable, :func:`_lagger`)
    each joint's map ``g, h, w`` goes through its friction lag (eq. 1) at the log's rate first."""

    def __init__(self, pf, w_fast, dq, moving=None, lag=None):
        self.pf, self.w, self.moving, self.lag = pf, w_fast, moving, lag
        sgn, lin = (np.sign(w_fast), w_fast) if lag is None else (lag(np.sign(w_fast)), lag(w_fast))
        if moving is None:  # the filtered velocity is the velocity column's filter, where no lag acts on it
            self.sgn, self.lin, self.one = pf(sgn), dq if lag is None else pf(lin), np.ones(dq.shape)
        else:
            mf = moving.astype(float)
            self.sgn, self.lin, self.one = pf(mf * sgn), pf(mf * lin), pf(mf)

    def __call__(self, j: int, Vs: float, delta: float) -> np.ndarray:
        m = self.sgn.shape[0]
        h = np.zeros(m)
        if np.isfinite(Vs):
            w = self.w[:, j]
            x = np.sign(w) * stribeck_shape(w, Vs, delta)
            if self.lag is not None:
                x = self.lag(x[:, None], j)[:, 0]
            h = self.pf(x if self.moving is None else x * self.moving[:, j])
        return np.column_stack([self.sgn[:, j] - h, h, self.lin[:, j], self.one[:, j]])


def _lagger(tau, Ts: float):
    """``lag(x, j=None)``: the columns of ``x`` (n, k) through each joint's first-order lag ``1/(tau_j s + 1)``
    (eq. 1; ``tau`` (N,) s, 0 or NaN: none) at the sample time ``Ts`` (s), exact for an input linear between the
    samples (first-order hold: ``y[k+1] = a y[k] + (c - a) x[k] + (1 - c) x[k+1]``, ``a = exp(-Ts/tau)``, ``c = (1 -
    a) tau / Ts``; Franklin, Powell and Workman, Digital Control of Dynamic Systems, the triangle hold), each column
    from its steady state at its first sample; ``j`` given: every column through joint ``j``'s lag."""
    from scipy.signal import lfilter, lfilter_zi

    tau = np.nan_to_num(np.asarray(tau, dtype=float), nan=0.0)

    def one(x, t):
        if not t > 0.0:
            return x
        a = float(np.exp(-Ts / t))
        c = (1.0 - a) * t / Ts
        b, d = [1.0 - c, c - a], [1.0, -a]
        return lfilter(b, d, x, axis=0, zi=lfilter_zi(b, d)[:, None] * x[:1])[0]

    def lag(x, j=None):
        if j is not None:
            return one(x, tau[j])
        return np.column_stack([one(x[:, [k]], tau[k])[:, 0] for k in range(x.shape[1])])

    return lag


class _Problem:
    """The stacked rows of one log: the rigid-body block, the velocities, the kept rows, the weights."""

    def __init__(self, Yb, dq, tau, keep, columns):
        self.m, self.n, self.r = Yb.shape
        self.Yb, self.dq, self.tau, self.keep = Yb, dq, tau, keep
        self.columns = columns
        self.w = np.ones(self.n)
        self._cache = (None, {})  # the weights the products below were made with, and the products

    def _joint_rows(self, j: int, Vs_j, delta_j) -> tuple:
        """Joint ``j``'s kept, weighted rows: rigid-body block ``Y`` (m_j, r), friction columns ``F`` (m_j, 4),
        torque ``y`` (m_j,), and their products ``(Y^T F, F^T F, F^T y)``, kept per ``(j, Vs_j, delta_j)``: the
        profile changes one joint's ``(Vs, delta)`` at a time."""
        w_seen, store = self._cache
        if w_seen is None or not np.array_equal(w_seen, self.w):
            store = {}
            self._cache = (self.w.copy(), store)
        if j not in store:
            k = self.keep.reshape(self.m, self.n)[:, j]
            Y, y = self.Yb[k, j, :] * self.w[j], self.tau[k, j] * self.w[j]
            store[j] = (k, Y, y, Y.T @ Y, Y.T @ y)
        key = (j, float(Vs_j), float(delta_j)) if np.isfinite(Vs_j) else (j, None, None)  # NaN: no Stribeck term
        if key not in store:
            k, Y, y = store[j][:3]
            F = self.columns(j, Vs_j, delta_j)[k] * self.w[j]
            store[key] = (F, Y.T @ F, F.T @ F, F.T @ y)
        return store[j] + store[key]

    def fit(self, Vs, delta):
        """``(x, weighted RSS)`` of the weighted fit at ``Vs, delta``: the normal equations of :meth:`design`'s kept,
        weighted rows assembled from the joints' blocks, solved for unit-norm columns (:func:`_scaled_solve`)."""
        r, p = self.r, self.r + 4 * self.n
        G, b = np.zeros((p, p)), np.zeros(p)
        rows = [self._joint_rows(j, Vs[j], delta[j]) for j in range(self.n)]
        for j, (_, _, _, YY, Yy, _, YF, FF, Fy) in enumerate(rows):
            c = slice(r + 4 * j, r + 4 * j + 4)
            G[:r, :r] += YY
            b[:r] += Yy
            G[:r, c], G[c, :r], G[c, c], b[c] = YF, YF.T, FF, Fy
        x = _scaled_solve(G, b)
        rss = 0.0
        for j, (_, Y, y, _, _, F, _, _, _) in enumerate(rows):
            e = y - Y @ x[:r] - F @ x[r + 4 * j: r + 4 * j + 4]
            rss += float(e @ e)
        return x, rss

    def design(self, Vs, delta) -> np.ndarray:
        """Rows (m*N, r + 4N): the rigid-body block and each joint's friction columns in its own rows."""
        A = np.zeros((self.m, self.n, self.r + 4 * self.n))
        A[:, :, : self.r] = self.Yb
        for j in range(self.n):
            A[:, j, self.r + 4 * j: self.r + 4 * j + 4] = self.columns(j, Vs[j], delta[j])
        return A.reshape(self.m * self.n, -1)

    def residuals(self, x, A) -> np.ndarray:
        """The unweighted residuals ``tau - A x`` (m, N), N·m, of the parameters ``x`` (p,) on the rows ``A`` (m*N, p)
        of :meth:`design`."""
        return self.tau - (A @ x).reshape(self.m, self.n)

    def solve(self, Vs, delta):
        """``(x, weighted RSS, A)`` of the weighted fit at ``Vs, delta`` (:meth:`fit`, and :meth:`design`)."""
        x, rss = self.fit(Vs, delta)
        return x, rss, self.design(Vs, delta)


def _scaled_solve(G, b) -> np.ndarray:
    """Least squares from its normal equations ``G x = b`` (``G = A^T A``, ``b = A^T y``) solved for the unit-norm
    columns of ``A`` (norms ``sqrt(diag G)``): a small p x p solve; a zero column gets 0. The products that make
    ``G`` run on one BLAS thread (:func:`identify_arm` holds the BLAS to one: a threaded call costs a hundred times
    more where other processes hold the cores)."""
    norm = np.sqrt(np.maximum(np.diag(G), 0.0))
    on = norm > 0
    Gs = G[np.ix_(on, on)] / np.outer(norm[on], norm[on])
    x = np.zeros(G.shape[0])
    try:
        x[on] = np.linalg.solve(Gs, b[on] / norm[on]) / norm[on]
    except np.linalg.LinAlgError:
        x[on] = np.linalg.lstsq(Gs, b[on] / norm[on], rcond=None)[0] / norm[on]
    return x


def _near_reversal(t, dq, window: float) -> np.ndarray:
    """(m, N) True within ``window`` seconds of a sign change of the joint's velocity: the low-pass spreads the
    friction's jump at a reversal over about one period of its cutoff, where no row of a static friction map
    holds."""
    out = np.zeros(dq.shape, dtype=bool)
    for j in range(dq.shape[1]):
        flips = t[1:][np.diff(np.sign(dq[:, j])) != 0]
        if flips.size:
            idx = np.searchsorted(flips, t)
            lo = np.abs(t - flips[np.clip(idx - 1, 0, flips.size - 1)])
            hi = np.abs(flips[np.clip(idx, 0, flips.size - 1)] - t)
            out[:, j] = np.minimum(lo, hi) < window
    return out


def _fast_velocity(log: ArmLog, cutoff: float) -> np.ndarray:
    """The log's velocity (n, N) at its own rate, low-passed (zero phase) at :data:`FRICTION_VELOCITY_FACTOR` times
    ``cutoff`` (at most 0.8 times the Nyquist frequency): the measured velocity where the log has one, else the
    positions' derivative."""
    from scipy.signal import butter, filtfilt

    Ts = float(np.median(np.diff(log.t)))
    b, a = butter(4, min(FRICTION_VELOCITY_FACTOR * cutoff * 2.0 * Ts, 0.8))
    if log.dq is not None:
        return filtfilt(b, a, log.dq, axis=0)
    return np.gradient(filtfilt(b, a, log.q, axis=0), Ts, axis=0)


def _rows_and_columns(log: ArmLog, cutoff: float, filtered, vmin, rows: str, tau=None) -> tuple:
    """Each joint's rows ``keep_j`` (m, N) and its friction columns (:class:`_FrictionColumns`, with the moving
    samples' mask ``|w_fast| >= vmin`` for ``rows="moving"``) for ``rows`` (:data:`ROWS`); ``filtered`` the
    ``(t, dq)`` of the filtered states and the log's fast velocity ``w_fast`` (:func:`_fast_velocity`); ``tau`` None
    or each joint's friction lag (N,) s (NaN: none), through which its columns go (:func:`_lagger`)."""
    t, dq, w_fast = filtered
    keep_j = (np.abs(dq) >= np.maximum(vmin, 1e-9)) & ~_near_reversal(t, dq, 1.0 / cutoff)
    pf = parallel_filter(log, cutoff)
    Ts = float(np.median(np.diff(log.t)))
    lag = None if tau is None else _lagger(tau, Ts)
    if rows == "moving":
        return keep_j, _FrictionColumns(pf, w_fast, dq, moving=np.abs(w_fast) >= np.maximum(vmin, 1e-9), lag=lag)
    window = int(round(REST_WINDOW / (cutoff * Ts)))
    return keep_j & ~_near_rest(pf, w_fast, np.maximum(vmin, 1e-9), window), _FrictionColumns(pf, w_fast, dq,
                                                                                                lag=lag)


def _moving_share(log: ArmLog, arm: ArmModel, cutoff: float, states, vmin, rb) -> tuple:
    """``states`` ``(t, dq, Yb, tau, w_fast)`` (:func:`identify_arm`'s) with each joint's torque and rigid-body rows
    holding the share of its moving samples only: ``tau_j - pf(stuck_j tau_j)`` and ``Yb_j - pf(stuck_j Yb_j)``,
    ``pf`` the torque's filter and decimation (:func:`adaptive_ff.arm.arm_log.parallel_filter`), ``stuck_j`` the
    log's samples where the joint's ``w_fast`` is slower than its ``vmin`` (N,) (at rest), the regressor there from
    the filtered states at the log's rate. ``rb`` is ``(independent, theta)``: the base parameters' columns of the
    regressor, and None or, with ``rigid_body="urdf"`` (``tau`` already less ``Y theta``, ``Yb`` empty), the URDF's
    inertias ``theta``, then the torque's share is ``pf(stuck_j (tau_j - (Y theta)_j))``.

    Why: the filtered torque of a row is linear in the log's samples, ``sum_i k_i tau_i``; at a sample where the
    joint is at rest its friction is whatever holds it, which no friction column gives (their map is 0 at rest), so
    that the rows next to a stick carry ``sum_stuck k_i f_hold_i`` unexplained. The stuck samples' share left out of
    the torque, the rigid body and (:class:`_FrictionColumns` with ``moving``) the friction columns alike, each row
    is the filter of the moving samples' own equation, which holds exactly."""
    t, dq, Yb, tau, w_fast = states
    independent, theta = rb
    pf = parallel_filter(log, cutoff)
    stuck = np.abs(w_fast) < np.maximum(vmin, 1e-9)
    n, r = log.t.shape[0], Yb.shape[2]
    _, q_n, dq_n, ddq_n, _ = filtered_states(log, cutoff, decimate=False)
    S = np.zeros((n, arm.n, r))
    U = np.where(stuck, log.tau, 0.0)
    at_rest = np.flatnonzero(stuck.any(axis=1))
    for idx in np.array_split(at_rest, max(1, at_rest.size // 5000)):  # the regressor in slices: memory
        Y = arm.regressor(q_n[idx], dq_n[idx], ddq_n[idx])
        if theta is not None:
            U[idx] -= np.where(stuck[idx], Y @ theta, 0.0)
        else:
            S[idx] = Y[:, :, independent] * stuck[idx][:, :, None]
    Yb_m = Yb - pf(S.reshape(n, -1)).reshape(Yb.shape) if r else Yb
    return t, dq, Yb_m, tau - pf(U), w_fast


def _near_rest(pf, w_fast, vmin, window: int) -> np.ndarray:
    """(m, N) True at the filtered rows (``pf``'s) within ``window`` log samples of a sample where the joint's
    ``w_fast`` is slower than ``vmin`` (N,) or changes sign: where the joint sticks or reverses, the friction is not
    the map of the measured velocity, and the torque's filter carries it that far."""
    slow = np.abs(w_fast) < vmin
    slow[1:] |= np.diff(np.sign(w_fast), axis=0) != 0
    ker = np.ones(2 * window + 1)
    out = np.column_stack([np.convolve(slow[:, j].astype(float), ker, mode="same") > 0.5
                           for j in range(w_fast.shape[1])])
    return out[pf.keep]


def _grids(dq, keep_j, vmin):
    """Per joint, the Stribeck velocity grid (N_VS values)."""
    out = []
    for j in range(dq.shape[1]):
        speed = np.abs(dq[keep_j[:, j], j])
        hi = max(np.median(speed) / 3.0, 2.0 * vmin[j])
        out.append(np.geomspace(vmin[j], hi, N_VS))
    return out


def _profile(prob: _Problem, grids, bound: float, progress=False):
    """Coordinate descent over the joints' ``(Vs, delta)`` grids (two sweeps); ``(Vs, delta, table)`` with
    ``table[j]`` the ``(Vs, delta, weighted RSS, estimate)`` of joint ``j``'s last sweep: the grid, then the grid's
    best refined in ``Vs`` (``table[j][-2]``), then the model without its Stribeck term (``Vs, delta`` NaN). A joint
    keeps no Stribeck term (``Vs`` NaN: ``Fs = Fc``) unless its best grid
    point lowers the weighted RSS by more than ``bound``."""
    from tqdm.auto import tqdm

    Vs = np.full(prob.n, np.nan)
    delta = np.ones(prob.n)
    table = [[] for _ in range(prob.n)]
    bar = tqdm(total=2 * prob.n, desc="arm Stribeck profile", unit="joint", leave=False,
               disable=(None if progress is None else not progress))
    for _ in range(2):
        for j in range(prob.n):
            Vs_off = Vs.copy()
            Vs_off[j] = np.nan
            x_off, rss_off = prob.fit(Vs_off, delta)
            rows = []
            for d in DELTA_GRID:
                for v in grids[j]:
                    Vs_try, d_try = Vs.copy(), delta.copy()
                    Vs_try[j], d_try[j] = v, d
                    x_try, rss_try = prob.fit(Vs_try, d_try)
                    rows.append((v, d, rss_try, x_try))
            best = _refine(prob, Vs, delta, j, min(rows, key=lambda x: x[2]), grids[j])
            rows += [best, (np.nan, np.nan, rss_off, x_off)]  # the last: no Stribeck term (Fs = Fc)
            on = rss_off - best[2] > bound
            Vs[j], delta[j] = (best[0], best[1]) if on else (np.nan, 1.0)
            table[j] = rows
            bar.update()
    bar.close()
    return Vs, delta, table


def _refine(prob: _Problem, Vs, delta, j: int, best, grid) -> tuple:
    """The grid's best ``(Vs, delta, rss)`` of joint ``j`` refined in ``log Vs`` between its grid neighbours (bounded
    Brent search, :func:`scipy.optimize.minimize_scalar`), ``delta`` kept."""
    from scipy.optimize import minimize_scalar

    k = int(np.argmin(np.abs(grid - best[0])))
    lo, hi = np.log(grid[max(k - 1, 0)]), np.log(grid[min(k + 1, grid.shape[0] - 1)])
    Vs_try, d_try = Vs.copy(), delta.copy()
    d_try[j] = best[1]

    def cost(lv):
        Vs_try[j] = np.exp(lv)
        return prob.fit(Vs_try, d_try)[1]

    r = minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": 0.01, "maxiter": 20})
    if r.fun >= best[2]:
        return best
    Vs_try[j] = np.exp(r.x)
    x, rss = prob.fit(Vs_try, d_try)
    return float(np.exp(r.x)), best[1], rss, x


def _bootstrap(prob: _Problem, A, x, n_boot: int, seed: int, progress=False):
    """The circular block bootstrap of the samples (rows of the regressor and torques of all joints resampled
    together, in blocks of consecutive samples) refitted at the profiled ``Vs, delta``: BootstrapResult over ``x``,
    and the residuals (m, N)."""
    from adaptive_ff.identification.covariance import (BootstrapResult, circular_block_resample,
                                                       politis_white_block)

    sw = np.tile(prob.w, prob.m)
    keep2 = prob.keep.reshape(prob.m, prob.n)
    resid = prob.residuals(x, A)
    block = max(politis_white_block(resid[keep2[:, j], j]) for j in range(prob.n))
    Aw = (A * sw[:, None])[prob.keep]  # the kept rows; a resample counts each as often as its sample is drawn
    yw = (prob.tau.reshape(-1) * sw)[prob.keep]
    sample = np.repeat(np.arange(prob.m), prob.n)[prob.keep]
    rng = np.random.default_rng(seed)
    from tqdm.auto import tqdm

    reps = []
    for _ in tqdm(range(n_boot), desc="arm bootstrap", unit="refit", leave=False,
                  disable=(None if progress is None else not progress)):
        idx = circular_block_resample(np.arange(prob.m), prob.m, block=block, rng=rng).astype(int)
        c = np.bincount(idx, minlength=prob.m)[sample].astype(float)
        cA = Aw * c[:, None]
        reps.append(_scaled_solve(Aw.T @ cA, cA.T @ yw))
    reps = np.array(reps)
    d = reps - x
    return BootstrapResult(stderr=np.sqrt(np.mean(d**2, axis=0)), bias=np.mean(d, axis=0), replicates=reps,
                           n=n_boot, block=block), resid


def _variance_ratio(prob: _Problem, A, rss: float, boot) -> float:
    """The largest ratio over the joints' ``Fc, Fs, sigma`` of the bootstrap variance to the least-squares variance for
    white residuals, ``s^2 (A^T A)^{-1}`` (weighted rows), at least 1: how much the residuals' correlation inflates the
    fit's variance, by which the likelihood-ratio bound of :func:`adaptive_ff.arm.intervals.profile_interval` is scaled
    (a zero column, of a dropped Stribeck term, has no ratio)."""
    Aw = A[prob.keep] * np.tile(prob.w, prob.m)[prob.keep][:, None]
    G = Aw.T @ Aw
    on = np.diag(G) > 0
    var = np.full(G.shape[0], np.nan)
    var[on] = np.diag(np.linalg.pinv(G[np.ix_(on, on)])) * rss / max(Aw.shape[0] - int(on.sum()), 1)
    kappa = boot.stderr ** 2 / np.where(var > 0, var, np.nan)
    friction = np.concatenate([kappa[prob.r + 4 * j: prob.r + 4 * j + 3] for j in range(prob.n)])
    return max(1.0, float(np.nanmax(friction))) if np.any(np.isfinite(friction)) else 1.0


def _shape_fit(prob: _Problem, Vs, delta):
    """``fit(j, Vs_j, delta_j) -> (estimate, weighted RSS)``: the weighted fit with joint ``j`` at ``(Vs_j, delta_j)``
    and the others at the final ``Vs, delta`` (N,) (:meth:`_Problem.fit`), for
    :func:`adaptive_ff.arm.intervals.crossings`."""

    def fit(j: int, Vs_j: float, delta_j: float):
        Vs_try, d_try = np.array(Vs, dtype=float), np.array(delta, dtype=float)
        Vs_try[j], d_try[j] = Vs_j, delta_j
        return prob.fit(Vs_try, d_try)

    return fit


def _inertia_rows(arm: ArmModel, base, q_mean) -> np.ndarray:
    """Rows ``a_j`` (N, r) with ``a_j @ beta = M_jj`` at ``q_mean`` (rigid body and armature)."""
    n = arm.n
    Y0 = arm.regressor(q_mean[None, :], np.zeros((1, n)), np.zeros((1, n)))[0]
    rows = np.empty((n, base.independent.shape[0]))
    for j in range(n):
        e = np.zeros((1, n))
        e[0, j] = 1.0
        Yj = arm.regressor(q_mean[None, :], np.zeros((1, n)), e)[0] - Y0
        rows[j] = Yj[j, base.independent]
    return rows


def _check(log: ArmLog, arm: ArmModel, n_bootstrap, rigid_body: str) -> None:
    if log.n_joints != arm.n:
        raise SignalError(f"{log.source}: {log.n_joints} joints in the log, {arm.n} in {arm.source} "
                          f"({', '.join(arm.names)})")
    if rigid_body not in ("fit", "urdf"):
        raise ParameterError(f"rigid_body must be 'fit' or 'urdf', got {rigid_body!r}")
    if isinstance(n_bootstrap, bool) or not isinstance(n_bootstrap, (int, np.integer)) or n_bootstrap < 2:
        raise ParameterError(f"n_bootstrap must be an integer >= 2, got {n_bootstrap!r}")
    arm.check_positions(log.q, log.source)


def _joint_warnings(arm, j, data, Vs, rel, lag) -> list:
    """What the log does not determine for joint ``j``: IdentificationWarning objects (the codes of
    :mod:`adaptive_ff.identification.plausibility`, so that ``design --from`` reads them as it reads identify's);
    ``data`` is ``(q, dq, keep_j, rest)``, ``rest`` (N,) each joint's share of the log at rest, or None
    (``rows="sliding"``: no rest warning)."""
    from adaptive_ff.identification.plausibility import IdentificationWarning as W

    q, dq, keep_j, rest = data
    name, out = arm.names[j], []
    span = float(np.ptp(q[:, j]))
    speed = float(np.percentile(np.abs(dq[:, j]), 99))
    if span < 0.05 or speed < 0.05:
        out.append(W("identifiability", "all", f"joint {name!r} barely moves (range {span:.3g} rad, "
                     f"99th-percentile speed {speed:.3g} rad/s): its friction is not determined by this log"))
    if not np.isfinite(Vs):
        out.append(W("model_form", "Fs", f"no Stribeck term for joint {name!r} (Fs = Fc, Vs and delta null): it "
                     "does not lower the residual beyond the 95 % likelihood-ratio bound; slow constant-speed "
                     "segments in the log determine it"))
    elif np.mean(np.abs(dq[keep_j[:, j], j]) < 3.0 * Vs) < 0.02:
        out.append(W("identifiability", "Vs", f"fewer than 2 % of joint {name!r}'s kept samples are slower than "
                     "3 Vs: Fs, Vs and delta rest on few low-speed samples"))
    if rest is not None and np.isfinite(Vs) and rest[j] > REST_WARN:
        out.append(W("method", "Fs", f"joint {name!r} is at rest (slower than its slowest kept speed) over "
                     f"{100 * rest[j]:.0f} % of the log: the Stribeck hump lies where it sticks and reverses, outside "
                     "its rows, so Fs and Vs are extrapolated from faster rows and may lie outside their intervals "
                     "(on simulated arms Fs reads low and Vs high); --rows sliding, or slow constant-speed segments "
                     "in the log, determine them"))
    for k in ("Fc", "sigma"):
        if rel[k] > 0.5:
            out.append(W("identifiability", k, f"{k} of joint {name!r} is poorly determined (95 % half-width "
                         f"{100 * rel[k]:.0f} % of the value)"))
    if lag.reason is not None:
        out.append(W("method", "tau", f"no friction lag (tau, eq. 1) for joint {name!r}: {lag.reason}; "
                     "tau is null"))
    elif "lowpass" in lag.info and lag.info["lowpass"] is None:  # asked for, its worlds not simulated or fitted
        out.append(W("method", "tau", f"the friction lag of joint {name!r} is not corrected for the record's "
                     "low-pass (the correction's worlds could not be simulated or fitted): tau is the output-error "
                     "fit's own reading, read it as an upper bound and its interval as too narrow"))
    return out


def _sign_warnings(name: str, params: dict) -> list:
    """The sign constraints of eqs. 1-3 (``J > 0``; ``Fc, Fs, sigma >= 0``) on joint ``name``'s ``params``: one
    ``implausible`` warning per failing parameter (:func:`adaptive_ff.identification.plausibility.check_physical`, as
    ``identify``'s), so that ``design``, ``compare`` and ``export-c --from`` refuse such a joint by name."""
    from adaptive_ff.identification.plausibility import check_physical

    return check_physical({k: params[k] for k in ("J", "Fc", "Fs", "sigma")}, source=f"identify-arm, joint {name!r}")


@threadpool_limits.wrap(limits=1, user_api="blas")  # the many small products of the fits: one thread each
def identify_arm(log: ArmLog, arm: ArmModel, *, cutoff: float = DEFAULT_CUTOFF, n_bootstrap: int = 200,
                 seed: int = 0, rigid_body: str = "fit", progress: bool | None = False,
                 lag: bool | LagOptions = True, rows: str = DEFAULT_ROWS) -> ArmIdentification:
    """Identify the rigid body and every joint's friction of ``arm`` from ``log`` (module docstring: the method).

    Parameters
    ----------
    log : ArmLog
        The log (:func:`adaptive_ff.arm.arm_log.read_arm_log`), joints in the URDF's order.
    arm : ArmModel
        The arm (:func:`adaptive_ff.arm.robot.load_urdf`).
    cutoff : float, keyword-only
        Cutoff (Hz) of the zero-phase low-pass before differentiation (default 20 Hz).
    n_bootstrap : int, keyword-only
        Refits of the block bootstrap of the samples (>= 2; default 200).
    seed : int, keyword-only
        Seeds the bootstrap.
    rigid_body : {"fit", "urdf"}, keyword-only
        ``"fit"``: the base parameters identified with the friction (the URDF's inertias only set which
        combinations exist); ``"urdf"``: the URDF's inertias used as given, only the friction fitted.
    progress : bool or None, keyword-only
        Progress bars of the Stribeck profile, the bootstrap and the lag fits on stderr (tqdm): True, False
        (default), None (only on a terminal).
    lag : bool or LagOptions, keyword-only
        Identify each joint's friction lag ``tau`` by output error (:mod:`adaptive_ff.arm.lag`): True (default)
        with :class:`adaptive_ff.arm.lag.LagOptions`' defaults (10 bootstrap refits per joint, the joints in 2
        worker processes), or those options; False: ``tau`` NaN with a warning (the costliest stage skipped).
    rows : {"moving", "sliding"}, keyword-only
        The joints' rows (:data:`ROWS`; module docstring; ``identify-arm --rows``): ``"moving"`` (default) where
        the filtered velocity is above 2 % of the joint's 99th-percentile speed and one cutoff period from its
        reversals, each the filter of the moving samples' share alone (torque, rigid body and friction columns);
        ``"sliding"`` also :data:`REST_WINDOW` cutoff periods from where the joint sticks; the profile's bound
        scaled by the bootstrap's variance ratio in both (their coverage: ``docs/your_arm.md``).

    Returns
    -------
    ArmIdentification
        Per joint ``J`` (its own diagonal inertia ``M_jj`` at the log's mean configuration, from the identified
        base parameters), ``Fc, Fs, Vs, delta, sigma, offset``, ``tau`` (NaN where the log does not determine it)
        with 95 % intervals and warnings, the velocity noise; the base parameters with intervals and the condition
        number.

    Raises
    ------
    SignalError
        The log's joint count differs from the URDF's; irregular time stamps; too few rows.
    ParameterError
        A position beyond the URDF's limits (file, joint, sample and value named); ``cutoff``, ``n_bootstrap``,
        ``lag``, ``rows`` or ``rigid_body`` invalid; a joint with no row fast enough to fit.
    ExcitationError
        A joint whose Stribeck profile has no finite weighted residual (the joint named).
    """
    _check(log, arm, n_bootstrap, rigid_body)
    if rows not in ROWS:
        raise ParameterError(f"rows must be one of {', '.join(map(repr, ROWS))}, got {rows!r}")
    if not isinstance(lag, (bool, LagOptions)):
        raise ParameterError(f"lag must be True, False or a LagOptions, got {lag!r}")
    t, q, dq, ddq, tau = filtered_states(log, cutoff)
    base = arm.base_parameters()
    Y = arm.regressor(q, dq, ddq)
    Yb = Y[:, :, base.independent]  # the dependent columns are Y_ind @ K: spanned already
    if rigid_body == "urdf":
        tau = tau - Y @ arm.theta_urdf
        Yb = Yb[:, :, :0]
    vmin = 0.02 * np.percentile(np.abs(dq), 99, axis=0)
    w_fast = _fast_velocity(log, cutoff)
    states = (t, dq, Yb, tau, w_fast)
    rb = (base.independent, arm.theta_urdf if rigid_body == "urdf" else None)
    fit_states = _moving_share(log, arm, cutoff, states, vmin, rb) if rows == "moving" else states
    settings = (int(n_bootstrap), seed, progress)
    first = _whole_arm((log, arm, cutoff, None), (states, fit_states), vmin, rows, settings)
    a_J = _inertia_rows(arm, base, log.q.mean(axis=0))  # the log's mean configuration (all its samples)
    r = Yb.shape[2]
    run = ((log, arm, cutoff), (states, fit_states), vmin, rows, settings)
    lags = _lags(first, (log, arm, (base, a_J, rigid_body), cutoff, (lag, seed, progress)))
    stage, lagged, lag_alts, lag_ends = _lagged_stage(first, lags, run)
    prob, keep_j, Vs, delta, table, x, rss, A, x_alt, boot, _, half, ratio = stage
    noise = velocity_noise(log)
    rest = np.mean(np.abs(w_fast) < vmin, axis=0) if rows == "moving" else None  # each joint's share at rest
    joints = []
    for j in range(arm.n):
        joints.append(_joint(arm, j, x, half, boot, a_J, r, base,
                             (Vs, delta, table, rss, int(prob.keep.sum()), ratio, x_alt, _shape_fit(prob, Vs, delta),
                              lag_alts),
                             (q, dq, keep_j, rest), (lags[j], noise[j])))
    scaled = A[prob.keep] * np.tile(prob.w, prob.m)[prob.keep][:, None]
    norm = np.linalg.norm(scaled, axis=0)
    scaled = scaled[:, norm > 0] / norm[norm > 0]  # a zero column (Fs of a joint without Stribeck term) is no fit
    beta = x[:r] if rigid_body == "fit" else base.of(arm.theta_urdf)
    ival = (np.column_stack(widen_lag(x[:r], *widen(x[:r], x[:r] - half[:r], x[:r] + half[:r],
                                                      None if x_alt is None else x_alt[:r]),
                                       None if lag_alts is None else [a[:r] for a in lag_alts]))
            if rigid_body == "fit" else np.full((beta.shape[0], 2), np.nan))
    rigid = (Yb @ x[:r]) if rigid_body == "fit" else np.zeros_like(tau)
    curves = tuple((dq[:, j], tau[:, j] - rigid[:, j]) for j in range(arm.n))
    info = {"cutoff": float(cutoff), "rows": [int(v) for v in keep_j.sum(axis=0)],
            "bootstrap": {"n": int(n_bootstrap), "valid": boot.n_valid, "block": boot.block, "seed": int(seed)},
            "rms": [float(v) for v in _residual_rms(stage.keep_j, stage.resid)],
            "J": "the joint's own diagonal inertia M_jj at the log's mean configuration", "row_selection": rows,
            "lagged_columns": [float(v) if np.isfinite(v) else None for v in lagged],
            "lag_ranges": [[float(lo), float(hi)] if np.isfinite(hi) else None
                           for lo, hi in zip(*(lag_ends or (np.full(arm.n, np.nan),) * 2))]}
    cond = float(np.linalg.cond(scaled))
    return ArmIdentification(joints=tuple(joints), base_names=base.names, base_values=beta, base_interval=ival,
                             cond=cond, rigid_body=rigid_body, info=info, curves=curves,
                             warnings=tuple(_arm_warnings(cond, rows == "moving" and x_alt is None)))


class _Stage(NamedTuple):
    """One whole-arm fit (:func:`_whole_arm`): the problem ``prob`` and each joint's rows ``keep_j``
    (:func:`_weighted_fit`), the profile's Stribeck shapes ``Vs``, ``delta`` and its ``table``, the solution ``x``,
    its weighted ``rss`` and rows ``A``, the row-sensitivity estimate ``alt`` (:func:`_sliding_estimate`, None with
    ``rows="sliding"``), the bootstrap ``boot`` with its residuals ``resid`` and 95 % half-widths ``half``, and the
    variance ratio ``ratio`` (:func:`_variance_ratio`)."""

    prob: _Problem
    keep_j: np.ndarray
    Vs: np.ndarray
    delta: np.ndarray
    table: list
    x: np.ndarray
    rss: float
    A: np.ndarray
    alt: np.ndarray | None
    boot: object
    resid: np.ndarray
    half: np.ndarray
    ratio: float


def _residual_rms(keep_j, resid) -> np.ndarray:
    """Each joint's residual RMS (N·m), shape (N,), over its kept rows: ``keep_j`` (m, N) bool, ``resid`` (m, N) N·m
    (a :func:`_whole_arm` result's ``keep_j`` and ``resid``)."""
    return np.array([np.sqrt(np.mean(resid[keep_j[:, j], j] ** 2)) for j in range(keep_j.shape[1])])


def _lagged_stage(stage, lags, run) -> tuple:
    """The whole-arm fit with each reported lag in its joint's friction columns (module docstring, "Lag"): ``(stage,
    lagged, lag_alts, ends)``. ``stage`` the lag-free :class:`_Stage`, ``lags`` the joints'
    :class:`adaptive_ff.arm.lag.JointLag`, ``run`` ``((log, arm, cutoff), states, vmin, rows, settings)``. A joint whose
    residual the lagged columns raise beyond the bound of :func:`_lag_raises_residual` keeps its columns lag-free (the
    lag then models something else than the friction map's delay), and the fit is run again without it. ``lagged`` (N,)
    the lags in the columns (s, NaN: none); ``lag_alts`` None, or the point fits (p,) at the ends of each joint's lag
    range (:func:`adaptive_ff.arm.intervals.lag_ranges`; all lower, all upper; at the fit's Stribeck shapes), whose
    distance from the estimate the intervals carry (:func:`adaptive_ff.arm.intervals.widen_lag`); ``ends`` None, or
    those ranges ``(low, high)``, each (N,) s, NaN where a joint has none (:func:`_capped_null_ranges`)."""
    (log, arm, cutoff), states, vmin, rows, settings = run
    lagged = np.array([lg.tau if np.isfinite(lg.tau) and lg.tau > 0.0 else np.nan for lg in lags])
    for _ in range(2):
        if not np.isfinite(lagged).any():
            new = stage
            break
        new = _whole_arm((log, arm, cutoff, lagged), states, vmin, rows, settings)
        worse = np.isfinite(lagged) & _lag_raises_residual(stage, _residual_rms(new.keep_j, new.resid))
        if not worse.any():
            break
        lagged = np.where(worse, np.nan, lagged)
    else:  # the second pass raised another joint's residual: no lag in the columns
        new, lagged = stage, np.full(lagged.shape, np.nan)
    ends = _capped_null_ranges(lag_ranges(lags, lagged), lags, lagged, (stage, new), run)
    if ends is None:
        return new, lagged, None, None
    alts = [_point_fit((log, arm, cutoff, tau), states[1], vmin, rows, (new.prob, new.Vs, new.delta)) for tau in ends]
    return new, lagged, alts, ends


def _capped_null_ranges(ends, lags, lagged, stages, run):
    """``ends`` (:func:`adaptive_ff.arm.intervals.lag_ranges`' ``(low, high)`` or None) with each null lag's upper
    end capped where, put in the joint's friction columns (the other joints' as in ``lagged``), it raises the joint's
    residual beyond the bound of :func:`_lag_raises_residual` over the lag-free fit: such a lag models something else
    than the friction map's delay, as a reported lag kept out of the columns does (module docstring, "Lag"). The end
    is halved until the residual accepts it or it reaches the floor (:data:`adaptive_ff.arm.lag.LAG_FLOOR_SAMPLES`
    samples of the joint's record), which stands unchecked: the log does not tell a lag that short from none; then
    the largest accepted end between that and the last rejected one is located by :data:`NULL_CAP_BISECTIONS`
    bisections (to within 2**-NULL_CAP_BISECTIONS of the bracket), so a cap does not fall up to half below it.
    One point fit per joint, halving and bisection (one joint's end at a time: a far too long lag in one joint's
    columns moves the rigid body and so the others' residuals), at the lagged fit's Stribeck shapes and weights;
    ``lags`` the joints' :class:`adaptive_ff.arm.lag.JointLag`, ``stages`` ``(lag-free, lagged)`` :class:`_Stage`,
    ``run`` as :func:`_lagged_stage`'s."""
    if ends is None:
        return None
    (log, arm, cutoff), states, vmin, rows, _ = run
    stage, new = stages

    def accepts(j, end):
        trial = lagged.copy()
        trial[j] = end
        upper = _point_problem((log, arm, cutoff, trial), states[1], vmin, rows, new.prob)
        x = upper.fit(new.Vs, new.delta)[0]
        resid = upper.residuals(x, upper.design(new.Vs, new.delta))
        return not _lag_raises_residual(stage, _residual_rms(new.keep_j, resid))[j]

    high = ends[1].copy()
    for j in np.flatnonzero(np.isfinite(high) & ~np.isfinite(lagged)):
        floor, rejected = lag_floor(lags[j].info), None
        while high[j] > floor and not accepts(j, high[j]):
            rejected, high[j] = high[j], max(0.5 * high[j], floor)
        if rejected is not None:
            for _ in range(NULL_CAP_BISECTIONS):
                mid = 0.5 * (high[j] + rejected)
                if accepts(j, mid):
                    high[j] = mid
                else:
                    rejected = mid
    return ends[0], high


def _lag_raises_residual(stage, rms) -> np.ndarray:
    """(N,) bool: joints whose residual RMS ``rms`` (N,) over their kept rows (:func:`_residual_rms` of a fit with lags
    in its columns) rises above ``stage``'s (the lag-free fit's) by more than the 95 % likelihood-ratio allowance
    (:func:`adaptive_ff.arm.intervals.lr_allowance` over the joint's rows, ``ratio`` the lag-free fit's variance
    ratio; the bound of the Stribeck profile's intervals), both taken as mean squares: a rise within it is the two
    fits' difference on the same rows, not a worse model."""
    ms0 = _residual_rms(stage.keep_j, stage.resid) ** 2
    return rms ** 2 > ms0 + lr_allowance(ms0, stage.keep_j.sum(axis=0), stage.ratio)


def _point_fit(setup, states, vmin, rows: str, at) -> np.ndarray:
    """The whole-arm fit's parameters (p,) with the columns of ``setup`` (:func:`_weighted_fit`'s) at the Stribeck
    shapes and weights of ``at`` ``(prob, Vs, delta)``, the same rows (no profile)."""
    prob, Vs, delta = at
    return _point_problem(setup, states, vmin, rows, prob).fit(Vs, delta)[0]


def _point_problem(setup, states, vmin, rows: str, prob) -> _Problem:
    """The :class:`_Problem` with the columns of ``setup`` (:func:`_weighted_fit`'s) on the rows and weights of
    ``prob``."""
    log, arm, cutoff, lags = setup
    t, dq, Yb, tau, w_fast = states
    _, columns = _rows_and_columns(log, cutoff, (t, dq, w_fast), vmin, rows, lags)
    other = _Problem(Yb, dq, tau, prob.keep, columns)
    other.w = prob.w
    return other


def _whole_arm(setup, states, vmin, rows: str, settings) -> _Stage:
    """The whole-arm fit with its intervals' ingredients (:class:`_Stage`); ``setup`` as :func:`_weighted_fit`'s,
    ``states`` ``(states, fit_states)`` (the filtered states, and those of the rows' fit), ``settings``
    ``(n_bootstrap, seed, progress)``."""
    states, fit_states = states
    n_bootstrap, seed, progress = settings
    prob, keep_j, (Vs, delta, table), (x, rss, A) = _weighted_fit(setup, fit_states, vmin, rows, progress)
    alt = _sliding_estimate(setup, states, vmin) if rows == "moving" else None
    boot, resid = _bootstrap(prob, A, x, n_bootstrap, seed, progress)
    return _Stage(prob, keep_j, Vs, delta, table, x, rss, A, alt, boot, resid, boot.half_width(0.95),
                  _variance_ratio(prob, A, rss, boot))


def _weighted_fit(setup, states, vmin, rows: str, progress=False) -> tuple:
    """The weighted fit of one rows choice (module docstring): ``(problem, keep_j, (Vs, delta, table), (x, rss, A))``;
    ``setup`` is ``(log, arm, cutoff, lags)``, ``lags`` None or each joint's friction lag (N,) s through which its
    friction columns go, ``states`` ``(t, dq, Yb, tau)`` of the filtered log and the log's fast velocity ``w_fast``,
    ``vmin`` (N,) each joint's slowest kept speed (rad/s). Raises ParameterError where a joint has fewer than 10
    rows."""
    log, arm, cutoff, lags = setup
    t, dq, Yb, tau, w_fast = states
    keep_j, columns = _rows_and_columns(log, cutoff, (t, dq, w_fast), vmin, rows, lags)
    for j in np.flatnonzero(keep_j.sum(axis=0) < 10):
        raise ParameterError(f"{log.source}: joint {arm.names[j]!r} moves in fewer than 10 of the filtered samples: "
                             "nothing to fit its friction on")
    prob = _Problem(Yb, dq, tau, keep_j.reshape(-1), columns)
    grids = _grids(dq, keep_j, vmin)
    mid = np.array([g[N_VS // 2] for g in grids])
    x0, _, A0 = prob.solve(mid, np.ones(arm.n))
    e0 = prob.residuals(x0, A0)
    prob.w = 1.0 / np.array([max(np.std(e0[keep_j[:, j], j]), 1e-12) for j in range(arm.n)])
    from adaptive_ff.identification.covariance import politis_white_block

    block0 = max(politis_white_block(e0[keep_j[:, j], j] * prob.w[j]) for j in range(arm.n))
    rss0 = float(np.sum((e0 * prob.w) ** 2 * keep_j))
    n_kept = max(int(keep_j.sum()), 1)
    Vs, delta, table = _profile(prob, grids, 5.99 * block0 * rss0 / n_kept, progress)
    return prob, keep_j, (Vs, delta, table), prob.solve(Vs, delta)


def _sliding_estimate(setup, states, vmin):
    """The ``rows="sliding"`` point estimate ``x`` (p,) of the same log (:func:`_weighted_fit`), or None where a
    joint has fewer than 10 sliding rows: the other rows choice, whose distance from the default's estimate is the
    row-sensitivity term of the default's intervals (:func:`adaptive_ff.arm.intervals.widen`; not of ``Fs`` and
    ``Vs``, which the sliding rows, without the slow samples, barely determine: :func:`_joint`)."""
    try:
        return _weighted_fit(setup, states, vmin, "sliding")[3][0]
    except ParameterError:
        return None


def _lags(stage, setup) -> list:
    """Every joint's :class:`adaptive_ff.arm.lag.JointLag` behind the whole-arm fit ``stage`` (:class:`_Stage`): each
    joint's record with that fit's rigid body removed (the URDF's with ``rigid_body="urdf"``) and its ``J`` (``M_jj``
    at the log's mean configuration) added back, each lag bootstrap refit ``i`` carrying the ``i``-th whole-arm
    bootstrap replicate's difference from it (:func:`adaptive_ff.arm.lag.lag_records`; :mod:`adaptive_ff.arm.lag`,
    "Reported"); the fit's Stribeck shapes held and its accepted shapes in the refits
    (:func:`adaptive_ff.arm.intervals.lag_shapes`, :func:`adaptive_ff.arm.intervals.accepted_shapes`); its ``Fs`` and
    ``Fc`` behind each joint's stop band and stick speed (:func:`adaptive_ff.arm.lag.stop_bands`,
    :func:`adaptive_ff.arm.lag.stick_speeds`). ``setup`` ``(log, arm, (base, a_J, rigid_body), cutoff, (lag, seed,
    progress))``, ``a_J`` (N, r) the rows of :func:`_inertia_rows`; ``lag`` False: every lag NaN, nothing fitted."""
    log, arm, (base, a_J, rigid_body), cutoff, (on, seed, progress) = setup
    if on is False:
        return [JointLag(np.nan, (np.nan, np.nan), "not asked for (lag=False; identify-arm --no-lag)")] * arm.n
    options = LagOptions() if on is True else on
    r = stage.prob.r

    def rigid_of(b):
        theta = np.zeros(11 * arm.n)
        theta[base.independent] = b  # the dependent columns are spanned by the independent ones
        return lambda Y: Y @ theta

    fitted = rigid_body == "fit"
    J = a_J @ (stage.x[:r] if fitted else base.of(arm.theta_urdf))
    rigid = rigid_of(stage.x[:r]) if fitted else (lambda Y: Y @ arm.theta_urdf)
    reps = stage.boot.replicates[:, :r] if fitted else None
    if reps is None or reps.shape[0] == 0:
        t, u, w = lag_records(log, arm, rigid, J, cutoff)
        errors = None
    else:
        J_reps = reps @ a_J.T
        k = np.arange(options.n_bootstrap) % reps.shape[0]  # fewer whole-arm replicates: taken in turn again
        t, u, w, errors = lag_records(log, arm, rigid, J, cutoff,
                                      replicates=[(rigid_of(reps[i]), J_reps[i]) for i in k])
    held = lag_shapes(stage.Vs, stage.delta, stage.table)
    accepted = accepted_shapes(stage.table, stage.rss, int(stage.prob.keep.sum()), stage.ratio)
    Fc = stage.x[r:r + 4 * arm.n:4]
    Fs = static_friction(Fc, np.where(np.isfinite(stage.Vs), stage.x[r + 1:r + 4 * arm.n:4], Fc))
    Ts = float(np.median(np.diff(t)))
    bands, sticks = stop_bands(Fs, J, Ts), stick_speeds(Fc, J, Ts)
    refined = refined_joints(sticks, options.refine_stops)
    worlds = [LagWorld(None if errors is None else errors[:, :, j], LAG_CUTOFF_FACTOR * cutoff,
                       None if accepted is None else accepted[j], float(bands[j]) if refined[j] else None,
                       float(sticks[j]) if np.isfinite(sticks[j]) else None) for j in range(arm.n)]
    return joint_lags(t, u, w, held, options=options, seed=seed, progress=progress, worlds=worlds)


def _arm_warnings(cond: float, no_sensitivity: bool = False) -> list:
    """A conditioning warning when the column-scaled regressor's condition number exceeds ``COND_WARN``; a method
    note when ``no_sensitivity`` (``rows="moving"`` and the sliding rows leave a joint fewer than 10 rows, so that
    the intervals carry no row-sensitivity term)."""
    from adaptive_ff.identification.plausibility import IdentificationWarning

    out = []
    if no_sensitivity:
        out.append(IdentificationWarning("method", "all", "the sliding rows (--rows sliding) leave a joint fewer "
                                         "than 10 rows: the intervals carry no row-sensitivity term and may be "
                                         "too narrow"))
    if cond > COND_WARN:
        out.append(IdentificationWarning("conditioning", "rigid_body", f"the weighted regressor (column-scaled) has "
                                         f"condition number {cond:.3g} > {COND_WARN:g}: the log does not excite every "
                                         "base parameter and friction term apart; a richer trajectory (more joints "
                                         "moving at once, wider ranges) separates them"))
    return out


def _joint(arm, j, x, half, boot, a_J, r, base, profile, data, lag_noise) -> ArmJoint:
    """Joint ``j``'s parameters, intervals, standard errors and warnings from the fit."""
    from adaptive_ff.identification.covariance import bootstrap_t_quantile

    Vs, delta, table, rss, n_rows, ratio, sliding, shape_fit, lag_alts = profile
    q, dq, keep_j, rest = data
    c = r + 4 * j
    p = dict(zip(_FRICTION, x[c: c + 4]))
    hw = dict(zip(_FRICTION, half[c: c + 4]))
    std = {k: float(v) for k, v in zip(_FRICTION, boot.stderr[c: c + 4])}
    if r:
        reps_J = boot.replicates[:, :r] @ a_J[j]
        J = float(a_J[j] @ x[:r])
        std["J"] = float(np.sqrt(np.mean((reps_J - J) ** 2)))
        hw["J"] = bootstrap_t_quantile(boot.n_valid, 0.95) * std["J"]
    else:
        J = float(a_J[j] @ base.of(arm.theta_urdf))
        hw["J"] = np.nan
    stribeck = bool(np.isfinite(Vs[j]))
    lo = {k: params_k - hw[k] for k, params_k in (("J", J), *p.items())}
    hi = {k: params_k + hw[k] for k, params_k in (("J", J), *p.items())}
    if not stribeck:  # no Stribeck term: Fs = Fc
        p["Fs"], hw["Fs"], std["Fs"], lo["Fs"], hi["Fs"] = p["Fc"], hw["Fc"], std["Fc"], lo["Fc"], hi["Fc"]
    # the friction's intervals are the profile likelihood's over every (Vs, delta) the profile accepts, the model
    # without a Stribeck term among them (band_share): a dropped term's Fs interval reaches as far as it allows
    vs_iv, d_iv, (x_lo, x_hi), xs, share = profile_interval(table[j], rss, n_rows, ratio, slice(c, c + 4),
                                                             arm.names[j], lambda v, d: shape_fit(j, v, d),
                                                             [hw[k] for k in _FRICTION])
    for i, k in enumerate(_FRICTION):
        lo[k], hi[k] = min(lo[k], x_lo[i]), max(hi[k], x_hi[i])
    if r:  # J as well: the rigid body's estimate moves with the joint's (Vs, delta)
        Js = xs[:, :r] @ a_J[j]
        lo["J"], hi["J"] = min(lo["J"], (Js - share * hw["J"]).min()), max(hi["J"], (Js + share * hw["J"]).max())
    if sliding is not None:  # the row sensitivity (rows="moving"): the sliding rows' estimate; not of Fs (nor Vs)
        alt = dict(zip(_FRICTION, sliding[c: c + 4]), J=float(a_J[j] @ sliding[:r]) if r else np.nan)
        for k, v in (("J", J), *p.items()):
            if k != "Fs":
                lo[k], hi[k] = widen(v, lo[k], hi[k], alt[k])
    if lag_alts is not None:  # the lags' uncertainty (the columns at the lags' interval ends)
        for k, v in (("J", J), *p.items()):
            a = [float(a_J[j] @ x_a[:r]) if k == "J" else float(x_a[c + _FRICTION.index(k)]) for x_a in lag_alts]
            lo[k], hi[k] = widen_lag(v, lo[k], hi[k], a)
    lag, noise = lag_noise
    params = {"J": J, **p, "Vs": float(Vs[j]), "delta": float(delta[j]) if stribeck else np.nan, "tau": lag.tau}
    interval = {k: (lo[k], hi[k]) for k in ("J", *_FRICTION)}
    interval.update({"Vs": vs_iv, "delta": d_iv, "tau": lag.interval95})
    rel = {k: hw[k] / max(abs(p[k]), 1e-12) for k in ("Fc", "sigma")}
    warn = _joint_warnings(arm, j, (q, dq, keep_j, rest), Vs[j], rel, lag) + _sign_warnings(arm.names[j], params)
    return ArmJoint(name=arm.names[j], params=params, interval95=interval, std=std, warnings=tuple(warn),
                    noise_std=float(noise), lag_info=lag.info or {},
                    min_speed=float(np.min(np.abs(dq[keep_j[:, j], j]))))
