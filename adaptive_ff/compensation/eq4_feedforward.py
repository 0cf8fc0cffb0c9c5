"""The paper's eq. 4 adaptive feedforward as a compensator component: RLS (eqs. 10-13) at Ts drives the feedforward.

The first prototype of the paper's future work, kept as a baseline to
:class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward`: the
regression model of eq. 4 (:class:`adaptive_ff.identification.regression.RegressionModel`)
is estimated online by recursive least squares on the (u, w) stream sampled
at ``Ts``, every estimate is mapped to physical parameters (inverse map of
eq. 4), projected onto the admissible set and, after the warm-up, put into a
:class:`adaptive_ff.compensation.feedforward.FrictionFeedforward`.

Compensator component (``KIND = 6``): the configuration is the float64 array
``params``, all state (the feedforward's, the RLS buffer of
:mod:`adaptive_ff.identification.rls`, the estimate in use) is ``state``. The
compiled kernels :func:`eq4_sample` (one sample of the stream),
:func:`eq4_compensate` and :func:`eq4_observe` (the closed-loop protocol) are
the one implementation, called by :class:`AdaptiveFrictionFeedforward`'s
methods and by the closed-loop engine. Layouts (``p`` = number of regression
parameters, :data:`FF_NPAR`/:data:`FF_NSTATE` the fixed feedforward's lengths, see
:mod:`adaptive_ff.compensation.ff_layout`)::

    params: feedforward[FF_NPAR], m, Ts, warmup, tau_max, F_max, Vs, delta, lag, stribeck, offset, p,
            torque range gate[RANGE_NPAR], velocity range gate[RANGE_NPAR]
    state:  feedforward[FF_NSTATE], due (periods to the next sample, m at start), u_prev, sampled,
            has_past, u(k-1), w(k-1), w(k-2), n_rejected, n_implausible, has_estimate,
            estimate (J, tau, sigma, Fc, Fs, offset, J_alt), torque and velocity range gates
            [2*RANGE_NSTATE], phi[p], theta[p] (scratch), RLS buffer[rls_buffer_size(p)]
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff.compensation.feedforward import FrictionFeedforward, ff_compensate, ff_set_estimate, project_levels
from adaptive_ff.compensation.ff_layout import FF_NPAR, FF_NSTATE
from adaptive_ff.compensation.gate import RANGE_NPAR, RANGE_NSTATE, RangeGate, range_commit, range_ok
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel, eq4_phi, eq4_to_physical
from adaptive_ff.identification.rls import (RecursiveLeastSquares, rls_buffer_size, rls_n_updates, rls_theta,
                                            rls_update)
from plant.component import Component
from plant.errors import ParameterError, check_multiple, check_positive
from plant.jit import kernel

__all__ = ["AdaptiveFrictionFeedforward", "eq4_sample", "eq4_compensate", "eq4_observe",
           "EQ4_KIND"]

#: Compensator kind code of :class:`AdaptiveFrictionFeedforward` (engine protocol).
EQ4_KIND = 6

# params slots after the feedforward's
(_P_M, _P_TS, _P_WARMUP, _P_TAUMAX, _P_FMAX, _P_VS, _P_DELTA, _P_LAG, _P_STRIB, _P_OFF,
 _P_NP) = range(FF_NPAR, FF_NPAR + 11)
_P_UR = FF_NPAR + 11  # torque range gate, then the velocity range gate
_NPAR = _P_UR + 2 * RANGE_NPAR
# state slots after the feedforward's
(_S_DUE, _S_UPREV, _S_SAMPLED, _S_HASPAST, _S_U1, _S_W1, _S_W2, _S_NREJ, _S_NIMPL,
 _S_HASEST) = range(FF_NSTATE, FF_NSTATE + 10)
_S_EST = FF_NSTATE + 10  # J, tau, sigma, Fc, Fs, offset, J_alt
_S_UR = _S_EST + 7  # torque range gate, velocity range gate
_S_PHI = _S_UR + 2 * RANGE_NSTATE  # phi (p), then theta scratch (p), then the RLS buffer


def _state_size(p: int) -> int:
    return _S_PHI + 2 * p + rls_buffer_size(p)


@kernel(inline="always")
def _use_estimate(par, st):
    """Map theta to physical parameters, project, and put an admissible estimate into use (else count it)."""
    p = np.int64(par[_P_NP])
    rls = st[_S_PHI + 2 * p:]
    th = st[_S_PHI + p:_S_PHI + 2 * p]
    for i in range(p):
        th[i] = rls_theta(rls, i)
    lag, strib, off = par[_P_LAG] != 0.0, par[_P_STRIB] != 0.0, par[_P_OFF] != 0.0
    J, tau, sigma, Fc, Fs, o, J_alt = eq4_to_physical(th, par[_P_TS], lag, strib, off)
    ok, tau, sigma, Fc, Fs = project_levels(J, tau, sigma, Fc, Fs, o, par[_P_TAUMAX], par[_P_FMAX])
    if not ok:
        st[_S_NIMPL] += 1.0
        return
    ff_set_estimate(par[:FF_NPAR], st[:FF_NSTATE], Fc, Fs, par[_P_VS], par[_P_DELTA], sigma, tau,
                    1.0 if strib else 0.0)
    st[_S_HASEST] = 1.0
    st[_S_EST] = J
    st[_S_EST + 1] = tau
    st[_S_EST + 2] = sigma
    st[_S_EST + 3] = Fc
    st[_S_EST + 4] = Fs
    st[_S_EST + 5] = o
    st[_S_EST + 6] = J_alt


@kernel
def eq4_sample(par, st, u, w):
    """One sample ``(u(k), w(k))`` of the stream at ``Ts``: RLS update with eq. 4's regressor, new estimate.

    Parameters
    ----------
    par, st : ndarray, float64
        :attr:`AdaptiveFrictionFeedforward.params` and ``.state`` (layouts in the module docstring).
    u : float
        Torque applied just before the sample (N·m).
    w : float
        Measured velocity (rad/s).

    Returns
    -------
    bool
        False if the sample was refused (non-finite or out-of-range ``u`` or ``w``, see the range gates
        of :class:`AdaptiveFrictionFeedforward`, or an RLS update that would overflow): only the counters
        change. True otherwise.

    Notes
    -----
    The first sample only fills the past ``u(k-1), w(k-1), w(k-2)``. Later ones build ``phi(k)`` (eq. 4),
    update the RLS (eqs. 10-13) with output ``w(k)`` and, after ``warmup`` updates, map ``theta`` to
    physical parameters (inverse map of eq. 4), project them
    (:func:`~adaptive_ff.compensation.feedforward.project_levels`) and put an admissible estimate into the
    feedforward (an inadmissible one is counted, the previous one kept).
    """
    pu = par[_P_UR:_P_UR + RANGE_NPAR]
    pw = par[_P_UR + RANGE_NPAR:_P_UR + 2 * RANGE_NPAR]
    su = st[_S_UR:_S_UR + RANGE_NSTATE]
    sw = st[_S_UR + RANGE_NSTATE:_S_UR + 2 * RANGE_NSTATE]
    uok = range_ok(pu, su, u)
    wok = range_ok(pw, sw, w)
    if not (uok and wok):
        if not uok:
            range_commit(pu, su, u, False)
        if not wok:
            range_commit(pw, sw, w, False)
        st[_S_NREJ] += 1.0
        return False
    if st[_S_HASPAST] == 0.0:
        range_commit(pu, su, u, True)
        range_commit(pw, sw, w, True)
        st[_S_U1] = u
        st[_S_W1] = w
        st[_S_W2] = w
        st[_S_HASPAST] = 1.0
        return True
    p = np.int64(par[_P_NP])
    phi = st[_S_PHI:_S_PHI + p]
    eq4_phi(phi, u, st[_S_U1], st[_S_W1], st[_S_W2], par[_P_VS], par[_P_DELTA], par[_P_LAG] != 0.0,
            par[_P_STRIB] != 0.0, par[_P_OFF] != 0.0)
    rls = st[_S_PHI + 2 * p:]
    n0 = rls_n_updates(rls)
    rls_update(rls, phi, w)
    if rls_n_updates(rls) == n0:  # non-finite regressor or an update that would overflow: refused
        st[_S_NREJ] += 1.0
        return False
    range_commit(pu, su, u, True)
    range_commit(pw, sw, w, True)
    st[_S_W2] = st[_S_W1]
    st[_S_W1] = w
    st[_S_U1] = u
    if rls_n_updates(rls) >= par[_P_WARMUP]:
        _use_estimate(par, st)
    return True


@kernel
def eq4_compensate(par, st, w_ctrl, w_meas, w_ref):
    """Compensator protocol (``KIND`` 6): every ``m``-th period a sample of the stream, then the feedforward.

    Parameters
    ----------
    par, st : ndarray, float64
        :attr:`AdaptiveFrictionFeedforward.params` and ``.state``.
    w_ctrl : float
        The controller's (gated) velocity (rad/s): the feedforward's input for ``ff_input="measured"``.
    w_meas : float
        Raw measured velocity (rad/s): the sample of the stream.
    w_ref : float
        Reference velocity (rad/s): the feedforward's input for ``ff_input="reference"`` (and while
        stuck, see :class:`adaptive_ff.compensation.feedforward.FrictionFeedforward`).

    Returns
    -------
    float
        Feedforward torque of this period (N·m).

    Notes
    -----
    In period ``k > 0`` with ``k % m == 0`` (``m = Ts/dt``) :func:`eq4_sample` gets the torque of the
    previous period (stored by :func:`eq4_observe`) and ``w_meas``, before the feedforward step, so the
    estimate of this sample is used at once.
    """
    if st[_S_DUE] == 0.0:  # period k > 0 with k % m == 0 (a countdown: no integer division per period)
        eq4_sample(par, st, st[_S_UPREV], w_meas)
        st[_S_SAMPLED] = 1.0
        st[_S_DUE] = par[_P_M]
    else:
        st[_S_SAMPLED] = 0.0
    st[_S_DUE] -= 1.0
    return ff_compensate(par[:FF_NPAR], st[:FF_NSTATE], w_ctrl, w_meas, w_ref)


@kernel
def eq4_observe(par, st, u, w_meas, theta_out):
    """Compensator protocol (``KIND`` 6): store the applied torque for the next sample; report theta.

    Parameters
    ----------
    par, st : ndarray, float64
        :attr:`AdaptiveFrictionFeedforward.params` and ``.state``.
    u : float
        Torque applied in this period (N·m).
    w_meas : float
        Measured velocity (rad/s), unused (the sample is taken in :func:`eq4_compensate`).
    theta_out : ndarray, shape (>= p,), float64
        Receives the RLS parameter vector when this period took a sample.

    Returns
    -------
    bool
        True in every period that took a sample of the stream (every ``m``-th from the ``m``-th on,
        including refused samples: the history is the estimate at each sample instant).
    """
    st[_S_UPREV] = u
    if st[_S_SAMPLED] == 0.0:
        return False
    p = np.int64(par[_P_NP])
    rls = st[_S_PHI + 2 * p:]
    for i in range(p):
        theta_out[i] = rls_theta(rls, i)
    return True


class AdaptiveFrictionFeedforward(Component):
    """Adaptive friction feedforward: RLS (eqs. 10-13) on the sampled (u, w) stream drives the feedforward.

    Parameters
    ----------
    model : RegressionModel
        Regression structure, with Vs, delta from the pre-fit (Sec. V-C).
    Ts : float, keyword-only
        Sample time of the (u, w) stream fed to :meth:`observe` (s), a multiple of ``dt``.
    dt : float, keyword-only
        Call period of :meth:`step` (s).
    lam : float, keyword-only
        RLS forgetting factor in (0, 1]; default 0.995 (memory ``Ts/(1-lam)``,
        2 s at Ts = 10 ms). The paper's 0.85 suits offline replay of noisy data,
        not a loop that must hold its estimate through slow phases.
    P0 : float, keyword-only
        Initial RLS covariance scale, default 1e4.
    warmup : int, keyword-only
        Accepted samples before the feedforward is switched on, default 300
        (the paper's RLS transient lasts about 4 s).
    lag, ff_max : see :class:`FrictionFeedforward`; estimates with ``Fc`` or
        ``Fs`` above ``ff_max`` are treated as implausible.
    tau_max : float, keyword-only
        Upper projection bound of ``tau`` (s), default 1.
    ff_input : {"measured", "reference"}, keyword-only
        Velocity the closed-loop engine evaluates the feedforward at
        (:func:`eq4_compensate`); default measured.
    u_range, w_range : RangeGate, keyword-only
        Range gates of the torque (N·m) and velocity (rad/s) samples; defaults
        ``RangeGate()`` and ``RangeGate(floor=model.Vs)`` (or ``floor`` 0 without
        the Stribeck term): a sample above 100 times the envelope of the accepted
        ones is refused (:class:`adaptive_ff.compensation.gate.RangeGate`).

    Attributes
    ----------
    KIND : int
        6 (compensator protocol of the closed-loop engine).
    params, state : ndarray, float64
        Configuration and state (layouts in the module docstring).
    n_theta : int
        ``model.n_params``.
    model : RegressionModel
    rls : RecursiveLeastSquares
        The estimator (public ``theta``, ``P``); its buffer is the tail of ``state``.
    estimate : FrictionEstimate or None
        Estimate in use (projected), None before the first admissible one.
    n_rejected : int
        Samples refused (non-finite or out-of-range ``u`` or ``w``, or an RLS update
        that would overflow); they leave the state unchanged but the counters.
    n_implausible : int
        RLS updates whose estimate could not be projected (held the previous one).

    Raises
    ------
    ParameterError
        Invalid hyperparameters, or ``Ts`` not a multiple of ``dt`` (message quotes the value).

    Notes
    -----
    At each sample ``k``: ``phi(k)`` from eq. 4 with the stored ``u(k-1)``,
    ``w(k-1)``, ``w(k-2)``; RLS update; ``theta`` mapped to physical
    parameters (inverse map in :mod:`adaptive_ff.identification.regression`), projected
    (:func:`~adaptive_ff.compensation.feedforward.project_levels`); the feedforward uses the last admissible estimate.
    """

    KIND = EQ4_KIND
    MODE = "adaptive"

    def __init__(self, model: RegressionModel, *, Ts: float, dt: float, lam: float = 0.995, P0: float = 1e4,
                 warmup: int = 300, lag: bool = True, ff_max: float = math.inf, tau_max: float = 1.0,
                 ff_input: str = "measured", u_range: RangeGate | None = None, w_range: RangeGate | None = None):
        ff = FrictionFeedforward(None, dt=dt, lag=lag, ff_max=ff_max, ff_input=ff_input)
        if not isinstance(model, RegressionModel):
            raise ParameterError(f"model must be a RegressionModel, got {type(model).__name__}")
        Ts = check_positive("Ts", Ts)
        m = check_multiple("Ts", Ts, "dt", ff.dt)
        if isinstance(warmup, bool) or not isinstance(warmup, (int, np.integer)) or warmup < 0:
            raise ParameterError(f"warmup must be an integer >= 0, got {warmup!r}")
        tau_max = check_positive("tau_max", tau_max)
        p = model.n_params
        rls = RecursiveLeastSquares(p, lam=lam, P0=P0)
        self.model = model
        self.n_theta = p
        self._init_arrays(_NPAR, _state_size(p))
        self.params[:FF_NPAR] = ff.params
        self.state[:FF_NSTATE] = ff.state
        self.state[_S_DUE] = float(m)
        self.params[FF_NPAR:_P_UR] = (float(m), Ts, float(warmup), tau_max, ff.ff_max,
                                 model.Vs if model.stribeck else 1.0, model.delta if model.stribeck else 1.0,
                                 float(model.lag), float(model.stribeck), float(model.offset), float(p))
        u_range = RangeGate() if u_range is None else u_range
        w_range = RangeGate(floor=model.Vs if model.stribeck else 0.0) if w_range is None else w_range
        for name, g in (("u_range", u_range), ("w_range", w_range)):
            if not isinstance(g, RangeGate):
                raise ParameterError(f"{name} must be a RangeGate, got {type(g).__name__}")
        self._ff = ff
        self.u_range = u_range
        self.w_range = w_range
        self.rls = rls
        self._attached()

    def _attached(self) -> None:
        p = self.n_theta
        self._ff.attach(self.params[:FF_NPAR], self.state[:FF_NSTATE])
        self.u_range.attach(self.params[_P_UR:_P_UR + RANGE_NPAR], self.state[_S_UR:_S_UR + RANGE_NSTATE])
        self.w_range.attach(self.params[_P_UR + RANGE_NPAR:_NPAR],
                            self.state[_S_UR + RANGE_NSTATE:_S_UR + 2 * RANGE_NSTATE])
        self.rls.attach(self.state[_S_PHI + 2 * p:])

    def __repr__(self) -> str:
        return (f"AdaptiveFrictionFeedforward({self.model!r}, Ts={self.Ts!r}, dt={self.dt!r}, "
                f"warmup={self.warmup}, n_updates={self.rls.n_updates})")

    # ---- configuration
    Ts = property(lambda self: float(self.params[_P_TS]), doc="Sample time of the (u, w) stream (s).")
    m = property(lambda self: int(self.params[_P_M]), doc="Periods ``dt`` per sample ``Ts``.")
    warmup = property(lambda self: int(self.params[_P_WARMUP]), doc="RLS updates before switch-on.")
    tau_max = property(lambda self: float(self.params[_P_TAUMAX]), doc="Upper projection bound of tau (s).")
    dt = property(lambda self: self._ff.dt, doc="Call period of :meth:`step` (s).")
    lag = property(lambda self: self._ff.lag, doc="Filter the feedforward through the estimated lag.")
    ff_max = property(lambda self: self._ff.ff_max, doc="Bound on |feedforward| (N·m).")
    ff_input = property(lambda self: self._ff.ff_input, doc="Velocity :func:`eq4_compensate` evaluates at.")
    sign_width = property(lambda self: self._ff.sign_width, doc="Sign ramp half-width (rad/s), 0.")
    stick_band = property(lambda self: self._ff.stick_band, doc="Stick-detection band (rad/s), 0.")
    stick_samples = property(lambda self: self._ff.stick_samples, doc="In-band samples that declare sticking.")

    # ---- state
    u_ff = property(lambda self: self._ff.u_ff, doc="Feedforward before the clip (N·m).")
    n_rejected = property(lambda self: int(self.state[_S_NREJ]), doc="Refused samples.")
    n_implausible = property(lambda self: int(self.state[_S_NIMPL]), doc="Estimates that failed the projection.")

    @property
    def theta(self) -> np.ndarray:
        """Current RLS parameter vector, shape (p,)."""
        return self.rls.theta

    @property
    def estimate(self) -> FrictionEstimate | None:
        """Estimate in use (projected onto the admissible set), or None before the first one."""
        if self.state[_S_HASEST] == 0.0:
            return None
        J, tau, sigma, Fc, Fs, off, J_alt = self.state[_S_EST:_S_EST + 7].tolist()
        return FrictionEstimate(J=J, tau=tau, sigma=sigma, Fc=Fc, Fs=Fs, offset=off, Vs=self.model.Vs,
                                delta=self.model.delta, J_alt=J_alt)

    def info(self) -> dict:
        """Counters and settings for run reports (JSON-safe).

        Returns
        -------
        dict
            ``estimator`` ("eq4"), ``n_rejected``, ``n_implausible``, ``n_updates`` (RLS), ``lam``,
            ``names`` (the regression parameters, :attr:`RegressionModel.names`).
        """
        return {"estimator": "eq4", "n_rejected": self.n_rejected, "n_implausible": self.n_implausible,
                "n_updates": self.rls.n_updates, "lam": self.rls.lam, "names": list(self.model.names)}

    def static(self, w: float) -> float:
        """Static friction of the estimate in use ``F_hat(w)`` (N·m), eq. 3 (no offset); 0 without one."""
        return self._ff.static(w)

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance the feedforward one period ``dt`` (:meth:`FrictionFeedforward.step` on this component's slices).

        Parameters
        ----------
        w : float
            Velocity the friction map is evaluated at (rad/s).
        w_ref : float, optional
            Used instead of ``w`` while the joint is detected as stuck (never here: ``stick_band`` is 0).

        Returns
        -------
        float
            Feedforward torque (N·m), bounded by ``ff_max``; 0 before the first admissible estimate.
        """
        return self._ff.step(w, w_ref)

    def observe(self, u: float, w: float) -> bool:
        """Feed one sample ``(u(k), w(k))`` taken ``Ts`` after the previous one (:func:`eq4_sample`).

        Parameters
        ----------
        u : float
            Torque applied just before the sample (N·m).
        w : float
            Measured velocity (rad/s).

        Returns
        -------
        bool
            True if the sample was used, False if rejected (non-finite or out of
            range, see ``u_range``, ``w_range``); a rejected sample changes no state
            except the counters.
        """
        return bool(eq4_sample(self.params, self.state, float(u), float(w)))
