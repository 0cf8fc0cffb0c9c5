"""Unusual input: a run too long for the memory, and a joint without friction.

A duration whose runs cannot fit is refused before anything is allocated, with the number of samples, the
memory they need and the longest duration that fits (the numbers recomputed here from the documented memory
model of :mod:`controllers.simulation.memory`: 8 bytes per sample and signal). A joint with ``Fc = Fs = sigma = 0``
runs through ``compare``: every mode whose feedforward is exactly zero tracks exactly as the frictionless loop,
the others within the bound the loop's own linear dynamics give, and eta is undefined (None, ``null``, ``n/a``).
"""

import json
import math
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

import controllers.simulation.memory as memory
from controllers.cli.main import main
from controllers.design.pi import PIController
from controllers.experiments.compare import compare
from controllers.experiments.quasi_static import stribeck_experiment
from controllers.experiments.sweep import load_spec, run_sweep
from controllers.experiments.zoo import ZooOptions, run_zoo
from controllers.simulation.closed_loop import MeasurementSettings, run_closed_loop
from controllers.simulation.compensators import MODES
from plant import JointParams
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset

#: The memory model the messages are checked against (controllers.simulation.memory): float64 signals of N samples.
SHARED, PER_MODE, PREPARATION = 4, 6, 40

#: A joint without friction (its lag and Stribeck factors have nothing to act on).
NO_FRICTION = JointParams(J=0.5, Fc=0.0, Fs=0.0, Vs=0.05, delta=1.5, sigma=0.0, tau=0.01)


def _fake_memory(monkeypatch, n_bytes):
    monkeypatch.setattr(memory, "available_memory", lambda: (int(n_bytes), "are available"))


# ------------------------------------------------------------------------------------------- run length and memory
def test_available_memory_is_memavailable_of_proc_meminfo():
    # read here by a regular expression over the text, the module reads the bytes; outside a cgroup limit the two
    # agree up to what the machine's other processes move between the reads (1 %: MemFree, the other number a
    # wrong line would give, lies a few % below MemAvailable where the kernel holds a page cache)
    try:
        text = open("/proc/meminfo", encoding="ascii").read()
    except OSError:
        pytest.skip("no /proc/meminfo")
    found = memory.available_memory()
    if found is None or found[1] != "are available":
        pytest.skip("a cgroup limit decides")
    expected = int(re.search(r"^MemAvailable:\s+(\d+) kB$", text, re.M).group(1)) * 1024
    assert found[0] == pytest.approx(expected, rel=0.01)


def test_cli_refuses_a_duration_too_long_for_the_memory_with_the_numbers(monkeypatch, capsys):
    _fake_memory(monkeypatch, 16e9)
    code = main(["compare", "--duration", "1e9", "--no-figures", "--quiet", "--yes"])  # --yes: past the work bound
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1
    samples = 1e9 / 1e-3  # 1 kHz
    per_sample = 8 * (SHARED + PER_MODE * len(MODES))  # 416 bytes for the 8 modes
    n_max = 16e9 // per_sample
    assert samples == 1e12 and per_sample * samples == 416e12
    assert err.startswith("adaptive-ff: error: duration = 1e+09 s is 1e12 samples at 1 kHz (Tc = 0.001 s): "
                          "about 416 TB for 8 modes, but 16 GB of memory are available: ")
    assert f"at most {math.floor(n_max * 1e-3):,} s ({n_max * 1e-3 / 3600:.3g} h) fit" in err


def test_cli_message_in_a_fresh_process_has_no_traceback_and_consistent_numbers():
    cli = "import sys; from controllers.cli.main import main; sys.exit(main())"  # the console script's body
    r = subprocess.run([sys.executable, "-c", cli, "compare", "--duration", "1e9", "--quiet", "--no-figures", "--yes"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "Traceback" not in r.stderr and r.stdout == ""
    m = re.fullmatch(r"adaptive-ff: error: duration = 1e\+09 s is 1e12 samples at 1 kHz \(Tc = 0\.001 s\): about "
                     r"416 TB for 8 modes, but ([\d.]+) (GB|TB|MB) of memory (?:are|is) [^:]+: at most ([\d,]+) s.*",
                     r.stderr.strip())
    assert m, r.stderr
    avail = float(m.group(1)) * {"MB": 1e6, "GB": 1e9, "TB": 1e12}[m.group(2)]
    fit = int(m.group(3).replace(",", ""))
    # the printed memory has three significant digits: the longest duration agrees to that rounding
    assert fit == pytest.approx(avail / 416 * 1e-3, rel=6e-3)


def test_python_entries_refuse_before_allocating(monkeypatch):
    with pytest.raises(ParameterError, match=r"duration = 1e\+09 s is 1e12 samples .* 8 modes"):
        compare(preset("paper"), duration=1e9, progress=False)
    # one recorded run of 10 s: the noise and five recorded signals (decimate 1)
    ref = multisine_reference(10.0, dt=1e-3, rng=np.random.default_rng(0))
    _fake_memory(monkeypatch, 100_000)
    ctrl = PIController(Kp=1.0, Ki=10.0, Tc=1e-3)
    with pytest.raises(ParameterError) as info:
        run_closed_loop(NO_FRICTION, ctrl, None, ref,
                        measurement=MeasurementSettings(noise_std=1e-3, rng=np.random.default_rng(0)))
    need = 10_000 * 8 * (1 + 5)
    assert need == 480_000
    assert (f"the reference's duration = 10 s is 10,000 samples at 1 kHz (Tc = 0.001 s): about 480 kB for the "
            f"noise and records of one run, but 100 kB of memory are available: at most "
            f"{100_000 // (8 * 6) * 1e-3:.3g} s fit") == str(info.value)


def test_zoo_and_sweep_count_every_worker(monkeypatch, tmp_path):
    n = 10_000  # 10 s at 1 kHz
    one_compare = 8 * n * (SHARED + PER_MODE * len(MODES))  # the zoo's CompareOptions: every mode
    zoo_worker = 8 * n * (SHARED + PREPARATION + 1)  # group 1: a joint's preparation and one joint's noise
    sweep_case = 8 * n * max(SHARED + PER_MODE * 3, PREPARATION)  # none, fixed, frictionless: fixed's identification
    avail = 1.1 * max(one_compare, zoo_worker, sweep_case)
    assert 2 * zoo_worker > avail and 2 * sweep_case > avail  # one process fits, two do not
    spec = load_spec({"preset": "paper", "grid": {"Fc": [20.0, 30.0]}, "seeds": [0], "modes": ["none", "fixed"],
                      "duration": 10.0})
    _fake_memory(monkeypatch, avail)
    with pytest.raises(ParameterError, match=r"noise of 1 joint in each of 2 processes"):
        run_zoo(ZooOptions.from_flat(n=4, group=1, workers=2, duration=10.0))
    with pytest.raises(ParameterError, match=r"for 3 modes in each of 2 processes"):
        run_sweep(spec, tmp_path / "s.csv", workers=2, progress=False)
    assert not (tmp_path / "s.csv").exists() or (tmp_path / "s.csv").read_text().count("\n") <= 1


# ------------------------------------------------------------------------------------------ a joint without friction
@pytest.fixture(scope="module")
def frictionless_comparison():
    # a data sheet's exact inertia: with the identified one (+2.5 %) dob tracks 3 % off the frictionless run
    return compare(NO_FRICTION, duration=5, seed=0, progress=False, J_design=NO_FRICTION.J)


def _loop_response(u_ff, J: float, Kp: float, Ki: float, Tc: float) -> np.ndarray:
    """Velocity the loop adds in response to the torque ``u_ff`` (same reference and noise): the frictionless
    inertia ``w[k+1] = w[k] + Tc/J*u[k]`` (exact for a torque held over the period) under the PI
    ``u[k] = Kp*e[k] + I[k]``, ``I[k] = I[k-1] + Ki*Tc*e[k]`` (backward Euler), ``e = -w``: linear, so a run with
    a feedforward is the run without it plus this."""
    dw, integ = np.zeros(len(u_ff)), 0.0
    for k in range(len(u_ff) - 1):
        integ -= Ki * Tc * dw[k]
        dw[k + 1] = dw[k] + Tc / J * (-Kp * dw[k] + integ + u_ff[k])
    return dw


def test_frictionless_joint_runs_every_mode_and_tracks_like_the_limit(frictionless_comparison):
    comp = frictionless_comparison
    assert list(comp.results) == list(MODES)
    assert comp.prefit is None and comp.offline is None
    assert any(n.startswith("no friction measured") and "fixed feeds forward zero friction" in n for n in comp.notes)
    r_fl = comp.results["frictionless"]
    rf = r_fl.metrics.rms_second_half
    assert np.all(comp.results["fixed"].u_ff == 0.0)  # nothing identified: a zero feedforward
    for mode in ("none", "fixed", "oracle"):  # zero (oracle: rounding-level) feedforward
        assert abs(comp.results[mode].u_ff).max() < 1e-12
        assert comp.results[mode].metrics.rms_second_half == pytest.approx(rf, rel=1e-9, abs=0)
    # the other modes feed forward what they estimate from noise; without friction the loop is linear, so the run
    # is the frictionless one plus the loop's response to that torque, and it stays within 2 % of its RMS error
    d = comp.design
    for mode in ("canudas", "dob"):
        r = comp.results[mode]
        dw = _loop_response(r.u_ff, NO_FRICTION.J, d.Kp, d.Ki, d.Tc)
        assert np.max(np.abs(dw)) > 1e-7, mode  # a feedforward that acts
        np.testing.assert_allclose(r.w - r_fl.w, dw, rtol=0, atol=1e-12, err_msg=mode)
        assert r.metrics.rms_second_half == pytest.approx(rf, rel=0.02), mode
    # the adaptive modes pass the feedforward supervisor (adaptive_ff/csrc/aff_supervisor.h): a friction feedforward
    # on a joint without friction only adds to the disturbance the PI sees, so it backs off for good, once, and
    # applies nothing after
    for mode in ("adaptive", "adaptive-dob"):
        r = comp.results[mode]
        assert r.info["n_backoff"] == 1 and r.info["n_restore"] == 0, mode
        k_off = len(r.t) - round(r.info["t_off"] / d.Tc)
        assert 0 < k_off < len(r.t) // 2 + len(r.t) // 4, mode
        assert np.all(r.u_ff[k_off:] == 0.0), mode
        assert np.max(np.abs(r.u_ff)) < 0.2, mode  # adaptive: the noise's Stribeck level, projected
        assert r.metrics.rms_second_half == pytest.approx(rf, rel=0.02), mode
    assert comp.results["adaptive"].info["n_implausible"] < 0.05 * comp.results["adaptive"].info["n_updates"]


def test_frictionless_joint_reports_eta_as_undefined(frictionless_comparison, tmp_path):
    comp = frictionless_comparison
    assert all(comp.eta[m] is None and comp.eta_full[m] is None for m in MODES)
    d = json.loads(json.dumps(comp.to_dict(), allow_nan=False))
    assert all(d["modes"][m]["eta"] is None and d["modes"][m]["eta_full"] is None for m in MODES)
    assert d["no_friction"] is True and "prefit" not in d and "offline_ls" not in d
    table = comp.table()
    assert "nan" not in table.lower()
    assert all(line.split()[5:7] == ["-", "-"] for line in table.splitlines()[2:])
    from controllers.report.figures import plot_eta
    from controllers.report.html import compare_report

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. matplotlib's singular axis limits
        fig = plot_eta(comp)
    assert [t.get_text() for t in fig.axes[0].texts] == ["n/a"] * len(MODES)
    html = compare_report(tmp_path / "rep", comp).read_text()
    assert "nan" not in re.sub(r"<img[^>]*>", "", html).lower() and "no friction measured" in html


def test_frictionless_joint_through_the_cli_json(tmp_path, monkeypatch, capsys):
    plant = tmp_path / "p.json"
    plant.write_text(json.dumps({"J": 0.5, "Fc": 0, "Fs": 0, "Vs": 0.05, "delta": 1.5, "sigma": 0, "tau": 0.01}))
    assert main(["compare", "--plant", str(plant), "--duration", "5", "--no-figures", "--quiet", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert [d["modes"][m]["eta"] for m in MODES] == [None] * len(MODES)
    assert d["modes"]["fixed"]["rms"] == d["modes"]["frictionless"]["rms"]


def test_quasi_static_runs_tell_no_friction_from_friction():
    none = stribeck_experiment(NO_FRICTION, J_design=NO_FRICTION.J, noise_std=1e-3, rng=np.random.default_rng(1))
    assert none.no_friction and none.fit is None and none.notes[0].startswith("no friction measured")
    p = preset("paper")
    some = stribeck_experiment(p, J_design=p.J, noise_std=1e-3, rng=np.random.default_rng(1), fit=False)
    assert not some.no_friction


def test_sweep_of_a_frictionless_joint_writes_an_undefined_eta_and_counts_the_case_finished(tmp_path):
    spec = load_spec({"plant": {"J": 0.5, "Fc": 0.0, "Fs": 0.0, "Vs": 0.05, "delta": 1.5, "sigma": 0.0,
                                "tau": 0.01}, "seeds": [0], "modes": ["none", "fixed"], "duration": 3.0})
    out = tmp_path / "s.csv"
    assert run_sweep(spec, out, workers=1, progress=False)["n_run"] == 1
    rows = out.read_text().splitlines()
    assert len(rows) == 1 + 2 and all(r.split(",")[-1] == "nan" for r in rows[1:])  # none, fixed
    assert run_sweep(spec, out, workers=1, progress=False)["n_run"] == 0
