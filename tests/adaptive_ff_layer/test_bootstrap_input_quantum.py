"""The output-error bootstrap's worlds can read their input as the log does: the logged torque's quantum
(``bootstrap_input_quantum``).

A drive that logs its torque rounded to a resolution ``q`` hands the fit an input that differs from the one that
drove the joint by an error spread over ``[-q/2, q/2]``. The bootstrap's replicate records are the estimate driven
by such an input (the logged one plus a uniform draw within half a quantum), refitted with the logged input, so
that the refits carry the input's reading error as the fit of the record does. The default finds the quantum from
the log (``"auto"``); None takes the logged input as exact.
"""

import numpy as np
import pytest

from adaptive_ff.identification import physical_id as pid
from adaptive_ff.identification.diagnostics import input_quantum
from plant import bandlimited_noise, irregular_sample_times, preset, sample, simulate
from plant.errors import ParameterError, SignalError

P = preset("paper")
KEYS = ("J", "Fc", "Fs", "sigma", "tau")


def _record(quant: float, seed: int = 2, duration: float = 8.0):
    _, u = bandlimited_noise(duration, dt=1e-3, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * np.radians(20.0)),
                             rng=np.random.default_rng(seed))
    resp = simulate(P, u, dt=1e-3)
    times = irregular_sample_times(duration - 0.1, base=0.01, outlier=0.02, jitter=1e-3, dt=1e-3,
                                   rng=np.random.default_rng(seed + 1))
    return sample(resp, Ts=0.01, times=times, noise_std=0.01 * float(np.max(np.abs(resp.w))), quantization=quant,
                  rng=np.random.default_rng(seed + 2))


@pytest.mark.parametrize("q", [0.6, 0.25, 2.0])
def test_the_quantum_of_a_rounded_input_is_its_step(q):
    rng = np.random.default_rng(0)
    u = np.round(rng.normal(0.0, 40.0, 2000) / q) * q
    assert input_quantum(u) == pytest.approx(q, rel=1e-9)
    assert input_quantum(u + 3.7) == pytest.approx(q, rel=1e-9)  # a lattice offset from 0
    assert input_quantum(np.round(u, 6)) == pytest.approx(q, rel=1e-6)  # as written to a CSV file


def test_a_continuous_input_has_no_quantum():
    rng = np.random.default_rng(1)
    u = rng.normal(0.0, 40.0, 2000)
    assert input_quantum(u) == 0.0
    assert input_quantum(np.array([1.0, 1.0, 2.0, 2.0])) == 0.0  # two levels: nothing to tell a lattice from
    # written with ten digits (as benchmarks/output_error_speed.py writes its log): a lattice of the last digit
    # with far more levels than samples, not a quantum
    assert input_quantum(np.array([float(f"{v:.10g}") for v in u])) == 0.0
    with pytest.raises(SignalError, match="u"):
        input_quantum(np.array([0.0, np.nan, 1.0, 2.0]))


@pytest.mark.parametrize("quantum", ["auto", 0.6])
def test_the_bootstrap_world_is_driven_by_an_input_the_log_reads_as_its_own(monkeypatch, quantum):
    # each replicate record is the estimate driven by the logged torque plus a uniform draw within half a quantum;
    # rounded to the quantum, that input is the logged one again. Spy on the simulations the worlds run.
    m = _record(0.6)
    seen = []
    sim = pid._OutputErrorProblem.simulate_input

    def spy(self, x, u):
        seen.append(np.array(u))
        return sim(self, x, u)

    monkeypatch.setattr(pid._OutputErrorProblem, "simulate_input", spy)
    kw = dict(Vs=P.Vs, delta=P.delta, input_delay=0.5e-3, start={k: getattr(P, k) for k in KEYS}, n_bootstrap=2,
              bootstrap_workers=1)
    f = pid.fit_physical(m.t, m.u, m.w, bootstrap_input_quantum=quantum, **kw)
    boot = f.info["bootstrap"]
    assert boot["input_quantum"] == pytest.approx(0.6, rel=1e-9) and len(seen) == 2
    for u_world in seen:
        dev = u_world - m.u
        assert np.max(np.abs(dev)) <= 0.3 and np.std(dev) == pytest.approx(0.6 / np.sqrt(12.0), rel=0.1)
        assert np.array_equal(np.round(u_world / 0.6) * 0.6, np.round(m.u / 0.6) * 0.6)
    assert not np.array_equal(seen[0], seen[1])  # each world its own draw
    # the default finds the quantum itself ("auto"); None (or 0) takes the logged input as exact: no world
    # simulation added, the same fit
    seen.clear()
    assert pid.OutputErrorOptions().bootstrap_input_quantum == "auto"
    g = pid.fit_physical(m.t, m.u, m.w, bootstrap_input_quantum=None, **kw)
    assert g.info["bootstrap"]["input_quantum"] == 0.0 and not seen and g.params == f.params
    assert g.stderr != f.stderr
    if quantum == "auto":  # a continuous torque has no quantum to draw
        h = pid.fit_physical(m.t, m.u_true, m.w, bootstrap_input_quantum="auto", **kw)
        assert h.info["bootstrap"]["input_quantum"] == 0.0 and not seen


@pytest.mark.parametrize("bad", [-0.1, "yes", float("nan")])
def test_the_quantum_option_is_validated(bad):
    with pytest.raises(ParameterError, match="bootstrap_input_quantum"):
        pid.OutputErrorOptions(bootstrap_input_quantum=bad)
