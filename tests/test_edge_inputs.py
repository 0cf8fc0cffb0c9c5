"""Unusual input: a run too long for the memory.

A duration whose runs cannot fit is refused before anything is allocated, with the number of samples, the
memory they need and the longest duration that fits (the numbers recomputed here from the documented memory
model of :mod:`controllers.simulation.memory`: 8 bytes per sample and signal).
"""

import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import controllers.simulation.memory as memory
from controllers.cli.main import main
from controllers.design.pi import PIController
from controllers.experiments.compare import compare
from controllers.experiments.sweep import load_spec, run_sweep
from controllers.experiments.zoo import ZooOptions, run_zoo
from controllers.simulation.closed_loop import run_closed_loop
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
def test_cli_refuses_a_duration_too_long_for_the_memory_with_the_numbers(monkeypatch, capsys):
    monkeypatch.setenv("ADAPTIVE_FF_NO_HELPER", "1")
    _fake_memory(monkeypatch, 16e9)
    code = main(["compare", "--duration", "1e9", "--no-figures", "--quiet"])
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
    r = subprocess.run([sys.executable, "-c", cli, "compare", "--duration", "1e9", "--quiet", "--no-figures"],
                       capture_output=True, text=True, timeout=300,
                       env={**os.environ, "ADAPTIVE_FF_NO_HELPER": "1"})
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
        run_closed_loop(NO_FRICTION, ctrl, None, ref, noise_std=1e-3, rng=np.random.default_rng(0))
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
        run_zoo(ZooOptions(n=4, group=1, workers=2, duration=10.0))
    with pytest.raises(ParameterError, match=r"for 3 modes in each of 2 processes"):
        run_sweep(spec, tmp_path / "s.csv", workers=2, progress=False)
    assert not (tmp_path / "s.csv").exists() or (tmp_path / "s.csv").read_text().count("\n") <= 1
