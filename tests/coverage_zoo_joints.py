"""The joints of ``benchmarks/coverage_zoo.py`` and their readouts, rebuilt from the plant's own functions.

Each joint: eqs. 1-3 drawn around the ``paper`` preset (J, Fc, Fs, Vs, delta, sigma, tau), driven open loop by the
Sec. IV-A band-limited torque for 15 s, read out with 1 % velocity noise, a 0.6 N·m torque quantum and the Fig. 10
sampling scaled to 10 ms (each torque stamped at the end of its 1 ms hold).
"""

import dataclasses
import math

import numpy as np

from plant import bandlimited_noise, irregular_sample_times, preset, sample, simulate


def zoo_joint(seed: int):
    """``(p, m)``: the joint of ``seed`` (a ``paper``-preset dataclass) and its sampled readout (``m.t``, ``m.u``,
    ``m.w``), as the coverage benchmark draws them."""
    rng = np.random.default_rng(seed)
    lu = lambda lo, hi: float(math.exp(rng.uniform(math.log(lo), math.log(hi))))  # noqa: E731
    J, Fc = lu(1.0, 10.0), float(rng.uniform(10.0, 40.0))
    Fs, Vs, delta = Fc * float(rng.uniform(1.2, 1.6)), lu(0.01, 0.05), float(rng.uniform(0.7, 1.5))
    sigma, tau = float(rng.uniform(20.0, 60.0)), lu(0.005, 0.05)
    p = dataclasses.replace(preset("paper"), J=J, Fc=Fc, Fs=Fs, Vs=Vs, delta=delta, sigma=sigma, tau=tau)
    s_u, s_t, s_n = np.random.SeedSequence(seed).spawn(3)
    _, u = bandlimited_noise(15.0, dt=1e-3, cutoff=1.0, std=1.2 * (p.Fs + p.sigma * math.radians(20.0)),
                             rng=np.random.default_rng(int(s_u.generate_state(1)[0])))
    resp = simulate(p, u, dt=1e-3)
    times = irregular_sample_times(14.9, base=0.01, outlier=0.02, jitter=1e-3, dt=1e-3,
                                   rng=np.random.default_rng(s_t))
    m = sample(resp, Ts=0.01, times=times, noise_std=0.01 * float(np.max(np.abs(resp.w))), quantization=0.6,
               rng=np.random.default_rng(s_n))
    return p, m
