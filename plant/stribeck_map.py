"""Ruderman's eq. 3, the static Stribeck friction map, implemented once (C) for every caller.

``F(w) = sgn(w)*(Fc + (Fs - Fc)*exp(-|w/Vs|**delta)) + sigma*w``

The one implementation is C (``plant/csrc/plant_stribeck.c``: ``plant_stribeck_eval``
and its array loop), which the plant step (``plant/csrc/plant_dynamics.c``), the
identification simulator and the closed-loop engine call; :func:`stribeck_scalar`
and the vectorised :func:`stribeck` are its Python entries. :func:`stribeck_cutoff`
gives the speed above which the Stribeck term no longer changes ``Fc`` in float64
(an exact shortcut). :func:`stribeck_shape` is the shape factor alone (C
``plant_stribeck_shape_array``), used by the regressors of eqs. 5-6.

The names are re-exported by :mod:`plant.friction` (the joint's parameters); eq. 3
lives in its own leaf module so that the plant step can use it without an
import cycle (:mod:`plant.friction` needs the step for ``JointParams.make_step``).
"""

from __future__ import annotations

import math

import numpy as np

from plant.errors import ParameterError, check_finite_scalar, check_positive
from plant._cplant import ffi, lib

__all__ = ["stribeck_scalar", "stribeck_shape_scalar", "stribeck_slope_scalar", "stribeck_cutoff", "stribeck",
           "stribeck_shape", "static_friction"]


def static_friction(Fc, Fs):
    """The largest friction the map of eq. 3 puts against a joint leaving rest, ``max(|Fc|, |Fs|)`` (N·m): ``Fs``
    where the Stribeck hump rises above the Coulomb level, ``Fc`` where it does not (``Fs < Fc``, or no Stribeck term:
    pass ``Fs = Fc``).

    Parameters
    ----------
    Fc, Fs : float or array_like
        Coulomb and static friction (N·m), broadcast together.

    Returns
    -------
    float or ndarray
        ``max(|Fc|, |Fs|)`` elementwise (a float for scalar inputs); NaN where either is NaN.
    """
    out = np.maximum(np.abs(np.asarray(Fc, dtype=float)), np.abs(np.asarray(Fs, dtype=float)))  # NaN propagates
    return float(out) if out.ndim == 0 else out


def stribeck_shape_scalar(w: float, Vs: float, delta: float) -> float:
    """The Stribeck decay of eq. 3 at one velocity: ``s(w) = exp(-|w/Vs|**delta)`` (dimensionless).

    Parameters
    ----------
    w : float
        Velocity (rad/s).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Shape factor, non-zero.

    Returns
    -------
    float
        In [0, 1]; at ``w == 0`` the limit (1 for ``delta > 0``, 0 for
        ``delta < 0``: the power overflows to ``inf``); NaN for a NaN velocity.

    Notes
    -----
    Ruderman, eq. 3 (and the regressors of eqs. 5-6). C
    (``plant/csrc/plant_stribeck.c``, ``plant_stribeck_shape``), the one
    implementation of the exponential: :func:`stribeck_scalar`,
    :func:`stribeck_shape` and the C eq. 4 regressor call it. The power of
    ``x = |w|/Vs`` is ``plant_stribeck_power``'s: ``x``, ``x*x`` and
    ``sqrt(x)`` at ``delta`` 1, 2 and 0.5 (correctly rounded, as NumPy's
    ``**`` of an array takes them), otherwise libm's ``pow``; then ``exp``.
    """
    return lib.plant_stribeck_shape(w, Vs, delta)


def stribeck_scalar(w: float, Fc: float, dF: float, Vs: float, delta: float, sigma: float, wcut: float) -> float:
    """Eq. 3 at one velocity: ``sgn(w)*(Fc + dF*exp(-|w/Vs|**delta)) + sigma*w`` (N·m).

    Parameters
    ----------
    w : float
        Velocity (rad/s).
    Fc : float
        Coulomb level (N·m).
    dF : float
        ``Fs - Fc`` (N·m), the static minus the Coulomb level.
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Shape factor, non-zero.
    sigma : float
        Viscous coefficient (N·m·s/rad).
    wcut : float
        Speed (rad/s) above which the Stribeck term is skipped, from
        :func:`stribeck_cutoff`; ``math.inf`` disables the shortcut.

    Returns
    -------
    float
        Friction (N·m); ``F(0) = 0``; NaN for a NaN velocity.

    Notes
    -----
    Ruderman, eq. 3: C (``plant/csrc/plant_stribeck.c``,
    ``plant_stribeck_eval``), the one implementation, which the plant step,
    the identification simulator and the closed-loop engine evaluate. The
    power of ``|w|/Vs`` as :func:`stribeck_shape_scalar`'s (``x*x`` at
    ``delta == 2``, ``sqrt`` at 0.5, none at 1, libm's ``pow`` otherwise);
    ``|w| > wcut`` skips the power and ``exp`` (there ``Fc + dF*exp(...)``
    rounds to ``Fc``). Otherwise the operations are those of the plain formula
    in this order, so the result equals a Python evaluation with that power
    and :func:`math.exp` bit for bit (both call libm; for ``delta < 0`` and
    tiny ``|w|`` the power overflows to ``inf`` and the shape factor is its
    limit 0).
    """
    return lib.plant_stribeck_eval(ffi.new("plant_stribeck *", (Fc, dF, Vs, delta, sigma, wcut)), w)


def stribeck_slope_scalar(x: float, dF: float, Vs: float, delta: float) -> float:
    """Slope of the Stribeck term of eq. 3 over the speed: ``d/d|w| dF*exp(-|w/Vs|**delta)`` (N·m·s/rad).

    Parameters
    ----------
    x : float
        Normalised speed ``|w|/Vs`` (1), >= 0.
    dF : float
        ``Fs - Fc`` (N·m).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Shape factor, non-zero.

    Returns
    -------
    float
        ``-dF*delta*x**(delta - 1)*exp(-x**delta)/Vs``; 0 where the exponential underflows (``x**delta``
        beyond ~745, and ``x -> 0`` for ``delta < 0``: the limit); ``inf`` times the sign of ``-dF`` at ``x = 0`` for
        ``0 < delta < 1`` (the map's slope is unbounded there). The slope of the whole map for ``w != 0`` is
        ``sigma`` plus this (eq. 3 is even in its slope).

    Notes
    -----
    Derivative of Ruderman's eq. 3 (chain rule on ``exp(-x**delta)``, ``x = |w|/Vs``): C
    (``plant/csrc/plant_stribeck.c``, ``plant_stribeck_slope``), the one implementation used by the stiffness
    bounds of the lagged plant (:func:`plant.rows.lagged_rate`, :func:`plant.stiff.lagged_local_rate`) and the
    Jacobian of the implicit LuGre step (:func:`plant.stiff.lugre_jacobian`). Positive (a rising map) where
    ``dF*delta < 0``.
    """
    return lib.plant_stribeck_slope(x, dF, Vs, delta)


def stribeck_cutoff(Fc: float, dF: float, Vs: float, delta: float) -> float:
    """Speed above which ``Fc + dF*exp(-(|w|/Vs)**delta)`` equals ``Fc`` exactly in float64.

    Parameters
    ----------
    Fc : float
        Coulomb level (N·m).
    dF : float
        ``Fs - Fc`` (N·m).
    Vs : float
        Stribeck velocity (rad/s).
    delta : float
        Shape factor.

    Returns
    -------
    float
        Cut-off speed ``wcut`` (rad/s) for :func:`stribeck_scalar`; 0 when
        ``dF == 0``; ``math.inf`` (never skip) for ``delta <= 0`` or
        non-finite or invalid arguments.

    Notes
    -----
    ``Fc + d == Fc`` when ``|d| < ulp(Fc)/2``, and ``ulp(Fc)/2 >= Fc*2**-54``
    (IEEE 754 binary64); so ``(|w|/Vs)**delta > log(|dF|/Fc) + 54*log(2)``
    suffices (plus a margin of 1). With ``Fc == 0`` only an underflow of
    ``exp`` (argument beyond 745.2) is exact. The result carries a relative
    margin of 1e-9 against the rounding of the power.
    """
    if not (Vs > 0.0 and 0.0 < delta < math.inf and math.isfinite(Fc) and math.isfinite(dF)):
        return math.inf
    if dF == 0.0:
        return 0.0
    xcut = 746.0 if Fc == 0.0 else max(math.log(abs(dF) / abs(Fc)) + 54.0 * math.log(2.0) + 1.0, 0.0)
    return Vs * xcut ** (1.0 / delta) * (1.0 + 1e-9)


def stribeck(w, *, Fc: float, Fs: float, Vs: float, delta: float, sigma: float):
    """Static Stribeck friction map F(w), eq. 3, on a scalar or an array.

    Parameters
    ----------
    w : float or ndarray, any shape
        Velocity (rad/s).
    Fc, Fs : float
        Coulomb and static friction levels (N·m).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Stribeck shape factor (1), non-zero.
    sigma : float
        Viscous coefficient (N·m·s/rad).

    Returns
    -------
    float or ndarray, same shape as ``w``
        Friction torque (N·m); ``F(0) = 0`` (``sgn(0) = 0``).

    Raises
    ------
    ParameterError
        ``Vs`` not > 0, ``delta`` zero, or a level not finite.
    TypeError
        A parameter is not a real number.

    Notes
    -----
    ``F(w) = sgn(w)*(Fc + (Fs - Fc)*exp(-|w/Vs|**delta)) + sigma*w``
    (Ruderman, eq. 3), evaluated element by element by :func:`stribeck_scalar`
    (so equal bit for bit to the plant step's friction). Equivalently
    ``F = Fc*g(w) + Fs*h(w) + sigma*w`` with the regressors g, h of eqs. 5-6.
    """
    Fc, Fs, sigma = check_finite_scalar("Fc", Fc), check_finite_scalar("Fs", Fs), check_finite_scalar("sigma", sigma)
    Vs, delta = check_positive("Vs", Vs), check_finite_scalar("delta", delta)
    if delta == 0.0:
        raise ParameterError("delta must be non-zero (|w/Vs|**0 is constant), got 0.0")
    dF = Fs - Fc
    wcut = stribeck_cutoff(Fc, dF, Vs, delta)
    m = ffi.new("plant_stribeck *", (Fc, dF, Vs, delta, sigma, wcut))
    if type(w) is float:  # one Python float (a plant's initial state): no array round trip
        return lib.plant_stribeck_eval(m, w)
    wa = np.asarray(w, dtype=float)
    flat = np.ascontiguousarray(wa.reshape(-1))
    out = np.empty_like(flat)
    lib.plant_stribeck_array(m, ffi.from_buffer("double[]", flat), ffi.from_buffer("double[]", out), flat.size)
    if wa.ndim == 0:
        return float(out[0])
    return out.reshape(wa.shape)


def stribeck_shape(w, Vs: float, delta: float):
    """Stribeck decay ``s(w) = exp(-|w/Vs|**delta)`` (the exponential of eq. 3).

    Parameters
    ----------
    w : float or ndarray, any shape
        Velocity (rad/s).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Shape factor, non-zero. For ``delta < 0`` the curve rises from ``Fc``
        at standstill towards ``Fs`` at high speed (paper Sec. II-B allows both
        signs).

    Returns
    -------
    float or ndarray, same shape as ``w``
        Values in [0, 1]. At ``w == 0`` the limit is returned (1 for
        ``delta > 0``, 0 for ``delta < 0``) without NaN or warnings.

    Notes
    -----
    Source: Ruderman, eq. 3 (the regressors of eqs. 5-6 use it): C
    (``plant_stribeck_shape_array``), :func:`stribeck_shape_scalar` looped over
    the array, so array and scalar callers (and the C eq. 4 regressor) get the
    same bits.
    """
    wa = np.asarray(w, dtype=float)
    flat = np.ascontiguousarray(wa).reshape(-1)
    out = np.empty_like(flat)
    lib.plant_stribeck_shape_array(ffi.from_buffer("double[]", flat), ffi.from_buffer("double[]", out), flat.size,
                                   float(Vs), float(delta))
    return float(out[0]) if wa.ndim == 0 else out.reshape(wa.shape)
