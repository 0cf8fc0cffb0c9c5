"""``adaptive-ff compare``: all friction-compensation modes on one plant, table and figures.

Two processes share the work (Linux, more than one usable CPU): at entry,
once the plant is loaded (numpy and numba imported), the command forks a
helper, a one-worker ``concurrent.futures.ProcessPoolExecutor`` on the
``fork`` start method (:class:`CompareHelper`). While this process imports
the simulation and runs the comparison, the helper imports matplotlib and the
figure code; if the PI designs the comparison will ask
:func:`controllers.design.pi.design_pi` for are not kept from an earlier run
(:func:`design_store`, beside the compiled kernels), it imports
python-control and makes them (handed over by
:func:`controllers.design.pi.remember_designs`; the same function, the same
numbers), so that a warm run neither waits for nor imports python-control.
When the runs are done this process takes from them what the figures show
(:func:`controllers.report.figures.figure_inputs`: well under 1 MB, where the
runs are ~55 MB) and sends it to the helper, which draws the figures (itself
and one forked pool worker, :func:`controllers.report.figures.draw_figures`)
while this process prints the table. Elsewhere, or when the helper fails,
everything runs here as before. The output is the same either way. The
imports run without garbage collections (:func:`imports_without_gc`).
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import json
import sys

__all__ = ["register", "run", "comparison_table", "figure_jobs", "CompareHelper", "design_store"]


def run(args) -> int:
    """Execute ``adaptive-ff compare`` with parsed ``args``; return the exit status (module docstring)."""
    from controllers.cli.data import check_output_dir

    out_dir = args.out if args.out is not None else (args.report or "out")
    if not args.no_figures:
        check_output_dir(out_dir, "--out")
    if args.report:
        check_output_dir(args.report, "--report")
    with imports_without_gc():
        p, modes = _load_plant(args), _modes(args)
        helper = CompareHelper.start(p, args)
        _import_modules(_RUN_MODULES)
    done = False
    try:
        code = _compare_and_print(args, p, modes, out_dir, helper)
        done = True
        return code
    finally:
        if helper is not None:
            helper.close(stop=not done)
        gc.unfreeze()  # a caller that goes on (tests calling main()) collects them again


@contextlib.contextmanager
def imports_without_gc():
    """Import modules without cyclic garbage collections, then keep what they made out of later collections.

    The garbage collector is off inside (imports make few cycles but many
    objects: every collection during them traverses all of them again, ~0.4 s
    CPU for numba, scipy and the package) and on again after it, if it was;
    everything alive at the end is moved to the permanent generation
    (``gc.freeze()``), which later collections, the forked helper's included,
    do not traverse: the pattern the :mod:`gc` documentation gives for a
    process that forks ("call gc.disable() early in the parent process,
    gc.freeze() right before fork(), and gc.enable() early in child
    processes"). ``gc.unfreeze()`` returns the objects to the oldest
    generation.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


def _load_plant(args):
    """The plant of ``adaptive-ff compare`` (``--plant``, ``--variant`` or ``--preset``)."""
    from plant.friction import preset
    from plant.models import load_plant
    from plant.variants import drift_case, variant

    if args.plant:
        p = load_plant(args.plant)
    elif args.variant == "drift":
        p = drift_case(args.duration)
    elif args.variant:
        p = variant(args.variant)
    else:
        p = preset(args.preset)
    return p


def _modes(args) -> tuple:
    """The modes of ``--modes`` (default: all), checked."""
    from controllers.simulation.compensators import MODES
    from plant.errors import ParameterError

    if not args.modes:
        return MODES
    modes = tuple(m.strip() for m in args.modes.split(",") if m.strip())
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise ParameterError(f"--modes: unknown mode(s) {unknown}; known: {list(MODES)}")
    return modes


def _compare_and_print(args, p, modes, out_dir, helper) -> int:
    """The comparison, its figures and report, and the output of :func:`run`."""
    from controllers.design.pi import remember_designs
    from controllers.experiments.compare import compare
    from controllers.report.figures import figure_inputs, plot_comparison
    from adaptive_ff.io.units import parameter_text
    from plant.models import plant_to_dict

    progress = None if not args.quiet else False
    if helper is not None:
        remember_designs(helper.designs())
    comp = compare(p, duration=args.duration, seed=args.seed, modes=modes, Ts=args.Ts, noise_std=args.noise,
                   lam=args.lam, crossover=args.crossover, phase_margin=args.phase_margin, progress=progress,
                   estimator=args.estimator, ff_input=args.ff_input, omega_q=args.omega_q,
                   prefit=not args.no_prefit, Vs=args.Vs, delta=args.delta, J_design=args.J_design,
                   adaptive_start=not args.no_fast_start)
    if args.no_figures:
        paths = []
    elif helper is not None:
        inputs = figure_inputs(comp)
        helper.draw(inputs, out_dir)
        paths = None  # drawn by the helper while the table is printed
    else:
        paths = plot_comparison(comp, out_dir, jobs=figure_jobs())
    if paths is None and (args.report or args.json):
        paths = helper.figures(inputs, out_dir)
    report = None
    if args.report:
        from controllers.cli.data import command_line
        from controllers.report.html import compare_report

        report = compare_report(args.report, comp, figures=paths, command=command_line())
    if args.json:
        d = comp.to_dict()
        d["figures"] = [str(x) for x in paths]
        if report is not None:
            d["report"] = str(report)
        print(json.dumps(d, indent=2))
        return 0
    src = args.plant if args.plant else (f"variant '{args.variant}'" if args.variant else f"preset '{args.preset}'")
    d = comp.design
    print(f"plant: {src}: {parameter_text(plant_to_dict(p))}")
    if hasattr(p, "at"):
        print(f"drift: Fc {p.Fc_change:+.0%}, Fs {p.Fs_change:+.0%} from t = {p.t_start:g} s to {p.t_end:g} s")
    print(f"PI: Kp={d.Kp:.4g} N·m·s/rad, Ki={d.Ki:.4g} N·m/rad, Tc={d.Tc:g} s; "
          f"phase margin {d.phase_margin:.1f} deg, gain margin {d.gain_margin:.3g}")
    print(f"design inertia J_design={comp.J_design:g} kg·m²")
    if comp.prefit is not None:
        fb = comp.prefit.fallback
        kind = "Coulomb + viscous (no Stribeck effect)" if fb == "coulomb-viscous" else f"Vs={comp.prefit.Vs:.4g} " \
            f"rad/s, delta={comp.prefit.delta:.4g}" + (f" ({fb})" if fb else "")
        print(f"Stribeck pre-fit (Sec. V-C): {kind}")
    elif args.Vs is not None:
        print(f"Stribeck factors given: Vs={args.Vs:g} rad/s, delta={args.delta:g} (no pre-fit)")
    for note in comp.notes:
        print(f"note: {note}")
    print(f"run: {args.duration:g} s, seed {args.seed}; metrics over the second half\n")
    print(comparison_table(comp, args))
    if paths is None:
        sys.stdout.flush()
        paths = helper.figures(inputs, out_dir)
    if paths:
        print("\nfigures: " + ", ".join(str(x) for x in paths))
    if report is not None:
        print(f"report: {report}")
    return 0


class CompareHelper:
    """The helper process of ``adaptive-ff compare`` (module docstring): PI designs and figures beside the runs.

    A one-worker ``concurrent.futures.ProcessPoolExecutor`` on the ``fork`` start
    method; the worker ignores Ctrl-C (this process takes it and stops the
    worker) and ends if this process dies
    (:func:`controllers.report.figures.worker_init`). Every request that fails
    in transport (the worker died, the comparison could not be sent) is done in
    this process instead; an error of the work itself (e.g. an output folder
    that cannot be written) is raised here as it would be without the helper.

    The PI designs are kept beside the compiled kernels (:func:`design_store`):
    a warm run reads them there and the helper imports no python-control.
    """

    def __init__(self, pool, keys, stored, figures: bool):
        self._pool, self._keys, self._stored, self._figures = pool, keys, stored, figures
        self._designs = self._drawn = None

    @classmethod
    def start(cls, p, args) -> CompareHelper | None:
        """Fork the helper and give it its first work: the figure code to import, or the PI designs to make.

        With figures, the helper is forked at once (this process has imported
        numpy, numba and the plant): it imports matplotlib and the figure code
        (:data:`_FIGURE_MODULES`) while this process imports the simulation and
        runs the comparison. Without figures, a helper is only started for PI
        designs that are not in :func:`design_store`, after this process has
        imported what both need (:data:`_SHARED_MODULES`).

        Parameters
        ----------
        p : plant model
            The plant of the comparison (only its ``J`` is read, when ``args.J_design`` is None).
        args : argparse.Namespace
            Parsed ``adaptive-ff compare`` arguments (``crossover``, ``phase_margin``, ``J_design``,
            ``no_figures``).

        Returns
        -------
        CompareHelper or None
            None where fork is unavailable (not Linux), only one CPU may be used (:func:`figure_jobs`),
            ``ADAPTIVE_FF_NO_HELPER`` is set or no process can be started: then everything runs in this process.
            With ``--no-figures`` and every design in :func:`design_store`, no process is started (the designs
            are handed over from the store).
        """
        import os

        if not sys.platform.startswith("linux") or figure_jobs() < 2 or os.environ.get("ADAPTIVE_FF_NO_HELPER"):
            return None
        figures = not args.no_figures
        forked = _fork_helper(_import_modules, _FIGURE_MODULES, True) if figures else None
        if figures and forked is None:  # no process left: everything here
            return None
        keys = _design_keys(p, args)
        stored = _stored_designs(keys)
        if figures:
            self = cls(forked[0], keys, stored, True)
            try:
                if stored is None:
                    self._designs = self._pool.submit(_helper_designs, keys)
                self._pool.submit(_helper_prepare, _modes(args), args.estimator)  # after the designs: this waits
            except Exception:  # noqa: BLE001 - a broken pool: :meth:`designs` gives none, designed here
                pass
            return self
        if stored is not None:  # --no-figures, designs kept: nothing left for a helper to do
            return cls(None, keys, stored, False)
        _import_modules(_SHARED_MODULES)
        forked = _fork_helper(_helper_designs, keys)
        if forked is None:
            return None
        self = cls(forked[0], keys, None, False)
        self._designs = forked[1]
        return self

    def designs(self) -> list:
        """The ``(kwargs, PIDesign)`` pairs for :func:`controllers.design.pi.remember_designs`: stored, or made by
        the helper (and then stored); empty if it failed (then :func:`controllers.design.pi.design_pi` designs
        them here)."""
        if self._stored is not None:
            return self._stored
        try:
            pairs = self._designs.result() if self._designs is not None else []
        except Exception:  # noqa: BLE001 - transport failure: design here
            return []
        if len(pairs) == len(self._keys):
            _store_designs(pairs)
        return pairs

    def draw(self, inputs, out_dir) -> None:
        """Send the figures' inputs (:func:`controllers.report.figures.figure_inputs`: well under 1 MB, not the
        runs) to the helper, which writes the figures into ``out_dir`` (:meth:`figures`)."""
        try:
            self._drawn = self._pool.submit(_helper_draw, inputs, str(out_dir), figure_jobs())
        except Exception:  # noqa: BLE001 - broken pool: :meth:`figures` draws here
            self._drawn = None

    def figures(self, inputs, out_dir) -> list:
        """Wait for the figures of :meth:`draw` (of ``inputs``): their paths (drawn here if the helper could not).

        Raises
        ------
        Exception
            What drawing them raised in the helper (a package error, OSError), re-raised here.
        """
        from controllers.report.figures import draw_figures

        outcome = None
        if self._drawn is not None:
            try:
                outcome = self._drawn.result()
            except Exception:  # noqa: BLE001 - transport failure (pickling, a dead worker): draw here
                outcome = None
        if outcome is None:
            return draw_figures(inputs, out_dir, jobs=figure_jobs())
        if isinstance(outcome, BaseException):
            raise outcome
        return outcome

    def close(self, *, stop: bool = False) -> None:
        """Shut the helper down; ``stop`` (an error or Ctrl-C here): drop its queued work.

        The task it is running is not killed but finishes (at most the drawing of its figures): a killed
        helper would leave its own figure worker waiting for work forever (that worker holds the helper's
        end of the pool's pipes, so neither this process nor the worker would see the helper end).
        """
        if self._pool is not None:
            self._pool.shutdown(wait=not stop, cancel_futures=True)


#: Imported before a helper is forked for the PI designs alone (``--no-figures``): both processes need them (the
#: comparison's identification runs filter with scipy.signal, python-control imports it; the designs need
#: scipy.optimize and the PI module), so they are imported once instead of twice.
_SHARED_MODULES = ("numpy", "numba", "scipy.optimize", "scipy.signal", "controllers.design.pi")

#: What this process needs for the comparison (scipy.signal: the identification runs filter their input), imported
#: with the rest (:func:`imports_without_gc`) instead of on first use.
_RUN_MODULES = ("scipy.optimize", "scipy.signal", "controllers.experiments.compare")

#: What the helper imports for the figures while the runs are made (it is sent the figures' inputs: plain numbers
#: and arrays, no package objects).
_FIGURE_MODULES = ("matplotlib.backends.backend_agg", "matplotlib.figure", "controllers.report.figures")


def _fork_helper(task, *task_args):
    """``(pool, future)``: a one-worker process pool on the ``fork`` start method, its worker forked now for its
    first ``task`` (``future``); None if no process can be started. What is alive here is frozen first
    (:func:`imports_without_gc`): the helper's collections then do not touch, and so copy, the pages it shares
    with this process."""
    import multiprocessing
    import warnings
    from concurrent.futures import ProcessPoolExecutor

    from controllers.report.figures import worker_init

    sys.stdout.flush()
    sys.stderr.flush()
    gc.freeze()
    try:
        pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("fork"),
                                   initializer=worker_init)
        with warnings.catch_warnings():  # Python >= 3.12 warns of forking with threads (the pool's own manager)
            warnings.filterwarnings("ignore", message=r".*fork\(\) may lead to deadlocks", category=DeprecationWarning)
            future = pool.submit(task, *task_args)  # the worker is forked at the first submission
    except OSError:
        return None
    return pool, future


def _design_keys(p, args) -> list[dict]:
    """The ``design_pi`` arguments ``compare`` will use: its PI loop and the two loops of the quasi-static runs."""
    from controllers.experiments.compare import CompareOptions
    from controllers.experiments.quasi_static import StribeckDesign

    p0 = p.at(0.0) if hasattr(p, "at") else p
    J = float(p0.J) if args.J_design is None else float(args.J_design)
    Tc, qs = CompareOptions().Tc, StribeckDesign()
    keys = [dict(J=J, sigma=0.0, crossover=float(args.crossover), phase_margin=float(args.phase_margin), Tc=Tc)]
    return keys + [dict(J=J, sigma=0.0, crossover=c, phase_margin=60.0, Tc=Tc) for c in (qs.crossover, qs.crossover_max)]


#: The numbers of a :class:`controllers.design.pi.PIDesign` kept by :func:`design_store` (exact, as float.hex).
_DESIGN_FIELDS = ("Kp", "Ki", "Tc", "crossover", "phase_margin", "gain_margin", "phase_crossover",
                  "stability_margin", "J", "sigma")


def design_store():
    """File of the PI designs kept for ``adaptive-ff compare``, or None (no cache folder).

    Beside the compiled kernels (:func:`plant.jit.cache_dir`, in the folder of the
    package's source digest), so that an edit of the package drops them with the
    kernels; each entry is keyed by the python-control version and the exact
    arguments of :func:`controllers.design.pi.design_pi`, whose result it holds
    exactly (JSON, floats as ``float.hex``).

    Returns
    -------
    pathlib.Path or None
    """
    from plant.jit import cache_dir, source_digest

    base = cache_dir()
    return None if base is None else base / source_digest() / "pi_designs.json"


def _design_key(kwargs) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        ctl = version("control")
    except PackageNotFoundError:
        ctl = "?"
    return f"control {ctl}: " + " ".join(float(kwargs[k]).hex() for k in ("J", "sigma", "crossover", "phase_margin",
                                                                             "Tc"))


def _stored_designs(keys) -> list | None:
    """The ``(kwargs, PIDesign)`` pairs of ``keys`` from :func:`design_store`; None unless every one is there."""
    from controllers.design.pi import PIDesign

    try:
        path = design_store()
        table = json.loads(path.read_text()) if path is not None else {}
        return [(kw, PIDesign(**{f: float.fromhex(table[_design_key(kw)][f]) for f in _DESIGN_FIELDS}))
                for kw in keys]
    except (OSError, ValueError, KeyError, TypeError, AttributeError):  # none, or not readable: the helper designs
        return None


def _store_designs(pairs) -> None:
    """Add ``(kwargs, PIDesign)`` pairs to :func:`design_store` (best effort: a folder that cannot be written is
    skipped; written to a temporary file and renamed, so a concurrent reader never sees half a file)."""
    import os
    import tempfile

    try:
        path = design_store()
        if path is None:
            return
        try:
            table = json.loads(path.read_text())
        except (OSError, ValueError):
            table = {}
        for kw, d in pairs:
            table[_design_key(kw)] = {f: float(getattr(d, f)).hex() for f in _DESIGN_FIELDS}
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            json.dump(table, fh)
        os.replace(tmp, path)
    except (OSError, ValueError, TypeError):
        pass


def _import_modules(modules, collect: bool = False) -> None:
    """Import ``modules`` before they are needed (:func:`imports_without_gc`); ``collect``: then switch the
    garbage collector on (the helper's first task: it is forked while this process imports without collections,
    so it starts with the collector off)."""
    with imports_without_gc():
        for name in modules:
            importlib.import_module(name)
    if collect:
        gc.enable()


#: Parameters of the default sliding estimator (``len(adaptive_ff.compensation.sliding_estimator.SLIDING_NAMES)``,
#: kept equal by a test): written here because importing that module (its compiled kernels) costs the helper more
#: than the skeletons save.
_SLIDING_PARAMETERS = 7


def _helper_prepare(modes, estimator: str) -> None:
    """Helper task, after the figure code is imported and the PI designs are made: the figures' data-free parts,
    made while this process runs the comparison (:func:`controllers.report.figures.prepare_figures`), for the
    layouts this comparison will most likely have: ``none``, ``modes`` and ``frictionless`` (``error``); the sliding
    estimator's parameters (``rls_convergence``). A wrong guess, or a failure here, only costs the helper's idle
    time (the figures are then made as they are drawn)."""
    from controllers.report.figures import prepare_figures, rls_grid

    layouts = {"tracking": None, "error": len(set(modes) | {"none", "frictionless"}), "friction": None, "eta": None}
    if "adaptive" in modes and estimator == "sliding":
        layouts["rls_convergence"] = rls_grid(_SLIDING_PARAMETERS)
    try:
        prepare_figures(layouts)
    except Exception:  # noqa: BLE001 - an optimisation only: the figures are made when drawn
        pass


def _helper_designs(keys) -> list:
    """Helper task: ``design_pi(**kwargs)`` for each of ``keys``; the ``(kwargs, design)`` pairs that succeeded
    (a failing one is designed, and raises, in the parent if the comparison needs it)."""
    from controllers.design.pi import design_pi

    out = []
    for kwargs in keys:
        kw = dict(kwargs)
        try:
            out.append((kwargs, design_pi(kw.pop("J"), **kw)))
        except Exception:  # noqa: BLE001 - see docstring
            pass
    return out


def _helper_draw(inputs, out_dir: str, jobs: int):
    """Helper task: :func:`controllers.report.figures.draw_figures`; its paths, or the exception it raised."""
    from controllers.report.figures import draw_figures

    gc.freeze()  # the inputs and the imported modules: not traversed by every collection while drawing
    try:
        return draw_figures(inputs, out_dir, jobs=jobs)
    except Exception as exc:  # noqa: BLE001 - returned, raised in the parent (CompareHelper.figures)
        return exc


def figure_jobs() -> int:
    """Processes that draw the figures of ``compare``: the CPUs this process may use (at least 1).

    ``os.sched_getaffinity`` where it exists (Linux: honours taskset and
    container CPU sets), else ``os.cpu_count()``; see
    :func:`controllers.report.figures.plot_comparison` (``jobs``).
    """
    import os

    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        n = os.cpu_count() or 1
    return max(1, n)


def comparison_table(comp, args) -> str:
    """The metrics table of a :class:`controllers.experiments.compare.Comparison` in the ``--units`` of ``args``.

    Velocities (RMS, max and reversal RMS of the tracking error over the second
    half) in deg/s or rad/s, the torque RMS in N·m, eta dimensionless; each
    header names its unit. Undefined values (eta without friction degradation)
    print as ``n/a``.
    """
    from controllers.cli.data import table_unit

    k, unit = table_unit(args)
    head = (f"{'mode':<13}{f'RMS [{unit}]':>14}{f'max [{unit}]':>14}{f'reversal RMS [{unit}]':>23}"
            f"{'u RMS [N·m]':>13}{'eta [-]':>9}")
    lines = [head, "-" * len(head)]
    for row in comp.rows():
        eta = row["eta"]
        eta_text = f"{eta:>9.3f}" if eta is not None and eta == eta else f"{'n/a':>9}"
        lines.append(f"{row['mode']:<13}{k * row['rms']:>14.4f}{k * row['max']:>14.4f}"
                     f"{k * row['rms_reversal']:>23.4f}{row['u_rms']:>13.2f}{eta_text}")
    return "\n".join(lines)


def register(sub) -> None:
    """Add the ``compare`` subcommand to an argparse subparsers object."""
    from controllers.cli.data import PRESET_NAMES, add_units_argument, seed_type

    c = sub.add_parser("compare", help="run all compensation modes on a plant and compare tracking error",
                       description="Simulate the 1 kHz plant in closed loop with the PI velocity controller in the "
                                   "modes none, fixed, adaptive, adaptive-dob (adaptive feedforward plus a "
                                   "disturbance observer on its residual), canudas (Canudas de Wit et al. 1987), dob "
                                   "(disturbance observer), oracle and frictionless; print the metrics table and "
                                   "write PNG figures.")
    c.add_argument("--preset", default="paper", choices=PRESET_NAMES,
                   help="named plant parameter set: %(choices)s (default: paper)")
    c.add_argument("--plant", metavar="FILE",
                   help='JSON plant file (SI units): "model" = "lagged-stribeck" (default; J, Fc, Fs, Vs, delta, '
                        'sigma, tau), "lugre" (J, Fc, Fs, Vs, delta, sigma0, sigma1, sigma2), "karnopp" (... tau, dv) '
                        'or "asymmetric" (J, Fc_pos, Fc_neg, Fs_pos, Fs_neg, Vs, delta, sigma_pos, sigma_neg, tau); '
                        'optional "drift": {"Fc_change", "Fs_change", "t_start", "t_end"}')
    c.add_argument("--variant", choices=("lugre", "karnopp", "asymmetric", "small-inertia", "long-lag",
                                         "negative-delta", "static", "drift"),
                   help="a plant variant of the paper preset (drift: Fc, Fs +50%% over the first half)")
    c.add_argument("--modes", help="comma-separated subset of none,fixed,adaptive,adaptive-dob,canudas,dob,oracle,"
                                   "frictionless "
                                   "(default: all; none and frictionless always run)")
    c.add_argument("--estimator", choices=("sliding", "eq4"), default="sliding",
                   help="adaptive estimator: sliding-regime inverse-dynamics RLS (default) or the paper's eq. 4")
    c.add_argument("--ff-input", choices=("measured", "reference"), default="measured",
                   help="velocity the friction feedforward is evaluated at (default: measured)")
    c.add_argument("--omega-q", type=float, default=500.0,
                   help="Q-filter cut-off of the disturbance observer in rad/s (default 500)")
    c.add_argument("--duration", type=float, default=120.0, help="run length in s (default 120)")
    c.add_argument("--seed", type=seed_type, default=0, help="random seed, an integer >= 0 (default 0)")
    c.add_argument("--out", default=None, help="directory for the PNG figures (default: the --report "
                                               "directory, else ./out)")
    c.add_argument("--Ts", type=float, default=0.01, help="estimator update period in s (default 0.01)")
    c.add_argument("--noise", type=float, default=1e-3, help="velocity noise std in rad/s (default 1e-3)")
    c.add_argument("--lam", type=float, default=None,
                   help="RLS forgetting factor per update (default 0.995; 0.999 for canudas)")
    c.add_argument("--crossover", type=float, default=20.0, help="PI crossover in rad/s (default 20)")
    c.add_argument("--phase-margin", type=float, default=60.0, help="PI phase margin in deg (default 60)")
    c.add_argument("--no-prefit", action="store_true",
                   help="do not run the Stribeck pre-fit (then fixed/adaptive need --Vs and --delta)")
    c.add_argument("--no-fast-start", action="store_true",
                   help="adaptive, adaptive-dob: no provisional feedforward from the pre-fit before the estimator's "
                        "first trusted estimate (CompareOptions.adaptive_start = False)")
    c.add_argument("--Vs", type=float, default=None,
                   help="Stribeck velocity in rad/s, if known (with --delta; no pre-fit then)")
    c.add_argument("--delta", type=float, default=None, help="Stribeck shape factor, if known (with --Vs)")
    c.add_argument("--J-design", dest="J_design", type=float, default=None,
                   help="design inertia in kg·m² for the PI, the estimator start, the gates and the DOB "
                        "(default: the plant's J, as a data sheet gives it)")
    c.add_argument("--json", action="store_true", help="print the metrics as JSON instead of the table")
    c.add_argument("--no-figures", action="store_true", help="do not write figures")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    c.add_argument("--report", metavar="DIR", default=None, help="write a self-contained HTML report into DIR")
    add_units_argument(c)
    c.set_defaults(func=run)

