"""Peer 2: disturbance observer with a Q-filter (the industrial default for friction compensation).

K. Ohnishi, M. Shibata, T. Murakami, "Motion control for advanced
mechatronics", IEEE/ASME Trans. Mechatronics 1(1), 1996; the discrete design
with a binomial Q-filter as in Umeno & Hori, "Robust speed control of DC
servomotors using modern two degrees-of-freedom controller design", IEEE
Trans. Ind. Electron. 38(5), 1991. The observer needs no friction model: it
estimates the lumped disturbance torque from the nominal inverse plant and
cancels it within the Q-filter bandwidth.

Compensator component (``KIND = 5``): configuration in the float64 array
``params``, state in ``state``; the compiled kernels :func:`dob_compensate`
and :func:`dob_observe` are the one implementation, called by
:class:`DisturbanceObserver`'s methods and by the closed-loop engine. Layouts::

    params: Tc, J_n, omega_q, order, a, d_max, torque and velocity range gates     (6 + 2*RANGE_NPAR)
    state:  d_hat, u_last, w_last, has_w_last, n_rejected, torque and velocity range gates,
            x[order]                                                              (5 + 2*RANGE_NSTATE + order)
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.compensation.gate import RANGE_NPAR, RANGE_NSTATE, RangeGate, range_commit, range_ok
from plant.component import Component
from plant.errors import ParameterError, check_nonnegative, check_positive
from plant.jit import kernel

__all__ = ["DisturbanceObserver", "dob_compensate", "dob_observe", "DOB_KIND"]

#: Compensator kind code of :class:`DisturbanceObserver` (engine protocol).
DOB_KIND = 5

_P_TC, _P_JN, _P_OMEGA, _P_ORDER, _P_A, _P_DMAX = range(6)
_P_UR = 6  # torque range gate, then the velocity range gate
_NPAR = _P_UR + 2 * RANGE_NPAR
_S_D, _S_ULAST, _S_WLAST, _S_HASW, _S_NREJ = range(5)
_S_UR = 5  # torque range gate, then the velocity range gate
_S_X = _S_UR + 2 * RANGE_NSTATE


@kernel
def dob_compensate(par, st, w_ctrl, w_meas, w_ref):
    """Advance the observer with the controller's velocity of this period; return the bounded ``d_hat`` (N·m).

    Parameters
    ----------
    par, st : ndarray, shape (6,) and (5 + order,), float64
        ``DisturbanceObserver.params`` and ``.state`` (layouts in the module docstring).
    w_ctrl : float
        Velocity the controller uses this period (rad/s); a non-finite or out-of-range value (the
        velocity range gate) is counted and the estimate held.
    w_meas, w_ref : float
        Raw measurement and reference (rad/s), unused.

    Returns
    -------
    float
        ``d_hat = Q[u(k-1) - J_n*(w(k) - w(k-1))/Tc]`` clipped to ``±d_max`` (Umeno & Hori 1991;
        class Notes).
    """
    pw = par[_P_UR + RANGE_NPAR:_NPAR]
    sw = st[_S_UR + RANGE_NSTATE:_S_X]
    ok = range_ok(pw, sw, w_ctrl)
    range_commit(pw, sw, w_ctrl, ok)
    if not ok:
        st[_S_NREJ] += 1.0
        return st[_S_D]
    if st[_S_HASW] == 0.0:
        st[_S_WLAST] = w_ctrl
        st[_S_HASW] = 1.0
        return st[_S_D]
    v = st[_S_ULAST] - par[_P_JN] * (w_ctrl - st[_S_WLAST]) / par[_P_TC]
    st[_S_WLAST] = w_ctrl
    a = par[_P_A]
    for i in range(np.int64(par[_P_ORDER])):
        j = _S_X + i
        st[j] += a * (v - st[j])
        v = st[j]
    dmax = par[_P_DMAX]
    y = -dmax if -dmax > v else v
    st[_S_D] = dmax if dmax < y else y
    return st[_S_D]


@kernel
def dob_observe(par, st, u, w_meas, theta_out):
    """Record the torque ``u`` (N·m) applied in this period (it drives the next velocity sample).

    Parameters
    ----------
    par, st : ndarray, float64
        ``DisturbanceObserver.params`` and ``.state``.
    u : float
        Applied torque (N·m); a non-finite or out-of-range value (the torque range gate) is counted
        and ignored (the last one is kept).
    w_meas : float
        Measured velocity (rad/s), unused.
    theta_out : ndarray, float64
        Unused (the observer reports no parameter vector).

    Returns
    -------
    bool
        Always False.
    """
    pu = par[_P_UR:_P_UR + RANGE_NPAR]
    su = st[_S_UR:_S_UR + RANGE_NSTATE]
    ok = range_ok(pu, su, u)
    range_commit(pu, su, u, ok)
    if ok:
        st[_S_ULAST] = u
    else:
        st[_S_NREJ] += 1.0
    return False


class DisturbanceObserver(Component):
    """Velocity-loop disturbance observer ``d_hat = Q*(u - J_n*dw/dt)``, added to the controller output.

    Parameters
    ----------
    J_n : float, keyword-only
        Nominal inertia (kg·m²), > 0 (the same value the PI design uses).
    omega_q : float, keyword-only
        Q-filter cut-off (rad/s), > 0; default 500 (25 times the default
        velocity-loop crossover, 80 Hz at the 1 kHz sampling rate; higher
        tracks better and injects more measurement noise into the torque,
        see docs/benchmarks/compensation.md).
    Tc : float, keyword-only
        Controller period (s).
    order : int, keyword-only
        Order of the binomial Q-filter ``1/(1 + s/omega_q)**order``, >= 1
        (``J_n*s*Q`` must be proper); default 2.
    d_max : float, keyword-only
        Bound on |d_hat| (N·m), default inf.
    u_range, w_range : RangeGate, keyword-only
        Range gates of the torque (N·m) and velocity (rad/s) samples; default
        ``RangeGate()`` each: a sample above 100 times the envelope of the
        accepted ones is ignored (:class:`adaptive_ff.compensation.gate.RangeGate`).

    Attributes
    ----------
    KIND : int
        5 (compensator protocol of the closed-loop engine).
    params, state : ndarray, float64
        Configuration and state (layouts in the module docstring; :class:`plant.component.Component`).
    n_theta : int
        0 (no parameter vector).
    d_hat : float
        Current disturbance estimate (N·m).
    n_rejected : int
        Non-finite or out-of-range velocity samples (the estimate is held) and
        torque samples (the last torque is kept).

    Raises
    ------
    ParameterError
        Invalid settings (the message quotes the value).

    Notes
    -----
    Plant ``J*dw/dt = u - d`` (here ``d`` = friction). Discrete form, exact for
    a torque held over each period: the raw disturbance sample is
    ``v(k) = u(k-1) - J_n*(w(k) - w(k-1))/Tc`` (the mean of ``d`` over the last
    period when ``J_n = J``), and ``d_hat = Q[v]`` with ``Q`` realised as
    ``order`` cascaded first-order lags (each ``x += a*(input - x)``,
    ``a = 1 - exp(-Tc*omega_q)``, unit gain at zero frequency). The
    compensated command is ``u = u_PI + d_hat``.
    """

    KIND = DOB_KIND
    MODE = "dob"
    n_theta = 0

    def __init__(self, *, J_n: float, omega_q: float = 500.0, Tc: float, order: int = 2, d_max: float = math.inf,
                 u_range: RangeGate | None = None, w_range: RangeGate | None = None):
        J_n = check_positive("J_n", J_n)
        omega_q = check_positive("omega_q", omega_q)
        Tc = check_positive("Tc", Tc)
        if isinstance(order, bool) or not isinstance(order, int) or order < 1:
            raise ParameterError(f"order must be an integer >= 1, got {order!r}")
        d_max = math.inf if d_max == math.inf else check_nonnegative("d_max", d_max)
        u_range = RangeGate() if u_range is None else u_range
        w_range = RangeGate() if w_range is None else w_range
        for name, g in (("u_range", u_range), ("w_range", w_range)):
            if not isinstance(g, RangeGate):
                raise ParameterError(f"{name} must be a RangeGate, got {type(g).__name__}")
        self._init_arrays(_NPAR, _S_X + order)
        self.params[:_P_UR] = (Tc, J_n, omega_q, float(order), 1.0 - math.exp(-Tc * omega_q), d_max)
        self.u_range = u_range
        self.w_range = w_range
        self._theta_out = np.empty(0)
        self._attached()

    def _attached(self) -> None:
        self.u_range.attach(self.params[_P_UR:_P_UR + RANGE_NPAR], self.state[_S_UR:_S_UR + RANGE_NSTATE])
        self.w_range.attach(self.params[_P_UR + RANGE_NPAR:_NPAR], self.state[_S_UR + RANGE_NSTATE:_S_X])

    def __repr__(self) -> str:
        return (f"DisturbanceObserver(J_n={self.J_n!r}, omega_q={self.omega_q!r}, Tc={self.Tc!r}, "
                f"order={self.order}, d_max={self.d_max!r})")

    @property
    def J_n(self) -> float:
        """Nominal inertia (kg·m²)."""
        return float(self.params[_P_JN])

    @property
    def omega_q(self) -> float:
        """Q-filter cut-off (rad/s)."""
        return float(self.params[_P_OMEGA])

    @property
    def Tc(self) -> float:
        """Controller period (s)."""
        return float(self.params[_P_TC])

    @property
    def order(self) -> int:
        """Order of the binomial Q-filter."""
        return int(self.params[_P_ORDER])

    @property
    def d_max(self) -> float:
        """Bound on |d_hat| (N·m)."""
        return float(self.params[_P_DMAX])

    @property
    def _a(self) -> float:
        return float(self.params[_P_A])

    @property
    def d_hat(self) -> float:
        """Current disturbance estimate (N·m)."""
        return float(self.state[_S_D])

    @d_hat.setter
    def d_hat(self, value: float) -> None:
        self.state[_S_D] = value

    @property
    def n_rejected(self) -> int:
        """Rejected samples: non-finite or out-of-range velocities (the estimate was held) and torques."""
        return int(self.state[_S_NREJ])

    @n_rejected.setter
    def n_rejected(self, value: int) -> None:
        self.state[_S_NREJ] = int(value)

    @property
    def _u_last(self) -> float:
        return float(self.state[_S_ULAST])

    @_u_last.setter
    def _u_last(self, value: float) -> None:
        self.state[_S_ULAST] = value

    @property
    def _w_last(self) -> float | None:
        return float(self.state[_S_WLAST]) if self.state[_S_HASW] != 0.0 else None

    @_w_last.setter
    def _w_last(self, value: float | None) -> None:
        self.state[_S_HASW] = 0.0 if value is None else 1.0
        self.state[_S_WLAST] = 0.0 if value is None else value

    def info(self) -> dict:
        """Counter and settings for run reports: ``n_rejected``, ``J_n`` (kg·m²), ``omega_q`` (rad/s).

        Returns
        -------
        dict
        """
        return {"n_rejected": self.n_rejected, "J_n": self.J_n, "omega_q": self.omega_q}

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Advance the observer with the measured velocity of this period (:func:`dob_compensate`).

        Parameters
        ----------
        w_meas : float
            Measured velocity (rad/s); a non-finite value is counted and the estimate held.
        w_ref : float
            Reference velocity (rad/s), unused.

        Returns
        -------
        float
            The bounded disturbance estimate ``d_hat`` (N·m).
        """
        w_meas = float(w_meas)
        return dob_compensate(self.params, self.state, w_meas, w_meas, float(w_ref))

    def observe(self, u: float, w: float) -> None:
        """Record the torque applied in this period (it drives the next velocity sample; :func:`dob_observe`).

        Parameters
        ----------
        u : float
            Applied torque (N·m); a non-finite value is ignored.
        w : float
            Measured velocity (rad/s), unused.
        """
        dob_observe(self.params, self.state, float(u), float(w), self._theta_out)
