"""Tests of adaptive_ff.io.data: CSV reader and its errors, uniform resampling, EMPS loader."""

from pathlib import Path

import numpy as np
import pytest
import scipy.io
from scipy.integrate import cumulative_trapezoid
from scipy.signal import butter, sosfiltfilt

from adaptive_ff.io.data import (MIN_SAMPLES, MeasuredData, is_uniform, load_csv, load_emps, load_measurements,
                              to_uniform)
from plant.errors import SignalError

ROOT = Path(__file__).resolve().parents[2]
EMPS = ROOT / "data" / "emps" / "DATA_EMPS.mat"


def _record(rng, n=200, Ts=1e-3):
    t = Ts * np.arange(n)
    u = rng.normal(size=n)
    w = rng.normal(size=n)
    return t, u, w


def _write_csv(path, header, rows):
    lines = [",".join(header)] + [",".join(str(c) for c in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")


# ---------------------------------------------------------------- CSV round trip


def test_csv_round_trip_with_extra_column(tmp_path):
    rng = np.random.default_rng(1)
    t, u, w = _record(rng)
    extra = rng.normal(size=t.shape[0])
    path = tmp_path / "rec.csv"
    # column order differs from t,u,w and an unrelated column sits between them
    np.savetxt(path, np.column_stack([w, t, extra, u]), delimiter=",", header="w, t,extra,U", comments="")
    d = load_csv(path)
    # savetxt's default '%.18e' is exact for float64
    np.testing.assert_array_equal(d.t, t)
    np.testing.assert_array_equal(d.u, u)
    np.testing.assert_array_equal(d.w, w)
    assert d.source == str(path)


def test_csv_numpy_default_comment_header(tmp_path):
    rng = np.random.default_rng(2)
    t, u, w = _record(rng, n=30)
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([t, u, w]), delimiter=",", header="t,u,w")  # writes '# t,u,w'
    d = load_measurements(path)
    np.testing.assert_array_equal(d.u, u)
    assert d.n_samples == 30


def test_measured_data_is_immutable_and_validated():
    t = np.arange(5.0)
    d = MeasuredData(t, t, t)
    with pytest.raises(ValueError):
        d.u[0] = 1.0
    t[0] = 99.0  # the record holds a copy
    assert d.t[0] == 0.0
    with pytest.raises(SignalError, match="strictly increasing"):
        MeasuredData([0.0, 1.0, 1.0], [1, 2, 3], [1, 2, 3])
    with pytest.raises(SignalError, match="length 3"):
        MeasuredData([0.0, 1.0, 2.0], [1, 2], [1, 2, 3])


# ---------------------------------------------------------------- bad CSV files


def _good_rows(n=30):
    return [[f"{1e-3 * i:.6f}", f"{np.sin(i):.6f}", f"{np.cos(i):.6f}"] for i in range(n)]


def _with(rows, i, j, value):
    rows = [list(r) for r in rows]
    rows[i][j] = value
    return rows


@pytest.mark.parametrize(
    "header, rows, needles",
    [
        (["t", "u", "v"], _good_rows(), ["'w'", "missing"]),
        # data row 5 is line 6 (the header is line 1)
        (["t", "u", "w"], _with(_good_rows(), 4, 1, "abc"), ["'u'", "row 5", "line 6", "'abc'"]),
        (["t", "u", "w"], _with(_good_rows(), 2, 2, ""), ["'w'", "row 3", "line 4", "not a number"]),
        (["t", "u", "w"], _with(_good_rows(), 7, 2, "nan"), ["'w'", "row 8", "line 9", "non-finite"]),
        (["t", "u", "w"], _with(_good_rows(), 0, 0, "inf"), ["'t'", "row 1", "line 2", "non-finite"]),
        (["t", "u", "w"], _with(_good_rows(), 9, 0, "0.001"), ["'t'", "row 10", "line 11", "increasing"]),
        (["t", "u", "w"], _good_rows(MIN_SAMPLES - 1), [f"{MIN_SAMPLES - 1} samples", f"at least {MIN_SAMPLES}"]),
        (["t", "u", "w"], [[r[0], "2.5", r[2]] for r in _good_rows()], ["'u'", "constant"]),
        (["t", "u", "w"], [r[:2] if i == 3 else r for i, r in enumerate(_good_rows())],
         ["'w'", "row 4", "line 5", "missing cell"]),
    ],
    ids=["missing-column", "non-numeric", "empty-cell", "nan", "inf", "non-increasing", "too-few",
         "constant-u", "short-row"],
)
def test_bad_csv_names_file_column_row(tmp_path, header, rows, needles):
    path = tmp_path / "bad.csv"
    _write_csv(path, header, rows)
    with pytest.raises(SignalError) as info:
        load_csv(path)
    msg = str(info.value)
    assert str(path) in msg
    for needle in needles:
        assert needle in msg, f"{needle!r} not in {msg!r}"


def test_empty_csv_and_unknown_suffix(tmp_path):
    empty = tmp_path / "empty.csv"
    empty.write_text("\n\n")
    with pytest.raises(SignalError, match="empty"):
        load_csv(empty)
    other = tmp_path / "rec.txt"
    other.write_text("t,u,w\n")
    with pytest.raises(SignalError, match="unsupported"):
        load_measurements(other)


# ---------------------------------------------------------------- uniform sampling


def test_is_uniform_tolerance():
    rng = np.random.default_rng(3)
    Ts = 1e-3
    small = Ts * (1 + rng.uniform(-0.005, 0.005, 500))  # jitter 0.5 %
    large = small.copy()
    large[100] = 1.05 * Ts                               # one interval 5 % long
    assert is_uniform(np.concatenate([[0.0], np.cumsum(small)]))
    assert not is_uniform(np.concatenate([[0.0], np.cumsum(large)]))
    assert is_uniform(np.concatenate([[0.0], np.cumsum(large)]), rtol=0.1)


def test_to_uniform_resamples_at_median_interval():
    rng = np.random.default_rng(4)
    Ts = 1e-3
    t = Ts * np.arange(300)
    u = rng.normal(size=300)
    w = rng.normal(size=300)
    # insert midpoints after a few samples: those intervals are Ts/2, the median stays Ts
    idx = np.array([10, 50, 51, 200])
    tm = 0.5 * (t[idx] + t[idx + 1])
    t2 = np.insert(t, idx + 1, tm)
    u2 = np.insert(u, idx + 1, 0.5 * (u[idx] + u[idx + 1]))
    w2 = np.insert(w, idx + 1, 0.5 * (w[idx] + w[idx + 1]))
    d = MeasuredData(t2, u2, w2, source="jittery", notes=("raw",))
    assert not is_uniform(d.t)
    out = to_uniform(d)
    # back on the original grid, the interpolated values are the originals; the grid t0 + k*Ts
    # matches t to rounding (~1e-16 s), which the slopes (~|du|/Ts ~ 5e3 per s) turn into ~1e-12
    np.testing.assert_allclose(out.t, t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(out.u, u, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out.w, w, rtol=0, atol=1e-9)
    assert out.notes[0] == "raw" and "resampled" in out.notes[1]
    assert out.source == "jittery"
    # an already uniform record is returned unchanged
    assert to_uniform(out) is out


def test_to_uniform_linear_signal_exact():
    rng = np.random.default_rng(5)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 400))])
    d = MeasuredData(t, 2.0 + 3.0 * t, -1.0 + 0.5 * t)
    out = to_uniform(d)
    Ts = np.median(np.diff(t))
    np.testing.assert_allclose(np.diff(out.t), Ts, rtol=1e-9)
    assert out.t[-1] <= t[-1] + 1e-12 and out.t[-1] > t[-1] - Ts
    np.testing.assert_allclose(out.u, 2.0 + 3.0 * out.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.w, -1.0 + 0.5 * out.t, rtol=0, atol=1e-12)


# ---------------------------------------------------------------- EMPS loader


@pytest.fixture(scope="module")
def emps_raw():
    return scipy.io.loadmat(str(EMPS))


def test_emps_force_and_velocity(emps_raw):
    d = load_emps(EMPS)
    skip = 49
    t = emps_raw["t"].ravel()
    qm = emps_raw["qm"].ravel()
    u_raw = (emps_raw["gtau"] * emps_raw["vir"]).ravel()
    np.testing.assert_array_equal(d.t, t[skip:])
    assert d.n_samples == t.shape[0] - skip

    # u is exactly gtau*vir passed through the same zero-phase filter (independent recomputation)
    sos = butter(4, 100.0, fs=1.0 / np.median(np.diff(t)), output="sos")
    np.testing.assert_allclose(d.u, sosfiltfilt(sos, u_raw)[skip:], rtol=0, atol=1e-9)
    # ... and stays close to the raw force: the filter only removes its > 100 Hz part.
    # Measured: rms(u - u_raw) / rms(u_raw) = 0.30 %; bound 1 %.
    rel = np.sqrt(np.mean((d.u - u_raw[skip:]) ** 2) / np.mean(u_raw[skip:] ** 2))
    assert rel < 0.01, rel

    # velocity vs. the centred finite difference of the raw encoder position, written out
    # independently of np.gradient. Quantisation alone (q = 5e-8 m) puts an rms noise of
    # q/(2*Ts)/sqrt(6) = 1e-5 m/s (1.2e-4 of rms w) on the raw difference; the filter also removes
    # real > 100 Hz content. Measured relative rms difference 1.9e-4; bound 1e-3.
    cd = (qm[2:] - qm[:-2]) / (t[2:] - t[:-2])        # at samples 1 .. N-2
    w_in = d.w[:-1]                                    # samples skip .. N-2
    cd_in = cd[skip - 1:]
    rel_w = np.sqrt(np.mean((w_in - cd_in) ** 2) / np.mean(w_in**2))
    print(f"EMPS velocity vs raw centred difference: relative rms {rel_w:.2e}")
    assert rel_w < 1e-3, rel_w
    # integrating w gives back the measured position: measured max error 1.1 um; bound 5 um (100 quanta)
    pos = qm[skip] + cumulative_trapezoid(d.w, d.t, initial=0.0)
    assert np.max(np.abs(pos - qm[skip:])) < 5e-6
    assert 0.1 < np.max(np.abs(d.w)) < 0.2            # README: peak speed about 0.13 m/s
    assert any("100 Hz" in n for n in d.notes) and any("49" in n for n in d.notes)


def test_emps_missing_variable_and_bad_options(tmp_path, emps_raw):
    bad = tmp_path / "no_vir.mat"
    scipy.io.savemat(str(bad), {k: v for k, v in emps_raw.items() if k in ("t", "qm", "gtau")})
    with pytest.raises(SignalError, match=r"'vir'.*missing"):
        load_emps(bad)
    notmat = tmp_path / "junk.mat"
    notmat.write_bytes(b"this is not a mat file at all" * 10)
    with pytest.raises(SignalError, match="not a readable"):
        load_measurements(notmat)
    with pytest.raises(ValueError, match="Nyquist"):
        load_emps(EMPS, cutoff=600.0)
    with pytest.raises(ValueError, match="order"):
        load_emps(EMPS, order=0)
