"""Offline (batch) least-squares identification of the regression model, eq. 9."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel, nrmse_fit
from plant.errors import ExcitationError, check_nonnegative, check_positive, check_signal
from plant.results import axes_or_new, json_safe

__all__ = ["LSResult", "fit_ls", "COND_LIMIT"]

#: Regressor condition number above which the data are declared not exciting.
COND_LIMIT = 1e10


@dataclass(frozen=True)
class LSResult:
    """Result of :func:`fit_ls`.

    Attributes
    ----------
    model : RegressionModel
        The structure that was fitted.
    Ts : float
        Sample time (s).
    theta : ndarray, shape (p,)
        Regression parameters, names in ``model.names``.
    theta_std : ndarray, shape (p,)
        Standard errors of ``theta`` (``s**2 * (X^T X)^-1`` from the SVD of X; NaN for ridge fits).
    estimate : FrictionEstimate
        Physical parameters (J, tau, sigma, Fc, Fs, offset).
    residual_rms : float
        RMS of the equation error ``y - X theta`` (rad/s).
    cond : float
        2-norm condition number of the column-scaled regressor matrix.
    fit_one_step : float
        One-step-ahead prediction fit, NRMSE % (paper Figs. 4, 9).
    fit_free_run : float
        Free-run simulation fit, NRMSE %.
    w_one_step, w_free_run : ndarray, shape (N,)
        The two model outputs, for plotting against the measurement.
    """

    model: RegressionModel
    Ts: float
    theta: np.ndarray
    theta_std: np.ndarray
    estimate: FrictionEstimate
    residual_rms: float
    cond: float
    fit_one_step: float
    fit_free_run: float
    w_one_step: np.ndarray
    w_free_run: np.ndarray

    def theta_dict(self) -> dict:
        """``{name: value}`` of the regression parameters."""
        return dict(zip(self.model.names, self.theta.tolist()))

    def to_dict(self) -> dict:
        """Strict-JSON dict (NaN/inf as None) without the two output signals.

        Returns
        -------
        dict
            ``model`` (:meth:`RegressionModel.to_dict`), ``Ts``, ``theta`` and ``theta_std`` (``{name: value}``),
            ``estimate`` (:meth:`FrictionEstimate.to_dict`), ``residual_rms``,
            ``cond``, ``fit_one_step``, ``fit_free_run``, ``n_samples``.
        """
        m = self.model
        return json_safe({
            "model": m.to_dict(),
            "Ts": self.Ts, "theta": self.theta_dict(), "theta_std": dict(zip(m.names, self.theta_std.tolist())),
            "estimate": self.estimate.to_dict(), "residual_rms": self.residual_rms, "cond": self.cond,
            "fit_one_step": self.fit_one_step, "fit_free_run": self.fit_free_run,
            "n_samples": int(self.w_one_step.shape[0])})

    def summary(self) -> str:
        """A few lines: each regression parameter with its standard error, the fits and the condition number."""
        lines = [f"LS fit of eq. 4 ({self.model!r}, Ts = {self.Ts:.6g} s, {self.w_one_step.shape[0]} samples)"]
        lines += [f"  {k:<4}{v:>14.6g} ± {s:.3g}" for k, v, s in zip(self.model.names, self.theta, self.theta_std)]
        lines.append(f"  fit one-step {self.fit_one_step:.3f} %, free-run {self.fit_free_run:.2f} %, "
                     f"residual RMS {self.residual_rms:.3g} rad/s, cond {self.cond:.3g}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """The one-step prediction and the free-run simulation of the model over time (paper Figs. 4, 9).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.

        Returns
        -------
        matplotlib.axes.Axes
            Time (s, ``k*Ts``) against velocity (rad/s).
        """
        ax = axes_or_new(ax)
        t = np.arange(self.w_one_step.shape[0]) * self.Ts
        ax.plot(t, self.w_one_step, lw=0.8, label=f"one-step prediction (fit {self.fit_one_step:.1f} %)")
        ax.plot(t, self.w_free_run, lw=0.8, label=f"free run (fit {self.fit_free_run:.1f} %)")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("velocity (rad/s)")
        ax.legend(loc="best")
        ax.grid(True, alpha=0.3)
        return ax


def fit_ls(model: RegressionModel, u, w, *, Ts: float, ridge: float = 0.0, free_run: bool = True) -> LSResult:
    """Fit the regression model of eq. 4 by linear least squares (eq. 9), with an SVD-based solver.

    Parameters
    ----------
    model : RegressionModel
        Structure (lag, Stribeck/Coulomb, offset) and the fixed Vs, delta.
    u : array_like, shape (N,)
        Input torque (N·m), uniformly sampled at ``Ts``.
    w : array_like, shape (N,)
        Measured velocity (rad/s) at the same instants.
    Ts : float, keyword-only
        Sample time (s).
    ridge : float, keyword-only
        Tikhonov weight ``r >= 0``: minimises ``||X theta - y||**2 + r*||theta||**2``.
        ``r = 1/p0`` reproduces RLS started from ``theta = 0``, ``P = p0*I`` with ``lam = 1``.
    free_run : bool, keyword-only
        Simulate the fitted model free-running on ``u`` for ``w_free_run`` and ``fit_free_run`` (default
        True). False leaves them NaN: a caller that needs only ``theta`` and ``estimate`` (the start values
        of the output-error fit) skips the simulation, a loop over the samples.

    Returns
    -------
    LSResult

    Raises
    ------
    SignalError
        Bad shapes, too few samples, non-finite values.
    ExcitationError
        A regressor column is identically zero, or the (column-scaled)
        condition number exceeds :data:`COND_LIMIT`: the data do not excite
        every parameter (e.g. no reversals, no low-speed samples). The message
        names the weakest parameter.

    Notes
    -----
    Eq. 9 writes ``theta = (X^T X)^{-1} X^T W``; forming ``X^T X`` squares the
    condition number, so this uses ``numpy.linalg.lstsq`` (SVD) on ``X`` with
    columns scaled to unit norm, which is numerically sound (Golub & Van Loan,
    *Matrix Computations*, Sec. 5.3). Standard errors: ``cov = s**2 (X^T X)^{-1}``
    with ``s**2 = RSS/(N - p)``, computed from the SVD (Ljung, *System
    Identification*, 2nd ed., Sec. 7.3 / 9.2).
    """
    Ts = check_positive("Ts", Ts)
    ridge = check_nonnegative("ridge", ridge)
    u = check_signal("u", u)
    w = check_signal("w", w, n=u.shape[0])
    X, y = model.regressors(u, w)
    n, p = X.shape
    norms = np.linalg.norm(X, axis=0)
    zero = np.flatnonzero(norms == 0)
    if zero.size and ridge == 0:
        raise ExcitationError(f"regressor column of {model.names[zero[0]]!r} is identically zero: "
                              "the data do not excite it")
    scale = np.where(norms > 0, norms, 1.0)
    Xs = X / scale
    sv = np.linalg.svd(Xs, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    if ridge == 0 and cond > COND_LIMIT:
        # name the parameter most aligned with the weakest direction
        _, _, Vt = np.linalg.svd(Xs, full_matrices=False)
        weak = model.names[int(np.argmax(np.abs(Vt[-1])))]
        raise ExcitationError(f"too little excitation: regressor condition number {cond:.3g} > {COND_LIMIT:.0e}; "
                              f"{weak!r} is not identifiable from these data")
    if ridge > 0:
        Xa = np.vstack([X, np.sqrt(ridge) * np.eye(p)])
        ya = np.concatenate([y, np.zeros(p)])
        theta = np.linalg.lstsq(Xa, ya, rcond=None)[0]
        theta_std = np.full(p, np.nan)
    else:
        ths, *_ = np.linalg.lstsq(Xs, y, rcond=None)
        theta = ths / scale
        _, s, Vt = np.linalg.svd(Xs, full_matrices=False)
        rss = float(np.sum((y - X @ theta) ** 2))
        s2 = rss / max(n - p, 1)
        cov_s = (Vt.T / s**2) @ Vt
        theta_std = np.sqrt(s2 * np.diag(cov_s)) / scale
    resid = y - X @ theta
    w_one = model.predict(theta, u, w)
    w_free = model.simulate(theta, u, w[:2]) if free_run else np.full(u.shape[0], np.nan)
    return LSResult(
        model=model, Ts=Ts, theta=theta, theta_std=theta_std, estimate=model.to_physical(theta, Ts),
        residual_rms=float(np.sqrt(np.mean(resid**2))), cond=cond,
        fit_one_step=nrmse_fit(w[2:], w_one[2:]),
        fit_free_run=nrmse_fit(w[2:], w_free[2:]) if free_run else float("nan"),
        w_one_step=w_one, w_free_run=w_free,
    )
