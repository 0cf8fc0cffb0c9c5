r"""Each joint's friction lag ``tau`` (eq. 1) and velocity noise, from the whole-arm log once the rigid body is known.

Joint ``j``'s row of the arm's dynamics, ``M(q) ddq + c(q, dq) + g(q) = u - f``, is a one-joint model of eqs. 1-3
once everything but the joint's own constant inertia is moved to the input:

.. math::

    J_j \dot w_j + f_j = u_j - \big(Y_b(q, \dot q, \ddot q)_j \beta - J_j \ddot q_j\big),
    \qquad \tau_j \dot f_j + f_j = F_j(w_j),

``J_j`` the joint's ``M_jj`` at the log's mean configuration, ``Y_b \beta`` the identified rigid body (or the
URDF's with ``rigid_body="urdf"``). That *rigid-body-removed* torque and the joint's velocity go through the
package's output-error fit of eqs. 1-3 (:func:`adaptive_ff.identification.physical_id.fit_physical`, the fit of
``identify --method output_error``), of which the lag and its 95 % bootstrap interval are kept; ``J, Fc, Fs, sigma,
offset`` stay the whole-arm fit's (every joint's rows in one fit). The Stribeck shape ``Vs``, ``delta`` is held at
the whole-arm fit's, and where that fit drops the term (``Fs = Fc``), at its profile's best grid point (the
output-error fit then fits ``Fs``); the bootstrap's refits hold the shapes the whole-arm profile accepts ("Reported"):
on the TX40 log of ``docs/benchmarks/arm_tx40.md``, whose joints keep no
Stribeck term, letting the output-error fit search ``Vs`` and ``delta`` itself cost 3 to 5 times the CPU time and
moved no reported lag by more than 8 %. The joints' fits are independent and run in worker processes
(:class:`LagOptions`, :func:`joint_lags`).

The record's positions, velocities, accelerations and torques come from a zero-phase low-pass (4th-order
Butterworth, forwards and backwards: no lag of its own) at :data:`LAG_CUTOFF_FACTOR` times the identification's
cutoff, at most a fifth of the record's rate, sampled at about :data:`LAG_RATE` Hz (every k-th sample of the log),
the filter's start-up at both ends left out. Why that cutoff: a friction jump at a reversal accelerates every joint
at once, and the coupling torque ``M_jk ddq_k`` of that step is what the output-error fit must not read as the
joint's own lag; and velocity noise, which the fit reads as lag, is what the filter removes.

Predictor
---------
The record's velocity noise, low-passed with it, lies below the threshold at which ``predictor="auto"`` takes the
free-run predictor, so the fit runs the one-step predictor. Its velocity after each sample moves
:data:`LAG_INJECTION_GAIN` of the way to the measured one (``injection_gain`` of
:class:`adaptive_ff.identification.oe_options.OutputErrorOptions`), not all of it: a reset to the measurement carries
the noise into the friction map's argument, where it flips the map's sign near each reversal (errors in variables),
and a longer lag averages those flips, so the fit reads the noise as lag, most on light joints (elbows, wrists),
lagged or not. With the smaller share the predictor follows its own simulated velocity between samples and the
measurement still keeps it from drifting off; a much smaller share brings it near the free-run predictor, whose
cost is rough at breakaway, and reads long lags short. The measurements behind the share: ``docs/your_arm.md``
(How, Lag).

Stops
-----
Each joint's lagged friction, which jumps with ``sgn(w)``, drives it through zero velocity at each stop in a damped
ringing of a few milliseconds per period on a light joint (elbows, wrists). The output-error simulation with one RK4
step per sample of the 1 kHz record keeps that ringing up and the fit reads the lag that mimics its own coarse step:
several times the true lag on the heavy wrists of ``benchmarks/arm_stops.py``. With ``LagOptions(refine_stops=True)``
the fit simulates the sample intervals in which the record's velocity is inside a band around zero, or reverses,
with sub-steps of a tenth of the sample time (``stop_band`` of the output-error fit,
:func:`adaptive_ff.identification.simulator.stop_intervals`); the band is :data:`LAG_STOP_BAND` times ``Fs Ts / J``,
the velocity the joint's static friction takes off in one sample, with ``Fs`` and ``J`` from the whole-arm fit
(:func:`stop_bands`). The low-pass correction's worlds are then simulated at that sub-step throughout. On arms
stepped finely it reads the lags of joints whose friction is large for their inertia right and those of joints with
light friction short, where the coarse step reads them right (the one-step predictor's pull toward the low-passed
velocity on a model that settles at its stops). So by default (``LagOptions(refine_stops="auto")``) the stops are
refined on the joints that stick: those whose Coulomb friction takes off at least :data:`LAG_REFINE_STICK` of their
velocity in one sample of the record (``Fc Ts / J``, :func:`stick_speeds`) and less than the stick rule's
:data:`LAG_STICK_MAX` (:func:`refined_joints`); the others are simulated at the record's step, and the lags of the
joints that stick harder are not reported ("Reported"): refining their stops reports them, at two to four times
their fits' CPU time on a log with long rests. ``refine_stops=True`` (``identify-arm --refine-stops``) refines every
joint's stops, False (``--coarse-stops``) none. The measurements behind the bounds: ``docs/your_arm.md`` (How,
Lag; Not yet) and ``benchmarks/arm_lag.py``, ``benchmarks/arm_coverage.py`` (their ``--refine-stops`` and
``--coarse-stops``).

The torque is taken at its time stamp (``input_delay=0``): a whole-arm log samples every joint's torque and
position together, and the output-error fit's profile over a sub-sample input delay, which ``identify`` runs on a
one-joint log, trades the delay against the lag here.

Reported
--------
A lag is reported where the log determines it (:func:`lag_reason`): the fit runs; its 95 % interval is finite and
excludes zero; the bootstrap's refits, whose world is the fitted lagged joint, do not read it longer by more than
:data:`LAG_SHIFT_MAX` (7.5 %) of it on average; and the interval stays above :data:`LAG_FLOOR_SAMPLES` (2) samples
of the record; and, where the stops are not refined, the joint does not stick hard: its Coulomb friction takes off
less than :data:`LAG_STICK_MAX` of its velocity in one sample of the record (``Fc Ts / J``, with ``Fc`` and ``J``
from the whole-arm fit, :func:`stick_speeds`). A joint that sticks harder stops within a sample or two, the
fit at the record's step reads the lag that mimics that step's ringing at the stops ("Stops"), long, and the bootstrap
does not see it (the measurements: ``docs/your_arm.md``, How, Lag). Elsewhere ``tau`` is NaN (null in JSON) and the
joint carries a warning that says why. Why more than the interval: a joint without a lag still reads a short one. Its
friction jumps at each reversal, which the zero-phase low-pass of the record smooths over a few ms, and it sticks
there, which eqs. 1-3 do not model; the fit reads both as a lag of about a sample, with an interval that excludes
zero, which the floor sets apart. The bootstrap's mean shift is a second guard: where the estimate is not a stable
point of the fit, its refits read the lag markedly longer; on a lagged joint they do not.

The bootstrap's worlds carry the identified rigid body's error: world ``i`` is driven by the record's torque less
the difference of the ``i``-th whole-arm bootstrap replicate's removed torque from the fit's (:func:`lag_records`'
``e``, :class:`LagWorld`; ``bootstrap_input_errors`` of the output-error fit), refitted with the record's torque.
And its refits carry the Stribeck shape's: the world is the fitted joint at the shape the fit holds, and each refit
holds a shape drawn from those the whole-arm profile accepts (its rows with the term within the 95 %
likelihood-ratio bound of the friction intervals, weighted by their likelihood, ``exp(-chi2 / 2)``;
:func:`adaptive_ff.arm.fit.identify_arm`; ``bootstrap_shapes`` of the output-error fit), as the fit itself holds
one the data determine only that far: the refits read the lag the held shape's error moves.
A reported lag is then corrected for the record's low-pass by indirect inference (:func:`_lowpass_correction`): the
fitted joint, its lag at the estimate and at the estimate's one-step correction, is driven by the record's torque,
that torque and its velocity put through the record's low-pass (as the record's torque and velocity went through it)
and fitted as the record is; the reported lag is the one that reads as the estimate on the secant through those two
readings. Its interval is centred there, ``± t rms / slope``: ``rms`` the bootstrap refits' root-mean-square
deviation from the estimate (their mean shift included), ``t`` the Student-t quantile of the valid refits
(:func:`adaptive_ff.identification.covariance.bootstrap_t_quantile`) and the secant's slope mapping the reading's
spread to the lag's, held within [:data:`LAG_SLOPE_MIN`, 1] (above 1 it would narrow the interval; far below 1 it is
the two world fits' own scatter, not the reading's sensitivity, and dividing by it would throw the correction out);
the correction, not the refits' mean shift (by which the fit's own interval is centred), stands for the bias. Where
that leaves no positive lag, or an interval that reaches below the floor (:func:`correction_reason`), ``tau`` is
NaN: a lag-free joint that sticks at its stops reads, from a fit at the record's step, a lag of a few samples whose
fit interval can stay above the floor where the corrected one does not. A fit with refined stops does not read those
as a lag, and its refits scatter more, so that its corrected intervals reach below the floor on lags read right:
there the corrected interval must exclude zero. Neither
carries an error common to the record and every refit: on a heavy joint, whose interval is narrow, the held
Stribeck shape and the identified rigid body can move the lag by more than its interval. The measurements behind the
rule, the correction and their limits: ``docs/your_arm.md`` (How, Lag; Not yet) and ``benchmarks/arm_lag.py``.

The velocity noise of each joint (``excitation.noise_std`` of ``identify --json``) is
:func:`adaptive_ff.identification.diagnostics.velocity_noise_std` of the log's velocity as measured (or of the
positions' central difference where the log has no velocities).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from plant.errors import ExcitationError, ParameterError, SignalError

__all__ = ["JointLag", "LagOptions", "LagWorld", "LAG_RATE", "LAG_CUTOFF_FACTOR", "LAG_BOOTSTRAP", "LAG_WORKERS",
           "LAG_FLOOR_SAMPLES", "LAG_SHIFT_MAX", "LAG_SLOPE_MIN", "LAG_INJECTION_GAIN", "LAG_STOP_BAND",
           "LAG_STICK_MAX", "lag_records", "joint_lag", "joint_lags", "lag_reason", "correction_reason",
           "LAG_REFINE_STICK", "corrected_interval", "lag_decision", "lag_floor", "refined_joints",
           "stick_speeds", "stop_bands", "velocity_noise"]

#: Rate (Hz) at which the output-error record samples the log (every k-th sample; a slower log is taken as is).
LAG_RATE = 1000.0
#: Cutoff of the states of the removed rigid-body torque, as a multiple of the identification's cutoff.
LAG_CUTOFF_FACTOR = 5.0
#: Output-injection gain of the output-error fit's one-step predictor on the velocity (``injection_gain`` of
#: :class:`adaptive_ff.identification.oe_options.OutputErrorOptions`; module docstring, "Predictor").
LAG_INJECTION_GAIN = 0.3
#: Default bootstrap refits of the output-error fit behind the lag's interval.
LAG_BOOTSTRAP = 10
#: A lag whose interval reaches below this many samples of the output-error record is not reported (s per sample:
#: 1 / the record's rate): joints without a lag read about one sample (module docstring, "Reported").
LAG_FLOOR_SAMPLES = 2.0
#: A lag whose bootstrap refits read more than this share of it longer on average is not reported (module
#: docstring, "Reported").
LAG_SHIFT_MAX = 0.075
#: Least slope of the low-pass correction's secant (its readings per s of the worlds' lag; module docstring,
#: "Reported"): a flatter secant is taken at this slope.
LAG_SLOPE_MIN = 0.5
#: Half-width of the band around zero velocity inside which the lag fit's output-error simulation takes sub-steps of
#: a tenth of the record's sample time, as a multiple of ``Fs Ts / J`` (the velocity the joint's static friction takes
#: off in one sample; ``stop_band`` of the output-error fit; module docstring, "Stops").
LAG_STOP_BAND = 2.0
#: A joint whose Coulomb friction takes off this much of its velocity (rad/s) or more in one sample of the record
#: (``Fc Ts / J``, :func:`stick_speeds`) has no lag reported unless its stops are refined (module docstring,
#: "Reported").
LAG_STICK_MAX = 0.015
#: With ``LagOptions(refine_stops="auto")`` (the default) the stops of a joint whose Coulomb friction takes off this
#: much of its velocity (rad/s) or more in one sample of the record, and less than :data:`LAG_STICK_MAX`, are refined
#: (:func:`refined_joints`; module docstring, "Stops").
LAG_REFINE_STICK = 0.006
#: Default worker processes the joints' lag fits run in (the fits are independent; the result does not depend on it).
LAG_WORKERS = 2


@dataclass(frozen=True)
class LagOptions:
    """How :func:`adaptive_ff.arm.fit.identify_arm` fits each joint's friction lag (validated on construction).

    Attributes
    ----------
    n_bootstrap : int
        Refits of each joint's output-error bootstrap (``bootstrap_refit="partial"``), >= 2; default
        :data:`LAG_BOOTSTRAP` (``identify-arm --lag-bootstrap``).
    workers : int
        Processes the joints' fits run in, >= 1; default :data:`LAG_WORKERS` (``identify-arm --workers``). 1: one
        after the other in this process. Each joint's fit has its own seed, so the result does not depend on it.
    refine_stops : bool or "auto"
        Which joints' stops their output-error fits simulate finely: the sample intervals in which the joint's
        velocity is inside its band (:func:`stop_bands`) or reverses at a tenth of the sample time (module
        docstring, "Stops"). ``"auto"`` (default): the joints that stick (their stick speed, :func:`stick_speeds`,
        in [:data:`LAG_REFINE_STICK`, :data:`LAG_STICK_MAX`)); True: every joint (``identify-arm --refine-stops``);
        False: none (``identify-arm --coarse-stops``). :func:`refined_joints`.

    Raises
    ------
    ParameterError
        ``n_bootstrap`` not an integer >= 2, ``workers`` not an integer >= 1 or ``refine_stops`` not True, False or
        ``"auto"`` (the field named).
    """

    n_bootstrap: int = LAG_BOOTSTRAP
    workers: int = LAG_WORKERS
    refine_stops: bool | str = "auto"

    def __post_init__(self):
        for name, least in (("n_bootstrap", 2), ("workers", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < least:
                raise ParameterError(f"LagOptions.{name} must be an integer >= {least}, got {v!r}")
        if not (isinstance(self.refine_stops, bool) or (isinstance(self.refine_stops, str)
                                                         and self.refine_stops == "auto")):
            raise ParameterError(f"LagOptions.refine_stops must be True, False or 'auto', got {self.refine_stops!r}")


@dataclass(frozen=True)
class JointLag:
    """One joint's lag from its rigid-body-removed record.

    Attributes
    ----------
    tau : float
        The friction lag (s); NaN where the log does not determine it.
    interval95 : tuple of float
        Its 95 % interval (s), ``(nan, nan)`` where none.
    reason : str or None
        Why ``tau`` is NaN (None where it is reported).
    info : dict
        ``samples``, ``rate`` (Hz), ``n_simulations``, ``predictor``, ``estimate`` (the fit's ``tau`` even where it
        is not reported), ``Vs`` and ``delta`` (the Stribeck shape held in the fit; NaN where it fitted them),
        ``stop_band`` (rad/s, the band its stops were refined in, :class:`LagWorld`; None: not refined),
        ``interval95`` (s, the fit's even where it is not reported), ``n_valid``, ``bias`` and ``rms`` (the
        bootstrap's valid refits and their mean shift and RMS deviation of ``tau`` from the estimate, s).
    """

    tau: float
    interval95: tuple
    reason: str | None = None
    info: dict | None = None


def _filtered_full(log, cutoff: float, step: int) -> tuple:
    """``(sel, q, dq, ddq)`` of ``log`` at every ``step``-th sample, low-passed (zero phase) at ``cutoff`` Hz."""
    from scipy.signal import butter, filtfilt

    Ts = float(np.median(np.diff(log.t)))
    cutoff = min(cutoff, 0.2 / (Ts * step))  # at most a fifth of the record's rate
    b, a = butter(4, cutoff / (0.5 / Ts))
    q = filtfilt(b, a, log.q, axis=0)
    dq = filtfilt(b, a, log.dq, axis=0) if log.dq is not None else np.gradient(q, Ts, axis=0)
    ddq = np.gradient(dq, Ts, axis=0)
    tau = filtfilt(b, a, log.tau, axis=0)
    edge = min(int(round(1.0 / (cutoff * Ts))), log.t.shape[0] // 10)
    sel = np.arange(edge, log.t.shape[0] - edge, step)
    return sel, q[sel], dq[sel], ddq[sel], tau[sel]


def lag_records(log, arm, rigid, J, cutoff: float, *, replicates=None) -> tuple:
    """Every joint's output-error record: the rigid-body-removed torque and the measured velocity (module docstring).

    Parameters
    ----------
    log : ArmLog
        The log (joint side, SI).
    arm : ArmModel
        The arm (its joint-torque regressor).
    rigid : callable
        ``rigid(Y)`` with ``Y`` the regressor (n, N, 11 N) of :meth:`adaptive_ff.arm.robot.ArmModel.regressor`:
        the identified rigid-body torque (n, N).
    J : array_like, shape (N,)
        Each joint's ``M_jj`` at the log's mean configuration (kg·m²).
    cutoff : float
        The identification's cutoff (Hz); the states here are filtered at :data:`LAG_CUTOFF_FACTOR` times it.
    replicates : sequence of (callable, array_like) or None, keyword-only
        The whole-arm bootstrap's replicates as ``(rigid_k, J_k)``, each like ``rigid`` and ``J``; None (default):
        none.

    Returns
    -------
    t : ndarray, shape (n,)
    u, w : ndarray, shape (n, N)
        Removed torque (N·m) and velocity (rad/s) per joint, both from the zero-phase low-pass.
    e : ndarray, shape (k, n, N)
        Only with ``replicates``: each replicate's removed torque less ``u`` (N·m), the draws of ``u``'s error from
        the identified rigid body that each joint's lag bootstrap carries (module docstring, "Reported").
    """
    Ts = float(np.median(np.diff(log.t)))
    step = max(1, int(round(1.0 / (LAG_RATE * Ts))))
    sel, q, dq, ddq, tau = _filtered_full(log, LAG_CUTOFF_FACTOR * cutoff, step)
    Y = arm.regressor(q, dq, ddq)
    other = rigid(Y) - ddq * np.asarray(J, dtype=float)
    if replicates is None:
        return log.t[sel], tau - other, dq
    e = np.array([other - (rigid_k(Y) - ddq * np.asarray(J_k, dtype=float)) for rigid_k, J_k in replicates])
    return log.t[sel], tau - other, dq, e


def velocity_noise(log) -> np.ndarray:
    """Each joint's white velocity-noise estimate (rad/s), shape (N,): module docstring."""
    from adaptive_ff.identification.diagnostics import velocity_noise_std

    if log.dq is not None:
        w = log.dq
    else:
        w = np.gradient(log.q, float(np.median(np.diff(log.t))), axis=0)
    return np.array([velocity_noise_std(w[:, j]) for j in range(w.shape[1])])


@dataclass(frozen=True)
class LagWorld:
    """What a joint's lag fit takes from beyond its record (:func:`joint_lag`; module docstring, "Reported").

    Attributes
    ----------
    input_errors : ndarray, shape (k, n), or None
        Draws of the removed torque's error from the identified rigid body (:func:`lag_records`' ``e`` of the
        joint): bootstrap world ``i`` is driven by the record's torque less row ``i mod k``
        (``bootstrap_input_errors`` of the output-error fit). None: the torque taken as exact.
    lowpass : float or None
        Cutoff (Hz) of the record's zero-phase low-pass (:func:`lag_records`; at most a fifth of the record's
        rate), through which a reported lag is corrected (:func:`joint_lag`). None: not corrected.
    shapes : ndarray, shape (k, 2), or None
        Stribeck shapes ``(Vs, delta)`` (rad/s, -) the whole-arm data accept: each bootstrap refit holds one of
        them, drawn by its own generator (``bootstrap_shapes`` of the output-error fit), its world the fitted
        joint at the shape the fit holds. None: every refit holds the fit's shape.
    stop_band : float or None
        Half-width (rad/s) of the band around zero velocity in which the output-error simulation takes sub-steps of
        a tenth of the record's sample time (:func:`stop_bands`; module docstring, "Stops"). None: none.
    stick : float or None
        The velocity (rad/s) the joint's Coulomb friction takes off in one sample of the record (:func:`stick_speeds`),
        checked against :data:`LAG_STICK_MAX` where the stops are not refined (:func:`lag_reason`). None: not
        checked.
    """

    input_errors: np.ndarray | None = None
    lowpass: float | None = None
    shapes: np.ndarray | None = None
    stop_band: float | None = None
    stick: float | None = None


def joint_lag(t, u, w, Vs: float, delta: float, *, n_bootstrap: int = LAG_BOOTSTRAP, seed: int = 0,
              world: LagWorld = LagWorld()) -> JointLag:
    """One joint's lag by the package's output-error fit on its rigid-body-removed record (module docstring).

    Parameters
    ----------
    t, u, w : ndarray, shape (n,)
        Time (s), removed torque (N·m), velocity (rad/s): one joint of :func:`lag_records`.
    Vs, delta : float
        The joint's Stribeck velocity (rad/s) and shape factor from the whole-arm fit; NaN (no Stribeck term kept):
        the output-error fit fits them too.
    n_bootstrap : int, keyword-only
        Refits of the fit's bootstrap (``bootstrap_refit="partial"``), >= 2.
    seed : int, keyword-only
        The bootstrap's seed.
    world : LagWorld, keyword-only
        The rigid body's error draws for the bootstrap and the record's low-pass for the correction; default none
        of either.

    Returns
    -------
    JointLag
        ``tau`` NaN with ``reason`` where the fit fails or :func:`lag_reason` gives one, or where the low-pass
        correction leaves no lag or an interval reaching below :data:`LAG_FLOOR_SAMPLES` samples of the record
        (module docstring, "Reported"); where ``world.lowpass`` is given a reported ``tau`` is corrected for the
        low-pass and its interval is ``tau ± t rms / slope`` (``info["lowpass"]``:
        :func:`_lowpass_correction`'s numbers, None where its worlds fail and the fit's own are reported).
    """
    from adaptive_ff.identification.physical_id import fit_physical

    stribeck = math.isfinite(Vs) and math.isfinite(delta)
    try:
        fit = fit_physical(t, u, w, Vs=Vs if stribeck else None, delta=delta if stribeck else None,
                           n_bootstrap=int(n_bootstrap), bootstrap_refit="partial", bootstrap_seed=int(seed),
                           bootstrap_workers=1, input_delay=0.0, injection_gain=LAG_INJECTION_GAIN,
                           bootstrap_input_errors=world.input_errors,
                           bootstrap_shapes=world.shapes if stribeck else None, stop_band=world.stop_band,
                           h_refine=_h_refine(t))
    except (ExcitationError, SignalError, ParameterError) as err:
        return JointLag(math.nan, (math.nan, math.nan), f"the output-error fit on its rigid-body-removed record "
                        f"failed ({err})", {"samples": int(t.shape[0])})
    est = float(fit.params["tau"])
    lo, hi = (fit.info.get("interval95") or {}).get("tau", (math.nan, math.nan))
    info = {"samples": int(t.shape[0]), "rate": float(1.0 / np.median(np.diff(t))),
            "n_simulations": int(fit.info.get("n_simulations", 0)), "predictor": fit.info.get("predictor"),
            "estimate": est, "Vs": float(Vs), "delta": float(delta), "stop_band": world.stop_band,
            "stick": world.stick, **_fit_stats(fit)}
    if world.lowpass is not None and lag_reason(est, (lo, hi), info) is None:  # the correction only where it counts
        info["lowpass"] = _lowpass_correction(t, u, w, fit, min(float(world.lowpass), 0.2 * info["rate"]))
    return JointLag(*lag_decision(info), info)


def lag_decision(info: dict) -> tuple:
    """``(tau, (lo, hi), reason)`` that a lag fit's ``info`` (:attr:`JointLag.info`: ``estimate``, ``interval95``,
    the numbers :func:`lag_reason` and :func:`correction_reason` read, ``lowpass`` where the fit was corrected)
    reports (s): NaN with the reason where :func:`lag_reason` or :func:`correction_reason` gives one, else the
    low-pass-corrected lag and interval (:func:`corrected_interval`) where the fit was corrected, the fit's estimate
    and interval where not, and reason None (module docstring, "Reported"). A fit without an estimate (it failed):
    NaN, with no reason of its own."""
    nan = (math.nan, (math.nan, math.nan))
    if "estimate" not in info:
        return (*nan, None)
    est, (lo, hi) = float(info["estimate"]), info["interval95"]
    reason = lag_reason(est, (lo, hi), info) or correction_reason(info)
    if reason is not None:
        return (*nan, reason)
    if info.get("lowpass") is not None:
        est, lo, hi = corrected_interval(info)
    return est, (float(lo), float(hi)), None


def _lowpass_correction(t, u, w, fit, lowpass: float) -> dict | None:
    """The lag the fit reads as its estimate once the record's low-pass is counted (indirect inference): ``{"tau",
    "slope", "worlds", "reads"}`` (s, -, s, s), or None where a world cannot be simulated or fitted.

    World ``k``: the fitted joint with lag ``worlds[k]`` (the estimate, then its one-step correction) driven by the
    record's input, that input and its velocity through the record's zero-phase low-pass (``lowpass`` Hz, 4th order;
    the record's torque passed it as its velocity did), fitted as the record is (from the fit's values, its
    predictor and robust scale, without the profile over tau): it reads ``reads[k]``. The worlds hold the fit's
    Stribeck shape: the one it held, or where it searched the shape (``Vs``, ``delta`` not given), the one it found.
    ``tau`` solves ``reads(tau) = estimate`` on their secant, whose slope (held within [:data:`LAG_SLOPE_MIN`, 1]; 1
    where it is not positive) maps the interval."""
    from scipy.signal import butter, filtfilt

    from adaptive_ff.identification.physical_id import fit_physical
    from adaptive_ff.identification.simulator import simulate_sampled
    from plant.friction import JointParams

    p = fit.params
    shape = fit.info["fixed"] or p  # the Stribeck shape the fit held, or (no shape given) the one it found
    Vs, delta = float(shape["Vs"]), float(shape["delta"])
    b, a = butter(4, min(2.0 * lowpass * float(np.median(np.diff(t))), 0.8))
    start = {k: float(p[k]) for k in ("J", "Fc", "Fs", "sigma", "offset")}
    u_world = filtfilt(b, a, u)

    def reads(tau):
        jp = JointParams(J=p["J"], Fc=p["Fc"], Fs=p["Fs"], Vs=Vs, delta=delta, sigma=p["sigma"], tau=tau)
        sim = simulate_sampled(jp, t, u, w0=float(w[0]), f0=float(u[0]), offset=float(p["offset"]), h_max=h_world)
        world = fit_physical(t, u_world, filtfilt(b, a, sim), Vs=Vs, delta=delta, n_bootstrap=0, input_delay=0.0,
                             start=dict(start, tau=tau), lag_profile=False, predictor=fit.info["predictor"],
                             injection_gain=LAG_INJECTION_GAIN, f_scale=fit.info["f_scale"],
                             stop_band=fit.info["stop_band"], h_refine=_h_refine(t))
        return float(world.params["tau"])

    est = float(p["tau"])
    # the worlds at the fit's finest step throughout where it refines its stops (a continuous joint), else as it
    h_world = _h_refine(t) if fit.info["stop_band"] is not None else float(fit.info["h_max"])
    try:
        b1 = reads(est)
        tau1 = max(est - (b1 - est), 0.5 * est)
        b2 = reads(tau1)
    except (ExcitationError, SignalError, ParameterError):  # e.g. a fit whose Fs < 0 makes no world
        return None
    slope = (b1 - b2) / (est - tau1) if est != tau1 else math.nan
    slope = min(max(slope, LAG_SLOPE_MIN), 1.0) if math.isfinite(slope) and slope > 0.0 else 1.0
    return {"tau": tau1 + (est - b2) / slope, "slope": slope, "worlds": [est, tau1], "reads": [b1, b2]}


def corrected_interval(info: dict) -> tuple:
    """A lag's low-pass-corrected estimate and 95 % interval ``(tau, lo, hi)`` (s): ``tau ± t rms / slope`` (module
    docstring, "Reported").

    Parameters
    ----------
    info : dict
        :attr:`JointLag.info` of the fit: ``lowpass`` (:func:`_lowpass_correction`'s ``tau`` and ``slope``, not
        None), ``n_valid`` and ``rms`` (s) of the bootstrap's refits.

    Returns
    -------
    tuple of float
        The corrected lag and its interval's ends (s), ``t`` the Student-t quantile of the valid refits
        (:func:`adaptive_ff.identification.covariance.bootstrap_t_quantile`).
    """
    from adaptive_ff.identification.covariance import bootstrap_t_quantile

    tau, slope = info["lowpass"]["tau"], info["lowpass"]["slope"]
    half = bootstrap_t_quantile(info["n_valid"], 0.95) * info["rms"] / slope
    return tau, tau - half, tau + half


def correction_reason(info: dict) -> str | None:
    """Why a lag that passes :func:`lag_reason` is not reported once corrected for the record's low-pass, or None
    where it is (module docstring, "Reported"): no positive lag reads as the estimate, or the corrected interval
    (:func:`corrected_interval`) reaches below :data:`LAG_FLOOR_SAMPLES` samples of the record (where the fit's stops
    are refined: reaches zero).

    Parameters
    ----------
    info : dict
        :attr:`JointLag.info` of the fit: ``estimate`` (s), ``rate`` (Hz), ``lowpass`` (None: not corrected, no
        reason), ``n_valid``, ``rms`` and ``stop_band`` (rad/s; None or absent: the stops not refined).

    Returns
    -------
    str or None
        The reason, the numbers named.
    """
    corr = info.get("lowpass")
    if corr is None:
        return None
    est = float(info["estimate"])
    if not corr["tau"] > 0.0:
        return (f"the output-error estimate {1e3 * est:.3g} ms is all the record's low-pass: the fitted joint read "
                f"through it reads {1e3 * corr['reads'][0]:.3g} ms")
    tau, lo, hi = corrected_interval(info)
    if info.get("stop_band") is not None:  # refined stops: the corrected interval must exclude zero, as the fit's
        return None if lo > 0.0 else (f"the output-error estimate {1e3 * est:.3g} ms reads {1e3 * tau:.3g} ms once "
                                      f"corrected for the record's low-pass, with the 95 % interval [{1e3 * lo:.3g}, "
                                      f"{1e3 * hi:.3g}] ms, which reaches zero")
    if lo <= lag_floor(info):
        return _below_floor(f"the output-error estimate {1e3 * est:.3g} ms reads {1e3 * tau:.3g} ms once corrected "
                            f"for the record's low-pass, with the 95 % interval [{1e3 * lo:.3g}, {1e3 * hi:.3g}] ms",
                            lag_floor(info))
    return None


def lag_floor(info: dict) -> float:
    """The floor (s) below which no lag is reported: :data:`LAG_FLOOR_SAMPLES` samples of the record, ``info["rate"]``
    (Hz) its rate (:attr:`JointLag.info`; module docstring, "Reported")."""
    return LAG_FLOOR_SAMPLES / float(info["rate"])


def _below_floor(span: str, floor: float) -> str:
    """The reason of a lag whose interval (``span``, the words that name it) reaches below the ``floor`` (s)."""
    return (f"the log does not determine it: {span}, which reaches below {LAG_FLOOR_SAMPLES:g} samples of the record "
            f"({1e3 * floor:.3g} ms), what joints without a lag read")


def _h_refine(t) -> float:
    """The output-error simulation's sub-step (s) inside the stop band: a tenth of the record's median sample time."""
    return 0.1 * float(np.median(np.diff(t)))


def stick_speeds(Fc, J, Ts: float) -> np.ndarray:
    """Each joint's :class:`LagWorld` ``stick`` (rad/s, shape (N,)): the velocity its Coulomb friction takes off in
    one sample of the record, ``|Fc| Ts / J`` (module docstring, "Reported"). The Coulomb level, not the static
    friction: the whole-arm fit determines it far better than the Stribeck peak ``Fs`` on a light joint.

    Parameters
    ----------
    Fc : array_like, shape (N,)
        Each joint's Coulomb friction (N·m; its magnitude is taken) from the whole-arm fit.
    J : array_like, shape (N,)
        Each joint's identified ``M_jj`` (kg·m²).
    Ts : float
        The lag record's sample time (s).

    Returns
    -------
    ndarray, shape (N,)
        The speeds (rad/s); NaN where ``J`` or ``Fc`` is not finite or ``J <= 0``.
    """
    return _taken_in_a_sample(Fc, J, Ts)


def _taken_in_a_sample(F, J, Ts: float) -> np.ndarray:
    """``|F| Ts / J`` (rad/s, shape (N,)): the velocity a friction level ``F`` (N·m) takes off a joint of inertia ``J``
    (kg·m²) in one sample ``Ts`` (s); NaN where ``F`` or ``J`` is not finite or ``J <= 0``."""
    F = np.abs(np.asarray(F, dtype=float))
    J = np.asarray(J, dtype=float)
    ok = np.isfinite(F) & np.isfinite(J) & (J > 0)
    return np.where(ok, np.where(ok, F, 0.0) * float(Ts) / np.where(ok, J, 1.0), np.nan)


def stop_bands(Fs, J, Ts: float) -> np.ndarray:
    """Each joint's :class:`LagWorld` ``stop_band`` (rad/s, shape (N,)): :data:`LAG_STOP_BAND` times the velocity
    its static friction takes off in one sample, ``Fs Ts / J``.

    Parameters
    ----------
    Fs : array_like, shape (N,)
        Each joint's static friction (N·m; its magnitude is taken) from the whole-arm fit.
    J : array_like, shape (N,)
        Each joint's identified ``M_jj`` (kg·m²); a non-positive or non-finite one gives no band (None-like: 0).
    Ts : float
        The lag record's sample time (s).

    Returns
    -------
    ndarray, shape (N,)
        The bands (rad/s); 0 where ``J`` or ``Fs`` is not finite or ``J <= 0`` (the reversals alone refined).
    """
    speed = _taken_in_a_sample(Fs, J, Ts)
    return np.where(np.isfinite(speed), LAG_STOP_BAND * speed, 0.0)


def refined_joints(sticks, refine_stops) -> np.ndarray:
    """Which joints' lag fits refine their stops (bool, shape (N,); :class:`LagOptions` ``refine_stops``; module
    docstring, "Stops").

    Parameters
    ----------
    sticks : array_like, shape (N,)
        Each joint's stick speed (rad/s, :func:`stick_speeds`); NaN where unknown.
    refine_stops : bool or "auto"
        True: every joint; False: none; ``"auto"``: the joints whose stick speed lies in
        [:data:`LAG_REFINE_STICK`, :data:`LAG_STICK_MAX`) (NaN: not refined).

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    s = np.asarray(sticks, dtype=float)
    if refine_stops is True or refine_stops is False:
        return np.full(s.shape, refine_stops)
    with np.errstate(invalid="ignore"):
        return (s >= LAG_REFINE_STICK) & (s < LAG_STICK_MAX)


def lag_reason(estimate: float, interval95: tuple, info: dict) -> str | None:
    """Why the log does not determine a joint's lag, or None where it does (module docstring, "Reported").

    Parameters
    ----------
    estimate : float
        The output-error fit's ``tau`` (s).
    interval95 : tuple of float
        Its 95 % bootstrap interval ``(lo, hi)`` (s); NaN or None where the fit gives none.
    info : dict
        :attr:`JointLag.info` of the fit: ``rate`` (Hz, the record's), ``bias`` (s, the refits' mean shift of
        ``tau``), ``stop_band`` (rad/s or None) and ``stick`` (rad/s or None, :class:`LagWorld`).

    Returns
    -------
    str or None
        The reason (the numbers named), in the order: no finite interval; the interval reaches zero; the refits
        shift the estimate up by more than :data:`LAG_SHIFT_MAX` of it; the interval reaches below
        :data:`LAG_FLOOR_SAMPLES` samples of the record; the stops are not refined (``stop_band`` None) and
        ``stick`` is at least :data:`LAG_STICK_MAX`.
    """
    lo, hi = interval95
    if not (lo is not None and hi is not None and math.isfinite(lo) and math.isfinite(hi)):
        return "the output-error fit gives no finite interval for it"
    span = f"the output-error estimate {1e3 * estimate:.3g} ms has the 95 % interval [{1e3 * lo:.3g}, {1e3 * hi:.3g}] ms"
    if lo <= 0.0:
        return (f"the log does not determine it: {span}, which reaches zero (more velocity reversals, or a lag longer "
                "than the sample time, determine it)")
    bias = float(info.get("bias", 0.0))
    if math.isfinite(bias) and bias > LAG_SHIFT_MAX * estimate:
        return (f"the log does not determine it: {span}, but its bootstrap refits read {1e3 * bias:.3g} ms more on "
                f"average (more than {100 * LAG_SHIFT_MAX:g} % of it), as on joints without a lag")
    if lo <= lag_floor(info):
        return _below_floor(span, lag_floor(info))
    stick = info.get("stick")
    if info.get("stop_band") is None and stick is not None and stick >= LAG_STICK_MAX:
        return (f"the log does not determine it at the record's step: {span}, but the joint sticks hard (its Coulomb "
                f"friction takes off {stick:.3g} rad/s of its velocity in one sample, Fc Ts / J, at least "
                f"{LAG_STICK_MAX:g}), where the fit reads the ringing of its own step at the stops as lag "
                "(identify-arm --refine-stops fits the stops finely)")
    return None


def _fit_stats(fit) -> dict:
    """The output-error fit's numbers behind the lag's decision: ``interval95`` (s; NaN where none) and the bootstrap's
    valid refits ``n_valid``, their mean shift ``bias`` and RMS deviation ``rms`` of ``tau`` (s) from the estimate."""
    boot = fit.info.get("bootstrap") or {}
    lo, hi = (fit.info.get("interval95") or {}).get("tau", (math.nan, math.nan))
    return {"interval95": [float(lo), float(hi)], "n_valid": int(boot.get("n_valid", 0)),
            "bias": float((boot.get("bias") or {}).get("tau", math.nan)),
            "rms": float((boot.get("stderr_refits") or {}).get("tau", math.nan))}


def _worker_init() -> None:
    """A lag worker's BLAS on one thread (the fits' products are small; the workers share the cores)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")


def joint_lags(t, u, w, shapes, *, options: LagOptions = LagOptions(), seed: int = 0, progress=False,
               worlds=None) -> list:
    """Every joint's :func:`joint_lag`, in ``options.workers`` processes (joint ``j`` seeded ``seed + j``).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Time (s) of :func:`lag_records`.
    u, w : ndarray, shape (n, N)
        Removed torques (N·m) and velocities (rad/s) of :func:`lag_records`.
    shapes : sequence of (float, float)
        Each joint's ``(Vs, delta)`` held in its fit (rad/s, -); NaN: fitted by the output-error fit.
    options : LagOptions, keyword-only
        Bootstrap refits and worker processes.
    seed : int, keyword-only
        Joint ``j``'s bootstrap takes ``seed + j``.
    progress : bool or None, keyword-only
        A tqdm bar over the joints on stderr: True, False (default), None (only on a terminal).
    worlds : sequence of LagWorld, or None, keyword-only
        Each joint's :class:`LagWorld` (its ``input_errors`` at least ``options.n_bootstrap`` rows: the first that
        many are taken); None (default): ``LagWorld()`` for every joint.

    Returns
    -------
    list of JointLag
        One per joint, in the joints' order; the same whatever ``options.workers``.

    Raises
    ------
    ParameterError
        ``worlds`` not one per joint.
    """
    from tqdm.auto import tqdm

    n = u.shape[1]
    if worlds is not None and len(worlds) != n:
        raise ParameterError(f"worlds must hold one LagWorld per joint ({n}), got {len(worlds)}")
    n_boot = int(options.n_bootstrap)
    jobs = [((t, u[:, j], w[:, j], float(shapes[j][0]), float(shapes[j][1])),
             {"n_bootstrap": n_boot, "seed": int(seed) + j,
              "world": LagWorld() if worlds is None else replace(
                  worlds[j], input_errors=None if worlds[j].input_errors is None else worlds[j].input_errors[:n_boot])})
            for j in range(n)]
    bar = tqdm(total=n, desc="arm friction lag", unit="joint", leave=False,
               disable=(None if progress is None else not progress))
    out = [None] * n
    with bar:
        if options.workers == 1 or n == 1:
            for j, (a, k) in enumerate(jobs):
                out[j] = joint_lag(*a, **k)
                bar.update()
            return out
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # fork where the platform has it: a spawned worker re-runs the caller's main script (one without a
        # __main__ guard, or a script read from stdin, would break it)
        method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
        with ProcessPoolExecutor(max_workers=min(int(options.workers), n), initializer=_worker_init,
                                 mp_context=multiprocessing.get_context(method)) as pool:
            futures = {pool.submit(joint_lag, *a, **k): j for j, (a, k) in enumerate(jobs)}
            for f in as_completed(futures):
                out[futures[f]] = f.result()
                bar.update()
    return out
