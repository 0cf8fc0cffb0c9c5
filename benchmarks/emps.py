"""The EMPS benchmark's cross-test: the package's fits of ``DATA_EMPS.mat`` scored on ``DATA_EMPS_PULSES.mat``.

Run:  python benchmarks/emps.py [--data DIR] [--loop]

Prints, as Markdown for docs/benchmarks/emps.md: the default IDIM-LS fit's summary and cross-test (a fenced
block), then one table of every procedure against the published reference model (Janot, Gautier, Brunot 2019:
M = 95.1089 kg, Fv = 203.5034 N·s/m, Fc = 20.3935 N, offset = -3.1648 N; fit error 4.08 %, cross-test 5.98 %):
``fit_idim`` with the default tail and with ``tail=0``, the published parameters scored by the same inverse model,
and the parameters of ``adaptive-ff identify --method paper`` and ``--form auto`` (run as commands, ``--json``).
Parameters are given as their relative deviation from the published ones; errors are
:func:`adaptive_ff.idim_force_error` (the benchmark's ``100*||y - y_model||/||y||`` of the filtered force decimated
by 10), on the estimation record (fit error) and the validation record (cross-test).

``--loop`` prints instead the closed-loop re-simulation table (:func:`adaptive_ff.validate_emps`: the drive's PD
loop driven by the measured reference) of the published model, the default fit (``identify``'s answer) and the
asymmetric fit on both records, beside the benchmark's published figures for its reference model.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from adaptive_ff import fit_idim, idim_force_error, validate_emps
from adaptive_ff.identification.idim import RigidAxisModel
from adaptive_ff.io.data import load_emps

ROOT = Path(__file__).resolve().parents[1]
#: The published reference model (M, Fv, Fc, offset), its relative standard deviations (%) and errors (%).
PUBLISHED = {"J": 95.1089, "sigma": 203.5034, "Fc": 20.3935, "offset": -3.1648}
PUBLISHED_REL_STD = "0.11, 0.56, 0.50, 1.40"
PUBLISHED_ERRORS = (4.08, 5.98)
#: The benchmark's published closed-loop figures of its reference model (velocity, simulated force, inverse
#: model; %), on the estimation and the validation record.
PUBLISHED_LOOP = {"DATA_EMPS.mat": ("0.23", "5.85", "4.08"), "DATA_EMPS_PULSES.mat": ("0.48", "8.94", "5.98")}
NAMES = ("J", "sigma", "Fc", "offset")


def _dev(x: float, name: str) -> str:
    """Relative deviation ``x/published - 1`` (%) from the published ``name`` (a true minus sign)."""
    d = 100.0 * (x / PUBLISHED[name] - 1.0)
    return f"{d:+.3f} %".replace("-", "−")


def _model(p: dict) -> RigidAxisModel:
    """The symmetric inverse model of the parameters ``p`` (keys of :data:`NAMES`)."""
    return RigidAxisModel.symmetric(p["J"], p["sigma"], p["Fc"], p["offset"])


def _identify(est: Path, val: Path, *flags: str) -> dict:
    """``adaptive-ff identify EST --validate VAL --json FLAGS`` run as a command; its JSON."""
    cmd = [sys.executable, "-c", "import sys; from controllers.cli import main; sys.exit(main())", "identify", str(est), "--validate", str(val), "--json", "--yes",
           *flags]
    r = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, text=True, check=True)
    return json.loads(r.stdout)


def loop_table(est_path: Path, val_path: Path) -> None:
    """Print the closed-loop re-simulation table (Markdown) of the published, default and asymmetric models."""
    est = load_emps(est_path)
    models = (("published reference model", _model(PUBLISHED)), ("`identify` model", fit_idim(est).model),
              ("asymmetric model", fit_idim(est, asymmetric=True).model))
    print("| model, record | velocity error | force error (simulation) | force error (inverse model) |")
    print("|---|---|---|---|")
    for path in (est_path, val_path):
        for label, model in models:
            v = validate_emps(model, path)
            what = f"{label}, `{path.name}`" + (", this loop" if label.startswith("published") else "")
            print(f"| {what} | {v.velocity_error:.3f} % | {v.force_error:.3f} % | {v.idim_force_error:.3f} % |")
            if label.startswith("published"):
                pv, pf, pi = PUBLISHED_LOOP[path.name]
                print(f"| published reference model, `{path.name}`, benchmark | {pv} % | {pf} % | {pi} % |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT / "data" / "emps", help="folder of the two .mat records")
    ap.add_argument("--loop", action="store_true", help="the closed-loop re-simulation table instead")
    a = ap.parse_args(argv)
    est_path, val_path = a.data / "DATA_EMPS.mat", a.data / "DATA_EMPS_PULSES.mat"
    if a.loop:
        loop_table(est_path, val_path)
        return 0
    est, val = load_emps(est_path), load_emps(val_path)
    fits = {tail: fit_idim(est, **({} if tail is None else {"tail": 0})) for tail in (None, 0)}
    f = fits[None]
    print("```")
    print(f.summary())
    print(f"cross-test on DATA_EMPS_PULSES.mat: {idim_force_error(f.model, val):.3f} %")
    print("```\n")
    print("| procedure (all: `load_emps`, first 49 samples dropped, decimation 10) | M | Fv | Fc | offset "
          "| rel. std (%) | fit error | cross-test |")
    print("|---|---|---|---|---|---|---|---|")
    pub = PUBLISHED
    print(f"| published reference (Janot et al. 2019) | {pub['J']} | {pub['sigma']} | {pub['Fc']} | "
          f"{pub['offset']:.4f} | {PUBLISHED_REL_STD} | {PUBLISHED_ERRORS[0]:.2f} % | **{PUBLISHED_ERRORS[1]:.2f} %** |"
          .replace("-", "−"))
    for tail, label in ((None, "`fit_idim`, last 49 samples left out (the default)"),
                        (0, "`fit_idim(..., tail=0)` (every sample to the end)")):
        fit, kw = fits[tail], ({} if tail is None else {"tail": 0})
        par = fit.params
        rel = ", ".join(f"{fit.rel_stderr[n]:.3f}" for n in NAMES)
        cross = f"{idim_force_error(fit.model, val, **kw):.3f} %"
        print(f"| {label} | " + " | ".join(_dev(par[n], n) for n in NAMES)
              + f" | {rel} | {fit.force_error:.3f} % | {'**' + cross + '**' if tail is None else cross} |")
    for tail, label in ((None, "default"), (0, "`tail=0`")):
        kw = {} if tail is None else {"tail": 0}
        m = _model(pub)
        print(f"| published parameters scored here, {label} | | | | | | {idim_force_error(m, est, **kw):.3f} % | "
              f"{idim_force_error(m, val, **kw):.3f} % |")
    for flags, label in ((("--method", "paper"), "`identify --method paper`"),
                         (("--form", "auto"), "`identify --form auto`")):
        d = _identify(est_path, val_path, *flags)
        what = f"{d['method']}, {d['form']['name']}"
        m = _model(d)
        print(f"| {label} ({what}) | " + " | ".join(_dev(d[n], n) for n in NAMES) + " | | | "
              f"{d['validation']['idim_force_error_percent']:.3f} % ({idim_force_error(m, val, tail=0):.3f} % "
              "`tail=0`) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
