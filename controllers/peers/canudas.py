"""Peer 1: adaptive Coulomb + viscous friction compensation (Canudas de Wit, Åström, Braun 1987).

C. Canudas de Wit, K. J. Åström, K. Braun, "Adaptive friction compensation in
DC-motor drives", IEEE J. Robotics and Automation 3(6), 1987, pp. 681-685: the
friction is modelled as Coulomb plus viscous friction with separate
coefficients for the two directions of motion, the coefficients are estimated
online by recursive least squares from the motor's input and velocity, and
the compensation adds the estimated friction torque to the controller output
(Ruderman's ref. [1]; Armstrong-Hélouvry, Dupont, Canudas de Wit, "A survey of
models, analysis tools and compensation methods for the control of machines
with friction", Automatica 30(7), 1994, Sec. 5).

Implemented here as the classic explicit scheme on the sampled motor model,
with the same RLS machinery as the package's own estimator (directional
forgetting, projection) so that the comparison is about the friction model and
the regression, not about numerics.

Compensator component (``KIND = 4``): the whole configuration is in the float64
array ``params``, the whole mutable state (including the RLS buffer of
:mod:`adaptive_ff.identification.rls`) in ``state``; the two compiled kernels
:func:`canudas_compensate` and :func:`canudas_observe` are the one
implementation, called by :class:`CanudasCompensator`'s methods and by the
closed-loop engine. Layouts::

    params: Tc, Ts, m, w_dead, warmup, ff_max, ff_measured (1.0/0.0), torque and velocity range gates
            (7 + 2*RANGE_NPAR)
    state:  on, Fc_pos, Fc_neg, sigma_pos, sigma_neg, k, u_sum, w_prev,
            has_prev, ok, n_rejected, k % m, phi[5] (scratch), torque and velocity range gates,
            RLS buffer (17 + 2*RANGE_NSTATE + rls_buffer_size(5))
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.compensation.gate import RANGE_NPAR, RANGE_NSTATE, RangeGate, range_commit, range_ok
from adaptive_ff.identification.rls import (RecursiveLeastSquares, rls_buffer_size, rls_n_updates, rls_theta,
                                            rls_update)
from plant.component import Component
from plant.errors import ParameterError, check_multiple, check_nonnegative, check_positive
from plant.jit import kernel

__all__ = ["CanudasCompensator", "canudas_compensate", "canudas_observe", "CANUDAS_KIND", "CANUDAS_N_THETA"]

#: Compensator kind code of :class:`CanudasCompensator` (engine protocol).
CANUDAS_KIND = 4
#: Length of the reported parameter vector ``theta``.
CANUDAS_N_THETA = 5

# params slots
_P_TC, _P_TS, _P_M, _P_WDEAD, _P_WARMUP, _P_FFMAX, _P_MEAS = range(7)
_P_UR = 7  # torque range gate, then the velocity range gate
_NPAR = _P_UR + 2 * RANGE_NPAR
# state slots
_S_ON, _S_FCP, _S_FCN, _S_SP, _S_SN, _S_K, _S_USUM, _S_WPREV, _S_HASPREV, _S_OK, _S_NREJ, _S_PHASE = range(12)
_S_PHI = 12
_S_UR = 17  # torque range gate, then the velocity range gate
_S_RLS = _S_UR + 2 * RANGE_NSTATE


@kernel(inline="always")
def _clip(x, lo, hi):
    """``min(max(x, lo), hi)`` with Python's tie and signed-zero rules."""
    y = lo if lo > x else x
    return hi if hi < y else y


@kernel
def canudas_compensate(par, st, w_ctrl, w_meas, w_ref):
    """Compensation torque for this period (N·m): the estimated direction-dependent friction map.

    Parameters
    ----------
    par, st : ndarray, shape (7,) and (17 + rls_buffer_size(5),), float64
        ``CanudasCompensator.params`` and ``.state`` (layout in the module docstring).
    w_ctrl : float
        Velocity the controller uses this period (rad/s); evaluated when ``ff_measured``; a non-finite
        velocity, or one at which the map overflows, gives 0 (no compensation without a velocity).
    w_meas : float
        Raw measured velocity (rad/s), unused.
    w_ref : float
        Reference velocity (rad/s); evaluated unless ``ff_measured``.

    Returns
    -------
    float
        ``Fc_pos + sigma_pos*w`` (w > 0), ``-Fc_neg + sigma_neg*w`` (w < 0), 0 at w = 0, clipped to
        ``±ff_max``; 0 before the warm-up is over (Canudas de Wit et al. 1987, eq. 2).
    """
    if st[_S_ON] == 0.0:
        return 0.0
    w = w_ctrl if par[_P_MEAS] != 0.0 else w_ref
    if not math.isfinite(w):
        return 0.0
    if w > 0.0:
        c = st[_S_FCP] + st[_S_SP] * w
    elif w < 0.0:
        c = -st[_S_FCN] + st[_S_SN] * w
    else:
        c = 0.0
    if not math.isfinite(c):  # a velocity so large that the map overflows: no compensation
        return 0.0
    return _clip(c, -par[_P_FFMAX], par[_P_FFMAX])


@kernel
def _canudas_update(par, st, w0, w1, ubar):
    """One RLS update on the interval ``w0 -> w1`` if it lies beyond the dead zone; True when used."""
    wd = par[_P_WDEAD]
    phi = st[_S_PHI:_S_PHI + 5]
    if w0 > wd and w1 > wd:
        phi[0] = ubar
        phi[1] = -w0
        phi[2] = 0.0
        phi[3] = -1.0
        phi[4] = 0.0
    elif w0 < -wd and w1 < -wd:
        phi[0] = ubar
        phi[1] = 0.0
        phi[2] = -w0
        phi[3] = 0.0
        phi[4] = 1.0
    else:
        return False
    buf = st[_S_RLS:]
    n0 = rls_n_updates(buf)
    rls_update(buf, phi, w1 - w0)
    n1 = rls_n_updates(buf)
    if n1 == n0:  # a non-finite row (overflow of finite samples) is refused and counted
        st[_S_NREJ] += 1.0
        return False
    if n1 >= par[_P_WARMUP]:
        b = rls_theta(buf, 0)
        st[_S_FCP] = rls_theta(buf, 3) / b
        st[_S_FCN] = rls_theta(buf, 4) / b
        st[_S_SP] = rls_theta(buf, 1) / b
        st[_S_SN] = rls_theta(buf, 2) / b
        st[_S_ON] = 1.0
    return True


@kernel
def canudas_observe(par, st, u, w_meas, theta_out):
    """Record the torque applied in this period and the velocity measured at its start; update every ``m`` periods.

    Parameters
    ----------
    par, st : ndarray, float64
        ``CanudasCompensator.params`` and ``.state``.
    u : float
        Torque applied in this period (N·m).
    w_meas : float
        Velocity measured at the start of this period (rad/s).
    theta_out : ndarray, shape (>= 5,), float64
        Receives ``theta = (b, b*sigma_pos, b*sigma_neg, b*Fc_pos, b*Fc_neg)`` when the RLS was updated.

    Returns
    -------
    bool
        True when the RLS estimate was updated in this call.

    Notes
    -----
    Every ``m``-th call closes a sample interval of ``Ts``: with the mean torque ``u_bar`` over it and the
    velocities ``w0``, ``w1`` at its ends, the row ``(u_bar, -w0*1(w>0), -w0*1(w<0), -1(w>0), +1(w<0))``
    with output ``w1 - w0`` updates the RLS (eqs. 10-13 with directional forgetting) when both velocities
    lie beyond ``±w_dead`` with one sign. A non-finite or out-of-range ``u`` or ``w`` (the range gates of
    :class:`CanudasCompensator`) is counted and spoils the current interval.
    """
    pu = par[_P_UR:_P_UR + RANGE_NPAR]
    pw = par[_P_UR + RANGE_NPAR:_P_UR + 2 * RANGE_NPAR]
    su = st[_S_UR:_S_UR + RANGE_NSTATE]
    sw = st[_S_UR + RANGE_NSTATE:_S_RLS]
    uok = range_ok(pu, su, u)
    wok = range_ok(pw, sw, w_meas)
    if not (uok and wok):  # a rejected sample counts in the failing gate(s) only
        if not uok:
            range_commit(pu, su, u, False)
        if not wok:
            range_commit(pw, sw, w_meas, False)
        st[_S_NREJ] += 1.0
        st[_S_OK] = 0.0
        return False
    range_commit(pu, su, u, True)
    range_commit(pw, sw, w_meas, True)
    upd = False
    if st[_S_PHASE] == 0.0:  # k % m == 0, kept as a counter (no integer division per period)
        if st[_S_HASPREV] != 0.0 and st[_S_OK] != 0.0:
            upd = _canudas_update(par, st, st[_S_WPREV], w_meas, st[_S_USUM] / par[_P_M])
        st[_S_WPREV] = w_meas
        st[_S_HASPREV] = 1.0
        st[_S_USUM] = 0.0
        st[_S_OK] = 1.0
    st[_S_USUM] += u
    st[_S_K] += 1.0
    ph = st[_S_PHASE] + 1.0
    st[_S_PHASE] = 0.0 if ph >= par[_P_M] else ph
    if upd:
        buf = st[_S_RLS:]
        for i in range(5):
            theta_out[i] = rls_theta(buf, i)
    return upd


class CanudasCompensator(Component):
    """Direction-dependent Coulomb + viscous friction, estimated by RLS, compensated at a velocity.

    Parameters
    ----------
    Tc : float, keyword-only
        Controller period (s): :meth:`compensate` and :meth:`observe` are called once per period.
    Ts : float, keyword-only
        Sample time of the estimator (s), a multiple of ``Tc``; default 10 ms.
    lam : float, keyword-only
        Forgetting factor per RLS update; default 0.999.
    forgetting : {"directional", "exponential"}, keyword-only
        RLS forgetting scheme, default directional.
    P0 : float, keyword-only
        Initial covariance scale, default 1e4.
    J_guess : float, keyword-only
        Initial inertia (kg·m²) for ``theta0``; default 1.
    w_dead : float, keyword-only
        Estimation dead zone (rad/s): a sample interval is used only if the
        velocity stays beyond ``±w_dead`` with one sign (no reversal, no
        sticking); default 5e-3.
    warmup : int, keyword-only
        RLS updates before the compensation is switched on; default 300.
    ff_max : float, keyword-only
        Bound on |compensation| (N·m), default inf.
    ff_input : {"measured", "reference"}, keyword-only
        Velocity the compensation is evaluated at; default measured (the
        velocity feedback of the original).
    u_range, w_range : RangeGate, keyword-only
        Range gates of the torque (N·m) and velocity (rad/s) samples; defaults
        ``RangeGate()`` and ``RangeGate(floor=w_dead)``: a sample above
        100 times the envelope of the accepted ones is refused
        (:class:`adaptive_ff.compensation.gate.RangeGate`).

    Attributes
    ----------
    KIND : int
        4 (compensator protocol of the closed-loop engine).
    params, state : ndarray, float64
        Configuration and state (layouts in the module docstring), advanced in place by
        :func:`canudas_compensate` and :func:`canudas_observe` (:class:`plant.component.Component`).
    n_theta : int
        5.
    rls : RecursiveLeastSquares
        ``theta = (b, b*sigma_pos, b*sigma_neg, b*Fc_pos, b*Fc_neg)``, ``b = Ts/J``; its buffer is the
        tail of ``state``.
    coef : tuple of 4 floats or None
        ``(Fc_pos, Fc_neg, sigma_pos, sigma_neg)`` in use, None before warm-up (read/write).
    n_rejected : int
        Samples ignored: non-finite or out of range (the range gates), or an RLS
        update that would overflow.

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Sampled motor model over one period ``Ts`` (Euler, torque averaged over the
    period ``u_bar``)::

        w(k+1) - w(k) = b*u_bar(k) - b*sigma_d*w(k) - b*Fc_d*sgn(w(k)),   b = Ts/J

    with ``d`` the direction of ``w(k)``. Regressor
    ``(u_bar, -w*1(w>0), -w*1(w<0), -1(w>0), +1(w<0))``. Compensation
    ``u_c = Fc_d*sgn(w) + sigma_d*w`` with the estimated coefficients. The
    model has no friction lag and no Stribeck effect: that is the difference
    to Ruderman's model that the comparison measures.
    """

    KIND = CANUDAS_KIND
    MODE = "canudas"
    n_theta = CANUDAS_N_THETA

    def __init__(self, *, Tc: float, Ts: float = 0.01, lam: float = 0.999, forgetting: str = "directional",
                 P0: float = 1e4, J_guess: float = 1.0, w_dead: float = 5e-3, warmup: int = 300,
                 ff_max: float = math.inf, ff_input: str = "measured", u_range: RangeGate | None = None,
                 w_range: RangeGate | None = None):
        Tc = check_positive("Tc", Tc)
        m = check_multiple("Ts", Ts, "Tc", Tc)
        w_dead = check_nonnegative("w_dead", w_dead)
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
            raise ParameterError(f"warmup must be an integer >= 0, got {warmup!r}")
        ff_max = math.inf if ff_max == math.inf else check_nonnegative("ff_max", ff_max)
        if ff_input not in ("measured", "reference"):
            raise ParameterError(f"ff_input must be 'measured' or 'reference', got {ff_input!r}")
        Ts = m * Tc
        b0 = Ts / check_positive("J_guess", J_guess)
        inf = math.inf
        rls = RecursiveLeastSquares(5, lam=lam, P0=P0, forgetting=forgetting, theta0=[b0, 0, 0, 0, 0],
                                    bounds=([1e-12, 0, 0, 0, 0], [inf, inf, inf, inf, inf]))
        u_range = RangeGate() if u_range is None else u_range
        w_range = RangeGate(floor=w_dead) if w_range is None else w_range
        for name, g in (("u_range", u_range), ("w_range", w_range)):
            if not isinstance(g, RangeGate):
                raise ParameterError(f"{name} must be a RangeGate, got {type(g).__name__}")
        self._init_arrays(_NPAR, _S_RLS + rls_buffer_size(5))
        self.params[:_P_UR] = (Tc, Ts, float(m), w_dead, float(warmup), ff_max,
                               1.0 if ff_input == "measured" else 0.0)
        self.state[_S_OK] = 1.0
        self.rls = rls
        self.u_range = u_range
        self.w_range = w_range
        self._theta_out = np.empty(5)
        self._attached()

    def _attached(self) -> None:
        self.u_range.attach(self.params[_P_UR:_P_UR + RANGE_NPAR], self.state[_S_UR:_S_UR + RANGE_NSTATE])
        self.w_range.attach(self.params[_P_UR + RANGE_NPAR:_NPAR], self.state[_S_UR + RANGE_NSTATE:_S_RLS])
        self.rls.attach(self.state[_S_RLS:])

    def __repr__(self) -> str:
        return (f"CanudasCompensator(Tc={self.Tc!r}, Ts={self.Ts!r}, w_dead={self.w_dead!r}, "
                f"warmup={self.warmup}, ff_max={self.ff_max!r}, n_updates={self.rls.n_updates})")

    # ---- configuration (read-only views of params)
    @property
    def Tc(self) -> float:
        """Controller period (s)."""
        return float(self.params[_P_TC])

    @property
    def Ts(self) -> float:
        """Estimator sample time ``m*Tc`` (s)."""
        return float(self.params[_P_TS])

    @property
    def m(self) -> int:
        """Controller periods per estimator sample."""
        return int(self.params[_P_M])

    @property
    def w_dead(self) -> float:
        """Estimation dead zone (rad/s)."""
        return float(self.params[_P_WDEAD])

    @property
    def warmup(self) -> int:
        """RLS updates before the compensation is switched on."""
        return int(self.params[_P_WARMUP])

    @property
    def ff_max(self) -> float:
        """Bound on |compensation| (N·m)."""
        return float(self.params[_P_FFMAX])

    @property
    def ff_measured(self) -> bool:
        """True: compensation at the controller's measured velocity; False: at the reference."""
        return self.params[_P_MEAS] != 0.0

    # ---- state (read/write views of state)
    @property
    def coef(self) -> tuple | None:
        """``(Fc_pos, Fc_neg, sigma_pos, sigma_neg)`` in use (N·m, N·m·s/rad), or None before warm-up."""
        st = self.state
        if st[_S_ON] == 0.0:
            return None
        return (float(st[_S_FCP]), float(st[_S_FCN]), float(st[_S_SP]), float(st[_S_SN]))

    @coef.setter
    def coef(self, value) -> None:
        st = self.state
        if value is None:
            st[_S_ON] = 0.0
            return
        try:
            Fcp, Fcn, sp, sn = (float(v) for v in value)
        except (TypeError, ValueError):
            raise ParameterError(f"coef must be None or 4 numbers (Fc_pos, Fc_neg, sigma_pos, sigma_neg), "
                                 f"got {value!r}") from None
        st[_S_FCP], st[_S_FCN], st[_S_SP], st[_S_SN] = Fcp, Fcn, sp, sn
        st[_S_ON] = 1.0

    @property
    def n_rejected(self) -> int:
        """Non-finite samples ignored."""
        return int(self.state[_S_NREJ])

    @n_rejected.setter
    def n_rejected(self, value: int) -> None:
        self.state[_S_NREJ] = int(value)

    @property
    def _k(self) -> int:
        return int(self.state[_S_K])

    @_k.setter
    def _k(self, value: int) -> None:
        self.state[_S_K] = int(value)
        self.state[_S_PHASE] = int(value) % self.m

    @property
    def _usum(self) -> float:
        return float(self.state[_S_USUM])

    @_usum.setter
    def _usum(self, value: float) -> None:
        self.state[_S_USUM] = value

    @property
    def _w_prev(self) -> float | None:
        return float(self.state[_S_WPREV]) if self.state[_S_HASPREV] != 0.0 else None

    @_w_prev.setter
    def _w_prev(self, value: float | None) -> None:
        self.state[_S_HASPREV] = 0.0 if value is None else 1.0
        self.state[_S_WPREV] = 0.0 if value is None else value

    @property
    def _ok(self) -> bool:
        return self.state[_S_OK] != 0.0

    @_ok.setter
    def _ok(self, value: bool) -> None:
        self.state[_S_OK] = 1.0 if value else 0.0

    @property
    def estimate(self) -> dict | None:
        """``{"J", "Fc_pos", "Fc_neg", "sigma_pos", "sigma_neg"}`` in use (SI units), or None before warm-up."""
        coef = self.coef
        if coef is None:
            return None
        b = float(self.rls.theta[0])
        Fcp, Fcn, sp, sn = coef
        return {"J": self.Ts / b, "Fc_pos": Fcp, "Fc_neg": Fcn, "sigma_pos": sp, "sigma_neg": sn}

    def info(self) -> dict:
        """Counters and the estimate in use, for run reports (JSON-safe).

        Returns
        -------
        dict
            ``n_rejected``, ``n_updates`` (RLS), ``lam``, ``canudas_estimate`` (:attr:`estimate`).
        """
        return {"n_rejected": self.n_rejected, "n_updates": self.rls.n_updates, "lam": self.rls.lam,
                "canudas_estimate": self.estimate}

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensation torque (N·m) for this period, bounded by ``ff_max`` (:func:`canudas_compensate`).

        Parameters
        ----------
        w_meas : float
            Measured velocity (rad/s).
        w_ref : float
            Reference velocity (rad/s).

        Returns
        -------
        float
        """
        w_meas = float(w_meas)
        return canudas_compensate(self.params, self.state, w_meas, w_meas, float(w_ref))

    def observe(self, u: float, w: float) -> None:
        """Record the torque applied in this period and the velocity measured at its start (:func:`canudas_observe`).

        Parameters
        ----------
        u : float
            Applied torque (N·m).
        w : float
            Measured velocity (rad/s).

        Notes
        -----
        A non-finite or out-of-range value is counted in ``n_rejected`` and spoils the current sample
        interval.
        """
        canudas_observe(self.params, self.state, float(u), float(w), self._theta_out)
