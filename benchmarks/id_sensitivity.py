"""How much compare's ``fixed`` row moves when its identification torque changes by one ulp.

Run:  python benchmarks/id_sensitivity.py

The offline identification run of :func:`controllers.experiments.compare.compare` (open loop, band-limited
noise torque through zero speed, lagged Stribeck friction with its ``sgn(w)``) amplifies the last bit of
its input: this scales the identification torque by ``1 + eps`` and prints the fitted ``Fs`` and the
metrics of the ``fixed`` mode (paper preset, 120 s). A change of the arithmetic of the plant step moves
the row by as much (docs/benchmarks/perf.md).
"""

from __future__ import annotations

import sys

import controllers.experiments.compare as cm
from plant import preset


def main() -> int:
    orig = cm.bandlimited_noise
    try:
        for eps in (0.0, 2.0 ** -52, -2.0 ** -52, 1e-12):
            def scaled(*a, eps=eps, **k):
                t, u = orig(*a, **k)
                return t, u * (1.0 + eps)

            cm.bandlimited_noise = scaled
            c = cm.compare(preset("paper"), progress=False, modes=("none", "fixed"))
            m = c.results["fixed"].metrics
            print(f"identification torque x (1 + {eps:+.1e}): fitted Fs {c.offline.estimate.Fs:.6g} N·m; fixed: "
                  f"RMS 2nd half {m.rms_second_half:.6g}, max 2nd half {m.max_second_half:.6g}, "
                  f"reversal RMS {m.rms_reversal:.6g} rad/s")
    finally:
        cm.bandlimited_noise = orig
    return 0


if __name__ == "__main__":
    sys.exit(main())
