"""Helpers for users' own regression tests: assert a tracking-error bound for their plant, inject sensor faults.

Example (pytest)::

    from plant import JointParams
    from controllers.testing import assert_tracking_bound

    def test_my_joint_tracks_with_adaptive_feedforward():
        p = JointParams(J=1.2, Fc=8.0, Fs=11.0, Vs=0.03, delta=1.5, sigma=6.0, tau=0.01)
        assert_tracking_bound(p, mode="adaptive", min_eta=0.8, max_rms=0.01, duration=60.0, seed=1)

    def test_pick_and_place():  # the plant, motion, sensor, drive and bounds of a scenario file
        assert_tracking_bound("examples/scenarios/robot_base.toml")
"""

from __future__ import annotations

import math
import os
from dataclasses import replace

import numpy as np

from controllers.simulation.closed_loop import MODES
from controllers.experiments.compare import Comparison, compare
from controllers.experiments.scenario import Scenario, load_scenario
from plant.errors import ParameterError, check_nonnegative, check_positive

__all__ = ["TrackingBoundError", "assert_tracking_bound", "velocity_faults"]


class TrackingBoundError(AssertionError):
    """A tracking-error bound of :func:`assert_tracking_bound` is violated (an ``AssertionError``, as tests expect)."""


def assert_tracking_bound(plant, *, mode: str | None = None, max_rms: float | None = None,
                          min_eta: float | None = None, max_error: float | None = None,
                          duration: float | None = None, seed: int | None = None, **compare_options) -> Comparison:
    """Run the closed loop on ``plant`` and fail with a readable message if ``mode`` misses a tracking bound.

    Parameters
    ----------
    plant : plant model, Scenario, str or os.PathLike
        The joint to test (see :mod:`plant.models`; run on the multisine of ``duration`` s), or a scenario
        (:class:`controllers.experiments.scenario.Scenario`, or the path of its TOML file): its plant,
        reference, sensor, drive, design and own compensators, and its ``[bounds]`` where no bound is given here.
    mode : str, keyword-only
        Compensation mode to check, one of :data:`controllers.simulation.closed_loop.MODES` (or, for a scenario,
        one of its own compensators); default the scenario's ``[bounds] mode``, else ``"adaptive"``.
    max_rms : float, keyword-only
        Bound on the RMS velocity error over the second half of the run (rad/s).
    min_eta : float, keyword-only
        Lower bound on the compensation efficiency
        ``eta = (RMS_none - RMS_mode)/(RMS_none - RMS_frictionless)``.
    max_error : float, keyword-only
        Bound on the largest |velocity error| over the second half (rad/s).
    duration : float, keyword-only
        Run length (s), default 60; a scenario's reference sets its own (``duration`` then only for a
        scenario on the multisine).
    seed : int, keyword-only
        Seed of the reference, the noise and the identification run (fixed seed: the test is deterministic);
        default 0, or the scenario's.
    **compare_options
        Further fields of :class:`controllers.experiments.compare.CompareOptions`
        (``noise_std``, ``crossover``, ``Ts``, ...).

    Returns
    -------
    Comparison
        The runs, for further checks.

    Raises
    ------
    TrackingBoundError
        A bound is violated or the run diverged; the message lists all
        metrics of ``mode`` next to the bounds.
    ParameterError
        No bound given (here or in the scenario), a bound out of range, or an unknown mode; a scenario file's
        own errors (:class:`controllers.experiments.scenario.ScenarioError`).
    """
    scenario = _as_scenario(plant)
    if scenario is not None and scenario.bounds is not None and (max_rms, min_eta, max_error) == (None,) * 3:
        b = scenario.bounds
        mode, max_rms, min_eta, max_error = mode or b.mode, b.max_rms, b.min_eta, b.max_error
    mode = mode or "adaptive"
    own = set(scenario.options.compensators or {}) if scenario is not None else set()
    if mode not in MODES and mode not in own:
        raise ParameterError(f"mode must be one of {MODES}" + (f" or {sorted(own)}" if own else "") +
                             f", got {mode!r}")
    if max_rms is None and min_eta is None and max_error is None:
        raise ParameterError("give at least one bound: max_rms, min_eta or max_error")
    if max_rms is not None:
        max_rms = check_positive("max_rms", max_rms)
    if max_error is not None:
        max_error = check_positive("max_error", max_error)
    if min_eta is not None and not (isinstance(min_eta, (int, float)) and math.isfinite(min_eta)):
        raise ParameterError(f"min_eta must be a finite number, got {min_eta!r}")
    modes = (mode,) if mode in MODES else ()
    if scenario is None:
        seed = 0 if seed is None else seed
        duration = 60.0 if duration is None else duration
        comp = compare(plant, duration=duration, seed=seed, modes=modes, progress=False, **compare_options)
        what = type(plant).__name__
    else:
        if seed is not None:
            compare_options["seed"] = seed
        if duration is not None:
            compare_options["duration"] = duration
        comp = scenario.compare(modes=modes, progress=False, **compare_options)
        o = replace(scenario.options, **compare_options)
        seed, duration, what = o.seed, o.duration, f"scenario {scenario.name!r}"
    _check_bounds(comp, mode, what, seed, duration, max_rms=max_rms, min_eta=min_eta, max_error=max_error)
    return comp


def _as_scenario(obj):
    """``obj`` as a Scenario: itself, or the scenario file at a path; None for a plant."""
    if isinstance(obj, Scenario):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        return load_scenario(obj)
    return None


def _check_bounds(comp: Comparison, mode: str, what: str, seed: int, duration: float, *, max_rms, min_eta,
                  max_error) -> None:
    """Raise TrackingBoundError listing every bound ``mode`` of ``comp`` misses, with its metrics."""
    r = comp.results[mode]
    m = r.metrics
    e = comp.eta[mode]
    failures = []
    if r.info.get("diverged"):
        failures.append("the run diverged")
    if max_rms is not None and not m.rms_second_half <= max_rms:
        failures.append(f"RMS error {m.rms_second_half:.4g} rad/s > max_rms {max_rms:.4g} rad/s")
    if max_error is not None and not m.max_second_half <= max_error:
        failures.append(f"max error {m.max_second_half:.4g} rad/s > max_error {max_error:.4g} rad/s")
    e_text = "undefined" if e is None else f"{e:.4f}"  # None: friction does not degrade the loop, or it diverged
    if min_eta is not None and (e is None or not e >= min_eta):
        failures.append(f"eta {e_text} < min_eta {min_eta:.4f}")
    if failures:
        raise TrackingBoundError(
            f"mode {mode!r} on {what} (seed {seed}, {duration:g} s): " + "; ".join(failures)
            + f". Metrics (second half): RMS {m.rms_second_half:.4g} rad/s, max {m.max_second_half:.4g} rad/s, "
            f"reversal RMS {m.rms_reversal:.4g} rad/s, eta {e_text}; RMS without compensation "
            f"{comp.results['none'].metrics.rms_second_half:.4g} rad/s, frictionless "
            f"{comp.results['frictionless'].metrics.rms_second_half:.4g} rad/s")


def velocity_faults(n: int, *, rng: np.random.Generator, n_nan: int = 0, n_inf: int = 0, n_spikes: int = 0,
                    spike: float = 1.0, start: int = 0) -> dict:
    """Random measurement faults for :func:`controllers.run_closed_loop` (``faults=``).

    Parameters
    ----------
    n : int
        Number of controller samples of the run.
    rng : numpy.random.Generator, keyword-only
        Draws the sample indices and the spike signs.
    n_nan, n_inf, n_spikes : int, keyword-only
        How many samples become NaN, ``±inf``, and outlier spikes.
    spike : float, keyword-only
        Spike value (rad/s): the measurement is replaced by ``±spike``, >= 0.
    start : int, keyword-only
        Faults are placed at indices ``>= start``.

    Returns
    -------
    dict
        ``{sample index: faulty measured velocity}``, distinct indices.

    Raises
    ------
    ParameterError
        Negative counts, more faults than samples, negative ``spike``.
    """
    for name, v in (("n", n), ("n_nan", n_nan), ("n_inf", n_inf), ("n_spikes", n_spikes), ("start", start)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
            raise ParameterError(f"{name} must be an integer >= 0, got {v!r}")
    spike = check_nonnegative("spike", spike)
    total = n_nan + n_inf + n_spikes
    if total > n - start:
        raise ParameterError(f"{total} faults do not fit into samples {start}..{n - 1}")
    idx = rng.choice(np.arange(start, n), size=total, replace=False)
    signs = rng.choice([-1.0, 1.0], size=total)
    vals = [math.nan] * n_nan + [math.inf * s for s in signs[n_nan:n_nan + n_inf]] + \
        [spike * s for s in signs[n_nan + n_inf:]]
    return {int(i): float(v) for i, v in zip(idx, vals)}
