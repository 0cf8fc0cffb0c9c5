"""The result objects of model-form selection (:func:`adaptive_ff.identification.model_forms.select_form`): one
candidate form with its fit and its out-of-sample error, and the selection with its table and figure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from adaptive_ff.io.units import VELOCITY_LABEL
from plant.errors import ParameterError, check_finite_scalar
from plant.results import axes_or_new, json_safe
from plant.stribeck_map import stribeck_shape

__all__ = ["FORMS", "FormCandidate", "FormSelection"]

#: Candidate forms, simplest first: ``name -> (label, stribeck, lag)``, ``stribeck`` one of ``"none"``
#: (``Fs = Fc``), ``"fixed"`` (given ``Vs``, ``delta``) or ``"free"`` (``Vs``, ``delta`` fitted).
FORMS = {
    "coulomb_viscous": ("Coulomb + viscous", "none", False),
    "coulomb_viscous_lag": ("Coulomb + viscous, lag", "none", True),
    "stribeck": ("Stribeck (given Vs, delta)", "fixed", False),
    "stribeck_lag": ("Stribeck (given Vs, delta), lag", "fixed", True),
    "stribeck_free": ("Stribeck (Vs, delta fitted)", "free", False),
    "stribeck_free_lag": ("Stribeck (Vs, delta fitted), lag", "free", True),
}


@dataclass(frozen=True)
class FormCandidate:
    """One candidate form of :func:`select_form` and how it did.

    Attributes
    ----------
    name : str
        Key of :data:`FORMS`, e.g. ``"coulomb_viscous_lag"``.
    label : str
        Human-readable form, e.g. ``"Coulomb + viscous, lag"``.
    stribeck : str
        ``"none"`` (``Fs = Fc``), ``"fixed"`` (given Vs, delta) or ``"free"`` (Vs, delta fitted).
    lag : bool
        Whether the lag ``tau`` of eq. 1 is fitted (else ``tau = 0``).
    status : str
        ``"fitted"``, or why not: ``"not identifiable from this log: ..."``, ``"needs Vs and delta ..."``,
        ``"fit failed: ..."``.
    n_params : int
        Number of fitted parameters ``k`` (offset included when fitted).
    params : dict
        ``J`` (kg·m²), ``Fc``, ``Fs`` (N·m), ``sigma`` (N·m·s/rad), ``tau`` (s), ``offset`` (N·m) and, for the
        Stribeck forms, ``Vs`` (rad/s) and ``delta``: the whole-record fit (``Fs = Fc`` for Coulomb + viscous,
        ``tau = 0`` without lag); empty if not fitted.
    stderr : dict
        Delete-a-block jackknife standard errors of the fitted parameters (module docstring); NaN if unknown.
    fitted : tuple of str
        Names of the fitted parameters.
    rms : float
        In-sample RMS velocity prediction error (rad/s) on the scored samples.
    fit_percent : float
        In-sample NRMSE fit (%) of the prediction.
    cv_mse : float
        Pooled held-out mean squared prediction error ((rad/s)²) over the blocks.
    cv_se : float
        Standard error of ``cv_mse``: ``std(mse_k, ddof=1)/sqrt(K)``.
    cv_fold_mse : tuple of float
        Held-out mean squared error of each block.
    aic, bic : float
        Information criteria (module docstring) of the whole-record fit.
    n_scored : int
        Samples whose prediction error is scored (after the burn-in).
    """

    name: str
    label: str
    stribeck: str
    lag: bool
    status: str
    n_params: int
    params: dict = field(default_factory=dict)
    stderr: dict = field(default_factory=dict)
    fitted: tuple = ()
    rms: float = math.nan
    fit_percent: float = math.nan
    cv_mse: float = math.nan
    cv_se: float = math.nan
    cv_fold_mse: tuple = ()
    aic: float = math.nan
    bic: float = math.nan
    n_scored: int = 0

    @property
    def ok(self) -> bool:
        """True if the form was fitted and cross-validated."""
        return self.status == "fitted" and math.isfinite(self.cv_mse)

    @property
    def cv_rms(self) -> float:
        """Root of :attr:`cv_mse` (rad/s)."""
        return math.sqrt(self.cv_mse) if math.isfinite(self.cv_mse) else math.nan

    def friction(self, w) -> np.ndarray:
        """The steady friction map ``F(w)`` (N·m) of the fitted form, offset included, at velocities ``w`` (rad/s).

        Raises
        ------
        ParameterError
            The form was not fitted.
        """
        if not self.params:
            raise ParameterError(f"form {self.name!r} was not fitted ({self.status})")
        p = self.params
        w = np.asarray(w, dtype=float)
        aw = np.abs(w)
        e = stribeck_shape(np.where(aw > 0, aw, 1.0), p["Vs"], p["delta"]) if self.stribeck != "none" else 0.0
        return np.sign(w) * (p["Fc"] + (p["Fs"] - p["Fc"]) * np.where(aw > 0, e, 1.0)) + p["sigma"] * w + p["offset"]

    def intervals(self, level: float = 0.95) -> dict:
        """Confidence intervals ``{name: (low, high)}`` of the fitted parameters from :attr:`stderr`.

        Parameters
        ----------
        level : float
            Coverage in (0, 1), default 0.95.

        Returns
        -------
        dict
            ``value -+ t * stderr`` with ``t`` the Student quantile of ``K - 1`` degrees of freedom (``K`` the
            number of cross-validation blocks: the jackknife's; Shao & Tu 1995, Sec. 2.4).

        Raises
        ------
        ParameterError
            ``level`` not in (0, 1).
        """
        from scipy.stats import t as student

        level = check_finite_scalar("level", level)
        if not 0.0 < level < 1.0:
            raise ParameterError(f"level must be in (0, 1), got {level!r}")
        q = float(student.ppf(0.5 + level / 2.0, max(len(self.cv_fold_mse) - 1, 1)))
        return {k: (self.params[k] - q * s, self.params[k] + q * s) for k, s in self.stderr.items()}

    def to_dict(self) -> dict:
        """Strict-JSON dict of every attribute (non-finite values as ``null``) plus ``cv_rms`` and ``ok``."""
        return json_safe({"name": self.name, "label": self.label, "stribeck": self.stribeck, "lag": self.lag,
                          "status": self.status, "n_params": int(self.n_params), "fitted": list(self.fitted),
                          "params": dict(self.params), "stderr": dict(self.stderr), "rms": self.rms,
                          "fit_percent": self.fit_percent, "cv_mse": self.cv_mse, "cv_se": self.cv_se,
                          "cv_rms": self.cv_rms, "cv_fold_mse": list(self.cv_fold_mse), "aic": self.aic,
                          "bic": self.bic, "n_scored": int(self.n_scored), "ok": self.ok})


@dataclass(frozen=True)
class FormSelection:
    """Result of :func:`select_form`: every candidate form and the chosen one.

    Attributes
    ----------
    candidates : tuple of FormCandidate
        In the order of :data:`FORMS` (only those asked for).
    chosen : str
        Name of the chosen form.
    criterion : str
        ``"cv"``, ``"aic"`` or ``"bic"`` (module docstring, "Selection rule").
    rule : str
        The rule in words, with its numbers.
    folds : int
        Number of cross-validation blocks.
    blocks : tuple of (int, int)
        ``(start, stop)`` sample indices of each block (half-open; they partition the record).
    method : str
        ``"output_error"``.
    predictor : str
        ``"free-run"`` or ``"one-step"``: the prediction whose error is judged.
    noise_std : float
        Velocity noise estimate of the record (rad/s).
    n_samples : int
        Samples of the record.
    w_range : (float, float)
        Smallest and largest measured velocity (rad/s): the range of :meth:`plot`.
    source : str
        The record's source.
    input_delay : float or None
        The input delay (s) of the output-error fits: the one given, or the one the profile chose; None for the
        sliding regression.
    input_delay_profile : dict or None
        Where the delay was profiled: ``delay`` (s) and ``cost`` of each point tried, ``chosen``, ``n_simulations``
        and ``form`` (the candidate refitted at each delay); else None.
    """

    candidates: tuple
    chosen: str
    criterion: str
    rule: str
    folds: int
    blocks: tuple
    method: str
    predictor: str
    noise_std: float
    n_samples: int
    w_range: tuple
    source: str = ""
    input_delay: float | None = None
    input_delay_profile: dict | None = None

    @property
    def best(self) -> FormCandidate:
        """The chosen :class:`FormCandidate`."""
        return next(c for c in self.candidates if c.name == self.chosen)

    def candidate(self, name: str) -> FormCandidate:
        """The candidate ``name``.

        Raises
        ------
        ParameterError
            No candidate of that name.
        """
        for c in self.candidates:
            if c.name == name:
                return c
        raise ParameterError(f"form must be one of {[c.name for c in self.candidates]}, got {name!r}")

    def to_dict(self) -> dict:
        """Strict JSON (``null`` for non-finite values): ``chosen``, ``criterion``, ``rule``, ``folds``,
        ``blocks``, ``method``, ``predictor``, ``noise_std``, ``n_samples``, ``w_range``, ``source``,
        ``input_delay``, ``input_delay_profile`` and ``candidates`` (list of :meth:`FormCandidate.to_dict`)."""
        return json_safe({"chosen": self.chosen, "criterion": self.criterion, "rule": self.rule,
                          "folds": int(self.folds), "blocks": [[int(a), int(b)] for a, b in self.blocks],
                          "method": self.method, "predictor": self.predictor, "noise_std": self.noise_std,
                          "n_samples": int(self.n_samples), "w_range": list(self.w_range), "source": self.source,
                          "input_delay": self.input_delay, "input_delay_profile": self.input_delay_profile,
                          "candidates": [c.to_dict() for c in self.candidates]})

    def to_json_dict(self) -> dict:
        """The same as :meth:`to_dict` (the name the CLI uses)."""
        return self.to_dict()

    def summary(self) -> str:
        """The table of candidates: parameters ``k``, in-sample RMS and fit, blocked-CV RMS with its standard
        error, AIC, BIC, status; the chosen form marked ``*`` and the rule below."""
        lines = [f"model forms of {self.source or 'the record'} ({self.n_samples} samples; {self.method}, "
                 f"{self.predictor} prediction error; blocked CV, {self.folds} contiguous blocks)",
                 f"  {'form':<34}{'k':>3}{'RMS in':>11}{'fit %':>8}{'CV RMS':>11}{'CV SE':>10}"
                 f"{'AIC':>12}{'BIC':>12}", "  " + "-" * 101]
        for c in self.candidates:
            mark = "*" if c.name == self.chosen else " "
            if c.status != "fitted":
                lines.append(f"{mark} {c.label:<34}{c.n_params:>3}  {c.status}")
                continue
            se_rms = c.cv_se / (2.0 * c.cv_rms) if c.cv_rms > 0 else math.nan  # delta method, MSE -> RMS
            lines.append(f"{mark} {c.label:<34}{c.n_params:>3}{c.rms:>11.4g}{c.fit_percent:>8.2f}{c.cv_rms:>11.4g}"
                         f"{se_rms:>10.2g}{c.aic:>12.6g}{c.bic:>12.6g}")
        lines += ["  " + "-" * 101, f"chosen: {self.best.label} ({self.chosen}); {self.rule}",
                  f"RMS and CV RMS in {_error_unit(self.method)}, CV SE the standard error of "
                  "the CV RMS; AIC = n ln(RSS/n) + 2k, BIC = n ln(RSS/n) + k ln n on the whole-record residuals"]
        b = self.best
        lines.append("chosen parameters: " + ", ".join(
            f"{k} {v:.6g}" + (f" ± {b.stderr[k]:.2g}" if k in b.stderr and math.isfinite(b.stderr[k]) else "")
            for k, v in b.params.items()) + " (± delete-a-block jackknife)")
        return "\n".join(lines)

    def plot(self, ax=None):
        """The fitted candidates' steady friction maps ``F(w)`` over the record's velocity range.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
            Velocity (rad/s) against friction (N·m, offset included), one curve per fitted form, the chosen
            one thick.
        """
        ax = axes_or_new(ax)
        lo, hi = self.w_range
        span = max(abs(lo), abs(hi), 1e-12)
        w = np.linspace(lo, hi, 801)
        w = np.unique(np.concatenate([w, np.linspace(-0.02 * span, 0.02 * span, 201)]))
        w = w[(w >= lo) & (w <= hi)]
        for c in self.candidates:
            if c.status != "fitted":
                continue
            F = c.friction(w)
            F[w == 0] = np.nan
            ax.plot(w, F, lw=2.4 if c.name == self.chosen else 1.0,
                    label=f"{c.label} (k={c.n_params})" + (" chosen" if c.name == self.chosen else ""))
        ax.set_xlabel(f"velocity ({VELOCITY_LABEL})")
        ax.set_ylabel("friction F(w) (N·m)")
        ax.set_title(f"candidate friction forms, {self.source or 'measured data'}")
        ax.legend(loc="best", fontsize="small")
        ax.grid(True, alpha=0.3)
        return ax


def _error_unit(method: str) -> str:
    """Unit and kind of the errors of a selection's table."""
    if method == "sliding":
        return "N·m (N) (equation error of the filtered torque L[u])"
    return f"{VELOCITY_LABEL} (velocity prediction error)"
