"""Every golden case recomputed and compared with its frozen record in ``tests/golden/``.

The records hold the results of the package as it was with its numba kernels (``tests/golden/README.md``:
commit, date, how they were made). After a change of the kernels' implementation (numba to C) every case must
give the same numbers:

* every float within ``RTOL = 1e-9`` relative, with an absolute floor of ``RTOL`` times the largest magnitude of
  its array (the whole list of a signal, the column of a parameter history), so that a signal's zero crossings
  and a parameter near zero do not fail on rounding;
* NaN (stored as ``null``) and infinities (``"inf"``, ``"-inf"``) where they were, integers, flags and strings
  exactly, the same keys and lengths;
* identified parameters (below :data:`ESTIMATE_KEYS`) within ``ESTIMATE_RTOL = 1e-6``, and the few cases of
  :data:`LOOSE` within their own tolerance, each with its reason.

The cases run the paper's discontinuous friction (the ``sgn(w)`` of eq. 3, sticking, a gate that rejects a
sample or not) in closed loop with noise: a change in the last bit of one input can move a trajectory by far
more than the bit. The cases are built so that it does not (tests/golden/README.md): every case passes with its
tolerance when recomputed on an emulated other CPU (``NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL AVX512_SPR"
NUMBA_CPU_NAME=generic``: numpy without its AVX-512 loops, numba for a generic x86-64) and when the reference,
the identification torque or ``Kp`` is changed in its last bit (the largest deviation is a third of the
tolerance).

Never regenerate a record to make this test pass (README).
"""

from __future__ import annotations

import json
import math

import pytest

from golden_cases import CASES, compute, golden_path

#: Relative tolerance of every float (and, times the array's largest magnitude, its absolute floor).
RTOL = 1e-9

#: Relative tolerance of the parameters an estimator identified (the subtrees under :data:`ESTIMATE_KEYS`). The
#: recursive estimators in closed loop, the Stribeck pre-fit and the UKF amplify a change in the last bit of their
#: data where the regression is ill-conditioned; most of all on parameters near zero (the torque offset of a joint
#: without one, the lag of a static joint): measured up to 2e-8 relative under a 1-ulp change of the reference
#: or of ``Kp`` (README). The signals those estimates drive (``u_ff``, ``u``, ``w``) stay at :data:`RTOL`.
ESTIMATE_RTOL = 1e-6

#: Keys whose values (and everything below them) are identified parameters.
ESTIMATE_KEYS = frozenset({"estimate", "raw_estimate", "canudas_estimate", "adaptive_final", "offline_ls", "prefit",
                           "theta", "theta_hist", "theta_std", "final", "final_std", "noise_estimate",
                           "stribeck_fit"})

_STIFF_LUGRE = ("the stiff LuGre joint takes error-controlled implicit sub-steps (plant.stiff.lugre_stiff_step, "
                "step doubling with LUGRE_RTOL = 1e-5 on the velocity, LUGRE_ZTOL = 1e-3 on the bristle state): a "
                "last-bit change can flip an accept/reject decision and move the state within those tolerances; "
                "measured under a 1-ulp change of the reference or Kp: ")

#: Cases compared with a looser relative tolerance (everything in them): case -> (rtol, reason). Each is about 10
#: to 30 times the largest deviation measured under changes of the last bit of the inputs (tests/golden/README.md).
LOOSE: dict = {
    "loop-stiff-lugre-fixed": (1e-7, _STIFF_LUGRE + "3e-9 (u_ff)"),
    "loop-stiff-lugre-adaptive": (1e-8, _STIFF_LUGRE + "2e-10 (the friction f), 3e-9 (offset estimate)"),
    "loop-stiff-lugre-oracle": (1e-6, _STIFF_LUGRE + "6e-8 (u_ff)"),
    "loop-stiff-lugre-adaptive-dob": (1e-4, _STIFF_LUGRE + "5e-6 (the friction f), 2e-7 (offset estimate)"),
    "loop-stiff-lugre-dob": (1e-3, _STIFF_LUGRE + "5e-5 (the friction f, through sigma1*dz/dt)"),
    "compare-paper-stickslip": (0.25, "the lagged paper joint sticks at the reversals under none, canudas and "
                                "fixed and chatters at w = 0 (the sign of eq. 3 flips every step or two): a "
                                "last-bit change grows e-fold per 25 ms of sticking; measured over six changes of "
                                "the inputs' last bits: up to 8.3 % (eta of canudas, weak: 0.11), 4 % (its "
                                "reversal RMS), 1.3 % (max of none), 0.7 % (RMS of none); the adaptive run, started from "
                                "the pre-fit and the offline fit, moves by 7e-10 (its metrics) and 5e-7 (its offset)"),
}

_NUMERIC = (int, float)


def _is_num(x) -> bool:
    return x is None or x in ("inf", "-inf") or (isinstance(x, _NUMERIC) and not isinstance(x, bool))


def _as_float(x) -> float:
    if x is None:
        return math.nan
    if x == "inf":
        return math.inf
    if x == "-inf":
        return -math.inf
    return float(x)


def _scale(values) -> float:
    """Largest finite magnitude among ``values`` (frozen numbers; None/inf ignored), 0 when none."""
    mags = [abs(_as_float(v)) for v in values if _is_num(v)]
    mags = [m for m in mags if math.isfinite(m)]
    return max(mags, default=0.0)


def _number(got, want, where: str, floor: float, est: bool):
    """``(ratio, where, got, want, est)``: ``|got - want| / (max(|got|, |want|) + floor)``, 0 when equal, inf when a
    flag, an integer, a NaN or an infinity differs."""
    if isinstance(want, bool) or isinstance(got, bool):
        return (0.0 if got is want else math.inf), where, got, want, est
    if isinstance(want, int) and isinstance(got, int):
        return (0.0 if got == want else math.inf), where, got, want, est
    g, w = _as_float(got), _as_float(want)
    if not (math.isfinite(g) and math.isfinite(w)):
        same = g == w or (math.isnan(g) and math.isnan(w))
        return (0.0 if same else math.inf), where, got, want, est
    if g == w:
        return 0.0, where, got, want, est
    return abs(g - w) / (max(abs(g), abs(w)) + floor), where, got, want, est


def deviations(got, want, where: str, est: bool = False, floor: float = 0.0):
    """Every number of the frozen record ``want`` against ``got``: yields ``(ratio, where, got, want, est)``.

    ``ratio`` is the relative difference with the floor of the enclosing array (module docstring): the value
    passes where ``ratio <= rtol``. A structural difference (keys, lengths, strings) gives ``inf``. ``est`` is
    True below a key of :data:`ESTIMATE_KEYS`.
    """
    if isinstance(want, dict):
        if not isinstance(got, dict) or set(got) != set(want):
            gk = sorted(got) if isinstance(got, dict) else type(got).__name__
            yield math.inf, where, f"keys {gk}", f"keys {sorted(want)}", est
            return
        for k in want:
            yield from deviations(got[k], want[k], f"{where}.{k}", est or k in ESTIMATE_KEYS)
        return
    if isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            n = len(got) if isinstance(got, list) else type(got).__name__
            yield math.inf, where, f"length {n}", f"length {len(want)}", est
            return
        if all(_is_num(v) for v in want) and all(_is_num(v) for v in got):  # a signal or vector: one scale
            s = _scale(want)
            for i, (g, w) in enumerate(zip(got, want)):
                yield _number(g, w, f"{where}[{i}]", s, est)
            return
        rows = [r for r in want if isinstance(r, list)]
        if rows and len(rows) == len(want) and all(len(r) == len(rows[0]) and all(_is_num(v) for v in r)
                                                   for r in rows):
            # a matrix (a parameter history, a covariance): the floor of each column is its own scale
            scales = [_scale([r[j] for r in rows]) for j in range(len(rows[0]))]
            for i, (gr, wr) in enumerate(zip(got, want)):
                if not (isinstance(gr, list) and len(gr) == len(wr) and all(_is_num(v) for v in gr)):
                    yield math.inf, f"{where}[{i}]", gr, wr, est
                    continue
                for j, (g, w) in enumerate(zip(gr, wr)):
                    yield _number(g, w, f"{where}[{i}][{j}]", scales[j], est)
            return
        for i, (g, w) in enumerate(zip(got, want)):
            yield from deviations(g, w, f"{where}[{i}]", est)
        return
    if _is_num(want) and _is_num(got):
        yield _number(got, want, where, floor, est)
    else:
        yield (0.0 if got == want else math.inf), where, got, want, est


def compare_records(got, want, where: str, rtol: float = RTOL, est_rtol: float = ESTIMATE_RTOL) -> list:
    """Differences of ``got`` from ``want`` beyond the tolerance (module docstring), as messages.

    Parameters
    ----------
    got, want : strict-JSON values
        Recomputed and frozen record.
    where : str
        Name of the record (the case), the start of every message's path.
    rtol, est_rtol : float
        Relative tolerance of the numbers, and of those below :data:`ESTIMATE_KEYS`.

    Returns
    -------
    list of str
        One message per mismatch: where (case, keys, index), recomputed and frozen value, difference, tolerance.
    """
    out = []
    for ratio, path, g, w, est in deviations(got, want, where):
        tol = max(rtol, est_rtol) if est else rtol
        if ratio > tol:
            if math.isinf(ratio):
                out.append(f"{path}: got {g!r}, frozen {w!r}")
            else:
                out.append(f"{path}: got {g!r}, frozen {w!r}, |diff| {abs(_as_float(g) - _as_float(w)):.3g} "
                           f"is {ratio:.3g} of the value (with the array's floor) > {tol:g}")
    return out


def _frozen(name: str) -> dict:
    return json.loads(golden_path(name).read_text())


@pytest.mark.parametrize("name", list(CASES))
def test_case_equals_frozen_record(name):
    path = golden_path(name)
    assert path.exists(), f"{name}: no frozen record {path} (python -m tests.golden_cases --freeze {name})"
    want = _frozen(name)["record"]
    got = json.loads(json.dumps(compute(name), allow_nan=False))
    rtol, why = LOOSE.get(name, (RTOL, ""))
    bad = compare_records(got, want, name, rtol)
    shown = "\n  ".join(bad[:12]) + (f"\n  ... and {len(bad) - 12} more" if len(bad) > 12 else "")
    loose = f"; loose: {why}" if why else ""
    assert not bad, (f"{name}: {len(bad)} value(s) differ from the frozen record {path.name} (rtol {rtol:g}, "
                     f"estimates {max(rtol, ESTIMATE_RTOL):g}{loose}):\n  {shown}")


def test_every_record_has_a_case():
    files = sorted(p.stem for p in golden_path("x").parent.glob("*.json"))
    assert set(files) == set(CASES), (sorted(set(files) - set(CASES)), sorted(set(CASES) - set(files)))


def test_comparison_catches_a_change():
    # the comparator itself: a relative change of 1e-8 fails, one of 1e-10 passes; the floor is the array's scale
    want = {"w": [1.0, -2.0, 0.0, None, "inf"], "n": 3, "m": [[1.0, 1e-3], [2.0, 2e-3]]}
    assert compare_records(json.loads(json.dumps(want)), want, "c") == []
    assert compare_records({**want, "w": [1.0 + 1e-8, -2.0, 0.0, None, "inf"]}, want, "c")
    assert compare_records({**want, "w": [1.0 + 1e-10, -2.0, 1e-9, None, "inf"]}, want, "c") == []
    assert compare_records({**want, "w": [1.0, -2.0, 0.0, 0.0, "inf"]}, want, "c")  # NaN must stay NaN
    assert compare_records({**want, "n": 4}, want, "c")
    assert compare_records({**want, "m": [[1.0, 1e-3 + 1e-11], [2.0, 2e-3]]}, want, "c")  # column scale 2e-3
    assert compare_records({**want, "w": [1.0, -2.0, 0.0, None, "-inf"]}, want, "c")  # the sign of inf
    msg = compare_records({**want, "w": [1.0, -2.5, 0.0, None, "inf"]}, want, "case")[0]
    assert msg.startswith("case.w[1]: got -2.5, frozen -2.0")
    # identified parameters: 1e-6; the same change elsewhere fails
    est = {"estimate": {"Fc": 25.0}, "metrics": {"rms": 0.02}}
    assert compare_records({"estimate": {"Fc": 25.0 * (1 + 1e-7)}, "metrics": {"rms": 0.02}}, est, "c") == []
    assert compare_records({"estimate": {"Fc": 25.0}, "metrics": {"rms": 0.02 * (1 + 1e-7)}}, est, "c")
    assert compare_records({"estimate": {"Fc": 25.0 * (1 + 1e-5)}, "metrics": {"rms": 0.02}}, est, "c")
