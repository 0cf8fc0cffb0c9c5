"""Standard errors and 95 % intervals of the output-error fit of :mod:`adaptive_ff.identification.physical_id`.

The Newey-West (HAC) sandwich and the white
Gauss-Newton errors around the forward-difference Jacobian of the free-run residuals (:func:`oe_stderr`), the
bootstrap's intervals centred on the estimate less the refits' mean shift where it is not negligible
and the profiled input delay's share added in quadrature (:func:`bootstrap_intervals`,
:data:`adaptive_ff.identification.covariance.BIAS_NEGLIGIBLE`),
the band of F(w) from the refits (:func:`oe_band`); the bootstrap's refits run in ``physical_id``.

Each function takes the fit's output-error problem ``pb`` (``physical_id``'s): it reads its residual functions
``res(x)`` / ``res_many(X)``, ``opts.diff_step``, ``chain(x)`` (the chain rule to physical units), ``free_shape``,
``Vs``, ``delta``, ``w`` and ``delay_profile``.

Standard errors
---------------
The free-run cost is rough at breakaway (the instants at which the
simulated joint breaks away shift in jumps with Fs, Fc and tau), and the
fit stops somewhere in a valley of local minima whose width, not the noise,
sets its error. A covariance from the local curvature does not see it: the
Newey-West (HAC) sandwich around the forward-difference Jacobian ``G`` of the
prediction errors (Bartlett bandwidth by Andrews' AR(1) rule,
:mod:`adaptive_ff.identification.covariance`; ``info["stderr_hac"]``) and the
white-noise Gauss-Newton ``s**2 (G^T G)^-1`` (Ljung, Sec. 9.3;
``info["stderr_white"]``) gave nominal 95 % intervals that covered the truth
in 25-50 % of simulated records (``benchmarks/coverage.py``).

``stderr`` is therefore (``n_bootstrap > 0``, default 20) a parametric
block wild bootstrap (Efron & Tibshirani, *An Introduction to the
Bootstrap*, 1993, Sec. 9.5; Wu, *Ann. Statist.* 14(4), 1986; Shao,
*J. Amer. Statist. Assoc.* 105(489), 2010): each replicate record is the
fitted model's own prediction on the same input and time stamps plus the
fit's residuals, each at its own instant, multiplied by a random sign per
block of ``3 (L + 1)`` samples (``L`` the Andrews bandwidth: the colour of
the residuals within a block, including the input quantisation's effect,
is kept; :func:`adaptive_ff.identification.covariance.block_wild_resample`).
The residuals are large at breakaway, where Fs is identified, and small
while sliding; a moving-block resampling (Künsch,
*Ann. Statist.* 17(3), 1989) carries them into the sliding stretches, and
its Fs intervals covered 88 % of the zoo joints of
``benchmarks/coverage_zoo.py`` (93 % with it; the documentation's
identification page, "Calibration on many joints"). With
``bootstrap_refit="partial"`` each replicate is refitted from a start drawn
around the estimate (normal, three typical
changes per parameter: 6 % of J, 9 % of tau, 3 % of the torques) by the
fit's own later steps (``_oe_refit``; ``info["bootstrap"]["refit"]``): a
trust-region pass at the wide robust scale of its global stage, its local
stage (a pass at the noise-level scale, the local Fs profile, a pass; the
better point kept) and one round of its coordinate search. The two
trust-region passes alone stop short of where the fit itself stops, so that
their scatter carries the memory of their start (measurements and coverage before and after: the documentation's
identification page, "Alternatives measured"). The
lag profile and the final Fs profile are not run in the refits (they cost
several times the rest of a refit). A refit started at the
estimate itself stays there on the rough cost (measured: spreads 10-100
times too small); from a spread start it has to find the valley again as
the real fit does. The refits' root-mean-square deviation from the estimate
(``info["bootstrap"]["stderr_refits"]``; it includes their mean shift,
``info["bootstrap"]["bias"]``) gives the standard error as the interval rule
below says. The start spread is a method constant,
calibrated on simulated records and checked on others
(``benchmarks/coverage.py``; the documentation's identification page has
the table); the intervals widen with it.

These partial refits (``bootstrap_refit="partial"``) are not the
estimator: on four joints of ``benchmarks/coverage_zoo.py`` their scatter was 1.3-2.9 times the fit's own
error over ten records of each joint (new input, time stamps and noise), while
the fit itself, run on the same bootstrap replicates, scattered as that Monte
Carlo did (J 0.38 % against 0.38 % on one of them; the partial refits 0.87 %).
``bootstrap_refit="full"`` refits each replicate by the fit itself, the
replicate taken as a record of its own (its noise level, robust scales and
eq. 4 start, every stage including the profile search over tau; the input
delay held at the fit's, not profiled again, its own share added to the
refits' spread in quadrature where the fit profiled it:
:func:`adaptive_ff.identification.delay_profile.delay_spread`): the bootstrap of
the estimator as it is (Efron & Tibshirani, Ch. 6), at about three times the
cost of the partial refits (a median 34 s, 22-68 s, against 11 s of CPU per
15 s zoo record with 20 refits, when each refit runs the fit's whole profile
search over tau); its coverage on the zoo: the identification
page, "The bootstrap of the fit itself, the default". The refits screen
that profile search (``bootstrap_lag_refits=2``, the default): the J grid
still runs at each of its ten values of tau, but the other parameters are
refitted at the two values of lowest J-grid cost only (None: at all ten, as
the fit itself). The profile is not dropped from the refits: on two zoo
joints with lags of 5.1 and 7.7 ms the refits' search stopped 4-70 % high in
tau before it, and it moved 41 of their 42 refits back towards the
estimate's tau (to 0.6-0.9 times the tau they had stopped at). Screened, it
runs about 230 instead of 745 of a refit's simulations on the log of
``benchmarks/output_error_speed.py``, where the intervals are those of the
whole profile bit for bit; the zoo coverage of both is on the identification
page ("The default on a slow, irregular readout"). The point estimate is the
same either way (the fit's own search refits at every value). The full refits
are the default: their 95 % intervals covered the truth on 91-96 % of 100 zoo
joints per parameter with the whole profile in each refit (two runs with
different draws; the identification page, "The bootstrap of the fit itself,
the default"), the partial refits' J and tau
intervals on 99 % (twice too wide). The refits run in threads
(``bootstrap_workers``; their time is in the C simulation, which releases the
GIL); every replicate and the generator of each refit are drawn before any
refit runs, so the result does not depend on the number of threads.

The bootstrap world can read its input as the log does
(``bootstrap_input_quantum``). A torque logged through a converter or as a
count is rounded to its resolution ``q`` (``"auto"``:
:func:`adaptive_ff.identification.diagnostics.input_quantum` finds the lattice
the samples lie on; 0 for a continuous input): the input that drove the joint
differs from the logged one by an error spread uniformly over ``[-q/2, q/2]``
(Widrow & Kollár, *Quantization Noise*, 2008, Ch. 5), an error in the fit's
input variable that the residuals do not carry (it moves the breakaway
instants, not only the velocity between them). With the option each replicate
record is the estimate driven by the logged input plus a uniform draw within
half a quantum (from the refit's own generator; one more simulation per refit),
refitted with the logged input, as the record is: the parametric bootstrap of
the data-generating process the log's readout implies (Efron & Tibshirani,
Sec. 6.5; ``info["bootstrap"]["input_quantum"]``). It is the default
(``"auto"``; a continuous input has no quantum and its bootstrap is that of
None bit for bit); None takes the logged input as exact.

The 95 % interval of each parameter is ``centre ± t stderr``
(:func:`adaptive_ff.identification.covariance.bias_corrected_interval`): centred
on the estimate less the refits' mean shift ``info["bootstrap"]["bias"]`` where
that shift exceeds :data:`adaptive_ff.identification.covariance.BIAS_NEGLIGIBLE`
(0.25) standard errors, on the
estimate otherwise (Efron & Tibshirani, Sec. 10.6) (the shift is the
estimator's bias in the bootstrap world, Efron & Tibshirani, Sec. 10.2; the
reflected, "basic" bootstrap interval is centred there too, Davison & Hinkley,
*Bootstrap Methods*, 1997, Sec. 5.2). Centred on the estimate, ``stderr`` is the
refits' root-mean-square deviation from it and ``t`` the Student quantile of the
valid refits; centred less the shift, it is the refits' standard deviation about
their mean times ``sqrt(1 + 1/n)`` (the shift's own Monte Carlo error) and ``t``
that of ``n - 1`` degrees of freedom, the prediction interval of a normal sample
(Hahn & Meeker, *Statistical Intervals*, 1991, Sec. 4.7); each with the profiled
input delay's share in quadrature. On the zoo the fit's errors lie on the side
of the refits' shift (Fc low, sigma high, tau low on the joints missed when the
interval was centred on the estimate), three to five times as far; the
identification page, "Calibrated on the zoo", has the coverage of each rule.
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.identification.covariance import bias_corrected_interval, hac_covariance
from adaptive_ff.identification.delay_profile import delay_spread
from plant.errors import ExcitationError

__all__ = ["bootstrap_intervals", "oe_band", "oe_stderr"]


def oe_stderr(pb, x: np.ndarray, names: tuple) -> tuple[dict, dict, float, np.ndarray, int]:
    """Standard errors (HAC and white), the scaled-Jacobian condition number, the residuals and the HAC bandwidth.

    Forward-difference Jacobian ``G`` of the raw residuals (steps as in the fit), chain rule for log J,
    log tau and the offset scale. ``stderr`` is the Newey-West sandwich
    (:func:`adaptive_ff.identification.covariance.hac_covariance`: the free-run residuals are correlated);
    ``stderr_white`` the Gauss-Newton ``s**2 (G^T G)^-1`` (Ljung Sec. 9.3) that assumes white residuals.
    """
    r = pb.res(x)
    G = np.empty((r.shape[0], x.shape[0]))
    h = [pb.opts.diff_step * max(1.0, abs(x[j])) for j in range(x.shape[0])]
    X = np.repeat(x[None, :], x.shape[0], axis=0)
    for j in range(x.shape[0]):
        X[j, j] += h[j]
    for j, rj in enumerate(pb.res_many(X)):
        G[:, j] = (rj - r) / h[j]
    dof = max(r.shape[0] - x.shape[0], 1)
    s2 = float(r @ r) / dof
    sc = np.linalg.norm(G, axis=0)
    zero = np.flatnonzero(sc == 0)
    if zero.size:
        raise ExcitationError(f"the output does not depend on {names[zero[0]]!r}: the data do not excite it")
    Gs = G / sc
    sv = np.linalg.svd(Gs, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    chain = pb.chain(x)
    lags = 0
    try:
        white = np.sqrt(np.clip(np.diag(s2 * np.linalg.inv(Gs.T @ Gs)), 0.0, None)) / sc
        cov, lags = hac_covariance(Gs, r)
        hac = np.sqrt(np.clip(np.diag(cov), 0.0, None)) / sc
    except np.linalg.LinAlgError:
        white = hac = np.full(x.shape[0], np.nan)
    return ({k: float(v) for k, v in zip(names, hac * chain)}, {k: float(v) for k, v in zip(names, white * chain)},
            cond, r, lags)


def oe_band(pb, names: tuple, est: np.ndarray, b) -> dict:
    """``band``: the 95 % band of F(w) from the refits of a bootstrap ``b``
    (:func:`adaptive_ff.identification.uncertainty.friction_band`); empty with fewer than 2 valid refits."""
    from adaptive_ff.identification.uncertainty import friction_band

    if b.n_valid < 2:
        return {}
    cols = [names.index(k) for k in ("Fc", "Fs", "sigma")]
    Vs, delta = (est[names.index("Vs")], est[names.index("delta")]) if pb.free_shape else (pb.Vs, pb.delta)
    band = friction_band(est[cols], b.replicates[:, cols], w_max=float(np.max(np.abs(pb.w))), Vs=float(Vs),
                         delta=float(delta))
    return {"band": band.to_dict()}


def bootstrap_intervals(pb, params: dict, rms: dict, boot: dict) -> dict:
    """The standard errors of the fit and ``boot["interval95"]`` (``centre ± t stderr``,
    :func:`adaptive_ff.identification.covariance.bias_corrected_interval`: centred on the estimate less the refits'
    mean shift ``boot["bias"]`` where it is not negligible; module docstring, "Standard errors") from the refits'
    RMS deviations ``rms``, with the input delay's share added in quadrature where the fit profiled the delay
    (:func:`adaptive_ff.identification.delay_profile.delay_spread`: the refits hold the delay; its share in
    ``boot["stderr_delay"]``). The refits' own RMS deviations go to ``boot["stderr_refits"]``. With fewer than 2
    valid refits: ``rms`` and the delay's share in quadrature, no interval."""
    spread = {k: 0.0 for k in rms} if pb.delay_profile is None else delay_spread(pb.delay_profile, rms)
    boot["stderr_refits"] = dict(rms)
    if pb.delay_profile is not None:
        boot["stderr_delay"] = spread
    if boot["n_valid"] < 2:
        return {k: float(math.hypot(rms[k], spread[k])) for k in rms}
    parts = {k: bias_corrected_interval(params[k], boot["bias"][k], rms[k], spread[k], boot["n_valid"]) for k in rms}
    boot["interval95"] = {k: [float(c - q * se), float(c + q * se)] for k, (c, se, q) in parts.items()}
    return {k: se for k, (c, se, q) in parts.items()}
