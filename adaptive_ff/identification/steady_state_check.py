r"""Does the answer's friction curve pass through the log's own steady state? (a model-form check)

At constant velocity eq. 1 has ``J*dw/dt = 0`` and the lag of eq. 2 has settled, so the mean torque of a
constant-velocity stretch is the friction ``F(w)`` plus the offset, whatever the inertia
(:mod:`adaptive_ff.identification.steady_state`, the support points of Sec. V-C, Fig. 8). Any answer of
:func:`adaptive_ff.identification.identify.identify` predicts these points without a simulation: ``F(w_i) +
offset`` with its ``Fc, Fs, Vs, delta, sigma``. :func:`steady_state_check` measures how far the answer's curve
lies from the log's support points, beside a static line through the same points (Coulomb + viscous, with the
offset when the answer has one: ``u_i = Fc*sgn(w_i) + sigma*w_i + offset``, weighted least squares), which is
what the points alone support.

Why a check of this kind: a dynamic fit (output error: the velocity simulated from the torque through eqs. 1-3)
can trade friction against inertia. On a log whose torque is already the friction torque (the rigid-body
dynamics removed by the log's authors: ``u = F(w)``, nothing left for ``J*dw/dt`` to explain) the output-error
fit used a large ``J`` as a low-pass filter of the torque's noise and put the friction levels far from the
log's (docs/benchmarks/identification.md, "Real logs beyond EMPS": Fc 0.91 N·m against 4.67), while the
steady-state points sit on the published curve. The check does not say which model is right; it says that the
answer does not reproduce what the log shows at constant velocity, by how much, and what a static curve through
those points gives, so that the difference is explained in the report rather than found later.

Rule (:data:`MISS_LIMIT`, :data:`MISS_RATIO`): the check *flags* the answer when its RMS miss of the points is
more than ``MISS_LIMIT`` (10 %) of the points' RMS torque **and** more than ``MISS_RATIO`` (2) times the static
line's RMS miss (or the line is not determined by the points: their speeds spread over less than
:data:`SPEED_SPREAD` of the top speed, or all in one direction). A flagged check becomes an
``IdentificationWarning`` with code ``"model_form"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from adaptive_ff.identification.covariance import bootstrap_t_quantile
from adaptive_ff.io.data import MeasuredData
from plant.errors import ExcitationError, ParameterError
from plant.friction import stribeck
from plant.results import json_safe

__all__ = ["SteadyStateCheck", "steady_state_check", "with_steady_state_check", "without_steady_state_check",
           "MISS_LIMIT", "MISS_RATIO", "SPEED_SPREAD"]

#: Relative RMS miss of the support points (fraction of their RMS torque) above which an answer can be flagged.
MISS_LIMIT = 0.10
#: ... and how many times the static line's own miss it must exceed.
MISS_RATIO = 2.0
#: The static line needs points whose speeds spread over at least this fraction of the top speed (Fc and sigma
#: apart) and points in both directions (Fc and the offset apart).
SPEED_SPREAD = 0.2


@dataclass(frozen=True)
class SteadyStateCheck:
    """The answer's friction curve against the log's steady-state support points.

    Attributes
    ----------
    n_points : int
        Support points (:func:`adaptive_ff.identification.steady_state.support_points`, ``method="auto"``).
    point_method : str
        ``"segments"`` or ``"bins"``.
    w, u : ndarray, shape (n_points,)
        The points: mean velocity (rad/s or m/s) and mean torque (N·m or N).
    answer_miss : float
        RMS of ``u_i - F(w_i) - offset`` over the points for the answer (N·m or N).
    scale : float
        RMS of ``u_i`` (N·m or N): the misses are read relative to it.
    static : dict or None
        The static line through the points: ``Fc``, ``sigma``, ``offset`` (0 when the answer has none),
        ``std`` (standard errors, ``s^2 (A^T W A)^-1`` with the points' own residual variance), ``interval95``
        (Student-t with ``n_points - k`` degrees of freedom), ``miss`` (its RMS miss); None when the points
        do not determine it (speeds spread over less than :data:`SPEED_SPREAD` of the top speed, all in one
        direction, or fewer than ``k + 2`` points).
    flagged : bool
        The module's rule.
    message : str
        The report's line (also the warning's text when flagged).
    """

    n_points: int
    point_method: str
    w: np.ndarray = field(repr=False)
    u: np.ndarray = field(repr=False)
    answer_miss: float
    scale: float
    static: dict | None
    flagged: bool
    message: str

    @property
    def relative_miss(self) -> float:
        """``answer_miss / scale`` (-)."""
        return self.answer_miss / self.scale if self.scale > 0 else math.inf

    def to_dict(self) -> dict:
        """Strict JSON: every attribute (``w``, ``u`` as lists) and ``relative_miss``."""
        return json_safe({"n_points": self.n_points, "point_method": self.point_method, "w": self.w.tolist(),
                          "u": self.u.tolist(), "answer_miss": self.answer_miss, "scale": self.scale,
                          "relative_miss": self.relative_miss, "static": self.static, "flagged": self.flagged,
                          "message": self.message})

    def summary(self) -> str:
        """The report's line."""
        return self.message


def _static_line(w: np.ndarray, u: np.ndarray, wt: np.ndarray, offset: bool) -> dict | None:
    """Weighted LS line ``Fc*sgn(w) + sigma*w (+ offset)`` through the points; None when not determined."""
    cols = [np.sign(w), w] + ([np.ones_like(w)] if offset else [])
    A = np.column_stack(cols)
    k = A.shape[1]
    aw = np.abs(w)
    if w.size < k + 2 or np.ptp(aw) < SPEED_SPREAD * np.max(aw) or np.ptp(np.sign(w)) == 0:
        return None
    Aw, uw = A * wt[:, None], u * wt
    x, *_ = np.linalg.lstsq(Aw, uw, rcond=None)
    r = Aw @ x - uw
    dof = w.size - k
    cov = float(r @ r) / dof * np.linalg.pinv(Aw.T @ Aw)
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    q = bootstrap_t_quantile(dof)  # Student-t, 95 %: scipy.stats loaded only here
    names = ("Fc", "sigma", "offset")[:k]
    out = {"Fc": float(x[0]), "sigma": float(x[1]), "offset": float(x[2]) if offset else 0.0,
           "std": {n: float(s) for n, s in zip(names, std)},
           "interval95": {n: [float(v - q * s), float(v + q * s)] for n, v, s in zip(names, x, std)},
           "miss": float(np.sqrt(np.mean((A @ x - u) ** 2)))}
    return out


def steady_state_check(data: MeasuredData, params: dict, *, Vs: float | None = None, delta: float | None = None
                       ) -> SteadyStateCheck | None:
    """Compare an identification's friction curve with the log's steady-state support points (module docstring).

    Parameters
    ----------
    data : MeasuredData
        The log the answer was identified from (``t`` s, ``u`` N·m or N, ``w`` rad/s or m/s).
    params : dict
        The answer: ``Fc``, ``sigma`` and optionally ``Fs`` (default ``Fc``) and ``offset`` (default 0), in the
        log's units.
    Vs, delta : float, keyword-only, optional
        The Stribeck velocity and shape of the answer (both or neither; ignored when ``Fs == Fc``).

    Returns
    -------
    SteadyStateCheck or None
        None when the log has fewer than 6 support points (no constant-velocity stretches and too few
        quasi-static samples): then there is nothing to check against.

    Raises
    ------
    TypeError
        ``data`` not a :class:`MeasuredData`.
    ParameterError
        ``params`` without ``Fc`` or ``sigma``, or a non-finite value.
    """
    from adaptive_ff.identification.steady_state import support_points

    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    missing = [k for k in ("Fc", "sigma") if k not in params]
    if missing:
        raise ParameterError(f"params must hold {missing}")
    Fc, sigma = float(params["Fc"]), float(params["sigma"])
    Fs, off = float(params.get("Fs", Fc)), float(params.get("offset", 0.0) or 0.0)
    for k, v in (("Fc", Fc), ("sigma", sigma), ("Fs", Fs), ("offset", off)):
        if not math.isfinite(v):
            raise ParameterError(f"params[{k!r}] must be finite, got {v}")
    try:
        pts = support_points(data, method="auto")
    except ExcitationError:
        return None
    w, u = np.asarray(pts.w_mean, float), np.asarray(pts.u_mean, float)
    stribeck_part = Fs != Fc and Vs is not None and delta is not None
    F = stribeck(w, Fc=Fc, Fs=Fs if stribeck_part else Fc, Vs=Vs if stribeck_part else 1.0,
                 delta=delta if stribeck_part else 1.0, sigma=sigma) + off
    answer_miss = float(np.sqrt(np.mean((u - F) ** 2)))
    scale = float(np.sqrt(np.mean(u ** 2)))
    se = np.asarray(pts.u_std, float) / np.sqrt(np.maximum(np.asarray(pts.n_samples, float), 1.0))
    wt = 1.0 / np.maximum(se, 1e-12 * max(scale, 1e-300))
    line = _static_line(w, u, wt / np.max(wt), offset=off != 0.0)
    rel = answer_miss / scale if scale > 0 else math.inf
    flagged = rel > MISS_LIMIT and (line is None or answer_miss > MISS_RATIO * line["miss"])
    msg = (f"steady state ({pts.n_points} support points by {pts.method}, Sec. V-C): the answer's F(w) misses the "
           f"log's constant-velocity torque by {answer_miss:.3g} RMS ({100 * rel:.1f} % of its RMS {scale:.3g})")
    if line is not None:
        iv = line["interval95"]
        msg += (f"; a static line through the points misses them by {line['miss']:.3g} with Fc {line['Fc']:.4g} "
                f"[{iv['Fc'][0]:.4g}, {iv['Fc'][1]:.4g}], sigma {line['sigma']:.4g} "
                f"[{iv['sigma'][0]:.4g}, {iv['sigma'][1]:.4g}]"
                + (f", offset {line['offset']:.4g}" if "offset" in iv else ""))
    if flagged:
        msg += (". The answer does not reproduce the log's steady state: its inertia or lag explains what the "
                "friction should (a log whose torque is already the friction torque, with the dynamics removed, "
                "has nothing for J*dw/dt to explain), or its form does not fit the log; the static line is what "
                "the steady state supports")
    return SteadyStateCheck(n_points=int(pts.n_points), point_method=pts.method, w=w, u=u, answer_miss=answer_miss,
                            scale=scale, static=line, flagged=bool(flagged), message=msg)


def with_steady_state_check(report, data: MeasuredData):
    """The report with its answer checked against the log's steady state (its ``steady_state``).

    Parameters
    ----------
    report : IdentificationReport
        Any report of :func:`adaptive_ff.identification.identify.identify` (a dataclass with ``params``, ``Vs``,
        ``delta``, ``notes``, ``warnings`` and ``steady_state``); its answer is checked.
    data : MeasuredData
        The log it was identified from.

    Returns
    -------
    IdentificationReport
        ``steady_state`` set (:func:`steady_state_check`), its line appended to the notes and, when it flags the
        answer, a ``"model_form"`` warning; a report checked before (e.g. for an earlier answer) loses that
        check's note and warning first (:func:`without_steady_state_check`). ``steady_state = None`` when the
        log has too few support points.
    """
    from adaptive_ff.identification.plausibility import IdentificationWarning

    report = without_steady_state_check(report)
    notes, warn = list(report.notes), list(report.warnings)
    check = steady_state_check(data, report.params, Vs=report.Vs, delta=report.delta)
    if check is not None:
        notes.append(check.message)
        if check.flagged:
            warn.append(IdentificationWarning("model_form", "all", check.message))
    return replace(report, steady_state=check, notes=tuple(notes), warnings=tuple(warn))


def without_steady_state_check(report):
    """The report (as for :func:`with_steady_state_check`) without its steady-state check, the check's note and
    its ``"model_form"`` warning (the model-error check's own ``"model_form"`` warnings stay); unchanged when it
    has none."""
    old = report.steady_state
    if old is None:
        return report
    return replace(report, steady_state=None, notes=tuple(n for n in report.notes if n != old.message),
                   warnings=tuple(w for w in report.warnings
                                  if not (getattr(w, "code", "") == "model_form" and str(w) == old.message)))
