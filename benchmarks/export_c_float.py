"""Why the float build of ``adaptive-ff export-c`` departs from double: its events, the RLS covariance, a cure.

Run: ``python benchmarks/export_c_float.py [--periods 1000000] [--kind mode|feedforward-only] [--variant V]``.

The setup is that of ``benchmarks/export_c.py`` (tests/export_c_helpers.py): the paper joint's identification
exported with ``--u-max 150``, a closed-loop log of mode ``adaptive`` (velocity noise 1e-3 rad/s) replayed through
the double and the float (``-DAFF_FLOAT``) build of one export. A replay program reads the compensator's state
after each period (the feedforward's output, the sign observer's ``w_hat``, the in-band count, the estimate in
use, the safety chain's counters, the RLS's ``theta`` and ``P``). Printed:

* the deviation of each build from the package's compensation (``deviation`` of tests/export_c_helpers.py);
* the events: runs of periods whose float output departs by more than 1 % of ``Fc``, each with its largest
  deviation, the periods inside the stick band whose sign observer's sign differs between the builds, and the
  lag in use of both builds;
* the largest deviation when each period may match any of its neighbours up to ±k periods;
* the RLS covariance ``P`` of both builds: its smallest eigenvalue over the log, the first update at which the
  float one is not positive definite, and the safety chain's counters that differ (lag held, boxed).

``--variant``: ``as-exported`` (default); ``ud``: the export's covariance update replaced by Bierman's update of
the factors ``P = U D U'`` (the same equations in exact arithmetic; G. J. Bierman, Factorization Methods for
Discrete Sequential Estimation, 1977, Ch. V), an experiment on a copy in a temporary folder, never the package's
sources; ``p0=X``: the export's ``P0`` set to X and its trace bound ``P_max`` to 7*X.
"""

from __future__ import annotations

import argparse
import pathlib
import re
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tests"))
from export_c_helpers import (IDENTIFIED, c_compiler, compile_export, deviation, export_folder,  # noqa: E402
                              package_ff, replay_inputs)

#: Columns of the state record the replay program writes per period.
COLS = ["out", "ff_out", "w_hat", "z_hat", "n_in_band", "u_ff", "gain", "g", "sup", "used0", "used1", "used2",
        "used3", "used4", "used5", "used6", "has", "n_updates", "tau", "n_lag_held", "n_boxed", "n_implausible",
        "n_undetermined", "e2"]
NP = 7

#: ``replay LOG STATE PMAT`` writes per period the record of :data:`COLS` (float64) to STATE, and per RLS update
#: the period, theta and P (float64, 1 + 7 + 49 values) to PMAT.
REPLAY_STATE_C = r"""
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>
#include "aff_config.h"
#define NC %(nc)d
int main(int argc, char **argv)
{
    FILE *f = fopen(argv[1], "rb"), *o, *q;
    long n, k;
    int i;
    int64_t last = 0;
    double *buf, r[NC], pr[1 + 7 + 49];
    static aff c;
    if (argc < 4 || !f || fseek(f, 0, SEEK_END) != 0) return 2;
    n = ftell(f) / 24;
    rewind(f);
    buf = malloc(3 * (size_t)n * sizeof(double));
    if (!buf || fread(buf, sizeof(double), 3 * (size_t)n, f) != 3 * (size_t)n) return 3;
    fclose(f);
    if (aff_init(&c, &AFF_CONFIG) != AFF_OK) return 5;
    o = fopen(argv[2], "wb");
    q = fopen(argv[3], "wb");
    for (k = 0; k < n; k++) {
        aff_adaptive *a = &c.mode;
        aff_robust_ff *ff = &a->ff;
        r[0] = (double)aff_step(&c, (aff_real)buf[n + k], (aff_real)buf[2 * n + k]);
        r[1] = (double)ff->ff.u_out;
        r[2] = (double)ff->ff.ob.w_hat;
        r[3] = (double)ff->ff.ob.z_hat;
        r[4] = (double)ff->ff.n_in_band;
        r[5] = (double)ff->ff.u_ff;
        r[6] = (double)ff->gain;
        r[7] = (double)a->res.sw.g;
        r[8] = (double)a->sup.on;
        for (i = 0; i < 7; i++) r[9 + i] = (double)ff->theta_used[i];
        r[16] = (double)ff->ff.has;
        if (aff_observe(&c, (aff_real)buf[k], (aff_real)buf[n + k]) != 1) return 6;
        r[17] = (double)ff->est.rls.n_updates;
        r[18] = (double)ff->ff.tau;
        r[19] = (double)ff->n_lag_held;
        r[20] = (double)ff->n_boxed;
        r[21] = (double)ff->n_implausible;
        r[22] = (double)ff->n_undetermined;
        r[23] = (double)ff->est.e2;
        if (fwrite(r, sizeof(double), NC, o) != NC) return 4;
        if (ff->est.rls.n_updates != last && ff->est.rls.p == 7) {
            last = ff->est.rls.n_updates;
            pr[0] = (double)k;
            for (i = 0; i < 7; i++) pr[1 + i] = (double)ff->est.rls.theta[i];
            for (i = 0; i < 49; i++) pr[8 + i] = (double)ff->est.rls.P[i];
            if (fwrite(pr, sizeof(double), 57, q) != 57) return 4;
        }
    }
    fclose(o);
    fclose(q);
    return 0;
}
""" % {"nc": len(COLS)}

#: Bierman's factored update (P = U D U', U unit upper triangular), inserted before ``aff_rls_step`` of an
#: export's aff.c by ``--variant ud``: the factors are kept beside the RLS (per struct, up to four), taken afresh
#: from P whenever P was changed outside the update, and P is rebuilt from them after each update, so that every
#: reader of P is unchanged.
UD_C = r"""
typedef struct { const void *key; aff_real U[49]; aff_real d[7]; aff_real P_last[49]; int ok; } aff_ud_slot;
static aff_ud_slot aff_ud_tab[4];
static aff_ud_slot *aff_ud_get(const void *key)
{
    int i;
    for (i = 0; i < 4; i++)
        if (aff_ud_tab[i].key == key) return &aff_ud_tab[i];
    for (i = 0; i < 4; i++)
        if (!aff_ud_tab[i].key) { aff_ud_tab[i].key = key; aff_ud_tab[i].ok = 0; return &aff_ud_tab[i]; }
    return NULL;
}
static void aff_ud_factor(aff_ud_slot *u, const aff_real *P, long p)
{
    long i, j, k;
    memset(u->U, 0, sizeof u->U);
    for (j = p - 1; j >= 0; j--) {
        aff_real dj = P[j * p + j];
        for (k = j + 1; k < p; k++) dj -= u->d[k] * u->U[j * p + k] * u->U[j * p + k];
        u->d[j] = dj;
        u->U[j * p + j] = 1;
        for (i = 0; i < j; i++) {
            aff_real x = P[i * p + j];
            for (k = j + 1; k < p; k++) x -= u->d[k] * u->U[i * p + k] * u->U[j * p + k];
            u->U[i * p + j] = x / dj;
        }
    }
}
/* P <- (P - P phi phi' P/(lam + phi' P phi))/lam through U and D */
static void aff_ud_update(aff_rls *r, const aff_real *phi, long p, aff_real lam)
{
    aff_ud_slot *u = aff_ud_get(r);
    aff_real f[7], g[7], kk[7], beta = lam, bprev;
    long i, j, k;
    if (!u->ok || memcmp(u->P_last, r->P, sizeof(aff_real) * (size_t)(p * p)) != 0) {
        aff_ud_factor(u, r->P, p);
        u->ok = 1;
    }
    for (j = 0; j < p; j++) {
        aff_real x = 0;
        for (i = 0; i <= j; i++) x += u->U[i * p + j] * phi[i];
        f[j] = x;
        g[j] = u->d[j] * x;
    }
    for (j = 0; j < p; j++) {
        aff_real mu;
        bprev = beta;
        beta = beta + f[j] * g[j];
        u->d[j] = u->d[j] * bprev / (beta * lam);
        mu = -f[j] / bprev;
        for (i = 0; i < j; i++) {
            aff_real t = u->U[i * p + j];
            u->U[i * p + j] = t + kk[i] * mu;
            kk[i] = kk[i] + t * g[j];
        }
        kk[j] = g[j];
    }
    for (i = 0; i < p; i++)
        for (j = i; j < p; j++) {
            aff_real x = 0;
            for (k = j; k < p; k++) x += u->U[i * p + k] * u->d[k] * u->U[j * p + k];
            r->P[i * p + j] = x;
            r->P[j * p + i] = x;
        }
    memcpy(u->P_last, r->P, sizeof(aff_real) * (size_t)(p * p));
}
"""

#: The exponential-forgetting covariance update of the export's ``rls_step`` that ``--variant ud`` replaces.
_EXP_UPDATE = re.compile(
    r"        for \(i = 0; i < p; i\+\+\) \{\n            aff_real vi = v\[i\];\n"
    r"            for \(j = i; j < p; j\+\+\) \{\n"
    r"                aff_real x = P\[i \* p \+ j\] - \(vi \* v\[j\]\) / s;\n"
    r"                if \(div != \(aff_real\)1.0\)\n                    x = x / div;\n"
    r"                P\[i \* p \+ j\] = x;\n                P\[j \* p \+ i\] = x;\n            \}\n        \}\n")


def apply_variant(export: pathlib.Path, variant: str) -> None:
    """Edit the export folder for ``variant`` (module docstring). Raises ValueError for an unknown variant or an
    export whose sources no longer have the edited spot."""
    if variant == "as-exported":
        return
    if variant == "ud":
        src = (export / "aff.c").read_text()
        anchor = "aff_real aff_rls_step(aff_rls *r, const aff_real *phi, aff_real y)\n{"
        m = _EXP_UPDATE.search(src)
        if anchor not in src or m is None:
            raise ValueError("variant ud: the export's rls_step is not the one this script edits")
        src = src[:m.start()] + "        (void)P;\n        aff_ud_update(r, phi, p, div);\n" + src[m.end():]
        i = src.index("/* The usual number of parameters")
        src = src[:i] + UD_C + src[i:]
        (export / "aff.c").write_text("#include <string.h>\n" + src)
        return
    if variant.startswith("p0="):
        p0 = float(variant[3:])
        cfg = (export / "aff_config.c").read_text()
        cfg, n1 = re.subn(r"\.P0 = \(aff_real\)[0-9.e+]+", f".P0 = (aff_real){p0!r}", cfg)
        cfg, n2 = re.subn(r"\.P_max = \(aff_real\)[0-9.e+]+", f".P_max = (aff_real){7 * p0!r}", cfg)
        if n1 != 1 or n2 != 1:
            raise ValueError(f"variant {variant}: P0/P_max not found once in aff_config.c")
        (export / "aff_config.c").write_text(cfg)
        return
    raise ValueError(f"--variant {variant!r}: expected as-exported, ud or p0=X")


def replay(periods: int, kind: str, variant: str) -> dict:
    """Export, replay the log through both builds of ``variant``; the package's compensation of the unedited
    export as the reference. Returns ``{"ref", "log", "double": (state, rls), "float": (state, rls)}``: state an
    array (periods, len(COLS)), rls an array (updates, 57): period, theta, P row-major."""
    cc = c_compiler()
    ff_only = kind == "feedforward-only"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        id_file, log, log_file = replay_inputs(tmp, periods)
        out = export_folder(id_file, tmp / "export", *(["--feedforward-only"] if ff_only else []))
        apply_variant(out, variant)
        res = {"ref": package_ff(id_file, log, ff_only), "log": np.asarray(log[:3])}
        for label, flags in (("double", []), ("float", ["-DAFF_FLOAT"])):
            exe = compile_export(cc, out, REPLAY_STATE_C, tmp / f"state_{label}", *flags)
            st, pm = tmp / f"st_{label}.bin", tmp / f"pm_{label}.bin"
            subprocess.run([str(exe), str(log_file), str(st), str(pm)], check=True, capture_output=True)
            res[label] = (np.fromfile(st).reshape(-1, len(COLS)), np.fromfile(pm).reshape(-1, 1 + NP + NP * NP))
    return res


def events(out_f: np.ndarray, out_d: np.ndarray, level: float, gap: int = 200) -> list:
    """Runs of periods with ``|out_f - out_d| > 0.01*level`` (a gap of more than ``gap`` periods starts a new run)."""
    over = np.flatnonzero(np.abs(out_f - out_d) > 0.01 * level)
    return np.split(over, np.flatnonzero(np.diff(over) > gap) + 1) if len(over) else []


def tolerance(out: np.ndarray, ref: np.ndarray, k: int) -> np.ndarray:
    """Per period the smallest ``|out[i] - ref[j]|`` over ``|i - j| <= k``."""
    best = np.abs(out - ref)
    for s in range(1, k + 1):
        best[s:] = np.minimum(best[s:], np.abs(out[s:] - ref[:-s]))
        best[:-s] = np.minimum(best[:-s], np.abs(out[:-s] - ref[s:]))
    return best


def report(res: dict, band: float = 0.003) -> None:
    """Print the tables of the module docstring for the result of :func:`replay`."""
    fc = IDENTIFIED["Fc"]
    ref = res["ref"]
    w = res["log"][1]
    (sd, pd), (sf, pf) = res["double"], res["float"]
    c = {n: i for i, n in enumerate(COLS)}
    for label, st in (("double", sd), ("float", sf)):
        d = deviation(st[:, 0], ref, fc)
        print(f"{label:<7} max {d['max']:.3g} N·m ({100 * d['max'] / fc:.3g} % of Fc), "
              f"±1 period {d['max_shift']:.3g} ({100 * d['max_shift'] / fc:.3g} %), RMS {d['rms']:.3g}, "
              f"> 1 % Fc {d['n_over']}")
    d = deviation(sf[:, 0], sd[:, 0], fc)
    print(f"float against this variant's double: max {d['max']:.3g} N·m ({100 * d['max'] / fc:.3g} %), "
          f"RMS {d['rms']:.3g}, > 1 % Fc {d['n_over']}")
    ev = events(sf[:, 0], ref, fc)
    print(f"events (runs of periods beyond 1 % of Fc): {len(ev)}")
    for e in sorted(ev, key=lambda e: -np.max(np.abs(sf[e, 0] - ref[e])))[:12]:
        k = e[np.argmax(np.abs(sf[e, 0] - ref[e]))]
        lo, hi = max(e[0] - 100, 0), e[-1] + 100
        inb = np.abs(w[lo:hi]) < band
        sign = np.flatnonzero(inb & (np.sign(sd[lo:hi, c["w_hat"]]) != np.sign(sf[lo:hi, c["w_hat"]]))) + lo
        print(f"  periods {e[0]}-{e[-1]} ({len(e)} beyond): max {abs(sf[k, 0] - ref[k]):.3g} N·m at {k}, "
              f"w {w[k]:+.2e} rad/s; in-band sign differs at {len(sign)} periods {sign[:5].tolist()}; "
              f"|w_hat| diff {np.max(np.abs(sd[lo:hi, c['w_hat']] - sf[lo:hi, c['w_hat']])):.2g} rad/s; "
              f"tau in use {sd[k, c['tau']] * 1e3:.3f} / {sf[k, c['tau']] * 1e3:.3f} ms")
    if ev:
        last = max(e[-1] for e in ev)
        tail = np.abs(sf[last + 1:, 0] - ref[last + 1:])
        if len(tail):
            print(f"after period {last}: max {tail.max():.3g} N·m ({100 * tail.max() / fc:.2g} % of Fc)")
    cells = []
    for k in (0, 1, 2, 5, 10):
        t = tolerance(sf[:, 0], ref, k)
        cells.append(f"±{k}: {t.max():.3g} ({100 * t.max() / fc:.3g} %, {np.count_nonzero(t > 0.01 * fc)})")
    print("max deviation with ±k periods of tolerance (periods beyond 1 % of Fc): " + "; ".join(cells))
    _report_rls(pd, pf, sd, sf, c)


def _report_rls(pd: np.ndarray, pf: np.ndarray, sd: np.ndarray, sf: np.ndarray, c: dict) -> None:
    """The RLS covariance's smallest eigenvalue in both builds and the safety chain's counters."""
    n = min(len(pd), len(pf))
    if n == 0:
        print("no RLS update with 7 parameters")
        return
    emin = {b: np.array([np.linalg.eigvalsh(p[i, 1 + NP:].reshape(NP, NP))[0] for i in range(n)])
            for b, p in (("double", pd), ("float", pf))}
    bad = np.flatnonzero(emin["float"] <= 0)
    print(f"RLS updates {n}; smallest eigenvalue of P: double min {emin['double'].min():.3g}, float min "
          f"{emin['float'].min():.3g}; float P not positive definite at {len(bad)} updates"
          + (f", first at period {int(pf[bad[0], 0])}, last at {int(pf[bad[-1], 0])}" if len(bad) else ""))
    dth = np.max(np.abs(pf[:n, 1:1 + NP] - pd[:n, 1:1 + NP]) / np.maximum(np.abs(pd[:n, 1:1 + NP]), 1.0), axis=1)
    i = int(np.argmax(dth))
    print(f"largest difference of the RLS theta (relative to max(|theta|, 1)): {dth[i]:.3g} at period "
          f"{int(pd[i, 0])}; e2 double {sd[-1, c['e2']]:.3g}, float {sf[-1, c['e2']]:.3g} at the end, float max "
          f"{sf[:, c['e2']].max():.3g} (double max {sd[:, c['e2']].max():.3g})")
    for name in ("n_lag_held", "n_boxed", "n_implausible", "n_undetermined"):
        print(f"  {name}: double {int(sd[-1, c[name]])}, float {int(sf[-1, c[name]])}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=10**6)
    ap.add_argument("--kind", choices=["mode", "feedforward-only"], default="mode")
    ap.add_argument("--variant", default="as-exported", help="as-exported, ud or p0=X (module docstring)")
    args = ap.parse_args(argv)
    try:
        res = replay(args.periods, args.kind, args.variant)
    except (RuntimeError, ValueError) as exc:
        print(exc)
        return 2
    print(f"log: {args.periods} periods of mode adaptive on the paper joint; export {args.kind}, variant "
          f"{args.variant}; Fc {IDENTIFIED['Fc']:.4g} N·m; reference: the package's compensation of the unedited "
          "export")
    report(res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
