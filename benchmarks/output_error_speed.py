"""CPU seconds of the output-error identification on a 20 k-sample log, per method, as a user runs it.

Run ``python benchmarks/output_error_speed.py [--duration S] [--methods NAME ...]``. Writes a simulated log
(the ``paper`` preset driven open loop by band-limited torque, the Sec. IV-A experiment, sampled at 1 kHz with
white velocity noise of 1 % of the peak velocity: 20 001 samples for 20 s) into a temporary folder, runs
``adaptive-ff identify`` on it once per method in a child process (``python -m controllers.cli.main``) and
prints a table: CPU seconds of the child (user + system, all its threads: ``resource.getrusage`` of the
children), wall seconds, the project's budget (output error <= 30 s, ``--form auto`` <= 60 s) and whether
it holds, and the fitted J, Fc, Fs against the truth.

Methods:

* ``output_error``: ``identify LOG --Vs 0.02 --delta 1 --lag --method output_error`` (the default bootstrap:
  20 refits by the fit itself);
* ``form_auto``: ``identify LOG --Vs 0.02 --delta 1 --lag --form auto`` (the candidate forms by output error,
  cross-validated);
* ``default``: ``identify LOG --Vs 0.02 --delta 1 --lag`` (the method ``auto`` chooses), for scale.

The CPU seconds count every thread (the bootstrap refits run in threads): on a machine with more cores the
wall time is shorter, the CPU time is the same.

``--work`` prints where the ``output_error`` command's work goes, from its JSON (``info``): the C grid simulations
of the fit (of which its profile over tau, ``info.lag_profile``, and its input-delay profile,
``info.input_delay_profile``), of the bootstrap's refits (``info.bootstrap``) and their CPU seconds per simulation;
then the CPU seconds of the command without its bootstrap (``--bootstrap 0``, imports included).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from plant import bandlimited_noise, preset, sample, simulate  # noqa: E402

DT = 1e-3
#: CPU budgets (s) for a 20 k-sample log.
BUDGET = {"output_error": 30.0, "form_auto": 60.0, "default": float("nan")}
ARGS = {"output_error": ["--method", "output_error"], "form_auto": ["--form", "auto"], "default": []}


def write_log(path: Path, duration: float, seed: int = 0, noise: float = 0.01) -> None:
    """The Sec. IV-A experiment on the ``paper`` preset, sampled at 1 kHz with velocity noise, as CSV t,u,w."""
    p = preset("paper")
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(duration, dt=DT, cutoff=1.0, std=1.2 * (p.Fs + p.sigma * math.radians(20.0)), rng=rng)
    resp = simulate(p, u, dt=DT)
    m = sample(resp, Ts=DT, noise_std=noise * float(np.max(np.abs(resp.w))), rng=rng)
    np.savetxt(path, np.column_stack([m.t, m.u, m.w]), delimiter=",", header="t,u,w", comments="", fmt="%.10g")


def _child(cmd: list) -> tuple:
    """``(cpu, wall, stdout)`` of one child process (user + system seconds of all its threads)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return cpu, wall, proc.stdout


def run(log: Path, method: str, out: Path, extra: tuple = ()) -> dict:
    """CPU and wall seconds of one ``identify`` child process, and its JSON result."""
    cmd = [sys.executable, "-m", "controllers.cli.main", "identify", str(log), "--Vs", "0.02", "--delta", "1",
           "--lag", "--json", "--quiet", "--yes", *ARGS[method], *extra]
    cpu, wall, stdout = _child(cmd)
    (out / f"{method}.json").write_text(stdout)
    try:
        res = json.loads(stdout)
    except json.JSONDecodeError:
        res = {}
    return {"cpu": cpu, "wall": wall, "result": res}


def _param(res: dict, name: str) -> float:
    """A parameter of the CLI's JSON, wherever the report keeps it (top level or under ``params``)."""
    for d in (res, res.get("params", {}), res.get("physical", {}).get("params", {}) if isinstance(
            res.get("physical"), dict) else {}):
        if isinstance(d, dict) and isinstance(d.get(name), (int, float)):
            return float(d[name])
    return float("nan")


def work(log: Path, out: Path, r: dict) -> None:
    """Print where the ``output_error`` command's work goes (module docstring, ``--work``); ``r`` its :func:`run`."""
    info = r["result"].get("info", {})
    fit, boot = int(info.get("n_simulations", 0)), info.get("bootstrap") or {}
    lag, delay = ((info.get(k) or {}).get("n_simulations", 0) for k in ("lag_profile", "input_delay_profile"))
    n_boot, n_valid = int(boot.get("n_simulations", 0)), int(boot.get("n_valid", 0))
    total = fit + n_boot
    print(f"work of output_error: {total} C grid simulations; the fit {fit} (its profile over tau {lag}, its "
          f"input-delay profile {delay}, the rest {fit - lag - delay}); the bootstrap's {n_valid} refits {n_boot} "
          f"(about {n_boot / max(n_valid, 1):.0f} each); {1e3 * r['cpu'] / max(total, 1):.2f} ms of CPU per "
          "simulation (the command's CPU seconds over its simulations)")
    bare = run(log, "output_error", out, ("--bootstrap", "0"))["cpu"]
    print(f"without its bootstrap (--bootstrap 0): {bare:.1f} CPU s (imports included)", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=20.0, help="log length (s) at 1 kHz (default 20: 20 001 samples)")
    ap.add_argument("--methods", nargs="+", choices=tuple(ARGS), default=["output_error", "form_auto"])
    ap.add_argument("--work", action="store_true", help="where the output_error command's work goes (needs "
                    "output_error among --methods)")
    args = ap.parse_args(argv)
    p = preset("paper")
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.csv"
        write_log(log, args.duration)
        n = sum(1 for _ in open(log)) - 1
        print(f"log: paper preset, {args.duration:g} s at 1 kHz ({n} samples), 1 % velocity noise, seed 0; "
              f"{os.cpu_count()} CPUs")
        print(f"{'method':<14}{'CPU s':>8}{'wall s':>8}{'budget':>8}  {'ok':<4}{'J':>8}{'Fc':>8}{'Fs':>8}")
        print(f"{'(truth)':<14}{'':>8}{'':>8}{'':>8}  {'':<4}{p.J:>8.4g}{p.Fc:>8.4g}{p.Fs:>8.4g}")
        runs = {}
        for method in args.methods:
            r = run(log, method, Path(tmp))
            b = BUDGET[method]
            ok = "-" if math.isnan(b) else ("yes" if r["cpu"] <= b else "NO")
            vals = [_param(r["result"], k) for k in ("J", "Fc", "Fs")]
            print(f"{method:<14}{r['cpu']:>8.1f}{r['wall']:>8.1f}{b:>8.0f}  {ok:<4}"
                  + "".join(f"{v:>8.4g}" for v in vals), flush=True)
            runs[method] = r
        if args.work and "output_error" in runs:
            work(log, Path(tmp), runs["output_error"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
