"""The warnings of :func:`adaptive_ff.identification.identify.identify` about its own estimates.

:func:`estimate_warnings` flags the eq. 4 LS and RLS values that violate the sign constraints of eqs. 1-3
(:func:`adaptive_ff.identification.plausibility.check_physical`), a badly conditioned regression, a friction lag
the data do not support (redundant inertia) and a model that fits one step ahead but not in free run.
:func:`ls_simex_judgment` and :func:`sliding_band_warnings` judge whether the record's own velocity noise biases
J and tau in the band of the regression that fits them, by simulation-extrapolation (SIMEX: Cook & Stefanski,
JASA 89(428), 1994): the record is refitted with its own noise level added once more, and a median change of
more than 10 % gives an ``"identifiability"`` warning with the number. :func:`as_baseline` turns an eq. 4
warning into a ``"method"`` note when another method gives the answer.
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.io.data import MeasuredData
from adaptive_ff.identification.identification_report import parameter_names
from adaptive_ff.identification.ls import LSResult, fit_ls
from adaptive_ff.identification.physical_id import PhysicalFit
from adaptive_ff.identification.plausibility import IdentificationWarning, check_physical
from adaptive_ff.identification.regression import FrictionEstimate
from plant.errors import ExcitationError

__all__ = ["FREE_RUN_MIN", "as_baseline", "estimate_warnings", "ls_simex_judgment", "sliding_band_warnings"]

#: Free-run fit (%) of the eq. 4 LS below which the dynamics (J, tau) are not determined by the record.
FREE_RUN_MIN = 50.0

#: Condition number above which :func:`estimate_warnings` adds a warning (fit_ls refuses above 1e10).
_COND_WARN = 1e6

#: Largest noise-induced change (relative) of J or tau that the identifiability check accepts.
_SIMEX_MAX = 0.1
#: Replicates of the simulation-extrapolation check (the median change is judged).
_SIMEX_REPS = 3


def _simex_median_change(fit_fn, w, noise_std: float, ref: dict) -> dict | None:
    """Median relative change of each parameter of ``ref`` when white noise of ``noise_std`` is added to ``w``.

    ``fit_fn(w)`` returns an object with the parameters as attributes; None if a refit fails (the record
    does not stand its own noise once more). Simulation-extrapolation (Cook & Stefanski, JASA 89(428),
    1994): the change estimates the bias the present noise causes.
    """
    changes = {k: [] for k in ref}
    for seed in range(_SIMEX_REPS):
        try:
            e = fit_fn(w + np.random.default_rng(seed).normal(0.0, noise_std, w.shape[0]))
        except ExcitationError:
            return None
        for k, v in ref.items():
            changes[k].append(abs(getattr(e, k) - v) / abs(v) if v != 0 else math.inf)
    return {k: float(np.median(c)) for k, c in changes.items()}


def _simex_warning(name: str, change: float, noise_std: float, regression: str) -> IdentificationWarning:
    return IdentificationWarning(
        "identifiability", name,
        f"{name} moves by {100 * change:.3g} % (median of {_SIMEX_REPS}) when the record's own velocity noise "
        f"({noise_std:.3g}) is added once more to {regression}: the noise biases it by about as much "
        f"(simulation-extrapolation), more than {100 * _SIMEX_MAX:g} %; {name} is not identifiable from this record")


def ls_simex_judgment(warn: list, model, u, w, Ts: float, ls: LSResult, noise_std: float) -> list:
    """Replace the sample-to-sample J warning of the excitation report by a judgment in the band of eq. 4.

    :func:`adaptive_ff.identification.diagnostics.excitation_report` warns when the velocity changes no more
    than its noise from sample to sample. Whether that biases J (and tau) depends on the band the LS of eq. 4
    uses; the simulation-extrapolation refit (:func:`_simex_median_change`) measures it on this record: the
    warning is kept, with the number, only if J (or tau) moves by more than 10 %.

    Parameters
    ----------
    warn : list of IdentificationWarning
        The excitation report's warnings (:attr:`adaptive_ff.identification.diagnostics.ExcitationReport.warnings`).
    model : RegressionModel
        The eq. 4 structure that ``ls`` was fitted with.
    u, w : array_like, shape (N,)
        The uniform record: input (N·m or N) and velocity (rad/s or m/s).
    Ts : float
        Sample time (s) of the record.
    ls : LSResult
        The eq. 4 LS fit (eq. 9) of the record (:func:`adaptive_ff.identification.ls.fit_ls`).
    noise_std : float
        The velocity noise level of the record (rad/s or m/s;
        :attr:`adaptive_ff.identification.diagnostics.ExcitationReport.noise_std`).

    Returns
    -------
    list of IdentificationWarning
        ``warn`` itself when it has no ``"identifiability"`` warning on J, when ``noise_std`` is not positive or
        when a refit fails; else its other warnings followed by one ``"identifiability"`` warning for each of J
        (and tau with the lag structure) that moves by more than 10 % (median of 3 seeded refits).

    Raises
    ------
    SignalError
        From :func:`adaptive_ff.identification.ls.fit_ls`: the noisier record is not finite (a non-finite
        ``noise_std``). An ExcitationError of a refit is caught (``warn`` is returned).
    """
    j_warn = [x for x in warn if x.code == "identifiability" and x.parameter == "J"]
    if not j_warn or not noise_std > 0:
        return warn
    rest = [x for x in warn if x not in j_warn]
    names = ("J", "tau") if model.lag else ("J",)
    ref = {k: getattr(ls.estimate, k) for k in names}
    ch = _simex_median_change(lambda ww: fit_ls(model, u, ww, Ts=Ts, free_run=False).estimate,  # estimate only
                              np.asarray(w, dtype=float), noise_std, ref)
    if ch is None:
        return warn
    return rest + [_simex_warning(k, c, noise_std, "the eq. 4 regression") for k, c in ch.items() if c > _SIMEX_MAX]


def sliding_band_warnings(uni: MeasuredData, Vs: float, delta: float, noise_std: float, fit: PhysicalFit) -> list:
    """J and tau identifiability of the sliding regression, judged in its own band by simulation-extrapolation.

    The record is refitted with seeded white noise of its own estimated level ``noise_std`` added to the
    velocity (variance doubled). Errors-in-variables bias grows about linearly with the noise variance, so
    the change of a parameter between the two fits estimates the bias the present noise causes (SIMEX:
    Cook & Stefanski, JASA 89(428), 1994). A median change over :data:`_SIMEX_REPS` seeds above
    :data:`_SIMEX_MAX` (10 %) means the parameter is not recovered within 10 % from data of this rate,
    noise and excitation, and gives an ``"identifiability"`` warning with the number.

    Parameters
    ----------
    uni : MeasuredData
        The uniform controller-rate record (``u`` in N·m or N, ``w`` in rad/s or m/s, shape (N,); ``Ts`` in s).
    Vs, delta : float
        The Stribeck velocity (rad/s or m/s) and shape factor of the pre-fit (Sec. V-C).
    noise_std : float
        The velocity noise level of the record (rad/s or m/s).
    fit : PhysicalFit
        The sliding regression's fit of the record (method ``"sliding"``; its ``params["J"]`` in kg·m² and
        ``params["tau"]`` in s are the reference values).

    Returns
    -------
    list of IdentificationWarning
        Empty when ``noise_std`` is not positive or neither J nor tau moves by more than 10 % or by more than
        the half-width of its 95 % interval (``fit.info["interval95"]``); else one ``"identifiability"``
        warning per parameter that moves by more than 10 %, one ``"model_form"`` warning per parameter that
        moves by less but beyond its interval's half-width (an errors-in-variables bias the bootstrap of the
        regression's residuals does not hold: on a 1 kHz PI log, tau -1.5 %, the move 1.2 half-widths), or a
        single ``"identifiability"`` warning on J when a refit fails.

    Raises
    ------
    SignalError
        From :func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`: the noisier record is not finite (a
        non-finite ``noise_std``). An ExcitationError of a refit is caught (the single warning on J).
    ParameterError
        From :func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`: invalid ``Vs`` or ``delta``.
    """
    from adaptive_ff.compensation.sliding_estimator import fit_sliding

    if not noise_std > 0:
        return []
    ch = _simex_median_change(lambda ww: fit_sliding(uni.u, ww, Tc=uni.Ts, Vs=Vs, delta=delta).estimate, uni.w,
                              noise_std, {k: fit.params[k] for k in ("J", "tau")})
    if ch is None:
        return [IdentificationWarning("identifiability", "J", "the sliding regression fails when the record's "
                                      "own noise level is added once more: J and tau are not identifiable")]
    out = [_simex_warning(k, c, noise_std, "the sliding regression") for k, c in ch.items() if c > _SIMEX_MAX]
    iv = fit.info.get("interval95") or {}
    for k, c in ch.items():
        if c > _SIMEX_MAX or k not in iv:
            continue
        lo, hi = iv[k]
        move = c * abs(fit.params[k])
        if move > 0.5 * (hi - lo):
            out.append(IdentificationWarning(
                "model_form", k,
                f"{k} of the sliding regression: the record's own velocity noise ({noise_std:.3g}), added once more, "
                f"moves it by {100 * c:.3g} % ({move:.4g}, median of {_SIMEX_REPS}; simulation-extrapolation), more "
                f"than the half-width {0.5 * (hi - lo):.4g} of its 95 % interval [{lo:.6g}, {hi:.6g}]: the noise in "
                "the filtered regressors biases it by about as much, which the interval does not hold"))
    return out


def as_baseline(w):
    """An eq. 4 LS/RLS warning as a ``"method"`` note when another method gives the answer (excitation kept).

    Parameters
    ----------
    w : IdentificationWarning
        A warning of the eq. 4 LS or RLS (:func:`estimate_warnings`, or of the excitation report).

    Returns
    -------
    IdentificationWarning
        ``w`` itself for an ``"identifiability"`` warning on the record's own excitation (it concerns every
        method); else (also for the simulation-extrapolation judgment of the eq. 4 regression, which concerns
        that regression only) a ``"method"`` warning on the same parameter whose message is ``w``'s after
        ``"eq. 4 baseline, not the answer: "``.

    Raises
    ------
    AttributeError
        ``w`` has no ``code`` or ``parameter`` (a plain str, not an :class:`IdentificationWarning`).
    """
    if w.code == "identifiability" and not w.startswith(("redundant inertia", "the eq. 4 model")) \
            and "the eq. 4 regression" not in w:
        return w  # the record's own excitation: it concerns every method
    return IdentificationWarning("method", w.parameter, f"eq. 4 baseline, not the answer: {w}")


def estimate_warnings(ls: LSResult, rls_est: FrictionEstimate, lag: bool) -> list:
    """Typed warnings about implausible estimates, weak excitation and an unsupported lag (one per parameter).

    Parameters
    ----------
    ls : LSResult
        The eq. 4 LS fit (eq. 9) of the record: its physical estimate, condition number and fits (%).
    rls_est : FrictionEstimate
        The physical parameters of the final RLS estimate (eqs. 10-13).
    lag : bool
        Whether the structure fits the friction lag (eq. 2): then the redundant inertia ``Ts*a2/b1`` is compared
        with J.

    Returns
    -------
    list of IdentificationWarning
        ``"implausible"`` warnings of the LS and RLS values that violate eqs. 1-3
        (:func:`adaptive_ff.identification.plausibility.check_physical`; J in kg·m², sigma in N·m·s/rad, Fc, Fs and
        offset in N·m, tau in s), a ``"conditioning"`` warning for a condition number above 1e6, an
        ``"identifiability"`` warning on tau when the redundant inertia differs from J by more than 10 % and one
        on J when the free-run fit is below 50 %; empty if none applies.
    """
    names = parameter_names(ls.model)
    warn = check_physical({k: getattr(ls.estimate, k) for k in names}, source="LS (eq. 4)")
    warn += check_physical({k: getattr(rls_est, k) for k in names}, source="final RLS (eqs. 10-13)")
    if ls.cond > _COND_WARN:
        warn.append(IdentificationWarning(
            "conditioning", "all", f"regressor condition number {ls.cond:.3g} > {_COND_WARN:.0e}: weak excitation, "
                                   "estimates are sensitive to noise"))
    if lag and math.isfinite(ls.estimate.J_alt) and abs(ls.estimate.J_alt - ls.estimate.J) > 0.1 * abs(ls.estimate.J):
        warn.append(IdentificationWarning(
            "identifiability", "tau",
            f"redundant inertia Ts*a2/b1 = {ls.estimate.J_alt:.4g} differs from J = {ls.estimate.J:.4g} by more "
            "than 10 %: the data do not support the friction-lag structure well (J and tau are not trustworthy)"))
    if ls.fit_free_run < FREE_RUN_MIN:
        warn.append(IdentificationWarning(
            "identifiability", "J",
            f"the eq. 4 model fits one step ahead ({ls.fit_one_step:.1f} %) but not in free run "
            f"({ls.fit_free_run:.1f} % < {FREE_RUN_MIN:g} %): the record does not determine the dynamics (J, tau); "
            "typical of a closed-loop log read out slower than the loop: log torque and velocity at the "
            "controller rate (method 'sliding'), or give the commanded velocity and the controller "
            "(identify --reference-column NAME --controller controller.json, or --Kp --Ki --Tc --u-max; "
            "with --Vs, --delta: method 'closed_loop')"))
    return warn
