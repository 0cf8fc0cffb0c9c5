"""The interval rules of the whole-arm fit (:mod:`adaptive_ff.arm.fit`): the Stribeck profile's 95 %
likelihood-ratio bound and what it accepts, the Stribeck shapes the lag fits hold, and an interval widened by a model
error its bootstrap does not see (the other rows choice, the lags).

A profile table (``table_j``, one joint's, as :func:`adaptive_ff.arm.fit._profile` makes it) is a list of rows
``(Vs, delta, weighted RSS, estimate (p,))``: the grid's rows, then the grid's best refined in ``Vs``, then the model
without the Stribeck term (``Vs``, ``delta`` NaN). Why each rule: ``docs/your_arm.md`` (How, Intervals; Lag; The
lags in the whole-arm fit).
"""

from __future__ import annotations

import numpy as np

from plant.errors import ExcitationError

from adaptive_ff.arm.lag import lag_floor

__all__ = ["CHI2_95", "CROSSING_STEPS", "LAG_SHAPE_DRAWS", "accepted_shapes", "band_share", "crossings", "lag_ranges",
           "lag_shapes", "lr_allowance", "profile_bound", "profile_interval", "widen", "widen_lag"]

#: The chi-square quantile of one degree of freedom at 95 %: the profile's likelihood-ratio bound
#: (:func:`profile_bound`).
CHI2_95 = 3.84

#: Bisections in ``log Vs`` that locate the profile's crossing of its likelihood-ratio bound between two grid values
#: (:func:`crossings`): the crossing to 2**-5 of the grid's step.
CROSSING_STEPS = 5

#: Stribeck shapes drawn by weight from each joint's accepted set for its lag bootstrap refits
#: (:func:`accepted_shapes`).
LAG_SHAPE_DRAWS = 20


def lr_allowance(rss, n_rows, ratio: float):
    """The 95 % likelihood-ratio allowance ``CHI2_95 ratio rss / n_rows`` on a residual sum of squares ``rss`` over
    ``n_rows`` rows (at least 1), the residuals' correlation counted by the variance ratio ``ratio``
    (:func:`adaptive_ff.arm.fit._variance_ratio`): how far another model's RSS on the same rows may lie above it
    before the data reject that model. Floats or arrays (broadcast)."""
    return rss * CHI2_95 * ratio / np.maximum(n_rows, 1)


def profile_bound(table_j, rss_min: float, n_rows: int, ratio: float) -> tuple:
    """``(best, allowance)`` of the profile's 95 % likelihood-ratio bound ``best + allowance``
    (:func:`profile_interval` says why): ``best = max(rss_min, min of table_j's finite RSS)`` (NaN where none is
    finite or ``rss_min`` is not), ``allowance`` :func:`lr_allowance` of ``rss_min``."""
    finite = [row[2] for row in table_j if np.isfinite(row[2])]
    best = max(rss_min, min(finite)) if finite and np.isfinite(rss_min) else np.nan
    return best, lr_allowance(rss_min, n_rows, ratio)


def profile_interval(table_j, rss_min: float, n_rows: int, ratio: float, cols: slice, name: str = "joint",
                      fit_at=None, half=None) -> tuple:
    """The ``(Vs range, delta range, (low, high) of the estimates[cols], estimates, shares)`` over the profile's rows
    within the 95 % likelihood-ratio bound of the best (the residuals' correlation counted by the variance ratio
    ``ratio``, :func:`adaptive_ff.arm.fit._variance_ratio`); ``estimates`` the accepted rows' whole estimates (k, p),
    ``shares`` (k,) each one's :func:`band_share`. The ``Vs`` range reaches the points where the profile crosses that
    bound between the grid's values (:func:`crossings`, with ``fit_at``; None: the accepted values alone), and the
    range of ``Fs`` (``cols``' second) covers its estimates there too: ``Fs`` moves with ``Vs``, the other parameters
    little. The model without a Stribeck term (``Vs`` NaN) counts with ``Fs = Fc``; the ranges of ``Vs`` and
    ``delta`` are NaN where no grid point is inside. ``half`` (shape (4,), the bootstrap's 95 % half-widths of
    ``estimates[cols]`` at the fit's shape; None: zeros): the range covers each accepted row's estimate ``± half``
    times its share, the profile likelihood's interval of each linear parameter (a crossing's share is 0).

    The bound is ``max(rss_min, min of table_j) + CHI2_95 ratio rss_min / n_rows`` (:func:`profile_bound`): the final
    fit's weighted RSS ``rss_min`` sets its scale, and it is counted from the profile's own minimum where that lies
    above ``rss_min``: ``table_j`` is the joint's profile of the last sweep, taken with the later joints' shapes of the
    sweep before, and their last steps lower each of its RSS about alike (the joints share only the rigid body), so that
    the final fit can lie below every row of it (then no row would be inside). The accepted rows hold the profile's
    best. Raises ExcitationError naming ``name`` (the joint) where the profile has no finite RSS or ``rss_min`` is not
    finite."""
    finite = [row[2] for row in table_j if np.isfinite(row[2])]
    if not finite or not np.isfinite(rss_min):
        raise ExcitationError(f"joint {name!r}: the Stribeck profile has no finite weighted residual sum of squares "
                              f"(final fit {rss_min!r}, {len(finite)} of {len(table_j)} profile rows finite): the "
                              "log does not determine its friction")
    best, allowance = profile_bound(table_j, rss_min, n_rows, ratio)
    inside = [row for row in table_j if row[2] <= best + allowance]
    edge = [] if fit_at is None else crossings(table_j, inside, allowance, fit_at)
    vs = [r[0] for r in inside + edge if np.isfinite(r[0])]
    ds = [r[1] for r in inside if np.isfinite(r[0])]
    xs = np.array([r[3][cols] for r in inside])
    off = np.array([not np.isfinite(r[0]) for r in inside])
    xs[off, 1] = xs[off, 0]  # Fs = Fc without the Stribeck term
    share = band_share(np.array([r[2] for r in inside]), best, allowance)
    band = np.outer(share, np.zeros(xs.shape[1]) if half is None else np.asarray(half, dtype=float))
    lo, hi = (xs - band).min(axis=0), (xs + band).max(axis=0)
    for r in edge:  # Fs moves with Vs: its range covers its estimates out to the Vs range's ends (at the bound)
        lo[1], hi[1] = min(lo[1], r[3][cols][1]), max(hi[1], r[3][cols][1])
    nan = (np.nan, np.nan)
    return ((min(vs), max(vs)) if vs else nan), ((min(ds), max(ds)) if ds else nan), (lo, hi), \
        np.array([r[3] for r in inside]), share


def band_share(rss, best: float, allowance: float):
    """The share ``sqrt(max(0, 1 - (rss - best) / allowance))`` of the bootstrap's 95 % half-width that a linear
    parameter's interval keeps about its estimate at a profile row of weighted RSS ``rss`` (float or array), the
    profile's bound ``best + allowance`` (:func:`profile_bound`): at fixed ``(Vs, delta)`` the RSS grows
    quadratically in each linear parameter, by ``allowance`` at the half-width's end, so that a row whose RSS lies
    ``rss - best`` above the best reaches the bound that much nearer its estimate (the profile likelihood of the
    parameter over the shape: Venzon & Moolgavkar, Appl. Statist. 37 (1988); Seber & Wild, *Nonlinear Regression*,
    Sec. 5.9). 1 at the best, 0 at the bound (an ``allowance`` not > 0: 1 at or below ``best``, else 0)."""
    rss = np.asarray(rss, dtype=float)
    if not allowance > 0.0:
        return (rss <= best).astype(float)
    return np.sqrt(np.clip(1.0 - (rss - best) / allowance, 0.0, 1.0))


def crossings(table_j, inside, allowance: float, fit_at, steps: int = CROSSING_STEPS) -> list:
    """The profile's crossings of its likelihood-ratio bound between the grid's values: for each ``delta`` with an
    accepted point (a grid point or the refined best), from its lowest and highest accepted ``Vs`` towards the
    grid's next value beyond (where the grid goes on), the farthest ``(Vs, delta, rss, estimate)`` still within
    ``allowance`` of the best, located by ``steps`` bisections in ``log Vs``. ``fit_at(Vs, delta)`` is
    ``(estimate, weighted RSS)`` with the joint at that shape and the others at their final ones; its RSS is counted
    from its own at the profile's best (``table_j[-2]``, refined), so that the other joints' last steps do not shift
    the bound. Rows of ``table_j`` as :func:`adaptive_ff.arm.fit._profile`'s; ``inside`` its accepted rows."""
    grid_rows = table_j[:-2]  # the grid's rows (the last two: the refined best, no Stribeck term)
    grid = np.unique([r[0] for r in grid_rows])
    ref = fit_at(*table_j[-2][:2])[1]
    out = []
    for d in sorted({r[1] for r in inside if np.isfinite(r[0])}):
        accepted = [r[0] for r in inside if r[1] == d and np.isfinite(r[0])]
        lo, hi = min(accepted), max(accepted)
        for v_in, beyond in ((lo, grid[grid < lo][-1:]), (hi, grid[grid > hi][:1])):
            if not beyond.size:
                continue  # the accepted range reaches the grid's end: no crossing located beyond it
            a, b, best = np.log(v_in), np.log(beyond[0]), None
            for _ in range(steps):
                mid = 0.5 * (a + b)
                x, rss = fit_at(float(np.exp(mid)), d)
                if rss - ref <= allowance:
                    a, best = mid, (float(np.exp(mid)), d, rss, x)
                else:
                    b = mid
            if best is not None:
                out.append(best)
    return out


def widen(value, lo, hi, alt):
    """``(lo, hi)`` with each half-width about ``value`` combined in quadrature with the row sensitivity
    ``|value - alt|`` (arrays or floats; ``alt`` None or NaN: unchanged): the model error that a bootstrap of one
    rows choice does not see, measured by the other rows choice's estimate (``docs/your_arm.md``, "Intervals")."""
    if alt is None:
        return lo, hi
    e = np.where(np.isfinite(alt), np.abs(np.asarray(value) - alt), 0.0)
    return value - np.hypot(value - lo, e), value + np.hypot(hi - value, e)


def widen_lag(value, lo, hi, alts):
    """``(lo, hi)`` widened as :func:`widen` by the larger distance of ``value`` from the two point fits ``alts`` at
    the lags' interval ends (None: unchanged): the lag's uncertainty, which the whole-arm bootstrap (at the
    estimated lags) does not carry."""
    if alts is None:
        return lo, hi
    e = np.maximum(np.abs(np.asarray(value) - alts[0]), np.abs(np.asarray(value) - alts[1]))
    return widen(value, lo, hi, np.asarray(value) + e)


def lag_shapes(Vs, delta, table) -> list:
    """Each joint's ``(Vs, delta)`` held in its lag fit: the whole-arm fit's where it keeps the Stribeck term, else
    the profile's best grid point (whose ``Fs`` the output-error fit then fits): the shape is not refitted there."""
    out = []
    for j in range(len(Vs)):
        if np.isfinite(Vs[j]):
            out.append((float(Vs[j]), float(delta[j])))
        else:
            best = min((row for row in table[j] if np.isfinite(row[0])), key=lambda row: row[2])
            out.append((float(best[0]), float(best[1])))
    return out


def accepted_shapes(table, rss_min: float, n_rows: int, ratio: float, draws: int = LAG_SHAPE_DRAWS) -> list:
    """Each joint's Stribeck shapes that its lag bootstrap refits hold (:mod:`adaptive_ff.arm.lag`, "Reported"):
    ``draws`` rows (Vs, delta) taken systematically, by weight ``exp(-chi2 / 2)``, from the profile's rows with a
    Stribeck term within its 95 % likelihood-ratio bound (:func:`profile_bound`'s, ``chi2 = CHI2_95 (rss -
    best) / allowance``), or None where no such row (the profile's table ``table``, the final fit's weighted RSS
    ``rss_min`` over ``n_rows`` rows, the variance ratio ``ratio``)."""
    out = []
    for table_j in table:
        best, allowance = profile_bound(table_j, rss_min, n_rows, ratio)
        rows = [row for row in table_j if np.isfinite(row[0]) and row[2] <= best + allowance]
        if not rows or not allowance > 0.0:
            out.append(None)
            continue
        chi2 = np.array([CHI2_95 * max(row[2] - best, 0.0) / allowance for row in rows])
        cum = np.cumsum(np.exp(-0.5 * chi2))
        pick = np.searchsorted(cum / cum[-1], (np.arange(draws) + 0.5) / draws)
        out.append(np.array([(rows[i][0], rows[i][1]) for i in pick], dtype=float))
    return out


def lag_ranges(lags, lagged):
    """Each joint's lag range for the intervals' two point fits (:func:`adaptive_ff.arm.fit._lagged_stage`).

    Parameters
    ----------
    lags : sequence of adaptive_ff.arm.lag.JointLag
        The joints' lag fits.
    lagged : ndarray, shape (N,)
        The lags in the friction columns (s; NaN: none).

    Returns
    -------
    tuple of ndarray or None
        ``(low, high)``, each (N,) s, NaN where the joint's columns stay lag-free; None where no joint has a range.
        A lag in the columns: its 95 % interval (a lower end at or below zero: none). A null lag whose output-error
        fit ran (``info["interval95"]`` finite): from none up to the larger of that fit's upper end and the floor
        below which no lag is reported (:data:`adaptive_ff.arm.lag.LAG_FLOOR_SAMPLES` samples of its record): the
        log does not tell such a lag from none, and a lag acts on the friction columns as an inertia term (the
        whole-arm fit, :func:`adaptive_ff.arm.fit.identify_arm`, caps that end where its residual rejects it). A lag
        reported but kept out of the columns (:func:`adaptive_ff.arm.fit._lag_raises_residual`): none, it models
        something else.
    """
    low, high = np.full(len(lags), np.nan), np.full(len(lags), np.nan)
    for j, (lg, v) in enumerate(zip(lags, lagged)):
        if np.isfinite(v):
            lo, hi = lg.interval95
            low[j], high[j] = (lo if np.isfinite(lo) and lo > 0.0 else 0.0), hi
        elif not np.isfinite(lg.tau) and lg.info and "rate" in lg.info:
            hi = (lg.info.get("interval95") or [np.nan, np.nan])[1]
            if np.isfinite(hi):
                low[j], high[j] = 0.0, max(float(hi), lag_floor(lg.info))
    return None if not np.isfinite(high).any() else (low, high)
