"""The paper's eq. 4 adaptive feedforward as a compensator component: RLS (eqs. 10-13) or IV at Ts drives it.

The first prototype of the paper's future work, kept as a baseline to
:class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward`: the
regression model of eq. 4 (:class:`adaptive_ff.identification.regression.RegressionModel`)
is estimated online by recursive least squares on the (u, w) stream sampled
at ``Ts``, every estimate is mapped to physical parameters (inverse map of
eq. 4), projected onto the admissible set and, after the warm-up, put into a
:class:`adaptive_ff.compensation.feedforward.FrictionFeedforward`. With ``iv=True`` the estimator is
the recursive instrumental-variable method (:class:`adaptive_ff.compensation.ivrls.RecursiveIV`) with the
velocities of the regressor delayed by two samples as instruments, consistent in the closed loop where the RLS is
biased, and ``w_band`` keeps stick and creep samples (where eq. 4 does not hold) from the estimator
(docs/theory.md, "Instrumental variables for eq. 4 in the closed loop").

Compensator component (ops table ``aff_eq4_ff_ops``): the configuration and state are the C struct ``aff_eq4_ff``
(``adaptive_ff/csrc/aff_eq4_ff.h``), which embeds the feedforward's (``aff_fixed_ff``), the two range gates' and the
RLS's (``aff_rls``) and the IV estimator's (``aff_ivrls``) structs. C is the one implementation:
``aff_eq4_ff_sample`` (one sample of the stream,
:meth:`AdaptiveFrictionFeedforward.observe`) and the compensator interface ``aff_eq4_ff_compensate`` /
``aff_eq4_ff_observe`` (ops table ``aff_eq4_ff_ops``), called by the class's methods and by the closed-loop engine.
"""

from __future__ import annotations

import math

import numpy as np

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart, start_output
from adaptive_ff.compensation.defaults import c_config_class
from adaptive_ff.compensation.feedforward import FF_INPUTS, FrictionFeedforward, FrictionFeedforwardConfig
from adaptive_ff.compensation.gate import RangeGate, range_gates
from adaptive_ff.compensation.ivrls import RecursiveIV
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from adaptive_ff.identification.rls import RecursiveLeastSquares
from plant.component import Component, struct_field, struct_fields
from plant.errors import ParameterError, check_multiple, check_optional

__all__ = ["AdaptiveFrictionFeedforward", "AdaptiveFrictionFeedforwardConfig"]

AdaptiveFrictionFeedforwardConfig = c_config_class(
    "AdaptiveFrictionFeedforwardConfig", "aff_eq4_ff_config", "aff_eq4_ff.h", module=__name__,
    summary="Settings of an :class:`AdaptiveFrictionFeedforward`: the sample time, the estimator (RLS or IV), the "
            "warm-up, the projection bound, the sliding-regime gate, the determinacy test and the feedforward's "
            "(``ff``).",
    fields={"ff": FrictionFeedforwardConfig})


@struct_fields(
    "Ts", "m", "warmup", "tau_max", "iv", "w_band", "ff.dt", "ff.lag", "ff.ff_max", "ff.sign_width", "ff.stick_band",
    "ff.stick_samples", "ff.u_ff", "n_rejected", "n_implausible", "n_gated", "n_undetermined", "map_rel_stderr",
    "provisional"
)
class AdaptiveFrictionFeedforward(Component):
    """Adaptive friction feedforward: RLS (eqs. 10-13) on the sampled (u, w) stream drives the feedforward.

    Parameters
    ----------
    model : RegressionModel
        Regression structure, with Vs, delta from the pre-fit (Sec. V-C).
    dt : float, keyword-only
        Call period of :meth:`step` (s).
    config : AdaptiveFrictionFeedforwardConfig, keyword-only
        The settings (default: the C defaults, :class:`AdaptiveFrictionFeedforwardConfig`), its field ``ff`` the
        feedforward's (:class:`~adaptive_ff.compensation.feedforward.FrictionFeedforwardConfig`), among them:

        ``Ts``
            Sample time of the (u, w) stream fed to :meth:`observe` (s), a multiple of ``dt``; default 10 ms.
        ``lam``
            RLS forgetting factor in (0, 1]; default 0.995 (memory ``Ts/(1-lam)``,
            2 s at Ts = 10 ms). The paper's 0.85 suits offline replay of noisy data,
            not a loop that must hold its estimate through slow phases.
        ``P0``
            Initial RLS covariance scale, default 1e4.
        ``warmup``
            Accepted samples before the feedforward is switched on, default 300
            (the paper's RLS transient lasts about 4 s).
        ``tau_max``
            Upper projection bound of ``tau`` (s), default 1.
        ``iv``
            Estimate with recursive IV (:class:`adaptive_ff.compensation.ivrls.RecursiveIV`, same ``lam``, ``P0``, trace
            bound ``p*P0``, ``guard``) and the instruments ``z(k)``, eq. 4's regressor of ``u(k)``, ``u(k-1)``, ``w(k-3)``,
            ``w(k-4)`` (the velocities two samples older than in ``phi(k)``), instead of the RLS; default False (the
            paper's RLS). A sample whose IV update is refused (``phi @ P @ z < 0``) still enters the stored past. In the
            closed loop (:meth:`compensate`) the torque of a sample is then the mean of the torques applied since the
            previous sample, not the last one (docs/theory.md).
        ``w_band``
            Sliding-regime gate (rad/s, >= 0): only samples with ``|w(k)|``, ``|w(k-1)|``, ``|w(k-2)|`` above it and of
            one sign update the estimator; default 0 (every sample, the paper).
        ``map_rel_stderr``
            Determinacy test of the estimates, with ``iv`` only (> 0; default ``inf``: none, every admissible estimate
            after the warm-up is used): an estimate is put into use (the first replacing the start map) only if, at the
            largest ``|w|`` of the IV updates and (with the Stribeck term, if below it) at ``Vs``, the standard error of
            its static map ``F(w)`` of eq. 3 is at most ``map_rel_stderr`` times its ``max(Fc, Fs)`` and the projection
            moved the map there by no more than that; else the estimate in use stays. The covariance of the IV estimate
            is ``e2 * P @ Szz @ P.T`` (Söderström & Stoica, System Identification, 1989, Sec. 8.2) with ``Szz`` the
            forgotten sum of ``z z'`` and ``e2`` the mean of the normalised a-priori errors. The counterpart of the
            sliding estimator's "Fc determined"
            (:func:`~adaptive_ff.compensation.adaptive_feedforward.fc_determined`); C ``aff_eq4_ff_require_determined``.

        The feedforward's, ``config.ff``:

        ``lag``, ``ff_max``
            See :class:`FrictionFeedforward`; estimates with ``Fc`` or
            ``Fs`` above ``ff_max`` are treated as implausible.
        ``ff_input``
            Velocity the closed-loop engine evaluates the feedforward at
            (:meth:`compensate`); default measured.
        ``sign_width``, ``stick_band``, ``stick_samples``
            The feedforward's input near standstill (see :class:`FrictionFeedforward`); defaults: none of it (the
            bare feedforward of the paper's prototype).
    u_range, w_range : RangeGate, keyword-only
        Range gates of the torque (N·m) and velocity (rad/s) samples; defaults
        ``RangeGate()`` and ``RangeGate(floor=model.Vs)`` (or ``floor`` 0 without
        the Stribeck term): a sample above 100 times the envelope of the accepted
        ones is refused (:class:`adaptive_ff.compensation.gate.RangeGate`).
    loop_model, sign_observer : keyword-only
        The feedforward's velocity inputs near standstill (see :class:`FrictionFeedforward`); default None.
    start : FeedforwardStart or None, keyword-only
        Provisional start: the prior map (the Stribeck pre-fit's, Sec. V-C, through a lag) acts from the first
        period, times its gain, until the first estimate is put into use, which replaces it at once (this
        feedforward has no fade-in); the start of
        :class:`~adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward`. Default None: no
        feedforward before the first estimate (the paper's prototype). With the joint stuck under the PI alone
        the estimator may get no sliding sample for seconds, or never on a small joint that hardly leaves the
        stick band (docs/benchmarks/compensation.md, "The eq. 4 feedforward's provisional start").

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
        The estimator without ``iv`` (public ``theta``, ``P``); its struct is a field of this component's.
    ivrls : RecursiveIV
        The estimator with ``iv`` (its struct is a field of this component's).
    n_gated : int
        Samples the sliding-regime gate kept from the estimator.
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
    ``w(k-1)``, ``w(k-2)``; RLS (or IV) update unless the sliding-regime gate refuses the sample; ``theta``
    mapped to physical
    parameters (inverse map in :mod:`adaptive_ff.identification.regression`), projected
    (:func:`~adaptive_ff.compensation.feedforward.project_levels`); the feedforward uses the last admissible estimate.
    """

    C_OPS = "aff_eq4_ff_ops"
    MODE = "adaptive"
    _ffi = ffi
    _ctype = "aff_eq4_ff"
    _parts = {"_ff": "ff", "u_range": "u_range", "w_range": "w_range", "rls": "rls", "ivrls": "ivrls"}

    #: The settings' class.
    Config = AdaptiveFrictionFeedforwardConfig

    def __init__(self, model: RegressionModel, *, dt: float, config: AdaptiveFrictionFeedforwardConfig | None = None,
                 u_range: RangeGate | None = None, w_range: RangeGate | None = None, loop_model=None,
                 sign_observer=None, start: FeedforwardStart | None = None):
        config = AdaptiveFrictionFeedforwardConfig() if config is None else config
        if not isinstance(config, AdaptiveFrictionFeedforwardConfig):
            raise ParameterError(f"config must be an AdaptiveFrictionFeedforwardConfig, got {type(config).__name__}")
        ff = FrictionFeedforward(None, dt=dt, config=config.ff, loop_model=loop_model, sign_observer=sign_observer)
        if not isinstance(model, RegressionModel):
            raise ParameterError(f"model must be a RegressionModel, got {type(model).__name__}")
        cfg = self._settings("aff_eq4_ff_config", lib.aff_eq4_ff_default_config(),
                             {k: v for k, v in config.c_fields().items() if k != "ff"}, counts=("warmup",))
        cfg.ff = ff.config[0]
        code = lib.aff_eq4_ff_check_config(cfg)  # the one validator of the settings' ranges
        if code != lib.AFF_OK:
            raise ParameterError(f"{type(self).__name__}: {ffi.string(lib.aff_error_message(code)).decode()}")
        Ts, warmup, tau_max, iv, w_band = cfg.Ts, cfg.warmup, cfg.tau_max, bool(cfg.iv), cfg.w_band
        map_rel_stderr = cfg.map_rel_stderr
        m = check_multiple("Ts", Ts, "dt", ff.dt)
        check_optional("start", start, FeedforwardStart)
        p = model.n_params
        rls = RecursiveLeastSquares(p, lam=config.lam, P0=config.P0)
        ivrls = RecursiveIV(p, lam=config.lam, P0=config.P0, guard=True)
        self.settings = config
        self.model = model
        self.n_theta = p
        u_range, w_range = range_gates(u_range, w_range, w_floor=model.Vs if model.stribeck else 0.0)
        self._new_struct()
        lib.aff_eq4_ff_init(self._c, ff.cdata, m, Ts, int(warmup), tau_max, ff.ff_max,
                            model.Vs if model.stribeck else 1.0, model.delta if model.stribeck else 1.0,
                            model.lag, model.stribeck, model.offset, u_range.cdata, w_range.cdata, rls.cdata,
                            int(bool(iv)), w_band, ivrls.cdata)
        self.start = start
        self._attach(_ff=ff, u_range=u_range, w_range=w_range, rls=rls, ivrls=ivrls)
        if math.isfinite(map_rel_stderr):
            lib.aff_eq4_ff_require_determined(self._c, map_rel_stderr)
        if start is not None:
            args = start.map_args(model.Vs, model.delta)
            if lib.aff_eq4_ff_start(self._c, *args, start.gain, start.ff_input == "reference") != 0:
                raise ParameterError(f"start: refused by aff_eq4_ff_start (Vs > 0 and a finite delta needed): "
                                     f"Vs={args[2]!r}, delta={args[3]!r}")

    def __repr__(self) -> str:
        return (f"AdaptiveFrictionFeedforward({self.model!r}, Ts={self.Ts!r}, dt={self.dt!r}, "
                f"warmup={self.warmup}, iv={self.iv}, w_band={self.w_band!r}, n_updates={self._est.n_updates})")

    # ---- configuration
    _est = property(lambda self: self.ivrls if self.iv else self.rls)
    ff_input = struct_field("ff.at_ref", FF_INPUTS.__getitem__, "Velocity :meth:`compensate` evaluates at.")

    # ---- state

    @property
    def theta(self) -> np.ndarray:
        """Current parameter vector of the estimator in use (RLS, or IV with ``iv``), shape (p,)."""
        return self._est.theta

    @property
    def active(self) -> bool:
        """Whether the feedforward acts: an admissible estimate, or the provisional start map, is in use."""
        return bool(self._c.has_estimate or self._c.provisional)

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
            ``estimator`` ("eq4-rls", "eq4" with ``iv``: the names of ``LoopConfig.estimator.name``), ``n_rejected``,
            ``n_implausible``, ``n_updates`` (of the estimator in use), ``lam``, ``names`` (the regression
            parameters, :attr:`RegressionModel.names`); with ``w_band > 0`` also ``n_gated`` and ``w_band``; with
            a finite ``map_rel_stderr`` also it and ``n_undetermined``.
        """
        d = {"estimator": "eq4" if self.iv else "eq4-rls", "n_rejected": self.n_rejected,
             "n_implausible": self.n_implausible, "n_updates": self._est.n_updates, "lam": self._est.lam,
             "names": list(self.model.names)}
        if self.w_band > 0:
            d.update(n_gated=self.n_gated, w_band=self.w_band)
        if math.isfinite(self.map_rel_stderr):
            d.update(n_undetermined=self.n_undetermined, map_rel_stderr=self.map_rel_stderr)
        return d

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
            Used instead of ``w`` while the joint is detected as stuck (only with ``stick_band > 0``).

        Returns
        -------
        float
            Feedforward torque (N·m), bounded by ``ff_max``; 0 before the first admissible estimate, but during the
            provisional start the start map times its gain (at ``w_ref``, when given, for a start at the reference).
        """
        c = self._c
        if c.provisional:  # as aff_fixed_ff_start_output in compensate
            return start_output(self._ff.step, w, w_ref, at_ref=bool(c.start_at_ref), gain=float(c.start_gain))
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
