"""The EMPS benchmark recomputed with scipy alone from the raw .mat files, independent of the package's pipeline
(used by tests/adaptive_ff_layer/test_emps_crosstest.py and tests/adaptive_ff_layer/test_identify_idim.py).

Published (Janot, Gautier, Brunot 2019; data/emps/README.md): M = 95.1089 kg, Fv = 203.5034 N·s/m,
Fc = 20.3935 N, offset = -3.1648 N; relative force error of that model on the validation record 5.98 %. The error
is the benchmark's ``100*||y - y_model||/||y||`` of the low-pass filtered force decimated by 10.
"""

from pathlib import Path

import numpy as np
from scipy.io import loadmat
from scipy.signal import butter, decimate, filtfilt

ROOT = Path(__file__).resolve().parents[1]
EMPS = ROOT / "data" / "emps" / "DATA_EMPS.mat"
PULSES = ROOT / "data" / "emps" / "DATA_EMPS_PULSES.mat"
#: The published reference model (SI) and its cross-test error (%).
PUB = {"J": 95.1089, "sigma": 203.5034, "Fc": 20.3935, "offset": -3.1648}
PUB_CROSS = 5.98
#: Samples dropped at the start, as the benchmark.
HEAD = 49


def raw(path):
    """Force (N), filtered velocity (m/s) and acceleration (m/s²) from the raw file (benchmark steps, scipy only)."""
    m = loadmat(path)
    t, qm = m["t"].ravel(), m["qm"].ravel()
    b, a = butter(4, 100.0 / (0.5 / np.median(np.diff(t))))
    dq = np.gradient(filtfilt(b, a, qm), t)
    return m["gtau"].item() * m["vir"].ravel(), dq, np.gradient(dq, t)


def decimated_rows(path, stop):
    """The IDIM regressor ``[ddq, dq, sign(dq), 1]`` and the force of samples ``HEAD:stop``, each decimated by 10."""
    force, dq, ddq = raw(path)
    sel = slice(HEAD, stop)
    W = np.column_stack([ddq, dq, np.sign(dq), np.ones_like(dq)])[sel]
    return decimate(W, 10, axis=0), decimate(force[sel], 10)


def independent_error(theta, path, stop) -> float:
    """The benchmark's relative force error (%) of ``(J, sigma, Fc, offset)`` on ``path``."""
    W, y = decimated_rows(path, stop)
    return 100 * np.linalg.norm(y - W @ theta) / np.linalg.norm(y)


def independent_fit(path, stop) -> np.ndarray:
    """The IDIM-LS ``(J, sigma, Fc, offset)`` of ``path`` by numpy's lstsq on the scipy-filtered rows."""
    W, y = decimated_rows(path, stop)
    return np.linalg.lstsq(W, y, rcond=None)[0]
