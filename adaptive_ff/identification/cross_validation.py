"""Cross-validation of an identified model on a record it was not fitted to: :func:`cross_validate`.

The model of an :class:`adaptive_ff.identification.identification_report.IdentificationReport` predicts the
velocity of the validation record one step ahead and in free run (eq. 4, NRMSE fits; Ljung, *System
Identification*, 2nd ed., Sec. 16.5), and its inverse dynamic model gives the force error of the EMPS benchmark
(:func:`adaptive_ff.identification.idim.idim_force_error`); :class:`CrossValidation` holds the three figures.
"""

from __future__ import annotations

from dataclasses import dataclass

from adaptive_ff.io.data import MeasuredData, to_uniform
from adaptive_ff.identification.identification_report import IdentificationReport
from adaptive_ff.identification.idim import RigidAxisModel, idim_force_error
from adaptive_ff.identification.regression import nrmse_fit
from plant.errors import ParameterError
from plant.results import json_safe

__all__ = ["CrossValidation", "cross_validate"]


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
