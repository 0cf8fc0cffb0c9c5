"""Composite compensator: the adaptive friction feedforward plus a disturbance observer on what remains.

Where the sliding friction model holds, the adaptive feedforward
(:class:`adaptive_ff.RobustAdaptiveFeedforward`) cancels friction with its
lag and reaches the frictionless limit; where it does not (true sticking of a
Karnopp joint, LuGre pre-sliding, direction-dependent levels, drift) a
disturbance observer, which needs no friction model, does better. The
composite feeds the adaptive feedforward forward and lets a disturbance
observer (:class:`controllers.DisturbanceObserver`) estimate and cancel
the *residual* ``f - u_ff``: the observer is given the torque without the
feedforward, ``u - u_ff``, so that with ``J*dw/dt = u - f`` its raw sample is
``(u - u_ff) - J_n*dw/dt = f - u_ff`` (for ``J_n = J``). This is the standard
two-degree-of-freedom arrangement of a model-based feedforward with a
disturbance observer for the model error (Umeno & Hori 1991; Ohnishi, Shibata,
Murakami 1996; for friction: Olsson, Åström, Canudas de Wit, Gäfvert,
Lischinsky, "Friction models and friction compensation", Eur. J. Control 4(3),
1998, Sec. 7). Before the feedforward switches on, the observer alone
compensates (a fast start that needs no friction model); the estimator learns
from the loop's own ``(u, w)`` as in the ``adaptive`` mode (``u`` is the total
torque, so the inverse-dynamics regression is unchanged).

Compensator component (``KIND = 7``): the parts' arrays are slices of the
composite's, and the compiled kernels :func:`adob_compensate` and
:func:`adob_observe` call the parts' compiled steps
(:func:`adaptive_ff.compensation.adaptive_feedforward.robust_compensate`,
:func:`~adaptive_ff.compensation.adaptive_feedforward.robust_observe`,
:func:`controllers.peers.dob.dob_compensate`,
:func:`~controllers.peers.dob.dob_observe`) on them. Layouts::

    params: so_dob_par, so_dob_state, u_max, feedforward params, observer params   (3 + ...)
    state:  u_ff of this period, feedforward state, observer state                  (1 + ...)
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward, robust_compensate, robust_observe
from controllers.peers.dob import DisturbanceObserver, dob_compensate, dob_observe
from plant.component import Component
from plant.errors import ParameterError, check_nonnegative
from plant.jit import kernel

__all__ = ["AdaptiveDOBCompensator", "adob_compensate", "adob_observe", "ADOB_KIND"]

#: Compensator kind code of :class:`AdaptiveDOBCompensator` (engine protocol).
ADOB_KIND = 7

_P_PDOB, _P_SDOB, _P_UMAX = range(3)
_OWN_NPAR = 3
_S_UFF = 0
_OWN_NSTATE = 1


@kernel
def adob_compensate(par, st, w_ctrl, w_meas, w_ref):
    """The composite's torque for this period: adaptive feedforward plus the observer's residual (N·m).

    Parameters
    ----------
    par, st : ndarray, float64
        :attr:`AdaptiveDOBCompensator.params` and ``.state`` (layouts in the module docstring).
    w_ctrl, w_meas, w_ref : float
        Controller's (gated) measurement, raw measurement and reference velocity (rad/s).

    Returns
    -------
    float
        ``u_ff + d_hat`` clipped to ``±u_max``, with ``u_ff`` of
        :func:`adaptive_ff.compensation.adaptive_feedforward.robust_compensate` (0 before switch-on) and ``d_hat``
        of :func:`controllers.peers.dob.dob_compensate` (module docstring).
    """
    pd = np.int64(par[_P_PDOB])
    sd = np.int64(par[_P_SDOB])
    uff = robust_compensate(par[_OWN_NPAR:pd], st[_OWN_NSTATE:sd], w_ctrl, w_meas, w_ref)
    st[_S_UFF] = uff
    d = dob_compensate(par[pd:], st[sd:], w_ctrl, w_meas, w_ref)
    out = uff + d
    lim = par[_P_UMAX]
    return min(max(out, -lim), lim)


@kernel
def adob_observe(par, st, u, w_meas, theta_out):
    """Record the applied torque ``u`` (N·m): the observer gets ``u - u_ff``, the estimator ``(u, w_meas)``.

    Parameters
    ----------
    par, st : ndarray, float64
        :attr:`AdaptiveDOBCompensator.params` and ``.state``.
    u : float
        Applied (saturated) torque of this period (N·m).
    w_meas : float
        Raw measured velocity (rad/s).
    theta_out : ndarray, shape (p,), float64
        Receives the estimator's parameter vector after an update.

    Returns
    -------
    bool
        True after an RLS update of the estimator (:func:`adaptive_ff.compensation.adaptive_feedforward.robust_observe`).
    """
    pd = np.int64(par[_P_PDOB])
    sd = np.int64(par[_P_SDOB])
    dob_observe(par[pd:], st[sd:], u - st[_S_UFF], w_meas, theta_out)
    return robust_observe(par[_OWN_NPAR:pd], st[_OWN_NSTATE:sd], u, w_meas, theta_out)


class AdaptiveDOBCompensator(Component):
    """Adaptive friction feedforward with a disturbance observer on the residual (mode ``adaptive-dob``).

    Parameters
    ----------
    feedforward : RobustAdaptiveFeedforward
        The adaptive feedforward (with its estimator); its arrays become slices of the composite's.
    observer : DisturbanceObserver
        The observer of the residual ``f - u_ff`` (nominal inertia: the design inertia).
    u_max : float, keyword-only
        Bound on |u_ff + d_hat| (N·m), default inf (each part keeps its own bound as well).

    Attributes
    ----------
    KIND : int
        7 (compensator protocol of the closed-loop engine).
    feedforward : RobustAdaptiveFeedforward
    observer : DisturbanceObserver
    estimator : SlidingFrictionEstimator
        The feedforward's estimator.
    n_theta : int
        Length of the estimator's parameter vector.
    u_ff : float
        Feedforward part of the last output (N·m).

    Raises
    ------
    ParameterError
        Parts of the wrong type, or ``u_max < 0``.

    Notes
    -----
    Per period: ``u_ff`` from the feedforward (faded in after its switch-on), ``d_hat = Q[(u - u_ff)(k-1) -
    J_n*(w(k) - w(k-1))/Tc]`` from the observer, output ``u_ff + d_hat``. For ``J_n = J`` the observer's
    raw sample is the mean residual ``f - u_ff`` over the last period (module docstring), so the observer
    cancels what the feedforward misses within the Q-filter bandwidth and the feedforward covers the fast
    reversals beyond it.
    """

    KIND = ADOB_KIND
    MODE = "adaptive-dob"

    def __init__(self, feedforward: RobustAdaptiveFeedforward, observer: DisturbanceObserver, *,
                 u_max: float = math.inf):
        if not isinstance(feedforward, RobustAdaptiveFeedforward):
            raise ParameterError(f"feedforward must be a RobustAdaptiveFeedforward, got {type(feedforward).__name__}")
        if not isinstance(observer, DisturbanceObserver):
            raise ParameterError(f"observer must be a DisturbanceObserver, got {type(observer).__name__}")
        u_max = math.inf if u_max == math.inf else check_nonnegative("u_max", u_max)
        self.feedforward = feedforward
        self.observer = observer
        self.n_theta = feedforward.n_theta
        pd = _OWN_NPAR + feedforward.params.shape[0]
        sd = _OWN_NSTATE + feedforward.state.shape[0]
        self._init_arrays(pd + observer.params.shape[0], sd + observer.state.shape[0])
        self.params[:_OWN_NPAR] = (float(pd), float(sd), u_max)
        self.params[_OWN_NPAR:pd] = feedforward.params
        self.params[pd:] = observer.params
        self.state[_OWN_NSTATE:sd] = feedforward.state
        self.state[sd:] = observer.state
        self._attached()

    def _attached(self) -> None:
        pd, sd = int(self.params[_P_PDOB]), int(self.params[_P_SDOB])
        self.feedforward.attach(self.params[_OWN_NPAR:pd], self.state[_OWN_NSTATE:sd])
        self.observer.attach(self.params[pd:], self.state[sd:])

    def __repr__(self) -> str:
        return f"AdaptiveDOBCompensator({self.feedforward.estimator!r}, {self.observer!r})"

    u_max = property(lambda self: float(self.params[_P_UMAX]), doc="Bound on the total output (N·m).")
    u_ff = property(lambda self: float(self.state[_S_UFF]), doc="Feedforward part of the last output (N·m).")

    @property
    def estimator(self):
        """The feedforward's :class:`adaptive_ff.SlidingFrictionEstimator`."""
        return self.feedforward.estimator

    @property
    def estimate(self):
        """The feedforward's estimate in use (None before its switch-on)."""
        return self.feedforward.estimate

    @property
    def active(self) -> bool:
        """Whether the feedforward part is switched on (the observer always is)."""
        return self.feedforward.active

    def info(self) -> dict:
        """The feedforward's counters (:meth:`RobustAdaptiveFeedforward.info`) plus the observer's, prefixed
        ``dob_`` (``dob_n_rejected``, ``dob_J_n`` kg·m², ``dob_omega_q`` rad/s)."""
        d = self.feedforward.info()
        d.update({f"dob_{k}": v for k, v in self.observer.info().items()})
        return d

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensator protocol: ``u_ff + d_hat`` for this period (N·m), see :func:`adob_compensate`.

        Parameters
        ----------
        w_meas, w_ref : float
            Measured and reference velocity (rad/s).
        """
        w_meas = float(w_meas)
        return float(adob_compensate(self.params, self.state, w_meas, w_meas, float(w_ref)))

    def observe(self, u: float, w: float) -> bool:
        """Compensator protocol: record the applied torque and the measurement (:func:`adob_observe`).

        Parameters
        ----------
        u : float
            Applied torque (N·m).
        w : float
            Measured velocity (rad/s).

        Returns
        -------
        bool
            True after an RLS update of the estimator.
        """
        return bool(adob_observe(self.params, self.state, float(u), float(w), self._theta_scratch()))

    def _theta_scratch(self) -> np.ndarray:
        t = getattr(self, "_scratch", None)
        if t is None:
            t = self._scratch = np.empty(self.n_theta)
        return t
