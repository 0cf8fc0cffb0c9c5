"""Inverse dynamic identification model (IDIM-LS) of a rigid axis with (asymmetric) friction.

The EMPS benchmark's reference identification (Janot, Gautier, Brunot, "Data Set
and Reference Models of EMPS", 2019; its ``Script_IDIM_LS.m`` and
``Script_IDIM_LS_Asym_Fric.m``) writes the rigid-body equation of the axis as a
model *linear in the parameters*::

    u = J*dw/dt + F(w) + offset                                  (IDIM)
    F(w) = Fc_pos + sigma_pos*w   (w > 0)
         = -Fc_neg + sigma_neg*w  (w < 0),    F(0) = 0

with ``u`` the measured torque/force. The symmetric model (``Fc_pos = Fc_neg = Fc``,
``sigma_pos = sigma_neg = sigma``) is eq. 3 of the Ruderman paper without the
Stribeck term (``Fs = Fc``) and eq. 2 without the lag (``tau = 0``). The
acceleration is the central difference of the (already zero-phase filtered)
velocity; every column of the regressor matrix and the force are low-pass
filtered and decimated ("parallel filtering", Gautier 1997), which removes the
high-frequency noise the differentiation amplified, and the parameters follow by
ordinary least squares with standard errors from ``s**2 (W^T W)^{-1}`` (Ljung,
*System Identification*, 2nd ed., Sec. 7.3 and 9.2).

Sample selection: the start of the record is left out by the caller (the
zero-phase filter's start transient, :func:`adaptive_ff.io.data.load_emps`
``skip``), the end by ``tail`` here (its end transient: a record that stops
while the axis moves ends in an acceleration spike made by the filter's
extrapolation). The figures pinned on ``DATA_EMPS.mat`` and the cross-test on
``DATA_EMPS_PULSES.mat`` are in ``tests/adaptive_ff_layer/test_idim.py`` and
``tests/adaptive_ff_layer/test_emps_crosstest.py``, the measurement on the EMPS benchmark page of
the documentation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from adaptive_ff.io.data import EMPS_SKIP, MeasuredData
from plant.errors import ExcitationError, ParameterError, SignalError, check_finite_scalar, check_nonnegative, \
    check_positive
from plant.friction import stribeck
from plant.results import json_safe

__all__ = ["RigidAxisModel", "IDIMFit", "fit_idim", "idim_rows", "idim_force_error", "relative_error", "IDIM_DECIMATE",
           "IDIM_TAIL"]

#: Default decimation factor of the parallel filtering: the benchmark's 10 at 1 kHz.
IDIM_DECIMATE = 10

#: Default samples left out at the *end* of a record before the parallel filtering: the end transient of the
#: zero-phase filters, as many as :func:`adaptive_ff.io.data.load_emps` drops at the start (49, the benchmark's).
IDIM_TAIL = EMPS_SKIP


def relative_error(y_meas, y_model) -> float:
    """Relative error in percent, the EMPS benchmark's definition.

    Parameters
    ----------
    y_meas : array_like, shape (N,)
        Measured signal (any unit).
    y_model : array_like, shape (N,)
        Model output (same unit).

    Returns
    -------
    float
        ``100 * ||y_meas - y_model||_2 / ||y_meas||_2`` (%).

    Raises
    ------
    SignalError
        Shapes differ, non-finite values, or ``y_meas`` is identically zero.

    Notes
    -----
    Janot, Gautier, Brunot (2019), the relative errors of the reference
    model (``100*norm(y - y_s)/norm(y)`` in the benchmark scripts).
    """
    y = np.asarray(y_meas, dtype=float).ravel()
    ys = np.asarray(y_model, dtype=float).ravel()
    if y.shape != ys.shape:
        raise SignalError(f"y_meas and y_model must have the same length, got {y.shape[0]} and {ys.shape[0]}")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(ys))):
        raise SignalError("y_meas and y_model must be finite")
    den = float(np.linalg.norm(y))
    if den == 0.0:
        raise SignalError("y_meas is identically zero: the relative error is undefined")
    return 100.0 * float(np.linalg.norm(y - ys)) / den


@dataclass(frozen=True)
class RigidAxisModel:
    """Rigid axis with Coulomb + viscous friction, possibly direction dependent, and a bias.

    ``J*dw/dt = u - F(w) - offset`` with ``F(w) = Fc_pos + sigma_pos*w`` for
    ``w > 0``, ``-Fc_neg + sigma_neg*w`` for ``w < 0`` (and sticking at ``w = 0``
    while ``-Fc_neg <= u - offset <= Fc_pos``).

    Attributes
    ----------
    J : float
        Inertia (kg·m²) or mass (kg), > 0.
    Fc_pos, Fc_neg : float
        Coulomb levels (N·m or N) for positive / negative velocity, >= 0
        (both are magnitudes: the friction is ``-Fc_neg`` when moving backwards).
    sigma_pos, sigma_neg : float
        Viscous coefficients (N·m·s/rad or N·s/m) for positive / negative velocity, >= 0.
    offset : float
        Constant torque/force bias (N·m or N).

    Raises
    ------
    ParameterError, TypeError
        A value not finite, ``J <= 0``, a friction coefficient < 0.

    Notes
    -----
    EMPS symbols (Janot et al., 2019): M = J, Fc+ = Fc_pos, Fc- = Fc_neg,
    Fv+ = sigma_pos, Fv- = sigma_neg. The symmetric case is eq. 3 of the
    Ruderman paper with ``Fs = Fc`` (no Stribeck term).
    """

    J: float
    Fc_pos: float
    Fc_neg: float
    sigma_pos: float
    sigma_neg: float
    offset: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "J", check_positive("J", self.J))
        for name in ("Fc_pos", "Fc_neg", "sigma_pos", "sigma_neg"):
            object.__setattr__(self, name, check_nonnegative(name, getattr(self, name)))
        object.__setattr__(self, "offset", check_finite_scalar("offset", self.offset))

    @classmethod
    def symmetric(cls, J: float, sigma: float, Fc: float, offset: float = 0.0) -> "RigidAxisModel":
        """The direction-independent model ``F(w) = Fc*sgn(w) + sigma*w``.

        Parameters
        ----------
        J : float
            Inertia (kg·m², kg), > 0.
        sigma : float
            Viscous coefficient (N·m·s/rad, N·s/m), >= 0.
        Fc : float
            Coulomb level (N·m, N), >= 0.
        offset : float
            Bias (N·m, N).

        Returns
        -------
        RigidAxisModel

        Raises
        ------
        ParameterError, TypeError
            As the constructor.
        """
        return cls(J=J, Fc_pos=Fc, Fc_neg=Fc, sigma_pos=sigma, sigma_neg=sigma, offset=offset)

    @property
    def is_symmetric(self) -> bool:
        """True if ``Fc_pos == Fc_neg`` and ``sigma_pos == sigma_neg``."""
        return self.Fc_pos == self.Fc_neg and self.sigma_pos == self.sigma_neg

    def friction(self, w) -> np.ndarray:
        """Friction ``F(w)`` without the bias (N·m or N).

        Parameters
        ----------
        w : array_like, shape (N,)
            Velocity (rad/s or m/s).

        Returns
        -------
        ndarray, shape (N,)
            ``Fc_pos + sigma_pos*w`` where ``w > 0``, ``-Fc_neg + sigma_neg*w``
            where ``w < 0``, 0 where ``w == 0``.

        Notes
        -----
        Eq. 3 of the Ruderman paper with ``Fs = Fc`` and the levels of each
        direction, evaluated by :func:`plant.friction.stribeck` (with no
        Stribeck excess the shape factor does not enter; ``Vs = delta = 1``
        are placeholders).
        """
        w = np.asarray(w, dtype=float)
        pos = stribeck(w, Fc=self.Fc_pos, Fs=self.Fc_pos, Vs=1.0, delta=1.0, sigma=self.sigma_pos)
        neg = stribeck(w, Fc=self.Fc_neg, Fs=self.Fc_neg, Vs=1.0, delta=1.0, sigma=self.sigma_neg)
        return np.where(w > 0, pos, np.where(w < 0, neg, 0.0))

    def force(self, acc, w) -> np.ndarray:
        """Torque/force of the inverse dynamic model ``J*acc + F(w) + offset`` (N·m or N).

        Parameters
        ----------
        acc : array_like, shape (N,)
            Acceleration (rad/s² or m/s²).
        w : array_like, shape (N,)
            Velocity (rad/s or m/s).

        Returns
        -------
        ndarray, shape (N,)
        """
        return self.J * np.asarray(acc, dtype=float) + self.friction(w) + self.offset

    def to_dict(self) -> dict:
        """Plain floats: ``J, Fc_pos, Fc_neg, sigma_pos, sigma_neg, offset`` (SI units; all finite by validation)."""
        return {k: float(getattr(self, k)) for k in ("J", "Fc_pos", "Fc_neg", "sigma_pos", "sigma_neg", "offset")}

    def summary(self) -> str:
        """One line with the six values."""
        if self.is_symmetric:
            return (f"rigid axis: J = {self.J:.6g}, sigma = {self.sigma_pos:.6g}, Fc = {self.Fc_pos:.6g}, "
                    f"offset = {self.offset:.6g}")
        return (f"rigid axis: J = {self.J:.6g}, sigma+ = {self.sigma_pos:.6g}, Fc+ = {self.Fc_pos:.6g}, "
                f"sigma- = {self.sigma_neg:.6g}, Fc- = {self.Fc_neg:.6g}, offset = {self.offset:.6g}")


#: Column names of the IDIM regressor per structure (asymmetric, offset).
_NAMES = {
    (False, False): ("J", "sigma", "Fc"),
    (False, True): ("J", "sigma", "Fc", "offset"),
    (True, False): ("J", "sigma_pos", "Fc_pos", "sigma_neg", "Fc_neg"),
    (True, True): ("J", "sigma_pos", "Fc_pos", "sigma_neg", "Fc_neg", "offset"),
}


def _regressor(acc: np.ndarray, w: np.ndarray, asymmetric: bool, offset: bool) -> np.ndarray:
    """IDIM regressor matrix ``W`` (N, p) with columns in the order of ``_NAMES``."""
    if asymmetric:
        pos, neg = (w > 0).astype(float), (w < 0).astype(float)
        cols = [acc, w * pos, pos, w * neg, -neg]
    else:
        cols = [acc, w, np.sign(w)]
    if offset:
        cols.append(np.ones_like(w))
    return np.column_stack(cols)


def _decimate(x: np.ndarray, q: int) -> np.ndarray:
    """Low-pass filter (zero phase) and keep every ``q``-th sample, column-wise; ``q = 1`` copies."""
    if q == 1:
        return np.array(x, dtype=float, copy=True)
    from scipy.signal import decimate

    return decimate(x, q, ftype="iir", axis=0, zero_phase=True)


def _check_decimate(decimate) -> int:
    if isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 1:
        raise ParameterError(f"decimate must be an integer >= 1, got {decimate!r}")
    return int(decimate)


def _check_tail(tail, n: int, where: str) -> int:
    if isinstance(tail, bool) or not isinstance(tail, (int, np.integer)) or tail < 0:
        raise ParameterError(f"tail must be an integer >= 0, got {tail!r}")
    if tail >= n:
        raise SignalError(f"{where}: tail = {tail} leaves no sample of the {n} in the record")
    return int(tail)


def _uniform(data: MeasuredData, where: str) -> None:
    dt = np.diff(data.t)
    if np.max(np.abs(dt - data.Ts)) > 0.01 * data.Ts:
        raise SignalError(f"{where}: the time stamps are not uniform within 1 % (intervals {dt.min():.6g}.."
                          f"{dt.max():.6g} s); resample first (adaptive_ff.io.data.to_uniform)")


@dataclass(frozen=True)
class IDIMFit:
    """Result of :func:`fit_idim`.

    Attributes
    ----------
    model : RigidAxisModel
        The identified model (symmetric fields equal for the symmetric structure;
        ``offset = 0`` when not fitted).
    names : tuple of str
        Names of the fitted parameters, in the column order of ``W``:
        ``J, sigma, Fc[, offset]`` or ``J, sigma_pos, Fc_pos, sigma_neg, Fc_neg[, offset]``.
    theta : ndarray, shape (p,)
        Least-squares estimate (SI units of each parameter).
    stderr : dict
        Standard error of each parameter, ``sqrt(diag(s**2 (W^T W)^{-1}))`` with
        ``s**2 = ||r||**2/(n - p)`` (same unit as the parameter). It assumes
        white residuals; decimation makes them closer to white than at the raw rate.
    cond : float
        2-norm condition number of the column-scaled (unit-norm columns)
        ``W``, as :func:`adaptive_ff.identification.ls.fit_ls` reports it (unit independent).
    cond_raw : float
        2-norm condition number of ``W`` as it is (SI units), the benchmark's
        figure (26.0 for its reference fit).
    force_error : float
        Relative force error (%) of the fit, :func:`relative_error` of the
        filtered, decimated force and ``W theta`` (the benchmark's 4.08 % figure).
    n_samples : int
        Rows of ``W`` after decimation.
    decimate : int
        Decimation factor used.
    asymmetric : bool
        Direction-dependent friction fitted.
    """

    model: RigidAxisModel
    names: tuple[str, ...]
    theta: np.ndarray
    stderr: dict
    cond: float
    cond_raw: float
    force_error: float
    n_samples: int
    decimate: int
    asymmetric: bool

    @property
    def params(self) -> dict:
        """``{name: value}`` of the fitted parameters (plain floats)."""
        return {n: float(v) for n, v in zip(self.names, self.theta)}

    @property
    def rel_stderr(self) -> dict:
        """Relative standard errors ``100*stderr/|value|`` (%), NaN for a zero value."""
        return {n: (100.0 * self.stderr[n] / abs(v) if v != 0 else float("nan")) for n, v in self.params.items()}

    def to_dict(self) -> dict:
        """Strict-JSON dict (NaN/inf as None).

        Returns
        -------
        dict
            The parameters ``{name: value}``, ``std`` (standard errors), ``cond``,
            ``cond_raw``, ``force_error_percent``, ``n_samples``, ``decimate``.
        """
        out = dict(self.params)
        out["std"] = dict(self.stderr)
        out["cond"] = self.cond
        out["cond_raw"] = self.cond_raw
        out["force_error_percent"] = self.force_error
        out["n_samples"] = int(self.n_samples)
        out["decimate"] = int(self.decimate)
        return json_safe(out)

    def to_json_dict(self) -> dict:
        """The same as :meth:`to_dict` (the name the CLI uses)."""
        return self.to_dict()

    def summary(self) -> str:
        """A few lines: each parameter with its relative standard error, force error and condition numbers."""
        rel = self.rel_stderr
        lines = [f"IDIM-LS fit ({'asymmetric' if self.asymmetric else 'symmetric'} friction, {self.n_samples} rows, "
                 f"decimation {self.decimate})"]
        lines += [f"  {k:<10}{v:>14.6g} ± {self.stderr[k]:.3g} ({rel[k]:.3g} %)" for k, v in self.params.items()]
        lines.append(f"  force error {self.force_error:.3f} %, cond {self.cond:.3g} (scaled), "
                     f"{self.cond_raw:.3g} (raw)")
        return "\n".join(lines)


def idim_rows(data: MeasuredData, *, asymmetric: bool = False, offset: bool | None = None,
              decimate: int = IDIM_DECIMATE, tail: int = IDIM_TAIL, extra=None) -> tuple:
    """The regression rows of :func:`fit_idim`: ``W`` and ``u`` filtered and decimated ("parallel filtering").

    Parameters
    ----------
    data, asymmetric, offset, decimate, tail
        As in :func:`fit_idim`.
    extra : array_like, shape (N,) or (N, c), optional
        Further columns at the record's rate (e.g. a term the model leaves out), filtered, decimated and
        appended to ``W`` the same way.

    Returns
    -------
    W : ndarray, shape (m, p [+ c])
        Decimated regressors, columns ``names`` (then ``extra``).
    y : ndarray, shape (m,)
        Decimated torque/force.
    names : tuple of str
        The fitted parameters (columns of ``W`` before ``extra``).

    Raises
    ------
    TypeError, ParameterError, SignalError
        As :func:`fit_idim` (``extra`` of another length: SignalError).
    """
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    q = _check_decimate(decimate)
    asymmetric = bool(asymmetric)
    offset = (not asymmetric) if offset is None else bool(offset)
    _uniform(data, "fit_idim")
    keep = data.n_samples - _check_tail(tail, data.n_samples, "fit_idim")
    names = _NAMES[(asymmetric, offset)]
    p = len(names)
    w = data.w
    acc = np.gradient(w, data.t)
    W = _regressor(acc, w, asymmetric, offset)
    if extra is not None:
        E = np.asarray(extra, dtype=float).reshape(data.n_samples, -1) if np.size(extra) % data.n_samples == 0 \
            else None
        if E is None or not np.all(np.isfinite(E)):
            raise SignalError(f"extra columns must be finite, {data.n_samples} rows, got shape {np.shape(extra)}")
        W = np.column_stack([W, E])
    W = W[:keep]
    if W.shape[0] // q < 3 * p:
        raise SignalError(f"fit_idim: {W.shape[0]} samples decimated by {q} leave fewer than {3 * p} rows")
    return _decimate(W, q), _decimate(data.u[:keep], q), names


def fit_idim(data: MeasuredData, *, asymmetric: bool = False, offset: bool | None = None,
             decimate: int = IDIM_DECIMATE, tail: int = IDIM_TAIL) -> IDIMFit:
    """Identify ``J`` and the friction of a rigid axis by the inverse dynamic model (IDIM-LS).

    Parameters
    ----------
    data : MeasuredData
        Uniformly sampled ``t`` (s), torque/force ``u`` (N·m or N) and velocity
        ``w`` (rad/s or m/s), each shape (N,), already low-pass filtered (zero
        phase) such as :func:`adaptive_ff.io.data.load_emps` returns them.
    asymmetric : bool, keyword-only
        Fit direction-dependent friction ``Fc_pos, Fc_neg, sigma_pos,
        sigma_neg`` (the benchmark's asymmetric variant). Default False.
    offset : bool or None, keyword-only
        Fit a constant bias. Default (None): True for the symmetric structure,
        False for the asymmetric one, as the benchmark (an offset is nearly
        collinear with ``Fc_pos - Fc_neg`` when the friction is asymmetric).
    decimate : int, keyword-only
        Parallel-filtering decimation factor (>= 1): every column of ``W`` and
        ``u`` pass through ``scipy.signal.decimate`` (8th-order Chebyshev I,
        zero phase, as MATLAB's ``decimate`` used by the benchmark). Default 10
        (1 kHz to 100 Hz as the benchmark); 1 uses every sample unfiltered.
    tail : int, keyword-only
        Samples left out at the end of the record (>= 0, fewer than the
        record), default :data:`IDIM_TAIL` (49). A record that stops while the
        axis moves (both EMPS records do) ends in the transient of the
        zero-phase filters: the forward-backward filter extrapolates the
        position past the last sample, which bends the velocity and puts an
        acceleration spike in the last few samples (0.5 m/s², 48 N of inertia
        force, on ``DATA_EMPS_PULSES.mat``). The start transient is left out
        by the caller (:func:`~adaptive_ff.io.data.load_emps` ``skip``); 0
        keeps every sample (the benchmark's selection).

    Returns
    -------
    IDIMFit

    Raises
    ------
    TypeError
        ``data`` is not a :class:`MeasuredData`.
    ParameterError
        ``decimate`` not an integer >= 1, ``tail`` not an integer >= 0.
    SignalError
        Non-uniform time stamps, ``tail`` not shorter than the record, or fewer
        than ``3*p`` rows after decimation.
    ExcitationError
        ``W`` is rank deficient (e.g. no motion in one direction for the
        asymmetric structure, or no reversals with an offset), naming the
        column, or an estimate violates ``J > 0`` / friction >= 0.

    Notes
    -----
    Janot, Gautier, Brunot (2019), reference procedure (here the force is
    filtered by the caller's zero-phase filter too, which :func:`~adaptive_ff.io.data.load_emps`
    does, and the acceleration is ``numpy.gradient(w, t)``). Standard errors:
    Ljung (1999), Sec. 9.2.
    """
    Wd, yd, names = idim_rows(data, asymmetric=asymmetric, offset=offset, decimate=decimate, tail=tail)
    q, p = _check_decimate(decimate), len(names)
    asymmetric = bool(asymmetric)
    scale = np.linalg.norm(Wd, axis=0)
    for j, s in enumerate(scale):
        if s == 0.0:
            why = {"sigma_pos": "no motion forwards", "Fc_pos": "no motion forwards",
                   "sigma_neg": "no motion backwards", "Fc_neg": "no motion backwards",
                   "J": "no acceleration", "sigma": "no motion", "Fc": "no motion"}.get(names[j], "zero column")
            raise ExcitationError(f"fit_idim: regressor column {names[j]!r} is zero ({why}): the record does not "
                                  f"excite {names[j]}")
    U, sv, Vt = np.linalg.svd(Wd / scale, full_matrices=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    if not cond < 1e10:
        raise ExcitationError(f"fit_idim: regressor matrix is rank deficient (condition number {cond:.3g}); "
                              f"the record does not separate {', '.join(names)}")
    theta = (Vt.T @ ((U.T @ yd) / sv)) / scale
    r = yd - Wd @ theta
    n = Wd.shape[0]
    s2 = float(r @ r) / (n - p)
    cov = s2 * ((Vt.T / sv**2) @ Vt) / np.outer(scale, scale)
    std = {nm: float(math.sqrt(max(v, 0.0))) for nm, v in zip(names, np.diag(cov))}
    par = dict(zip(names, (float(x) for x in theta)))
    if par["J"] <= 0 or any(par[k] < 0 for k in names if k not in ("J", "offset")):
        raise ExcitationError(f"fit_idim: estimate not physical (J > 0, friction >= 0 required): {par}")
    if asymmetric:
        model = RigidAxisModel(J=par["J"], Fc_pos=par["Fc_pos"], Fc_neg=par["Fc_neg"], sigma_pos=par["sigma_pos"],
                               sigma_neg=par["sigma_neg"], offset=par.get("offset", 0.0))
    else:
        model = RigidAxisModel.symmetric(par["J"], par["sigma"], par["Fc"], par.get("offset", 0.0))
    return IDIMFit(model=model, names=names, theta=theta, stderr=std, cond=cond,
                   cond_raw=float(np.linalg.cond(Wd)),
                   force_error=relative_error(yd, Wd @ theta), n_samples=int(n), decimate=q, asymmetric=asymmetric)


def idim_force_error(model: RigidAxisModel, data: MeasuredData, *, decimate: int = IDIM_DECIMATE,
                     tail: int = IDIM_TAIL) -> float:
    """Relative force error (%) of a model's inverse dynamics on a record (cross-validation).

    Parameters
    ----------
    model : RigidAxisModel
        Model to test (fitted on another record).
    data : MeasuredData
        Uniform, zero-phase filtered ``t`` (s), ``u`` (N·m, N), ``w`` (rad/s, m/s), shape (N,).
    decimate : int, keyword-only
        Parallel-filtering factor as in :func:`fit_idim` (default 10).
    tail : int, keyword-only
        Samples left out at the end, as in :func:`fit_idim` (default 49, the
        zero-phase filters' end transient; 0 keeps every sample).

    Returns
    -------
    float
        :func:`relative_error` of the filtered, decimated measured force and of
        ``J*dw/dt + F(w) + offset`` (each term through the same filter and decimation).

    Raises
    ------
    TypeError
        ``model`` or ``data`` of the wrong type.
    ParameterError
        ``decimate`` or ``tail`` invalid.
    SignalError
        Non-uniform time stamps, ``tail`` not shorter than the record.

    Notes
    -----
    The benchmark's cross-test (Janot et al., 2019): the reference model
    scores 5.98 % on ``DATA_EMPS_PULSES.mat``; the figures of this function
    with and without ``tail`` are on the EMPS benchmark page of the documentation.
    """
    if not isinstance(model, RigidAxisModel):
        raise TypeError(f"model must be a RigidAxisModel, got {type(model).__name__}")
    if not isinstance(data, MeasuredData):
        raise TypeError(f"data must be a MeasuredData, got {type(data).__name__}")
    q = _check_decimate(decimate)
    _uniform(data, "idim_force_error")
    keep = data.n_samples - _check_tail(tail, data.n_samples, "idim_force_error")
    acc = np.gradient(data.w, data.t)
    pred = _decimate(model.force(acc, data.w)[:keep], q)
    return relative_error(_decimate(data.u[:keep], q), pred)
