"""Work bounded up front: the time and memory a command's options ask for, estimated before it starts.

Every option that scales a command's work (``compare --duration``, ``identify --bootstrap`` and ``--folds`` on
the log's samples, ``design --step-duration``, ``paper-figures --sim-duration``/``--exp-duration``/``--speeds``,
the cases of a ``sweep`` spec, the joints of the zoo) is turned into an estimate of the wall time and the peak
memory (:class:`WorkEstimate`) before any work is done. Beyond :data:`TIME_LIMIT` (10 minutes) or
:data:`MEMORY_LIMIT` (4 GiB) the command refuses with exit status 2 and says what the run would cost, e.g.::

    adaptive-ff: error: --bootstrap 1000000000 on 60,001 samples (method sliding): about 38.6 h and 1.86 TiB
    (limits 10 min, 4 GiB); pass --yes to run it anyway

``--yes`` runs it anyway (a run that does not fit into the memory available is still refused:
:mod:`controllers.simulation.memory`).

The estimates are the per-unit costs below times the units of work, measured on the project's 2-core
development machine (``python benchmarks/work_costs.py`` measures them again on yours); they are meant to tell
seconds from hours, not to predict a run to the second (a loaded machine is slower, a fit that converges early
faster). Costs per sample are per sample of the signal at its own rate (1 kHz in the simulations).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from plant.errors import ParameterError

__all__ = ["TIME_LIMIT", "MEMORY_LIMIT", "OE_FIT_SIMULATIONS", "OE_REFIT_SHARE", "WorkEstimate", "WorkLimitError", "check_work", "add_yes_argument",
           "compare_runs", "compare_estimate", "identify_estimate", "design_estimate", "paper_figures_estimate",
           "sweep_estimate", "zoo_estimate", "COSTS"]

#: Wall time (s) beyond which a command asks for ``--yes``.
TIME_LIMIT = 600.0
#: Peak memory (bytes) beyond which a command asks for ``--yes``.
MEMORY_LIMIT = 4 * 2**30

#: Per-unit costs (seconds; bytes), ``python benchmarks/work_costs.py``:
#:
#: ``loop``: one closed-loop run of one mode, per sample (the C engine, with its recording);
#: ``prepare``: a comparison's preparation (the identification run behind ``fixed`` and the adaptive start), per
#: sample; ``compare_fixed``: a comparison's fixed part (the Stribeck pre-fit's quasi-static runs, the designs);
#: ``step``: ``design``'s step response, per sample; ``step_bytes``: its memory per sample;
#: ``paper_sim``/``paper_exp``: ``paper-figures``' open-loop simulation and closed-loop experiment, per sample;
#: ``paper_speed``: one quasi-static speed of its Fig. 8;
#: ``eq4``: the eq. 4 LS/RLS fit (``paper``) and the sliding regression, per sample (reading the file included);
#: ``linear_refit``: one refit of their residual bootstrap, per sample; ``refit_bytes``: the memory a replicate
#: keeps (its parameters and its friction curve on the band's grid);
#: ``output_error``/``closed_loop``: one output-error fit (or bootstrap refit) of the physical parameters, per
#: sample (``output_error`` as measured by benchmarks/output_error_speed.py, 3.4 s of CPU per fit of a
#: 20 k-sample log, with a margin; a bootstrap refit costs :data:`OE_REFIT_SHARE` of it); ``form``: one fit of
#: a candidate form in ``--form``, per sample.
COSTS = {"loop": 2.7e-7, "prepare": 6e-7, "compare_fixed": 0.3, "step": 1.5e-5, "step_bytes": 130.0,
         "paper_sim": 3e-6, "paper_exp": 4e-6, "paper_speed": 0.02, "eq4": 8e-5, "linear_refit": 1e-8,
         "refit_bytes": 2000.0, "output_error": 2.5e-4, "closed_loop": 6e-3, "form": 8e-4}

#: Simulations of the record in one output-error fit (its staged search, the profiles over tau and over the input
#: delay included, and the Jacobian of its HAC errors), whatever the record's length: 1600-2070 measured on 5-20 s
#: of the open-loop log of benchmarks/output_error_speed.py (``physical.info["n_simulations"]``).
OE_FIT_SIMULATIONS = 2000
#: A bootstrap refit's share of a fit, by ``--bootstrap-refit`` (measured on the same logs,
#: ``info["bootstrap"]["n_simulations"]``): ``full`` runs the fit's own search on the replicate with the fit's input
#: delay held (its delay profile one point instead of the fit's grid) and its profile over tau screened
#: (``bootstrap_lag_refits=2``: 0.47 of the fit's simulations a refit on the 20 s log), ``partial`` the fit's later
#: steps from a spread start (182-197 simulations: 0.09-0.12). The closed-loop fit's refits are that fit again
#: (:data:`CLOSED_LOOP_REFIT_SHARE`).
OE_REFIT_SHARE = {"full": 0.5, "partial": 0.12}
#: A full bootstrap refit's share of the closed-loop fit (the fit again).
CLOSED_LOOP_REFIT_SHARE = 1.0

#: Default bootstrap refits of each identification method (``identify --bootstrap``'s help).
_DEFAULT_BOOTSTRAP = {"paper": 200, "sliding": 200, "idim": 200, "output_error": 20, "closed_loop": 10}
#: Candidate forms of ``identify --form`` (adaptive_ff.identification.model_forms.FORMS).
_N_FORMS = 6


@dataclass(frozen=True)
class WorkEstimate:
    """What a command's options ask for: ``what`` (the options and the units of work, for the message), about
    ``seconds`` of wall time and ``bytes`` of peak memory; ``simulations``: the simulations of the record the
    output-error fits run (:data:`OE_FIT_SIMULATIONS` a fit), 0 where none (the count the estimate rests on)."""

    what: str
    seconds: float
    bytes: float
    simulations: float = 0.0

    def __add__(self, other: WorkEstimate) -> WorkEstimate:
        return WorkEstimate(f"{self.what}, {other.what}", self.seconds + other.seconds, max(self.bytes, other.bytes),
                            self.simulations + other.simulations)


class WorkLimitError(ParameterError):
    """A command's estimated work is beyond :data:`TIME_LIMIT` or :data:`MEMORY_LIMIT` and ``--yes`` was not
    given."""


def _duration_text(s: float) -> str:
    if s < 120:
        return f"{s:.3g} s"
    if s < 2 * 3600:
        return f"{s / 60:.3g} min"
    if s < 3 * 86400:
        return f"{s / 3600:.3g} h"
    if s < 3 * 365 * 86400:
        return f"{s / 86400:.3g} days"
    return f"{s / (365.25 * 86400):.3g} years"


def _bytes_text(b: float) -> str:
    if not math.isfinite(b):
        return "unbounded memory"
    for unit, scale in (("EiB", 2**60), ("PiB", 2**50), ("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20)):
        if b >= scale:
            return f"{b / scale:.3g} {unit}"
    return f"{b / 1024:.3g} KiB"


def check_work(estimate: WorkEstimate, *, yes: bool, time_limit: float = TIME_LIMIT,
               memory_limit: float = MEMORY_LIMIT) -> None:
    """Refuse an estimated run beyond the limits unless ``yes``.

    Parameters
    ----------
    estimate : WorkEstimate
        What the options ask for.
    yes : bool, keyword-only
        ``--yes`` was given: run it anyway.
    time_limit, memory_limit : float, keyword-only
        Seconds and bytes (default :data:`TIME_LIMIT`, :data:`MEMORY_LIMIT`).

    Raises
    ------
    WorkLimitError
        ``"<options>: about <time> and <memory> (limit ...); pass --yes to run it anyway"``.
    """
    over = []
    if not estimate.seconds <= time_limit:
        over.append(_duration_text(time_limit))
    if not estimate.bytes <= memory_limit:
        over.append(_bytes_text(memory_limit))
    if not over or yes:
        return
    limit = f"limit {over[0]}" if len(over) == 1 else f"limits {', '.join(over)}"
    cost = (f"about {_duration_text(estimate.seconds)} and {_bytes_text(estimate.bytes)}"
            if math.isfinite(estimate.seconds) else f"a run without end and {_bytes_text(estimate.bytes)}")
    raise WorkLimitError(f"{estimate.what}: {cost} ({limit}); pass --yes to run it anyway")


def add_yes_argument(parser) -> None:
    """Add ``--yes`` to a subcommand whose options scale its work (:func:`check_work`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The subcommand's parser.
    """
    parser.add_argument("--yes", action="store_true",
                        help=f"run even if the options ask for more than {_duration_text(TIME_LIMIT)} or "
                             f"{_bytes_text(MEMORY_LIMIT)} (estimated before the start; without it the command "
                             "says what the run would cost and stops)")


def _samples(duration: float, Tc: float) -> float:
    """Samples of ``duration`` s at ``Tc`` (inf for a non-finite duration; 0 for a bad one: checked elsewhere)."""
    if not (isinstance(duration, (int, float)) and duration > 0 and Tc > 0):
        return 0.0
    return duration / Tc if math.isfinite(duration) else math.inf


def _count(n: float) -> str:
    if not math.isfinite(n):
        return "infinitely many"
    return f"{n:,.0f}" if n < 1e7 else f"{n:.3g}"


def compare_runs(modes, *, estimator_rows=(), compensators=(), adaptive_start: bool = True) -> tuple[int, bool]:
    """The recorded runs of a comparison and whether it makes the identification run (as
    :meth:`controllers.experiments.compare.CompareOptions.check_memory` counts them).

    Parameters
    ----------
    modes : iterable of str
        The modes asked for (``none`` and ``frictionless`` always run).
    estimator_rows : iterable of str, keyword-only
        Further adaptive rows.
    compensators : iterable of str, keyword-only
        Names of your own compensators.
    adaptive_start : bool, keyword-only
        The adaptive modes start from the pre-fit (their identification run).

    Returns
    -------
    (int, bool)
    """
    rows = tuple(estimator_rows or ())
    run = set(modes) | {"none", "frictionless"} | set(compensators or ()) | {f"adaptive[{e}]" for e in rows}
    adaptive = bool(run & {"adaptive", "adaptive-dob"} or rows)
    return len(run), "fixed" in run or (adaptive_start and adaptive)


def compare_estimate(duration: float, n_modes: int, *, identification: bool = True, Tc: float = 1e-3,
                     what: str | None = None) -> WorkEstimate:
    """The work of one comparison: ``n_modes`` closed-loop runs of ``duration`` s and the preparation.

    Parameters
    ----------
    duration : float
        Run length (s).
    n_modes : int
        Recorded runs (the modes, ``none`` and ``frictionless`` included, and the estimator rows).
    identification : bool, keyword-only
        The preparation's identification run is made (``fixed`` or an adaptive mode with its start).
    Tc : float, keyword-only
        Controller period (s), default 1 ms.
    what : str, keyword-only
        The options for the message (default ``--duration D``).

    Returns
    -------
    WorkEstimate
    """
    from controllers.simulation.memory import MODE_SIGNALS, PREPARATION_SIGNALS, SHARED_SIGNALS, run_bytes

    n = _samples(duration, Tc)
    seconds = COSTS["compare_fixed"] + n * (COSTS["loop"] * n_modes + (COSTS["prepare"] if identification else 0.0))
    signals = max(SHARED_SIGNALS + MODE_SIGNALS * n_modes, PREPARATION_SIGNALS if identification else 0)
    memory = math.inf if not math.isfinite(n) else float(run_bytes(int(n), signals))
    text = what or f"--duration {duration:g}"
    return WorkEstimate(f"{text} ({_count(n)} samples, {n_modes} runs)", seconds, memory)


def identify_estimate(n_samples: int, method, *, bootstrap: int | None = None, refit: str | None = None,
                      folds: int | None = None, workers: int | None = None) -> WorkEstimate:
    """The work of ``identify`` on a log of ``n_samples`` samples.

    Parameters
    ----------
    n_samples : int
        Samples of the log.
    method : str or tuple of str
        The method that runs (``auto`` resolved): ``paper``, ``sliding``, ``idim``, ``output_error`` or
        ``closed_loop``; or the methods ``auto`` may run one after the other
        (:func:`adaptive_ff.identification.identify.auto_methods`, e.g. ``("sliding", "output_error")``: the
        sliding regression, then the output-error fit where the record is open loop and the regression's own
        simulation-extrapolation finds J or tau biased), each counted.
    bootstrap : int or None, keyword-only
        ``--bootstrap`` (None: each method's default).
    refit : str or None, keyword-only
        ``--bootstrap-refit`` (``partial``: :data:`OE_REFIT_SHARE` of a fit per refit).
    folds : int or None, keyword-only
        ``--folds`` of ``--form`` (None: no form selection).
    workers : int or None, keyword-only
        CPUs the output-error refits run on (default: this process's).

    Returns
    -------
    WorkEstimate
        With ``simulations``: the output-error fit's and its refits' simulations
        (:data:`OE_FIT_SIMULATIONS` times ``1 + refits * share``).
    """
    n = float(n_samples)
    methods = (method,) if isinstance(method, str) else tuple(method)
    seconds = COSTS["eq4"] * n
    memory = 64.0 * n  # the log, its uniform copy and the regressors
    if folds is not None:
        fits = _N_FORMS * (folds + 1)
        seconds += COSTS["form"] * n * fits
        return WorkEstimate(f"--folds {folds} on {_count(n)} samples ({fits} fits)", seconds, memory)
    given = bootstrap is not None
    sims, texts = 0.0, []
    for m in methods:
        b = _DEFAULT_BOOTSTRAP.get(m, 0) if bootstrap is None else int(bootstrap)
        texts.append(f"{m} {b}")
        if m in ("paper", "sliding", "idim"):
            seconds += COSTS["linear_refit"] * n * b
            memory += COSTS["refit_bytes"] * b
        elif m in ("output_error", "closed_loop"):
            share = OE_REFIT_SHARE["partial" if refit == "partial" else "full"]
            if m == "closed_loop" and refit != "partial":
                share = CLOSED_LOOP_REFIT_SHARE
            cpus = (workers or _cpus()) if m == "output_error" else 1
            seconds += COSTS[m] * n * (1.0 + b * share / cpus)
            memory += COSTS["refit_bytes"] * b
            if m == "output_error":
                sims += OE_FIT_SIMULATIONS * (1.0 + b * share)
    if len(methods) == 1:
        b = texts[0].split()[-1]
        text = f"--bootstrap {b}{'' if given else ' (default)'} on {_count(n)} samples (method {methods[0]})"
    else:
        boot = f"--bootstrap {bootstrap}" if given else f"the default bootstraps ({', '.join(texts)})"
        text = (f"{boot} on {_count(n)} samples (method auto: {' then '.join(methods)}, the {methods[-1]} fit "
                f"where the {methods[0]} regression is biased on this open-loop log; --method {methods[0]} keeps "
                "it)")
    return WorkEstimate(text, seconds, memory, sims)


def _cpus() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def design_estimate(step_duration: float, Tc: float, *, what: str) -> WorkEstimate:
    """The work of ``design``'s step response over ``step_duration`` s at the period ``Tc``.

    Parameters
    ----------
    step_duration : float
        Length of the step response (s).
    Tc : float
        Controller period (s).
    what : str
        The options for the message.

    Returns
    -------
    WorkEstimate
    """
    n = _samples(step_duration, Tc)
    return WorkEstimate(f"{what} ({_count(n)} samples)", COSTS["step"] * n, COSTS["step_bytes"] * n)


def paper_figures_estimate(sim_duration: float, exp_duration: float, speeds: int) -> WorkEstimate:
    """The work of ``paper-figures``: the open-loop simulation, the closed-loop experiment and the quasi-static
    speeds.

    Parameters
    ----------
    sim_duration, exp_duration : float
        ``--sim-duration`` and ``--exp-duration`` (s).
    speeds : int
        ``--speeds``.

    Returns
    -------
    WorkEstimate
    """
    from controllers.simulation.memory import PREPARATION_SIGNALS, run_bytes

    n_sim, n_exp = _samples(sim_duration, 1e-3), _samples(exp_duration, 1e-3)
    seconds = COSTS["paper_sim"] * n_sim + COSTS["paper_exp"] * n_exp + COSTS["paper_speed"] * max(speeds, 0)
    n = max(n_sim, n_exp)
    memory = math.inf if not math.isfinite(n) else float(run_bytes(int(n), PREPARATION_SIGNALS))
    return WorkEstimate(f"--sim-duration {sim_duration:g}, --exp-duration {exp_duration:g}, --speeds {speeds}",
                        seconds, memory)


def sweep_estimate(cases, workers: int | None = None) -> WorkEstimate:
    """The work of a sweep: each case a comparison (:func:`compare_estimate`), spread over ``workers`` processes.

    Parameters
    ----------
    cases : sequence of dict
        The cases still to run (:func:`controllers.experiments.sweep.expand_cases`): ``duration`` and ``modes``.
    workers : int or None, keyword-only
        Worker processes (default: the CPUs).

    Returns
    -------
    WorkEstimate
        The memory of the largest case times the workers.
    """
    w = workers or _cpus()
    seconds, memory = 0.0, 0.0
    for case in cases:
        n_runs, ident = compare_runs(case.get("modes") or ())
        e = compare_estimate(float(case.get("duration", 0.0)), n_runs, identification=ident)
        seconds += e.seconds
        memory = max(memory, e.bytes)
    n = len(cases)
    return WorkEstimate(f"{n:,} cases on {w} worker(s)", seconds / min(w, max(n, 1)), memory * min(w, max(n, 1)))


def zoo_estimate(n: int, duration: float, n_modes: int, workers: int | None = None) -> WorkEstimate:
    """The work of the zoo (``benchmarks/zoo.py``): ``n`` joints, each prepared and run in ``n_modes`` modes.

    Parameters
    ----------
    n : int
        Joints (``--n``).
    duration : float
        Run length (s).
    n_modes : int
        Modes run per joint.
    workers : int or None, keyword-only
        Worker processes (default: the CPUs).

    Returns
    -------
    WorkEstimate
    """
    w = workers or _cpus()
    e = compare_estimate(duration, n_modes)
    par = min(w, max(int(n), 1))
    return WorkEstimate(f"--n {n} --duration {duration:g} ({n_modes} modes, {w} worker(s))",
                        e.seconds * n / par, e.bytes * par)
