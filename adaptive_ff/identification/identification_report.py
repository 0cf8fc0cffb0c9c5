"""The result of :func:`adaptive_ff.identification.identify.identify`: :class:`IdentificationReport`.

The report holds the chosen method's answer (:attr:`IdentificationReport.params`, its standard errors,
95 % intervals and the band of the friction curve) beside the paper's eq. 4 LS (eq. 9) and RLS (eqs. 10-13)
baselines, the model fitted (:attr:`IdentificationReport.form`), the notes and the warnings; it writes them as
strict JSON (:meth:`IdentificationReport.to_dict`, read back by
:func:`adaptive_ff.identification.result_file.read_identification`), as text
(:meth:`IdentificationReport.summary`) and as a figure (:meth:`IdentificationReport.plot`).
:func:`parameter_names` names the physical parameters a regression structure identifies.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from adaptive_ff.io.units import PARAM_UNITS, VELOCITY_LABEL
from adaptive_ff.identification.diagnostics import ExcitationReport
from adaptive_ff.identification.idim import RigidAxisModel
from adaptive_ff.identification.ls import LSResult
from adaptive_ff.identification.physical_id import PhysicalFit
from adaptive_ff.identification.plausibility import IdentificationWarning, warning_from_dict
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.identification.steady_state_check import SteadyStateCheck
from adaptive_ff.identification.uncertainty import ParameterUncertainty

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ff.identification.model_forms import FormSelection
from plant.results import PhysicalParams, axes_or_new, json_safe

__all__ = ["IdentificationReport", "parameter_names"]


def _warning_dict(w) -> dict:
    """JSON form of a warning (a plain str, from a report built by hand, as an identifiability warning)."""
    return (w if isinstance(w, IdentificationWarning) else warning_from_dict(str(w))).to_dict()


def parameter_names(model: RegressionModel) -> tuple[str, ...]:
    """The physical parameters a regression structure identifies (Fs only with Stribeck, tau only with lag).

    Parameters
    ----------
    model : RegressionModel
        The eq. 4 structure (:class:`adaptive_ff.identification.regression.RegressionModel`); only its flags
        ``stribeck``, ``lag`` and ``offset`` are read.

    Returns
    -------
    tuple of str
        ``("J", "sigma", "Fc")``, then ``"Fs"`` for the Stribeck structure, ``"tau"`` with the friction lag and
        ``"offset"`` with the constant torque bias: the rows of the report's eq. 4 table, in that order (units
        in :data:`adaptive_ff.io.units.PARAM_UNITS`: kg·m², N·m·s/rad, N·m, N·m, s, N·m).

    Raises
    ------
    AttributeError
        ``model`` has no ``stribeck``, ``lag`` or ``offset`` attribute (it is not a regression structure).
    """
    return (("J", "sigma", "Fc") + (("Fs",) if model.stribeck else ()) + (("tau",) if model.lag else ())
            + (("offset",) if model.offset else ()))


@dataclass(frozen=True)
class IdentificationReport(PhysicalParams):
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
        The residual block bootstrap of the eq. 4 LS (:func:`adaptive_ff.identification.uncertainty.eq4_block_bootstrap`),
        its intervals widened where the model-error check finds model error (its ``model_error``,
        :mod:`adaptive_ff.identification.model_error`): standard errors, 95 % intervals and the friction band when
        the eq. 4 LS is the answer; None otherwise or with ``n_bootstrap = 0``.
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
        (:attr:`uncertainty`, or the physical method's ``info["interval95"]``), else ``value ± 1.96 stderr``
        (with ``Vs`` and ``delta`` where the output-error fit fits them: its HAC errors)."""
        if self.physical is None and self.uncertainty is not None and self.uncertainty.level == 0.95:
            return dict(self.uncertainty.interval)
        info = self.physical.info if self.physical is not None else {}
        iv = info.get("interval95") or (info.get("bootstrap") or {}).get("interval95")
        if iv:
            return {k: (float(v[0]), float(v[1])) for k, v in iv.items()}
        vals = self.params
        if self.physical is not None:  # Vs and delta too where output error fits them
            vals = {**vals, **{k: float(v) for k, v in self.physical.params.items() if k in ("Vs", "delta")}}
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
        if self.physical is not None and "Vs" in self.physical.params:  # fitted by output error (no pre-fit)
            return self.physical.params["Vs"]
        return self.model.Vs if self.model.stribeck else None

    @property
    def delta(self) -> float | None:
        """Stribeck shape factor of the fitted model, fixed by the pre-fit; None without Stribeck (as :attr:`Vs`)."""
        if self.forms is not None and self.forms.best.stribeck == "free":
            return self.forms.best.params["delta"]
        if self.physical is not None and "delta" in self.physical.params:
            return self.physical.params["delta"]
        return self.model.delta if self.model.stribeck else None

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
            (``{"Vs", "delta"}`` from the Stribeck pre-fit; empty without Stribeck, and where output error
            fitted Vs and delta, which are then in ``fitted``), ``constrained``
            (``{"Fs": "Fc"}`` for the Coulomb structure, ``{"tau": 0.0}`` without lag, ``{"offset": 0.0}``
            without offset) and ``estimator`` (the function that fitted it).
        """
        m = self.model
        if self.forms is not None:
            return _selected_form(self.forms, m, self.physical)
        fixed = {"Vs": m.Vs, "delta": m.delta} if m.stribeck else {}
        if self.physical is not None and self.physical.method == "idim":
            fitted = [k for k in _ANSWER_KEYS if k in self.physical.info.get("fitted", ())]
            lag, stribeck, offset = False, False, "offset" in fitted
            equations = "IDIM: u = J dw/dt + Fc sgn(w) + sigma w + offset (eqs. 1, 3 with Fs = Fc, tau = 0)"
            estimator = _ESTIMATORS["idim"]
        elif self.physical is not None:
            fitted = [k for k in _ANSWER_KEYS + ("Vs", "delta") if k in self.physical.params]
            if "Vs" in fitted:  # output error without the pre-fit: Vs and delta fitted, none fixed
                fixed = {}
            lag, stribeck, offset = "tau" in fitted, True, "offset" in fitted
            equations = "eqs. 1-3"
            estimator = _ESTIMATORS.get(self.method, _ESTIMATORS["output_error"])
        else:
            fitted = list(parameter_names(m))
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
        """The LS estimate, or the answer of method ``"idim"``, as a
        :class:`adaptive_ff.identification.idim.RigidAxisModel` (Coulomb + viscous + offset).

        Returns
        -------
        RigidAxisModel
            ``J, sigma, Fc, offset`` of the IDIM-LS answer (method ``"idim"``), else of the eq. 4 LS fit; a fitted
            ``Fs`` (Stribeck structure) and ``tau`` (lag) are not part of that model and are dropped.

        Raises
        ------
        ParameterError
            The estimate is not physical (``J <= 0``, ``sigma < 0`` or ``Fc < 0``).
        """
        if self.method == "idim":  # the answer is this very model
            p = self.params
            return RigidAxisModel.symmetric(p["J"], p["sigma"], p["Fc"], p["offset"])
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
                if self.method == "idim" and nm in f["constrained"]:
                    continue  # Fs = Fc and tau = 0 by the structure: one line below
                unit = PARAM_UNITS.get(nm, VELOCITY_LABEL if nm == "Vs" else "-")  # Vs, delta: fitted by output error
                lines.append(f"{nm:<10}{v:>14.6g}{ph.stderr.get(nm, float('nan')):>13.3g}  {unit}")
            if self.method == "idim":
                lines.append("(" + ", ".join(f"{k} = {v}" for k, v in f["constrained"].items()) + ": not fitted)")
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
        for nm in parameter_names(m):
            lines.append(f"{nm:<10}{getattr(e, nm):>14.6g}{std[nm]:>13.3g}{getattr(r, nm):>14.6g}"
                         f"  {PARAM_UNITS[nm]}")
        if self.physical is None:
            lines += _fixed_rows(m, f"{'':>14}")
        lines += ["-" * 70,
                  f"fit one-step {self.ls.fit_one_step:.3f} %, free-run {self.ls.fit_free_run:.2f} %, "
                  f"RLS one-step {self.rls_fit_percent:.3f} % (lam = {self.lam:g}), cond {self.ls.cond:.3g}",
                  "relative std errors: " + ", ".join(
                      f"{nm} {100 * std[nm] / abs(getattr(e, nm)):.3g} %" if getattr(e, nm) != 0 else f"{nm} n/a"
                      for nm in parameter_names(m))]
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
               "idim": "adaptive_ff.identification.idim.fit_idim",
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
