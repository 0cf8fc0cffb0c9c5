"""``adaptive-ff identify``: friction parameters from a measured log (offline LS and RLS).

Besides the eq. 4 LS/RLS table: ``--asymmetric`` adds the direction-dependent
friction fit of the EMPS benchmark (IDIM-LS, :func:`adaptive_ff.identification.idim.fit_idim`);
an EMPS record (variables ``t, qm, qg, vir, gtau, kp, kv``) is re-simulated in
its PD position loop (:func:`adaptive_ff.identification.emps_validation.validate_emps`);
``--validate FILE`` judges the model(s) on a second record
(:func:`adaptive_ff.identification.cross_validation.cross_validate`, plus the closed loop for EMPS).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

__all__ = ["register"]

#: Row labels of the asymmetric table: package symbol and the EMPS benchmark's name.
_ASYM_LABELS = {"J": "J (M)", "sigma_pos": "sigma+ (Fv+)", "Fc_pos": "Fc+", "sigma_neg": "sigma- (Fv-)",
                "Fc_neg": "Fc-", "offset": "offset"}
_ASYM_UNITS = {"J": "J", "sigma_pos": "sigma", "Fc_pos": "Fc", "sigma_neg": "sigma", "Fc_neg": "Fc",
               "offset": "offset"}


class _Units:
    """Units of identify's printed tables: scale and label of each parameter, for the axis (``--axis``: rotary,
    or linear: SI, m/s and N) and the velocity unit (``--units``; rad: exactly SI)."""

    def __init__(self, args, si: bool = False, linear: bool = False):
        from adaptive_ff.io.units import LINEAR_UNITS, PARAM_UNITS, PARAMETER_UNITS
        from controllers.cli.data import per_angle, table_unit

        self.linear = linear
        self.si = si or linear or (getattr(args, "units", "deg") or "deg") == "rad"
        k, unit = (1.0, "rad/s") if self.si else table_unit(args)
        c, angle = (1.0, "rad") if self.si else per_angle(args)
        table = {**PARAMETER_UNITS, **LINEAR_UNITS} if linear else PARAMETER_UNITS
        self.units = {n: table[n] for n in PARAM_UNITS}
        self.scale = {n: 1.0 for n in PARAM_UNITS}
        self.Vs = (k, table["Vs"] if self.si else unit)
        self.velocity_si = table["Vs"]  # the SI velocity unit of the axis (notes and warnings print in SI)
        if not self.si:
            self.units["sigma"] = f"N·m·s/{angle}"
            self.scale["sigma"] = c

    def row(self, name: str, value: float, *rest: float) -> str:
        """A row of an identify table: ``name``, value (width 14), std error (13) and RLS (14), unit."""
        c = self.scale.get(name, 1.0)
        nums = f"{c * value:>14.6g}" + "".join(f"{c * x:>{w}{fmt}}" for x, w, fmt in zip(rest, (13, 14), (".3g", ".6g")))
        return f"{name:<10}{nums}  {self.units.get(name, '')}"


def _relabel(obj, old: str, new: str):
    """``obj`` (JSON-like dicts, lists, strings) with ``old`` replaced by ``new`` in every string: the report's
    "rotary (linear)" velocity label in the notes and warnings becomes the axis's one, as in the text report."""
    if isinstance(obj, str):
        return obj.replace(old, new)
    if isinstance(obj, dict):
        return {k: _relabel(v, old, new) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_relabel(v, old, new) for v in obj]
    return obj


def _summary(report, units: _Units) -> str:
    """``report.summary()`` in the units of the axis (``--axis``) and with sigma (and Vs) in the printed velocity
    unit (``--units``); the report's own "rotary (linear)" labels become the axis's one."""
    from adaptive_ff.io.units import PARAM_UNITS, VELOCITY_LABEL

    text = report.summary().splitlines()
    e, r, m = report.estimate, report.rls_estimate, report.model
    out = []
    physical = report.physical is not None  # the answer's table comes first; the eq. 4 baselines after it
    for line in text:
        name = line.split(" ", 1)[0]
        if line.startswith("baselines:"):
            physical = False
        unit = PARAM_UNITS.get(name)
        if unit is not None and line.endswith(unit) and name == "sigma" and not units.si:
            ph = report.physical
            line = (units.row("sigma", ph.params["sigma"], ph.stderr.get("sigma", float("nan")))
                    if physical else units.row("sigma", e.sigma, (report.std if report.physical is not None
                                                                  else report.stderr)["sigma"], r.sigma))
        elif unit is not None and line.endswith(unit):
            line = line[:-len(unit)] + units.units[name]
        elif "intervals: " in line and not units.si:  # sigma's interval in the printed velocity unit
            c = units.scale.get("sigma", 1.0)
            line = re.sub(r"sigma \[([^,\]]+), ([^\]]+)\]",
                          lambda g: f"sigma [{c * float(g.group(1)):.6g}, {c * float(g.group(2)):.6g}]", line)
        elif name == "Vs" and line.endswith(VELOCITY_LABEL) and m.stribeck:
            k, label = units.Vs
            line = f"{'Vs':<10}{k * m.Vs:>14.6g}" + line[24:-len(VELOCITY_LABEL)] + label
        out.append(line.replace(VELOCITY_LABEL, units.velocity_si))
    return "\n".join(out)


def _asymmetric_lines(fit, units: _Units) -> list[str]:
    no_offset = "" if "offset" in fit.names else ", no offset"
    lines = ["", f"asymmetric friction (inverse dynamic model, IDIM-LS{no_offset}; Janot et al. 2019), "
                 f"decimated by {fit.decimate}: {fit.n_samples} rows",
             f"{'parameter':<14}{'value':>12}{'std error':>12}{'rel. std':>10}  unit", "-" * 70]
    rel = fit.rel_stderr
    for n, v in fit.params.items():
        c, unit = units.scale[_ASYM_UNITS[n]], units.units[_ASYM_UNITS[n]]
        lines.append(f"{_ASYM_LABELS[n]:<14}{c * v:>12.6g}{c * fit.stderr[n]:>12.3g}{rel[n]:>9.2f}%  {unit}")
    lines += ["-" * 70, f"force error {fit.force_error:.3f} %, cond {fit.cond:.3g} (unscaled {fit.cond_raw:.3g})"]
    return lines


def _loop_line(label: str, v) -> str:
    return (f"{label}: velocity error {v.velocity_error:.3f} %, force error {v.force_error:.3f} %, "
            f"position error {v.position_error:.4f} %; inverse-model force error {v.idim_force_error:.3f} %")


def _time_stamps(data, method: str, asymmetric: bool = False) -> dict:
    """How the record's time stamps were used: uniform or not, and resampled by which method (plain words)."""
    import numpy as np

    from adaptive_ff.io.data import is_uniform

    dt = np.diff(data.t)
    uniform = is_uniform(data.t)
    resampled = [] if uniform else ["paper"] + (["asymmetric"] if asymmetric else [])
    message = None
    if not uniform:
        kept = "; --method output_error fits on the stamps as read" if method == "paper" else (
            f"; the {method} fit of the physical parameters uses the stamps as read")
        message = (f"time stamps: irregular (intervals {1e3 * dt.min():.4g} to {1e3 * dt.max():.4g} ms); the paper "
                   f"method (eq. 4 needs one Ts) RESAMPLED them onto a uniform grid at Ts = "
                   f"{1e3 * float(np.median(dt)):.4g} ms by linear interpolation"
                   f"{' (so did --asymmetric)' if asymmetric else ''}{kept}")
    return {"uniform": uniform, "Ts_min": float(dt.min()), "Ts_max": float(dt.max()),
            "resampled_by": resampled, "message": message}


def _split_reference(args) -> tuple:
    """``(reference column or None, --columns text without an r= item)``; ParameterError if both name one."""
    from plant.errors import ParameterError

    ref, cols = args.reference_column, args.columns
    if cols is not None:
        items = [x.strip() for x in cols.split(",") if x.strip()]
        rs = [x for x in items if x.replace(" ", "").startswith("r=")]
        if rs:
            if ref is not None or len(rs) > 1:
                raise ParameterError(f"the reference column is named twice (--columns {cols!r}, "
                                     f"--reference-column {ref!r}): give it once")
            ref = rs[0].split("=", 1)[1].strip()
            cols = ",".join(x for x in items if x not in rs) or None
    return ref, cols


def _controller_spec(args):
    """The :class:`controllers.experiments.closed_loop_id.ControllerSpec` of ``--controller`` or ``--Kp/--Ki/--Tc
    [--u-max]``; None if neither is given."""
    from controllers.experiments.closed_loop_id import ControllerSpec
    from plant.errors import ParameterError

    given = {k: getattr(args, k) for k in ("Kp", "Ki", "Tc", "u_max") if getattr(args, k) is not None}
    if args.controller is not None:
        if given:
            raise ParameterError(f"give the controller either as --controller {args.controller} or by "
                                 f"--Kp/--Ki/--Tc/--u-max, not both (got {sorted(given)})")
        return ControllerSpec.from_json(args.controller)
    if not given:
        return None
    missing = [f"--{k}" for k in ("Kp", "Ki", "Tc") if k not in given]
    if missing:
        raise ParameterError(f"the controller needs --Kp, --Ki and --Tc (--u-max optional); missing {missing}")
    return ControllerSpec.from_dict({k: v for k, v in given.items()}, where="--Kp/--Ki/--Tc/--u-max")


def _read_reference(args, name: str, n: int):
    """The reference column ``name`` of ``args.file`` in rad/s (``--velocity-unit``), checked to have ``n`` rows."""
    from adaptive_ff.io.logs import parse_column_map, read_columns
    from adaptive_ff.io.units import VELOCITY_UNITS
    from controllers.cli.data import io_options_from_args
    from plant.errors import SignalError

    cmap = parse_column_map(args.columns) if args.columns else {}
    t_name = cmap.get("t", "t")
    table = read_columns(args.file, {"t": t_name, "r": name}, csv_format=io_options_from_args(args)["csv_format"])
    r = table.columns["r"] * VELOCITY_UNITS[args.velocity_unit]
    if r.shape[0] != n:
        raise SignalError(f"{args.file}: reference column {name!r} has {r.shape[0]} rows, the log {n}")
    return r


def _identify(args, data):
    """The report: :func:`controllers.experiments.closed_loop_id.identify_closed_loop` when the reference and the
    controller are given (methods auto, closed_loop), else :func:`adaptive_ff.identification.identify.identify`."""
    from adaptive_ff.identification.identify import identify
    from controllers.cli.data import progress_from_args
    from plant.errors import ParameterError

    ref_name, spec = args.reference_name, _controller_spec(args)
    common = {"lag": args.lag, "offset": not args.no_offset, "lam": args.lam}
    boot = {} if args.bootstrap is None else {"n_bootstrap": args.bootstrap}
    output_error = args.method == "output_error" and args.form is None
    if args.bootstrap_refit is not None and not output_error:
        raise ParameterError(f"--bootstrap-refit applies to --method output_error (without --form), got "
                             f"--method {args.method}" + (f" --form {args.form}" if args.form else ""))
    if args.input_delay is not None and args.form is None:
        if args.method not in ("auto", "output_error") or (args.method == "auto" and ref_name and spec):
            raise ParameterError(f"--input-delay applies to the output-error fit of the log (--method output_error, "
                                 f"or auto where it answers by output error), got --method {args.method}"
                                 + (" with the reference and the controller (closed_loop)" if args.method == "auto"
                                    else ""))
        boot["input_delay"] = args.input_delay
    if output_error:  # its bootstrap takes minutes on a long log
        boot["progress"] = progress_from_args(args)
        if args.bootstrap_refit is not None:
            boot["bootstrap_refit"] = args.bootstrap_refit
    if args.form is not None:
        return _identify_form(args, data, ref_name, spec, common)
    if args.method == "closed_loop" and (ref_name is None or spec is None):
        need = [x for x, ok in (("--reference-column NAME (or r=NAME in --columns)", ref_name is not None),
                                ("--controller FILE (or --Kp, --Ki, --Tc, --u-max)", spec is not None)) if not ok]
        raise ParameterError(f"--method closed_loop simulates your velocity loop: add {' and '.join(need)}")
    if ref_name is None or spec is None or args.method not in ("auto", "closed_loop"):
        mopts = boot if args.method in ("auto", "output_error", "paper", "sliding", "idim") else None
        if args.method == "auto":  # it may answer by output error, whose bootstrap takes a while on a long log
            mopts = {**boot, "progress": progress_from_args(args)}
        return identify(data, Vs=args.Vs, delta=args.delta, method=args.method, method_options=mopts, **common)
    if args.Vs is None and args.method == "closed_loop":
        raise ParameterError("--method closed_loop fits the Stribeck model of eqs. 1-3: give --Vs and --delta "
                             "(pre-fit: adaptive-ff stribeck)")
    from controllers.experiments.closed_loop_id import ClosedLoopIdOptions, identify_closed_loop

    if args.Vs is None:
        return identify(data, Vs=None, delta=None, method="auto", **common)
    w_ref = _read_reference(args, ref_name, data.t.shape[0])
    return identify_closed_loop(data, w_ref, controller=spec, Vs=args.Vs, delta=args.delta, method=args.method,
                                options=ClosedLoopIdOptions(**boot), **common)


def _identify_form(args, data, ref_name, spec, common):
    """``--form auto|NAME``: the model-form selection (:func:`adaptive_ff.identification.model_forms.select_form`)
    through :func:`adaptive_ff.identification.identify.identify`; the options that do not apply are refused."""
    from adaptive_ff.identification.identify import identify
    from plant.errors import ParameterError

    if args.folds < 2:
        raise ParameterError(f"--folds must be an integer >= 2, got {args.folds}")
    if args.method not in ("auto", "output_error", "paper", "sliding"):
        raise ParameterError(f"--form {args.form} fits every candidate form by output error (--method auto, "
                             f"output_error or paper) or by the sliding regression (--method sliding), got "
                             f"{args.method}")
    if ref_name is not None or spec is not None:
        raise ParameterError(f"--form {args.form} fits the open-loop model of eqs. 1-3 to the log; it does not "
                             "simulate your controller (drop --reference-column and --controller/--Kp/--Ki/--Tc)")
    if args.bootstrap is not None:
        raise ParameterError(f"--bootstrap does not apply to --form {args.form}: its standard errors are the "
                             "delete-a-block jackknife of the cross-validation")
    options = {"folds": args.folds, "criterion": args.criterion}
    if args.input_delay is not None:
        options["input_delay"] = args.input_delay
    if args.method == "sliding":
        if args.predictor != "auto":
            raise ParameterError("--predictor applies to the output-error fits of --form, not to --method sliding")
    else:
        from controllers.cli.data import progress_from_args

        options["predictor"] = args.predictor
        options["progress"] = progress_from_args(args)  # the output-error searches take a minute on a long log
    return identify(data, Vs=args.Vs, delta=args.delta, method=args.method if args.method == "sliding" else
                    "output_error", form=args.form, form_options=options, **common)


def _forms_figure(selection, out_dir) -> str:
    """``OUT/model_forms.png``: the candidate forms' friction maps over the log's velocity range."""
    import matplotlib.pyplot as plt

    path = Path(out_dir) / "model_forms.png"
    ax = selection.plot()
    ax.figure.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(ax.figure)
    return str(path)


def _form_rigid_axis(report):
    """The chosen form's J, sigma, Fc, offset as a rigid-axis model (the EMPS closed-loop re-simulation)."""
    from adaptive_ff.identification.idim import RigidAxisModel

    return RigidAxisModel.symmetric(report.J, report.sigma, report.Fc, report.offset)


def _check_bootstrap(args) -> None:
    """``--bootstrap N``: an integer >= 0, ``--input-delay SECONDS``: a finite time >= 0 (ParameterError naming the
    option otherwise), checked before the data are read."""
    from plant.errors import ParameterError

    if args.bootstrap is not None and args.bootstrap < 0:
        raise ParameterError(f"--bootstrap must be an integer >= 0 (0: HAC standard errors), got {args.bootstrap}")
    d = args.input_delay
    if d is not None and not (math.isfinite(d) and d >= 0.0):
        raise ParameterError(f"--input-delay must be a finite time >= 0 in seconds (the time by which each torque "
                             f"sample precedes its stamp), got {d!r}")


def _bootstrap_lines(args, report) -> list:
    """What ``--bootstrap`` did: nothing for a method without a bootstrap; with 0 the HAC caveat."""
    if args.bootstrap is None:
        return []
    ph = report.physical
    kind = None if ph is None else ph.info.get("stderr_kind")
    if ph is None or ph.method in ("sliding", "idim"):  # the residual block bootstrap of the regression (0: none)
        return [] if args.bootstrap else [f"note: --bootstrap 0: the {report.method} standard errors assume white "
                                          "residuals (optimistic on real data); use --bootstrap N >= 2"]
    if kind is None:
        used = "paper" if ph is None else ph.method
        return [f"note: --bootstrap {args.bootstrap} not used: method {used!r} has no bootstrap (output_error and "
                "closed_loop have)"]
    if kind == "hac":
        return [f"note: --bootstrap 0: the {ph.method} standard errors are HAC (Newey-West, asymptotic): too small "
                "on the rough free-run cost (2-10 times measured), a lower bound; use --bootstrap N > 0"]
    return []


def _check_work(args, data) -> None:
    """Refuse an identification whose estimated time or memory is beyond the limits without ``--yes``: the refits
    of ``--bootstrap`` or the fits of ``--form``/``--folds`` on the log's samples, for ``--method auto`` those of
    every method it may run (:func:`adaptive_ff.identification.identify.auto_methods`;
    :func:`controllers.cli.budget.identify_estimate`)."""
    from adaptive_ff.identification.identify import auto_methods
    from controllers.cli.budget import check_work, identify_estimate

    method = args.method
    if args.form is None and method == "auto":  # what auto runs: the sliding fit and the output-error fit after it
        controller = args.controller is not None or args.Kp is not None
        method = "closed_loop" if args.reference_name and controller and args.Vs is not None else \
            auto_methods(data, Vs=args.Vs, lag=args.lag)
    folds = args.folds if args.form is not None else None
    check_work(identify_estimate(data.n_samples, method, bootstrap=args.bootstrap, refit=args.bootstrap_refit,
                                 folds=folds), yes=args.yes)


def _identify_and_write(args, data, plot_dir, report_dir) -> tuple:
    """The identification of ``data`` with every check ``args`` asks for, its figures written into ``plot_dir`` and
    its report into ``report_dir`` (None: not asked for); ``(report, extra JSON, printed lines, units)``."""
    from adaptive_ff.identification.emps_validation import is_emps_record, validate_emps
    from adaptive_ff.identification.cross_validation import cross_validate
    from adaptive_ff.io.data import to_uniform
    from adaptive_ff.identification.idim import fit_idim
    from controllers.cli.data import command_line, load_data_from_args, named_by
    from plant.errors import ParameterError

    with named_by(args.file):  # what the data cannot tell names the file
        report = _identify(args, data)
    used = report.physical.method if report.physical is not None else "paper"  # what --method auto chose
    extra: dict = {"time_stamps": _time_stamps(data, used, args.asymmetric)}
    lines: list[str] = []
    asym = None
    emps_file = args.columns is None and is_emps_record(args.file)
    linear = emps_file or args.axis == "linear"
    units = _Units(args, si=emps_file, linear=linear)  # the EMPS axis is prismatic: m/s, never deg/s
    if linear and getattr(args, "units", "deg") != "rad":
        what = "the EMPS record is a prismatic axis" if emps_file else "--axis linear"
        lines.append(f"units: {what}; its tables stay in SI (N, m/s)")
    lines += _bootstrap_lines(args, report)
    if args.input_delay is not None and args.form is None and (report.physical is None
                                                               or report.physical.method != "output_error"):
        lines.append(f"note: --input-delay {args.input_delay:g} not used: method {report.method!r} is not the "
                     "output-error fit")
    if args.asymmetric:
        uni = to_uniform(data)
        with named_by(args.file):
            asym = fit_idim(uni, asymmetric=True, decimate=max(1, int(round(0.01 / uni.Ts))))
    if asym is not None:
        extra["asymmetric"] = asym.to_json_dict()
        lines += _asymmetric_lines(asym, units)

    try:
        model = report.rigid_axis_model() if report.forms is None else _form_rigid_axis(report)
    except ParameterError as exc:
        model = None
        lines.append(f"WARNING: no closed-loop re-simulation, the LS estimate is not physical ({exc})")
    dropped = [n for n, on in (("Fs", report.model.stribeck), ("tau", report.model.lag)) if on]
    if report.forms is not None:
        dropped = [n for n, on in (("Fs", report.forms.best.stribeck != "none"), ("tau", report.forms.best.lag)) if on]
    if model is not None and emps_file:
        loop = validate_emps(model, args.file)
        extra["closed_loop"] = loop.to_json_dict()
        lines += ["", _loop_line("closed loop (EMPS PD loop driven by the measured reference qg)", loop)]
        if dropped:
            lines.append(f"note: the re-simulated model is J, sigma, Fc, offset ({', '.join(dropped)} dropped)")
        if asym is not None:
            aloop = validate_emps(asym.model, args.file)
            extra["asymmetric"]["closed_loop"] = aloop.to_json_dict()
            lines.append(_loop_line("closed loop, asymmetric model", aloop))
    if args.validate:
        vdata = load_data_from_args(args, path=args.validate)
        cv = cross_validate(report, vdata)
        extra["validation"] = cv.to_json_dict()
        ife = "n/a" if cv.idim_force_error is None else f"{cv.idim_force_error:.3f} %"
        lines += ["", f"validation on {args.validate}: fit one-step {cv.fit_one_step:.3f} %, "
                      f"free-run {cv.fit_free_run:.2f} %, inverse-model force error {ife}"]
        if args.columns is None and is_emps_record(args.validate):
            if model is not None:
                vloop = validate_emps(model, args.validate)
                extra["validation"]["closed_loop"] = vloop.to_json_dict()
                lines.append(_loop_line("validation closed loop", vloop))
            if asym is not None:
                aval = validate_emps(asym.model, args.validate)
                extra["asymmetric"]["validation"] = aval.to_json_dict()
                lines.append(_loop_line("validation closed loop, asymmetric model", aval))

    if plot_dir is not None or report_dir is not None:
        from controllers.experiments.paper_figures import identification_figures, save_figures

        figures = identification_figures(report, data)
        if plot_dir is not None:
            extra["figures"] = [str(x) for x in save_figures(figures, plot_dir)]
            if report.forms is not None:
                extra["figures"].append(_forms_figure(report.forms, plot_dir))
    if report_dir is not None:
        from controllers.report.html import identify_report

        extra["report"] = str(identify_report(report_dir, report, data, command=command_line()))
    return report, extra, lines, units


def run(args) -> int:
    """Execute ``adaptive-ff identify`` with parsed ``args``; return the exit status.

    The figures (``--plot``) and the report (``--report``) are staged and appear together when the whole command
    has succeeded (:class:`adaptive_ff.io.output.StagedOutputs`).
    """
    from adaptive_ff.io.output import StagedOutputs
    from controllers.cli.data import check_output_dir, load_data_from_args

    for option, value in (("--plot", args.plot), ("--report", args.report)):
        if value:
            check_output_dir(value, option)
    _check_bootstrap(args)
    args.reference_name, args.columns = _split_reference(args)
    with StagedOutputs() as staged:
        plot_dir = staged.folder(args.plot, "--plot") if args.plot else None
        report_dir = staged.folder(args.report, "--report") if args.report else None
        data = load_data_from_args(args)
        _check_work(args, data)
        report, extra, lines, units = _identify_and_write(args, data, plot_dir, report_dir)
    extra = staged.relocate(extra)
    if args.json:
        from adaptive_ff.io.units import VELOCITY_LABEL

        print(json.dumps(_relabel({**report.to_json_dict(), **extra}, VELOCITY_LABEL, units.velocity_si), indent=2))
    else:
        if extra["time_stamps"]["message"]:
            print(extra["time_stamps"]["message"])
        print(_summary(report, units))
        for line in lines:
            print(line)
        if "figures" in extra:
            print("figures: " + ", ".join(extra["figures"]))
        if "report" in extra:
            print(f"report: {extra['report']}")
    return 0


def _add_fit_options(i) -> None:
    """``--bootstrap``, ``--input-delay`` and ``--bootstrap-refit``: the options of the fits' uncertainty and timing."""
    i.add_argument("--bootstrap", metavar="N", type=int, default=None,
                   help="refits of the bootstrap behind the standard errors: the residual block bootstrap of "
                        "methods paper and sliding (default 200, >= 2; 0: white-residual errors), the parametric "
                        "block bootstrap of output_error and closed_loop (default 20 and 10; more: steadier errors, "
                        "proportionally slower; 0: HAC (Newey-West) errors instead, too small on their rough cost)")
    i.add_argument("--input-delay", dest="input_delay", metavar="SECONDS", type=float, default=None,
                   help="time (s, >= 0) by which each torque sample precedes its time stamp, for the output-error "
                        "fit (--method output_error, or auto where it answers by output error; --form): e.g. "
                        "0.0005 for a torque held over 1 ms and stamped at the end of its hold. Default: not "
                        "known, profiled by the fit over sub-sample delays (0 to one median interval) and reported "
                        "(JSON info.input_delay)")
    i.add_argument("--bootstrap-refit", dest="bootstrap_refit", choices=("full", "partial"), default=None,
                   help="how the output_error bootstrap refits each replicate: full (default; the fit itself on "
                        "each replicate: intervals calibrated on the zoo of benchmarks/coverage_zoo.py; the "
                        "refits run on every CPU) or partial (the fit's later steps from a spread start: about 3 "
                        "times faster, J and tau intervals about twice too wide); --method output_error only")


def register(sub) -> None:
    """Add the ``identify`` subcommand to an argparse subparsers object."""
    from controllers.cli.budget import add_yes_argument
    from controllers.cli.data import DATA_EPILOG, add_data_arguments, add_units_argument

    i = sub.add_parser("identify", help="identify friction parameters from measured data", epilog=DATA_EPILOG,
                       description="Offline LS (eq. 9) and RLS (eqs. 10-13) identification of the discrete-time "
                                   "friction model from a measured log (CSV/TXT, .mat, .npz with columns t,u,w or mapped "
                                   "by --columns; SI units unless told otherwise) or the EMPS benchmark .mat file. "
                                   "Prints standard errors, the condition number and warnings naming what the data "
                                   "do not excite; an EMPS record is also re-simulated in its PD position loop.")
    i.add_argument("file", help="data file (CSV/TXT, .mat, .npz) or the EMPS benchmark .mat")
    i.add_argument("--Vs", type=float, default=None, help="Stribeck velocity (rad/s); with --delta selects the "
                                                          "Stribeck structure, else Coulomb + viscous")
    i.add_argument("--delta", type=float, default=None, help="Stribeck shape factor")
    i.add_argument("--lag", action="store_true", help="also estimate the friction lag tau (default: tau = 0; on "
                                                      "EMPS the fitted tau follows the velocity filter, not the plant)")
    i.add_argument("--no-offset", action="store_true", help="no constant torque offset regressor")
    i.add_argument("--lam", type=float, default=1.0, help="RLS forgetting factor (default 1)")
    i.add_argument("--method", choices=("auto", "paper", "output_error", "sliding", "idim", "closed_loop"),
                   default="auto",
                   help="auto (default): idim for a uniform log whose velocity comes from a measured position (the "
                        "EMPS .mat files, a log mapping q) without --Vs or --lag; sliding for a uniform log at the "
                        "controller rate (<= 2 ms) with --Vs, --delta; closed_loop for a slower log when its reference (--reference-column) and the "
                        "controller (--controller or --Kp/--Ki/--Tc) are given; output_error for an open-loop record with --Vs, "
                        "--delta (at the controller rate: no feedback in the log and a sliding fit the noise moves by > "
                        "10 %%; slower: the eq. 4 model fits it in free run by >= 50 %%); else "
                        "paper; the choice is named in "
                        "the notes. closed_loop: output-error fit of J, Fc, Fs, sigma, tau that simulates the known "
                        "PI loop on the reference (closed-loop log read out slower than the loop; needs --Vs, "
                        "--delta). paper: the eq. 4 LS/RLS as "
                        "printed; output_error: also fit the physical J, tau, sigma, Fc, Fs of eqs. 1-3 by "
                        "simulation-error minimisation on the record's own time stamps (open-loop records; robust "
                        "to noise and irregular sampling; without --Vs, --delta it fits Vs and delta too); "
                        "sliding: the sliding-regime "
                        "inverse-dynamics regression on a controller-rate log (closed loop; needs --Vs, --delta); idim: the "
                        "inverse dynamic model (IDIM-LS, the EMPS benchmark's torque regression: Coulomb + viscous + "
                        "offset, no --Vs, no --lag)")
    f = i.add_argument_group("model-form selection (adaptive_ff.identification.model_forms.select_form)")
    f.add_argument("--form", default=None, metavar="auto|NAME",
                   help="auto: fit the candidate forms (Coulomb + viscous; Stribeck with --Vs, --delta; Stribeck "
                        "with Vs, delta fitted where the log has low-speed data; each with and without lag) by "
                        "output error, print their table (parameters, in-sample and blocked cross-validated "
                        "error, AIC, BIC) and answer with the form chosen by the one-standard-error rule; NAME "
                        "(coulomb_viscous, coulomb_viscous_lag, stribeck, stribeck_lag, stribeck_free, "
                        "stribeck_free_lag): answer with that form, table printed too. The answer (JSON top "
                        "level) drives design --from and the plant file for compare --plant")
    f.add_argument("--folds", type=int, default=5, help="contiguous cross-validation blocks of --form (>= 2, "
                                                          "default 5)")
    f.add_argument("--criterion", choices=("cv", "aic", "bic"), default="cv",
                   help="rule of --form: cv (default; one-standard-error rule on the blocked-CV error), aic, bic")
    f.add_argument("--predictor", choices=("auto", "free-run", "one-step"), default="auto",
                   help="prediction --form fits and judges: auto (default; one-step on a nearly noise-free "
                        "velocity, else free-run), free-run (simulation on the torque alone), one-step (velocity "
                        "reset to the measurement after each sample)")
    i.add_argument("--asymmetric", action="store_true",
                   help="also fit direction-dependent friction Fc+, Fc-, sigma+ (Fv+), sigma- (Fv-) by the inverse "
                        "dynamic model (IDIM-LS, no offset), as the EMPS benchmark's asymmetric variant")
    i.add_argument("--validate", metavar="FILE", default=None, type=Path,
                   help="judge the identified model(s) on a second record (same format and options): one-step and "
                        "free-run fit, inverse-model relative force error; EMPS records also closed-loop velocity "
                        "and force errors")
    c = i.add_argument_group("closed-loop log read out slower than the loop (method closed_loop)")
    c.add_argument("--reference-column", metavar="NAME", default=None,
                   help="column of the commanded velocity (same unit as the velocity, --velocity-unit); or r=NAME "
                        "in --columns")
    c.add_argument("--controller", metavar="FILE", default=None, type=Path,
                   help="JSON file of the velocity PI: Kp (N·m·s/rad), Ki (N·m/rad), Tc (s), u_max (N·m, null = "
                        "none), e.g. controller.json of paper-figures --save-data")
    c.add_argument("--Kp", type=float, default=None, help="PI proportional gain (N·m·s/rad), instead of --controller")
    c.add_argument("--Ki", type=float, default=None, help="PI integral gain (N·m/rad): C(z) = Kp + Ki*Tc*z/(z-1)")
    c.add_argument("--Tc", type=float, default=None, help="controller period (s)")
    c.add_argument("--u-max", dest="u_max", type=float, default=None, help="torque limit (N·m), default none")
    _add_fit_options(i)
    i.add_argument("--axis", choices=("rotary", "linear"), default="rotary",
                   help="rotary (default): tables in N·m, kg·m², rad/s (or deg/s, --units); linear: a prismatic "
                        "axis, tables in N, kg, m/s (SI; --units does not apply). The values are the same numbers "
                        "(SI of the axis); JSON unchanged")
    i.add_argument("--json", action="store_true",
                   help="print the parameters as JSON: the chosen method's (method, form, J, Fc, Fs, sigma, tau, "
                        "offset, Vs, delta, std) at the top level, the paper's eq. 4 LS/RLS under baselines")
    i.add_argument("--plot", metavar="DIR", default=None,
                   help="write the paper's kinds of figures for these data (measured vs LS/RLS velocity, "
                        "parameter convergence, sample-time histogram) as PNG into DIR")
    i.add_argument("--report", metavar="DIR", default=None, help="write a self-contained HTML report into DIR")
    i.add_argument("--quiet", action="store_true", help="no progress bar")
    add_units_argument(i, extra="Converts sigma (N·m·s/deg) and Vs (deg/s); a prismatic axis (m/s) takes "
                                "--units rad (an EMPS record always prints in SI)")
    add_yes_argument(i)
    add_data_arguments(i)
    i.set_defaults(func=run)
