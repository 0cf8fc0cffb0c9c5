"""Golden cases: short runs of the package's public API whose numbers are frozen in ``tests/golden/``.

Each case is a function without arguments that runs one scenario through the public API only (the
closed loop :func:`controllers.simulation.closed_loop.run_mode` and :func:`run_closed_loop`, the batch
:func:`controllers.simulation.batch.run_batch`, the main job :func:`controllers.experiments.compare.compare`,
the identification functions of :mod:`adaptive_ff.identification`, the quasi-static experiments of
:mod:`controllers.experiments.quasi_static`, the plant's open-loop simulation) and returns a record of
strict-JSON values: metrics (everything of the result's ``to_dict()``), decimated signals, parameter
histories and identified parameters. ``tests/controllers_layer/test_golden.py`` recomputes every case and compares it with the
frozen record (``tests/golden/README.md`` says when and how the records were made, and the tolerances).

The cases exist to hold the results fixed while the compiled kernels change their implementation (numba to
C): they cover every compensation mode on every plant model, the batch engine, the sensor noise and fault
paths, the stiff plant steps, and every compiled identification kernel. A closed-loop case is at most 3 s of
simulated time at 1 kHz; where a last-bit change of an input would grow beyond 1e-10 within that time (a
lagged joint that sticks and chatters, an estimator driven by noise through an ill-conditioned stretch) the case
is shorter or noise-free (:data:`MATRIX_SETTINGS`, :data:`BATCH_MORE`, tests/golden/README.md), so that a port
that is correct but not bit-identical still passes.

Usage::

    python -m tests.golden_cases --list             # the case names
    python -m tests.golden_cases --freeze           # (re)write tests/golden/<case>.json for every case
    python -m tests.golden_cases --freeze NAME ...  # only these cases

A record must NOT be regenerated to make a failing comparison pass: a regeneration is a deliberate change
of the frozen behaviour and its commit says why (``tests/golden/README.md``).
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from adaptive_ff.compensation.adaptive_feedforward import FeedforwardStart
from adaptive_ff.compensation.sliding_estimator import SlidingFrictionEstimatorConfig, fit_sliding
from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.online_ukf import run_online_ukf
from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel, eq4_phi, eq4_to_physical
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.identification.simulator import input_grid, simulate_on_grid, simulate_sampled
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers.design.pi import PIController, design_pi
from controllers.experiments.compare import compare
from controllers.experiments.quasi_static import (StribeckDesign, bidirectional_velocities, prefit_stribeck,
                                                  quasi_static_runs, stribeck_experiment)
from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import MeasurementSettings, LoopConfig, RunSettings, run_closed_loop, run_mode
from controllers.simulation.compensators import MODES, build_mode
from plant.dynamics import plant_params
from plant.excitation import Reference, bandlimited_noise, multisine_reference
from plant.friction import JointParams, preset
from plant.joint import simulate
from plant.lugre import LuGreParams
from plant.models import plant_to_dict
from plant.sampling import sample
from plant.variant_plants import drift_case, variant

GOLDEN_DIR = Path(__file__).parent / "golden"

#: Date the records were frozen (tests/golden/README.md).
FROZEN_ON = "2026-11-23"

DURATION = 3.0  # s, the longest closed-loop run (MATRIX_SETTINGS shortens some)
TC = 1e-3
NOISE = 1e-3  # rad/s, velocity measurement noise of the noisy cases
EVERY = 20  # signals: every 20th sample (50 Hz)
EVERY_MATRIX = 50  # signals of the mode x plant matrix: every 50th sample (20 Hz; keeps the files small)


# --------------------------------------------------------------------------- strict-JSON conversion


def _num(x):
    """One float as strict JSON: NaN -> None, +-inf -> "inf"/"-inf" (kept apart from NaN)."""
    x = float(x)
    if math.isnan(x):
        return None
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return x


def jsonable(obj):
    """``obj`` as strict-JSON values (numbers as above; numpy arrays as nested lists; tuples as lists)."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return _num(obj)
    if isinstance(obj, np.ndarray):
        if obj.dtype == bool:
            return obj.tolist()
        if np.issubdtype(obj.dtype, np.integer):
            return obj.tolist()
        return [jsonable(v) for v in obj] if obj.ndim > 1 else [_num(v) for v in obj.tolist()]
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if hasattr(obj, "to_dict"):
        return jsonable(obj.to_dict())
    raise TypeError(f"no JSON form for {type(obj).__name__}")


def _dec(x, every: int) -> np.ndarray:
    """Every ``every``-th sample of ``x`` and its last one (the end of a run is where drift accumulates)."""
    x = np.asarray(x)
    if x.shape[0] == 0:
        return x
    idx = np.arange(0, x.shape[0], every)
    if idx[-1] != x.shape[0] - 1:
        idx = np.append(idx, x.shape[0] - 1)
    return x[idx]


# --------------------------------------------------------------------------- scenario


def reference(duration: float = DURATION, seed: int = 0) -> Reference:
    """The velocity reference of the closed-loop cases: a multi-sine of 0.2-2 Hz, peak 20 deg/s, 0.3 s fade-in
    (several reversals within the short run); a shorter run is the start of the 3 s reference."""
    r = multisine_reference(DURATION, dt=TC, f_min=0.2, f_max=2.0, ramp=0.3, rng=np.random.default_rng(seed))
    n = int(round(duration / TC))
    return r if n >= r.t.shape[0] else Reference(t=r.t[:n], w=r.w[:n], dw=r.dw[:n])


def _stiff_lagged():
    # a rising static map (delta < 0) without lag on a light joint: the implicit stiff lagged step
    return JointParams(J=0.02, Fc=1.0, Fs=3.0, Vs=0.002, delta=-0.5, sigma=0.5, tau=0.0)


def _stiff_lugre():
    # bristles 1e8 N·m/rad on a light joint: the implicit stiff LuGre step
    return LuGreParams(J=0.01, Fc=0.05, Fs=0.1, Vs=0.01, delta=2.0, sigma0=1e8, sigma1=1e3, sigma2=0.01)


#: Plant models of the matrix: name -> (plant, torque limit u_max in N·m).
PLANTS = {
    "paper": (preset("paper"), 150.0),  # lagged Stribeck (eqs. 1-3)
    "lugre": (variant("lugre"), 150.0),
    "karnopp": (variant("karnopp"), 150.0),
    "asymmetric": (variant("asymmetric"), 150.0),
    "drift": (drift_case(DURATION), 150.0),  # Fc, Fs +50 % over the first half, re-frozen every period
    "static": (variant("static"), 150.0),  # tau = 0: the set-valued static map (Filippov sticking)
    "stiff-lagged": (_stiff_lagged(), 12.0),
    "stiff-lugre": (_stiff_lugre(), 1.0),
}

#: The compensation modes of the matrix: the registry's modes plus ``adaptive`` with the paper's eq. 4 RLS.
MATRIX_MODES = tuple(MODES) + ("adaptive-eq4",)


def _frozen(p):
    return p.at(0.0) if hasattr(p, "at") else p


def _levels(p) -> dict:
    """The friction parameters a user would know roughly (for the fixed estimate and the adaptive start)."""
    q = _frozen(p)
    d = plant_to_dict(q)
    if d["model"] == "asymmetric":
        Fc, Fs, sigma = 0.5 * (q.Fc_pos + q.Fc_neg), 0.5 * (q.Fs_pos + q.Fs_neg), 0.5 * (q.sigma_pos + q.sigma_neg)
    else:
        Fc, Fs = q.Fc, q.Fs
        sigma = q.sigma2 if d["model"] == "lugre" else q.sigma
    tau = getattr(q, "tau", 0.01)
    return {"J": q.J, "Fc": Fc, "Fs": Fs, "sigma": sigma, "tau": tau, "Vs": q.Vs, "delta": q.delta}


def rough_estimate(p, level: float = 0.9) -> FrictionEstimate:
    """A friction estimate ``level`` times the plant's levels (a fixed compensation that is 10 % off)."""
    v = _levels(p)
    return FrictionEstimate(J=v["J"], tau=v["tau"], sigma=level * v["sigma"], Fc=level * v["Fc"],
                            Fs=level * v["Fs"], offset=0.0, Vs=v["Vs"], delta=v["delta"], J_alt=math.nan)


@functools.lru_cache(maxsize=None)
def _design(J: float):
    """design_pi for the plant's J at 20 rad/s, 60 deg (cached: its margins take 0.1 s)."""
    return design_pi(J, crossover=20.0, phase_margin=60.0, Tc=TC)


def mode_options(p, u_max: float, mode: str, *, noise_std: float = NOISE, **changes) -> tuple[str, LoopConfig]:
    """The registry mode and its options for a matrix column: the PI designed for the plant's J (20 rad/s, 60
    deg), the settings :func:`controllers.experiments.compare.compare` uses (warm-up 50, stick band 3 noise
    levels, 50 stick samples, the pre-fit start) with the plant's own Stribeck factors."""
    v = _levels(p)
    d = _design(v["J"])
    est = rough_estimate(p)
    o = LoopConfig.from_flat(Kp=d.Kp, Ki=d.Ki, u_max=u_max, Tc=TC, noise_std=noise_std, Vs=v["Vs"], delta=v["delta"],
                    warmup=50, stick_band=3.0 * max(noise_std, 1e-4), stick_samples=50, estimate=est,
                    initial=est, start=FeedforwardStart(est), model=RegressionModel(v["Vs"], v["delta"]))
    if mode == "adaptive-eq4":
        mode, o = "adaptive", o.replace(estimator="eq4-rls")  # the paper's RLS (named "eq4" until 2026-11-24)
    return mode, o.replace(**changes)


# --------------------------------------------------------------------------- records


def closed_loop_record(res, every: int = EVERY, theta_every: int = 10, inputs: bool = False) -> dict:
    """``to_dict()`` of a :class:`ClosedLoopResult` plus its signals every ``every``-th sample and its parameter
    history every ``theta_every``-th update; the time and the reference (the inputs) only with ``inputs``."""
    names = ("t", "w_ref") if inputs else ()
    names += ("w", "w_meas", "u", "u_ff", "f")
    if res.mode == "frictionless":  # its friction is 0 up to rounding (1e-16 N·m): no signal to compare
        names = names[:-1]
    rec = {"result": res.to_dict(), "signals": {k: _dec(getattr(res, k), every) for k in names}}
    if res.theta.size:
        rec["theta"] = {"t": _dec(res.t_theta, theta_every), "theta": _dec(res.theta, theta_every)}
    return rec


def batch_record(b) -> dict:
    """``to_dict()`` of a :class:`BatchResult` plus each compensator's final estimate and counters."""
    comps = []
    for c in b.compensators:
        if c is None:
            comps.append(None)
            continue
        est = getattr(c, "estimate", None)
        comps.append({"estimate": est.to_dict() if isinstance(est, FrictionEstimate) else None,
                      "info": c.info() if hasattr(c, "info") else None})
    return {"result": b.to_dict(), "compensators": comps}


#: Matrix cases run shorter or without noise, so that a change in the last bit of an input (the reference or
#: ``Kp`` times ``1 + 2**-52``, measured for every case) moves no recorded number by more than 1e-10 of its scale
#: (ten times below the tolerance of tests/controllers_layer/test_golden.py): ``(plant, mode) -> (duration in s, noise in rad/s)``.
#: Two mechanisms amplify such a change. (1) A lagged joint (eqs. 1-3, ``tau > 0``) that sticks under a weak
#: compensation chatters around ``w = 0`` (the sign of eq. 3 flips every step or two): a difference grows about
#: e-fold per 25 ms of sticking, 1e-16 to 1e-10 within 0.3-0.4 s of the first stick. Those runs end before it.
#: (2) The noise drives the RLS estimators through ill-conditioned stretches (a short sliding segment, the stick
#: detection switching): a difference grows to 1e-10..1e-8 but not further. Those runs are noise-free, or shorter.
MATRIX_SETTINGS = {
    ("paper", "none"): (1.0, NOISE),  # chaotic stick from 0.8 s (first reversal), 1e-10 reached at 1.03 s
    ("paper", "canudas"): (DURATION, 0.0),
    ("paper", "adaptive-eq4"): (1.7, NOISE),
    ("lugre", "adaptive-dob"): (DURATION, 0.0),
    ("karnopp", "adaptive-eq4"): (DURATION, 0.0),
    ("asymmetric", "none"): (1.0, NOISE),  # chaotic stick, 1e-10 reached at 1.1 s
    ("asymmetric", "adaptive"): (DURATION, 0.0),
    ("asymmetric", "adaptive-dob"): (DURATION, 0.0),
    ("asymmetric", "canudas"): (2.7, 0.0),
    ("asymmetric", "adaptive-eq4"): (1.3, NOISE),
    ("drift", "none"): (0.9, 0.0),  # chaotic stick, 1e-10 reached at 0.92 s
    ("drift", "fixed"): (2.3, 0.0),  # the fixed estimate falls 50 % short by then: the joint sticks
    ("drift", "canudas"): (0.9, 0.0),
    ("drift", "adaptive-eq4"): (1.7, 0.0),
    ("static", "adaptive"): (1.7, NOISE),
    ("static", "adaptive-dob"): (1.7, NOISE),
    ("static", "adaptive-eq4"): (DURATION, 0.0),
}


def _matrix_case(plant_name: str, mode_name: str):
    duration, noise = MATRIX_SETTINGS.get((plant_name, mode_name), (DURATION, NOISE))

    def run():
        p, u_max = PLANTS[plant_name]
        if plant_name == "drift":
            p = drift_case(DURATION)  # the same drift whatever the run's length
        mode, o = mode_options(p, u_max, mode_name, noise_std=noise)
        res = run_mode(p, reference(duration), mode, o, rng=np.random.default_rng(1))
        return {"plant": plant_to_dict(_frozen(p)), "mode": mode_name,
                **closed_loop_record(res, every=EVERY_MATRIX)}
    run.__doc__ = (f"run_mode: {mode_name} on the {plant_name} plant, {duration:g} s, noise {noise:g} rad/s "
                   "(seed 1).")
    return run


CASES: dict = {}


def case(fn):
    """Register a case under its function's name (``_`` -> ``-``)."""
    CASES[fn.__name__.lstrip("_").replace("_", "-")] = fn
    return fn


for _pn in PLANTS:
    for _mn in MATRIX_MODES:
        CASES[f"loop-{_pn}-{_mn}"] = _matrix_case(_pn, _mn)


# --------------------------------------------------------------------------- closed loop: variants of the settings


@case
def loop_lugre_adaptive_bare():
    """Sliding adaptive feedforward from zero friction, no start map, no stick detection, no noise, on the LuGre
    variant (on the lagged paper joint the loop sticks for most of its warm-up and chatters); all signals every
    20th sample."""
    p, u_max = PLANTS["lugre"]
    mode, o = mode_options(p, u_max, "adaptive", noise_std=0.0, initial=None, start=None, stick_band=0.0,
                           warmup=200)
    return closed_loop_record(run_mode(p, reference(), mode, o))


@case
def loop_karnopp_adaptive_variants():
    """Directional forgetting, evaluated at the reference, measured sign, reference stick input, no offset,
    own observer bandwidth, lag memory 0, J_design 10 % high; on the Karnopp variant (on the paper joint the
    measured sign lets the joint stick and chatter)."""
    p, u_max = PLANTS["karnopp"]
    mode, o = mode_options(p, u_max, "adaptive", forgetting="directional", ff_input="reference",
                           sign_input="measured", stick_input="reference", offset=False, lag_memory=0.0,
                           J_design=4.4, observer_bandwidth=80.0, lam=0.99, sign_width=0.002)
    return closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(2)))


@case
def loop_paper_fixed_nolag_reference():
    """Fixed compensation without the lag filter at the reference velocity, sign width, ff_max."""
    p, u_max = PLANTS["paper"]
    mode, o = mode_options(p, u_max, "fixed", lag=False, ff_input="reference", sign_width=0.005, ff_max=30.0)
    return closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(3)))


@case
def loop_paper_eq4_variants():
    """The paper's eq. 4 RLS feedforward: Coulomb structure with offset, no lag, lam 0.98, Ts 5 ms."""
    p, u_max = PLANTS["paper"]
    mode, o = mode_options(p, u_max, "adaptive-eq4", model=RegressionModel(stribeck=False, offset=True, lag=False),
                           lam=0.98, Ts=0.005, warmup=100)
    return closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(4)))


@case
def loop_karnopp_canudas_measured_dob_omega():
    """Canudas at the measured velocity with directional forgetting, and the DOB at 200 rad/s with J_n off; on
    the Karnopp variant (on the paper joint the measured-velocity Canudas loop sticks and chatters)."""
    p, u_max = PLANTS["karnopp"]
    out = {}
    mode, o = mode_options(p, u_max, "canudas", ff_input="measured", forgetting="directional")
    out["canudas"] = closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(5)))
    mode, o = mode_options(p, u_max, "dob", omega_q=200.0, J_n=3.0)
    out["dob"] = closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(5)))
    return out


@case
def loop_karnopp_sensor_fault():
    """Adaptive, none and adaptive-dob with sensor faults (a spike, a NaN, a dropout to 0, an inf) through the
    gate, and small faults without the gate on the DOB (the raw measurement); on the Karnopp variant (on the
    lagged paper joint the uncompensated loop sticks and chatters)."""
    p, u_max = PLANTS["karnopp"]
    faults = {700: 5.0, 701: math.nan, 1400: 0.0, 1401: 0.0, 1402: 0.0, 2100: math.inf, 2500: -3.0}
    out = {}
    for mode_name in ("adaptive", "none", "adaptive-dob"):
        mode, o = mode_options(p, u_max, mode_name)
        out[mode_name] = closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(6),
                                                     faults=faults))
    mode, o = mode_options(p, u_max, "dob", sensor_gate=False)
    out["dob-ungated"] = closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(6),
                                                     faults={700: 0.05, 1400: -0.05}))
    return out


@case
def loop_paper_saturated_diverged():
    """A torque limit that saturates at the reference's peaks (anti-windup; 50 N·m against 35 N·m of friction and
    the inertia's share) and a run that leaves w_limit (diverged)."""
    p, u_max = PLANTS["paper"]
    out = {}
    mode, o = mode_options(p, 50.0, "adaptive")
    out["saturated"] = closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(7)))
    mode, o = mode_options(p, 1e4, "none", Kp=2e4, Ki=0.0, w_limit=0.5)  # Kp*Tc/J = 5 > 2: unstable
    out["diverged"] = closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(7)))
    return out


@case
def loop_engine_decimate_friction0():
    """run_closed_loop with objects built by build_mode: engine-side decimation (every 20th sample), a lagged
    plant that starts unloaded (friction0 = 0), reversal window 0.1 s."""
    p, u_max = PLANTS["paper"]
    mode, o = mode_options(p, u_max, "adaptive")
    run_plant, ctrl, comp = build_mode(p, mode, o)
    res = run_closed_loop(run_plant, ctrl, comp, reference(),
                          measurement=MeasurementSettings(noise_std=NOISE, rng=np.random.default_rng(8)),
                          settings=RunSettings(decimate=20, reversal_window=0.1, friction0=0.0))
    out = closed_loop_record(res, every=1, theta_every=1, inputs=True)
    out["controller_state"] = np.array([ctrl.integral, float(ctrl.saturated)])  # (I, saturated) of the PI
    return out


@case
def loop_variants_more():
    """Two more plant variants (long lag, negative delta) in the adaptive mode. (The small-inertia variant
    sticks and chatters here: a last-bit change moves the estimator's update count; it runs open loop and in the
    frictionless batch.)"""
    out = {}
    for name in ("long-lag", "negative-delta"):
        p = variant(name)
        mode, o = mode_options(p, 150.0, "adaptive")
        out[name] = closed_loop_record(run_mode(p, reference(), mode, o, rng=np.random.default_rng(9)),
                                       every=EVERY_MATRIX)
    return out


# --------------------------------------------------------------------------- batch


#: Scenarios of the batch cases (each with its own noise seed), several plant models packed into one engine call.
#: Every mode runs the robust core; a plant joins a mode's batch where a change in the last bit of the reference
#: moves its metrics by less than 1e-10 (measured): the lagged plants that stick under the mode (``paper``,
#: ``asymmetric``, ``long-lag`` without compensation, ``drift`` under the compensators that fall behind its
#: rising friction, ``small-inertia``) chatter at ``w = 0`` and are left out there (see MATRIX_SETTINGS).
BATCH_CORE = ("lugre", "karnopp", "static", "negative-delta", "stiff-lagged")
BATCH_MORE = {
    "none": (),
    "fixed": ("paper", "asymmetric", "long-lag"),
    "adaptive": ("paper", "asymmetric", "long-lag"),
    "adaptive-dob": ("paper", "asymmetric", "long-lag", "drift"),
    "canudas": ("paper", "asymmetric", "long-lag"),
    "dob": ("paper", "asymmetric", "long-lag", "drift"),
    "oracle": ("paper", "asymmetric", "long-lag", "drift", "stiff-lugre"),
    "frictionless": ("paper", "asymmetric", "long-lag", "drift", "stiff-lugre", "small-inertia"),
    "adaptive-eq4": ("long-lag",),
}


def _named_plant(name: str) -> tuple:
    """``(plant, u_max)`` of a matrix plant or a variant of :mod:`plant.variant_plants`."""
    return PLANTS[name] if name in PLANTS else (variant(name), 150.0)


def _batch_case(mode_name: str):
    names = BATCH_CORE + BATCH_MORE[mode_name]

    def run():
        plants = [_named_plant(n) for n in names]
        opts = [mode_options(p, u_max, mode_name)[1] for p, u_max in plants]
        mode = mode_options(plants[0][0], plants[0][1], mode_name)[0]
        res = run_batch([p for p, _ in plants], reference(seed=10), mode, opts,
                        seeds=list(range(20, 20 + len(plants))))
        return {"scenarios": list(names), **batch_record(res)}
    run.__doc__ = (f"run_batch: {mode_name} on {len(names)} scenarios ({', '.join(names)}), 3 s, noise 1e-3 rad/s, "
                   f"seeds 20-{19 + len(names)}.")
    return run


for _mn in MATRIX_MODES:
    CASES[f"batch-{_mn}"] = _batch_case(_mn)


@case
def batch_common_options_noise_array():
    """run_batch with one ModeOptions for all, an explicit noise array (B, N), the paper plant object given
    three times, and a stiff-lagged pair without noise."""
    p, u_max = PLANTS["paper"]
    mode, o = mode_options(p, u_max, "adaptive")
    ref = reference(seed=11)
    noise = np.random.default_rng(30).normal(0.0, NOISE, size=(3, ref.t.size))
    out = {"paper": batch_record(run_batch([p] * 3, ref, mode, o, noise=noise))}
    q, uq = PLANTS["stiff-lagged"]
    mode, o = mode_options(q, uq, "none", noise_std=0.0)
    out["stiff"] = batch_record(run_batch([q, q.replace(Fs=2.0)], ref, mode, o))
    return out


# --------------------------------------------------------------------------- the main job


#: The compare cases run with a data sheet's exact inertia (``J_design``, the preset's ``J``), as they were frozen:
#: they hold the engine's results fixed; the design inertia's own experiment (``compare``'s default) is tested in
#: tests/controllers_layer/test_first_inertia.py.
@functools.lru_cache(maxsize=1)
def _compare_paper():
    p = preset("paper")
    return compare(p, duration=4.0, seed=0, progress=False, J_design=p.J)


#: Modes of compare-paper whose runs amplify a change in the last bit of an input beyond 1e-10 (measured with the
#: reference, the identification torque or ``Kp`` times ``1 + 2**-52``): under none, canudas and (at the first
#: reversal) fixed the lagged joint sticks and chatters at ``w = 0``, a difference grows to a few per cent (8 % on
#: eta of canudas); adaptive starts from the pre-fit and the offline fit and moves by 7e-10 (its metrics) and 5e-7
#: (its offset estimate, near zero). They are compared in compare-paper-stickslip.
SENSITIVE = ("none", "canudas", "fixed", "adaptive")


@case
def compare_paper():
    """compare(): every mode on the paper preset, 4 s, seed 0 (the pre-fit's quasi-static runs, the identification
    run, the offline sliding fit, the adaptive start): the pre-fit, the offline fit, and the runs of the modes
    that do not amplify last-bit changes (adaptive-dob, dob, oracle, frictionless; SENSITIVE)."""
    c = _compare_paper()
    d = c.to_dict()
    return {"prefit": d["prefit"], "offline_ls": d["offline_ls"], "adaptive_final": d["adaptive_final"],
            "notes": d["notes"], "controller": d["controller"], "J_design": d["J_design"],
            "results": {m: {"result": r.to_dict(), "w": _dec(r.w, 100), "u_ff": _dec(r.u_ff, 100)}
                        for m, r in c.results.items() if m not in SENSITIVE}}


@case
def compare_paper_stickslip():
    """compare() on the paper preset as compare-paper: the comparison table (every mode's metrics, eta, rms_dev,
    t_ff_on; eta is relative to none) and the metrics and final estimates of the SENSITIVE modes."""
    c = _compare_paper()
    return {"modes": c.to_dict()["modes"],
            "results": {m: {"metrics": c.results[m].metrics.to_dict(), "estimate": c.results[m].to_dict()["estimate"]}
                        for m in SENSITIVE}}


@case
def compare_lugre_eq4_faults():
    """compare() on the LuGre variant with the eq. 4 estimator and fixed method, measured canudas, sensor faults,
    no noise (with noise the fixed mode's peak error moves by 5e-10 under a last-bit change of the reference)."""
    c = compare(variant("lugre"), duration=3.0, seed=1, progress=False, noise_std=0.0, estimator="eq4-rls",
                fixed_method="eq4", J_design=variant("lugre").J,
                canudas_input="measured", faults={1000: 2.0, 1001: math.nan},
                modes=("none", "fixed", "adaptive", "canudas", "frictionless"))
    return {"comparison": c.to_dict(), "rows": c.rows(),
            "results": {m: {"result": r.to_dict(), "w": _dec(r.w, 100)} for m, r in c.results.items()}}


# --------------------------------------------------------------------------- open-loop plant


def sine_torque(amplitude: float, hz: float, t):
    """``amplitude*sin(2 pi hz t + 0.3)`` (N·m)."""
    return amplitude * np.sin(2 * np.pi * hz * np.asarray(t) + 0.3)


@case
def plant_open_loop():
    """plant.joint.simulate: every plant model (the matrix's, and the variants) under a 2 Hz sine torque of twice
    the static level (breakaway, sliding, reversal; at 1.5 times the small-inertia joint sticks and chatters), 1 s
    at 1 kHz; and the static maps."""
    out = {}
    n = 1000
    tk = np.arange(n) * TC
    wg = np.concatenate([-np.geomspace(1.0, 1e-4, 40), [0.0], np.geomspace(1e-4, 1.0, 40)])
    plants = {k: _frozen(v[0]) for k, v in PLANTS.items()}
    plants.update({k: variant(k) for k in ("small-inertia", "long-lag", "negative-delta")})
    for name, p in plants.items():
        lv = _levels(p)
        u = sine_torque(2.0 * lv["Fs"], 2.0, tk)
        r = simulate(p, u, dt=TC)
        out[name] = {"w": _dec(r.w, 10), "friction_map": p.friction(wg)}
    return out


# --------------------------------------------------------------------------- identification


def _open_loop_log(seconds: float = 20.0, seed: int = 1, noise_std: float = NOISE):
    """Paper Sec. IV-A: the paper joint under band-limited noise torque at 1 kHz, sampled at 10 ms with velocity
    noise; returns the plant, the 1 kHz torque, the response and the measurement.

    The torque (2 Hz, std 120 N·m) drives the joint through zero velocity without sticking: under a weaker one
    (the paper's 1 Hz, 40 N·m) the joint sticks, the lagged friction chatters around ``w = 0`` and a change in
    the last bit of the torque grows to 3 % of the velocity within 20 s (measured); here it stays below 1e-11.
    """
    p = preset("paper")
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(seconds, dt=TC, cutoff=2.0, std=120.0, rng=rng)
    resp = simulate(p, u, dt=TC)
    m = sample(resp, Ts=0.01, noise_std=noise_std, rng=rng)
    return p, u, resp, m


@case
def ident_ls():
    """fit_ls (eq. 9) of the eq. 4 model on the simulated open-loop log (20 s at 10 ms), three structures."""
    p, _, _, m = _open_loop_log()
    out = {}
    for name, model in (("stribeck-lag-offset", RegressionModel(p.Vs, p.delta, offset=True)),
                        ("stribeck-lag", RegressionModel(p.Vs, p.delta)),
                        ("coulomb-nolag", RegressionModel(stribeck=False, lag=False))):
        r = fit_ls(model, m.u, m.w, Ts=0.01)
        out[name] = {"fit": r.to_dict(), "w_one_step": _dec(r.w_one_step, 20), "w_free_run": _dec(r.w_free_run, 20)}
    r = fit_ls(RegressionModel(p.Vs, p.delta), m.u, m.w, Ts=0.01, ridge=1e-4)
    out["ridge"] = {"fit": r.to_dict(), "w_free_run": _dec(r.w_free_run, 20)}
    return out


@case
def ident_rls():
    """RecursiveLeastSquares over the eq. 4 regressors of the log: no forgetting, exponential 0.995 with the
    trace bound, directional 0.98, vector forgetting with bounds, the paper's plain 0.85; per-sample update()
    and predict() against update_many()."""
    p, _, _, m = _open_loop_log()
    model = RegressionModel(p.Vs, p.delta, offset=True)
    X, y = model.regressors(m.u, m.w)
    k = model.n_params
    out = {}
    setups = {
        "lam1": dict(lam=1.0, P0=1e4),
        "exponential": dict(lam=0.995, P0=1e4),
        "directional": dict(lam=0.98, P0=1e3, forgetting="directional"),
        "vector-bounds": dict(lam=np.linspace(0.99, 0.999, k), P0=1e4,
                              bounds=(np.full(k, -2.0), np.full(k, 2.0))),
        "paper-plain": dict(lam=0.85, P0=1e4, P_max=math.inf),
    }
    for name, kw in setups.items():
        r = RecursiveLeastSquares(k, **kw)
        hist = r.update_many(X, y)
        out[name] = {"theta_hist": _dec(hist, 50), "theta": r.theta.copy(), "P": r.P.copy(),
                     "n_updates": r.n_updates, "n_projected": r.n_projected, "n_rejected": r.n_rejected,
                     "estimate": model.to_physical(r.theta, 0.01).to_dict()}
    r = RecursiveLeastSquares(k, lam=0.995, theta0=np.full(k, 0.1))
    errs = [r.update(X[i], y[i]) for i in range(300)]
    out["per-sample"] = {"errors": _dec(np.array(errs), 10), "theta": r.theta.copy(),
                         "predict": r.predict(X[400])}
    return out


@case
def ident_eq4_kernels():
    """The compiled regressor eq4_phi and inverse map eq4_to_physical on the log's samples, every structure."""
    p, _, _, m = _open_loop_log(seconds=5.0)
    out = {}
    rows = range(2, m.w.shape[0], 25)
    for lag in (True, False):
        for stribeck in (True, False):
            for offset in (True, False):
                model = RegressionModel(p.Vs if stribeck else None, p.delta if stribeck else None, lag=lag,
                                        stribeck=stribeck, offset=offset)
                phis = []
                for i in rows:
                    phi = np.empty(model.n_params)
                    n = eq4_phi(phi, model, m.u[i], m.u[i - 1], m.w[i - 1], m.w[i - 2])
                    phis.append(phi[:n])
                theta = model.theta_from_physical(p, 0.01, offset=1.5)[:model.n_params] if stribeck else \
                    np.linspace(0.9, 0.1, model.n_params)
                key = f"lag{int(lag)}-stribeck{int(stribeck)}-offset{int(offset)}"
                out[key] = {"phi": np.array(phis), "physical": list(eq4_to_physical(theta, 0.01, lag, stribeck,
                                                                                    offset))}
    return out


@case
def ident_sliding_fit():
    """fit_sliding: the offline sliding-regime inverse-dynamics LS on the 1 kHz log (the fixed mode's fit)."""
    p, u, resp, _ = _open_loop_log(seconds=10.0)
    w = resp.w[:-1] + np.random.default_rng(40).normal(0.0, NOISE, u.shape[0])
    out = {}
    for name, config in (("default", None),
                         ("Ts10ms-nolag", SlidingFrictionEstimatorConfig(Ts=0.01, lag=False, offset=False))):
        f = fit_sliding(u, w, Tc=TC, Vs=p.Vs, delta=p.delta, config=config)
        out[name] = {"names": list(f.names), "theta": f.theta, "theta_std": f.theta_std,
                     "estimate": f.estimate.to_dict(), "n_rows": f.n_rows, "n_gated": f.n_gated,
                     "residual_rms": f.residual_rms}
    return out


@case
def ident_stribeck_fit():
    """fit_stribeck (Sec. V-C) on quasi-static points of the paper joint: with and without F_std, a fixed start."""
    qs = _quasi_static()
    w, F = qs.w_mean, qs.u_mean
    out = {}
    for name, kw in (("default", {}), ("weighted", dict(F_std=np.maximum(qs.u_std, 0.05))),
                     ("p0", dict(p0=(20.0, 30.0, 0.03, 1.5, 30.0), delta_starts=(1.0,)))):
        out[name] = {"stribeck_fit": fit_stribeck(w, F, **kw).to_dict()}
    return out


def _quasi_static():
    p = preset("paper")
    v = bidirectional_velocities(0.003, 0.5, 8)
    return quasi_static_runs(p, v, hold=0.5, settle=1.0, noise_std=NOISE, rng=np.random.default_rng(50))


@case
def quasi_static_runs_paper():
    """quasi_static_runs: 16 bidirectional constant-velocity runs of the paper joint (compiled run loop), noise."""
    qs = _quasi_static()
    return {k: getattr(qs, k) for k in ("setpoints", "w_mean", "w_std", "u_mean", "u_std")}


@case
def quasi_static_experiment():
    """stribeck_experiment (speeds designed from the joint's response, refinement, pre-fit) on the paper joint
    and a coarse-only sweep on the Karnopp variant; prefit_stribeck on its data."""
    fast = StribeckDesign(per_decade=2, n_refine=2, max_rounds=1, settle=1.0, hold=0.5, settle_max=3.0)
    e = stribeck_experiment(preset("paper"), J_design=4.0, noise_std=NOISE, rng=np.random.default_rng(60),
                            options=fast)
    k = stribeck_experiment(variant("karnopp"), J_design=4.0, noise_std=0.0, options=fast, fit=False)
    return {"paper": e.to_dict(), "prefit_qs": prefit_stribeck(_quasi_static(), fallback=True).to_dict(),
            "karnopp_coarse": k.to_dict(), "torque_scale": [e.torque_scale, k.torque_scale]}


@case
def ident_online_ukf():
    """run_online_ukf on 4 s of a PI-loop stream of the paper joint at 10 ms (the compiled RK4 propagation)."""
    p = preset("paper")
    rng = np.random.default_rng(70)
    ref = multisine_reference(4.0, dt=TC, f_min=0.2, f_max=2.0, ramp=0.3, rng=rng)
    mode, o = mode_options(p, 150.0, "oracle", noise_std=0.0)  # the joint does not stick: no chatter
    res = run_mode(p, ref, mode, o)
    t, u = res.t[::10], res.u[::10]
    w = res.w[::10] + rng.normal(0.0, NOISE, t.shape[0])
    th0 = {"Fc": 0.9 * p.Fc, "Fs": 1.1 * p.Fs, "Vs": 1.2 * p.Vs, "delta": 1.15 * p.delta, "sigma": 0.9 * p.sigma,
           "tau": 0.7 * p.tau}
    r = run_online_ukf(t, u, w, J=p.J, theta0=th0, noise_std=NOISE)
    return {"result": r.to_dict(), "theta": {k: _dec(v, 20) for k, v in r.theta.items()},
            "w_hat": _dec(r.w_hat, 20), "f_hat": _dec(r.f_hat, 20), "innovation": _dec(r.innovation, 20)}


@case
def ident_simulator():
    """input_grid + simulate_on_grid (free and with output injection) and simulate_sampled on an irregular grid."""
    p, _, _, m = _open_loop_log(seconds=5.0)
    out = {}
    for name, kw in (("linear", {}), ("cubic-delay", dict(interp="cubic", input_delay=5e-4, h_max=5e-4))):
        g = input_grid(m.t, m.u, **kw)
        par = plant_params(p)
        free = simulate_on_grid(par, g, w0=float(m.w[0]), f0=0.0)
        inj = simulate_on_grid(par, g, w0=float(m.w[0]), f0=0.0, offset=0.5, gain=(0.3, 0.1), w_meas=m.w)
        out[name] = {"free": _dec(free, 10), "injected": _dec(inj, 10), "n_grid": int(g.tg.shape[0])}
    rng = np.random.default_rng(80)
    t = np.cumsum(rng.uniform(0.01, 0.04, 150))
    t -= t[0]
    u = sine_torque(80.0, 0.7, t) + 10.0
    out["sampled"] = simulate_sampled(p, t, u, w0=0.0)
    return out


# --------------------------------------------------------------------------- freezing


def compute(name: str) -> dict:
    """The record of case ``name`` as strict-JSON values."""
    return jsonable(CASES[name]())


def commit() -> str:
    """The commit the package sources are at (``git rev-parse HEAD``, ``+dirty`` with uncommitted package edits)."""
    root = Path(__file__).resolve().parent.parent
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "plant", "adaptive_ff", "controllers"], cwd=root,
                           capture_output=True, text=True).stdout.strip()
    return head + ("+dirty" if dirty else "")


def golden_path(name: str) -> Path:
    return GOLDEN_DIR / f"{name}.json"


def freeze(names=None) -> None:
    """Compute and write the records of ``names`` (default all)."""
    import cffi
    GOLDEN_DIR.mkdir(exist_ok=True)
    about = {"commit": commit(), "date": FROZEN_ON, "made_by": "python -m tests.golden_cases --freeze",
             "numpy": np.__version__, "core": f"C (cffi {cffi.__version__})", "note": "do NOT regenerate to make a failing "
             "comparison pass (tests/golden/README.md)"}
    for name in names or list(CASES):
        doc = " ".join((CASES[name].__doc__ or "").split())
        rec = {"_about": dict(about, case=name, what=doc), "record": compute(name)}
        golden_path(name).write_text(json.dumps(rec, separators=(",", ":"), allow_nan=False) + "\n")
        print(f"froze {name}", file=sys.stderr)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.golden_cases", description=__doc__.split("\n")[0])
    ap.add_argument("--freeze", action="store_true", help="write tests/golden/<case>.json")
    ap.add_argument("--list", action="store_true", help="list the case names")
    ap.add_argument("names", nargs="*", help="cases (default: all)")
    a = ap.parse_args(argv)
    unknown = [n for n in a.names if n not in CASES]
    if unknown:
        print(f"unknown case(s) {unknown}", file=sys.stderr)
        return 2
    if a.list:
        print("\n".join(a.names or CASES))
    if a.freeze:
        freeze(a.names)
    return 0


if __name__ == "__main__":
    sys.exit(main())
