r"""Profile search over the friction lag ``tau`` for the output-error fit of
:func:`adaptive_ff.identification.physical_id.fit_physical`.

Why
---
On joints whose lag is about the sample time (5-15 ms at the 10 ms sampling of the zoo of
``benchmarks/coverage_zoo.py``) the free-run cost has a long valley in which ``J`` trades against ``tau``
(a heavier joint with a longer lag predicts nearly the same velocity). The staged search of the fit
(global tau and Fs profiles at a wide robust scale, then local trust-region fits) stopped on such joints
in a local minimum of that valley: on 9 of the zoo's first 60 joints it reported tau 9-70 % and J 2-21 % off, 2.4-5.7 of its bootstrap standard errors, and the cost near the truth (a refit
started at the true parameters, or the profile point at the true tau) was *lower* each time
(documentation, identification benchmark page, "Calibration on many joints"). The bootstrap intervals cannot cover an estimate that is off because the optimiser
stopped early: the point fit has to find the valley's bottom.

What
----
:func:`lag_profile_search` holds ``log tau`` at each of :data:`TAU_FACTORS` times the current estimate,
chooses ``log J`` there on a grid of ``+-`` :data:`J_SPAN` (the trade direction the trust region does not
follow on the rough cost), refits the other parameters by a wide-scale and a noise-level trust-region pass
(graduated non-convexity, as the fit's global stage) and keeps the point of lowest cost; if it is below the
current one, all parameters are refitted from it. It is a profile of the cost over ``tau`` (Venzon &
Moolgavkar, *Appl. Statist.* 37(1), 1988; Bates & Watts, *Nonlinear Regression Analysis and its
Applications*, Wiley 1988, Sec. 6.1) used as a search, not as an interval: the profile cost is rough at the
level of the breakaway jitter (a chi-square threshold scaled by the residual variance, even with the
long-run variance of coloured residuals, gave intervals narrower than the bootstrap's on the six joints
measured), so the intervals stay those of the bootstrap.
"""

from __future__ import annotations

import math

import numpy as np

from plant.errors import ParameterError, check_optional_number

__all__ = ["TAU_FACTORS", "J_SPAN", "J_GRID", "lag_profile_search"]

#: Values of tau tried, as multiples of the current estimate (log-spaced on each side; 0.9 and 1.1 because
#: the fit is often 8-25 % off in tau on joints with a lag near the sample time).
TAU_FACTORS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.1, 1.25, 1.4, 1.7, 2.0)
#: Half-width of the grid of log J at each tau (0.3: J -26 .. +35 %; the zoo's J-tau misses were within 21 %).
J_SPAN = 0.3
#: Points of that grid.
J_GRID = 13


def lag_profile_search(pb, best: tuple, *, factors=TAU_FACTORS, j_tau: int = 4, j_J: int = 0,
                       n_refit: int | None = None) -> tuple:
    """Lowest-cost point of a profile of the output-error cost over the lag, refitted (module docstring).

    Parameters
    ----------
    pb : adaptive_ff.identification.physical_id._OutputErrorProblem
        The problem: ``cost(x, fsc=None)``, ``refine(x, ds, fsc=None, free=None)`` (a trust-region fit, result
        with ``.x``: the free coordinates), ``profile(x, lo, hi, n, j, fsc)`` (grid search of one coordinate),
        ``opts.diff_step``, ``f_wide`` (wide robust scale, rad/s), ``n_sim`` (simulations so far).
    best : tuple (float, ndarray)
        ``(cost, x)`` of the current estimate, ``x`` the fit's parameter vector (``log J`` at ``j_J``,
        ``log tau`` at ``j_tau``).
    factors : sequence of float, keyword-only
        Values of tau tried as multiples of the current one, each > 0. Default :data:`TAU_FACTORS`.
    j_tau, j_J : int, keyword-only
        Indices of ``log tau`` and ``log J`` in ``x``. Defaults 4 and 0 (``_OutputErrorProblem``).
    n_refit : int or None, keyword-only
        None (default): the other parameters are refitted at every value of tau. An integer >= 1: the J grid
        is run at every value of tau first (its lowest cost at the wide robust scale screens the values) and
        the others are refitted at the ``n_refit`` values of lowest screening cost only (the bootstrap refits'
        shortcut, ``OutputErrorOptions.bootstrap_lag_refits``); the profile points not refitted keep their
        screening point, and their ``cost`` in ``details`` is at the noise-level scale there.

    Returns
    -------
    best : tuple (float, ndarray)
        ``(cost, x)``: the input ``best`` if no profile point is below it, else the better of the lowest
        profile point and the full refit from it.
    details : dict
        JSON-able: ``tau`` (s) and ``cost`` of each profile point (the cost at the noise-level robust scale,
        as ``best``), ``n_simulations`` spent, ``moved`` (whether the estimate changed).

    Raises
    ------
    plant.errors.ParameterError
        ``factors`` empty, or a factor that is not a finite number > 0; ``n_refit`` not None nor an integer
        >= 1.

    Notes
    -----
    The lowest cost over the profile and the refit is kept, so the returned cost is never above the input's
    (the search cannot make the fit worse by its own criterion).
    """
    fac = np.asarray(factors, dtype=float).reshape(-1)
    if fac.size == 0 or not np.all(np.isfinite(fac)) or np.any(fac <= 0):
        raise ParameterError(f"factors must be finite numbers > 0, got {factors!r}")
    n_refit = check_optional_number("n_refit", n_refit, integer=True, low=1)
    c0, x0 = float(best[0]), np.asarray(best[1], dtype=float)
    ds = pb.opts.diff_step / 3.0
    free = [j for j in range(x0.shape[0]) if j != j_tau]
    n0 = pb.n_sim

    def grid(f):  # tau held at f times the current one, log J on its grid (wide robust scale)
        xs = x0.copy()
        xs[j_tau] = x0[j_tau] + math.log(f)
        return pb.profile(xs, xs[j_J] - J_SPAN, xs[j_J] + J_SPAN, J_GRID, j=j_J, fsc=pb.f_wide)

    def refit(xs):  # the others refitted at that tau: a wide-scale and a noise-level trust-region pass
        xs[free] = pb.refine(xs, pb.opts.diff_step, pb.f_wide, free=free).x
        xs[free] = pb.refine(xs, ds, free=free).x
        return xs

    points, costs, screen = [], [], []
    for f in fac:
        xs = grid(f)
        if n_refit is None:
            xs = refit(xs)
        else:  # its costs while its residual vector is at hand (the problem keeps the last few only)
            screen.append(pb.cost(xs, pb.f_wide))
        points.append(xs)
        costs.append(pb.cost(xs))
    if n_refit is not None:
        for k in sorted(np.argsort(screen, kind="stable")[:n_refit]):
            points[k] = refit(points[k])
            costs[k] = pb.cost(points[k])
    taus = [math.exp(xs[j_tau]) for xs in points]
    k = int(np.argmin(costs))
    out = (c0, x0)
    if costs[k] < c0:
        sol = pb.refine(points[k], ds)
        c = pb.cost(sol.x)
        out = (c, sol.x) if c < costs[k] else (costs[k], points[k])
    details = {"tau": [float(v) for v in taus], "cost": [float(v) for v in costs],
               "n_simulations": int(pb.n_sim - n0), "moved": bool(out[0] < c0)}
    return out, details
