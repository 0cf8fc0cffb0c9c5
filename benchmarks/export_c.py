"""Benchmark of ``adaptive-ff export-c``: the exported C library's float deviation, time and instructions per period.

Run: ``python benchmarks/export_c.py [--periods 1000000] [--repeat 5] [--callgrind-periods 100000]``.
Two exports: mode ``adaptive`` (the default: the feedforward, the residual observer, the supervisor) and the
feedforward alone (``--feedforward-only``), each in double and float.
``benchmarks/perf.py`` prints the time, tick and instruction rows of this script (``perf_rows``) in its table.

The setup is that of tests/adaptive_ff_layer/test_export_c.py (tests/export_c_helpers.py): the paper joint's identification
exported with ``--u-max 150``, a closed-loop log of the ``adaptive`` mode (velocity noise 1e-3 rad/s) replayed
through the export. Printed, for the double and the float (``-DAFF_FLOAT``) build:

* the deviation of the feedforward from the package's (``aff_replay`` of the package's C core): max and RMS in
  N·m, the max relative to the identified friction level ``Fc`` (target <= 1 % for float), the max when each
  period may also match its neighbour (a threshold decision taken one period later in float), and the number
  of periods beyond 1 % of ``Fc`` (tests/export_c_helpers.py, ``deviation``);
* ns per period (``aff_step`` + ``aff_observe``): a C timing loop compiled with the system compiler at ``-O2``,
  ``clock_gettime(CLOCK_MONOTONIC)`` around the whole replay of the log, median over ``--repeat`` replays; and
  the 99.9th and 99.99th percentile of the single periods of one replay timed period by period (timer
  included): what a real-time task budgets for (the maximum of a shared machine is its scheduler's, not the
  code's); on x86-64 also the time-stamp-counter ticks per period of a whole replay (``__rdtsc``: ticks at
  the CPU's nominal clock, close to its cycles when it runs at that clock);
* instructions per period under ``valgrind --tool=callgrind`` (if valgrind is installed), counted inside the
  replay loop only (``--toggle-collect``) over the first ``--callgrind-periods`` periods of the log: machine
  independent, unlike the times.
"""

from __future__ import annotations

import argparse
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))
from export_c_helpers import (IDENTIFIED, REPLAY_C, c_compiler, compile_export, deviation,  # noqa: E402
                              export_folder, package_ff, replay_inputs)

#: Times the replay of the log: ``time LOG REPEATS``; prints the median over the repeats of the ns per period of a
#: whole replay, then of one replay timed period by period (timer included) the median, 99.9th and 99.99th
#: percentile (ns), the compensator's activity flag, a checksum, and the median time-stamp-counter ticks per period
#: of a whole replay (x86-64 with GCC or Clang: ``__rdtsc``, ticks at the CPU's nominal clock; -1 elsewhere).
TIMING_C = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "aff_config.h"
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <x86intrin.h>
#define TICKS() ((double)__rdtsc())
#else
#define TICKS() (-1.0)
#endif

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    FILE *f = argc < 3 ? NULL : fopen(argv[1], "rb");
    int reps = argc < 3 ? 0 : atoi(argv[2]), r;
    long n, k;
    double *buf, *ns, *per, *tk, sink = 0.0;
    static aff c;
    if (!f || reps < 1 || fseek(f, 0, SEEK_END) != 0) return 2;
    n = ftell(f) / (3 * (long)sizeof(double));
    rewind(f);
    buf = malloc(3 * (size_t)n * sizeof(double));
    ns = malloc((size_t)reps * sizeof(double));
    per = malloc((size_t)n * sizeof(double));
    tk = malloc((size_t)reps * sizeof(double));
    if (!buf || !ns || !per || !tk || fread(buf, sizeof(double), 3 * (size_t)n, f) != 3 * (size_t)n) return 3;
    fclose(f);
    for (r = 0; r < reps; r++) {
        double t0, k0;
        if (aff_init(&c, &AFF_CONFIG) != AFF_OK) return 4;
        k0 = TICKS();
        t0 = now();
        for (k = 0; k < n; k++) {
            sink += (double)aff_step(&c, (aff_real)buf[n + k], (aff_real)buf[2 * n + k]);
            aff_observe(&c, (aff_real)buf[k], (aff_real)buf[n + k]);
        }
        ns[r] = (now() - t0) / (double)n;
        tk[r] = (TICKS() - k0) / (double)n;
    }
    aff_init(&c, &AFF_CONFIG);
    for (k = 0; k < n; k++) {
        double t0 = now();
        sink += (double)aff_step(&c, (aff_real)buf[n + k], (aff_real)buf[2 * n + k]);
        aff_observe(&c, (aff_real)buf[k], (aff_real)buf[n + k]);
        per[k] = now() - t0;
    }
    qsort(ns, (size_t)reps, sizeof(double), cmp);
    qsort(per, (size_t)n, sizeof(double), cmp);
    qsort(tk, (size_t)reps, sizeof(double), cmp);
    printf("%.6g %.6g %.6g %.6g %d %g %.6g\n", ns[reps / 2], per[n / 2], per[n - 1 - n / 1000],
           per[n - 1 - n / 10000], aff_active(&c), sink, tk[reps / 2] < 0 ? -1.0 : tk[reps / 2]);
    return 0;
}
"""


def _callgrind(exe: pathlib.Path, log_file: pathlib.Path, out: pathlib.Path, n: int) -> float | None:
    """Instructions per period inside the replay loop (callgrind, collection toggled on in main's loop only)."""
    vg = shutil.which("valgrind")
    if vg is None:
        return None
    cg = out.with_suffix(".cg")
    subprocess.run([vg, "--tool=callgrind", f"--callgrind-out-file={cg}", "--collect-atstart=no",
                    "--toggle-collect=aff_step", "--toggle-collect=aff_observe", str(exe), str(log_file),
                    str(out), str(n)], check=True, capture_output=True, timeout=3600)
    text = cg.read_text()
    m = re.search(r"^summary:\s+(\d+)", text, re.M) or re.search(r"^totals:\s+(\d+)", text, re.M)
    return int(m.group(1)) / n


#: Time budgets of the compensator per period (ns): 1 µs of a 1 kHz drive's 1 ms period, and the whole 31 µs
#: period of a 32 kHz one.
BUDGETS_NS = {"1 kHz drive (1 µs)": 1000.0, "32 kHz drive (31 µs period)": 31_250.0}


#: The two exports measured: label -> export-c's extra arguments.
EXPORTS = {"mode": [], "feedforward only": ["--feedforward-only"]}


def measure(periods: int = 10**6, repeat: int = 5, callgrind_periods: int = 100_000) -> dict:
    """Export the paper joint's compensator (mode ``adaptive``, and the feedforward alone), replay a closed-loop log
    of mode ``adaptive`` through the double and float builds of each.

    Returns ``{"periods", "compiler", "max_uff", "Fc", "builds": {"mode double": {...}, "mode float": {...},
    "feedforward only double": {...}, ...}}``; each build has the deviation from the package's compensation of the
    same export (``deviation``: max, rms, max_shift, n_over, argmax in N·m), ``ns`` (median ns per period over
    ``repeat`` whole replays), ``p999``/``p9999`` (percentiles of single periods, timer included), ``ticks``
    (time-stamp-counter ticks per period, x86-64 only, else None) and ``instr`` (instructions per period under
    callgrind, None without valgrind).

    Raises
    ------
    RuntimeError
        No C compiler (``cc`` or ``gcc``) on PATH.
    """
    cc = c_compiler()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        id_file, log, log_file = replay_inputs(tmp, periods)
        res = {"periods": periods, "compiler": cc, "Fc": IDENTIFIED["Fc"], "builds": {}}
        for kind, extra in EXPORTS.items():
            out = export_folder(id_file, tmp / kind.replace(" ", "_"), *extra)
            ref = package_ff(id_file, log, feedforward_only=bool(extra))
            res.setdefault("max_uff", float(np.max(np.abs(ref))))
            for label, flags in (("double", []), ("float", ["-DAFF_FLOAT"])):
                name = f"{kind} {label}"
                stem = name.replace(" ", "_")
                rep = compile_export(cc, out, REPLAY_C, tmp / f"replay_{stem}", *flags)
                uff_out = tmp / f"uff_{stem}.bin"
                subprocess.run([str(rep), str(log_file), str(uff_out)], check=True, capture_output=True)
                d = deviation(np.fromfile(uff_out, dtype=np.float64), ref, IDENTIFIED["Fc"])
                timer = compile_export(cc, out, TIMING_C, tmp / f"time_{stem}", *flags)
                r = subprocess.run([str(timer), str(log_file), str(repeat)], check=True, capture_output=True,
                                   text=True)
                fields = r.stdout.split()
                ns, _, p999, p9999 = (float(x) for x in fields[:4])
                ticks = float(fields[6])
                res["builds"][name] = {"deviation": d, "ns": ns, "p999": p999, "p9999": p9999,
                                       "ticks": None if ticks < 0 else ticks,
                                       "instr": _callgrind(rep, log_file, tmp / f"cg_{stem}.out", callgrind_periods)}
    return res


def perf_rows(quick: bool = False) -> list[tuple]:
    """Rows for ``benchmarks/perf.py``'s table, ``(what, value, unit[, fastest])``: per build, ns per period
    (``aff_step`` + ``aff_observe``, median of whole replays; the 99.99th percentile of single periods as the
    second column) with its share of each budget of :data:`BUDGETS_NS`, and instructions per period.

    ``quick``: 10^5 periods, 3 replays, 2*10^4 periods under callgrind (else 10^6, 5, 10^5).
    """
    try:
        res = measure(*((10**5, 3, 20_000) if quick else (10**6, 5, 100_000)))
    except (RuntimeError, OSError, subprocess.CalledProcessError) as exc:
        return [(f"C compensator (aff_step + aff_observe): not measured ({exc})", None, "")]
    rows = []
    for label, b in res["builds"].items():
        share = ", ".join(f"{100 * b['ns'] / ns:.2g} % of {name}" for name, ns in BUDGETS_NS.items())
        rows.append((f"C compensator, {label} build, aff_step + aff_observe per period ({share}); "
                     f"2nd column: 99.99th percentile of single periods", b["ns"], "ns", b["p9999"]))
        if b["ticks"] is not None:
            rows.append(("  the same, time-stamp-counter ticks per period (x86 __rdtsc, the CPU's nominal clock)",
                         b["ticks"], "ticks"))
        if b["instr"] is not None:
            rows.append((f"  the same, instructions per period (callgrind, {res['compiler']} -O2)", b["instr"],
                         "instr"))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=10**6)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--callgrind-periods", type=int, default=100_000)
    args = ap.parse_args(argv)
    try:
        res = measure(args.periods, args.repeat, args.callgrind_periods)
    except RuntimeError as exc:
        print(exc)
        return 1
    fc = res["Fc"]
    print(f"log: {res['periods']} periods of the adaptive mode on the paper joint (noise 1e-3 rad/s); "
          f"compiler {res['compiler']} -O2; max |u_ff| {res['max_uff']:.4g} N·m, Fc {fc:.4g} N·m")
    print(f"{'build':<24}{'max dev':>10}{'of Fc':>10}{'±1 period':>11}{'of Fc':>10}{'RMS dev':>10}{'> 1 % Fc':>10}"
          f"{'ns/period':>11}{'p99.9 ns':>10}{'p99.99 ns':>12}{'ticks':>8}{'instr/period':>14}")
    for label, b in res["builds"].items():
        d, ir = b["deviation"], b["instr"]
        ticks = "n/a" if b["ticks"] is None else f"{b['ticks']:.0f}"
        print(f"{label:<24}{d['max']:>10.3g}{100 * d['max'] / fc:>9.2g}%{d['max_shift']:>11.3g}"
              f"{100 * d['max_shift'] / fc:>9.2g}%{d['rms']:>10.3g}{d['n_over']:>10d}{b['ns']:>11.1f}"
              f"{b['p999']:>10.0f}{b['p9999']:>12.0f}{ticks:>8}{'n/a' if ir is None else f'{ir:.0f}':>14}")
    print("deviations in N·m from the package's compensation of the same export (aff_replay of the package's C core); "
          "'mode': mode adaptive (the default export), 'feedforward only': --feedforward-only; '±1 period': "
          "each period may also match its neighbour (a threshold decision one period later); '> 1 % Fc': "
          "periods whose plain deviation exceeds 1 % of Fc; 'ticks': time-stamp-counter ticks per period (x86)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
