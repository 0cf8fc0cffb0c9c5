"""Settings of the output-error method of :func:`adaptive_ff.identification.physical_id.fit_physical`.

:class:`OutputErrorOptions` validates them on construction; the search they control is described in the
docstring of :mod:`adaptive_ff.identification.physical_id` ("the module docstring" below; its "Standard errors"
are in :mod:`adaptive_ff.identification.oe_intervals`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields

import numpy as np

from adaptive_ff.identification.simulator import H_MAX_DEFAULT, H_REFINE_DEFAULT
from plant.errors import ParameterError, check_finite_scalar, check_optional, check_optional_number, check_positive

__all__ = ["OutputErrorOptions", "BOOTSTRAP_REFITS", "JACOBIANS"]

#: Jacobians of the output-error trust-region fits (``OutputErrorOptions.jacobian``).
JACOBIANS = ("difference", "sensitivity")
#: Refits of the output-error bootstrap (``OutputErrorOptions.bootstrap_refit``).
BOOTSTRAP_REFITS = ("full", "partial")


@dataclass(frozen=True)
class OutputErrorOptions:
    """Settings of the output-error method of :func:`fit_physical` (validated on construction).

    Parameters
    ----------
    predictor : {"auto", "free-run", "one-step"}, keyword-only
        Prediction used in the cost. ``"auto"`` (default): one-step below a
        velocity noise of 0.03 % of the peak ``|w|``, else free-run (module docstring).
    injection_gain : float, keyword-only
        The one-step predictor's output-injection gain on the velocity, ``Kw`` in (0, 1]
        (:mod:`adaptive_ff.identification.simulator`): after each sample the predicted velocity moves this share
        of the way to the measured one. 1 (default): it is reset to it. Below 1 the predictor carries less of the
        velocity's noise, which a low-passed record hides from ``"auto"`` and which the reset would read as a
        friction lag (errors in variables; :data:`adaptive_ff.arm.lag.LAG_INJECTION_GAIN` for the arm's lag
        fits). Not used by the free-run predictor.
    h_max : float, keyword-only
        Largest RK4 sub-step (s), > 0. Default 1e-3 (the paper's simulation rate).
    stop_band : float or None, keyword-only
        Half-width (rad/s) of a band around zero velocity, >= 0: the sample intervals in which the measured
        velocity is inside it at either end or reverses are simulated with sub-steps of at most ``h_refine``
        (:func:`adaptive_ff.identification.simulator.stop_intervals`), where a lagged joint rings through zero
        at its stops faster than ``h_max`` resolves. None (default): every interval at ``h_max``.
    h_refine : float, keyword-only
        Largest RK4 sub-step (s) inside ``stop_band``, > 0. Default 1e-4.
    input_delay : float or None, keyword-only
        Time (s) by which each input sample precedes its time stamp, >= 0 (0.5e-3 for
        :func:`plant.sampling.sample` at 1 kHz). None (default): not known, profiled by the fit
        (:func:`adaptive_ff.identification.delay_profile.delay_profile_search`: sub-sample delays, the
        parameters refitted at each, the lowest cost kept; reported in ``info["input_delay"]``; the bootstrap's
        refits hold the delay chosen).
    interp : {"linear", "cubic"}, keyword-only
        Input reconstruction between the samples. Default ``"linear"``.
    burn : float, keyword-only
        Time (s) at the start excluded from the cost, >= 0. Default 0.5.
    fs_grid : int, keyword-only
        Points of the global ``Fs`` profile, >= 3. Default 31.
    fs_max_ratio : float, keyword-only
        Upper end of the global ``Fs`` profile as a multiple of ``Fc``, > 1. Default 2.5.
    diff_step : float, keyword-only
        Relative finite-difference step of the Jacobian, > 0. Default 1e-2.
    max_nfev : int, keyword-only
        Largest number of residual evaluations per trust-region fit, >= 1. Default 200.
    loss : {"soft_l1", "linear"}, keyword-only
        Loss of ``scipy.optimize.least_squares``. Default ``"soft_l1"``.
    f_scale : float or None, keyword-only
        Robust scale of the loss (rad/s), > 0. Default None:
        ``max(3*noise, 1e-3*peak |w|)``.
    start : mapping or None, keyword-only
        Start values ``J`` (kg·m², > 0), ``Fc``, ``Fs`` (N·m), ``sigma``
        (N·m·s/rad), ``tau`` (s, > 0) and optionally ``offset`` (N·m); skips
        the eq. 4 start and the start profiles. Default None.
    n_bootstrap : int, keyword-only
        Refits of re-simulated records behind ``stderr`` (module docstring,
        "Standard errors"), >= 0; each costs a fit of its own with
        ``bootstrap_refit="full"`` (the fit runs 1200-2100 simulations on the
        zoo of ``benchmarks/coverage_zoo.py``), about 180 simulations with
        ``"partial"``. 0: ``stderr`` is the HAC sandwich
        (too small on the rough free-run cost). Default 20.
    bootstrap_seed : int, keyword-only
        Seed of the bootstrap's residual blocks and start points, >= 0. Default 0.
    bootstrap_refit : {"full", "partial"}, keyword-only
        How each bootstrap replicate is refitted. ``"full"`` (default): by the fit itself, the replicate taken
        as a record of its own (its noise level, scales and eq. 4 start; every stage including the profile
        searches, the input delay's with the fit's delay as its one point where ``input_delay`` is None: the
        same estimator on every replicate, Efron & Tibshirani 1993, Ch. 6); its 95 % intervals
        covered the truth on 91-96 % of 100 zoo joints per parameter (module docstring, "Standard errors"). ``"partial"``:
        from a start spread around the estimate by the fit's later steps (above; ``_oe_refit``), with the
        record's noise level and robust scales, about a third of the CPU time; its J and tau intervals are about
        twice too wide (the partial refits stop short of where the fit stops).
    bootstrap_workers : int or None, keyword-only
        Threads the bootstrap refits run in, >= 1 (their time is in the C simulation, which releases the GIL;
        :func:`adaptive_ff.identification.covariance.parametric_block_bootstrap`). None (default): the CPUs this
        process may use, at most ``n_bootstrap``. The result does not depend on it.
    progress : bool or None, keyword-only
        A tqdm bar over the bootstrap refits on stderr (a 60 s record at 1 kHz takes minutes): True, False
        (default) or None (only when stderr is a terminal; the CLI's choice unless ``--quiet``). The result
        does not depend on it.
    lag_profile : bool, keyword-only
        Run the profile search over tau after the local stage
        (:func:`adaptive_ff.identification.lag_profile.lag_profile_search`: ten values of tau, J on a grid
        and the others refitted at each; about 1000 simulations). Default True; False gives the fit
        without it (found tau 9-70 % off on joints with a lag near the sample time).
    bootstrap_lag_refits : int or None, keyword-only
        The profile search over tau in each ``"full"`` bootstrap refit (``lag_profile`` True): an integer >= 1
        (default 2), the J grid at each of its ten values of tau screens them by its cost and the others are
        refitted at the ``bootstrap_lag_refits`` values of lowest screening cost only
        (:func:`adaptive_ff.identification.lag_profile.lag_profile_search`, ``n_refit``; 2: about two thirds of
        the bootstrap's simulations); None, the fit's own (the other parameters refitted at each of the ten
        values). The point estimate does not depend on it (the fit's own search always refits at every value); the
        refits' scatter, and with it the intervals, do (module docstring, "Standard errors"; the zoo coverage of
        both: the documentation's identification benchmark page).
    bootstrap_input_quantum : float, "auto" or None, keyword-only
        The resolution (N·m) the log's input was read with, drawn into the input of each bootstrap world
        (module docstring of :mod:`adaptive_ff.identification.oe_intervals`, "Standard errors"): each replicate
        record is the estimate driven by the logged input plus a uniform draw within half of it, refitted with the
        logged input (one more simulation per refit). ``"auto"`` (default): the step of the lattice the logged
        samples lie on (:func:`adaptive_ff.identification.diagnostics.input_quantum`; 0 for a continuous input,
        whose bootstrap is then that of None bit for bit); a float >= 0: that resolution (0: none); None: the
        logged input taken as exact. Reported in ``info["bootstrap"]["input_quantum"]``.
    bootstrap_input_errors : array_like or None, keyword-only
        Draws of the logged input's error (logged less true, N·m), shape (k, N) with N the record's samples
        (finite; a record's input that is itself an estimate, e.g. a torque with an identified rigid body
        removed, whose own bootstrap gives the draws): bootstrap world ``i`` is the estimate driven by the logged
        input less row ``i mod k`` (one more simulation per replicate), refitted with the logged input, so that
        the refits carry that error too (module docstring of :mod:`adaptive_ff.identification.oe_intervals`,
        "Standard errors"; with ``bootstrap_input_quantum`` its draw is added about the logged input). None
        (default): none. Reported in ``info["bootstrap"]["input_errors"]`` (the rows k).
    bootstrap_shapes : array_like or None, keyword-only
        Stribeck shapes ``(Vs, delta)`` (rad/s, -), shape (k, 2), finite, ``Vs > 0``, ``delta`` non-zero: each
        partial refit (``bootstrap_refit="partial"``, ``Vs`` and ``delta`` given) holds the row its own generator
        draws (uniformly, after its start) in place of the given shape, its world staying the estimate at the given
        shape, so that the refits carry the error of a held shape that the data determine only to within those rows
        (e.g. a profile's accepted set, repeated by weight). Ignored by full refits and where the fit searches the
        shape. None (default): the given shape in every refit. Reported in ``info["bootstrap"]["shapes"]`` (k).
    jacobian : {"difference", "sensitivity"}, keyword-only
        Jacobian of the trust-region fits. ``"difference"`` (default): forward differences with the relative
        step ``diff_step`` (a secant over 1 % of each parameter, which sees past the breakaway jitter of the
        free-run output). ``"sensitivity"``: the exact Jacobian of the discrete simulation, its forward
        sensitivities computed alongside it in C
        (:func:`adaptive_ff.identification.simulator.simulate_on_grid_sens`; module docstring, "Jacobian").

    Raises
    ------
    ParameterError
        A value out of range (the message names it).
    TypeError
        A number that is not a real number.

    Notes
    -----
    The staging these settings control is described in the module docstring
    (prediction-error method, Ljung, *System Identification*, 2nd ed., Sec. 7.2).
    """

    predictor: str = "auto"
    injection_gain: float = 1.0
    h_max: float = H_MAX_DEFAULT
    stop_band: float | None = None
    h_refine: float = H_REFINE_DEFAULT
    input_delay: float | None = None
    interp: str = "linear"
    burn: float = 0.5
    fs_grid: int = 31
    fs_max_ratio: float = 2.5
    diff_step: float = 1e-2
    max_nfev: int = 200
    loss: str = "soft_l1"
    f_scale: float | None = None
    start: dict | None = None
    n_bootstrap: int = 20
    bootstrap_seed: int = 0
    bootstrap_refit: str = "full"
    bootstrap_workers: int | None = None
    progress: bool | None = False
    lag_profile: bool = True
    bootstrap_lag_refits: int | None = 2
    jacobian: str = "difference"
    bootstrap_input_quantum: float | str | None = "auto"
    bootstrap_input_errors: np.ndarray | None = field(default=None, compare=False, repr=False)
    bootstrap_shapes: np.ndarray | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        put("h_max", check_positive("h_max", self.h_max))
        put("stop_band", check_optional_number("stop_band", self.stop_band, low=0.0, unit="rad/s", none="none"))
        put("h_refine", check_positive("h_refine", self.h_refine))
        put("injection_gain", check_positive("injection_gain", self.injection_gain))
        if self.injection_gain > 1.0:
            raise ParameterError(f"injection_gain must be in (0, 1], got {self.injection_gain!r}")
        put("input_delay", check_optional_number("input_delay", self.input_delay, low=0.0, unit="s", none="profiled"))
        put("burn", check_finite_scalar("burn", self.burn))
        if self.burn < 0:
            raise ParameterError(f"burn must be >= 0, got {self.burn!r}")
        put("fs_grid", _check_int("fs_grid", self.fs_grid, 3))
        put("fs_max_ratio", check_finite_scalar("fs_max_ratio", self.fs_max_ratio))
        if self.fs_max_ratio <= 1.0:
            raise ParameterError(f"fs_max_ratio must be > 1, got {self.fs_max_ratio!r}")
        put("diff_step", check_positive("diff_step", self.diff_step))
        put("max_nfev", _check_int("max_nfev", self.max_nfev, 1))
        put("n_bootstrap", _check_int("n_bootstrap", self.n_bootstrap, 0))
        put("bootstrap_seed", _check_int("bootstrap_seed", self.bootstrap_seed, 0))
        put("bootstrap_workers", check_optional_number("bootstrap_workers", self.bootstrap_workers, integer=True,
                                                       low=1))
        check_optional("progress", self.progress, (bool, np.bool_), what="True, False")
        if not isinstance(self.lag_profile, (bool, np.bool_)):
            raise ParameterError(f"lag_profile must be True or False, got {self.lag_profile!r}")
        put("lag_profile", bool(self.lag_profile))
        put("bootstrap_lag_refits", check_optional_number("bootstrap_lag_refits", self.bootstrap_lag_refits,
                                                          integer=True, low=1))
        put("start", _check_start(self.start))
        for name, allowed in (("loss", ("linear", "soft_l1")), ("predictor", ("auto", "free-run", "one-step")),
                              ("interp", ("linear", "cubic")), ("bootstrap_refit", BOOTSTRAP_REFITS),
                              ("jacobian", JACOBIANS)):
            if getattr(self, name) not in allowed:
                raise ParameterError(f"{name} must be one of {list(allowed)}, got {getattr(self, name)!r}")
        put("f_scale", check_optional_number("f_scale", self.f_scale, low=0.0, strict=True))
        q = self.bootstrap_input_quantum
        if q is not None and not (isinstance(q, str) and q == "auto"):
            if isinstance(q, str):
                raise ParameterError(f"bootstrap_input_quantum must be a resolution >= 0 N·m, 'auto' or None, "
                                     f"got {q!r}")
            q = check_finite_scalar("bootstrap_input_quantum", q)
            if q < 0:
                raise ParameterError(f"bootstrap_input_quantum must be >= 0 N·m, 'auto' or None, got {q!r}")
            put("bootstrap_input_quantum", float(q))
        if self.bootstrap_input_errors is not None:
            e = np.array(self.bootstrap_input_errors, dtype=float)
            if e.ndim != 2 or e.shape[0] < 1 or not np.all(np.isfinite(e)):
                raise ParameterError(f"bootstrap_input_errors must be a finite (k, N) array with k >= 1, got shape "
                                     f"{e.shape}{'' if np.all(np.isfinite(e)) else ' with non-finite values'}")
            e.setflags(write=False)
            put("bootstrap_input_errors", e)
        if self.bootstrap_shapes is not None:
            put("bootstrap_shapes", _check_shapes(self.bootstrap_shapes))

    def workers(self) -> int:
        """Threads of the bootstrap refits: ``bootstrap_workers``, or (None) the CPUs this process may use
        (:func:`os.sched_getaffinity` where there is one, else :func:`os.cpu_count`), at most ``n_bootstrap``;
        >= 1."""
        if self.bootstrap_workers is not None:
            return self.bootstrap_workers
        cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
        return max(1, min(cpus, self.n_bootstrap))

    @classmethod
    def from_options(cls, options: Mapping) -> "OutputErrorOptions":
        """Build from a ``{name: value}`` mapping (the ``**options`` of :func:`fit_physical`).

        Parameters
        ----------
        options : mapping
            Keys among the fields of this class.

        Returns
        -------
        OutputErrorOptions

        Raises
        ------
        ParameterError
            An unknown key, or a value out of range.
        """
        unknown = set(options) - {f.name for f in fields(cls)}
        if unknown:
            raise ParameterError(f"unknown option(s) for method 'output_error': {sorted(unknown)}")
        return cls(**options)


def _check_int(name: str, value, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ParameterError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def _check_shapes(shapes) -> np.ndarray:
    """``bootstrap_shapes`` as a read-only finite (k, 2) array with ``Vs > 0`` and ``delta != 0``, else
    ParameterError."""
    a = np.array(shapes, dtype=float)
    if a.ndim != 2 or a.shape[0] < 1 or a.shape[1] != 2 or not np.all(np.isfinite(a)) or np.any(a[:, 0] <= 0.0) \
            or np.any(a[:, 1] == 0.0):
        raise ParameterError(f"bootstrap_shapes must be a finite (k, 2) array of (Vs > 0, delta != 0) with k >= 1, "
                             f"got {np.array2string(a, threshold=6)} of shape {a.shape}")
    a.setflags(write=False)
    return a


def _check_start(start) -> dict | None:
    if start is None:
        return None
    if not isinstance(start, Mapping):
        raise ParameterError(f"start must be a dict of J, Fc, Fs, sigma, tau, got {type(start).__name__}")
    missing = {"J", "Fc", "Fs", "sigma", "tau"} - set(start)
    if missing:
        raise ParameterError(f"start is missing {sorted(missing)}")
    start = {k: check_finite_scalar(f"start[{k!r}]", v) for k, v in start.items()}
    check_positive("start['J']", start["J"])
    check_positive("start['tau']", start["tau"])
    return start
