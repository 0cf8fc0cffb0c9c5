"""The paper's eq. 4 adaptive feedforward as a compensator component: RLS (eqs. 10-13) at Ts drives the feedforward.

The first prototype of the paper's future work, kept as a baseline to
:class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward`: the
regression model of eq. 4 (:class:`adaptive_ff.identification.regression.RegressionModel`)
is estimated online by recursive least squares on the (u, w) stream sampled
at ``Ts``, every estimate is mapped to physical parameters (inverse map of
eq. 4), projected onto the admissible set and, after the warm-up, put into a
:class:`adaptive_ff.compensation.feedforward.FrictionFeedforward`.

Compensator component (ops table ``aff_eq4_ff_ops``): the configuration and state are the C struct ``aff_eq4_ff``
(``adaptive_ff/csrc/aff_eq4_ff.h``), which embeds the feedforward's (``aff_fixed_ff``), the two range gates' and the
RLS's (``aff_rls``) structs. C is the one implementation: ``aff_eq4_ff_sample`` (one sample of the stream,
:meth:`AdaptiveFrictionFeedforward.observe`) and the compensator interface ``aff_eq4_ff_compensate`` /
``aff_eq4_ff_observe`` (ops table ``aff_eq4_ff_ops``), called by the class's methods and by the closed-loop engine.
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.feedforward import FrictionFeedforward
from adaptive_ff.compensation.gate import RangeGate
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.identification.rls import RecursiveLeastSquares
from plant.component import Component
from plant.errors import ParameterError, check_multiple, check_positive

__all__ = ["AdaptiveFrictionFeedforward"]


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
        (:meth:`compensate`); default measured.
    u_range, w_range : RangeGate, keyword-only
        Range gates of the torque (N·m) and velocity (rad/s) samples; defaults
        ``RangeGate()`` and ``RangeGate(floor=model.Vs)`` (or ``floor`` 0 without
        the Stribeck term): a sample above 100 times the envelope of the accepted
        ones is refused (:class:`adaptive_ff.compensation.gate.RangeGate`).

    Attributes
    ----------
    C_OPS : str
        ``"aff_eq4_ff_ops"``, the C ops table (``aff_compensator_ops``) the closed-loop engine calls with :attr:`cdata`.
    cdata : cffi pointer
        The C struct ``aff_eq4_ff`` (``adaptive_ff/csrc/aff_eq4_ff.h``), which embeds the feedforward's, the range
        gates' and the RLS's structs: a copy of the struct is a complete, independent compensator.
    n_theta : int
        ``model.n_params``.
    model : RegressionModel
    rls : RecursiveLeastSquares
        The estimator (public ``theta``, ``P``); its struct is a field of this component's.
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

    C_OPS = "aff_eq4_ff_ops"
    MODE = "adaptive"
    _ffi = ffi
    _ctype = "aff_eq4_ff"

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
        u_range = RangeGate() if u_range is None else u_range
        w_range = RangeGate(floor=model.Vs if model.stribeck else 0.0) if w_range is None else w_range
        for name, g in (("u_range", u_range), ("w_range", w_range)):
            if not isinstance(g, RangeGate):
                raise ParameterError(f"{name} must be a RangeGate, got {type(g).__name__}")
        self._new_struct()
        lib.aff_eq4_ff_init(self._c, ff.cdata, m, Ts, int(warmup), tau_max, ff.ff_max,
                            model.Vs if model.stribeck else 1.0, model.delta if model.stribeck else 1.0,
                            model.lag, model.stribeck, model.offset, u_range.cdata, w_range.cdata, rls.cdata)
        self._ff = ff
        self.u_range = u_range
        self.w_range = w_range
        self.rls = rls
        self._attached()

    def _attached(self) -> None:
        """Point the parts (feedforward, range gates, RLS) into this component's struct."""
        self._ff._use(ffi.addressof(self._c, "ff"), self)
        self.u_range._use(ffi.addressof(self._c, "u_range"), self)
        self.w_range._use(ffi.addressof(self._c, "w_range"), self)
        self.rls._use(ffi.addressof(self._c, "rls"), self)

    def _use(self, ptr, owner) -> None:
        super()._use(ptr, owner)
        self._attached()

    def __repr__(self) -> str:
        return (f"AdaptiveFrictionFeedforward({self.model!r}, Ts={self.Ts!r}, dt={self.dt!r}, "
                f"warmup={self.warmup}, n_updates={self.rls.n_updates})")

    # ---- configuration
    Ts = property(lambda self: float(self._c.Ts), doc="Sample time of the (u, w) stream (s).")
    m = property(lambda self: int(self._c.m), doc="Periods ``dt`` per sample ``Ts``.")
    warmup = property(lambda self: int(self._c.warmup), doc="RLS updates before switch-on.")
    tau_max = property(lambda self: float(self._c.tau_max), doc="Upper projection bound of tau (s).")
    dt = property(lambda self: self._ff.dt, doc="Call period of :meth:`step` (s).")
    lag = property(lambda self: self._ff.lag, doc="Filter the feedforward through the estimated lag.")
    ff_max = property(lambda self: self._ff.ff_max, doc="Bound on |feedforward| (N·m).")
    ff_input = property(lambda self: self._ff.ff_input, doc="Velocity :meth:`compensate` evaluates at.")
    sign_width = property(lambda self: self._ff.sign_width, doc="Sign ramp half-width (rad/s), 0.")
    stick_band = property(lambda self: self._ff.stick_band, doc="Stick-detection band (rad/s), 0.")
    stick_samples = property(lambda self: self._ff.stick_samples, doc="In-band samples that declare sticking.")

    # ---- state
    u_ff = property(lambda self: self._ff.u_ff, doc="Feedforward before the clip (N·m).")
    n_rejected = property(lambda self: int(self._c.n_rejected), doc="Refused samples.")
    n_implausible = property(lambda self: int(self._c.n_implausible), doc="Estimates that failed the projection.")

    @property
    def theta(self) -> np.ndarray:
        """Current RLS parameter vector, shape (p,)."""
        return self.rls.theta

    @property
    def estimate(self) -> FrictionEstimate | None:
        """Estimate in use (projected onto the admissible set), or None before the first one."""
        if not self._c.has_estimate:
            return None
        x = self._c.est
        return FrictionEstimate(J=x.J, tau=x.tau, sigma=x.sigma, Fc=x.Fc, Fs=x.Fs, offset=x.offset,
                                Vs=self.model.Vs, delta=self.model.delta, J_alt=x.J_alt)

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
        """Advance the feedforward one period ``dt`` (:meth:`FrictionFeedforward.step` on this component's part).

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
        """Feed one sample ``(u(k), w(k))`` taken ``Ts`` after the previous one (C ``aff_eq4_ff_sample``).

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
        return bool(lib.aff_eq4_ff_sample(self._c, float(u), float(w)))
