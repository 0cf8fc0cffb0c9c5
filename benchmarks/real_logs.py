"""Real joint logs beyond EMPS: fetch, identify (``adaptive-ff identify --form auto``), compare to the published curve.

The logs are two of the "Comparative data" files of the NNFM repository (S. Long et al., "NNFM: A Novel Neural
Network Modeling Approach for Robot Flexible Joints Friction Considering Abrupt Non-smooth Properties";
https://github.com/longshike/NNFM-A-Novel-Neural-Network-Modeling-Approach-for-Robot-Flexible-Joints-Friction).
The repository states no license, so the files are *not* copied into this repository: this script reads them
from a local clone (``--repo-dir``, read with ``git show COMMIT:PATH``) or downloads them from
raw.githubusercontent.com at the pinned commit into ``--cache``.

Each file holds ``time`` (s), the joint position, velocity ``dqJ`` (rad/s), acceleration, the joint torque with
the rigid-body dynamics compensated ``qJ_tau_J_compensate`` (N·m: the measured friction torque) and the outputs
of the paper's identified models on the same samples; the column ``CV`` is its Coulomb + viscous model
``Fc*sgn(w) + fv*w``, whose two parameters are recovered here exactly by least squares on that column
(residual below 1e-5 N·m). The friction-curve error is the RMS of ``F_package(w) - F_published(w)`` over a
uniform grid of the log's velocity range (1st to 99th percentile of ``|w|``, both signs), relative to the RMS of
``F_published`` on the same grid.

Each log is identified as a user would: ``adaptive-ff identify LOG`` (the default: eq. 4 LS with residual
block-bootstrap intervals), the same with ``--no-offset`` (the published model's form: no constant torque), and
with ``--form auto`` (the model-form selection by output error); each answer's steady-state check (its line in
the report, :mod:`adaptive_ff.identification.steady_state_check`) is printed with the published values against
its static line's intervals. The static-curve path (support points, eq. 3 with fallback) is the last row.

Run (the ``--form auto`` searches take most of it: several minutes per log)::

    python benchmarks/real_logs.py --repo-dir PATH_TO_CLONE/.git   # or without it: download (needs network)
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np

REPO = "longshike/NNFM-A-Novel-Neural-Network-Modeling-Approach-for-Robot-Flexible-Joints-Friction"

#: name -> (commit, path in the repository, joint index, description)
LOGS = {
    "franka_j2": ("a343d3a3537addd116d6283dae55f687fbf7748f", "Comparative data/Franka Robot/case3_slow.csv", 2,
                  "Franka Emika Panda joint 2, case 3, slow trajectory, 60 s, 1-8 ms steps (median 2 ms)"),
    "fairino_j3": ("21308a1690fd49b49f254bb696fdf13383f5f34e",
                   "Comparative data/FAIRINO Robot/verify_robot_S_slow_processed.csv", 3,
                   "FAIRINO collaborative arm joint 3, S trajectory, slow, 180 s, 10-48 ms steps (median 15.5 ms)"),
}


def raw_log(name: str, repo_dir: Path | None, cache: Path) -> Path:
    """The original CSV of a log, from a local clone (``git show``) or downloaded at the pinned commit."""
    commit, path, _, _ = LOGS[name]
    out = cache / f"{name}_original.csv"
    if out.is_file():
        return out
    cache.mkdir(parents=True, exist_ok=True)
    if repo_dir is not None:
        text = subprocess.run(["git", "--git-dir", str(repo_dir), "show", f"{commit}:{path}"], check=True,
                              capture_output=True).stdout
    else:
        url = f"https://raw.githubusercontent.com/{REPO}/{commit}/{urllib.request.quote(path)}"
        with urllib.request.urlopen(url, timeout=60) as r:  # noqa: S310 - fixed https URL
            text = r.read()
    out.write_bytes(text)
    return out


def read_log(name: str, original: Path) -> dict:
    """Time, torque, velocity and the published Coulomb + viscous parameters of one log (rows with NaN dropped)."""
    j = LOGS[name][2]
    d = np.genfromtxt(original, delimiter=",", names=True)
    t, u, w, cv = d["time"], d[f"q{j}_tau_J_compensate"], d[f"dq{j}"], d["CV"]
    ok = np.isfinite(t) & np.isfinite(u) & np.isfinite(w) & np.isfinite(cv)
    t, u, w, cv = t[ok], u[ok], w[ok], cv[ok]
    X = np.column_stack([np.sign(w), w])
    (Fc, fv), *_ = np.linalg.lstsq(X, cv, rcond=None)
    return {"t": t, "u": u, "w": w, "Fc": float(Fc), "fv": float(fv),
            "cv_residual": float(np.max(np.abs(X @ np.array([Fc, fv]) - cv)))}


def curve_error(pkg: dict, Fc_pub: float, fv_pub: float, w: np.ndarray) -> float:
    """Relative RMS (%) of the package's friction curve minus the published one over the log's velocity range."""
    from plant.friction import stribeck

    lo, hi = np.percentile(np.abs(w), [1, 99])
    lo = max(lo, 1e-3 * hi)
    g = np.linspace(lo, hi, 400)
    grid = np.r_[-g[::-1], g]
    Vs = pkg.get("Vs") or 1.0
    delta = pkg.get("delta") or 1.0
    ours = stribeck(grid, Fc=pkg["Fc"], Fs=pkg.get("Fs", pkg["Fc"]), Vs=Vs, delta=delta, sigma=pkg["sigma"])
    pub = Fc_pub * np.sign(grid) + fv_pub * grid
    return 100.0 * float(np.sqrt(np.mean((ours - pub) ** 2)) / np.sqrt(np.mean(pub**2)))


#: The ``adaptive-ff identify`` runs of each log: name -> extra CLI arguments.
PATHS = {"identify": [], "identify --no-offset": ["--no-offset"], "identify --form auto": ["--form", "auto"]}


def identify(csv: Path, extra: list) -> dict:
    """``adaptive-ff identify CSV --units rad --json --quiet`` plus ``extra`` (the CLI, as a user runs it)."""
    cmd = [sys.executable, "-m", "controllers.cli.main", "identify", str(csv), "--units", "rad", "--json", "--quiet",
           *extra]
    res = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(res.stdout)


def _inside(interval, value) -> bool | None:
    """Whether ``value`` lies in ``[lo, hi]`` (None without an interval)."""
    return None if not interval or None in interval else bool(interval[0] <= value <= interval[1])


def path_row(name: str, path: str, rep: dict, log: dict) -> dict:
    """One table row of an ``identify`` run: the answer, its intervals against the published values, and the
    steady-state check (its flag, its static line and whether that line's intervals hold the published values)."""
    iv = rep.get("interval95", {})
    form = rep.get("form") or {}
    row = {"log": name, "path": path, "method": rep["method"], "form": form.get("label") or form.get("name", ""),
           "Fc": rep["Fc"], "sigma": rep["sigma"], "offset": rep.get("offset"), "J": rep.get("J"),
           "std": rep.get("std", {}), "Fc_inside_95": _inside(iv.get("Fc"), log["Fc"]),
           "sigma_inside_95": _inside(iv.get("sigma"), log["fv"]),
           "warnings": [w.get("code", "") if isinstance(w, dict) else str(w) for w in rep.get("warnings", [])]}
    pkg = {"Fc": rep["Fc"], "Fs": rep.get("Fs") or rep["Fc"], "sigma": rep["sigma"], "Vs": rep.get("Vs"),
           "delta": rep.get("delta")}
    row["curve_error_percent"] = curve_error(pkg, log["Fc"], log["fv"], log["w"])
    ss = rep.get("steady_state") or {}
    line = ss.get("static") or {}
    row["steady_state"] = {"flagged": ss.get("flagged"), "relative_miss": ss.get("relative_miss"),
                           "n_points": ss.get("n_points"), "line": line,
                           "Fc_inside_95": _inside(line.get("interval95", {}).get("Fc"), log["Fc"]),
                           "sigma_inside_95": _inside(line.get("interval95", {}).get("sigma"), log["fv"])}
    return row


def static_fit(log: dict) -> dict:
    """The package's static-curve path: binned steady-state support points, then the eq. 3 fit with fallback.

    :func:`adaptive_ff.identification.steady_state.support_points` (``method="auto"``) and
    :func:`adaptive_ff.identification.stribeck_fit.fit_stribeck` (``fallback=True``: the Coulomb + viscous line
    when the Stribeck factors are not identifiable), i.e. ``adaptive-ff stribeck`` without its refusal.
    """
    from adaptive_ff.io.data import MeasuredData
    from adaptive_ff.identification.steady_state import support_points
    from adaptive_ff.identification.stribeck_fit import fit_stribeck

    pts = support_points(MeasuredData(log["t"], log["u"], log["w"]), method="auto")
    f = fit_stribeck(pts.w_mean, pts.u_mean, F_std=pts.u_std, fallback=True)
    std = getattr(f, "stderr", None) or {}
    return {"Fc": float(f.Fc), "Fs": float(f.Fs), "Vs": float(f.Vs), "delta": float(f.delta), "sigma": float(f.sigma),
            "std": {k: float(v) for k, v in dict(std).items()}, "fallback": f.fallback, "points": int(pts.w_mean.size),
            "point_method": pts.method}


def run(name: str, repo_dir: Path | None, cache: Path, paths=tuple(PATHS)) -> dict:
    """Fetch, convert to ``t,u,w``, identify by each of ``paths`` and by the static-curve path, compare."""
    log = read_log(name, raw_log(name, repo_dir, cache))
    csv = cache / f"{name}_tuw.csv"
    np.savetxt(csv, np.column_stack([log["t"], log["u"], log["w"]]), delimiter=",", header="t,u,w", comments="")
    out = {"log": name, "n": int(log["t"].size), "Fc_pub": log["Fc"], "fv_pub": log["fv"],
           "cv_residual": log["cv_residual"], "paths": [path_row(name, p, identify(csv, PATHS[p]), log) for p in paths]}
    st = static_fit(log)
    st["curve_error_percent"] = curve_error(st, log["Fc"], log["fv"], log["w"])
    for k, pub in (("Fc", log["Fc"]), ("sigma", log["fv"])):  # normal 95 % interval of the fit's standard error
        half = 1.96 * st["std"].get(k, 0.0)
        st[f"{k}_inside_95"] = _inside([st[k] - half, st[k] + half], pub)
    out["static"] = st
    return out


def _yes(v) -> str:
    return "-" if v is None else ("yes" if v else "**no**")


def main(argv=None) -> int:
    """Command line: ``--repo-dir``, ``--cache``, ``--only NAME``, ``--paths``; prints a Markdown table (one row per
    log and path) and the JSON of each log on stderr."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repo-dir", type=Path, default=None, help="git directory of a clone of " + REPO)
    ap.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "adaptive-ff" / "real_logs")
    ap.add_argument("--only", choices=sorted(LOGS), default=None)
    ap.add_argument("--paths", default=",".join(PATHS),
                    help=f"comma-separated identify runs, of {list(PATHS)} (the --form auto search takes minutes)")
    args = ap.parse_args(argv)
    paths = [p.strip() for p in args.paths.split(",") if p.strip()]
    bad = [p for p in paths if p not in PATHS]
    if bad:
        ap.error(f"--paths: unknown {bad}; choose from {list(PATHS)}")
    print("| log, path | answer (form) | Fc ± std | sigma ± std | offset | curve error | published inside 95 % "
          "(Fc, sigma) | steady-state check: miss, flag | its static line: Fc [95 %], sigma [95 %] | published "
          "inside the line's 95 % |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in ([args.only] if args.only else LOGS):
        r = run(name, args.repo_dir, args.cache, paths)
        for p in r["paths"]:
            s, ss = p["std"], p["steady_state"]
            ln = ss["line"]
            liv = ln.get("interval95", {})
            line = ("-" if not ln else f"{ln['Fc']:.4g} [{liv['Fc'][0]:.4g}, {liv['Fc'][1]:.4g}], {ln['sigma']:.4g} "
                    f"[{liv['sigma'][0]:.4g}, {liv['sigma'][1]:.4g}]")
            miss = "-" if ss["relative_miss"] is None else (f"{100 * ss['relative_miss']:.1f} %, "
                                                           f"{'**flagged**' if ss['flagged'] else 'passed'}")
            print(f"| `{name}`, `{p['path']}` | {p['method']} ({p['form']}) | "
                  f"{p['Fc']:.4g} ± {s.get('Fc', float('nan')):.2g} | "
                  f"{p['sigma']:.4g} ± {s.get('sigma', float('nan')):.2g} | {p['offset'] or 0:.3g} | "
                  f"{p['curve_error_percent']:.1f} % | {_yes(p['Fc_inside_95'])}, {_yes(p['sigma_inside_95'])} | "
                  f"{miss} | {line} | {_yes(ss['Fc_inside_95'])}, {_yes(ss['sigma_inside_95'])} |")
        st = r["static"]
        print(f"| `{name}`, static curve | {st['fallback'] or 'Stribeck'} | "
              f"{st['Fc']:.4g} ± {st['std'].get('Fc', 0):.2g} | {st['sigma']:.4g} ± {st['std'].get('sigma', 0):.2g} | "
              f"- | {st['curve_error_percent']:.1f} % | {_yes(st['Fc_inside_95'])}, {_yes(st['sigma_inside_95'])} | "
              f"- | - | - |")
        print(f"published: Fc = {r['Fc_pub']:.4g}, fv = {r['fv_pub']:.4g} ({name}, {r['n']} samples)", file=sys.stderr)
        print(json.dumps(r, default=str), file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
