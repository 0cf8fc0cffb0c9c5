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

Compensator component: the C struct ``ctl_adob``
(``controllers/csrc/ctl_adob.h``) embeds the feedforward's ``aff_robust_ff``
and the shared part ``aff_residual`` (the observer's ``aff_dob``, the switch-in,
the bound); ``ctl_adob_compensate`` and ``ctl_adob_observe`` (the
``aff_compensator_ops`` table ``ctl_adob_ops``) call the parts' C functions on
them and are the one implementation, called by
:class:`AdaptiveDOBCompensator`'s methods and by the closed-loop engine. Over
the paper's eq. 4 feedforward (:class:`adaptive_ff.AdaptiveFrictionFeedforward`,
estimators ``eq4`` and ``eq4-rls``) the struct is ``ctl_eq4_dob``, the same
composite with ``aff_eq4_ff`` in place of ``aff_robust_ff``.

Mode ``adaptive`` is the same arrangement with a :class:`ResidualSwitchIn`: the observer runs from the start, but
its estimate is applied only once a residual test finds that the feedforward leaves too much of the friction
in the loop's band (sticking joints, small fast joints, LuGre pre-sliding: where the sliding model misses), faded
in; ``info()["t_switch_in"]`` says when (``adaptive_ff/csrc/aff_residual.h``). Over the sliding estimator it is
one component with its supervisor, :class:`AdaptiveCompensator` (C ``aff_adaptive``, the struct ``export-c``
writes for a drive); over the eq. 4 estimators the composite ``ctl_eq4_dob`` with the switch-in. A trial then
keeps it only if the loop's measured error, against the frictionless loop's, is no worse with it than before, where
the observer had little to gain (``info()["t_switch_out"]``).

After a rest of the reference (the supervisor's rest rule withheld the output; the engine calls the ops table's
``at_rest``) the feedforward part is held back until the measured velocity moves in the reference's direction
(``w_ctrl*w_ref > 0``), the observer's estimate applied from the rest's end and the observer told that no
feedforward was applied; before the switch-in of mode ``adaptive`` the output is then 0 (C ``aff_residual_at_rest``;
docs/benchmarks/compensation.md, "The composite's observer at rest").
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass
from typing import NamedTuple

from adaptive_ff.compensation.adaptive_feedforward import RobustAdaptiveFeedforward
from adaptive_ff.compensation.eq4_feedforward import AdaptiveFrictionFeedforward
from adaptive_ff.compensation.defaults import c_defaults
from adaptive_ff.compensation.supervisor import FeedforwardSupervisor
from controllers._cctl import ffi, lib
from controllers.peers.dob import DisturbanceObserver
from plant.component import Component, c_compensate, c_observe, ops_table, step_time, struct_field
from plant.errors import ParameterError, check_nonnegative, check_optional, check_positive

__all__ = ["AdaptiveDOBCompensator", "AdaptiveCompensator", "ResidualSwitchIn", "residual_config"]


class _Composite(NamedTuple):
    """The C struct of the composite over one kind of feedforward, and its functions."""

    ctype: str
    init: object
    compensate: object
    observe: object


#: The composite over each kind of feedforward (``controllers/csrc/ctl_adob.h``).
_COMPOSITES = {
    RobustAdaptiveFeedforward: _Composite("ctl_adob", lib.ctl_adob_init, lib.ctl_adob_compensate,
                                          lib.ctl_adob_observe),
    AdaptiveFrictionFeedforward: _Composite("ctl_eq4_dob", lib.ctl_eq4_dob_init, lib.ctl_eq4_dob_compensate,
                                            lib.ctl_eq4_dob_observe),
}
_BY_CTYPE = {c.ctype: c for c in _COMPOSITES.values()}
_SWITCH_IN = c_defaults("aff_switch_in_config")
_SLEW_TIME = float(lib.aff_residual_default_config().slew_time)  # the C default, 0.4 s
#: The fields of ``aff_switch_in_config`` a :class:`ResidualSwitchIn` sets, and their reader.
_SWITCH_IN_FIELDS = ("Tc", "J_n", "Kp", "Ki", "window", "ratio", "share", "fade_in", "trial_margin")
_switch_in_values = operator.attrgetter(*_SWITCH_IN_FIELDS)


@dataclass(frozen=True)
class ResidualSwitchIn:
    """Settings of the residual switch-in of mode ``adaptive`` (C ``aff_switch_in``, adaptive_ff/csrc/aff_residual.h).

    The loop's linear model (design inertia ``J_n``, PI gains ``Kp``, ``Ki``) predicts the frictionless loop's error
    on the reference and the velocity that the observer's residual estimate ``d_hat`` adds to it; the loop being
    linear, its error with the residual is the difference of the two. The observer's estimate is applied once what the
    residual raises the loop's mean-square error by (its own mean square, or with its correlation with the loop's
    error where that adds; time constant ``window``, over at least twice ``window`` of periods in which the
    feedforward acts and the reference moves) exceeds ``ratio`` times the frictionless loop's mean square, or
    ``share`` times what the whole friction estimate ``u_ff + d_hat`` would raise it by, while the loop's measured
    mean-square error (of ``w_ref - w_ctrl`` over the same periods) exceeds the frictionless loop's predicted one (a
    loop that already tracks as well as the frictionless one with the feedforward alone keeps it alone); or after
    ``5*window`` without the feedforward acting (a provisional start map acting alone is not replaced so: from then
    on its periods count as the estimate's would). It then fades in over ``fade_in``. A switch-in with little to gain
    (the measured mean-square error at most ``1 + ratio`` times the frictionless loop's; not the idle switch-in) is
    put on trial: over two windows of moving reference after the fade-in, the loop's measured mean-square error with
    the observer, relative to the frictionless loop's predicted one, is compared with the same ratio over the last
    window before the switch-in; where it is higher by more than ``trial_margin`` the observer fades out again, for
    good (``t_switch_out``), else it stays. The C header ``controllers/csrc/ctl_adob.h`` gives the equations.

    Parameters
    ----------
    Tc : float
        Controller period (s), > 0.
    J_n : float
        Design inertia (kg·m²), > 0.
    Kp, Ki : float
        The loop's PI gains (N·m·s/rad, > 0; N·m/rad, >= 0).
    window : float
        Time constant of the mean squares and the evidence needed (s), > 0; default 2.
    ratio : float
        Threshold (-), > 0; default 0.1: the residual raises the loop's mean-square error by 10 % of the
        frictionless loop's (5 % in RMS).
    share : float
        Second threshold (-), > 0; default 0.1: the observer is also switched in where what the residual raises
        the loop's mean-square error by exceeds ``share`` times what the whole friction estimate ``u_ff + d_hat``
        would raise it by (as predicted, the feedforward removes less than nine tenths of the friction's effect in
        mean square; that prediction for the uncompensated loop is 1.5-10 times too large, so the test errs toward
        keeping the feedforward alone) -- on joints whose friction hardly matters next to the loop's own error the
        first test cannot fire.
    fade_in : float
        Time over which the observer's share rises from 0 to 1 (s), >= 0 (0: a step); default 0.5.
    trial_margin : float
        The trial (of a switch-in with little to gain) takes the observer out where the measured mean-square error
        with it, relative to the frictionless loop's, is more than ``1 + trial_margin`` times what it was before the
        switch-in (-), >= 0; ``math.inf``: no trial (the switch-in for good).
        Default 0.03: below it the observers the trial took out on the zoos had helped as often as hurt (the
        sampling noise of two ratios over two windows; docs/benchmarks/compensation.md, "The switch-in on trial").

    Raises
    ------
    ParameterError
        A value out of range (named).
    """

    Tc: float
    J_n: float
    Kp: float
    Ki: float
    window: float = _SWITCH_IN["window"]  # the C defaults, aff_switch_in_default_config()
    ratio: float = _SWITCH_IN["ratio"]
    share: float = _SWITCH_IN["share"]
    fade_in: float = _SWITCH_IN["fade_in"]
    trial_margin: float = _SWITCH_IN["trial_margin"]

    def __post_init__(self):
        for name in ("Tc", "J_n", "Kp", "window", "ratio", "share"):
            check_positive(name, getattr(self, name))
        check_nonnegative("Ki", self.Ki)
        check_nonnegative("fade_in", self.fade_in)
        m = self.trial_margin
        if not (isinstance(m, (int, float)) and not isinstance(m, bool) and m >= 0.0):
            raise ParameterError(f"trial_margin must be >= 0 (math.inf: no trial), got {m!r}")

    def config_fields(self) -> dict:
        """The fields of the C settings ``aff_switch_in_config`` (``aff_residual_init`` computes the EWMA factor, the
        fade step and the evidence count from them)."""
        return dict(zip(_SWITCH_IN_FIELDS, map(float, _switch_in_values(self))))


def residual_config(observer: DisturbanceObserver, u_max: float, switch_in: ResidualSwitchIn | None, *,
                    crossover: float = 0.0, slew_time: float = _SLEW_TIME):
    """The settings of the residual part (C ``aff_residual_config``) of a composite: the observer's, the bound
    ``u_max`` (N·m), the switch-in (None: the observer always applied) and the slew limit on the applied estimate
    (``crossover``: the loop's ``Kp/J_n`` in rad/s, ``slew_time`` in s; either 0: none; ``aff_residual_init``
    checks them)."""
    cfg = ffi.new("aff_residual_config *", lib.aff_residual_default_config())
    cfg.u_max, cfg.dob, cfg.use_switch_in = u_max, observer.config[0], switch_in is not None
    cfg.crossover, cfg.slew_time = float(crossover), float(slew_time)
    if switch_in is not None:
        cfg.switch_in = switch_in.config_fields()
    return cfg


class AdaptiveDOBCompensator(Component):
    """Adaptive friction feedforward with a disturbance observer on the residual (mode ``adaptive-dob``).

    Parameters
    ----------
    feedforward : RobustAdaptiveFeedforward or AdaptiveFrictionFeedforward
        The adaptive feedforward (with its estimator: the sliding estimator, or the paper's eq. 4 by RLS or IV);
        its struct is copied into the composite's, and the object points there from now on (as ``observer``).
    observer : DisturbanceObserver
        The observer of the residual ``f - u_ff`` (nominal inertia: the design inertia).
    u_max : float, keyword-only
        Bound on |u_ff + d_hat| (N·m), default inf (each part keeps its own bound as well).
    switch_in : ResidualSwitchIn or None, keyword-only
        None (default): the observer's estimate is always applied (mode ``adaptive-dob``); else it is applied after
        the residual switch-in (mode ``adaptive``).
    crossover, slew_time : float, keyword-only
        The slew limit on the observer's applied estimate: per period it moves by at most ``slew_time*crossover``
        times the feedforward's largest torque so far times the Q-filter's factor ``1 - exp(-Tc*omega_q)``;
        ``crossover`` the loop's ``Kp/J_n`` (rad/s, the observers' nominal inertia), ``slew_time`` (s, default 0.4); either 0:
        no limit (``crossover``'s default; C ``aff_residual_config``).

    Attributes
    ----------
    C_OPS : str
        ``"ctl_adob_ops"`` (``"ctl_eq4_dob_ops"`` over the eq. 4 feedforward), the C ops table
        (``aff_compensator_ops``) the engine calls with :attr:`cdata`.
    cdata : cffi ``ctl_adob *`` or ``ctl_eq4_dob *``
        The composite's struct; the parts' structs are its fields ``ff`` and ``res.dob``.
    feedforward : RobustAdaptiveFeedforward or AdaptiveFrictionFeedforward
        Points into the field ``ff``.
    observer : DisturbanceObserver
        Points into the field ``res.dob``.
    estimator : SlidingFrictionEstimator or AdaptiveFrictionFeedforward
        The feedforward's estimator (the eq. 4 feedforward is its own).
    n_theta : int
        Length of the estimator's parameter vector.
    u_ff : float
        Feedforward part of the last output (N·m).

    Raises
    ------
    ParameterError
        Parts of the wrong type, ``u_max < 0`` or ``switch_in`` not a :class:`ResidualSwitchIn`.

    Notes
    -----
    Per period: ``u_ff`` from the feedforward (faded in after its switch-on), ``d_hat = Q[(u - u_ff)(k-1) -
    J_n*(w(k) - w(k-1))/Tc]`` from the observer, output ``u_ff + d_hat``. For ``J_n = J`` the observer's
    raw sample is the mean residual ``f - u_ff`` over the last period (module docstring), so the observer
    cancels what the feedforward misses within the Q-filter bandwidth and the feedforward covers the fast
    reversals beyond it.
    """

    MODE = "adaptive-dob"
    #: Name of the C ops table (``aff_compensator_ops``) the engine calls with :attr:`cdata`, see :attr:`ops`.
    C_OPS = "ctl_adob_ops"
    _ffi = ffi
    _ctype = "ctl_adob"
    #: The feedforward (its estimator follows its struct) and the observer (with its gates), in this struct.
    _parts = {"feedforward": "ff", "observer": "res.dob"}

    def __init__(self, feedforward: RobustAdaptiveFeedforward | AdaptiveFrictionFeedforward,
                 observer: DisturbanceObserver, *, u_max: float = math.inf, switch_in: ResidualSwitchIn | None = None,
                 crossover: float = 0.0, slew_time: float = _SLEW_TIME):
        composite = _COMPOSITES.get(type(feedforward))
        if composite is None:
            raise ParameterError("feedforward must be a RobustAdaptiveFeedforward or an AdaptiveFrictionFeedforward, "
                                 f"got {type(feedforward).__name__}")
        if not isinstance(observer, DisturbanceObserver):
            raise ParameterError(f"observer must be a DisturbanceObserver, got {type(observer).__name__}")
        u_max = math.inf if u_max == math.inf else check_nonnegative("u_max", u_max)
        self.feedforward = feedforward
        self.observer = observer
        self.n_theta = feedforward.n_theta
        self.switch_in = check_optional("switch_in", switch_in, ResidualSwitchIn)
        if switch_in is not None:
            self.MODE = "adaptive"  # the mode it is (run_closed_loop's default result name)
        self._ctype = composite.ctype
        self.C_OPS = f"{composite.ctype}_ops"
        self._configure(lambda c, cfg: composite.init(c, feedforward.cdata, cfg),
                        residual_config(observer, u_max, switch_in, crossover=crossover, slew_time=slew_time),
                        lib.aff_error_message, keep=False)
        self._attached()

    def __repr__(self) -> str:
        return f"AdaptiveDOBCompensator({self.estimator!r}, {self.observer!r})"

    ops = ops_table(lib)

    u_max = struct_field("res.u_max", float, "Bound on the total output (N·m).")
    u_ff = struct_field("res.u_ff", float, "Feedforward part of the last output as its observer is told it (N·m; 0 "
                        "at rest and while held after a rest, once the observer's estimate is applied).")
    held = struct_field("res.held", bool, "Whether the feedforward part is held back after a rest until the joint "
                        "moves in the reference's direction (C ``aff_residual_at_rest``).")
    n_held = struct_field("res.n_held", int,
                          "Periods outside rest in which the feedforward part was held back after a rest.")

    @property
    def estimator(self):
        """The feedforward's estimator: :class:`adaptive_ff.SlidingFrictionEstimator`, or the eq. 4 feedforward
        itself (:class:`adaptive_ff.AdaptiveFrictionFeedforward`, which holds its RLS or IV)."""
        ff = self.feedforward
        return ff.estimator if isinstance(ff, RobustAdaptiveFeedforward) else ff

    @property
    def estimate(self):
        """The feedforward's estimate in use (None before its switch-on)."""
        return self.feedforward.estimate

    @property
    def active(self) -> bool:
        """Whether the feedforward part is switched on (the observer always is)."""
        return self.feedforward.active

    t_switch_in = step_time("res.sw.k_in", "switch_in.Tc", "Time of the residual switch-in from the first period "
                            "(s; ``k*Tc``), None without it or before.")
    t_switch_out = step_time("res.sw.k_out", "switch_in.Tc", "Time at which the switch-in's trial took the observer "
                             "out again (s; ``k*Tc``), None if it did not (no switch-in, the trial pending, or the "
                             "observer kept).")

    def info(self) -> dict:
        """The feedforward's counters (:meth:`RobustAdaptiveFeedforward.info`) plus the observer's, prefixed
        ``dob_`` (``dob_n_rejected``, ``dob_J_n`` kg·m², ``dob_omega_q`` rad/s); with the switch-in also
        ``t_switch_in`` (s or None), ``residual_ratio`` (``R_r/M_l``, what the test compares with ``ratio``) and
        ``residual_share`` (``R_r/R_f``, what it compares with ``share``), ``R = max(M, M - 2*C)`` the rise of the
        loop's mean-square error with the cross term where it adds, and ``measured_ratio`` (``M_e/M_l``, the loop's
        measured mean-square error against the frictionless loop's predicted one: the test fires only above 1), when
        last updated (None before any evidence); and the trial's ``t_switch_out`` (s or None: the observer kept or
        not yet judged) and ``trial_ratio`` (the loop's measured mean-square error against the frictionless loop's
        with the observer in, over the same ratio at the switch-in; the observer is taken out above ``1 +
        trial_margin``; None until the trial has judged, and where there is no trial: after the idle switch-in and
        after one with more than ``ratio`` to gain). C ``aff_switch_in``, whose header names the means."""
        d = self.feedforward.info()
        d.update({f"dob_{k}": v for k, v in self.observer.info().items()})
        if self.switch_in is not None:
            sw = self._c.res.sw
            m_l, rises = float(sw.m_l), ffi.new("double[2]")
            lib.aff_switch_in_rises(ffi.addressof(self._c.res, "sw"), rises, rises + 1)
            rise_r, rise_f = float(rises[0]), float(rises[1])
            d["t_switch_in"] = self.t_switch_in
            d["residual_ratio"] = rise_r / m_l if m_l > 0.0 else None
            d["residual_share"] = rise_r / rise_f if rise_f > 0.0 else None
            d["measured_ratio"] = float(sw.m_e) / m_l if m_l > 0.0 else None
            d["t_switch_out"] = self.t_switch_out
            ratio_in, v_l = float(sw.ratio_in), float(sw.v_l)
            d["trial_ratio"] = (float(sw.v_e) / v_l / ratio_in if sw.decided and v_l > 0.0 and math.isfinite(ratio_in)
                                else None)
        return d

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensator protocol: ``u_ff + d_hat`` for this period (N·m), C ``ctl_adob_compensate`` (or
        ``ctl_eq4_dob_compensate``).

        Parameters
        ----------
        w_meas, w_ref : float
            Measured and reference velocity (rad/s).
        """
        w_meas = float(w_meas)
        return float(_BY_CTYPE[self._ctype].compensate(self._c, w_meas, w_meas, float(w_ref)))

    def at_rest(self) -> None:
        """Compensator protocol, optional: the loop withheld this period's output because the reference rests (the
        supervisor's rest rule), called between :meth:`compensate` and :meth:`observe` (C ``aff_residual_at_rest``:
        the observer told that the feedforward was not applied, and the hold after the rest armed). The engine
        calls it itself; call it when you step the compensator by hand with a rest rule of your own."""
        lib.aff_residual_at_rest(ffi.addressof(self._c, "res"))

    def observe(self, u: float, w: float) -> bool:
        """Compensator protocol: record the applied torque and the measurement (C ``ctl_adob_observe`` or
        ``ctl_eq4_dob_observe``).

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
        return bool(_BY_CTYPE[self._ctype].observe(self._c, float(u), float(w), ffi.NULL))


class AdaptiveCompensator(AdaptiveDOBCompensator):
    """Mode ``adaptive`` as one component: the feedforward, the residual observer it switches in and the supervisor.

    The C struct ``aff_adaptive`` (``adaptive_ff/csrc/aff_adaptive.h``) holds the sliding estimator's robust
    feedforward, the residual observer with its :class:`ResidualSwitchIn` and trial (``aff_residual``) and the
    :class:`adaptive_ff.compensation.supervisor.FeedforwardSupervisor` with its rest rule; ``aff_adaptive_compensate``
    and ``aff_adaptive_observe`` (the ops table ``aff_adaptive_ops``) compose them in the order the closed-loop
    engine did around the composite, and are the one implementation the engine runs and ``adaptive-ff export-c``
    writes for a drive (``aff_drive.h``).

    Parameters
    ----------
    feedforward : RobustAdaptiveFeedforward
        The adaptive feedforward with its sliding estimator (copied into the composite's struct; the object points
        there from now on).
    observer : DisturbanceObserver or None
        The observer of the residual ``f - u_ff`` (with ``switch_in``); None: the feedforward without the observer.
    u_max : float, keyword-only
        Bound on |u_ff + d_hat| (N·m), default inf.
    switch_in : ResidualSwitchIn or None, keyword-only
        The observer's switch-in; None with an observer: the observer always applied (as ``adaptive-dob``).
    crossover, slew_time : float, keyword-only
        The slew limit on the observer's applied estimate, as :class:`AdaptiveDOBCompensator`'s (with an observer).
    supervisor : FeedforwardSupervisor or None, keyword-only
        The supervisor of the compensation (copied into the struct; the object points there from now on); None:
        none.

    Attributes
    ----------
    C_OPS : str
        ``"aff_adaptive_ops"``.
    cdata : cffi ``aff_adaptive *``
    supervisor : FeedforwardSupervisor or None
        Points into the field ``sup``.
    transfer : float
        The supervisor's bumpless transfer of the last :meth:`compensate` (N·m): add it to your PI's integrator in
        that period (0 unless the supervisor switched the compensation on or off).

    Raises
    ------
    ParameterError
        Parts of the wrong type, ``u_max < 0``, a ``switch_in`` without an observer or refused.
    """

    MODE = "adaptive"
    C_OPS = "aff_adaptive_ops"
    _ctype = "aff_adaptive"
    #: The feedforward, the observer and the supervisor (each but the first optional), in this struct.
    _parts = {"feedforward": "ff", "observer": "res.dob", "supervisor": "sup"}

    def __init__(self, feedforward: RobustAdaptiveFeedforward, observer: DisturbanceObserver | None = None, *,
                 u_max: float = math.inf, switch_in: ResidualSwitchIn | None = None,
                 supervisor: FeedforwardSupervisor | None = None, crossover: float = 0.0,
                 slew_time: float = _SLEW_TIME):
        if not isinstance(feedforward, RobustAdaptiveFeedforward):
            raise ParameterError(f"feedforward must be a RobustAdaptiveFeedforward, got {type(feedforward).__name__}")
        check_optional("observer", observer, DisturbanceObserver)
        check_optional("switch_in", switch_in, ResidualSwitchIn)
        if switch_in is not None and observer is None:
            raise ParameterError("switch_in needs an observer (the residual observer it switches in)")
        check_optional("supervisor", supervisor, FeedforwardSupervisor)
        u_max = math.inf if u_max == math.inf else check_nonnegative("u_max", u_max)
        self.feedforward = feedforward
        self.observer = observer
        self.supervisor = supervisor
        self.switch_in = switch_in
        self.n_theta = feedforward.n_theta
        cfg = self._settings("aff_adaptive_config", lib.aff_adaptive_default_config(),
                             {"use_residual": observer is not None, "use_supervisor": supervisor is not None,
                              "ff": feedforward.config[0]})  # the parts not used keep the C defaults
        if observer is not None:
            cfg.res = residual_config(observer, u_max, switch_in, crossover=crossover, slew_time=slew_time)[0]
        else:
            cfg.res.u_max = u_max
        if supervisor is not None:
            cfg.sup = supervisor.config[0]
        self._configure(lib.aff_adaptive_init, cfg, lib.aff_error_message)
        self._attached()

    def __repr__(self) -> str:
        return (f"AdaptiveCompensator({self.estimator!r}, observer={self.observer!r}, switch_in={self.switch_in!r}, "
                f"supervisor={self.supervisor!r})")

    def drive_config(self, **guard):
        """The drive's settings (C ``aff_config``, for ``aff_init`` of ``adaptive_ff/csrc/aff_drive.h``): this
        compensator's (:attr:`config`) and the input guard's, ``aff_guard_default_config()`` at the feedforward's
        period with the fields given in ``guard`` (``Tc`` s, ``w_max`` rad/s, ``u_max`` N·m, ``hold_time`` s)."""
        cfg = ffi.new("aff_config *")
        cfg.mode = self.config[0]
        cfg.guard = lib.aff_guard_default_config()
        cfg.guard.Tc = self.feedforward.dt
        for k, v in guard.items():
            setattr(cfg.guard, k, v)
        return cfg

    transfer = struct_field("transfer", float, "The supervisor's bumpless transfer of the last compensate (N·m), "
                            "for the PI's integrator.")

    def info(self) -> dict:
        """:meth:`AdaptiveDOBCompensator.info` (without the ``dob_`` keys where there is no observer); the
        supervisor's counters are its own :meth:`FeedforwardSupervisor.info`."""
        if self.observer is not None:
            return super().info()
        return self.feedforward.info()

    compensate = c_compensate(lib.aff_adaptive_compensate, """Compensator protocol: this period's compensation
        (N·m), C ``aff_adaptive_compensate`` (the measurement as the controller's); then :attr:`transfer` holds the
        supervisor's bumpless transfer.""")

    def at_rest(self) -> None:
        """Nothing to do: the composite's own supervisor tells the observer (C ``aff_adaptive_compensate``)."""

    observe = c_observe(lib.aff_adaptive_observe, """Compensator protocol: the applied torque ``u`` (N·m) and the
        measured velocity ``w`` (rad/s), C ``aff_adaptive_observe``; True after an RLS update of the estimator.""",
                        bool)
