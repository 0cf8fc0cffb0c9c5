"""Fixed friction feedforward (a friction estimate, fed forward through the estimated lag) and the estimate projection.

:class:`FrictionFeedforward` is a compensator component (mode ``fixed``): its configuration and state are the C
struct ``aff_fixed_ff`` (``adaptive_ff/csrc/aff_feedforward.h``), configured from its settings ``aff_fixed_ff_config``
by ``aff_fixed_ff_init`` and advanced by C, the one implementation, called by the class's methods and by the
closed-loop engine: ``aff_fixed_ff_set_estimate`` (put an estimate into use),
``aff_fixed_ff_static`` (the static map, eq. 3), ``aff_fixed_ff_step`` (stick detection, the lag of eq. 1, the
clip) and the compensator interface ``aff_fixed_ff_compensate`` / ``aff_fixed_ff_observe``
(``adaptive_ff/csrc/aff_compensator.h``, ops table ``aff_fixed_ff_ops``). Near standstill its velocity input comes
from the loop model and the sign observer of :mod:`adaptive_ff.compensation.velocity_input`, whose structs it
embeds.

:func:`project_estimate` (C: ``aff_project_levels``, also :func:`project_levels`) projects a raw estimate onto the
physically admissible set or rejects it.

The adaptive feedforwards embed this one's struct: the recommended
:class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward` (online sliding-regime RLS,
the paper's future work) and the paper's eq. 4 RLS feedforward, kept as a baseline, in
:mod:`adaptive_ff.compensation.eq4_feedforward`.
"""
from __future__ import annotations

import math

from adaptive_ff._caff import ffi, lib
from adaptive_ff.compensation.velocity_input import LoopModel, SignObserver
from adaptive_ff.identification.regression import FrictionEstimate
from adaptive_ff.compensation.defaults import c_config_class
from plant.component import Component, struct_field, struct_fields
from plant.errors import ParameterError, check_optional

__all__ = ["FrictionFeedforward", "FrictionFeedforwardConfig", "project_estimate", "project_levels", "FF_INPUTS",
           "at_ref"]

#: The velocity the feedforward is evaluated at, by the C flag ``at_ref`` (0: the measured, 1: the reference).
FF_INPUTS = ("measured", "reference")

FrictionFeedforwardConfig = c_config_class(
    "FrictionFeedforwardConfig", "aff_fixed_ff_config", "aff_feedforward.h", module=__name__,
    summary="Settings of a :class:`FrictionFeedforward` (and of the feedforward part of the adaptive ones): the lag, "
            "the bound, the sign near standstill, the stick detection, the input velocity.",
    exclude=("dt", "use_loop_model", "use_sign_observer"),
    fields={"at_ref": ("ff_input", dict(enumerate(FF_INPUTS)))})


def at_ref(ff_input: str) -> int:
    """The C flag ``at_ref`` of ``ff_input`` (one of :data:`FF_INPUTS`); ParameterError naming ``ff_input`` else."""
    if ff_input not in FF_INPUTS:
        raise ParameterError(f"ff_input must be one of {FF_INPUTS}, got {ff_input!r}")
    return FF_INPUTS.index(ff_input)


def project_levels(J, tau, sigma, Fc, Fs, offset, tau_max, F_max) -> tuple:
    """Projection of a physical estimate onto the admissible set by C (``adaptive_ff/csrc/aff_feedforward.c``,
    ``aff_project_levels``; the one implementation of :func:`project_estimate`).

    Parameters
    ----------
    J, tau, sigma, Fc, Fs, offset : float
        Raw estimate from the inverse map of eq. 4 (kg·m², s, N·m·s/rad, N·m, N·m, N·m).
    tau_max : float
        Largest admissible lag (s).
    F_max : float
        Largest admissible Coulomb or static level (N·m).

    Returns
    -------
    tuple (bool, float, float, float, float)
        ``(ok, tau, sigma, Fc, Fs)``: ``ok`` False if a value is non-finite, ``J <= 0`` or
        ``Fc``/``Fs`` exceeds ``F_max`` (the values unchanged); otherwise ``tau`` clipped to ``[0, tau_max]`` and
        ``sigma``, ``Fc``, ``Fs`` to ``>= 0`` (Ioannou & Sun, *Robust Adaptive Control*, 1996, Sec. 4.11.3;
        used by :func:`project_estimate` and by the C eq. 4 feedforward).
    """
    e = ffi.new("aff_physical *", {"J": J, "tau": tau, "sigma": sigma, "Fc": Fc, "Fs": Fs, "offset": offset})
    ok = lib.aff_project_levels(e, tau_max, F_max)
    return bool(ok), e.tau, e.sigma, e.Fc, e.Fs


def project_estimate(est: FrictionEstimate, *, tau_max: float = 1.0,
                     F_max: float = math.inf) -> FrictionEstimate | None:
    """Project a raw estimate onto the physically admissible set, or reject it.

    Parameters
    ----------
    est : FrictionEstimate
        Raw estimate from :meth:`RegressionModel.to_physical`.
    tau_max : float, keyword-only
        Largest admissible lag (s).
    F_max : float, keyword-only
        Largest admissible Coulomb or static friction level (N·m), e.g. the
        feedforward bound; default inf.

    Returns
    -------
    FrictionEstimate or None
        ``None`` if a value is non-finite, ``J <= 0`` (the input gain
        ``b0 - b1`` has the wrong sign: nothing physical can be read from it),
        or ``Fc`` or ``Fs`` exceeds ``F_max`` (an unconverged estimate);
        otherwise a copy with ``Fc, Fs, sigma`` clipped to ``>= 0`` and ``tau``
        clipped to ``[0, tau_max]``.

    Notes
    -----
    Projection onto a box of physical bounds, the standard safeguard of
    adaptive control (Ioannou & Sun, *Robust Adaptive Control*, 1996, Sec. 4.11.3),
    applied here to the physical parameters rather than to ``theta``.
    """
    ok, tau, sigma, Fc, Fs = project_levels(est.J, est.tau, est.sigma, est.Fc, est.Fs, est.offset, tau_max, F_max)
    if not ok:
        return None
    return FrictionEstimate(J=est.J, tau=tau, sigma=sigma, Fc=Fc, Fs=Fs, offset=est.offset, Vs=est.Vs,
                            delta=est.delta, J_alt=est.J_alt)


@struct_fields("dt", "lag", "ff_max", "sign_width", "stick_band", "stick_samples", "u_ff", "w_max", via="_f")
class FrictionFeedforward(Component):
    """Friction feedforward torque from a fixed estimate, with the estimated lag.

    Parameters
    ----------
    estimate : FrictionEstimate or None
        Friction parameters; ``None`` gives zero feedforward.
    dt : float, keyword-only
        Call period of :meth:`step` (s), e.g. the controller period.
    config : FrictionFeedforwardConfig, keyword-only
        The settings (default: the C defaults, :class:`FrictionFeedforwardConfig`), among them:

        ``lag``
            Filter the static map through the estimated lag ``tau`` (eq. 1), default True.
        ``ff_max``
            Bound on |feedforward| (N·m), default inf.
        ``sign_width``
            Treatment of the sign near zero velocity (rad/s): 0 (default) uses
            ``sgn(w)``; ``> 0`` the linear ramp ``clip(w/sign_width, -1, 1)``, which
            stops measurement noise from flipping the full Coulomb torque.
        ``stick_band``
            Velocity band (rad/s) for the stick detection: once the first velocity
            given to :meth:`step` (the measurement) has stayed inside
            ``±stick_band`` for ``stick_samples`` consecutive calls, the joint is
            taken as stuck and the second velocity (the reference: the intended
            direction of motion) is used instead, until the measurement leaves the
            band. A stuck joint's measured velocity is noise; its sign says
            nothing. Default 0 (off).
        ``stick_samples``
            Consecutive in-band samples that declare sticking, >= 1; default 10.
        ``ff_input``
            Velocity the closed-loop engine evaluates the feedforward at (:meth:`compensate`): the
            controller's measurement with stick detection (default), or the reference itself.
        ``w_max``
            Largest plausible speed (rad/s), > 0: a velocity above it is rejected like a
            non-finite one (see Notes); default inf.
    loop_model : LoopModel or None, keyword-only
        The nominal velocity loop. Given, :meth:`compensate` uses its velocity (driven by the
        reference) instead of the reference while the joint is detected as stuck (see Notes); default
        None: the reference.
    sign_observer : SignObserver or None, keyword-only
        Given, :meth:`compensate` takes the sign of the friction map from this velocity observer while the
        measurement is inside ``±stick_band`` (before the joint is detected as stuck; see Notes); default None:
        the measurement's sign.

    Attributes
    ----------
    cdata : cffi pointer
        The C struct ``aff_fixed_ff`` (``adaptive_ff/csrc/aff_feedforward.h``) that C advances
        (``aff_fixed_ff_step``, the compensator interface ``aff_fixed_ff_compensate`` / ``aff_fixed_ff_observe``,
        ops table ``aff_fixed_ff_ops``); a copy of the struct is a complete, independent compensator.
    u_ff : float
        The lag filter's output before the clip (N·m).
    n_step_rejected : int
        Calls of :meth:`step` whose input was rejected (non-finite or above ``w_max``,
        or a non-finite friction map); they returned the held output.

    Raises
    ------
    ParameterError
        ``dt <= 0``, ``ff_max < 0``, ``sign_width < 0``, ``stick_band < 0``, ``stick_samples < 1`` or an
        unknown ``ff_input``.

    Notes
    -----
    ``u_ff`` follows ``tau*du_ff/dt + u_ff = F_hat(w)`` (eq. 1 with the estimate),
    discretised exactly for a held input: ``u_ff += (1 - exp(-dt/tau))*(F_hat(w) - u_ff)``.
    The constant ``offset`` of the estimate is not fed forward (it is a sensor
    or drive bias, not friction; the PI integrator removes it).

    **Input rejection.** A call with a non-finite velocity (or reference, when
    given), a velocity above ``w_max`` in magnitude, or a friction map that is
    not finite there (e.g. ``sigma*w`` overflowing) changes nothing but
    :attr:`n_step_rejected` and returns the last output (held, clipped): one
    bad sample cannot poison the lag filter. Finite spikes within ``w_max`` are
    the job of the measurement's gate (:class:`adaptive_ff.compensation.gate.OutlierGate`).

    **Stick-detection fallback.** Inside the stick band the measured velocity is noise and its sign
    says nothing; a friction map fed back from it turns every wrong-signed sample into a ``2*Fs``
    torque error, and near a slow zero crossing those kicks push the joint the way the noise said
    (the joint then follows the wrong sign). The reference gives the intended direction but leads
    the joint at reversals by the loop's lag (the feedforward flips early and kicks the joint). The
    loop model's velocity (:class:`LoopModel`, C ``aff_loop_model_step``) is the noise-free trajectory of
    the compensated joint, with the loop's lag: at a reversal it crosses zero when the joint should.
    Outside the band the measurement is used (it cancels the Stribeck dip's negative damping, which a
    map at any other velocity would not). Measured on ``paper`` (docs/benchmarks/variants.md).

    **Sign inside the band.** Before the joint counts as stuck (a reversal crosses the band in a few
    periods), the measured sign near zero flips with the noise, and each wrong-signed sample is a ``2*Fs``
    step into the lag filter. With a :class:`SignObserver` the map is evaluated at the measured speed with the
    observer's sign there (C ``aff_sign_observer_step``): a noise-filtered estimate that follows the joint's
    acceleration through the applied torque and crosses zero with the joint (docs/benchmarks/compensation.md).
    """

    #: The C ops table (``aff_compensator_ops``) the closed-loop engine calls with :attr:`cdata`.
    C_OPS = "aff_fixed_ff_ops"
    MODE = "fixed"
    n_theta = 0
    _ffi = ffi
    _ctype = "aff_fixed_ff"

    #: The settings' class.
    Config = FrictionFeedforwardConfig

    def __init__(self, estimate: FrictionEstimate | None, *, dt: float, config: FrictionFeedforwardConfig | None = None,
                 loop_model: LoopModel | None = None, sign_observer: SignObserver | None = None):
        config = FrictionFeedforwardConfig() if config is None else config
        cfg = self._settings_of(dt, config, loop_model, sign_observer)
        self._configure(lib.aff_fixed_ff_init, cfg, lib.aff_error_message)
        self.settings = config
        self.loop_model = loop_model
        self.sign_observer = sign_observer
        self._attached()
        self.estimate = None
        self._set(estimate)

    def _settings_of(self, dt, config, loop_model, sign_observer):
        """The C settings of the constructor's arguments, their types checked (their ranges are C's to check)."""
        if not isinstance(config, FrictionFeedforwardConfig):
            raise ParameterError(f"config must be a FrictionFeedforwardConfig, got {type(config).__name__}")
        check_optional("loop_model", loop_model, LoopModel)
        check_optional("sign_observer", sign_observer, SignObserver)
        cfg = self._settings("aff_fixed_ff_config", lib.aff_fixed_ff_default_config(), {
            **config.c_fields(), "dt": dt, "use_loop_model": loop_model is not None,
            "use_sign_observer": sign_observer is not None}, counts=("stick_samples",))
        if loop_model is not None:
            cfg.loop_model = loop_model.config_fields()
        if sign_observer is not None:
            cfg.sign_observer = sign_observer.config_fields()
        return cfg

    @classmethod
    def checked_settings(cls, *, dt: float, config: FrictionFeedforwardConfig | None = None,
                         loop_model: LoopModel | None = None, sign_observer: SignObserver | None = None):
        """The settings a ``FrictionFeedforward(None, dt=dt, config=config, ...)`` is configured from, checked as its
        constructor checks them, without making its struct: the feedforward part of a composite, whose C init makes
        the struct (:class:`adaptive_ff.compensation.adaptive_feedforward.RobustAdaptiveFeedforward`).

        Parameters
        ----------
        dt, config, loop_model, sign_observer : keyword-only
            As the constructor's.

        Returns
        -------
        cffi ``aff_fixed_ff_config *``
            The C settings (``aff_fixed_ff_check_config`` accepted them).

        Raises
        ------
        ParameterError, SettingTypeError
            The constructor's errors, with its messages (``FrictionFeedforward: ...``).
        """
        config = FrictionFeedforwardConfig() if config is None else config
        cfg = cls.__new__(cls)._settings_of(dt, config, loop_model, sign_observer)
        code = int(lib.aff_fixed_ff_check_config(cfg))
        if code != 0:  # the sentence of the constructor's _configure (aff_fixed_ff_init checks first the same)
            raise ParameterError(f"{cls.__name__}: {ffi.string(lib.aff_error_message(code)).decode()}")
        return cfg

    # ---- the struct: self._f points to the aff_fixed_ff (this component's struct, or the part of a composite's)
    def _attached(self) -> None:
        self._f = self._c
        super()._attached()

    def __getstate__(self) -> dict:
        d = super().__getstate__()
        d.pop("_f", None)
        return d

    ff_input = struct_field("at_ref", FF_INPUTS.__getitem__,
                            "Velocity the engine evaluates the feedforward at (``compensate``).", via="_f")
    n_step_rejected = struct_field("n_rejected", int,
                                   "Calls of step() whose input was rejected (the output was held).", via="_f")

    def _set(self, est: FrictionEstimate | None) -> None:
        self.estimate = est
        if est is not None:
            has = est.Vs is not None
            lib.aff_fixed_ff_set_estimate(self._f, est.Fc, est.Fs, est.Vs if has else 1.0,
                                          est.delta if has else 1.0, est.sigma, est.tau, has)

    def static(self, w: float) -> float:
        """Static friction estimate ``F_hat(w)`` (N·m), eq. 3 with the estimate (no offset); C
        ``aff_fixed_ff_static``."""
        return float(lib.aff_fixed_ff_static(self._f, float(w)))

    def step(self, w: float, w_ref: float | None = None) -> float:
        """Advance one period; return the bounded feedforward (N·m) (C ``aff_fixed_ff_step``).

        Parameters
        ----------
        w : float
            Velocity the friction map is evaluated at (rad/s), e.g. the measurement.
        w_ref : float, optional
            Used instead of ``w`` while the joint is detected as stuck (see
            ``stick_band``), e.g. the reference velocity.

        Returns
        -------
        float
            The feedforward (N·m), within ``±ff_max``; the held output if the input was
            rejected (class Notes, counted in :attr:`n_step_rejected`).
        """
        has = w_ref is not None
        return float(lib.aff_fixed_ff_step(self._f, float(w), float(w_ref) if has else 0.0, has))

    def compensate(self, w_meas: float, w_ref: float) -> float:
        """Compensator protocol: the feedforward for this period at the measured velocity (with stick detection)
        or at the reference, as ``ff_input`` says (N·m); C ``aff_fixed_ff_compensate``."""
        return float(lib.aff_fixed_ff_compensate(self._f, float(w_meas), float(w_meas), float(w_ref)))

    def observe(self, u: float, w: float) -> bool:
        """Compensator protocol: nothing to learn (returns False); the sign observer (if any) takes the applied
        torque ``u`` (N·m) of this period (C ``aff_fixed_ff_observe``)."""
        lib.aff_fixed_ff_observe(self._f, float(u), float(w), ffi.NULL)
        return False
