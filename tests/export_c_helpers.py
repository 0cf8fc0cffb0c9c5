"""Shared by tests/adaptive_ff_layer/test_export_c.py and benchmarks/export_c.py: the identification, the closed-loop log and the C
programs that replay it through an export of ``adaptive-ff export-c``."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

#: Periods of the replayed log (1000 s at 1 kHz).
N = 10**6
U_MAX = 150.0
NOISE = 1e-3

#: An ``identify --json`` output of the paper joint (J 4, Fc 25, Fs 35, sigma 40, tau 0.02, Vs 0.02, delta 1):
#: the values ``adaptive-ff identify --Vs 0.02 --delta 1`` gave for a simulated 8 s log of it, method sliding.
IDENTIFIED = {"J": 4.103424729656735, "Fc": 24.950807390864934, "Fs": 37.21688646402248,
              "sigma": 40.130682711238826, "tau": 0.020772473265106176, "offset": 0.001036172817080081}
#: Its layout: the answer (method sliding) at the top level, the paper's eq. 4 LS/RLS (far off in closed loop)
#: under ``baselines`` (tests/adaptive_ff_layer/test_identification_file.py reads the former layout, answer under ``physical``).
ID_JSON = {"method": "sliding", **IDENTIFIED, "Vs": 0.02, "delta": 1.0, "std": {},
           "baselines": {"eq4_ls": {"J": 10.0, "sigma": 36.7, "Fc": 26.1, "Fs": 9.96, "tau": 0.0, "offset": 0.0},
                         "eq4_rls": {"J": 10.0, "sigma": 36.7, "Fc": 26.1, "Fs": 9.96, "tau": 0.0, "offset": 0.0}},
           "excitation": {"noise_std": NOISE, "n_reversals": 8, "low_speed_fraction": 0.05},
           "warnings": [], "notes": []}

#: The replay program: ``replay LOG OUT [N]`` reads u, w, w_ref (float64, one block after the other) from LOG,
#: replays the first N periods (default all) and writes u_ff (float64) to OUT; prints aff_active, aff_n_updates
#: and aff_n_rejected at the end.
REPLAY_C = r"""
#include <stdio.h>
#include <stdlib.h>
#include "aff_config.h"

int main(int argc, char **argv)
{
    FILE *f = fopen(argv[1], "rb");
    long total, n, k;
    double *buf, *u, *w, *w_ref, *uff;
    static aff c;
    if (!f || fseek(f, 0, SEEK_END) != 0) return 2;
    total = ftell(f) / (3 * (long)sizeof(double));
    n = argc > 3 && atol(argv[3]) < total ? atol(argv[3]) : total;
    rewind(f);
    buf = malloc(3 * (size_t)total * sizeof(double));
    uff = malloc((size_t)n * sizeof(double));
    if (!buf || !uff || fread(buf, sizeof(double), 3 * (size_t)total, f) != 3 * (size_t)total) return 3;
    fclose(f);
    u = buf;
    w = buf + total;
    w_ref = buf + 2 * total;
    if (aff_init(&c, &AFF_CONFIG) != AFF_OK) return 5;
    for (k = 0; k < n; k++) {
        uff[k] = (double)aff_step(&c, (aff_real)w[k], (aff_real)w_ref[k]);
        if (aff_observe(&c, (aff_real)u[k], (aff_real)w[k]) != 1) return 6; /* a clean log: no period dropped */
    }
    f = fopen(argv[2], "wb");
    if (!f || fwrite(uff, sizeof(double), (size_t)n, f) != (size_t)n) return 4;
    fclose(f);
    printf("%d %lld %lld\n", aff_active(&c), (long long)aff_n_updates(&c), (long long)aff_n_rejected(&c));
    free(buf);
    free(uff);
    return 0;
}
"""

#: Configures an ``aff`` from AFF_CONFIG and writes the bytes of its mode ``adaptive`` (``c.mode``).
DUMP_C = r"""
#include <stdio.h>
#include "aff_config.h"

int main(int argc, char **argv)
{
    static aff c;
    FILE *f;
    (void)argc;
    if (aff_init(&c, &AFF_CONFIG) != AFF_OK)
        return 2;
    f = fopen(argv[1], "wb");
    return !(f && fwrite(&c.mode, sizeof c.mode, 1, f) == 1 && fclose(f) == 0);
}
"""

WARN = ["-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror", "-ffp-contract=off"]


def compile_export(cc: str, src: Path, main_c: str, exe: Path, *flags: str) -> Path:
    """Compile the export in ``src`` with ``main_c`` into ``exe``: the system compiler, no include path but the
    export's folder, no Python header."""
    (exe.parent / (exe.name + ".c")).write_text(main_c)
    cmd = [cc, *WARN, *flags, f"-I{src}", str(src / "aff.c"), str(src / "aff_config.c"),
           str(exe.parent / (exe.name + ".c")), "-o", str(exe), "-lm"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0 and not r.stderr.strip(), f"{' '.join(cmd)}\n{r.stderr}"
    return exe


def closed_loop_log(options, n: int = N) -> tuple:
    """``n`` periods of the adaptive mode of ``options`` (LoopConfig) on the ``paper`` joint, velocity noise
    :data:`NOISE`, no sensor gate (the loop's measurement is the raw sample the compensator gets), a multisine
    reference (seed 1; noise seed 2): ``(u, w_meas, w_ref, u_ff)``, arrays of ``n``."""

    from controllers.simulation.closed_loop import run_mode
    from plant import preset
    from plant.excitation import multisine_reference

    opts = options.replace(noise_std=NOISE, decimate=1, sensor_gate=False)
    ref = multisine_reference(n * opts.controller.Tc, dt=opts.controller.Tc, rng=np.random.default_rng(1))
    r = run_mode(preset("paper"), ref, "adaptive", opts, rng=np.random.default_rng(2))
    assert r.u.shape == (n,)
    return r.u, r.w_meas, r.w_ref, r.u_ff


def c_compiler() -> str:
    """The system C compiler the replays are built with: ``cc``, else ``gcc``.

    Raises
    ------
    RuntimeError
        Neither is on PATH.
    """
    import shutil

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        raise RuntimeError("no C compiler (cc or gcc) on PATH")
    return cc


def replay_inputs(tmp: Path, periods: int = N) -> tuple:
    """The benchmarks' identification and log in the folder ``tmp``: ``(id_file, log, log_file)``, with
    ``id_file`` :data:`ID_JSON` written as ``tmp/id.json``, ``log`` :func:`closed_loop_log` of ``periods`` periods
    of the compensator it configures, ``log_file`` its ``u, w, w_ref`` (float64, one block after the other) as
    ``tmp/log.bin``, the input of :data:`REPLAY_C`."""
    import json

    from controllers.experiments.compensator_file import compensator_from_file

    id_file = tmp / "id.json"
    id_file.write_text(json.dumps(ID_JSON))
    _, s = compensator_from_file(id_file, u_max=U_MAX)
    log = closed_loop_log(s["options"], periods)
    log_file = tmp / "log.bin"
    np.concatenate([np.asarray(x, dtype=np.float64) for x in log[:3]]).tofile(log_file)
    return id_file, log, log_file


def export_folder(id_file: Path, out: Path, *flags: str) -> Path:
    """``adaptive-ff export-c --from id_file --u-max U_MAX --out out --quiet FLAGS`` (e.g. ``--feedforward-only``):
    the folder ``out``.

    Raises
    ------
    RuntimeError
        The command fails.
    """
    from controllers.cli.main import main as cli

    if cli(["export-c", "--from", str(id_file), "--u-max", str(U_MAX), "--out", str(out), "--quiet", *flags]) != 0:
        raise RuntimeError("adaptive-ff export-c failed on the benchmark's identification")
    return out


def package_ff(path, log, feedforward_only: bool = False) -> np.ndarray:
    """The package's compensation (N·m, an array of the log's length) for ``log`` (``(u, w_meas, w_ref, ...)``, arrays
    of one length): ``aff_replay`` of the package's C core (cffi) on mode ``adaptive``'s compensator configured from
    the identification file ``path`` (``--feedforward-only``'s with ``feedforward_only``), ``u_max`` :data:`U_MAX`.

    Raises
    ------
    RuntimeError
        ``aff_init`` refuses the package's compensator.
    """
    from adaptive_ff._caff import ffi, lib
    from controllers.experiments.compensator_file import compensator_from_file

    comp, _ = compensator_from_file(path, u_max=U_MAX, feedforward_only=feedforward_only)
    u, w, wr = (np.ascontiguousarray(x, dtype=np.float64) for x in log[:3])
    c = ffi.new("aff *")
    if lib.aff_init(c, comp.drive_config()) != lib.AFF_OK:
        raise RuntimeError("aff_init refused the package's compensator")
    uff = np.empty(len(u))
    buf = ffi.from_buffer
    lib.aff_replay(c, buf("double[]", u), buf("double[]", w), ffi.NULL, buf("double[]", wr), buf("double[]", uff),
                   ffi.NULL, len(u))
    return uff


def deviation(uff: np.ndarray, ref: np.ndarray, level: float) -> dict:
    """How far a feedforward sequence ``uff`` is from ``ref`` (N·m, arrays of one length), in N·m.

    ``max`` and ``rms`` of ``|uff - ref|``; ``max_shift``: the largest deviation when each period may also be
    compared with its neighbour in ``ref`` (one period earlier or later): a threshold decision (a sign inside the
    stick band, the count of in-band samples) that falls one period later in float than in double shifts a
    reversal by one period and gives a plain deviation of the feedforward's change over one period there, without
    the compensators differing otherwise; ``n_over``: periods whose plain deviation exceeds 1 % of ``level``
    (N·m, the friction level Fc).
    """
    d = np.abs(uff - ref)
    shifted = d.copy()
    shifted[1:] = np.minimum(shifted[1:], np.abs(uff[1:] - ref[:-1]))
    shifted[:-1] = np.minimum(shifted[:-1], np.abs(uff[:-1] - ref[1:]))
    return {"max": float(np.max(d)), "rms": float(np.sqrt(np.mean(d ** 2))), "max_shift": float(np.max(shifted)),
            "n_over": int(np.count_nonzero(d > 0.01 * level)), "argmax": int(np.argmax(d))}


#: The strict warnings both precisions of an export build clean with, on gcc and clang.
STRICT = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Wconversion", "-Wshadow", "-Wdouble-promotion", "-Werror"]

#: A Cortex-M4F with its single-precision FPU (hard float ABI), the float build.
CORTEX_M4F = ["-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-O2", "-std=c99",
              "-DAFF_FLOAT", "-ffp-contract=off"]

#: Run-time helpers of the ARM EABI that emulate double arithmetic in software: none may be referenced by the float
#: build (its arithmetic is float end to end).
SOFT_DOUBLE = ("__aeabi_d", "__aeabi_f2d", "__aeabi_d2f", "__aeabi_l2d", "__aeabi_i2d", "__aeabi_ui2d")

#: The drive's calls whose worst stack is measured.
ENTRY_POINTS = ("aff_init", "aff_step", "aff_step_gated", "aff_transfer", "aff_observe", "aff_status")


def worst_stack(ci_text: str, entries=ENTRY_POINTS) -> dict:
    """The worst stack depth (bytes) of each entry point from gcc's ``-fcallgraph-info=su`` output: the largest sum
    of the static frame sizes along a call path (the functions of the C library, e.g. ``expf``, count 0: they are
    outside the export). Raises ValueError on a dynamic or unknown frame, or on recursion."""
    import re

    size, calls = {}, {}
    for m in re.finditer(r'node: \{ title: "([^"]+)" label: "([^"]*)"', ci_text):
        title, label = m.group(1), m.group(2)
        fr = re.search(r"\\n(\d+) bytes \((\w+)\)", label)
        if fr and fr.group(2) != "static":
            raise ValueError(f"{title}: a {fr.group(2)} stack frame")
        size[title.split(":")[-1]] = int(fr.group(1)) if fr else 0
    for m in re.finditer(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"', ci_text):
        calls.setdefault(m.group(1).split(":")[-1], set()).add(m.group(2).split(":")[-1])

    def depth(f: str, path: tuple) -> int:
        if f in path:
            raise ValueError("recursion: " + " -> ".join(path + (f,)))
        return size.get(f, 0) + max((depth(g, path + (f,)) for g in calls.get(f, ())), default=0)

    return {e: depth(e, ()) for e in entries}


#: The libFuzzer harness of the exported C API (tests/fuzz_aff.c).
FUZZ_C = Path(__file__).resolve().parent / "fuzz_aff.c"


def build_fuzzer(clang: str, src: Path, exe: Path, *flags: str) -> Path:
    """Compile :data:`FUZZ_C` against the export in ``src`` with libFuzzer, AddressSanitizer and UBSan (any sanitizer
    finding aborts) into ``exe``; ``flags``: e.g. ``-DAFF_FLOAT``."""
    cmd = [clang, "-O1", "-g", *flags, "-fsanitize=fuzzer,address,undefined", "-fno-sanitize-recover=all",
           f"-I{src}", str(src / "aff.c"), str(src / "aff_config.c"), str(FUZZ_C), "-o", str(exe), "-lm"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(cmd)}\n{r.stderr}"
    return exe


def run_fuzzer(exe: Path, corpus: Path, seconds: float, *, seed: int = 1) -> dict:
    """Run a fuzzer of :func:`build_fuzzer` for ``seconds`` from ``corpus`` (a folder, created; new inputs are
    kept there). Returns ``{"returncode", "executions", "coverage", "features", "log"}`` (coverage: libFuzzer's
    covered edges ``cov``, features ``ft``; the log's tail holds a crash's report)."""
    import re

    corpus.mkdir(parents=True, exist_ok=True)
    r = subprocess.run([str(exe), f"-max_total_time={max(1, int(round(seconds)))}", f"-seed={seed}",
                        "-print_final_stats=1", str(corpus)], capture_output=True, text=True,
                       timeout=seconds + 120, cwd=corpus.parent)
    log = r.stdout + r.stderr
    runs = re.search(r"stat::number_of_executed_units: (\d+)", log)
    cov = re.findall(r"cov: (\d+) ft: (\d+)", log)
    return {"returncode": r.returncode, "executions": int(runs.group(1)) if runs else 0,
            "coverage": int(cov[-1][0]) if cov else 0, "features": int(cov[-1][1]) if cov else 0,
            "log": log[-4000:]}
