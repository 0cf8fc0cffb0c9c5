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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from adaptive_ff.io.data import MeasuredData, to_uniform
from adaptive_ff.io.units import PARAM_UNITS, VELOCITY_LABEL
from adaptive_ff.identification.diagnostics import ExcitationReport, excitation_report
from adaptive_ff.identification.idim import RigidAxisModel, idim_force_error
from adaptive_ff.identification.ls import LSResult, fit_ls
from adaptive_ff.identification.physical_id import METHODS, PhysicalFit, fit_physical
from adaptive_ff.identification.plausibility import IdentificationWarning, check_physical, warning_from_dict
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel, nrmse_fit
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.identification.steady_state_check import (SteadyStateCheck, with_steady_state_check,
                                                            without_steady_state_check)
from adaptive_ff.identification.uncertainty import (DEFAULT_N_BOOTSTRAP, ParameterUncertainty, eq4_block_bootstrap,
                                                    regression_block_bootstrap)
from plant.errors import ExcitationError, ParameterError, check_positive

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ff.identification.model_forms import FormSelection
from plant.results import axes_or_new, json_safe

__all__ = ["IdentificationReport", "identify", "PARAM_UNITS", "CrossValidation", "cross_validate", "stderr_note",
           "IDENTIFY_METHODS", "choose_method", "attach_physical"]

#: Methods of :func:`identify`: ``"auto"`` chooses among the others from the record (:func:`choose_method`).
#: ``"closed_loop"`` simulates the user's controller and lives in ``controllers``
#: (:func:`controllers.experiments.closed_loop_id.identify_closed_loop`), which attaches its fit to the report
#: of :func:`identify` by :func:`attach_physical`.
IDENTIFY_METHODS = ("auto", "paper", "output_error", "sliding", "closed_loop")

#: Largest sample time (s) of a uniform record that ``"auto"`` treats as logged at the controller rate.
CONTROLLER_RATE_TS = 2e-3

#: Free-run fit (%) of the eq. 4 LS below which the dynamics (J, tau) are not determined by the record.
_FREE_RUN_MIN = 50.0

#: Condition number above which :func:`identify` adds a warning (fit_ls refuses above 1e10).
_COND_WARN = 1e6


def _warning_dict(w) -> dict:
    """JSON form of a warning (a plain str, from a report built by hand, as an identifiability warning)."""
    return (w if isinstance(w, IdentificationWarning) else warning_from_dict(str(w))).to_dict()


def _parameter_names(model: RegressionModel) -> tuple[str, ...]:
    """The physical parameters a structure identifies (Fs only with Stribeck, tau only with lag)."""
    return (("J", "sigma", "Fc") + (("Fs",) if model.stribeck else ()) + (("tau",) if model.lag else ())
            + (("offset",) if model.offset else ()))


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


@dataclass(frozen=True)
class IdentificationReport:
    """Result of :func:`identify`.

    The answer is the chosen method's (:attr:`method`): :attr:`params` (``J``, ``Fc``, ``Fs``, ``sigma``,
    ``tau``, ``offset``, also as attributes ``report.J`` ...), :attr:`stderr`, :attr:`Vs`, :attr:`delta` and
    :attr:`form` (the model fitted). The paper's eq. 4 LS and RLS are baselines (:attr:`baselines`; ``ls``,
    ``estimate``, ``rls_estimate``): with ``physical`` set they are *not* the answer (on a closed-loop
    log eq. 4 gave J 171.6 kg·m² for a joint of 4, the sliding-regime regression 4.1).

    Attributes
    ----------
    ls : LSResult
        Offline least-squares fit (eq. 9): theta, standard errors, fits, estimate.
    rls_theta : ndarray, shape (p,)
        Final RLS parameter vector (names in ``ls.model.names``).
    rls_estimate : FrictionEstimate
        Physical parameters of ``rls_theta``.
    rls_fit_percent : float
        One-step-ahead NRMSE fit (%) of ``rls_theta`` on the whole record.
    theta_time : ndarray, shape (M,)
        Time (s) of the output sample after which each history row was taken.
    theta_history : ndarray, shape (M, p)
        RLS estimate over time, decimated to at most ``n_history`` rows.
    std : dict
        Standard errors of the LS physical parameters (same units), by the
        delta method from ``s**2 (X^T X)^{-1}``; they assume white equation
        error and so understate the uncertainty on real (coloured) data
        (ten-fold on EMPS): the reported ones are :attr:`stderr`.
    Ts : float
        Sample time (s) used.
    lam, P0 : float
        RLS forgetting factor and initial covariance scale.
    source : str
        Where the data came from.
    notes : tuple of str
        Preprocessing and choices (from the data and from :func:`identify`).
    warnings : tuple of IdentificationWarning
        Signs of a poor or implausible identification (empty if none), each a
        str with a ``code`` and the ``parameter`` it concerns
        (:mod:`adaptive_ff.identification.plausibility`): one ``"implausible"``
        warning per LS, RLS or physical-method value that violates eqs. 1-3
        (``J > 0``; ``tau, sigma, Fc, Fs >= 0``), plus the excitation warnings of
        :func:`adaptive_ff.identification.diagnostics.excitation_report` that name the
        parameter the record does not excite and why.
    excitation : ExcitationReport or None
        Noise level, velocity reversals and low-speed fraction of the record
        (None only for reports built by hand).
    physical : PhysicalFit or None
        The physical parameters by the method asked for
        (:func:`adaptive_ff.identification.physical_id.fit_physical`, e.g. ``"output_error"``:
        unbiased where eq. 4 is not); None for ``method="paper"``, where the
        eq. 4 LS (``ls``, ``estimate``) is the answer.
    forms : FormSelection or None
        The model-form selection (``identify(form=...)``,
        :func:`adaptive_ff.identification.model_forms.select_form`): every candidate form and the chosen one,
        whose output-error fit is then ``physical``; None without it.
    steady_state : SteadyStateCheck or None
        The answer's friction curve against the log's own steady-state support points
        (:func:`adaptive_ff.identification.steady_state_check.steady_state_check`; its line is among the notes, and
        a ``"model_form"`` warning when it flags the answer); None when the log has too few support points.
    uncertainty : ParameterUncertainty or None
        The residual block bootstrap of the eq. 4 LS (:func:`adaptive_ff.identification.uncertainty.eq4_block_bootstrap`):
        standard errors, 95 % intervals and the friction band when the eq. 4 LS is the answer; None otherwise
        or with ``n_bootstrap = 0``.
    """

    ls: LSResult
    rls_theta: np.ndarray
    rls_estimate: FrictionEstimate
    rls_fit_percent: float
    theta_time: np.ndarray
    theta_history: np.ndarray
    std: dict
    Ts: float
    lam: float
    P0: float
    source: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)
    warnings: tuple[str, ...] = field(default_factory=tuple)
    excitation: ExcitationReport | None = None
    physical: PhysicalFit | None = None
    forms: "FormSelection | None" = None
    uncertainty: ParameterUncertainty | None = None
    steady_state: SteadyStateCheck | None = None

    @property
    def model(self) -> RegressionModel:
        """The fitted regression structure."""
        return self.ls.model

    @property
    def estimate(self) -> FrictionEstimate:
        """Physical parameters of the eq. 4 LS fit: the baseline, the answer only for ``method == "paper"``
        (the answer is :attr:`params`)."""
        return self.ls.estimate

    @property
    def method(self) -> str:
        """The method whose parameters are the answer: ``physical.method``, or ``"paper"`` (eq. 4 LS)."""
        return self.physical.method if self.physical is not None else "paper"

    @property
    def params(self) -> dict:
        """The answer: ``{"J": kg·m², "Fc": N·m, "Fs": N·m, "sigma": N·m·s/rad, "tau": s, "offset": N·m}`` of the
        chosen method (:attr:`method`); ``Fs = Fc`` for the Coulomb structure, ``tau = 0`` without lag,
        ``offset = 0`` without offset."""
        if self.physical is not None:
            return {k: float(self.physical.params.get(k, 0.0)) for k in _ANSWER_KEYS}
        e = self.estimate
        return {k: float(getattr(e, k)) for k in _ANSWER_KEYS}

    @property
    def stderr(self) -> dict:
        """Standard errors of the fitted :attr:`params` (same keys and units; NaN where the method gives none):
        the method's own (``physical.stderr``: bootstrap, HAC or regression errors, ``physical.info``), or for
        ``"paper"`` the residual block bootstrap of the eq. 4 LS (:attr:`uncertainty`; the delta-method errors
        ``std`` only with ``n_bootstrap = 0``)."""
        if self.physical is not None:
            return {k: float(v) for k, v in self.physical.stderr.items()}
        if self.uncertainty is not None:
            return dict(self.uncertainty.stderr)
        return dict(self.std)

    @property
    def stderr_kind(self) -> str:
        """What :attr:`stderr` is: ``"residual block bootstrap"``, ``"delta method (white equation error)"``, or
        the physical method's ``info["stderr_kind"]`` (``"method"`` if it names none)."""
        if self.physical is not None:
            return str(self.physical.info.get("stderr_kind", "method"))
        return self.uncertainty.kind if self.uncertainty is not None else "delta method (white equation error)"

    @property
    def interval95(self) -> dict:
        """Nominal 95 % intervals ``{name: (low, high)}`` of the fitted parameters: the bootstrap's
        (:attr:`uncertainty`, or the physical method's ``info["interval95"]``), else ``value ± 1.96 stderr``."""
        if self.physical is None and self.uncertainty is not None and self.uncertainty.level == 0.95:
            return dict(self.uncertainty.interval)
        info = self.physical.info if self.physical is not None else {}
        iv = info.get("interval95") or (info.get("bootstrap") or {}).get("interval95")
        if iv:
            return {k: (float(v[0]), float(v[1])) for k, v in iv.items()}
        vals = self.params
        return {k: (vals[k] - _Z95 * s, vals[k] + _Z95 * s) for k, s in self.stderr.items() if k in vals}

    @property
    def band(self):
        """The 95 % band of the friction curve F(w) (:class:`adaptive_ff.identification.uncertainty.FrictionBand`):
        the eq. 4 bootstrap's or the physical method's (``info["band"]``, as a dict); None without one."""
        if self.physical is None:
            return None if self.uncertainty is None else self.uncertainty.band
        return self.physical.info.get("band")

    @property
    def Vs(self) -> float | None:
        """Stribeck velocity (rad/s or m/s) of the fitted model, fixed by the pre-fit; None without Stribeck.
        With a form selection (:attr:`forms`): the chosen form's (fitted for the free Stribeck forms; the given
        one, without effect since ``Fs = Fc``, for Coulomb + viscous)."""
        if self.forms is not None and self.forms.best.stribeck == "free":
            return self.forms.best.params["Vs"]
        return self.model.Vs if self.model.stribeck else None

    @property
    def delta(self) -> float | None:
        """Stribeck shape factor of the fitted model, fixed by the pre-fit; None without Stribeck (as :attr:`Vs`)."""
        if self.forms is not None and self.forms.best.stribeck == "free":
            return self.forms.best.params["delta"]
        return self.model.delta if self.model.stribeck else None

    @property
    def J(self) -> float:
        """Inertia (kg·m²) of the chosen method (:attr:`params`)."""
        return self.params["J"]

    @property
    def Fc(self) -> float:
        """Coulomb level (N·m) of the chosen method."""
        return self.params["Fc"]

    @property
    def Fs(self) -> float:
        """Stiction level (N·m) of the chosen method."""
        return self.params["Fs"]

    @property
    def sigma(self) -> float:
        """Viscous coefficient (N·m·s/rad) of the chosen method."""
        return self.params["sigma"]

    @property
    def tau(self) -> float:
        """Friction lag (s) of the chosen method."""
        return self.params["tau"]

    @property
    def offset(self) -> float:
        """Constant torque bias (N·m) of the chosen method (0 if not fitted)."""
        return self.params["offset"]

    @property
    def form(self) -> dict:
        """The model the chosen method fitted (strict JSON).

        Returns
        -------
        dict
            ``name`` (e.g. ``"lagged Stribeck"``, ``"Coulomb + viscous"``), ``equations`` (the paper's),
            ``stribeck``, ``lag``, ``offset`` (bool), ``fitted`` (names of the fitted parameters), ``fixed``
            (``{"Vs", "delta"}`` from the Stribeck pre-fit; empty without Stribeck), ``constrained``
            (``{"Fs": "Fc"}`` for the Coulomb structure, ``{"tau": 0.0}`` without lag, ``{"offset": 0.0}``
            without offset) and ``estimator`` (the function that fitted it).
        """
        m = self.model
        if self.forms is not None:
            return _selected_form(self.forms, m, self.physical)
        fixed = {"Vs": m.Vs, "delta": m.delta} if m.stribeck else {}
        if self.physical is not None:
            fitted = [k for k in _ANSWER_KEYS if k in self.physical.params]
            lag, stribeck, offset = "tau" in fitted, True, "offset" in fitted
            equations = "eqs. 1-3"
            estimator = _ESTIMATORS.get(self.method, _ESTIMATORS["output_error"])
        else:
            fitted = list(_parameter_names(m))
            lag, stribeck, offset = m.lag, m.stribeck, m.offset
            equations = "eq. 4 regression of eqs. 1-3, LS of eq. 9"
            estimator = "adaptive_ff.identification.ls.fit_ls"
        constrained = {}
        if not stribeck:
            constrained["Fs"] = "Fc"
        if not lag:
            constrained["tau"] = 0.0
        if not offset:
            constrained["offset"] = 0.0
        name = ("lagged " if lag else "") + ("Stribeck" if stribeck else "Coulomb + viscous")
        return json_safe({"name": name, "equations": equations, "stribeck": stribeck, "lag": lag, "offset": offset,
                          "fitted": fitted, "fixed": fixed, "constrained": constrained, "estimator": estimator})

    @property
    def baselines(self) -> dict:
        """The paper's eq. 4 estimates beside the answer: ``{"eq4_ls": {...}, "eq4_rls": {...}}`` as in
        :meth:`to_dict` (J, sigma, Fc, Fs, tau, offset; the LS with ``std``, ``rel_std``, fits, ``cond``, ``Ts``;
        the RLS with ``fit_percent``, ``lam``, ``P0``)."""
        e, r = self.estimate, self.rls_estimate
        ls = {k: getattr(e, k) for k in _ANSWER_KEYS}
        ls.update(std=dict(self.std), rel_std=_relative(self.std, ls), fit_percent=self.ls.fit_one_step,
                  fit_free_run_percent=self.ls.fit_free_run, cond=self.ls.cond, Ts=self.Ts)
        rls = {k: getattr(r, k) for k in _ANSWER_KEYS}
        rls.update(fit_percent=self.rls_fit_percent, lam=self.lam, P0=self.P0)
        return json_safe({"eq4_ls": ls, "eq4_rls": rls})

    def rigid_axis_model(self) -> RigidAxisModel:
        """The LS estimate as a :class:`adaptive_ff.identification.idim.RigidAxisModel` (Coulomb + viscous + offset).

        Returns
        -------
        RigidAxisModel
            ``J, sigma, Fc, offset`` of the LS fit; a fitted ``Fs`` (Stribeck
            structure) and ``tau`` (lag) are not part of that model and are dropped.

        Raises
        ------
        ParameterError
            The estimate is not physical (``J <= 0``, ``sigma < 0`` or ``Fc < 0``).
        """
        e = self.estimate
        return RigidAxisModel.symmetric(e.J, e.sigma, e.Fc, e.offset)

    def to_dict(self) -> dict:
        """Strict-JSON summary of the identification (the CLI's JSON output): the chosen method at the top.

        Returns
        -------
        dict
            ``method`` (:attr:`method`), ``form`` (:attr:`form`: the model fitted), the answer ``J, Fc, Fs,
            sigma, tau, offset`` (SI units; :attr:`params`), ``Vs`` and ``delta`` (for the Stribeck structure,
            fixed by the pre-fit), ``std`` (standard errors of the fitted parameters, :attr:`stderr`) and
            ``rel_std`` (in % of the value), ``fit_percent`` with ``fit_kind`` (which prediction),
            ``cond``, ``n_samples``, ``Ts`` (the uniform grid of the record); for ``"paper"`` also
            ``fit_free_run_percent``, for other methods ``info`` (the method's details, e.g. the bootstrap);
            ``baselines`` (:attr:`baselines`: ``eq4_ls`` and ``eq4_rls``, the paper's eq. 4 values, never the
            answer unless ``method`` is ``"paper"``); ``excitation`` (``noise_std``, ``n_reversals``,
            ``low_speed_fraction``), ``warnings`` (list of ``{"code", "parameter", "message"}``) and
            ``notes`` (list of str, as printed by :meth:`summary`). Non-finite values become ``None``.
            :func:`adaptive_ff.identification.result_file.read_identification` reads it back (and older files,
            whose top level was the eq. 4 LS with the answer under ``physical.params``).
        """
        params = self.params
        out = {"method": self.method, "form": self.form, **params}
        if self.Vs is not None:
            out["Vs"] = self.Vs
            out["delta"] = self.delta
        std = self.stderr
        out["std"] = std
        out["rel_std"] = _relative(std, params)
        out["std_kind"] = self.stderr_kind
        out["interval95"] = {k: list(v) for k, v in self.interval95.items()}
        if self.physical is None:
            out["std_delta"] = dict(self.std)
            out["uncertainty"] = None if self.uncertainty is None else self.uncertainty.to_dict()
        band = self.band
        out["band"] = band.to_dict() if hasattr(band, "to_dict") else band
        if self.physical is not None:
            ph = self.physical
            out.update(fit_percent=ph.nrmse, fit_kind=ph.nrmse_kind, cond=ph.cond, n_samples=ph.n_samples,
                       Ts=self.Ts, info=ph.info)
        else:
            out.update(fit_percent=self.ls.fit_one_step, fit_kind="one-step",
                       fit_free_run_percent=self.ls.fit_free_run, cond=self.ls.cond,
                       n_samples=int(self.ls.w_one_step.shape[0]), Ts=self.Ts)
        out["baselines"] = self.baselines
        if self.forms is not None:
            out["forms"] = self.forms.to_dict()
        out["steady_state"] = None if self.steady_state is None else self.steady_state.to_dict()
        if self.excitation is not None:
            x = self.excitation
            out["excitation"] = {"noise_std": x.noise_std, "n_reversals": int(x.n_reversals),
                                 "low_speed_fraction": x.low_speed_fraction}
        out["warnings"] = [_warning_dict(w) for w in self.warnings]
        out["notes"] = [str(n) for n in self.notes]
        return json_safe(out)

    def to_json_dict(self) -> dict:
        """The same as :meth:`to_dict` (the name the CLI uses)."""
        return self.to_dict()

    def plot(self, ax=None, *, band_ax=None):
        """Convergence of the RLS (paper Fig. 5) and, beside it, the 95 % band of the friction curve F(w).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes of the RLS convergence; default a new figure, with a second axes for the band when the report
            has one (:attr:`band`).
        band_ax : matplotlib.axes.Axes, optional, keyword-only
            Axes of the band when ``ax`` is given (default: the band is not drawn then).

        Returns
        -------
        matplotlib.axes.Axes
            The RLS axes: time (s) against ``theta_RLS(t)/theta_LS`` per regression parameter (1 = the LS
            value); parameters whose LS value is 0 are left out. Its figure holds the band's axes
            (:meth:`adaptive_ff.identification.uncertainty.FrictionBand.plot`: fitted curve and shaded band).
        """
        band = self.band
        if isinstance(band, dict):
            from adaptive_ff.identification.uncertainty import FrictionBand

            band = FrictionBand(**{k: np.asarray(v, dtype=float) if isinstance(v, list) else v
                                   for k, v in band.items()})
        if ax is None and band is not None:
            from matplotlib.figure import Figure

            ax, band_ax = Figure(figsize=(12.0, 4.0), layout="constrained").subplots(1, 2)
        ax = axes_or_new(ax)
        if band is not None and band_ax is not None:
            band.plot(band_ax)
        for i, name in enumerate(self.model.names):
            ref = self.ls.theta[i]
            if ref != 0.0:
                ax.plot(self.theta_time, self.theta_history[:, i] / ref, lw=0.9, label=name)
        ax.axhline(1.0, color="0.5", lw=0.6, ls="--")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("RLS estimate / LS estimate (-)")
        ax.set_title(f"RLS convergence (lam = {self.lam:g}), {self.source or 'measured data'}")
        ax.legend(loc="best", ncol=2)
        ax.grid(True, alpha=0.3)
        return ax

    def summary(self) -> str:
        """Human-readable report: the chosen method's parameters first, then the eq. 4 LS/RLS baselines.

        Returns
        -------
        str
            A header naming the method and the model fitted (:attr:`form`); the answer's table (parameter,
            value, std error, unit; for ``"paper"`` with the RLS column); its fit; for another method the
            table of the baselines (``baselines: ...``, eq. 4 LS with std error and RLS); notes and warnings.
        """
        m = self.model
        f = self.form
        fixed = ", ".join(f"{k} fixed" for k in f["fixed"])
        lines = [f"Identification of {self.source or 'measured data'}",
                 f"method {self.method!r}: {f['name']} ({f['equations']}; {f['estimator']}), fitted "
                 f"{', '.join(f['fitted'])}" + (f"; {fixed} (Stribeck pre-fit)" if fixed else ""), ""]
        if self.forms is not None:
            lines[-1:] = ["", self.forms.summary(), ""]
        if self.physical is not None:
            ph = self.physical
            lines += [f"{'parameter':<10}{'value':>14}{'std error':>13}  unit", "-" * 70]
            for nm, v in ph.params.items():
                lines.append(f"{nm:<10}{v:>14.6g}{ph.stderr.get(nm, float('nan')):>13.3g}  {PARAM_UNITS[nm]}")
            lines += _fixed_rows(m, "") if self.forms is None else _form_rows(self.forms, m)
            lines += ["-" * 70, f"fit ({ph.nrmse_kind}) {ph.nrmse:.3f} %, cond {ph.cond:.3g}, "
                                f"{ph.n_samples} samples",
                      f"std errors: {self.stderr_kind}; 95 % intervals: " + ", ".join(
                          f"{k} [{lo:.6g}, {hi:.6g}]" for k, (lo, hi) in self.interval95.items()),
                      "", f"baselines: the paper's eq. 4 LS (eq. 9) and RLS (eqs. 10-13), not the answer; "
                          f"model: {m!r}, Ts = {self.Ts:.6g} s, {self.ls.w_one_step.shape[0]} samples"]
        else:
            lines[-1:] = [f"model: {m!r}, Ts = {self.Ts:.6g} s, {self.ls.w_one_step.shape[0]} samples", ""]
        e, r = self.estimate, self.rls_estimate
        std = self.std if self.physical is not None or self.uncertainty is None else self.uncertainty.stderr
        lines += [f"{'parameter':<10}{'value':>14}{'std error':>13}{'RLS':>14}  unit", "-" * 70]
        for nm in _parameter_names(m):
            lines.append(f"{nm:<10}{getattr(e, nm):>14.6g}{std[nm]:>13.3g}{getattr(r, nm):>14.6g}"
                         f"  {PARAM_UNITS[nm]}")
        if self.physical is None:
            lines += _fixed_rows(m, f"{'':>14}")
        lines += ["-" * 70,
                  f"fit one-step {self.ls.fit_one_step:.3f} %, free-run {self.ls.fit_free_run:.2f} %, "
                  f"RLS one-step {self.rls_fit_percent:.3f} % (lam = {self.lam:g}), cond {self.ls.cond:.3g}",
                  "relative std errors: " + ", ".join(
                      f"{nm} {100 * std[nm] / abs(getattr(e, nm)):.3g} %" if getattr(e, nm) != 0 else f"{nm} n/a"
                      for nm in _parameter_names(m))]
        lines += self._uncertainty_lines()
        lines += [f"note: {n}" for n in self.notes]
        lines += [f"WARNING [{getattr(w, 'code', 'note')}: {getattr(w, 'parameter', 'all')}]: {w}"
                  for w in self.warnings]
        return "\n".join(lines)


    def _uncertainty_lines(self) -> list:
        """What the std errors of the eq. 4 table are, and the 95 % intervals of the answer."""
        if self.physical is not None or self.uncertainty is None:
            return ["eq. 4 std errors assume white equation error (optimistic on real data)"]
        u = self.uncertainty
        return [f"std errors: {u.kind} ({u.n_valid} refits, blocks of {u.block} samples; see the note); "
                "white-noise delta-method ones (std_delta): "
                + ", ".join(f"{k} {v:.3g}" for k, v in self.std.items()),
                f"{100 * u.level:g} % intervals: " + ", ".join(f"{k} [{lo:.6g}, {hi:.6g}]"
                                                                for k, (lo, hi) in u.interval.items())]


#: The answer's keys, in the order of :attr:`IdentificationReport.params`.
_ANSWER_KEYS = ("J", "Fc", "Fs", "sigma", "tau", "offset")

#: Two-sided 95 % normal quantile (intervals of methods that give only a standard error).
_Z95 = 1.959963984540054

#: The function behind each method other than ``"paper"`` (the report's header and ``form["estimator"]``).
_ESTIMATORS = {"sliding": "adaptive_ff.compensation.sliding_estimator.fit_sliding",
               "closed_loop": "controllers.experiments.closed_loop_id.fit_closed_loop",
               "output_error": "adaptive_ff.identification.physical_id.fit_physical"}


def _selected_form(sel, m: RegressionModel, physical) -> dict:
    """The :attr:`IdentificationReport.form` of a form selection: the chosen candidate's model (strict JSON)."""
    b = sel.best
    offset = "offset" in b.fitted
    fixed = {"Vs": m.Vs, "delta": m.delta} if b.stribeck == "fixed" else {}
    constrained = {}
    if b.stribeck == "none":
        constrained["Fs"] = "Fc"
    if not b.lag:
        constrained["tau"] = 0.0
    if not offset:
        constrained["offset"] = 0.0
    name = ("lagged " if b.lag else "") + ("Coulomb + viscous" if b.stribeck == "none" else "Stribeck")
    return json_safe({"name": name, "equations": "eqs. 1-3", "stribeck": b.stribeck != "none", "lag": b.lag,
                      "offset": offset, "fitted": list(b.fitted), "fixed": fixed, "constrained": constrained,
                      "estimator": "adaptive_ff.identification.model_forms.select_form", "selected": b.name,
                      "label": b.label, "criterion": sel.criterion, "rule": sel.rule})


def _form_rows(sel, m: RegressionModel) -> list:
    """The Vs and delta rows of the chosen form: fixed (given), fitted (free Stribeck) or none."""
    b = sel.best
    if b.stribeck == "fixed":
        return _fixed_rows(m, "")
    if b.stribeck == "free":
        return [f"{'Vs':<10}{b.params['Vs']:>14.6g}{b.stderr.get('Vs', float('nan')):>13.3g}  {VELOCITY_LABEL}",
                f"{'delta':<10}{b.params['delta']:>14.6g}{b.stderr.get('delta', float('nan')):>13.3g}  -"]
    return []


def _relative(std: dict, values: dict) -> dict:
    """Standard errors in % of the value (None where the value is 0)."""
    return {k: 100.0 * v / abs(values[k]) if values.get(k) else None for k, v in std.items()}


def _fixed_rows(m: RegressionModel, pad: str) -> list:
    """The Vs and delta rows (fixed by the Stribeck pre-fit) of a summary table; none without Stribeck."""
    if not m.stribeck:
        return []
    return [f"{'Vs':<10}{m.Vs:>14.6g}{'(fixed)':>13}{pad}  {VELOCITY_LABEL}",
            f"{'delta':<10}{m.delta:>14.6g}{'(fixed)':>13}{pad}  -"]


def choose_method(data: MeasuredData, *, Vs: float | None, controller_Tc: float | None = None) -> tuple[str, str]:
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

    Returns
    -------
    method : str
        ``"sliding"`` for a uniform record at most :data:`CONTROLLER_RATE_TS` apart (a controller-rate
        log: torque and measured velocity as the controller had them) when ``Vs`` is known;
        ``"closed_loop"`` for any other record read out slower than the controller (median interval above
        1.5 ``controller_Tc``) when ``Vs`` and ``controller_Tc`` are known (the loop is simulated:
        :mod:`controllers.experiments.closed_loop_id`); ``"paper"`` otherwise (eq. 4 LS).
    reason : str
        One sentence for the report.

    Notes
    -----
    The sliding-regime inverse-dynamics regression
    (:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`) regresses the torque, which the
    controller knows exactly at its own rate, on filtered velocity signals (Gautier & Khalil; Janot et
    al., IEEE TCST 22(1), 2014): unbiased in closed loop. It needs the samples at the controller rate.
    """
    d = np.diff(data.t)
    med = float(np.median(d))
    uniform = bool(np.all(np.abs(d - med) <= 0.01 * med))
    if Vs is None:
        return "paper", "no Stribeck pre-fit (Vs, delta) given: the eq. 4 LS of the paper"
    if uniform and med <= CONTROLLER_RATE_TS:
        return "sliding", (f"uniform samples {med * 1e3:.3g} ms apart (controller rate): the sliding-regime "
                           "inverse-dynamics regression, unbiased in closed loop")
    if controller_Tc is not None and med > 1.5 * controller_Tc:
        return "closed_loop", (f"samples {med * 1e3:.3g} ms apart{'' if uniform else ' (irregular)'}, slower than "
                               f"the controller period {controller_Tc * 1e3:.3g} ms, with the reference and the "
                               "controller given: the output-error fit that simulates the known PI loop")
    return "paper", (f"samples {med * 1e3:.3g} ms apart{'' if uniform else ' (irregular)'}: the eq. 4 LS of the "
                     "paper; a closed-loop drive identifies best from its controller-rate log (method 'sliding') "
                     "or, read out slower, with its reference and controller (method 'closed_loop'), an open-loop "
                     "record by method 'output_error'")


def _fit_sliding_physical(uni: MeasuredData, Vs: float, delta: float, offset: bool, options=None) -> PhysicalFit:
    """The sliding-regime regression on a uniform controller-rate record, as a :class:`PhysicalFit`.

    ``stderr`` is the residual block bootstrap of the regression rows
    (:func:`adaptive_ff.identification.uncertainty.regression_block_bootstrap`; ``n_bootstrap``, ``bootstrap_seed``
    of ``options``), the white OLS errors stay as ``info["stderr_ols"]`` (on a simulated 1 kHz PI log they put
    the true J 95 of them away)."""
    from adaptive_ff.compensation.sliding_estimator import estimate_from_theta, fit_sliding, sliding_regressors

    f = fit_sliding(uni.u, uni.w, Tc=uni.Ts, Vs=Vs, delta=delta, lag=True, offset=offset)
    X, y, *_ = sliding_regressors(uni.u, uni.w, Tc=uni.Ts, Vs=Vs, delta=delta, lag=True, offset=offset)
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
    if n > 0:
        unc = regression_block_bootstrap(X, y, f.theta, lambda th: estimate_from_theta(f.names, th, Vs, delta), names,
                                         w_max=float(np.max(np.abs(uni.w))), Vs=Vs, delta=delta, n=n, seed=seed)
        stderr = dict(unc.stderr)
        info.update(stderr_kind=unc.kind, interval95={k: list(v) for k, v in unc.interval.items()},
                    bootstrap={"n": unc.n, "n_valid": unc.n_valid, "block": unc.block, "seed": unc.seed},
                    band=None if unc.band is None else unc.band.to_dict())
    return PhysicalFit(method="sliding", params=params, stderr=stderr,
                       cond=float(sv[0] / sv[-1]), nrmse=float(nrmse_fit(y, X @ f.theta)),
                       n_samples=int(uni.n_samples), nrmse_kind="filtered torque L[u]", info=info,
                       warnings=tuple(check_physical(params, source="sliding (fit_sliding)")))


def identify(data: MeasuredData, *, Vs: float | None = None, delta: float | None = None, lag: bool = False,
             offset: bool = True, lam: float = 1.0, P0: float = 1e4, n_history: int = 500,
             method: str = "paper", method_options: dict | None = None, form: str | None = None,
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
        One of :data:`IDENTIFY_METHODS`. ``"paper"`` (default): the eq. 4
        LS/RLS is the answer. ``"output_error"`` also fits the physical
        parameters of eqs. 1-3 by simulation-error minimisation on the record
        as measured (its own, possibly irregular, time stamps);
        ``"sliding"`` by the sliding-regime inverse-dynamics regression
        (:func:`adaptive_ff.compensation.sliding_estimator.fit_sliding`) on a
        uniform controller-rate record (closed loop); both store them in
        ``report.physical``, need ``Vs`` and ``delta``, and the eq. 4 LS/RLS
        still runs (the paper's baseline and the online estimate; its
        warnings then become ``"method"`` notes, the answer's own warnings
        stay). ``"auto"``: the method of :func:`choose_method` (named in the notes).
    method_options : dict, keyword-only, optional
        Extra keyword options of :func:`adaptive_ff.identification.physical_id.fit_physical`; for ``"paper"``
        (also when ``"auto"`` chooses it) ``n_bootstrap`` (replicates of the residual block bootstrap of the
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
        ``forms``, ``h_max``, ``input_delay``, ``predictor``.

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
    P0 = _check_identify_args(data, Vs, delta, n_history, P0, method if form is None else "paper", method_options)
    form_options = _check_form_args(form, form_options, method, method_options)
    auto_reason = None
    if form is not None:
        form_options.setdefault("method", "sliding" if method == "sliding" else "output_error")
        method = "paper"  # the eq. 4 LS/RLS baselines; the answer is the selected form's (below)
    if method == "auto":
        method, auto_reason = choose_method(data, Vs=Vs)
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
    std = _physical_std(model, u, w, ls, _parameter_names(model))
    unc = _eq4_uncertainty(model, u, w, ls, method_options) if method == "paper" and form is None else None
    X, y = model.regressors(u, w)
    keep, hist = _rls_pass(rls, X, y, n_history)
    rls_theta = rls.theta.copy()
    rls_est = model.to_physical(rls_theta, Ts)
    rls_fit = nrmse_fit(y, X @ rls_theta)
    warn = _ls_simex_judgment(list(excitation.warnings), model, u, w, Ts, ls, excitation.noise_std)
    warn += _estimate_warnings(ls, rls_est, lag)
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
        if method == "sliding":
            try:
                physical = _fit_sliding_physical(uni, Vs, delta, offset, method_options)
            except ExcitationError as exc:
                if auto_reason is None:
                    raise
                notes.append(f"method 'sliding' not possible ({exc}): the eq. 4 LS is the answer")
                unc = _eq4_uncertainty(model, u, w, ls, method_options)
                notes += [] if unc is None else [unc.note()]
                return with_steady_state_check(_report(ls, rls, rls_est, rls_fit, uni, keep, hist, std, P0, data,
                                                       notes, warn, excitation, None, unc), data)
            notes.append(f"physical parameters by 'sliding' on {physical.info['n_rows']} sliding-regime rows "
                         f"({physical.info['n_gated']} near-zero-velocity rows gated out)")
        else:
            physical = fit_physical(data.t, data.u, data.w, Vs=Vs, delta=delta, method=method, offset=offset,
                                    **(method_options or {}))
            notes.append(f"physical parameters by {method!r} on the record's own time stamps "
                         f"({physical.n_samples} samples, fit {physical.nrmse_kind}); {stderr_note(physical)}")
        if method == "sliding":  # judge J and tau in the band of the sliding regression, not sample to sample
            warn = [w for w in warn if not (w.code == "identifiability" and w.parameter == "J")]
            warn += _sliding_band_warnings(uni, Vs, delta, excitation.noise_std, physical)
        warn = [_as_baseline(w) for w in warn] + list(physical.warnings)
    if physical is None and unc is not None:
        notes.append(unc.note())
    report = _report(ls, rls, rls_est, rls_fit, uni, keep, hist, std, P0, data, notes, warn, excitation, physical,
                     unc if physical is None else None)
    if form is not None:
        report = _attach_form(report, data, form, form_options, Vs, delta, offset)
    return with_steady_state_check(report, data)


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
    allowed = ("folds", "criterion", "forms", "h_max", "input_delay", "predictor")
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
                                 "delta": b.params.get("delta"), "aic": b.aic, "bic": b.bic},
                           warnings=tuple(check_physical(params, source=f"form {b.name} (select_form)")))
    notes = list(report.notes) + [
        f"model form {b.label!r} ({b.name}, k = {b.n_params}) {'chosen' if form == 'auto' else 'asked for'} "
        f"among {sum(c.ok for c in sel.candidates)} fitted candidate forms by {sel.criterion} "
        f"({sel.folds} contiguous blocks): "
        + ("output-error fit on the record's own time stamps" if sel.method == "output_error" else
           "sliding-regime torque regression on the uniform grid") + ", standard errors the "
        "delete-a-block jackknife of the cross-validation refits"]
    unfitted = {k for k in ("Fs", "tau", "Vs") if k not in b.fitted}
    warn = [_not_in_form(_as_baseline(w), b, unfitted) for w in report.warnings] + list(physical.warnings)
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
    warn = [_as_baseline(w) for w in report.warnings] + list(physical.warnings)
    out = replace(report, physical=physical, notes=tuple(notes), warnings=tuple(warn))
    return out if data is None else with_steady_state_check(out, data)


def stderr_note(fit: PhysicalFit) -> str:
    """What a physical fit's standard errors are: one clause for the report's notes.

    Parameters
    ----------
    fit : PhysicalFit
        A fit whose ``info["stderr_kind"]`` is ``"bootstrap"`` (with ``info["bootstrap"]``), ``"hac"`` or absent.

    Returns
    -------
    str
        E.g. ``"standard errors by a parametric block bootstrap (20 refits of re-simulated records, seed 0, ...)"``;
        for HAC the caveat that they are too small on a rough free-run cost (Künsch 1989; Newey & West 1987:
        :mod:`adaptive_ff.identification.covariance`).
    """
    boot = fit.info.get("bootstrap")
    if fit.info.get("stderr_kind") == "bootstrap" and boot:
        return (f"standard errors by a parametric block bootstrap ({boot['n_valid']} refits of re-simulated "
                f"records, seed {boot['seed']}; options n_bootstrap, bootstrap_seed)")
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
    """The residual block bootstrap of the eq. 4 LS with ``n_bootstrap``/``bootstrap_seed`` of ``options``;
    None for ``n_bootstrap = 0``. Options of other methods in ``options`` are left to them."""
    n, seed = _bootstrap_options(options)
    if n == 0:
        return None
    return eq4_block_bootstrap(model, u, w, ls.theta, ls.Ts, _parameter_names(model), n=n, seed=seed)


def _bootstrap_options(options) -> tuple[int, int]:
    """``(n_bootstrap, bootstrap_seed)`` of ``options`` (defaults 200 and 0), checked; other keys ignored."""
    o = {k: v for k, v in (options or {}).items() if k in _EQ4_BOOT_OPTIONS}
    n, seed = o.get("n_bootstrap", DEFAULT_N_BOOTSTRAP), o.get("bootstrap_seed", 0)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0 or n == 1:
        raise ParameterError(f"n_bootstrap must be 0 (no bootstrap) or an integer >= 2, got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"bootstrap_seed must be an integer >= 0, got {seed!r}")
    return int(n), int(seed)


def _check_identify_args(data, Vs, delta, n_history, P0, method, method_options) -> float:
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
    if method in ("output_error", "sliding") and Vs is None:
        raise ParameterError(f"method {method!r} fits the Stribeck model of eqs. 1-3: give Vs and delta "
                             f"(pre-fit, Sec. V-C), got Vs = {Vs!r}, delta = {delta!r}")
    if method_options is not None and not isinstance(method_options, dict):
        raise ParameterError(f"method_options must be a dict, got {method_options!r}")
    if method in ("paper", "sliding") and set(method_options or {}) - set(_EQ4_BOOT_OPTIONS):
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


def _ls_simex_judgment(warn: list, model, u, w, Ts: float, ls: LSResult, noise_std: float) -> list:
    """Replace the sample-to-sample J warning of the excitation report by a judgment in the band of eq. 4.

    :func:`adaptive_ff.identification.diagnostics.excitation_report` warns when the velocity changes no more
    than its noise from sample to sample. Whether that biases J (and tau) depends on the band the LS of eq. 4
    uses; the simulation-extrapolation refit (:func:`_simex_median_change`) measures it on this record: the
    warning is kept, with the number, only if J (or tau) moves by more than 10 %.
    """
    j_warn = [x for x in warn if x.code == "identifiability" and x.parameter == "J"]
    if not j_warn or not noise_std > 0:
        return warn
    rest = [x for x in warn if x not in j_warn]
    names = ("J", "tau") if model.lag else ("J",)
    ref = {k: getattr(ls.estimate, k) for k in names}
    ch = _simex_median_change(lambda ww: fit_ls(model, u, ww, Ts=Ts).estimate, np.asarray(w, dtype=float),
                              noise_std, ref)
    if ch is None:
        return warn
    return rest + [_simex_warning(k, c, noise_std, "the eq. 4 regression") for k, c in ch.items() if c > _SIMEX_MAX]


def _sliding_band_warnings(uni: MeasuredData, Vs: float, delta: float, noise_std: float, fit: PhysicalFit) -> list:
    """J and tau identifiability of the sliding regression, judged in its own band by simulation-extrapolation.

    The record is refitted with seeded white noise of its own estimated level ``noise_std`` added to the
    velocity (variance doubled). Errors-in-variables bias grows about linearly with the noise variance, so
    the change of a parameter between the two fits estimates the bias the present noise causes (SIMEX:
    Cook & Stefanski, JASA 89(428), 1994). A median change over :data:`_SIMEX_REPS` seeds above
    :data:`_SIMEX_MAX` (10 %) means the parameter is not recovered within 10 % from data of this rate,
    noise and excitation, and gives an ``"identifiability"`` warning with the number.
    """
    from adaptive_ff.compensation.sliding_estimator import fit_sliding

    if not noise_std > 0:
        return []
    ch = _simex_median_change(lambda ww: fit_sliding(uni.u, ww, Tc=uni.Ts, Vs=Vs, delta=delta).estimate, uni.w,
                              noise_std, {k: fit.params[k] for k in ("J", "tau")})
    if ch is None:
        return [IdentificationWarning("identifiability", "J", "the sliding regression fails when the record's "
                                      "own noise level is added once more: J and tau are not identifiable")]
    return [_simex_warning(k, c, noise_std, "the sliding regression") for k, c in ch.items() if c > _SIMEX_MAX]


def _as_baseline(w):
    """An eq. 4 LS/RLS warning as a ``"method"`` note when another method gives the answer (excitation kept)."""
    if w.code == "identifiability" and not w.startswith(("redundant inertia", "the eq. 4 model")):
        return w  # the record's own excitation: it concerns every method
    return IdentificationWarning("method", w.parameter, f"eq. 4 baseline, not the answer: {w}")


def _estimate_warnings(ls: LSResult, rls_est: FrictionEstimate, lag: bool) -> list:
    """Typed warnings about implausible estimates, weak excitation and an unsupported lag (one per parameter)."""
    names = _parameter_names(ls.model)
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
    if ls.fit_free_run < _FREE_RUN_MIN:
        warn.append(IdentificationWarning(
            "identifiability", "J",
            f"the eq. 4 model fits one step ahead ({ls.fit_one_step:.1f} %) but not in free run "
            f"({ls.fit_free_run:.1f} % < {_FREE_RUN_MIN:g} %): the record does not determine the dynamics (J, tau); "
            "typical of a closed-loop log read out slower than the loop: log torque and velocity at the "
            "controller rate (method 'sliding'), or give the commanded velocity and the controller "
            "(identify --reference-column NAME --controller controller.json, or --Kp --Ki --Tc --u-max; "
            "with --Vs, --delta: method 'closed_loop')"))
    return warn


@dataclass(frozen=True)
class CrossValidation:
    """How an identified model predicts another record (:func:`cross_validate`).

    Attributes
    ----------
    fit_one_step : float
        One-step-ahead NRMSE fit (%) of the LS eq. 4 model on the record.
    fit_free_run : float
        Free-run (simulation) NRMSE fit (%) of the LS eq. 4 model.
    idim_force_error : float or None
        Relative force error (%) of the inverse dynamic model ``J*dw/dt +
        Fc*sgn(w) + sigma*w + offset`` (:func:`adaptive_ff.identification.idim.idim_force_error`) of the
        eq. 4 LS estimate, or of the chosen form's answer for a report with a form selection;
        None if the estimate is not physical.
    decimate : int
        Decimation used for ``idim_force_error``.
    n_samples : int
        Samples of the record (after resampling, if any).
    source : str
        The record's source.
    """

    fit_one_step: float
    fit_free_run: float
    idim_force_error: float | None
    decimate: int
    n_samples: int
    source: str

    def to_dict(self) -> dict:
        """Strict-JSON dict: ``fit_percent, fit_free_run_percent, idim_force_error_percent, decimate, n_samples,
        source`` (NaN/inf as None)."""
        return json_safe({"fit_percent": self.fit_one_step, "fit_free_run_percent": self.fit_free_run,
                          "idim_force_error_percent": self.idim_force_error, "decimate": int(self.decimate),
                          "n_samples": int(self.n_samples), "source": self.source})

    def to_json_dict(self) -> dict:
        """The same as :meth:`to_dict` (the name the CLI uses)."""
        return self.to_dict()

    def summary(self) -> str:
        """One line: the fits and the inverse-dynamics force error on the validation record."""
        fe = "n/a" if self.idim_force_error is None else f"{self.idim_force_error:.3f} %"
        return (f"cross-validation on {self.source or 'a record'} ({self.n_samples} samples): fit one-step "
                f"{self.fit_one_step:.3f} %, free-run {self.fit_free_run:.2f} %, inverse-dynamics force error {fe} "
                f"(decimation {self.decimate})")


def cross_validate(report: IdentificationReport, data: MeasuredData, *, decimate: int | None = None
                   ) -> CrossValidation:
    """Judge an identified model on a record it was not fitted to.

    Parameters
    ----------
    report : IdentificationReport
        Result of :func:`identify` on the estimation record.
    data : MeasuredData
        Validation record: ``t`` (s), ``u`` (N·m or N), ``w`` (rad/s or m/s),
        shape (N,), at the same sample time as the estimation record (within
        1 %; resampled first if its stamps jitter, as in :func:`identify`).
    decimate : int or None, keyword-only
        Decimation of the inverse-dynamics force error. Default: the
        benchmark's 10 at 1 kHz scaled to the sample time,
        ``max(1, round(0.01/Ts))`` (i.e. down to about 100 Hz).

    Returns
    -------
    CrossValidation

    Raises
    ------
    TypeError
        Wrong argument types.
    ParameterError
        The sample times differ by more than 1 %, or ``decimate`` invalid.

    Notes
    -----
    Cross-validation on fresh data (Ljung, *System Identification*, 2nd ed.,
    Sec. 16.5): one-step and free-run fits of eq. 4 as in :func:`identify`,
    and the EMPS benchmark's inverse-model force error (Janot, Gautier,
    Brunot, 2019; 5.98 % for its reference model on ``DATA_EMPS_PULSES.mat``).
    For EMPS records, :func:`adaptive_ff.identification.emps_validation.validate_emps` adds
    the closed-loop re-simulation.
    """
    if not isinstance(report, IdentificationReport):
        raise TypeError(f"report must be an IdentificationReport, got {type(report).__name__}")
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    uni = to_uniform(data)
    if abs(uni.Ts - report.Ts) > 0.01 * report.Ts:
        raise ParameterError(f"validation record sample time {uni.Ts:.6g} s differs from the estimation "
                             f"record's {report.Ts:.6g} s by more than 1 %")
    q = max(1, int(round(0.01 / uni.Ts))) if decimate is None else decimate
    m, theta = report.model, report.ls.theta
    w_one = m.predict(theta, uni.u, uni.w)
    w_free = m.simulate(theta, uni.u, uni.w[:2])
    try:
        rigid = (report.rigid_axis_model() if report.forms is None else  # the chosen form's (Fs, tau dropped)
                 RigidAxisModel.symmetric(report.J, report.sigma, report.Fc, report.offset))
        fe = idim_force_error(rigid, uni, decimate=q)
    except ParameterError:
        fe = None
    return CrossValidation(fit_one_step=nrmse_fit(uni.w[2:], w_one[2:]),
                           fit_free_run=nrmse_fit(uni.w[2:], w_free[2:]), idim_force_error=fe, decimate=int(q), n_samples=uni.n_samples, source=data.source)
