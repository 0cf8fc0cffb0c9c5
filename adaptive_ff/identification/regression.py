r"""The discrete-time regression model of the joint with lagged friction (eqs. 2, 4-6), derived.

Derivation (corrects the printed a1, b0, b1)
--------------------------------------------
Eliminating ``f`` from ``J*dw/dt = u - f`` and ``tau*df/dt + f = F(w)`` gives
eq. 2::

    J*tau*w'' + J*w' + F(w) = u + tau*u'

Replace the derivatives by the paper's backward differences,
``w' = (w(k) - w(k-1))/Ts``, ``w'' = (w(k) - 2*w(k-1) + w(k-2))/Ts**2``,
``u' = (u(k) - u(k-1))/Ts``, write ``F(w) = Fc*g(w) + Fs*h(w) + sigma*w``
(eqs. 3, 5, 6) with the viscous term at ``k`` and g, h at ``k-1`` (as the
paper does), and multiply by ``Ts**2``::

    D*w(k) = (2*J*tau + J*Ts)*w(k-1) - J*tau*w(k-2) + (Ts**2 + tau*Ts)*u(k)
             - tau*Ts*u(k-1) - Ts**2*Fc*g(w(k-1)) - Ts**2*Fs*h(w(k-1))

with ``D = J*tau + J*Ts + sigma*Ts**2``. Hence, in eq. 4
``w(k) = a1*w(k-1) - a2*w(k-2) + b0*u(k) - b1*u(k-1) - c1*g(w(k-1)) - d1*h(w(k-1))``::

    a1 = (2*J*tau + J*Ts) / D      (paper: J*tau + J*Ts   -- wrong)
    a2 = J*tau / D
    b0 = (Ts**2 + tau*Ts) / D      (paper: Ts**2 + tau*Ts**2 -- wrong units)
    b1 = tau*Ts / D                (paper: tau*Ts**2     -- wrong units)
    c1 = Fc*Ts**2 / D
    d1 = Fs*Ts**2 / D

Checks: every coefficient of ``w`` is dimensionless and every coefficient of
``u`` has units (rad/s)/(N·m); at steady state (``w``, ``u`` constant,
``w > 0``) the model gives ``u = sigma*w + Fc*g(w) + Fs*h(w) = F(w)`` only
with ``1 - a1 + a2 = sigma*Ts**2/D``, which the printed ``a1`` violates.

Inverse map (six parameters, five physical ones plus one redundancy)::

    b0 - b1 = Ts**2/D
    tau   = Ts*b1/(b0 - b1)
    J     = Ts*(a1 - 2*a2)/(b0 - b1)      (also J = Ts*a2/b1 when tau > 0)
    sigma = (1 - a1 + a2)/(b0 - b1)
    Fc    = c1/(b0 - b1),  Fs = d1/(b0 - b1),  offset = o1/(b0 - b1)

An optional constant ``offset`` torque (real data carry one) adds the
regressor ``-1`` with parameter ``o1 = offset*Ts**2/D``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from adaptive_ff._caff import ffi, lib
from plant.errors import ExcitationError, ParameterError, check_finite_scalar, check_positive, check_signal
from plant.friction import JointParams, stribeck, stribeck_shape
from plant.results import axes_or_new, json_safe

__all__ = [
    "g_regressor",
    "h_regressor",
    "RegressionModel",
    "FrictionEstimate",
    "theta_from_physical",
    "theta_from_physical_printed",
    "THETA_NAMES",
    "nrmse_fit",
    "eq4_phi",
    "eq4_to_physical",
]

#: Canonical names of the regression parameters (eq. 4), plus the offset term.
THETA_NAMES = ("a1", "a2", "b0", "b1", "c1", "d1", "o1")


def g_regressor(w, Vs: float, delta: float):
    """Coulomb regressor ``g(w) = sgn(w)*(1 - exp(-|w/Vs|**delta))``, eq. 5.

    Parameters
    ----------
    w : float or ndarray
        Velocity (rad/s).
    Vs : float
        Stribeck velocity (rad/s), > 0.
    delta : float
        Stribeck shape factor, non-zero.

    Returns
    -------
    float or ndarray, same shape as ``w``; dimensionless, ``g(0) = 0``.
    """
    return np.sign(w) * (1.0 - stribeck_shape(w, Vs, delta))


def h_regressor(w, Vs: float, delta: float):
    """Stiction regressor ``h(w) = sgn(w)*exp(-|w/Vs|**delta)``, eq. 6.

    Parameters and returns as :func:`g_regressor`; ``h(0) = 0``.
    """
    return np.sign(w) * stribeck_shape(w, Vs, delta)


def theta_from_physical(p: JointParams, Ts: float, *, offset: float = 0.0) -> np.ndarray:
    """Regression parameters of eq. 4 from physical ones, with the corrected formulas.

    Parameters
    ----------
    p : JointParams
        Physical parameters (``Vs``, ``delta`` enter only through g, h).
    Ts : float
        Sample time (s), > 0.
    offset : float, optional
        Constant torque bias (N·m).

    Returns
    -------
    ndarray, shape (7,)
        ``(a1, a2, b0, b1, c1, d1, o1)``; see the module docstring for the formulas.

    Raises
    ------
    ParameterError
        ``Ts`` not > 0.
    """
    Ts = check_positive("Ts", Ts)
    J, tau, sigma = p.J, p.tau, p.sigma
    D = J * tau + J * Ts + sigma * Ts**2
    return np.array([
        (2 * J * tau + J * Ts) / D,
        J * tau / D,
        (Ts**2 + tau * Ts) / D,
        tau * Ts / D,
        p.Fc * Ts**2 / D,
        p.Fs * Ts**2 / D,
        offset * Ts**2 / D,
    ])


def theta_from_physical_printed(p: JointParams, Ts: float) -> np.ndarray:
    """The paper's *printed* (erroneous) a1, a2, b0, b1, c1, d1, kept to show the erratum.

    Returns
    -------
    ndarray, shape (6,)
        As printed in Sec. III: ``a1 = (J*tau + J*Ts)/D``, ``b0 = (Ts**2 + tau*Ts**2)/D``,
        ``b1 = tau*Ts**2/D``; the others agree with :func:`theta_from_physical`.
        Do not use for identification: its steady state is not ``u = F(w)``.
    """
    Ts = check_positive("Ts", Ts)
    J, tau, sigma = p.J, p.tau, p.sigma
    D = J * tau + J * Ts + sigma * Ts**2
    return np.array([(J * tau + J * Ts) / D, J * tau / D, (Ts**2 + tau * Ts**2) / D,
                     tau * Ts**2 / D, p.Fc * Ts**2 / D, p.Fs * Ts**2 / D])


@dataclass(frozen=True)
class FrictionEstimate:
    """Physical parameters recovered from a regression parameter vector (not range-checked).

    Attributes
    ----------
    J : float
        Inertia (kg·m²).
    tau : float
        Friction lag (s).
    sigma : float
        Viscous coefficient (N·m·s/rad).
    Fc, Fs : float
        Coulomb and static friction (N·m).
    offset : float
        Constant torque bias (N·m), 0 if not modelled.
    Vs, delta : float or None
        The Stribeck factors the model used (fixed, pre-estimated), None for Coulomb structure.
    J_alt : float
        The redundant inertia estimate ``Ts*a2/b1`` (NaN when ``b1 == 0``); its
        distance from ``J`` measures how well the data fit the physical structure.
    """

    J: float
    tau: float
    sigma: float
    Fc: float
    Fs: float
    offset: float
    Vs: float | None
    delta: float | None
    J_alt: float

    def is_plausible(self) -> bool:
        """True if all values are finite and ``J > 0``, ``tau, sigma, Fc, Fs >= 0``."""
        vals = (self.J, self.tau, self.sigma, self.Fc, self.Fs, self.offset)
        return bool(all(np.isfinite(vals)) and self.J > 0 and self.tau >= 0 and self.sigma >= 0
                    and self.Fc >= 0 and self.Fs >= 0)

    def friction(self, w):
        """Static friction ``F(w) + offset`` (N·m) of the estimate: eq. 3 plus the bias.

        Parameters
        ----------
        w : float or ndarray, any shape
            Velocity (rad/s).

        Returns
        -------
        float or ndarray, same shape as ``w``
            :func:`plant.friction.stribeck` with ``Fc, Fs, Vs, delta, sigma``,
            plus ``offset``; for the Coulomb structure (``Vs`` None)
            ``Fc*sgn(w) + sigma*w + offset`` (eq. 3 with ``Fs = Fc``).

        Raises
        ------
        ParameterError
            A level or coefficient of the estimate is not finite (nothing to evaluate).
        """
        if self.Vs is None:
            F = stribeck(w, Fc=self.Fc, Fs=self.Fc, Vs=1.0, delta=1.0, sigma=self.sigma)  # no Stribeck excess
        else:
            F = stribeck(w, Fc=self.Fc, Fs=self.Fs, Vs=self.Vs, delta=self.delta, sigma=self.sigma)
        return F + self.offset

    def to_dict(self) -> dict:
        """Strict-JSON dict of the fields (SI units); NaN/inf become None (e.g. ``J_alt`` without a lag).

        :meth:`from_dict` turns it back into an equal estimate.
        """
        return json_safe(asdict(self))

    @classmethod
    def from_dict(cls, d) -> "FrictionEstimate":
        """The estimate of a :meth:`to_dict` dict: None becomes NaN, except ``Vs``/``delta`` (None = Coulomb).

        Parameters
        ----------
        d : mapping
            Keys ``J, tau, sigma, Fc, Fs, offset, Vs, delta, J_alt``.

        Returns
        -------
        FrictionEstimate

        Raises
        ------
        ParameterError
            Missing or unknown keys.
        """
        names = [f.name for f in fields(cls)]
        if set(d) != set(names):
            raise ParameterError(f"a FrictionEstimate dict needs exactly the keys {names}, got {sorted(d)}")
        return cls(**{k: (d[k] if d[k] is not None or k in ("Vs", "delta") else math.nan) for k in names})

    def summary(self) -> str:
        """One line with the physical parameters (and the fixed Stribeck factors)."""
        txt = (f"J = {self.J:.6g}, tau = {self.tau:.6g}, sigma = {self.sigma:.6g}, Fc = {self.Fc:.6g}, "
               f"Fs = {self.Fs:.6g}, offset = {self.offset:.6g}")
        if self.Vs is not None:
            txt += f" (Vs = {self.Vs:.6g}, delta = {self.delta:.6g} fixed)"
        return txt + ("" if self.is_plausible() else "; NOT physically plausible")

    def plot(self, ax=None, *, w_max: float | None = None):
        """The static friction ``F(w) + offset`` of the estimate over ``-w_max <= w <= w_max``.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw into; default a new figure.
        w_max : float, keyword-only, optional
            Largest speed drawn (rad/s), > 0; default ``20*Vs`` (1 rad/s for the Coulomb structure).

        Returns
        -------
        matplotlib.axes.Axes

        Raises
        ------
        ParameterError
            ``w_max`` not > 0, or a parameter of the estimate not finite.
        """
        w_max = (20.0 * self.Vs if self.Vs is not None else 1.0) if w_max is None else check_positive("w_max", w_max)
        ax = axes_or_new(ax)
        w = np.linspace(-w_max, w_max, 801)
        ax.plot(w, self.friction(w), lw=1.0, label="F(w) + offset")
        ax.axhline(0.0, color="0.7", lw=0.5)
        ax.axvline(0.0, color="0.7", lw=0.5)
        ax.set_xlabel("velocity w (rad/s)")
        ax.set_ylabel("friction torque (N·m)")
        ax.legend(loc="best")
        ax.grid(True, alpha=0.3)
        return ax


class RegressionModel:
    """The linear-in-parameters model of eq. 4 for a chosen structure.

    Parameters
    ----------
    Vs : float, optional
        Stribeck velocity (rad/s), pre-estimated (Sec. V-C). Required when ``stribeck=True``.
    delta : float, optional
        Stribeck shape factor, pre-estimated. Required when ``stribeck=True``.
    lag : bool, keyword-only
        Model the friction lag ``tau`` (columns a2, b1). ``False`` fixes ``tau = 0``.
    stribeck : bool, keyword-only
        Separate Coulomb (g) and stiction (h) regressors. ``False`` is the
        Coulomb + viscous structure ``Fs = Fc`` (one regressor ``sgn(w)``), for
        data that do not excite the low-speed region.
    offset : bool, keyword-only
        Add a constant torque bias regressor (``-1``, parameter ``o1``).

    Raises
    ------
    ParameterError
        Missing or invalid ``Vs``/``delta`` for the Stribeck structure.

    Notes
    -----
    Regressor at sample ``k`` (Ruderman eq. 4; the signs make every parameter
    positive for a physical plant)::

        phi(k) = [w(k-1), -w(k-2), u(k), -u(k-1), -g(w(k-1)), -h(w(k-1)), -1]
        w(k)   = phi(k) @ theta

    with the columns of absent parts removed (``lag=False``: no ``-w(k-2)``,
    ``-u(k-1)``; ``stribeck=False``: ``-sgn(w(k-1))`` with parameter ``c1``
    standing for ``c1 = d1``; ``offset=False``: no ``-1``).
    """

    def __init__(self, Vs: float | None = None, delta: float | None = None, *, lag: bool = True,
                 stribeck: bool = True, offset: bool = False):
        self.lag = bool(lag)
        self.stribeck = bool(stribeck)
        self.offset = bool(offset)
        if self.stribeck:
            if Vs is None or delta is None:
                raise ParameterError("the Stribeck structure needs Vs and delta (pre-estimate them, Sec. V-C), "
                                     f"got Vs = {Vs!r}, delta = {delta!r}; or use stribeck=False")
            self.Vs = check_positive("Vs", Vs)
            self.delta = check_finite_scalar("delta", delta)
            if self.delta == 0.0:
                raise ParameterError("delta must be non-zero, got 0.0")
        else:
            self.Vs = None
            self.delta = None
        names = ["a1"] + (["a2"] if self.lag else []) + ["b0"] + (["b1"] if self.lag else [])
        names += ["c1", "d1"] if self.stribeck else ["c1"]
        names += ["o1"] if self.offset else []
        self.names: tuple[str, ...] = tuple(names)

    def __repr__(self) -> str:
        return (f"RegressionModel(Vs={self.Vs!r}, delta={self.delta!r}, lag={self.lag}, "
                f"stribeck={self.stribeck}, offset={self.offset})")

    def to_dict(self) -> dict:
        """Strict-JSON dict: ``Vs, delta`` (None for the Coulomb structure), ``lag, stribeck, offset, names``."""
        return json_safe({"Vs": self.Vs, "delta": self.delta, "lag": self.lag, "stribeck": self.stribeck,
                          "offset": self.offset, "names": list(self.names)})

    @property
    def n_params(self) -> int:
        """Number of parameters ``p`` (length of ``theta``)."""
        return len(self.names)

    def friction_regressors(self, w) -> list:
        """The friction columns for velocity ``w``: ``[-g, -h]`` or ``[-sgn]`` (each like ``w``)."""
        if self.stribeck:
            return [-g_regressor(w, self.Vs, self.delta), -h_regressor(w, self.Vs, self.delta)]
        return [-np.sign(w)]

    def phi(self, u_k: float, u_km1: float, w_km1: float, w_km2: float) -> np.ndarray:
        """One regressor vector ``phi(k)``, shape (p,), for the online (RLS) case."""
        cols = [w_km1] + ([-w_km2] if self.lag else []) + [u_k] + ([-u_km1] if self.lag else [])
        cols += [float(c) for c in self.friction_regressors(w_km1)]
        cols += [-1.0] if self.offset else []
        return np.array(cols, dtype=float)

    def regressors(self, u, w) -> tuple[np.ndarray, np.ndarray]:
        """Regressor matrix and output for batch identification (eq. 7: ``W = X theta + E``).

        Parameters
        ----------
        u : array_like, shape (N,)
            Input torque (N·m), uniformly sampled.
        w : array_like, shape (N,)
            Velocity (rad/s) at the same instants.

        Returns
        -------
        X : ndarray, shape (N - 2, p)
            Rows ``phi(k)`` for ``k = 2 .. N-1``.
        y : ndarray, shape (N - 2,)
            ``w(k)`` for ``k = 2 .. N-1``.

        Raises
        ------
        SignalError
            Shapes differ, fewer than ``p + 2`` samples, or non-finite values.
        """
        u = check_signal("u", u, min_len=self.n_params + 2)
        w = check_signal("w", w, n=u.shape[0])
        cols = [w[1:-1]] + ([-w[:-2]] if self.lag else []) + [u[2:]] + ([-u[1:-1]] if self.lag else [])
        cols += self.friction_regressors(w[1:-1])
        if self.offset:
            cols.append(-np.ones(u.shape[0] - 2))
        return np.column_stack(cols), w[2:].copy()

    def full_theta(self, theta) -> np.ndarray:
        """Expand a structure's ``theta`` (p,) to the canonical ``(a1, a2, b0, b1, c1, d1, o1)`` (7,)."""
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (self.n_params,):
            raise ParameterError(f"theta must have shape ({self.n_params},) for {self.names}, got {theta.shape}")
        d = dict(zip(self.names, theta))
        if not self.stribeck:
            d["d1"] = d["c1"]
        return np.array([d.get(k, 0.0) for k in THETA_NAMES])

    def theta_from_physical(self, p: JointParams, Ts: float, *, offset: float = 0.0) -> np.ndarray:
        """This structure's ``theta`` (p,) for physical parameters ``p`` (see module docstring)."""
        full = dict(zip(THETA_NAMES, theta_from_physical(p, Ts, offset=offset)))
        return np.array([full[k] for k in self.names])

    def to_physical(self, theta, Ts: float) -> FrictionEstimate:
        """Physical parameters from ``theta`` by the inverse map of the module docstring.

        Parameters
        ----------
        theta : array_like, shape (p,)
            Regression parameters of this structure.
        Ts : float
            Sample time (s) the model was identified at.

        Returns
        -------
        FrictionEstimate
            Non-finite entries if ``b0 == b1`` (no input gain identified).

        Raises
        ------
        ParameterError
            Wrong shape of ``theta`` or ``Ts`` not > 0.
        """
        Ts = check_positive("Ts", Ts)
        a1, a2, b0, b1, c1, d1, o1 = self.full_theta(theta)
        gain = b0 - b1
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.float64(1.0) / np.float64(gain)
            J_alt = Ts * a2 / b1 if b1 != 0 else float("nan")
            return FrictionEstimate(
                J=float(Ts * (a1 - 2 * a2) * inv), tau=float(Ts * b1 * inv),
                sigma=float((1 - a1 + a2) * inv), Fc=float(c1 * inv), Fs=float(d1 * inv),
                offset=float(o1 * inv), Vs=self.Vs, delta=self.delta, J_alt=float(J_alt))

    def predict(self, theta, u, w) -> np.ndarray:
        """One-step-ahead prediction ``w_hat(k) = phi(k) @ theta`` from measured data.

        Returns
        -------
        ndarray, shape (N,)
            The first two entries are the measured ``w[0], w[1]`` (no prediction possible).
        """
        X, y = self.regressors(u, w)
        out = np.asarray(w, dtype=float).reshape(-1).copy()
        out[2:] = X @ np.asarray(theta, dtype=float)
        return out

    def simulate(self, theta, u, w_init) -> np.ndarray:
        """Free-run simulation of eq. 4: the model's own past outputs feed back.

        Parameters
        ----------
        theta : array_like, shape (p,)
            Regression parameters.
        u : array_like, shape (N,)
            Input torque (N·m).
        w_init : array_like, shape (2,)
            ``w[0], w[1]`` to start from (rad/s).

        Returns
        -------
        ndarray, shape (N,)
            Simulated velocity (rad/s). Diverging models give inf/NaN, not an error.
        """
        u = check_signal("u", u, min_len=2)
        th = self.full_theta(theta)
        a1, a2, b0, b1, c1, d1, o1 = th.tolist()
        w = np.empty(u.shape[0])
        w[0], w[1] = np.asarray(w_init, dtype=float)[:2]
        with np.errstate(all="ignore"):
            for k in range(2, u.shape[0]):
                wk1 = w[k - 1]
                if self.stribeck:
                    fr = c1 * g_regressor(wk1, self.Vs, self.delta) + d1 * h_regressor(wk1, self.Vs, self.delta)
                else:
                    fr = c1 * np.sign(wk1)
                w[k] = a1 * wk1 - a2 * w[k - 2] + b0 * u[k] - b1 * u[k - 1] - fr - o1
        return w


def nrmse_fit(y, y_hat) -> float:
    """Normalised fit in percent, ``100*(1 - ||y - y_hat|| / ||y - mean(y)||)`` (MATLAB ``compare``).

    Parameters
    ----------
    y, y_hat : array_like, shape (N,)
        Measured and modelled signal.

    Returns
    -------
    float
        100 for a perfect fit, 0 for the mean, negative (or -inf) for worse.

    Raises
    ------
    ExcitationError
        ``y`` is constant (the fit is undefined).
    """
    y = np.asarray(y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float)
    den = np.linalg.norm(y - y.mean())
    if den == 0:
        raise ExcitationError("nrmse_fit: the measured signal is constant; the fit is undefined")
    with np.errstate(all="ignore"):
        num = np.linalg.norm(y - y_hat)
    return float(100.0 * (1.0 - num / den)) if np.isfinite(num) else float("-inf")


def eq4_phi(phi, model: "RegressionModel", u_k, u_km1, w_km1, w_km2) -> int:
    """Regressor ``phi(k)`` of eq. 4 written into ``phi`` by C (``adaptive_ff/csrc/aff_regression.c``,
    ``aff_eq4_phi``): :meth:`RegressionModel.phi` as the C components compute it.

    Parameters
    ----------
    phi : ndarray, shape (>= p,), float64, C-contiguous, writable
        Output, ``p`` as :attr:`RegressionModel.n_params` of ``model``.
    model : RegressionModel
        The structure (``lag``, ``stribeck``, ``offset``) and, for the Stribeck structure, its ``Vs`` (rad/s) and
        shape ``delta``.
    u_k, u_km1 : float
        Torque ``u(k)``, ``u(k-1)`` (N·m).
    w_km1, w_km2 : float
        Velocity ``w(k-1)``, ``w(k-2)`` (rad/s).

    Returns
    -------
    int
        ``p``, the number of entries written.

    Raises
    ------
    ParameterError
        ``phi`` not a writable C-contiguous float64 array of at least ``p`` entries.

    Notes
    -----
    Ruderman eqs. 4-6: ``[w(k-1), -w(k-2), u(k), -u(k-1), -g(w(k-1)), -h(w(k-1)), -1]`` without the
    absent columns; the operations of :meth:`RegressionModel.phi`, with plant's one Stribeck decay of eq. 3
    (C ``plant_stribeck_shape``).
    """
    p = model.n_params
    if (not isinstance(phi, np.ndarray) or phi.dtype != np.float64 or phi.ndim != 1 or phi.shape[0] < p
            or not phi.flags.c_contiguous or not phi.flags.writeable):
        raise ParameterError(f"phi must be a writable C-contiguous float64 array of at least {p} entries")
    Vs, delta = (model.Vs, model.delta) if model.stribeck else (1.0, 1.0)  # unused by C without the Stribeck term
    return int(lib.aff_eq4_phi(ffi.from_buffer("double[]", phi, require_writable=True), u_k, u_km1, w_km1, w_km2,
                               Vs, delta, model.lag, model.stribeck, model.offset))


def eq4_to_physical(theta, Ts, lag, stribeck, offset) -> tuple:
    """Inverse map of eq. 4 by C (``adaptive_ff/csrc/aff_regression.c``, ``aff_eq4_to_physical``):
    :meth:`RegressionModel.to_physical` as the C components compute it.

    Parameters
    ----------
    theta : array_like, shape (p,)
        Regression parameters of the structure ``(lag, stribeck, offset)`` (order of
        :attr:`RegressionModel.names`).
    Ts : float
        Sample time (s) of the model, > 0 (not checked).
    lag, stribeck, offset : bool
        The structure.

    Returns
    -------
    tuple of 7 floats
        ``(J, tau, sigma, Fc, Fs, offset, J_alt)`` by the inverse map of the module docstring (same
        operations as :meth:`RegressionModel.to_physical`; ``±inf``/NaN where ``b0 == b1``, ``J_alt``
        NaN where ``b1 == 0``).

    Raises
    ------
    ParameterError
        ``theta`` of the wrong length for the structure.
    """
    lag, stribeck, offset = bool(lag), bool(stribeck), bool(offset)
    th = np.ascontiguousarray(theta, dtype=float).reshape(-1)
    p = 3 + 2 * lag + stribeck + offset
    if th.shape != (p,):
        raise ParameterError(f"theta must have {p} entries for this structure, got shape {np.shape(theta)}")
    out = ffi.new("aff_physical *")
    lib.aff_eq4_to_physical(ffi.from_buffer("double[]", th), Ts, lag, stribeck, offset, out)
    return (out.J, out.tau, out.sigma, out.Fc, out.Fs, out.offset, out.J_alt)
