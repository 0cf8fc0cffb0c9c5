r"""Profile of the output-error cost over the input delay, for
:func:`adaptive_ff.identification.physical_id.fit_physical` where the log's input timing is not given.

Why
---
A logger stamps each torque sample at some instant of the period it was applied over: the simulated readout of
:func:`plant.sampling.sample` at the end of the 1 ms step (half a millisecond after the middle of its hold), a
controller often at the start of the next period. The output-error fit reconstructs the input between the
stamps; taken at the wrong instant, the input leads or lags the velocity it drove, and the fit moves the lag,
the Stribeck level and the Coulomb level to make up for it. On two joints of ``benchmarks/coverage_zoo.py``
(10 ms readout of a 1 kHz hold) the fit taking each torque at its stamp missed sigma, Fc and Fs by 1.7-16 %; told
the delay of 0.5 ms it missed them by 0.3-1.9 % (documentation, identification benchmark page). The cost told
the delay apart: lowest at 0.5 ms on both (77.0 -> 71.5 and 72.1 -> 67.8 from 0 to 0.5 ms, back up at 1 ms).

What
----
:func:`delay_profile_search` holds the delay at each of :data:`DELAY_FRACTIONS` times the median stamp interval
(sub-sample: a logger's stamp is within the period it belongs to, or one period late), refits the parameters
there by one trust-region pass at the noise-level robust scale from the current estimate, and keeps the delay of
lowest cost; between the two neighbours of the lowest grid point the vertex of the parabola through the three
costs is tried too (the cost is smooth enough in the delay at the grid's scale). The delay is reported with the
fit (``info["input_delay"]`` and ``info["input_delay_profile"]``). The bootstrap's full refits hold the delay the
fit chose (``info["bootstrap"]["input_delay"]``): each runs the fit's search at delay 0 and then this profile
with that delay as its one point (the same refit from the same stage of the search as the fit's profile there),
instead of the whole grid, which was a third of each refit's simulations (about 650 of 2070 on the 20 s log of
``benchmarks/output_error_speed.py``; the one point 110-130). Refits held at the delay without that last refit
(the whole search at the delay) scattered 1.8-2.8 times wider in Fc, Fs and sigma on that log: the refit is part
of the estimator, the refits keep it.

The delay's own uncertainty
---------------------------
Held at the fit's delay, the refits do not carry the delay's error, and the profile cannot resolve the delay
finer than its neighbouring points: where the residuals are nearly white, the costs there differ by about the
landing scatter of its refits, so which of two or three neighbouring delays is chosen is as much the optimiser's
landing as the log. :func:`delay_spread` takes the delay's share from the profile itself: the root-mean-square
move of the parameters refitted at the delays tried next to the chosen one (the estimator's own answers there)
from the profile's refit at the chosen delay (the same stage of the search),
which ``fit_physical`` adds in quadrature to the refits' spread (``info["bootstrap"]["stderr_delay"]``). It costs
no simulation. What it does to the coverage of the zoo of ``benchmarks/coverage_zoo.py`` is on the identification
benchmark page ("The input delay's share").
"""

from __future__ import annotations

import numpy as np

__all__ = ["DELAY_FRACTIONS", "delay_profile_search", "delay_spread"]

#: Input delays tried, as fractions of the median stamp interval.
DELAY_FRACTIONS = (0.0, 1.0 / 16.0, 1.0 / 8.0, 1.0 / 4.0, 1.0 / 2.0, 1.0)


def _vertex(d: np.ndarray, c: np.ndarray) -> float | None:
    """The abscissa of the lowest point of the parabola through three points, if it is a minimum strictly between
    the outer two; else None."""
    a = np.polyfit(d, c, 2)
    if not a[0] > 0:
        return None
    v = float(-a[1] / (2.0 * a[0]))
    return v if d[0] < v < d[2] else None


def delay_profile_search(pb, best, refit, *, fractions=DELAY_FRACTIONS, delays=None, values=None) -> tuple:
    """The input delay of lowest output-error cost on a grid of sub-sample delays, the parameters refitted at each
    (module docstring).

    Parameters
    ----------
    pb : adaptive_ff.identification.physical_id._OutputErrorProblem
        The problem: ``t`` (stamps, s), ``set_delay(d)`` (the input taken ``d`` s before its stamps from then on),
        ``n_sim`` (simulations so far). Left at the delay returned.
    x : ndarray
        The current parameter vector, the start of every refit.
    refit : callable
        ``refit(x) -> (cost, x)``: the parameters refitted from ``x`` at the problem's current delay, and the cost
        there (the same stage and robust scale at every delay, so that the costs compare).
    fractions : sequence of float, keyword-only
        Delays tried, as fractions of the median stamp interval, >= 0, increasing. Default :data:`DELAY_FRACTIONS`.
        The grid stops once two delays in a row cost more than the lowest so far (the cost rises away from its
        minimum).
    delays : sequence of float or None, keyword-only
        The delays tried (s), in place of ``fractions`` where given: the bootstrap's full refits pass the fit's
        chosen delay as the one point (module docstring). Default None.
    values : callable or None, keyword-only
        ``values(x) -> dict`` (physical parameters of a vector ``x``); where given, ``details["params"]`` holds
        the parameters refitted at each delay tried, in the order of ``details["delay"]`` (the input of
        :func:`delay_spread`). Default None.

    Returns
    -------
    x : ndarray
        The refitted parameters at the delay chosen.
    details : dict
        JSON-able: ``delay`` (s) and ``cost`` of each point tried (the grid, then the parabola's vertex if tried),
        ``chosen`` (s), ``n_simulations`` spent.
    """
    Ts = float(np.median(np.diff(pb.t)))
    x0 = np.asarray(best[1], dtype=float)
    n0 = pb.n_sim
    tried = {}

    def at(d):
        pb.set_delay(d)
        tried[d] = refit(x0)
        return tried[d][0]

    grid, costs = [], []
    for d in ([f * Ts for f in fractions] if delays is None else delays):
        grid.append(float(d))
        costs.append(at(grid[-1]))
        if len(costs) >= 3 and costs[-1] > min(costs) and costs[-2] > min(costs):
            break
    k = int(np.argmin(costs))
    if 0 < k < len(grid) - 1:
        v = _vertex(np.array(grid[k - 1:k + 2]), np.array(costs[k - 1:k + 2]))
        if v is not None:
            at(v)
    chosen = min(tried, key=lambda d: tried[d][0])
    pb.set_delay(chosen)
    details = {"delay": [float(d) for d in tried], "cost": [float(tried[d][0]) for d in tried],
               "chosen": float(chosen), "n_simulations": int(pb.n_sim - n0)}
    if values is not None:
        details["params"] = [{k: float(v) for k, v in values(tried[d][1]).items()} for d in tried]
    return tried[chosen], details


def delay_spread(details: dict, names) -> dict:
    """The input delay's share of the parameters' error: per parameter the root-mean-square move, from the
    profile's own refit at the chosen delay, of the parameters refitted at the delays tried next to it.

    The profile resolves the delay only to its neighbouring points: the costs of neighbouring delays differ by about
    the landing scatter of the profile's refits, several times the likelihood's 95 % threshold on nearly white
    residuals, so the chosen point is one of two or three the log does not tell apart. The refits there are the
    estimator's own answers at those delays; their moves, added in quadrature to the bootstrap's spread (which
    holds the delay, module docstring), give intervals that carry the delay's uncertainty without another
    simulation. The moves are measured from the profile's refit at the chosen delay, the same stage of the search
    as at the neighbours, not from the fit's estimate: the final Fs profile that follows the delay's profile
    moves the estimate's Fs (and what correlates with it) by its own polish, which is no effect of the delay and
    which the bootstrap's refits, running that profile too, already hold.

    Parameters
    ----------
    details : dict
        :func:`delay_profile_search`'s details with ``params`` (``delay``, ``chosen``, ``params``: the parameters
        refitted at each delay tried, in the order of ``delay``).
    names : iterable of str
        The parameters (keys of each entry of ``details["params"]``); the keys of the result.

    Returns
    -------
    dict
        Name -> root-mean-square move (the parameter's units) over the tried delays nearest below and above the
        chosen one (one of them at an end of the profile); 0.0 for every parameter where the profile tried one
        delay (the bootstrap's refits) or has no ``params``.
    """
    names = list(names)
    delays, params = list(details.get("delay", ())), details.get("params")
    if not params or len(delays) < 2:
        return {k: 0.0 for k in names}
    order = sorted(range(len(delays)), key=lambda i: delays[i])
    ch = delays.index(details["chosen"])
    pos = order.index(ch)
    nb = [order[j] for j in (pos - 1, pos + 1) if 0 <= j < len(order)]
    return {k: float(np.sqrt(np.mean([(params[i][k] - params[ch][k]) ** 2 for i in nb]))) for k in names}
