"""The paper's figures regenerated from the simulation (Figs. 4, 5, 7-12), and the same kinds of figures for any log.

Experiments, following Ruderman's paper on the simulated joint (``paper`` preset by default):

* **Sec. IV-A/B, Figs. 4, 5** — open loop, low-pass band-limited white-noise
  torque, 1 kHz RK4 plant, sampled every 10 ms; offline LS fit of eq. 4 (Fig. 4:
  simulated vs LS model velocity) and RLS from ``theta = 0`` on the same data
  (Fig. 5: simulated vs RLS a-priori predicted velocity).
* **Sec. V-C, Fig. 8** — bidirectional constant-velocity runs
  (:func:`controllers.experiments.quasi_static.quasi_static_runs`) and the
  Levenberg-Marquardt Stribeck fit (:func:`adaptive_ff.identification.stribeck_fit.fit_stribeck`);
  its ``Vs``, ``delta`` fix the regression model of every other figure.
* **Sec. V-B/D/E, Figs. 7, 9-12** — a stiff PI velocity loop (200 rad/s
  crossover, like an industrial robot's) tracks a 0.01-1 Hz multi-sine
  reference (up to 20 deg/s, frequent reversals; the joint is stuck below
  0.2 deg/s only a few per cent of the time, :func:`joint_motion`); torque and
  velocity are read out at irregular instants (Fig. 10: about 22 ms mean,
  outliers up to twice that), with velocity noise and torque quantisation
  (Fig. 7). Offline LS on the irregular samples as they are, with
  ``Ts`` = their mean (Fig. 9), and RLS with ``lam = 0.85`` as in the paper
  (Fig. 11: velocity, Fig. 12: parameter convergence, windup bursts shown,
  not clipped). Fig. 7 is the read-out torque with close-ups of its
  quantisation steps and uneven time grid. Axes in rad/s, or deg/s as in the
  paper (``PaperFigureOptions(units="deg")``).

The plotting functions (:mod:`controllers.experiments.paper_plots`, re-exported here) take plain arrays, so
:func:`identification_figures` draws the same figures for a measured log identified by
:func:`adaptive_ff.identification.identify.identify`.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from adaptive_ff.identification.ls import fit_ls
from adaptive_ff.identification.regression import RegressionModel, nrmse_fit
from adaptive_ff.identification.rls import RecursiveLeastSquares
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers.experiments.paper_plots import (AXIS_UNITS, plot_input_torque, plot_parameter_convergence,
                                                 plot_sample_times, plot_stribeck_figure, plot_velocity_fit)
from controllers.experiments.quasi_static import bidirectional_velocities, quasi_static_runs
from controllers.experiments.synthetic_logs import (closed_loop_readout, encoder_counts, quasi_static_log,
                                                    write_controller_log, write_log_csv)
from plant.errors import ParameterError, check_nonnegative, check_positive, check_signal
from plant.excitation import bandlimited_noise
from plant.friction import JointParams, preset
from plant.joint import simulate
from plant.results import json_safe
from plant.sampling import sample

if TYPE_CHECKING:  # annotations only: matplotlib is imported by the plotting functions when they run
    from matplotlib.figure import Figure

__all__ = [
    "MAX_SPEEDS",
    "PaperFigures",
    "PaperFigureOptions",
    "paper_figures",
    "rls_pass",
    "plot_velocity_fit",
    "plot_sample_times",
    "plot_parameter_convergence",
    "plot_stribeck_figure",
    "plot_input_torque",
    "joint_motion",
    "AXIS_UNITS",
    "identification_figures",
    "save_figures",
    "FIGURE_CAPTIONS",
    "DEMO_CURRENT_TO_TORQUE",
    "DEMO_COUNTS_PER_REV",
]

#: Captions of the regenerated figures (keys are the output file stems).
FIGURE_CAPTIONS = {
    "fig04_ls_simulation": "Fig. 4: simulated and offline (LS) estimated output velocity",
    "fig05_rls_simulation": "Fig. 5: simulated and online (RLS) estimated output velocity",
    "fig07_input_torque": "Fig. 7: applied input joint torque signal with close-up views",
    "fig08_stribeck": "Fig. 8: Stribeck curve from bidirectional quasi-static drive experiments",
    "fig09_ls_experiment": "Fig. 9: measured and offline identified joint velocity",
    "fig10_sample_time": "Fig. 10: evaluated sample time of the identification experiment",
    "fig11_rls_experiment": "Fig. 11: measured and online identified joint velocity",
    "fig12_rls_parameters": "Fig. 12: parameter convergence of RLS identification",
}

#: Torque constant (N·m/A, joint side) of the demonstration log: 0.5 N·m/A motor constant times gear ratio 120.
DEMO_CURRENT_TO_TORQUE = 60.0
#: Encoder resolution (counts per joint revolution) of the demonstration log: 2**14 per motor turn times 120.
DEMO_COUNTS_PER_REV = 2**14 * 120


def joint_motion(w, *, stuck_below: float = math.radians(0.2)) -> dict:
    """How a joint moved: share of time stuck, speed range and motion reversals.

    Parameters
    ----------
    w : array_like, shape (N,)
        Joint velocity (rad/s) on a uniform time grid.
    stuck_below : float, keyword-only
        Speed (rad/s) below which the joint counts as stuck, > 0; default 0.2 deg/s.

    Returns
    -------
    dict
        ``stuck_fraction`` (share of samples with ``|w| < stuck_below``),
        ``speed_p05``, ``speed_p95``, ``speed_max`` (percentiles and maximum of
        ``|w|`` while moving, rad/s) and ``reversals`` (sign changes between
        samples moving faster than ``stuck_below``, so noise while stuck does
        not count).

    Raises
    ------
    SignalError
        ``w`` empty or not finite.
    """
    w = check_signal("w", w)
    thr = check_positive("stuck_below", stuck_below)
    a = np.abs(w)
    moving = a >= thr
    sgn = np.sign(w[moving])
    sp = a[moving] if moving.any() else np.zeros(1)
    return {"stuck_fraction": float(np.mean(~moving)), "speed_p05": float(np.percentile(sp, 5)),
            "speed_p95": float(np.percentile(sp, 95)), "speed_max": float(sp.max()),
            "reversals": int(np.count_nonzero(sgn[1:] != sgn[:-1]))}


# --------------------------------------------------------------------------- RLS pass


def rls_pass(model: RegressionModel, u, w, *, lam: float = 1.0, P0: float = 1e4):
    """Run RLS (eqs. 10-13) from ``theta = 0`` over a record and keep its a-priori predictions.

    Parameters
    ----------
    model : RegressionModel
        Regression structure (eq. 4).
    u, w : array_like, shape (N,)
        Input torque (N·m) and velocity (rad/s), sampled in order.
    lam : float, keyword-only
        Forgetting factor in (0, 1].
    P0 : float, keyword-only
        Initial covariance ``P0*I``, > 0 ("large", as in the paper).

    Returns
    -------
    w_pred : ndarray, shape (N,)
        A-priori prediction ``phi(k) @ theta(k-1)`` (rad/s); the first two
        entries are the measured ``w[0], w[1]``.
    theta : ndarray, shape (N - 2, p)
        Estimate after each update.

    Raises
    ------
    SignalError
        Bad ``u``, ``w``.
    ParameterError
        Bad ``lam`` or ``P0``.

    Notes
    -----
    :class:`adaptive_ff.identification.rls.RecursiveLeastSquares` over the rows of
    ``model.regressors(u, w)``; Ruderman, Sec. IV-B.
    """
    X, y = model.regressors(u, w)
    rls = RecursiveLeastSquares(model.n_params, lam=lam, P0=P0)
    w_pred = np.asarray(w, dtype=float).reshape(-1).copy()
    hist = np.empty((X.shape[0], model.n_params))
    for i in range(X.shape[0]):
        e = rls.update(X[i], y[i])
        w_pred[i + 2] = y[i] - e
        hist[i] = rls.theta
    return w_pred, hist


# --------------------------------------------------------------------------- the paper's figures


#: Most quasi-static speeds per direction of Fig. 8 (``--speeds``): each is a run of a few seconds.
MAX_SPEEDS = 10_000


@dataclass(frozen=True, kw_only=True)
class PaperFigureOptions:
    """Settings of the experiments behind :func:`paper_figures` (keyword-only, validated).

    Parameters
    ----------
    seed : int
        Seed of all random draws (excitation, reference, sample times, noise), >= 0.
    sim_duration : float
        Length (s) of the open-loop simulation experiment (Figs. 4, 5), >= 2.
    exp_duration : float
        Length (s) of the closed-loop "robot" experiment (Figs. 9-12), >= 2.
    n_speeds : int
        Quasi-static speeds per direction (Fig. 8), 3 to :data:`MAX_SPEEDS`, log-spaced from
        ``0.2*Vs`` to 0.4 rad/s.
    noise_std : float
        Velocity measurement noise (rad/s), >= 0, of the quasi-static runs and the
        closed-loop experiment (the open-loop simulation is noise-free, as in Sec. IV).
    quantization : float
        Torque quantisation step (N·m), >= 0, of the closed-loop experiment's readout (Fig. 7).
    lam_sim, lam_exp : float
        RLS forgetting factors in (0, 1] of Fig. 5 and of Figs. 11-12 (paper: 0.85).
    P0 : float
        RLS initial covariance scale, > 0.
    crossover : float
        Gain crossover (rad/s) of the PI velocity loop of the closed-loop experiment, > 0; default 200,
        a stiff loop like an industrial robot's, so the joint moves like the paper's (1-20 deg/s, frequent
        reversals, rarely stuck; a 20 rad/s loop leaves the joint stuck about 40 % of the time).
    units : {"rad", "deg"}
        Velocity unit on the figures' axes: rad/s (SI, default) or deg/s as in the paper. The numbers
        (:attr:`PaperFigures.numbers`) stay SI.

    Raises
    ------
    ParameterError
        A setting out of range (the message names it).
    TypeError
        ``seed`` or ``n_speeds`` not an integer, another setting not a real number.
    """

    seed: int = 0
    sim_duration: float = 30.0
    exp_duration: float = 60.0
    n_speeds: int = 10
    noise_std: float = 1e-3
    quantization: float = 0.6
    lam_sim: float = 0.995
    lam_exp: float = 0.85
    P0: float = 1e4
    crossover: float = 200.0
    units: str = "rad"

    def __post_init__(self):
        for name in ("seed", "n_speeds"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise TypeError(f"{name} must be an integer, got {v!r} ({type(v).__name__})")
        if self.seed < 0:
            raise ParameterError(f"seed must be >= 0, got {self.seed!r}")
        if not 3 <= self.n_speeds <= MAX_SPEEDS:
            raise ParameterError(f"n_speeds must be an integer in 3..{MAX_SPEEDS}, got {self.n_speeds!r}")
        for name in ("sim_duration", "exp_duration"):
            if check_positive(name, getattr(self, name)) < 2.0:
                raise ParameterError(f"{name} must be >= 2 s, got {getattr(self, name)!r}")
        check_nonnegative("noise_std", self.noise_std)
        check_nonnegative("quantization", self.quantization)
        for name in ("lam_sim", "lam_exp"):
            if not 0.0 < check_positive(name, getattr(self, name)) <= 1.0:
                raise ParameterError(f"{name} must be in (0, 1], got {getattr(self, name)!r}")
        check_positive("P0", self.P0)
        check_positive("crossover", self.crossover)
        if self.units not in AXIS_UNITS:
            raise ParameterError(f"units must be one of {sorted(AXIS_UNITS)}, got {self.units!r}")
        for name in ("seed", "n_speeds"):
            object.__setattr__(self, name, int(getattr(self, name)))
        for name in ("sim_duration", "exp_duration", "noise_std", "quantization", "lam_sim", "lam_exp", "P0",
                     "crossover"):
            object.__setattr__(self, name, float(getattr(self, name)))

    def to_dict(self) -> dict:
        """The settings as strict JSON (SI units)."""
        return json_safe(asdict(self))


@dataclass(frozen=True)
class PaperFigures:
    """Result of :func:`paper_figures`.

    Attributes
    ----------
    out_dir : Path
        Where the files are.
    figures : dict
        ``{stem: Path}`` of the PNG files (stems as in :data:`FIGURE_CAPTIONS`).
    captions : dict
        ``{stem: caption}``.
    numbers : dict
        Numbers behind the figures (SI units): fits (%), estimates, Stribeck
        parameters, sample-time statistics, settings.
    data_files : dict
        ``{name: Path}`` of the demonstration logs (with ``save_data=True``).
    """

    out_dir: Path
    figures: dict
    captions: dict
    numbers: dict
    data_files: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """Strict JSON: ``{"summary": numbers, "figures": {stem: path}, "data_files": {name: path}}``."""
        return json_safe({"summary": self.numbers, "figures": self.figures, "data_files": self.data_files})

    #: Same as :meth:`to_dict` (the older name).
    to_json_dict = to_dict

    def summary(self) -> str:
        """A few lines: the Stribeck fit and the LS/RLS fits of both experiments, and where the files are."""
        st, sim, ex = self.numbers["stribeck"], self.numbers["simulation"], self.numbers["experiment"]
        return "\n".join([
            f"Fig. 8  Stribeck fit: Fc={st['Fc']:.4g} N·m, Fs={st['Fs']:.4g} N·m, Vs={st['Vs']:.4g} rad/s, "
            f"delta={st['delta']:.4g}, sigma={st['sigma']:.4g} N·m·s/rad ({st['n_points']} runs)",
            f"Figs. 4, 5  simulation: LS fit one-step {sim['ls_fit_one_step']:.2f} %, free run "
            f"{sim['ls_fit_free_run']:.2f} %; RLS a-priori {sim['rls_fit']:.2f} %",
            f"Figs. 9-12  experiment (mean Ts {ex['Ts_mean'] * 1e3:.2f} ms): "
            f"LS one-step {ex['ls_fit_one_step']:.2f} %, free run {ex['ls_fit_free_run']:.2f} %; RLS a-priori {ex['rls_fit']:.2f} %",
            f"{len(self.figures)} figures in {self.out_dir}",
        ])


def _estimate_dict(est) -> dict:
    return {k: float(getattr(est, k)) for k in ("J", "tau", "sigma", "Fc", "Fs")}


def _fig8_stribeck(p: JointParams, opt: PaperFigureOptions, qs_ss) -> tuple:
    """Sec. V-C: quasi-static runs and the LM Stribeck fit; returns ``(velocities, model, figure, numbers)``."""
    vel = bidirectional_velocities(0.2 * p.Vs, 0.4, opt.n_speeds)
    qs = quasi_static_runs(p, vel, noise_std=opt.noise_std, rng=np.random.default_rng(qs_ss))
    sfit = fit_stribeck(qs.w_mean, qs.u_mean)
    fig = plot_stribeck_figure(sfit, qs.w_mean, qs.u_mean, F_std=qs.u_std, title=FIGURE_CAPTIONS["fig08_stribeck"],
                               units=opt.units)
    numbers = {**sfit.params(), "stderr": dict(sfit.stderr), "n_points": sfit.n_points}
    return vel, RegressionModel(sfit.Vs, sfit.delta, lag=True), fig, numbers


def _figs45_simulation(p: JointParams, opt: PaperFigureOptions, model: RegressionModel, sim_ss, Tc: float,
                       peak: float) -> tuple[dict, dict]:
    """Sec. IV: open-loop band-limited-noise run sampled at 10 ms, LS and RLS; returns ``(figures, numbers)``."""
    Ts_sim = 0.01
    _, u_id = bandlimited_noise(opt.sim_duration, dt=Tc, cutoff=1.0,
                                std=1.2 * (max(p.Fs, p.Fc) + p.sigma * peak), rng=np.random.default_rng(sim_ss))
    meas_sim = sample(simulate(p, u_id, dt=Tc), Ts=Ts_sim)
    ls_sim = fit_ls(model, meas_sim.u, meas_sim.w, Ts=Ts_sim)
    figs = {"fig04_ls_simulation": plot_velocity_fit(
        meas_sim.t, meas_sim.w, (ls_sim.w_free_run, "LS model, free run", ls_sim.fit_free_run),
        model2=(ls_sim.w_one_step, "LS model, one-step prediction", ls_sim.fit_one_step),
        measured_label="simulated (1 kHz RK4, sampled at 10 ms)", title=FIGURE_CAPTIONS["fig04_ls_simulation"], units=opt.units)}
    w_rls_sim, th_sim = rls_pass(model, meas_sim.u, meas_sim.w, lam=opt.lam_sim, P0=opt.P0)
    fit_rls_sim = nrmse_fit(meas_sim.w[2:], w_rls_sim[2:])
    figs["fig05_rls_simulation"] = plot_velocity_fit(
        meas_sim.t, meas_sim.w, (w_rls_sim, f"RLS a-priori prediction (λ = {opt.lam_sim:g})", fit_rls_sim),
        measured_label="simulated", title=FIGURE_CAPTIONS["fig05_rls_simulation"], units=opt.units)
    numbers = {"duration": opt.sim_duration, "Ts": Ts_sim, "n_samples": int(meas_sim.t.shape[0]),
               "ls_fit_one_step": ls_sim.fit_one_step, "ls_fit_free_run": ls_sim.fit_free_run,
               "ls_estimate": _estimate_dict(ls_sim.estimate), "rls_fit": fit_rls_sim, "rls_lam": opt.lam_sim,
               "rls_estimate": _estimate_dict(model.to_physical(th_sim[-1], Ts_sim))}
    return figs, numbers


def _figs9_12_experiment(p: JointParams, opt: PaperFigureOptions, model: RegressionModel, design, meas) -> tuple:
    """Sec. V-D/E: LS and RLS on the irregular samples as they are; returns ``(figures, numbers)``."""
    Ts_exp = meas.Ts
    ls_exp = fit_ls(model, meas.u, meas.w, Ts=Ts_exp)
    figs = {"fig09_ls_experiment": plot_velocity_fit(
        meas.t, meas.w, (ls_exp.w_one_step, "LS model, one-step prediction", ls_exp.fit_one_step),
        model2=(ls_exp.w_free_run, "LS model, free run", ls_exp.fit_free_run), measured_label="measured (irregular readout, noise, quantised torque)",
        title=FIGURE_CAPTIONS["fig09_ls_experiment"], units=opt.units)}
    figs["fig10_sample_time"] = plot_sample_times(meas.t)
    figs["fig07_input_torque"] = plot_input_torque(meas.t, meas.u, title=FIGURE_CAPTIONS["fig07_input_torque"])
    w_rls, th = rls_pass(model, meas.u, meas.w, lam=opt.lam_exp, P0=opt.P0)
    fit_rls = nrmse_fit(meas.w[2:], w_rls[2:])
    figs["fig11_rls_experiment"] = plot_velocity_fit(
        meas.t, meas.w, (w_rls, f"RLS a-priori prediction (λ = {opt.lam_exp:g})", fit_rls),
        title=FIGURE_CAPTIONS["fig11_rls_experiment"], units=opt.units)
    figs["fig12_rls_parameters"] = plot_parameter_convergence(
        meas.t[2:], th, model.names, true=model.theta_from_physical(p, Ts_exp),
        title=f"{FIGURE_CAPTIONS['fig12_rls_parameters']} (λ = {opt.lam_exp:g}; dashed: true plant at mean Ts)",
        units=opt.units)
    d = np.diff(meas.t)
    numbers = {
        "duration": opt.exp_duration, "n_samples": int(meas.t.shape[0]), "Ts_mean": float(d.mean()),
        "Ts_min": float(d.min()), "Ts_max": float(d.max()), "noise_std": opt.noise_std,
        "quantization": opt.quantization,
        "controller": {"Kp": design.Kp, "Ki": design.Ki, "Tc": design.Tc, "phase_margin": design.phase_margin},
        "ls_fit_one_step": ls_exp.fit_one_step, "ls_fit_free_run": ls_exp.fit_free_run,
        "ls_estimate": _estimate_dict(ls_exp.estimate), "rls_fit": fit_rls, "rls_lam": opt.lam_exp,
        "rls_estimate": _estimate_dict(model.to_physical(th[-1], Ts_exp))}
    return figs, numbers


def _write_demo_logs(out: Path, p: JointParams, vel, opt: PaperFigureOptions, experiment, rng) -> dict:
    """``quasi_static_log.csv``, ``robot_log.csv``, ``controller_log.csv``, ``controller.json`` and ``plant.json``
    (see :func:`paper_figures`) of the ``experiment`` (a
    :class:`controllers.experiments.synthetic_logs.ClosedLoopReadout`); ``{name: Path}``."""
    run, meas = experiment.run, experiment.measurement
    resp = run.response
    data_files = {}
    qlog = quasi_static_log(p, vel, hold=1.5, settle=1.5, noise_std=opt.noise_std, rng=rng)
    data_files["quasi_static_log"] = write_log_csv(
        out / "quasi_static_log.csv", {"t": qlog.t, "u": qlog.u, "w": qlog.w},
        header_comment="simulated bidirectional constant-velocity runs: t (s), u (N·m), w (rad/s)")
    counts = encoder_counts(resp, meas.t, counts_per_rev=DEMO_COUNTS_PER_REV)
    data_files["robot_log"] = write_log_csv(
        out / "robot_log.csv",
        {"time_ms": np.round(meas.t * 1e3, 6), "current_A": meas.u / DEMO_CURRENT_TO_TORQUE,
         "velocity_deg_s": np.rad2deg(meas.w), "encoder_counts": counts, "reference_deg_s": np.rad2deg(experiment.w_ref)},
        header_comment=(f"simulated robot-joint log: u = {DEMO_CURRENT_TO_TORQUE:g} N·m/A * current_A, "
                        f"{DEMO_COUNTS_PER_REV} counts/rev, irregular readout; reference_deg_s: the commanded "
                        "velocity; the PI velocity loop (1 kHz) is in controller.json"))
    data_files["controller_log"] = write_controller_log(out / "controller_log.csv", run,
                                                        current_to_torque=DEMO_CURRENT_TO_TORQUE)
    ctl_json = out / "controller.json"
    ctl_json.write_text(json.dumps(experiment.controller(), indent=2) + "\n")
    data_files["controller"] = ctl_json
    plant_json = out / "plant.json"
    plant_json.write_text(json.dumps(p.to_dict(), indent=2) + "\n")
    data_files["plant"] = plant_json
    return data_files


def paper_figures(out_dir, *, p: JointParams | None = None, options: PaperFigureOptions | None = None,
                  save_data: bool = False, progress: bool | None = None, dpi: int = 110) -> PaperFigures:
    """Regenerate the paper's Figs. 4, 5, 7, 8, 9, 10, 11, 12 from the simulated joint and write them as PNG.

    Parameters
    ----------
    out_dir : str or os.PathLike
        Output directory (created).
    p : JointParams, keyword-only
        Plant; default the ``paper`` preset.
    options : PaperFigureOptions, keyword-only
        Seed, run lengths, speeds, noise, quantisation and RLS settings; default
        ``PaperFigureOptions()`` (30 s simulation, 60 s experiment, 10 speeds,
        1e-3 rad/s noise, 0.6 N·m quantum, lambda 0.995 and 0.85, P0 = 1e4).
    save_data : bool, keyword-only
        Also write demonstration logs: ``quasi_static_log.csv`` (``t, u, w``)
        for ``adaptive-ff stribeck`` and ``robot_log.csv`` (``time_ms``,
        ``current_A`` with ``u = 60 A·current``, ``velocity_deg_s``,
        ``encoder_counts`` with :data:`DEMO_COUNTS_PER_REV`; irregular time
        stamps) for ``adaptive-ff identify``, ``controller_log.csv`` (the same run as the PI
        recorded it at 1 kHz: ``time_ms``, ``current_A``, ``velocity_deg_s``,
        ``reference_deg_s``; :func:`controllers.experiments.synthetic_logs.write_controller_log`),
        plus ``plant.json`` and ``controller.json`` (the PI of the loop: ``Kp`` N·m·s/rad, ``Ki`` N·m/rad,
        ``Tc`` s, ``u_max`` N·m, as :class:`controllers.experiments.closed_loop_id.ControllerSpec` reads it);
        ``robot_log.csv`` also has ``reference_deg_s`` (the commanded velocity at the stamps) for
        ``identify --method closed_loop``.
    progress : bool or None, keyword-only
        tqdm progress bar over the stages (None: when stderr is a terminal).
    dpi : int, keyword-only
        PNG resolution.

    Returns
    -------
    PaperFigures

    Raises
    ------
    TypeError
        ``p`` not a JointParams or ``options`` not a PaperFigureOptions.
    ExcitationError
        A fit fails for lack of excitation (too short runs).
    ParameterError
        ``sim_duration`` or ``exp_duration`` whose run does not fit into the memory available
        (:func:`controllers.simulation.memory.check_run_memory`).

    Notes
    -----
    The experiments of the module docstring (Ruderman, Secs. IV and V), in the
    order Fig. 8 (its ``Vs``, ``delta`` fix the regression model of the others),
    Figs. 4-5, Figs. 9-12. One ``numpy.random.SeedSequence(options.seed)`` is
    spawned into independent streams for the stages.
    """
    from tqdm.auto import tqdm

    p = preset("paper") if p is None else p
    if not isinstance(p, JointParams):
        raise TypeError(f"p must be a JointParams, got {type(p).__name__}")
    opt = PaperFigureOptions() if options is None else options
    if not isinstance(opt, PaperFigureOptions):
        raise TypeError(f"options must be a PaperFigureOptions, got {type(opt).__name__}")
    from controllers.simulation.memory import PREPARATION_SIGNALS, check_run_memory

    for name in ("sim_duration", "exp_duration"):  # refused before anything is allocated when it cannot fit
        check_run_memory(getattr(opt, name), 1e-3, signals=PREPARATION_SIGNALS, what=name, detail="its run")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ss = np.random.SeedSequence(opt.seed)
    qs_ss, sim_ss, ref_ss, times_ss, meas_ss, loop_ss = ss.spawn(6)
    Tc = 1e-3
    peak = math.radians(20.0)
    numbers: dict = {"plant": p.to_dict(), "seed": opt.seed}
    bar = tqdm(total=5, desc="paper-figures", disable=(None if progress is None else not progress), leave=False)

    bar.set_postfix_str("quasi-static runs (Fig. 8)")
    vel, model, fig8, numbers["stribeck"] = _fig8_stribeck(p, opt, qs_ss)
    figs = {"fig08_stribeck": fig8}
    bar.update()
    bar.set_postfix_str("simulation LS/RLS (Figs. 4, 5)")
    sim_figs, numbers["simulation"] = _figs45_simulation(p, opt, model, sim_ss, Tc, peak)
    figs.update(sim_figs)
    bar.update()
    bar.set_postfix_str("closed-loop experiment (Figs. 9-12)")
    exp = closed_loop_readout(p, opt.exp_duration, seeds=(ref_ss, loop_ss, times_ss, meas_ss),
                              crossover=opt.crossover, peak=peak, noise_std=opt.noise_std,
                              quantization=opt.quantization, Tc=Tc)
    design, run, meas = exp.design, exp.run, exp.measurement
    bar.update()
    bar.set_postfix_str("LS/RLS on the irregular samples")
    exp_figs, numbers["experiment"] = _figs9_12_experiment(p, opt, model, design, meas)
    numbers["experiment"]["motion"] = joint_motion(run.response.w)
    figs.update(exp_figs)
    bar.update()

    bar.set_postfix_str("writing")
    paths = save_figures({stem: figs[stem] for stem in FIGURE_CAPTIONS}, out, dpi=dpi)
    data_files = {}
    if save_data:
        data_files = _write_demo_logs(out, p, vel, opt, exp, np.random.default_rng(ss.spawn(1)[0]))
    bar.update()
    bar.close()
    return PaperFigures(out_dir=out, figures=dict(zip(FIGURE_CAPTIONS, paths)), captions=dict(FIGURE_CAPTIONS),
                        numbers=numbers, data_files=data_files)


# --------------------------------------------------------------------------- user data


def identification_figures(report, data) -> dict:
    """The paper's kinds of figures for an identified measured log (for ``identify --plot/--report``).

    Parameters
    ----------
    report : adaptive_ff.identification.identification_report.IdentificationReport
        Result of :func:`adaptive_ff.identification.identify.identify` on ``data``.
    data : adaptive_ff.io.data.MeasuredData
        The record as loaded (time stamps may be non-uniform).

    Returns
    -------
    dict
        ``{"ls_fit": Figure, "rls_fit": Figure, "rls_parameters": Figure,
        "sample_time": Figure}``: measured vs LS (one-step and free-run)
        velocity (Fig. 9 kind), measured vs RLS a-priori velocity (Fig. 11),
        RLS parameter convergence (Fig. 12), sample-time plot (Fig. 10).

    Notes
    -----
    :func:`adaptive_ff.identification.identify.identify` fits on a uniform grid
    (:func:`adaptive_ff.io.data.to_uniform`); the model curves are drawn on that
    grid, and the RLS pass is repeated with the report's ``lam`` and ``P0`` to
    get its a-priori predictions.
    """
    from adaptive_ff.io.data import to_uniform

    uni = to_uniform(data)
    ls = report.ls
    model = ls.model
    figs = {"ls_fit": plot_velocity_fit(
        uni.t, uni.w, (ls.w_one_step, "LS model, one-step prediction", ls.fit_one_step),
        model2=(ls.w_free_run, "LS model, free run", ls.fit_free_run),
        title=f"measured and offline (LS) identified velocity: {data.source}")}
    w_rls, th = rls_pass(model, uni.u, uni.w, lam=report.lam, P0=report.P0)
    figs["rls_fit"] = plot_velocity_fit(
        uni.t, uni.w, (w_rls, f"RLS a-priori prediction (λ = {report.lam:g})", nrmse_fit(uni.w[2:], w_rls[2:])),
        title="measured and online (RLS) identified velocity")
    figs["rls_parameters"] = plot_parameter_convergence(uni.t[2:], th, model.names)
    figs["sample_time"] = plot_sample_times(data.t)
    return figs


def save_figures(figures: dict, out_dir, *, dpi: int = 110) -> list:
    """Write ``{stem: Figure}`` as ``out_dir/<stem>.png`` (directory created), e.g. for ``identify --plot DIR``.

    Parameters
    ----------
    figures : dict
        ``{file stem: matplotlib.figure.Figure}``, e.g. from :func:`identification_figures`.
    out_dir : str or os.PathLike
        Directory.
    dpi : int, keyword-only
        Resolution.

    Returns
    -------
    list of Path
        The files written, in the order of ``figures``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for stem, fig in figures.items():
        path = out / f"{stem}.png"
        fig.savefig(path, dpi=dpi)
        paths.append(path)
    return paths
