"""A single self-contained HTML report of a run: data, parameters, fits, controller design, compensation.

:func:`report_html` renders whatever pieces it is given — a
:class:`adaptive_ff.io.data.MeasuredData` record, an
:class:`adaptive_ff.identification.identification_report.IdentificationReport`, a
:class:`adaptive_ff.identification.stribeck_fit.StribeckFit` (with its support points), a
:class:`controllers.design.pi.PIDesign` (or a :class:`controllers.design.loop_analysis.LoopAnalysis`),
a :class:`controllers.experiments.compare.Comparison`, figures and free key/value tables —
into one HTML page with inline CSS and the PNG figures embedded as base64
``data:`` URIs, so the file can be mailed or archived on its own.
:func:`write_report` writes it to ``DIR/report.html``; :func:`identify_report`
and :func:`compare_report` are the calls for ``identify --report`` and
``compare --report``.

Sections appear in the order: summary, data, Stribeck pre-fit, identification,
controller design, compensation comparison, figures, notes.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["ReportPage", "report_html", "write_report", "identify_report", "compare_report", "figure_png", "PNG_MAGIC"]

#: First bytes of every PNG file.
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

_CSS = """
body{font-family:-apple-system,'Segoe UI',Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1.5em;
color:#222;line-height:1.45}
h1{font-size:1.6em;border-bottom:2px solid #2a6fb0;padding-bottom:.3em}
h3{font-size:1.05em;margin-bottom:.2em}
h2{font-size:1.25em;color:#2a6fb0;margin-top:1.8em;border-bottom:1px solid #ddd;padding-bottom:.2em}
table{border-collapse:collapse;margin:.6em 0 1em 0;font-size:.92em}
th,td{border:1px solid #ccc;padding:.3em .7em;text-align:right}
th{background:#eef3f8}
td.l,th.l{text-align:left}
.meta{color:#666;font-size:.9em}
.warn{background:#fff4e5;border-left:4px solid #f0a030;padding:.4em .8em;margin:.4em 0}
.note{color:#555;font-size:.9em;margin:.2em 0}
figure{margin:1em 0 1.6em 0}
figure img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.9em;color:#444;margin-top:.3em}
pre{background:#f6f8fa;padding:.6em;overflow-x:auto;font-size:.85em}
"""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _num(x, fmt: str = ".6g") -> str:
    if x is None:
        return "–"
    try:
        v = float(x)
    except (TypeError, ValueError):
        return _e(x)
    if math.isnan(v):
        return "n/a"
    if math.isinf(v):
        return "∞" if v > 0 else "−∞"
    return format(v, fmt)


def _table(header: Sequence[str], rows: Sequence[Sequence], *, left: int = 1) -> str:
    """HTML table; the first ``left`` columns left-aligned; cells already formatted as text (escaped here)."""
    th = "".join(f'<th class="l">{_e(h)}</th>' if i < left else f"<th>{_e(h)}</th>" for i, h in enumerate(header))
    body = []
    for r in rows:
        tds = "".join(f'<td class="l">{_e(c)}</td>' if i < left else f"<td>{_e(c)}</td>" for i, c in enumerate(r))
        body.append(f"<tr>{tds}</tr>")
    return f"<table><thead><tr>{th}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def figure_png(fig, *, dpi: int = 110) -> bytes:
    """PNG bytes of a figure given as a matplotlib Figure, a PNG file path, or PNG bytes.

    Parameters
    ----------
    fig : matplotlib.figure.Figure, str, os.PathLike or bytes
        The figure.
    dpi : int, keyword-only
        Resolution for a Figure.

    Returns
    -------
    bytes
        PNG data.

    Raises
    ------
    FileNotFoundError
        A path that does not exist.
    ValueError
        The file or bytes are not PNG.
    TypeError
        Any other type.
    """
    if isinstance(fig, (bytes, bytearray)):
        data = bytes(fig)
    elif isinstance(fig, (str, Path)):
        data = Path(fig).read_bytes()
    elif hasattr(fig, "savefig"):
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi)
        data = buf.getvalue()
    else:
        raise TypeError(f"a figure must be a matplotlib Figure, a PNG path or PNG bytes, got {type(fig).__name__}")
    if not data.startswith(PNG_MAGIC):
        raise ValueError(f"not PNG data: {fig!r}"[:200])
    return data


def _img(fig, caption: str) -> str:
    b64 = base64.b64encode(figure_png(fig)).decode("ascii")
    return (f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{b64}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


# --------------------------------------------------------------------------- sections


def _section_summary(summary: Mapping) -> str:
    rows = []

    def walk(prefix, d):
        for k, v in d.items():
            key = f"{prefix}{k}"
            if isinstance(v, Mapping):
                walk(key + ".", v)
            elif isinstance(v, (list, tuple)):
                rows.append((key, ", ".join(_num(x) if isinstance(x, (int, float)) else str(x) for x in v)))
            elif isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool):
                rows.append((key, _num(v)))
            else:
                rows.append((key, str(v)))

    walk("", summary)
    return _table(["quantity", "value"], rows)


def _section_data(data) -> str:
    t, u, w = np.asarray(data.t), np.asarray(data.u), np.asarray(data.w)
    d = np.diff(t)
    rows = [
        ("source", data.source or "–", ""),
        ("samples", str(t.shape[0]), ""),
        ("duration", _num(t[-1] - t[0], ".4g"), "s"),
        ("sample time median / mean", f"{_num(np.median(d) * 1e3, '.4g')} / {_num(d.mean() * 1e3, '.4g')}", "ms"),
        ("sample time min / max", f"{_num(d.min() * 1e3, '.4g')} / {_num(d.max() * 1e3, '.4g')}", "ms"),
        ("uniform (within 1 %)", "yes" if np.max(np.abs(d - np.median(d))) <= 0.01 * np.median(d) else "no", ""),
        ("input u min / max / RMS", f"{_num(u.min(), '.4g')} / {_num(u.max(), '.4g')} / "
                                    f"{_num(np.sqrt(np.mean(u**2)), '.4g')}", "N·m"),
        ("velocity w min / max / RMS", f"{_num(w.min(), '.4g')} / {_num(w.max(), '.4g')} / "
                                       f"{_num(np.sqrt(np.mean(w**2)), '.4g')}", "rad/s"),
        ("velocity reversals", str(int(np.sum(np.sign(w[1:]) * np.sign(w[:-1]) < 0))), ""),
    ]
    out = _table(["quantity", "value", "unit"], rows, left=1)
    out += "".join(f'<p class="note">{_e(n)}</p>' for n in getattr(data, "notes", ()))
    return out


def _units() -> dict:
    try:
        from adaptive_ff.io.units import PARAM_UNITS
        return dict(PARAM_UNITS)
    except ImportError:  # pragma: no cover - identify is part of the package
        return {}


def _section_answer(rep, units: dict) -> str:
    """The chosen method's parameters (the answer of an identification whose method is not eq. 4), with the
    model it fitted; empty for the paper's method, whose answer is the LS table."""
    ph = getattr(rep, "physical", None)
    if ph is None:
        return ""
    form = rep.form
    rows = []
    for n, v in ph.params.items():
        se = ph.stderr.get(n)
        rel = f"{100 * se / abs(v):.2g} %" if se is not None and v not in (0, None) and math.isfinite(se) else "–"
        rows.append((n, _num(v), _num(se, ".3g"), rel, units.get(n, "")))
    for k, v in form["fixed"].items():
        rows.append((f"{k} (pre-fit, fixed)", _num(v), "", "", "rad/s (m/s)" if k == "Vs" else "1"))
    out = (f'<p>Answer: method <b>{_e(ph.method)}</b>, {_e(form["name"])} ({_e(form["equations"])}; '
           f'{_e(form["estimator"])}); fitted {_e(", ".join(form["fitted"]))}.</p>')
    out += _table(["parameter", "value", "std error", "rel.", "unit"], rows)
    out += (f'<p class="note">fit ({_e(ph.nrmse_kind)}) {_num(ph.nrmse, ".3f")} %, condition number '
            f'{_num(ph.cond, ".3g")}, {ph.n_samples} samples.</p>')
    return out + ("<p>Baselines: the paper's eq. 4 LS (eq. 9) and RLS (eqs. 10-13), not the answer.</p>")


def _section_identification(rep, seen=frozenset()) -> str:
    units = _units()
    answer = _section_answer(rep, units)
    est, rls = rep.estimate, rep.rls_estimate
    std = dict(getattr(rep, "std", {}) or {})
    names = list(std) or [n for n in ("J", "sigma", "Fc", "Fs", "tau", "offset") if hasattr(est, n)]
    rows = []
    for n in names:
        v = getattr(est, n)
        se = std.get(n)
        rel = f"{100 * se / abs(v):.2g} %" if se is not None and v not in (0, None) and math.isfinite(se) else "–"
        rows.append((n, _num(v), _num(se, ".3g"), rel, _num(getattr(rls, n, None)), units.get(n, "")))
    m = rep.model
    if getattr(m, "stribeck", False):
        rows.append(("Vs (pre-fit, fixed)", _num(m.Vs), "", "", "", "rad/s (m/s)"))
        rows.append(("delta (pre-fit, fixed)", _num(m.delta), "", "", "", "1"))
    out = answer + _table(["parameter", "LS value", "std error", "rel.", "RLS final", "unit"], rows)
    ls = rep.ls
    fit_rows = [("model", repr(m)), ("Ts", f"{_num(rep.Ts, '.6g')} s"),
                ("one-step fit (NRMSE)", f"{_num(ls.fit_one_step, '.3f')} %"),
                ("free-run fit (NRMSE)", f"{_num(ls.fit_free_run, '.2f')} %"),
                ("RLS one-step fit", f"{_num(rep.rls_fit_percent, '.3f')} % (λ = {_num(rep.lam, 'g')})"),
                ("regressor condition number", _num(ls.cond, ".3g"))]
    out += _table(["fit", "value"], fit_rows)
    out += '<p class="note">Standard errors by the delta method from s²(XᵀX)⁻¹; they assume white equation ' \
           "error and understate the uncertainty on real (coloured) data.</p>"
    out += "".join(f'<p class="note">{_e(n)}</p>' for n in getattr(rep, "notes", ()) if n not in seen)
    out += "".join(f'<div class="warn">⚠ {_e(wn)}</div>' for wn in getattr(rep, "warnings", ()))
    return out


def _section_stribeck(fit, points) -> str:
    units = {"Fc": "N·m", "Fs": "N·m", "Vs": "rad/s", "delta": "1", "sigma": "N·m·s/rad"}
    ci = fit.confidence_intervals(0.95) if fit.dof > 0 else {}
    rows = []
    for k in ("Fc", "Fs", "Vs", "delta", "sigma"):
        lo, hi = ci.get(k, (float("nan"), float("nan")))
        rows.append((k, _num(getattr(fit, k)), _num(fit.stderr[k], ".3g"), f"[{_num(lo, '.5g')}, {_num(hi, '.5g')}]",
                     units[k]))
    out = _table(["parameter", "value", "std error", "95 % interval", "unit"], rows)
    out += (f'<p class="note">Levenberg-Marquardt fit of eq. 3 to {fit.n_points} support points; residual RMS '
            f'{_num(fit.residual_rms, ".3g")} N·m; converged: {"yes" if fit.converged else "no"}.</p>')
    if points is not None:
        prow = [(_num(a, ".4g"), _num(b, ".2g"), _num(c, ".5g"), _num(d, ".3g"), str(int(n)))
                for a, b, c, d, n in zip(points.w_mean, points.w_std, points.u_mean, points.u_std, points.n_samples)]
        out += "<details><summary>support points (" + _e(points.method) + ")</summary>"
        out += _table(["w mean (rad/s)", "w std", "u mean (N·m)", "u std", "samples"], prow, left=0)
        out += "".join(f'<p class="note">{_e(n)}</p>' for n in points.notes) + "</details>"
    return out


def _section_design(analysis) -> str:
    from controllers.design.loop_analysis import LoopAnalysis
    from controllers.design.pi import PIDesign

    if isinstance(analysis, PIDesign):
        from controllers.design.loop_analysis import analyse_design
        analysis = analyse_design(analysis)
    if not isinstance(analysis, LoopAnalysis):
        raise TypeError(f"design must be a PIDesign or LoopAnalysis, got {type(analysis).__name__}")
    d = analysis.design
    gm = d.gain_margin
    rows = [
        ("plant", f"1/(J s + σ), J = {_num(d.J)} kg·m², σ = {_num(d.sigma)} N·m·s/rad", ""),
        ("controller period Tc", _num(d.Tc), "s"),
        ("Kp", _num(d.Kp), "N·m·s/rad"),
        ("Ki", _num(d.Ki), "N·m/rad"),
        ("gain crossover", _num(d.crossover, ".5g"), "rad/s"),
        ("phase margin", _num(d.phase_margin, ".2f"), "deg"),
        ("gain margin", (f"{_num(gm, '.4g')} ({_num(20 * math.log10(gm), '.1f')} dB)" if math.isfinite(gm) else "∞"),
         ""),
        ("phase crossover", _num(d.phase_crossover, ".5g"), "rad/s"),
        ("stability margin (1/Ms)", _num(d.stability_margin, ".3f"), ""),
        ("closed-loop bandwidth (−3 dB)", _num(analysis.bandwidth, ".5g"), "rad/s"),
        ("step rise time (10–90 %)", _num(analysis.rise_time * 1e3, ".3g"), "ms"),
        ("step overshoot", _num(analysis.overshoot, ".3g"), "%"),
        ("step settling time (2 %)", _num(analysis.settling_time * 1e3, ".3g"), "ms"),
        ("peak torque per rad/s step", _num(analysis.peak_torque, ".4g"), "N·m"),
    ]
    return _table(["quantity", "value", "unit"], rows, left=2)


def _section_comparison(comp) -> str:
    from controllers.experiments.comparison import settling_text

    stops = getattr(comp, "has_stops", False)
    rows = []
    for r in comp.rows():
        row = (r["mode"], _num(np.rad2deg(r["rms"]), ".4f"), _num(np.rad2deg(r["max"]), ".4f"),
               _num(np.rad2deg(r["rms_reversal"]), ".4f"), _num(r["u_rms"], ".2f"), _num(r["eta"], ".3f"))
        if stops:
            row += (_num(np.rad2deg(r["rms_motion"]), ".4f"), settling_text(r["settling_max"], r["n_unsettled"]),
                    _num(np.rad2deg(r["max_reversal"]), ".4f"))
        rows.append(row)
    head = ["mode", "RMS error (deg/s)", "max error (deg/s)", "reversal RMS (deg/s)", "u RMS (N·m)", "η"]
    if stops:
        head += ["RMS error in motion (deg/s)", "longest settling (s)", "max error at a reversal (deg/s)"]
    out = _table(head, rows)
    out += ('<p class="note">η = (RMS<sub>none</sub> − RMS<sub>mode</sub>) / (RMS<sub>none</sub> − '
            'RMS<sub>frictionless</sub>), over the second half of the run.'
            + (' In motion: where the reference moves; settling: after each stop of the second half, until '
               '|w<sub>ref</sub> − w| stays within 2 % of the move\'s peak speed (“no (k)”: k stops did not '
               'settle within their dwell).' if stops else '') + '</p>')
    return out


# --------------------------------------------------------------------------- public


@dataclass(frozen=True)
class ReportPage:
    """The pieces of one report page (:func:`report_html`); every piece is optional.

    Parameters
    ----------
    title : str
        Page title.
    summary : mapping, optional
        Free key/value table (nested mappings are flattened to ``a.b`` keys).
    data : adaptive_ff.io.data.MeasuredData, optional
        Data summary: samples, duration, sample-time statistics, ranges, notes.
    stribeck : adaptive_ff.identification.stribeck_fit.StribeckFit, optional
        Parameters with standard errors and 95 % intervals.
    support_points : adaptive_ff.identification.steady_state.SupportPoints, optional
        Shown (collapsed) under the Stribeck fit.
    identification : adaptive_ff.identification.identification_report.IdentificationReport, optional
        Parameter table with standard errors, RLS values and units; fits; notes; warnings.
    design : controllers.design.pi.PIDesign or controllers.design.loop_analysis.LoopAnalysis, optional
        Gains, margins, bandwidth, step metrics.
    comparison : controllers.experiments.compare.Comparison, optional
        Tracking metrics per compensation mode.
    tables : sequence, optional
        Free tables ``[(title, header, rows), ...]``: ``header`` a sequence of
        column names, ``rows`` sequences of cells (numbers are formatted with 6
        significant digits), shown under "Results".
    figures : mapping or sequence, optional
        ``{caption: figure}`` or ``[(caption, figure), ...]``; a figure is a
        matplotlib Figure, a PNG path or PNG bytes (:func:`figure_png`);
        embedded as base64.
    notes : sequence of str
        Free notes at the end.
    command : str, optional
        The command line that produced the run, shown under the title.
    """

    title: str = "adaptive-ff report"
    summary: Mapping | None = None
    data: object = None
    stribeck: object = None
    support_points: object = None
    identification: object = None
    design: object = None
    comparison: object = None
    tables: Sequence | None = None
    figures: object = None
    notes: Sequence[str] = ()
    command: str | None = None


def report_html(page: ReportPage) -> str:
    """Render the pieces of a run as one self-contained HTML page.

    Parameters
    ----------
    page : ReportPage
        The pieces (title, summary, data, Stribeck fit, identification, design, comparison, tables, figures,
        notes, command line).

    Returns
    -------
    str
        The HTML document (UTF-8 text, no external resources).

    Raises
    ------
    TypeError, ValueError
        ``page`` not a ReportPage, a figure of the wrong type or not PNG; ``design`` of the wrong type.
    """
    if not isinstance(page, ReportPage):
        raise TypeError(f"page must be a ReportPage, got {type(page).__name__}")
    title, summary, data, command, notes = page.title, page.summary, page.data, page.command, page.notes
    stribeck, support_points, identification = page.stribeck, page.support_points, page.identification
    design, comparison, tables, figures = page.design, page.comparison, page.tables, page.figures
    parts = [f"<h1>{_e(title)}</h1>"]
    stamp = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    meta = f"generated {stamp} by adaptive-ff"
    if command:
        meta += f" — <code>{_e(command)}</code>"
    parts.append(f'<p class="meta">{meta}</p>')
    if summary:
        parts += ["<h2>Summary</h2>", _section_summary(summary)]
    if data is not None:
        parts += ["<h2>Data</h2>", _section_data(data)]
    if stribeck is not None:
        parts += ["<h2>Stribeck pre-fit (Sec. V-C)</h2>", _section_stribeck(stribeck, support_points)]
    if identification is not None:
        seen = set(getattr(data, "notes", ())) if data is not None else set()
        parts += ["<h2>Identified parameters (LS eq. 9, RLS eqs. 10–13)</h2>",
                  _section_identification(identification, seen)]
    if design is not None:
        parts += ["<h2>Controller design (discrete PI velocity loop)</h2>", _section_design(design)]
    if comparison is not None:
        parts += ["<h2>Friction compensation comparison</h2>", _section_comparison(comparison)]
    if tables:
        parts.append("<h2>Results</h2>")
        for tab_title, header, rows in tables:
            cells = [[_num(c) if isinstance(c, (int, float, np.floating, np.integer)) and not isinstance(c, bool)
                      else str(c) for c in r] for r in rows]
            parts += [f"<h3>{_e(tab_title)}</h3>", _table(list(header), cells)]
    if figures:
        items = list(figures.items()) if isinstance(figures, Mapping) else list(figures)
        parts.append("<h2>Figures</h2>")
        parts += [_img(fig, str(cap)) for cap, fig in items]
    if notes:
        parts.append("<h2>Notes</h2>")
        parts += [f'<p class="note">{_e(n)}</p>' for n in notes]
    body = "\n".join(parts)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{_e(title)}</title><style>{_CSS}</style></head>\n<body>\n{body}\n</body></html>\n")


def write_report(out_dir, *, filename: str = "report.html", **pieces) -> Path:
    """Write :func:`report_html` of ``pieces`` to ``out_dir/filename`` (directory created).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Directory.
    filename : str, keyword-only
        File name, default ``report.html``.
    **pieces
        The fields of its :class:`ReportPage`.

    Returns
    -------
    Path
        The written file.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / filename
    path.write_text(report_html(ReportPage(**pieces)), encoding="utf-8")
    return path


def identify_report(out_dir, report, data, *, design=None, figures=None, command: str | None = None,
                    title: str | None = None) -> Path:
    """Report of ``adaptive-ff identify``: data summary, parameter table, fit figures (and a design, if given).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Report directory.
    report : adaptive_ff.identification.identification_report.IdentificationReport
        The identification.
    data : adaptive_ff.io.data.MeasuredData
        The record it was identified from.
    design : PIDesign or LoopAnalysis, keyword-only, optional
        A velocity-loop design for the identified inertia.
    figures : mapping, keyword-only, optional
        ``{caption: figure}``; default
        :func:`controllers.experiments.paper_figures.identification_figures` (LS fit, RLS
        fit, RLS parameters, sample times).
    command : str, keyword-only, optional
        Command line to show.
    title : str, keyword-only, optional
        Default ``"Friction identification: <source>"``.

    Returns
    -------
    Path
        ``out_dir/report.html``.
    """
    if figures is None:
        from controllers.experiments.paper_figures import identification_figures

        f = identification_figures(report, data)
        figures = {"measured vs offline (LS) identified velocity (cf. paper Fig. 9)": f["ls_fit"],
                   "measured vs online (RLS) identified velocity (cf. Fig. 11)": f["rls_fit"],
                   "RLS parameter convergence (cf. Fig. 12)": f["rls_parameters"],
                   "sample time of the record (cf. Fig. 10)": f["sample_time"]}
    return write_report(out_dir, title=title or f"Friction identification: {data.source or 'measured data'}",
                        data=data, identification=report, design=design, figures=figures, command=command)


def compare_report(out_dir, comparison, *, figures=None, command: str | None = None,
                   title: str = "Friction compensation comparison") -> Path:
    """Report of ``adaptive-ff compare``: plant, controller design, Stribeck pre-fit, metrics table, figures and
    the comparison's notes (e.g. that the joint's runs measured no friction: then eta is undefined, ``–``).

    Parameters
    ----------
    out_dir : str or os.PathLike
        Report directory.
    comparison : controllers.experiments.compare.Comparison
        The comparison.
    figures : mapping or sequence, keyword-only, optional
        ``{caption: figure}`` or PNG paths (e.g. the list returned by
        :func:`controllers.report.figures.plot_comparison`; captions are the file stems).
    command : str, keyword-only, optional
        Command line to show.
    title : str, keyword-only

    Returns
    -------
    Path
        ``out_dir/report.html``.
    """
    if figures is not None and not isinstance(figures, Mapping):
        figures = [(Path(f).stem.replace("_", " "), f) if not isinstance(f, tuple) else f for f in figures]
    summary = {"plant": comparison.plant.to_dict()}
    return write_report(out_dir, title=title, summary=summary, stribeck=getattr(comparison, "prefit", None),
                        design=comparison.design, comparison=comparison, figures=figures, command=command,
                        notes=tuple(getattr(comparison, "notes", ())))
