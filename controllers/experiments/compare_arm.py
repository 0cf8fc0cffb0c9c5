"""The whole arm in closed loop: a velocity PI and the package's compensator per joint on the coupled rigid body.

:func:`compare_arm` runs every joint of a simulated arm (:class:`adaptive_ff.arm.simulate.ArmPlant`: Pinocchio's
articulated-body algorithm, a lagged Stribeck friction per joint) in its own velocity loop, each joint following its
own velocity reference, in the modes ``none``, ``fixed``, ``adaptive`` and ``frictionless``, and reports eta per
joint (:func:`controllers.experiments.comparison.eta`, second-half RMS errors against ``none`` and
``frictionless``); on request also the peers ``dob`` and ``canudas`` per joint, as ``compare`` runs them on one
joint, and a sensor with an encoder and/or a measurement delay (:class:`controllers.simulation.sensor_drive.Sensor`,
the one-joint engine's).

What each joint's loop has is what a user has from ``identify-arm --json``: the joint's entry (its identified
diagonal inertia ``J``, ``sigma``, ``Fc``, ``Fs``, ``Vs``, ``delta``), never the simulated arm's values. Its PI is
the one ``design --from ARM.json --joint NAME`` designs; its ``adaptive`` compensator is the one
``export-c --from ARM.json`` writes for the joint (:func:`controllers.experiments.compensator_file.compensator_from_file`: the
C struct ``aff_adaptive`` a drive runs, stepped here through its ops table); its ``fixed`` compensator the
identified static map (eq. 3, no lag) as
:class:`adaptive_ff.FrictionFeedforward` with the same settings; the peers' the ones ``compare``'s modes of the same
names build (:func:`controllers.simulation.compensators.build_mode`) from those settings: ``dob`` the disturbance
observer on the identified ``J`` (Q-filter cut-off ``LoopConfig.observer.omega_q``), ``canudas`` the adaptive Coulomb and
viscous compensator of Canudas de Wit et al. at the reference velocity (``compare``'s ``canudas_input``
default). The rigid-body torques of the other joints
(inertia coupling, Coriolis, gravity) are disturbances to each joint's loop: no model-based rigid-body
feedforward runs, as on a drive that has none; the PI's integral takes up gravity.

Per controller period, joint by joint, the order of the one-joint engine (:mod:`controllers.simulation.engine`):
the sensor sample (``w + noise``; with an encoder the quantised position's backward difference plus the noise,
with a delay the sample of ``delay`` periods before: C ``ctl_sensor_measure``), the sensor gate (:class:`adaptive_ff.OutlierGate`), the compensator's
``compensate`` (and its supervisor's bumpless transfer into the PI's integrator), the PI
(:class:`controllers.PIController`, saturated at the drive's limit), the compensator's ``observe``; then the arm
advances one period with every joint's torque held (:meth:`adaptive_ff.arm.simulate.ArmPlant.step`). The
coupling step is Python; every compensator, gate and PI step is the package's C.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm

from adaptive_ff.arm.simulate import ArmPlant, arm_reference
from adaptive_ff.compensation.gate import OutlierGate
from adaptive_ff.identification.regression import FrictionEstimate
from controllers._cctl import ffi, lib
from controllers.design.pi import PIController, PITuning
from controllers.experiments.comparison import eta_or_none, options_with_changes
from controllers.simulation.compensators import build_mode, own_supervisor
from controllers.simulation.loop_config import stick_band_for
from controllers.simulation.metrics import LoopMetrics, loop_metrics, reversal_times
from controllers.simulation.sensor_drive import DELAY_MAX, Sensor
from plant.errors import ParameterError, check_nonnegative, check_optional_number, check_positive

__all__ = ["ARM_MODES", "DEFAULT_MODES", "ETA_NOTE", "CompareArmOptions", "ArmComparison", "ArmRun",
           "JointLoopDesign", "compare_arm", "joint_designs"]

#: The modes of :func:`compare_arm`, in table order (``none`` and ``frictionless`` always run: eta needs them):
#: ``adaptive-ff`` is mode ``adaptive``'s feedforward alone (``export-c --feedforward-only``: no residual observer,
#: no supervisor), which shows what the adaptive friction model itself does beside the observer that also takes up
#: part of the rigid-body coupling; ``dob`` and ``canudas`` are ``compare``'s peers of those names, per joint.
ARM_MODES = ("none", "fixed", "adaptive", "adaptive-ff", "dob", "canudas", "frictionless")
#: eta above this is noted in the summary (the loop beats the frictionless arm by more than noise).
ETA_NOTE = 1.01
#: The modes run by default.
DEFAULT_MODES = ("none", "fixed", "adaptive", "frictionless")


@dataclass(frozen=True)
class CompareArmOptions:
    """Settings of :func:`compare_arm` (keyword, validated; SI units).

    Parameters
    ----------
    duration : float
        Length of each run (s), default 20; eta uses its second half.
    seed : int
        Seeds the references' phases and amplitudes and the sensor noise (the same in every mode), >= 0.
    modes : tuple of str
        A subset of :data:`ARM_MODES`; ``none`` and ``frictionless`` always run.
    crossover, phase_margin : float
        Each joint's PI targets (rad/s, deg), designed on the joint's identified ``J`` and ``sigma`` as
        ``design --from ARM.json --joint NAME`` designs it (:func:`controllers.design.pi.design_pi`).
    Tc, Ts : float
        Controller period (s) and the adaptive estimator's sample time (s, a multiple of ``Tc``).
    u_max : float, sequence of float or None
        The drives' torque limits (N·m): one for every joint or one per joint; None (default): the URDF's effort
        limits (refused where a joint has none).
    noise_std : float
        White velocity-measurement noise per joint (rad/s), default 1e-3.
    amplitude : float
        Position amplitude (rad) of each joint's multisine reference
        (:func:`adaptive_ff.arm.simulate.arm_reference`: 5 sines, 0.1-1 Hz), default 0.5.
    substeps : int
        Runge-Kutta steps of the arm per controller period, default 1.
    stop_refine : int
        Runge-Kutta steps per step in a period in which a joint of the arm with friction comes to rest or reverses
        (:meth:`adaptive_ff.arm.simulate.ArmPlant.step`, each joint's band at the start position), >= 1; 1
        (default): none, the arm stepped as the one-joint engine steps its plant;
        :data:`adaptive_ff.arm.simulate.STOP_REFINE`: as a finely stepped arm.
    reversal_window : float
        Half-width (s) of the metrics' reversal windows.
    decimate : int
        Keep every ``decimate``-th sample of the recorded signals (the metrics use every sample), default 10.
    start : bool
        Start the adaptive modes' feedforward from the identified map with its lag (``export-c --start``) on every
        joint whose entry has a ``tau`` (the others wait, as without it; ``JointLoopDesign.settings["start"]`` says
        which), default False: off until the estimator's first trusted estimate.
    encoder_counts : int or None
        Each joint's loop measures with an encoder of this many counts per joint revolution (quantised position,
        velocity by backward difference, plus ``noise_std``), as ``compare``'s ``[sensor] encoder_counts``;
        default None: a velocity sensor, ``w + noise``.
    delay : int
        Measurement delay of every joint's sensor (periods, 0 to
        :data:`controllers.simulation.sensor_drive.DELAY_MAX`), as ``compare``'s ``[sensor] delay``; default 0.
        The compensators are the exported ones either way (nothing of the sensor reaches them but its samples).

    Raises
    ------
    ParameterError
        A value out of range, an unknown mode, ``Ts`` not a multiple of ``Tc``.
    """

    duration: float = 20.0
    seed: int = 0
    modes: tuple = DEFAULT_MODES
    crossover: float = 20.0
    phase_margin: float = 60.0
    Tc: float = 1e-3
    Ts: float = 0.01
    u_max: object = None
    noise_std: float = 1e-3
    amplitude: float = 0.5
    substeps: int = 1
    stop_refine: int = 1
    reversal_window: float = 0.2
    decimate: int = 10
    start: bool = False
    encoder_counts: int | None = None
    delay: int = 0

    def __post_init__(self):
        for name in ("duration", "crossover", "phase_margin", "Tc", "Ts", "amplitude"):
            check_positive(name, getattr(self, name))
        check_nonnegative("noise_std", self.noise_std)
        check_nonnegative("reversal_window", self.reversal_window)
        for name in ("seed", "substeps", "stop_refine", "decimate"):
            v = getattr(self, name)
            low = 0 if name == "seed" else 1
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise ParameterError(f"{name} must be an integer >= {low}, got {v!r}")
        check_optional_number("encoder_counts", self.encoder_counts, integer=True, low=1,
                              unit="counts per joint revolution")
        if isinstance(self.delay, bool) or not isinstance(self.delay, (int, np.integer)) or \
                not 0 <= self.delay <= DELAY_MAX:
            raise ParameterError(f"delay must be an integer number of periods in 0..{DELAY_MAX}, got {self.delay!r}")
        ratio = self.Ts / self.Tc
        if abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ParameterError(f"Ts = {self.Ts!r} s must be a multiple of Tc = {self.Tc!r} s")
        modes = tuple(self.modes)
        unknown = [m for m in modes if m not in ARM_MODES]
        if unknown:
            raise ParameterError(f"modes: unknown mode(s) {unknown}; compare_arm runs {list(ARM_MODES)}")
        object.__setattr__(self, "modes", tuple(m for m in ARM_MODES if m in modes or m in ("none",
                                                                                            "frictionless")))

    def limits(self, arm) -> np.ndarray:
        """The drives' torque limits (N·m), shape (N,), for ``arm``: :attr:`u_max` or the URDF's effort limits.

        Raises
        ------
        ParameterError
            A limit not > 0 and finite, a list of the wrong length, or no ``u_max`` and a joint of the URDF
            without an effort limit (named).
        """
        if self.u_max is None:
            eff = np.asarray(arm.model.effortLimit, dtype=float).reshape(-1)
            bad = [arm.names[j] for j in range(arm.n) if not (math.isfinite(eff[j]) and 0.0 < eff[j] < 1e20)]
            if bad:
                raise ParameterError(f"u_max: the URDF ({arm.source}) gives no effort limit for joint(s) {bad}: "
                                     f"give the drives' torque limits")
            return eff.copy()
        u = np.atleast_1d(np.asarray(self.u_max, dtype=float)).reshape(-1)
        if u.shape[0] == 1:
            u = np.full(arm.n, u[0])
        if u.shape[0] != arm.n:
            raise ParameterError(f"u_max: {u.shape[0]} limits for the {arm.n} joints of {arm.source} (give one for "
                                 f"every joint or one per joint)")
        for j in range(arm.n):
            if not (math.isfinite(u[j]) and u[j] > 0.0):
                raise ParameterError(f"u_max of joint {j + 1} ({arm.names[j]!r}) must be a finite number > 0 (N·m), "
                                     f"got {u[j]!r}")
        return u


@dataclass(frozen=True)
class JointLoopDesign:
    """One joint's loop as :func:`joint_designs` builds it from the identification.

    Attributes
    ----------
    name : str
        The joint (the URDF's name).
    J_design : float
        The identified ``J`` (kg·m²): the design inertia of the PI, the gates and the compensators.
    Kp, Ki : float
        The PI gains (N·m·s/rad, N·m/rad).
    u_max : float
        The drive's torque limit (N·m).
    estimate : FrictionEstimate
        The identified static map the ``fixed`` mode feeds forward (no lag).
    options : LoopConfig
        The settings of the joint's compensators (``export-c``'s).
    settings : dict
        What :func:`controllers.experiments.compensator_file.compensator_from_file` is given beside the file and the joint (as
        ``export-c --u-max --Kp --Ki`` would give it): ``u_max``, ``Kp``, ``Ki``, ``Tc``, ``Ts``, ``stick_band``
        (three times the entry's velocity noise estimate ``excitation.noise_std``, as ``export-c`` sets it; three
        times :attr:`CompareArmOptions.noise_std` where the entry has none) and ``omega_r`` (the residual
        observer's cut-off, :func:`controllers.experiments.observer_design.residual_cutoff` of ``J_design``, that
        noise and the identified level ``max(Fc, Fs)``); ``start`` with :attr:`CompareArmOptions.start`.
    noise_std : float
        The velocity noise (rad/s) behind ``stick_band`` and ``omega_r``.
    noise_source : str
        ``"identification"`` (the entry's estimate) or ``"options"`` (:attr:`CompareArmOptions.noise_std`).
    notes : tuple of str
        What the joint's compensator assumed (:func:`controllers.experiments.compensator_file.compensator_from_file`'s
        ``notes``: the placeholders ``Vs``, ``delta`` of an entry without a Stribeck term).
    """

    name: str
    J_design: float
    Kp: float
    Ki: float
    u_max: float
    estimate: FrictionEstimate
    options: object
    settings: dict
    noise_std: float = math.nan
    noise_source: str = "options"
    notes: tuple = ()

    def to_dict(self) -> dict:
        """``{"name", "J_design", "Kp", "Ki", "u_max", "stick_band", "noise_source"}``."""
        return {"name": self.name, "J_design": self.J_design, "Kp": self.Kp, "Ki": self.Ki, "u_max": self.u_max,
                "stick_band": float(self.settings["stick_band"]), "noise_source": self.noise_source}


def joint_designs(identification, arm, options: CompareArmOptions) -> list:
    """Every joint's loop from its entry of an ``identify-arm --json`` file, in the URDF's order.

    Parameters
    ----------
    identification : str or os.PathLike
        The file (``adaptive-ff identify-arm ... --json``); every joint of ``arm`` must have an entry.
    arm : ArmModel
        The arm (its joint names and effort limits).
    options : CompareArmOptions

    Returns
    -------
    list of JointLoopDesign

    Raises
    ------
    ParameterError
        A joint of the URDF without an entry, an entry with a Stribeck term (``Fs != Fc``) but no ``Vs``/``delta``
        or a ``J`` not > 0 (the file and the joint named). An entry without a Stribeck term gets ``Fs = Fc`` and
        the placeholders of :func:`controllers.experiments.compensator_file.compensator_from_file` (its ``notes``).
    """
    from adaptive_ff.arm.result import read_arm_entries
    from controllers.experiments.compensator_file import compensator_from_file, read_identified
    from controllers.experiments.observer_design import residual_cutoff

    names = [e["name"] for e in read_arm_entries(identification)]
    missing = [n for n in arm.names if n not in names]
    if missing:
        raise ParameterError(f"{identification}: no entry for joint(s) {missing} of the URDF ({arm.source}; the "
                             f"file has {names}): the identification and the URDF disagree")
    u_max = options.limits(arm)
    out = []
    for j, name in enumerate(arm.names):
        _, s = compensator_from_file(identification, arm_joint=name, u_max=float(u_max[j]),
                                     pi=PITuning(crossover=options.crossover, phase_margin=options.phase_margin),
                                     Tc=options.Tc, Ts=options.Ts)
        fr = s["joint"]
        level = max(fr.get("Fc", 0.0), fr.get("Fs", 0.0))
        ident = read_identified(identification, name)
        noise, source = ident.noise_std, "identification"
        if noise is None or not (math.isfinite(noise) and noise >= 0.0):
            noise, source = options.noise_std, "options"
        settings = {"u_max": float(u_max[j]), "pi": PITuning(Kp=s["Kp"], Ki=s["Ki"]), "Tc": options.Tc,
                    "Ts": options.Ts,
                    "stick_band": stick_band_for(noise),
                    "omega_r": residual_cutoff(s["J_design"], noise, options.Tc, level),
                    "start": bool(options.start) and math.isfinite(ident.params.get("tau", math.nan))}
        o = compensator_from_file(identification, arm_joint=name, **settings)[1]["options"]
        est = FrictionEstimate(J=s["J_design"], tau=0.0, sigma=fr.get("sigma", 0.0), Fc=fr.get("Fc", 0.0),
                               Fs=fr.get("Fs", 0.0), offset=0.0, Vs=o.estimator.Vs, delta=o.estimator.delta, J_alt=math.nan)
        out.append(JointLoopDesign(name=name, J_design=float(s["J_design"]), Kp=float(s["Kp"]), Ki=float(s["Ki"]),
                                   u_max=float(u_max[j]), estimate=est, options=o, settings=settings,
                                   noise_std=float(noise), noise_source=source, notes=tuple(s["notes"])))
    return out


class _JointLoop:
    """One joint's gate, PI and compensator, stepped as the one-joint engine steps them (ctl_engine.c)."""

    def __init__(self, design: JointLoopDesign, mode: str, identification, w0: float, Tc: float):
        o = design.options
        self.pi = PIController(Kp=design.Kp, Ki=design.Ki, Tc=Tc, u_max=design.u_max)
        self.gate = OutlierGate(max_step=2.0 * design.u_max * Tc / design.J_design)
        self.held = float(w0)
        self.comp, self.ops, self.ptr = None, None, None
        if mode in ("adaptive", "adaptive-ff"):
            from controllers.experiments.compensator_file import compensator_from_file

            self.comp, _ = compensator_from_file(identification, arm_joint=design.name,
                                                 feedforward_only=mode == "adaptive-ff", **design.settings)
        elif mode == "fixed":
            _, _, self.comp = build_mode(None, "fixed", o.replace(estimate=design.estimate))
        elif mode in ("dob", "canudas"):  # compare's peers, on the joint's identified J and the same settings
            _, _, self.comp = build_mode(None, mode, o.replace(ff_input="reference") if mode == "canudas" else o)
        if self.comp is not None:
            # cffi reads a const table as a value: a copy, as the engine makes (EngineRun.set_compensator)
            self.ops = ffi.new("aff_compensator_ops *", getattr(lib, self.comp.C_OPS))
            self.ptr = ffi.cast("void *", self.comp.cdata)
            self.transfer = self.ops.transfer if self.ops.transfer != ffi.NULL else None

    def period(self, wm: float, wr: float) -> tuple:
        """``(u, u_ff)`` of one period with the sensor sample ``wm`` and the reference ``wr`` (rad/s)."""
        if lib.aff_gate_check(self.gate.cdata, wm):
            self.held = wm
        wc = self.held
        uff = 0.0
        if self.comp is not None:
            uff = self.ops.compensate(self.ptr, wc, wm, wr)
            if self.transfer is not None:
                tr = self.transfer(self.ptr)
                if tr != 0.0:
                    self.pi.cdata.I += tr
        u = lib.ctl_pi_step(self.pi.cdata, wr - wc, uff)
        if self.comp is not None:
            self.ops.observe(self.ptr, u, wm, ffi.NULL)
        return u, uff


@dataclass(frozen=True)
class ArmRun:
    """One mode's run of the arm.

    Attributes
    ----------
    mode : str
    metrics : tuple of LoopMetrics
        Per joint (:func:`controllers.simulation.metrics.loop_metrics`); NaN after a divergence.
    diverged : bool
        A joint's velocity left ``100*max|w_ref| + 1`` (or a position its URDF limits by more than 0.5 rad).
    t : ndarray, shape (n,)
        Time (s), every ``decimate``-th period.
    w, u, u_ff : ndarray, shape (n, N)
        Velocity (rad/s), torque and compensation (N·m) at those periods.
    info : dict
        Per joint the compensator's counters (``info()``), where it has any.
    """

    mode: str
    metrics: tuple
    diverged: bool
    t: np.ndarray
    w: np.ndarray
    u: np.ndarray
    u_ff: np.ndarray
    info: dict = field(default_factory=dict)


def _run_mode(plant: ArmPlant, designs, mode: str, identification, t, w_ref, noise, o: CompareArmOptions) -> ArmRun:
    """One mode on a fresh copy of ``plant`` (the frictionless twin for ``frictionless``)."""
    arm = plant.arm
    run_plant = ArmPlant(arm, None if mode == "frictionless" else plant.friction, armature=plant.armature)
    run_plant.set_state(np.zeros(arm.n), w_ref[0])
    band = run_plant.stop_band(o.Tc) if run_plant.friction is not None else None
    loops = [_JointLoop(d, mode, identification, w_ref[0, j], o.Tc) for j, d in enumerate(designs)]
    sensors = [Sensor(Tc=o.Tc, counts_per_rev=o.encoder_counts, delay=int(o.delay)) for _ in designs]
    n, N = w_ref.shape
    W, U, UFF = (np.full((n, N), math.nan) for _ in range(3))
    w_limit = 100.0 * np.max(np.abs(w_ref), axis=0) + 1.0
    lo, hi = arm.lower - 0.5, arm.upper + 0.5
    diverged = False
    for k in range(n):
        w = run_plant.dq
        W[k] = w
        for j, loop in enumerate(loops):
            U[k, j], UFF[k, j] = loop.period(sensors[j].measure(float(w[j]), float(noise[k, j])),
                                             float(w_ref[k, j]))
        run_plant.step(U[k], o.Tc, o.substeps, stop_band=band, stop_refine=o.stop_refine)
        q, dq = run_plant.q, run_plant.dq
        if not (np.all(np.abs(dq) < w_limit) and np.all(q > lo) and np.all(q < hi)):
            diverged = True
            break
    metrics = []
    for j in range(N):
        if diverged:
            nan = math.nan
            metrics.append(LoopMetrics(rms=nan, max=nan, rms_second_half=nan, max_second_half=nan,
                                       rms_reversal=nan, u_rms=nan))
            continue
        metrics.append(loop_metrics(t, w_ref[:, j], W[:, j], U[:, j], reversals=reversal_times(t, w_ref[:, j]),
                                    window=o.reversal_window))
    info = {d.name: _counters(loop.comp) for d, loop in zip(designs, loops) if loop.comp is not None}
    sl = slice(None, None, o.decimate)
    return ArmRun(mode=mode, metrics=tuple(metrics), diverged=diverged, t=t[sl], w=W[sl], u=U[sl], u_ff=UFF[sl],
                  info=info)


def _counters(comp) -> dict:
    """A compensator's counters (``info()``) with its own supervisor's (mode ``adaptive``), as the one-joint run
    reports them."""
    out = dict(comp.info()) if hasattr(comp, "info") else {}
    sup = own_supervisor(comp)
    if sup is not None:
        out.update(sup.info())
    return out


def _json_number(x):
    """A finite float, else None (strict JSON)."""
    return float(x) if x is not None and math.isfinite(x) else None


@dataclass(frozen=True)
class ArmComparison:
    """Every mode on the arm: per joint the second-half RMS error and eta.

    Attributes
    ----------
    joints : tuple of str
        The joints, in the URDF's order.
    designs : tuple of JointLoopDesign
        Each joint's loop.
    runs : dict of str -> ArmRun
        Per mode.
    eta : dict of str -> dict of str -> float or None
        ``eta[mode][joint]`` (:func:`controllers.experiments.comparison.eta_or_none` of the second-half RMS errors
        of ``none``, the mode and ``frictionless``); None where undefined.
    t_ref, w_ref : ndarray
        The references (every ``decimate``-th period), shape (n,) and (n, N).
    options : CompareArmOptions
    source : str
        The URDF and the identification (for the summary).
    """

    joints: tuple
    designs: tuple
    runs: dict
    eta: dict
    t_ref: np.ndarray
    w_ref: np.ndarray
    options: CompareArmOptions
    source: str = ""

    def rms(self, mode: str) -> dict:
        """``{joint: second-half RMS error (rad/s)}`` of ``mode``."""
        return {n: m.rms_second_half for n, m in zip(self.joints, self.runs[mode].metrics)}

    def to_dict(self) -> dict:
        """Strict JSON: ``{"joints", "modes", "eta": {mode: {joint: x}}, "rms_second_half": {mode: {joint: rad/s}},
        "max_second_half", "u_rms", "diverged": {mode: bool}, "pi": [{"name", "J_design", "Kp", "Ki", "u_max"}],
        "info": {"duration", "seed", "Tc", "Ts", "noise_std", "start", "encoder_counts", "delay", "amplitude",
        "crossover", "phase_margin"}}`` (NaN as null)."""
        o = self.options
        per = {k: {mode: {n: _json_number(getattr(m, k)) for n, m in zip(self.joints, r.metrics)}
                   for mode, r in self.runs.items()} for k in ("rms_second_half", "max_second_half", "u_rms")}
        return {"joints": list(self.joints), "modes": list(self.runs),
                "eta": {mode: {n: _json_number(v) for n, v in e.items()} for mode, e in self.eta.items()},
                **per, "diverged": {mode: bool(r.diverged) for mode, r in self.runs.items()},
                "pi": [d.to_dict() for d in self.designs],
                "info": {"duration": o.duration, "seed": int(o.seed), "Tc": o.Tc, "Ts": o.Ts, "noise_std": o.noise_std,
                         "start": bool(o.start), "encoder_counts": o.encoder_counts, "delay": int(o.delay),
                         "amplitude": o.amplitude, "crossover": o.crossover, "phase_margin": o.phase_margin}}

    def summary(self) -> str:
        """A table per joint: the second-half RMS error (deg/s) of every mode, then eta of the compensating
        modes."""
        modes = list(self.runs)
        comp = [m for m in modes if m not in ("none", "frictionless")]
        width = max(8, max(len(n) for n in self.joints) + 1)
        cells = [max(13, len(m) + 6) for m in modes]
        etas = [max(11, len(m) + 6) for m in comp]
        head = f"{'joint':<{width}}" + "".join(f"{m + ' RMS':>{c}}" for m, c in zip(modes, cells)) + "".join(
            f"{'eta ' + m:>{c}}" for m, c in zip(comp, etas))
        lines = [f"second-half RMS velocity error [deg/s] per joint, {self.options.duration:g} s, seed "
                 f"{self.options.seed}", head, "-" * len(head)]
        for j, n in enumerate(self.joints):
            row = f"{n:<{width}}" + "".join(
                f"{math.degrees(self.runs[m].metrics[j].rms_second_half):>{c}.4f}" for m, c in zip(modes, cells))
            row += "".join(f"{_eta_text(self.eta[m][n]):>{c}}" for m, c in zip(comp, etas))
            lines.append(row)
        lines += self.notes()
        return "\n".join(lines)

    def notes(self) -> list:
        """The notes of :meth:`summary`: a joint's compensator's assumptions (the placeholders of a joint without a
        Stribeck term), undefined eta, eta above 1, a diverged run."""
        out = [f"note: {n}" for d in self.designs for n in d.notes]
        undefined = [n for n in self.joints if self.eta["none"][n] is None]
        if undefined:
            out.append(f"note: eta is undefined (-) on {', '.join(undefined)}: friction does not raise the joint's "
                       "error there (none tracks at least as well as the frictionless arm, whose error is the "
                       "coupling's)")
        for m in self.runs:
            above = [n for n in self.joints if (self.eta[m][n] or 0.0) > ETA_NOTE]
            if above and m not in ("none", "frictionless"):
                out.append(f"note: {m}: eta above {ETA_NOTE:g} on {', '.join(above)}: the joint tracks better than "
                           "on the frictionless arm, whose error is the rigid-body coupling's; an observer (the "
                           "residual observer of adaptive) or a map at the measured velocity is feedback too and "
                           "takes up part of that coupling")
            if self.runs[m].diverged:
                out.append(f"note: {m}: the arm diverged (a velocity beyond 100 times its reference's peak, or a "
                           "position 0.5 rad beyond its URDF limits); its metrics are NaN")
        return out

    def plot(self, ax=None):
        """eta per joint and compensating mode as grouped bars (matplotlib); returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        comp = [m for m in self.runs if m not in ("none", "frictionless")]
        x = np.arange(len(self.joints))
        width = 0.8 / max(len(comp), 1)
        for i, m in enumerate(comp):
            vals = [np.nan if self.eta[m][n] is None else self.eta[m][n] for n in self.joints]
            ax.bar(x + (i - (len(comp) - 1) / 2) * width, vals, width, label=m)
        ax.axhline(1.0, color="0.5", lw=0.8, ls="--")
        ax.set_xticks(x)
        ax.set_xticklabels(self.joints)
        ax.set_ylabel("eta [-]")
        ax.set_title("compensation efficiency per joint (second half)")
        ax.legend()
        return ax


def _eta_text(e) -> str:
    return "-" if e is None else f"{e:.3f}"


def compare_arm(plant: ArmPlant, identification, options: CompareArmOptions | None = None, *,
                progress: bool | None = False, **changes) -> ArmComparison:
    """Run the arm's joints in their velocity loops in every mode of ``options`` and compare tracking per joint.

    Parameters
    ----------
    plant : ArmPlant
        The true arm (:class:`adaptive_ff.arm.simulate.ArmPlant`: rigid body, armatures, friction per joint);
        copied for every mode, itself not stepped. Nothing of it reaches a design or a compensator.
    identification : str or os.PathLike
        The arm's ``identify-arm --json`` file: every joint's design inertia, PI and compensators come from its
        entry (:func:`joint_designs`).
    options : CompareArmOptions, optional
        Settings; default ``CompareArmOptions()``.
    progress : bool or None, keyword-only
        A progress bar over the modes on stderr (tqdm): True, False (default), None (only on a terminal).
    **changes
        Fields of :class:`CompareArmOptions` to change.

    Returns
    -------
    ArmComparison

    Raises
    ------
    ParameterError
        Bad settings, a plant without friction, an identification that does not fit the URDF (named).
    FileNotFoundError
        No such identification file.

    Notes
    -----
    The references: :func:`adaptive_ff.arm.simulate.arm_reference` of ``seed`` (each joint its own multisine
    velocity); the noise: ``normal(0, noise_std)`` per joint and period from ``default_rng([seed, 1])``, the same in
    every mode. The arm starts at ``q = 0`` moving at the references' first velocities, each lagged friction
    at its steady value (as the one-joint engine starts a joint, :func:`plant.dynamics.plant_state`).
    """
    o = options_with_changes(options if options is not None else CompareArmOptions(), changes, where="compare_arm")
    if not isinstance(plant, ArmPlant) or plant.friction is None:
        raise ParameterError("plant must be an ArmPlant with a friction per joint (adaptive_ff.arm.simulate)")
    arm = plant.arm
    designs = joint_designs(identification, arm, o)
    t, w_ref = arm_reference(arm.n, o.duration, o.Tc, np.random.default_rng(o.seed), o.amplitude)
    noise = np.random.default_rng([o.seed, 1]).normal(0.0, o.noise_std, size=w_ref.shape) if o.noise_std > 0 \
        else np.zeros_like(w_ref)
    runs = {}
    bar = tqdm(total=len(o.modes), desc="compare-arm", unit="mode", disable=None if progress is None else not progress,
               leave=False)
    for m in o.modes:
        bar.set_postfix_str(m)
        runs[m] = _run_mode(plant, designs, m, identification, t, w_ref, noise, o)
        bar.update()
    bar.close()
    rn, rf = (np.array([x.rms_second_half for x in runs[m].metrics]) for m in ("none", "frictionless"))
    eta = {m: {n: eta_or_none(rn[j], r.metrics[j].rms_second_half, rf[j]) for j, n in enumerate(arm.names)}
           for m, r in runs.items()}
    sl = slice(None, None, o.decimate)
    return ArmComparison(joints=tuple(arm.names), designs=tuple(designs), runs=runs, eta=eta, t_ref=t[sl],
                         w_ref=w_ref[sl], options=o, source=f"{arm.source}, {identification}")
