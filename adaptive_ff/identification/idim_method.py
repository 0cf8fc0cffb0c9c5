"""The inverse dynamic model (IDIM-LS) as a method of :func:`adaptive_ff.identification.identify.identify`.

Why a method of its own: the paper's eq. 4 LS minimises the one-step *velocity* equation error; on a log whose
velocity is the derivative of a measured position (an encoder, filtered forward and backward: EMPS) the
torque is the clean signal and the velocity a smoothed derivative, and the torque regression of the
benchmark's own estimator (Janot, Gautier, Brunot 2019; :func:`adaptive_ff.identification.idim.fit_idim`) is
the one the log calls for. On EMPS it gives the benchmark's cross-test error (5.953 % on
``DATA_EMPS_PULSES.mat``, published 5.98 %) where eq. 4 gives 6.045 %
(``tests/adaptive_ff_layer/test_identify_idim.py``).

The answer is Coulomb + viscous with an offset (``Fs = Fc``, ``tau = 0``): ``u = J dw/dt + Fc sgn(w) + sigma w +
offset``, the columns and torque low-pass filtered and decimated to about 100 Hz (``decimate = round(0.01/Ts)``).
Its standard errors and 95 % intervals are the residual block bootstrap of the decimated rows
(:func:`adaptive_ff.identification.uncertainty.regression_block_bootstrap`) widened by the model-error check
(:func:`adaptive_ff.identification.model_error.assess_model_error`, with a Stribeck low-speed term and a torque
linear in position as the richer structures).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from adaptive_ff.identification.idim import IDIM_TAIL, fit_idim, idim_rows
from adaptive_ff.identification.model_error import (STRIBECK_FRACTION, Alternative, ModelErrorSettings,
                                                    assess_model_error, position_column, widened)
from adaptive_ff.identification.physical_id import PhysicalFit
from adaptive_ff.identification.plausibility import check_physical
from adaptive_ff.identification.regression import h_regressor, nrmse_fit
from adaptive_ff.identification.uncertainty import BootstrapSettings, regression_block_bootstrap
from adaptive_ff.io.data import MeasuredData

__all__ = ["fit_idim_physical", "idim_decimation", "IDIM_ESTIMATOR"]

#: The function behind method ``"idim"``.
IDIM_ESTIMATOR = "adaptive_ff.identification.idim.fit_idim"


def idim_decimation(Ts: float) -> int:
    """The parallel-filtering decimation of a record sampled every ``Ts`` s: ``max(1, round(0.01/Ts))`` (the
    benchmark's 10 at 1 kHz, down to about 100 Hz)."""
    return max(1, int(round(0.01 / float(Ts))))


def fit_idim_physical(uni: MeasuredData, *, offset: bool = True, n_bootstrap: int = 200, seed: int = 0
                      ) -> PhysicalFit:
    """IDIM-LS of a uniform record as a :class:`adaptive_ff.identification.physical_id.PhysicalFit` (method
    ``"idim"``).

    Parameters
    ----------
    uni : MeasuredData
        Uniform record (``t`` s, ``u`` N·m or N, ``w`` rad/s or m/s), zero-phase filtered as the loaders give it.
    offset : bool, keyword-only
        Fit a constant bias. Default True.
    n_bootstrap : int, keyword-only
        Replicates of the residual block bootstrap (0: the white OLS errors, no interval widening).
    seed : int, keyword-only
        Seed of the bootstrap.

    Returns
    -------
    PhysicalFit
        ``params`` ``J, Fc, Fs (= Fc), sigma, tau (= 0), offset``; ``stderr`` of ``J, sigma, Fc[, offset]``;
        ``info``: ``fitted``, ``decimate``, ``tail``, ``n_rows``, ``force_error_percent`` (the benchmark's
        relative force error of the fit), ``stderr_kind``, ``stderr_ols``, ``interval95``, ``bootstrap``,
        ``band``, ``model_error``.

    Raises
    ------
    SignalError, ExcitationError
        From :func:`adaptive_ff.identification.idim.fit_idim`.
    """
    q = idim_decimation(uni.Ts)
    fit = fit_idim(uni, offset=offset, decimate=q)
    W, y, names = idim_rows(uni, offset=offset, decimate=q)
    par = fit.params
    params = {"J": par["J"], "Fc": par["Fc"], "Fs": par["Fc"], "sigma": par["sigma"], "tau": 0.0}
    if offset:
        params["offset"] = par["offset"]
    info = {"fitted": list(names), "decimate": q, "tail": IDIM_TAIL, "n_rows": int(fit.n_samples),
            "force_error_percent": fit.force_error, "cond_raw": fit.cond_raw, "stderr_kind": "ols (white residuals)",
            "stderr_ols": dict(fit.stderr)}
    stderr = dict(fit.stderr)
    warn = []
    if n_bootstrap > 0:
        def phys(th):
            d = dict(zip(names, th))
            return SimpleNamespace(J=d["J"], sigma=d["sigma"], Fc=d["Fc"], Fs=d["Fc"], offset=d.get("offset", 0.0),
                                   Vs=None, delta=None)  # Coulomb + viscous: the band has no Stribeck term

        unc = regression_block_bootstrap(W, y, fit.theta, phys, names, w_max=float(np.max(np.abs(uni.w))),
                                         settings=BootstrapSettings(n=n_bootstrap, seed=seed))
        check = assess_model_error(W, y, fit.theta, lambda th: np.asarray(th, dtype=float), names, base=unc,
                                   alternatives=_alternatives(uni, offset, q, names),
                                   settings=ModelErrorSettings(level=float(unc.level)))
        unc = widened(unc, check)
        stderr = dict(unc.stderr)
        warn = check.warnings("the IDIM-LS")
        info.update(stderr_kind=unc.kind, interval95={k: list(v) for k, v in unc.interval.items()},
                    bootstrap={"n": unc.n, "n_valid": unc.n_valid, "block": unc.block, "seed": unc.seed},
                    band=None if unc.band is None else unc.band.to_dict(), model_error=check.to_dict())
    return PhysicalFit(method="idim", params=params, stderr=stderr, cond=float(fit.cond),
                       nrmse=float(nrmse_fit(y, W @ fit.theta)), n_samples=int(uni.n_samples),
                       nrmse_kind=f"decimated torque (IDIM, 1/{q})", info=info,
                       warnings=tuple(check_physical(params, source="idim (fit_idim)")) + tuple(warn))


def _alternatives(uni: MeasuredData, offset: bool, q: int, names) -> list:
    """Richer IDIM structures: a Stribeck low-speed term ``h(w)`` (eq. 6, ``Vs`` a tenth of the top speed) and a
    torque linear in position (the integral of ``w``), each one more column."""
    p = len(names)
    wmax = float(np.max(np.abs(uni.w)))
    cols = []
    if wmax > 0:
        cols.append(("Stribeck low-speed term", h_regressor(uni.w, STRIBECK_FRACTION * wmax, 1.0)))
    qcol = position_column(np.r_[uni.w, uni.w[-1]], uni.Ts, uni.n_samples)  # q(k) for k = 0 .. N-1
    cols.append(("torque linear in position", qcol))
    out = []
    for name, col in cols:
        W2, y2, _ = idim_rows(uni, offset=offset, decimate=q, extra=col)
        out.append(Alternative(name, W2, y2, (p,), lambda th: np.asarray(th[:p], dtype=float)))
    return out
