"""One-call identification of a measured record: offline LS (eq. 9) and an RLS pass (eqs. 10-13).

The default structure (``lag=False``) was chosen on the EMPS benchmark
(``DATA_EMPS.mat``): the errors of both structures against the published
parameters are on the documentation's EMPS benchmark page.

With ``lag=True`` the lag estimate follows the velocity filter, not the plant
(tau = 0.003, 0.009, 0.018, 0.099, 0.189 s for cutoffs 300, 200, 100, 30,
20 Hz), and the redundant inertia ``Ts*a2/b1`` disagrees with J by 6.6 %, so
the data do not support a friction lag; the Coulomb + viscous estimates without
lag stay within 0.5 % over cutoffs 50-300 Hz. Hence ``lag=False`` is the
default. (The paper, whose robot joint does show a lag, fits it: pass
``lag=True``.)

Quality figures: standard errors and 95 % intervals of every parameter and a 95 % band
of the friction curve from a residual block bootstrap of the fit's own residuals
(:mod:`adaptive_ff.identification.uncertainty`; the white-noise delta-method errors stay
as ``std``), the condition number, and warnings that name what the record does not excite
(:func:`adaptive_ff.identification.diagnostics.excitation_report`). :func:`cross_validate`
judges the model on another record; for the EMPS benchmark see also
:func:`adaptive_ff.identification.idim.fit_idim` (the benchmark's own IDIM-LS, symmetric and
asymmetric friction) and :func:`adaptive_ff.identification.emps_validation.validate_emps`
(closed-loop re-simulation).

The report is :class:`adaptive_ff.identification.identification_report.IdentificationReport`, the
cross-validation :mod:`adaptive_ff.identification.cross_validation` (both re-exported here), and the warnings
on the estimates (plausibility, conditioning, identifiability by simulation-extrapolation) are
:mod:`adaptive_ff.identification.identify_warnings`.
"""

from __future__ import annotations

import math

import numpy as np
from threadpoolctl import threadpool_limits

from adaptive_ff.io.data import MeasuredData, to_uniform
from adaptive_ff.io.units import PARAM_UNITS, VELOCITY_LABEL
from adaptive_ff.identification.cross_validation import CrossValidation, cross_validate
from adaptive_ff.identification.diagnostics import FEEDBACK_MIN, excitation_report, feedback_correlation
from adaptive_ff.identification.identification_report import IdentificationReport, parameter_names
from adaptive_ff.identification.identify_warnings import (FREE_RUN_MIN, as_baseline, estimate_warnings,
                                                          ls_simex_judgment, sliding_band_warnings)
from adaptive_ff.identification.idim_method import IDIM_ESTIMATOR, fit_idim_physical
from adaptive_ff.identification.ls import LSResult, fit_ls
from adaptive_ff.identification.model_error import (ModelErrorSettings, assess_model_error, eq4_model_error,
                                                    widened)
from adaptive_ff.identification.physical_id import PhysicalFit, fit_physical
from adaptive_ff.identification.plausibility import IdentificationWarning, check_physical
from adaptive_ff.identification.regression import RegressionModel, nrmse_fit
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.identification.steady_state_check import with_steady_state_check, without_steady_state_check
from adaptive_ff.identification.uncertainty import (DEFAULT_N_BOOTSTRAP, BootstrapSettings, ParameterUncertainty,
                                                    eq4_block_bootstrap, regression_block_bootstrap)
from plant.errors import ExcitationError, ParameterError, check_optional, check_positive

__all__ = ["IdentificationReport", "identify", "PARAM_UNITS", "CrossValidation", "cross_validate", "stderr_note",
           "IDENTIFY_METHODS", "choose_method", "auto_methods", "attach_physical", "input_delay_note"]

#: Methods of :func:`identify`: ``"auto"`` chooses among the others from the record (:func:`choose_method`).
#: ``"closed_loop"`` simulates the user's controller and lives in ``controllers``
#: (:func:`controllers.experiments.closed_loop_id.identify_closed_loop`), which attaches its fit to the report
#: of :func:`identify` by :func:`attach_physical`.
IDENTIFY_METHODS = ("auto", "paper", "output_error", "sliding", "idim", "closed_loop")

#: Largest sample time (s) of a uniform record that ``"auto"`` treats as logged at the controller rate.
CONTROLLER_RATE_TS = 2e-3


def _physical_vector(model: RegressionModel, theta, Ts: float, names: tuple[str, ...]) -> np.ndarray:
    est = model.to_physical(theta, Ts)
    return np.array([getattr(est, n) for n in names])


def _physical_std(model: RegressionModel, u, w, ls: LSResult, names: tuple[str, ...]) -> dict:
    """Standard errors of physical parameters by the delta method (Ljung, Sec. 9.2).

    ``cov(theta) = s**2 (X^T X)^{-1}`` (SVD of the column-scaled X) is mapped
    through the numerical Jacobian ``G`` of ``theta -> physical``:
    ``cov(physical) = G cov(theta) G^T``.
    """
    X, y = model.regressors(u, w)
    n, p = X.shape
    scale = np.linalg.norm(X, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    _, s, Vt = np.linalg.svd(X / scale, full_matrices=False)
    s2 = float(np.sum((y - X @ ls.theta) ** 2)) / max(n - p, 1)
    cov = s2 * ((Vt.T / s**2) @ Vt) / np.outer(scale, scale)
    G = np.empty((len(names), p))
    for j in range(p):
        h = 1e-6 * max(abs(ls.theta[j]), 1e-12)
        tp, tm = ls.theta.copy(), ls.theta.copy()
        tp[j] += h
        tm[j] -= h
        G[:, j] = (_physical_vector(model, tp, ls.Ts, names) - _physical_vector(model, tm, ls.Ts, names)) / (2 * h)
    var = np.einsum("ij,jk,ik->i", G, cov, G)
    return {nm: float(math.sqrt(v)) if v >= 0 else float("nan") for nm, v in zip(names, var)}




def choose_method(data: MeasuredData, *, Vs: float | None, controller_Tc: float | None = None,
                  lag: bool = False, eq4_free_run: float | None = None) -> tuple[str, str]:
    """The identification method ``identify(method="auto")`` uses for a record, and why.

    Parameters
    ----------
    data : MeasuredData
        The record (``t`` in s).
    Vs : float or None
        The pre-fitted Stribeck velocity (rad/s), None if not given.
    controller_Tc : float or None, keyword-only
        The period (s) of the user's velocity controller when the controller (gains, limit) and the
        commanded velocity of the log are known; None (default) if not.
    lag : bool, keyword-only
        A friction lag is asked for (IDIM fits none). Default False.
    eq4_free_run : float or None, keyword-only
        The free-run fit (%) of the eq. 4 LS on the record (:attr:`adaptive_ff.identification.ls.LSResult.fit_free_run`;
        :func:`identify` passes it); None (default): not known, the record is taken as one the eq. 4 model
        simulates (an open-loop record).

    Returns
    -------
    method : str
        ``"idim"`` for a uniform record whose velocity was derived from a measured position
        (``data.w_from_position``: an encoder axis such as EMPS) when neither ``Vs`` nor ``lag`` is asked for:
        the inverse dynamic model (:mod:`adaptive_ff.identification.idim_method`), whose torque regression
        the log calls for; ``"paper"`` (eq. 4 LS) for any other record without ``Vs``; ``"sliding"`` for a
        uniform record at most :data:`CONTROLLER_RATE_TS` apart (a controller-rate log: torque and measured
        velocity as the controller had them) when ``Vs`` is known (:func:`identify` replaces it by
        ``"output_error"`` where the sliding regression's own simulation-extrapolation finds J or tau biased
        by the record's noise and the torque does not follow the velocity noise: an open-loop record); ``"closed_loop"`` for any other record read out slower than the controller
        (median interval above 1.5 ``controller_Tc``) when ``Vs`` and ``controller_Tc`` are known (the loop is
        simulated: :mod:`controllers.experiments.closed_loop_id`); for any other record with ``Vs``
        (slower than :data:`CONTROLLER_RATE_TS` or irregular) ``"output_error"``, unless ``eq4_free_run`` is
        below :data:`adaptive_ff.identification.identify_warnings.FREE_RUN_MIN` (50 %): then ``"paper"``, whose
        warning names the way out.
    reason : str
        One sentence for the report.

    Notes
    -----
    The sliding-regime inverse-dynamics regression
    (:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`) regresses the torque, which the
    controller knows exactly at its own rate, on filtered velocity signals (Gautier & Khalil; Janot et
    al., IEEE TCST 22(1), 2014): unbiased in closed loop. It needs the samples at the controller rate.
    On a slower or irregular readout the eq. 4 LS is biased (backward differences across the Stribeck
    hump at the resampled grid, velocity noise in its regressors: J, tau and Fs miss their 95 % intervals on
    most joints of ``benchmarks/coverage_zoo.py``), while the output-error fit simulates eqs. 1-3 on the
    record's own stamps and its bootstrap intervals cover (docs/benchmarks/identification.md). A record the
    eq. 4 model fits one step ahead but not in free run is the signature of a closed-loop log read out slower
    than its loop: the torque between two readouts is not in the log, which no method that reconstructs the
    input between readouts (eq. 4 or output error) can mend.
    """
    d = np.diff(data.t)
    med = float(np.median(d))
    uniform = bool(np.all(np.abs(d - med) <= 0.01 * med))
    if Vs is None and not lag and uniform and data.w_from_position:
        return "idim", (f"the velocity is the derivative of a measured position (samples {med * 1e3:.3g} ms apart) "
                        "and no Stribeck pre-fit or lag is asked for: the inverse dynamic model (IDIM-LS, the EMPS "
                        "benchmark's estimator) regresses the torque, the signal such a log measures best, on the "
                        "filtered, decimated acceleration and velocity")
    if Vs is None:
        return "paper", "no Stribeck pre-fit (Vs, delta) given: the eq. 4 LS of the paper"
    if uniform and med <= CONTROLLER_RATE_TS:
        return "sliding", (f"uniform samples {med * 1e3:.3g} ms apart (controller rate): the sliding-regime "
                           "inverse-dynamics regression, unbiased in closed loop")
    spacing = f"samples {med * 1e3:.3g} ms apart{'' if uniform else ' (irregular)'}"
    if controller_Tc is not None and med > 1.5 * controller_Tc:
        return "closed_loop", (f"{spacing}, slower than the controller period {controller_Tc * 1e3:.3g} ms, with the "
                               "reference and the controller given: the output-error fit that simulates the known "
                               "PI loop")
    if eq4_free_run is not None and eq4_free_run < FREE_RUN_MIN:
        return "paper", (f"{spacing}, and the eq. 4 model fits the record in free run by only {eq4_free_run:.1f} % "
                         f"(< {FREE_RUN_MIN:g} %): the signature of a closed-loop log read out slower than its loop, "
                         "whose torque between readouts is not in the log, so neither the eq. 4 LS nor the output-"
                         "error fit determines J and tau; the eq. 4 LS of the paper, with the warning that names the "
                         "way out (a controller-rate log, method 'sliding', or the reference and the controller, "
                         "method 'closed_loop')")
    run = "" if eq4_free_run is None else f" (the eq. 4 model runs freely: free-run fit {eq4_free_run:.1f} %)"
    return "output_error", (f"{spacing}, slower than the {CONTROLLER_RATE_TS * 1e3:g} ms the sliding regression needs "
                            f"or irregular, with the Stribeck pre-fit given{run}: the output-error fit of eqs. 1-3 "
                            "on the record's own stamps, the torque's delay to its stamps profiled where not given "
                            "(method_options input_delay); the eq. 4 LS is "
                            "biased on such a readout (differences across the Stribeck hump, velocity noise in its "
                            "regressors)")


def auto_methods(data: MeasuredData, *, Vs: float | None, lag: bool = False) -> tuple[str, ...]:
    """The methods ``identify(method="auto")`` may run on a record, in the order it runs them, known before any fit.

    Parameters
    ----------
    data : MeasuredData
        The record.
    Vs : float or None, keyword-only
        The pre-fitted Stribeck velocity (rad/s), None if not given.
    lag : bool, keyword-only
        A friction lag is asked for. Default False.

    Returns
    -------
    tuple of str
        ``(choose_method(...),)``, except for ``"sliding"`` on a record whose torque does not follow the velocity
        noise (:func:`adaptive_ff.identification.diagnostics.feedback_correlation` below
        :data:`adaptive_ff.identification.diagnostics.FEEDBACK_MIN` in magnitude: an open-loop record):
        ``("sliding", "output_error")``, since :func:`identify` replaces the sliding regression by the output-error
        fit there when the regression's own simulation-extrapolation finds J or tau biased, which only the fit tells.
        An upper bound of the work: a record slower than the controller rate is counted as ``"output_error"``
        (``identify`` takes the cheaper eq. 4 LS where its free-run fit is below 50 %, which needs that fit).
        Used by the CLI's work estimate (:func:`controllers.cli.budget.identify_estimate`).
    """
    method = choose_method(data, Vs=Vs, lag=lag)[0]
    if method != "sliding":
        return (method,)
    uni = to_uniform(data)
    return ("sliding",) if abs(feedback_correlation(uni.u, uni.w)) >= FEEDBACK_MIN else ("sliding", "output_error")


def _fit_sliding_physical(uni: MeasuredData, Vs: float, delta: float, offset: bool, options=None) -> PhysicalFit:
    """The sliding-regime regression on a uniform controller-rate record, as a :class:`PhysicalFit`.

    ``stderr`` is the residual block bootstrap of the regression rows
    (:func:`adaptive_ff.identification.uncertainty.regression_block_bootstrap`; ``n_bootstrap``, ``bootstrap_seed``
    of ``options``), the white OLS errors stay as ``info["stderr_ols"]`` (on a simulated 1 kHz PI log they put
    the true J 95 of them away)."""
    from adaptive_ff.compensation.sliding_estimator import (SlidingFrictionEstimatorConfig, estimate_from_theta,
                                                            fit_sliding, sliding_regressors)

    config = SlidingFrictionEstimatorConfig(Ts=uni.Ts, lag=True, offset=offset)
    f = fit_sliding(uni.u, uni.w, Tc=uni.Ts, Vs=Vs, delta=delta, config=config)
    X, y, *_ = sliding_regressors(uni.u, uni.w, Tc=uni.Ts, Vs=Vs, delta=delta, config=config)
    sv = np.linalg.svd(X / np.where(np.linalg.norm(X, axis=0) > 0, np.linalg.norm(X, axis=0), 1.0), compute_uv=False)
    e = f.estimate
    std = dict(zip(f.names, (float(x) for x in f.theta_std)))
    names = ("J", "Fc", "Fs", "sigma", "tau") + (("offset",) if offset else ())
    params = {k: float(getattr(e, k)) for k in names}
    ols = {k: std.get(k, float("nan")) for k in names}
    n, seed = _bootstrap_options(options)
    info = {"n_rows": f.n_rows, "n_gated": f.n_gated, "residual_rms": f.residual_rms, "Tc": uni.Ts, "J_alt": e.J_alt,
            "stderr_kind": "ols (white residuals)", "stderr_ols": ols}
    stderr = ols
    extra_warn = []
    if n > 0:
        phys = lambda th: estimate_from_theta(f.names, th, Vs, delta)  # noqa: E731
        unc = regression_block_bootstrap(X, y, f.theta, phys, names, w_max=float(np.max(np.abs(uni.w))),
                                         settings=BootstrapSettings(n=n, seed=seed))
        vec = lambda th: np.array([getattr(phys(th), k) for k in names])  # noqa: E731
        check = assess_model_error(X, y, f.theta, vec, names, base=unc,
                                   settings=ModelErrorSettings(level=float(unc.level), colour_reference="shared"),
                                   alternatives=(_stribeck_shape_alternative(uni, Vs, delta, offset, X, y, f.theta,
                                                                             vec),))
        unc = widened(unc, check)
        extra_warn = check.warnings("the sliding regression")
        stderr = dict(unc.stderr)
        info.update(stderr_kind=unc.kind, interval95={k: list(v) for k, v in unc.interval.items()},
                    bootstrap={"n": unc.n, "n_valid": unc.n_valid, "block": unc.block, "seed": unc.seed},
                    band=None if unc.band is None else unc.band.to_dict(), model_error=check.to_dict())
    return PhysicalFit(method="sliding", params=params, stderr=stderr,
                       cond=float(sv[0] / sv[-1]), nrmse=float(nrmse_fit(y, X @ f.theta)),
                       n_samples=int(uni.n_samples), nrmse_kind="filtered torque L[u]", info=info,
                       warnings=tuple(check_physical(params, source="sliding (fit_sliding)")) + tuple(extra_warn))


def _stribeck_shape_alternative(uni: MeasuredData, Vs: float, delta: float, offset: bool, X, y, theta, vec):
    """The sliding regression with the Stribeck shape freed to first order: the rows ``X`` with the derivatives of
    the fitted prediction ``X theta`` along ``log Vs`` and ``delta`` as two extra columns (central differences of
    the regressors at ``Vs (1 +- 1e-3)``, ``delta +- 1e-3``; the sliding gate does not depend on them), as an
    :class:`adaptive_ff.identification.model_error.Alternative`: where the log supports another shape than the
    pre-fit's, the Fc, Fs and sigma it moves are named (a pre-fit off by 1-2 % moved Fs by +0.5..+0.9 % and sigma
    by -0.3 % on 1 kHz PI logs, beyond their intervals)."""
    from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig, sliding_regressors
    from adaptive_ff.identification.model_error import Alternative

    def rows(v, d):
        return sliding_regressors(uni.u, uni.w, Tc=uni.Ts, Vs=v, delta=d,
                                  config=SlidingFrictionEstimatorConfig(Ts=uni.Ts, lag=True, offset=offset))[0]

    h = 1e-3
    cv = (rows(Vs * (1 + h), delta) - rows(Vs * (1 - h), delta)) @ theta / (2 * h)
    cd = (rows(Vs, delta + h) - rows(Vs, delta - h)) @ theta / (2 * h)
    p = X.shape[1]
    return Alternative("Stribeck shape other than the given Vs, delta", np.column_stack([X, cv, cd]), y, (p, p + 1),
                       lambda th: vec(th[:p]))


# one BLAS thread for the whole identification: OpenBLAS's threads spin between the small products of the eq. 4
# LS, the RLS pass and the checks, and against the output-error fit's simulation (measured on the 20 s log of
# benchmarks/output_error_speed.py: 0.5 s of CPU less for the command, its JSON the same)
@threadpool_limits.wrap(limits=1, user_api="blas")
def identify(data: MeasuredData, *, Vs: float | None = None, delta: float | None = None, lag: bool = False,
             offset: bool = True, lam: float = 1.0, P0: float = 1e4, n_history: int = 500,
             method: str = "auto", method_options: dict | None = None, form: str | None = None,
             form_options: dict | None = None) -> IdentificationReport:
    """Identify the joint model of eq. 4 from a measured record, offline (LS) and online (RLS).

    Parameters
    ----------
    data : MeasuredData
        Input ``u`` (N·m or N) and velocity ``w`` (rad/s or m/s). Resampled to a
        uniform grid first if its time stamps are not uniform within 1 %
        (:func:`adaptive_ff.io.data.to_uniform`; a note is added).
    Vs, delta : float, keyword-only, optional
        Pre-estimated Stribeck velocity (rad/s or m/s) and shape factor
        (Sec. V-C). Both given: Stribeck structure (separate Fc, Fs). Both
        omitted: Coulomb + viscous structure (``Fs = Fc``), for data that
        hardly excite the low-speed region (such as EMPS).
    lag : bool, keyword-only
        Fit the friction lag ``tau`` (eq. 2). Default False, measured to be
        better on EMPS (docs/benchmarks/emps.md).
    offset : bool, keyword-only
        Fit a constant torque/force bias. Default True (real data carry one).
    lam : float, keyword-only
        RLS forgetting factor in (0, 1] (eqs. 12-13). Default 1.
    P0 : float, keyword-only
        RLS initial covariance ``P0*I``, > 0 (RLS starts at ``theta = 0`` as in
        the paper). Default 1e4.
    n_history : int, keyword-only
        At most this many rows of RLS history are kept (>= 2). Default 500.
    method : str, keyword-only
        One of :data:`IDENTIFY_METHODS`. ``"auto"`` (default, as the CLI's ``--method``): the method of
        :func:`choose_method` (named in the notes and in ``physical.info["auto_reason"]``): ``"idim"`` for a
        uniform log whose velocity comes from a measured position without ``Vs``/``lag``, ``"paper"`` for any
        other log without ``Vs``, ``"sliding"`` or ``"output_error"`` with ``Vs``. ``"paper"``: the eq. 4
        LS/RLS is the answer. ``"output_error"`` also fits the physical
        parameters of eqs. 1-3 by simulation-error minimisation on the record
        as measured (its own, possibly irregular, time stamps);
        ``"sliding"`` by the sliding-regime inverse-dynamics regression
        (:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`) on a
        uniform controller-rate record (closed loop); both store them in
        ``report.physical``, need ``Vs`` and ``delta``, and the eq. 4 LS/RLS
        still runs (the paper's baseline and the online estimate; its
        warnings then become ``"method"`` notes, the answer's own warnings
        stay). ``"idim"``: the inverse dynamic model (IDIM-LS, the torque regression of the EMPS
        benchmark; :mod:`adaptive_ff.identification.idim_method`), Coulomb + viscous without ``Vs``,
        ``delta`` or ``lag``, for a log whose velocity comes from a measured position.
        Where the eq. 4 LS, the sliding regression or the IDIM-LS is the answer, its 95 % intervals are
        widened where the model-error check finds model error, which then names the parameters in
        ``"model_form"`` warnings (:mod:`adaptive_ff.identification.model_error`).
    method_options : dict, keyword-only, optional
        Extra keyword options of :func:`adaptive_ff.identification.physical_id.fit_physical`; for ``"paper"``,
        ``"sliding"`` and ``"idim"`` (also when ``"auto"`` chooses them) ``n_bootstrap`` (replicates of the residual block bootstrap of the
        eq. 4 LS, integer >= 2, default 200; 0: none, the delta-method errors are reported) and
        ``bootstrap_seed`` (integer >= 0, default 0) (:func:`adaptive_ff.identification.uncertainty.eq4_block_bootstrap`).
    form : str or None, keyword-only
        Model-form selection (:func:`adaptive_ff.identification.model_forms.select_form`). None (default):
        none, the structure is the one given (``Vs``, ``delta``, ``lag``). ``"auto"``: the candidate forms
        (Coulomb + viscous, Stribeck with the given ``Vs``, ``delta``, Stribeck with ``Vs``, ``delta`` fitted
        where the log allows; each with and without lag) are fitted by output error and the one chosen by
        blocked cross-validation (one-standard-error rule) is the answer (``physical``, method
        ``"output_error"``, or ``"sliding"`` with ``method="sliding"``: the sliding-regime regression); a name of :data:`adaptive_ff.identification.model_forms.FORMS` makes that
        candidate the answer. The table of candidates is :attr:`IdentificationReport.forms` (``to_dict()["forms"]``).
        Needs ``method`` ``"paper"``, ``"auto"``, ``"output_error"`` (all three: output error) or ``"sliding"``,
        and no ``method_options``.
    form_options : dict, keyword-only, optional
        Options of :func:`adaptive_ff.identification.model_forms.select_form`: ``folds``, ``criterion``,
        ``forms``, ``h_max``, ``input_delay``, ``predictor``, ``progress``.

    Returns
    -------
    IdentificationReport
        With :attr:`IdentificationReport.uncertainty` (standard errors, 95 % intervals, band of F(w)) when the
        eq. 4 LS is the answer.

    Raises
    ------
    TypeError
        ``data`` is not a :class:`MeasuredData`.
    ParameterError
        Only one of ``Vs``/``delta`` given, invalid ``Vs``/``delta``/``lam``/
        ``P0``/``n_history``, an unknown ``method``, or a ``method`` other than
        ``"paper"`` without ``Vs``/``delta``; an unknown ``form`` or ``form_options`` key, ``folds < 2``,
        ``form`` with ``method`` ``"closed_loop"`` or with ``method_options``, or a named form that could not
        be fitted on the record.
    SignalError
        Too few samples for the structure.
    ExcitationError
        The data do not excite every parameter (from :func:`adaptive_ff.identification.ls.fit_ls`);
        the message adds the causes found by
        :func:`adaptive_ff.identification.diagnostics.excitation_report` (e.g. no velocity
        reversals, so ``Fc`` cannot be told from the offset).

    Notes
    -----
    The RLS runs over the same regressor rows as the LS fit (Sec. IV-B). With
    ``lam = 1`` its final value is the ridge solution with weight ``1/P0``
    (see :class:`adaptive_ff.identification.rls.RecursiveLeastSquares`), i.e. the LS one up to
    that regularisation and rounding. On EMPS (``lag=False``) the ridge
    ``1/P0 = 1e-4`` moves J, sigma, Fc by at most 0.13 %. With ``lag=True`` it
    is not negligible: the lag columns are nearly collinear at Ts = 1 ms
    (cond 1e4), the tiny ``b1`` is weakly determined, and the default ``P0`` shrinks the RLS tau to
    about -0.001 s (LS: 0.0175 s); ``P0`` of 1e8-1e10 brings RLS within 4 % of
    LS there, larger values lose accuracy to rounding.
    """
    P0 = _check_identify_args(data, Vs, delta, n_history, P0, method if form is None else "paper", method_options,
                              lag)
    form_options = _check_form_args(form, form_options, method, method_options)
    auto_reason = None
    if form is not None:
        form_options.setdefault("method", "sliding" if method == "sliding" else "output_error")
        method = "paper"  # the eq. 4 LS/RLS baselines; the answer is the selected form's (below)
    stribeck = Vs is not None
    model = RegressionModel(Vs, delta, lag=lag, stribeck=stribeck, offset=offset)
    rls = RecursiveLeastSquares(model.n_params, lam=lam, P0=P0)
    notes = list(data.notes)
    uni = to_uniform(data)
    if uni is not data:
        notes.append(uni.notes[-1])
    Ts = uni.Ts
    u, w = uni.u, uni.w
    # Excitation first (Ljung 1999, Sec. 13.2): its causes explain a failing or a poor fit.
    excitation = excitation_report(u, w, Vs=Vs if stribeck else None)
    ls = _fit_ls_with_causes(model, u, w, Ts, excitation)
    std = _physical_std(model, u, w, ls, parameter_names(model))
    if method == "auto":
        method, auto_reason = choose_method(data, Vs=Vs, lag=lag, eq4_free_run=ls.fit_free_run)
    unc = _eq4_uncertainty(model, u, w, ls, method_options) if method == "paper" and form is None else None
    X, y = model.regressors(u, w)
    keep, hist = _rls_pass(rls, X, y, n_history)
    rls_theta = rls.theta.copy()
    rls_est = model.to_physical(rls_theta, Ts)
    rls_fit = nrmse_fit(y, X @ rls_theta)
    warn = ls_simex_judgment(list(excitation.warnings), model, u, w, Ts, ls, excitation.noise_std)
    warn += estimate_warnings(ls, rls_est, lag)
    if auto_reason is not None:
        notes.append(f"method {method!r} chosen automatically: {auto_reason}")
    notes.append(f"structure: {'Stribeck' if stribeck else 'Coulomb + viscous (Fs = Fc)'}, "
                 f"lag={lag}, offset={offset}; RLS lam = {rls.lam:g}, P0 = {P0:g}")
    low = ("" if not stribeck else
           f", {100 * excitation.low_speed_fraction:.2f} % of the samples in the Stribeck transition |w| < 3*Vs")
    notes.append(f"excitation: {excitation.n_reversals} velocity reversals, velocity noise "
                 f"{excitation.noise_std:.3g} {VELOCITY_LABEL} (robust, from third differences){low}")
    physical = None
    if method != "paper":
        physical, warn = _physical_answer(method, auto_reason, data, uni, Vs, delta, offset, method_options,
                                          excitation.noise_std, notes, warn)
        if physical is None:  # 'sliding' chosen automatically but not possible: the eq. 4 LS answers
            unc = _eq4_uncertainty(model, u, w, ls, method_options)
    if physical is None and unc is not None:
        notes += [unc.note(), unc.model_error.note()]
        warn += unc.model_error.warnings("the eq. 4 LS")
    report = _report(ls, rls, rls_est, rls_fit, uni, keep, hist, std, P0, data, notes, warn, excitation, physical,
                     unc if physical is None else None)
    if form is not None:
        report = _attach_form(report, data, form, form_options, Vs, delta, offset)
    return with_steady_state_check(report, data)


def _physical_answer(method, auto_reason, data, uni, Vs, delta, offset, method_options, noise_std, notes,
                     warn) -> tuple:
    """The physical fit of ``method`` (not ``"paper"``) and the warnings of the report, its notes appended to
    ``notes``. ``(None, warn)`` where ``"sliding"`` was chosen automatically and the record has too few
    sliding rows (the eq. 4 LS answers). Where ``"sliding"`` was chosen automatically and its own
    simulation-extrapolation finds J or tau biased by the record's noise by more than 10 % and the log shows no
    feedback (:func:`adaptive_ff.identification.diagnostics.feedback_correlation` below
    :data:`adaptive_ff.identification.diagnostics.FEEDBACK_MIN` in magnitude: an open-loop record), the
    output-error fit answers instead (its residual is the velocity noise itself, not an error in its regressors)
    and the sliding fit's judgment becomes a ``"method"`` note. In a closed loop the sliding regression stays,
    with its warnings (the output-error fit of a 1 kHz PI log with 3e-3 rad/s noise gave J 4.9 [1.2, 8.6] and
    tau 0.0007 s for 4 and 0.02 s)."""
    if method == "sliding":
        try:
            physical = _fit_sliding_physical(uni, Vs, delta, offset, method_options)
        except ExcitationError as exc:
            if auto_reason is None:
                raise
            notes.append(f"method 'sliding' not possible ({exc}): the eq. 4 LS is the answer")
            return None, warn
        # judge J and tau in the band of the sliding regression, not sample to sample
        warn = [w for w in warn if not (w.code == "identifiability" and w.parameter == "J")]
        band = sliding_band_warnings(uni, Vs, delta, noise_std, physical)
        biased = [w for w in band if w.code == "identifiability"]  # J or tau moved by > 10 %: the switch below
        rho = feedback_correlation(uni.u, uni.w) if auto_reason is not None and biased else -1.0
        if auto_reason is None or not biased or abs(rho) >= FEEDBACK_MIN:
            notes.append(f"physical parameters by 'sliding' on {physical.info['n_rows']} sliding-regime rows "
                         f"({physical.info['n_gated']} near-zero-velocity rows gated out)")
            from dataclasses import replace  # the answer's own model_form warnings: not eq. 4 baselines

            physical = replace(physical, warnings=tuple(physical.warnings) + tuple(w for w in band
                                                                                  if w.code == "model_form"))
            return _with_auto_reason(physical, auto_reason, notes, warn + biased)
        named = " and ".join(sorted({w.parameter for w in biased}, key=("J", "tau").index))
        auto_reason += (f"; but on this record the sliding regression's own simulation-extrapolation moves {named} "
                        "by more than 10 % (the velocity noise in its filtered regressors biases it; the numbers "
                        "are in the 'method' warnings) and the torque does not follow the velocity noise (correlation "
                        f"of their third differences {rho:+.3f}: no feedback loop in the log, an open-loop record), "
                        "so the output-error fit of eqs. 1-3 answers instead")
        i = next(i for i, n in enumerate(notes) if n.startswith("method 'sliding' chosen automatically"))
        notes[i] = f"method 'output_error' chosen automatically: {auto_reason}"
        warn += [IdentificationWarning("method", w.parameter, f"sliding regression, not the answer: {w}")
                 for w in band]
        method = "output_error"
    if method == "idim":
        n_boot, seed = _bootstrap_options(method_options)
        physical = fit_idim_physical(uni, offset=offset, n_bootstrap=n_boot, seed=seed)
        notes.append(f"physical parameters by 'idim' (IDIM-LS, {IDIM_ESTIMATOR}) on {physical.info['n_rows']} "
                     f"rows decimated by {physical.info['decimate']}: force error "
                     f"{physical.info['force_error_percent']:.3f} %")
    else:
        physical = fit_physical(data.t, data.u, data.w, Vs=Vs, delta=delta, method=method, offset=offset,
                                **(method_options or {}))
        notes.append(f"physical parameters by {method!r} on the record's own time stamps "
                     f"({physical.n_samples} samples, fit {physical.nrmse_kind}); {stderr_note(physical)}")
        if method == "output_error":
            notes.append(input_delay_note(physical))
    return _with_auto_reason(physical, auto_reason, notes, warn)


def _with_auto_reason(physical: PhysicalFit, auto_reason, notes: list, warn: list) -> tuple:
    """``(physical, warnings)``: the eq. 4 warnings as baseline notes followed by the fit's own; the reason of
    ``"auto"`` in ``physical.info`` and the model-error note in ``notes``."""
    warn = [as_baseline(w) if w.code != "method" else w for w in warn] + list(physical.warnings)
    if auto_reason is not None:
        physical.info["auto_reason"] = auto_reason
    if physical.info.get("model_error"):
        notes.append(physical.info["model_error"]["note"])
    return physical, warn


def _check_form_args(form, form_options, method, method_options) -> dict:
    """The checks of ``identify(form=...)``; returns the options of ``select_form`` as a dict."""
    from adaptive_ff.identification.model_forms import FORMS

    if form is None:
        if form_options:
            raise ParameterError(f"form_options apply to a form selection: give form='auto' (got form_options = "
                                 f"{form_options!r})")
        return {}
    if not isinstance(form, str) or (form != "auto" and form not in FORMS):
        raise ParameterError(f"form must be 'auto' or one of {list(FORMS)}, got {form!r}")
    if method not in ("paper", "auto", "output_error", "sliding"):
        raise ParameterError(f"form {form!r} fits the candidate forms by output error (method 'paper', 'auto' or "
                             f"'output_error') or by the sliding regression (method 'sliding'), got {method!r}")
    if method_options:
        raise ParameterError(f"method_options do not apply to a form selection (its standard errors are the "
                             f"delete-a-block jackknife of the cross-validation); got {method_options!r}")
    if form_options is None:
        return {}
    if not isinstance(form_options, dict):
        raise ParameterError(f"form_options must be a dict, got {form_options!r}")
    allowed = ("folds", "criterion", "forms", "h_max", "input_delay", "predictor", "progress")
    unknown = sorted(set(form_options) - set(allowed))
    if unknown:
        raise ParameterError(f"unknown form_options {unknown}; allowed: {list(allowed)}")
    return dict(form_options)


def _attach_form(report: IdentificationReport, data, form: str, options: dict, Vs, delta,
                 offset: bool) -> IdentificationReport:
    """The report with the form selection's chosen (or named) candidate as its answer (method ``"output_error"``)."""
    from dataclasses import replace

    from adaptive_ff.identification.model_forms import select_form

    sel = select_form(data, Vs=Vs, delta=delta, offset=offset, **options)
    if form != "auto":
        c = sel.candidate(form)
        if not c.ok:
            raise ParameterError(f"form {form!r} was not fitted on this record: {c.status}")
        sel = replace(sel, chosen=form, rule=f"asked for by name (form={form!r}); {sel.rule}")
    b = sel.best
    keys = ("J", "Fc", "Fs", "sigma", "tau") + (("offset",) if offset else ())
    params = {k: float(b.params[k]) for k in keys}
    stderr = {k: float(b.stderr[k]) for k in keys if k in b.stderr}
    if b.stribeck == "none" and "Fc" in b.stderr:
        stderr["Fs"] = stderr["Fc"]  # Fs = Fc
    physical = PhysicalFit(method=sel.method, params=params, stderr=stderr, cond=float("nan"),
                           nrmse=float(b.fit_percent), n_samples=int(sel.n_samples), nrmse_kind=sel.predictor,
                           info={"form": b.name, "stderr_kind": "jackknife", "cv_rms": b.cv_rms, "rms": b.rms,
                                 "noise_std": sel.noise_std, "Vs": b.params.get("Vs"),
                                 "delta": b.params.get("delta"), "aic": b.aic, "bic": b.bic,
                                 "input_delay": sel.input_delay, "input_delay_profile": sel.input_delay_profile},
                           warnings=tuple(check_physical(params, source=f"form {b.name} (select_form)")))
    notes = list(report.notes) + [
        f"model form {b.label!r} ({b.name}, k = {b.n_params}) {'chosen' if form == 'auto' else 'asked for'} "
        f"among {sum(c.ok for c in sel.candidates)} fitted candidate forms by {sel.criterion} "
        f"({sel.folds} contiguous blocks): "
        + ("output-error fit on the record's own time stamps" if sel.method == "output_error" else
           "sliding-regime torque regression on the uniform grid") + ", standard errors the "
        "delete-a-block jackknife of the cross-validation refits"]
    if sel.input_delay is not None:
        notes.append(input_delay_note(physical))
    unfitted = {k for k in ("Fs", "tau", "Vs") if k not in b.fitted}
    warn = [_not_in_form(as_baseline(w), b, unfitted) for w in report.warnings] + list(physical.warnings)
    return replace(report, physical=physical, forms=sel, notes=tuple(notes), warnings=tuple(warn))


def _not_in_form(w, cand, unfitted: set):
    """A warning on a parameter the chosen form does not fit (Fs of Coulomb + viscous, tau without lag) as a
    ``"method"`` note: the selection answered it by leaving the parameter out."""
    if getattr(w, "parameter", None) in unfitted and w.code != "method":
        return IdentificationWarning("method", w.parameter, f"not fitted by the chosen form {cand.name!r}: {w}")
    return w


def attach_physical(report: IdentificationReport, physical: PhysicalFit, *, note: str,
                    auto_reason: str | None = None, data: MeasuredData | None = None) -> IdentificationReport:
    """The report with a physical fit computed outside :func:`identify` as its answer (e.g. ``"closed_loop"``).

    Parameters
    ----------
    report : IdentificationReport
        From :func:`identify` with ``method="paper"`` (the eq. 4 LS/RLS baseline).
    physical : PhysicalFit
        The fit that answers (e.g. :func:`controllers.experiments.closed_loop_id.fit_closed_loop`).
    note : str, keyword-only
        One line for the notes (how the fit was made).
    auto_reason : str or None, keyword-only
        Why ``"auto"`` chose this method (:func:`choose_method`); None if it was asked for by name.
    data : MeasuredData or None, keyword-only
        The log: the new answer is checked against its steady state
        (:func:`adaptive_ff.identification.steady_state_check.with_steady_state_check`); without
        it the check of the former answer is dropped.

    Returns
    -------
    IdentificationReport
        ``physical`` set; the eq. 4 warnings become ``"method"`` notes (the record's own excitation
        warnings stay), followed by the fit's own warnings, as for the methods :func:`identify` runs itself.

    Raises
    ------
    TypeError
        ``report`` or ``physical`` of the wrong type.
    """
    from dataclasses import replace

    if not isinstance(report, IdentificationReport) or not isinstance(physical, PhysicalFit):
        raise TypeError("attach_physical needs an IdentificationReport and a PhysicalFit, got "
                        f"{type(report).__name__} and {type(physical).__name__}")
    report = without_steady_state_check(report)
    notes = list(report.notes)
    if auto_reason is not None:
        notes.append(f"method {physical.method!r} chosen automatically: {auto_reason}")
    notes.append(note)
    warn = [as_baseline(w) for w in report.warnings] + list(physical.warnings)
    out = replace(report, physical=physical, notes=tuple(notes), warnings=tuple(warn))
    return out if data is None else with_steady_state_check(out, data)


def input_delay_note(fit: PhysicalFit) -> str:
    """How an output-error fit took the input's timing: one clause for the report's notes.

    Parameters
    ----------
    fit : PhysicalFit
        An output-error fit (``info["input_delay"]``, ``info["input_delay_profile"]``).

    Returns
    -------
    str
        E.g. ``"input delay 0.625 ms, profiled (cost 80.36 at 0 ms, 75.35 at 0.625 ms, ...; give it by
        method_options input_delay, CLI --input-delay)"`` or ``"input delay 0.5 ms, given"``.
    """
    d = fit.info.get("input_delay")
    prof = fit.info.get("input_delay_profile")
    if d is None:
        return "input delay: not reported"
    if not prof:
        return f"input delay {d * 1e3:.3g} ms, given"
    pts = ", ".join(f"{c:.4g} at {t * 1e3:.3g} ms" for t, c in sorted(zip(prof["delay"], prof["cost"])))
    return (f"input delay {d * 1e3:.3g} ms, profiled (each torque sample taken that long before its stamp; cost "
            f"{pts}; give it by method_options input_delay, CLI --input-delay)")


def stderr_note(fit: PhysicalFit) -> str:
    """What a physical fit's standard errors are: one clause for the report's notes.

    Parameters
    ----------
    fit : PhysicalFit
        A fit whose ``info["stderr_kind"]`` is ``"bootstrap"`` (with ``info["bootstrap"]``), ``"hac"`` or absent.

    Returns
    -------
    str
        E.g. ``"standard errors by a parametric block bootstrap (20 refits of re-simulated records, seed 0, ...)"``,
        with the input quantum of the bootstrap worlds and the profiled input delay's share where the output-error
        fit used them (:func:`adaptive_ff.identification.delay_profile.delay_spread`) and the intervals' centre;
        for HAC the caveat that they are too small on a rough free-run cost (Künsch 1989; Newey & West 1987:
        :mod:`adaptive_ff.identification.covariance`).
    """
    boot = fit.info.get("bootstrap")
    if fit.info.get("stderr_kind") == "bootstrap" and boot:
        delay = ("; the profiled input delay's share added in quadrature (the parameters refitted at its "
                 "neighbouring delays)") if boot.get("stderr_delay") else ""
        quantum = (f"; each world driven by the logged input plus a draw within half its {boot['input_quantum']:.4g} "
                   f"quantum") if boot.get("input_quantum") else ""
        return (f"standard errors by a parametric block bootstrap ({boot['n_valid']} refits of re-simulated "
                f"records, seed {boot['seed']}; options n_bootstrap, bootstrap_seed){quantum}{delay}; 95 % "
                f"intervals centred on the estimate less the refits' mean shift (info.bootstrap.bias)")
    if fit.info.get("stderr_kind") == "hac":
        return ("standard errors HAC (Newey-West, asymptotic; too small on the rough free-run cost, a lower "
                "bound: use n_bootstrap > 0)")
    return "standard errors as the method gives them"


def _report(ls, rls, rls_est, rls_fit, uni, keep, hist, std, P0, data, notes, warn, excitation, physical, unc=None):
    return IdentificationReport(
        ls=ls, rls_theta=rls.theta.copy(), rls_estimate=rls_est, rls_fit_percent=rls_fit,
        theta_time=uni.t[2:][keep].copy(), theta_history=hist, std=std, Ts=uni.Ts, lam=rls.lam,
        P0=P0, source=data.source, notes=tuple(notes), warnings=tuple(warn), excitation=excitation,
        physical=physical, uncertainty=unc)


#: Options of the eq. 4 bootstrap in ``method_options`` (method ``"paper"``).
_EQ4_BOOT_OPTIONS = ("n_bootstrap", "bootstrap_seed")


def _eq4_uncertainty(model, u, w, ls: LSResult, options) -> ParameterUncertainty | None:
    """The residual block bootstrap of the eq. 4 LS with ``n_bootstrap``/``bootstrap_seed`` of ``options``, its
    intervals widened where the model-error check finds model error
    (:func:`adaptive_ff.identification.model_error.eq4_model_error`); None for ``n_bootstrap = 0``. Options of
    other methods in ``options`` are left to them."""
    n, seed = _bootstrap_options(options)
    if n == 0:
        return None
    unc = eq4_block_bootstrap(model, u, w, ls.theta, ls.Ts, parameter_names(model),
                              settings=BootstrapSettings(n=n, seed=seed))
    return widened(unc, eq4_model_error(model, u, w, ls.theta, ls.Ts, parameter_names(model), unc))


def _bootstrap_options(options) -> tuple[int, int]:
    """``(n_bootstrap, bootstrap_seed)`` of ``options`` (defaults 200 and 0), checked; other keys ignored."""
    o = {k: v for k, v in (options or {}).items() if k in _EQ4_BOOT_OPTIONS}
    n, seed = o.get("n_bootstrap", DEFAULT_N_BOOTSTRAP), o.get("bootstrap_seed", 0)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0 or n == 1:
        raise ParameterError(f"n_bootstrap must be 0 (no bootstrap) or an integer >= 2, got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"bootstrap_seed must be an integer >= 0, got {seed!r}")
    return int(n), int(seed)


def _check_identify_args(data, Vs, delta, n_history, P0, method, method_options, lag=False) -> float:
    """The argument checks of :func:`identify` that need no computation; returns ``P0`` as a float."""
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    if (Vs is None) != (delta is None):
        raise ParameterError(f"give both Vs and delta for the Stribeck structure, or neither; "
                             f"got Vs = {Vs!r}, delta = {delta!r}")
    if isinstance(n_history, bool) or not isinstance(n_history, (int, np.integer)) or n_history < 2:
        raise ParameterError(f"n_history must be an integer >= 2, got {n_history!r}")
    P0 = check_positive("P0", P0)
    if method not in IDENTIFY_METHODS:
        raise ParameterError(f"method must be one of {IDENTIFY_METHODS}, got {method!r}")
    if method == "closed_loop":
        raise ParameterError("method 'closed_loop' simulates the user's controller: use "
                             "controllers.experiments.closed_loop_id.identify_closed_loop (CLI: identify "
                             "--reference-column NAME --controller controller.json)")
    if method == "idim" and (Vs is not None or lag):
        raise ParameterError(f"method 'idim' fits Coulomb + viscous friction without lag (u = J dw/dt + Fc sgn(w) + "
                             f"sigma w + offset): drop Vs, delta and lag, got Vs = {Vs!r}, lag = {lag!r}")
    if method == "sliding" and Vs is None:  # output_error without them fits Vs and delta (fit_physical)
        raise ParameterError(f"method {method!r} fits the Stribeck model of eqs. 1-3: give Vs and delta "
                             f"(pre-fit, Sec. V-C), got Vs = {Vs!r}, delta = {delta!r}")
    check_optional("method_options", method_options, dict)
    if method in ("paper", "sliding", "idim") and set(method_options or {}) - set(_EQ4_BOOT_OPTIONS):
        raise ParameterError(f"method {method!r} takes the options {list(_EQ4_BOOT_OPTIONS)}, got "
                             f"{sorted(method_options)}")
    return P0


def _fit_ls_with_causes(model, u, w, Ts, excitation) -> LSResult:
    """The paper's eq. 4 LS (eq. 9); an ExcitationError is extended by the excitation warnings."""
    try:
        return fit_ls(model, u, w, Ts=Ts)
    except ExcitationError as exc:
        if not excitation.warnings:
            raise
        raise ExcitationError(f"{exc}; cause: {'; '.join(excitation.warnings)}") from None


def _rls_pass(rls, X, y, n_history: int) -> tuple[np.ndarray, np.ndarray]:
    """Run ``rls`` over the regressor rows ``X``, ``y`` (Sec. IV-B); kept row indices and the theta history there."""
    n = X.shape[0]
    keep = np.unique(np.linspace(0, n - 1, min(n, n_history)).round().astype(int))
    hist = np.empty((keep.shape[0], X.shape[1]))
    j = 0
    for i in range(n):
        rls.update(X[i], y[i])
        if j < keep.shape[0] and i == keep[j]:
            hist[j] = rls.theta
            j += 1
    return keep, hist
