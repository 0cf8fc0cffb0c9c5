"""Regression pins: one plant of each friction model, every adaptive mode against the
fixed feedforward and the disturbance observer, with margins that a 10 % error in the estimated lag breaks.

Each case is one seeded ``compare`` run of 30 s (the numbers are deterministic). Pinned: the margin target
(``adaptive-dob``, and ``adaptive`` where friction is a sliding model, reach ``max(fixed, dob) - 0.02``), the
estimated lag within 5 % of the plant's where the plant has one, and ``rms_dev`` (RMS of ``w -
w_frictionless``, which does not saturate near the limit as eta does) within 10 % of the measured value.
"""

import pytest

from controllers.experiments.compare import compare
from plant.friction import preset
from plant.variant_plants import variant

MODES = ("fixed", "adaptive", "adaptive-dob", "dob")
#: plant -> (sliding model, {mode: true lag the estimate is pinned to}, measured rms_dev of adaptive-dob in rad/s).
#: LuGre has no lag parameter; on the asymmetric plant the estimated lag absorbs part of the direction-dependent
#: levels (biased low, see docs/benchmarks/variants.md), and on Karnopp the observer's residual torque biases the
#: composite's lag estimate: those are pinned through rms_dev instead.
#: The rms_dev values are those with the feedforward's provisional start (FeedforwardStart, commit 5801f5b; without
#: it: paper 1.3502e-3, lugre 1.4118e-3, karnopp 2.2466e-3 rad/s) and the loop-model stick fallback (LoopModel,
#: merge f44a519; with the reference as the fallback: paper 7.4706e-4, karnopp 1.8791e-3 rad/s, lugre within 10 %).
#: Since the adaptive start takes its lag from the identification run and acts from the first period (commit
#: 9717cda; before: paper 6.1861e-4, lugre 1.2475e-3, karnopp 1.6510e-3 rad/s and t_ff_on 1 ms): plain adaptive's
#: rms_dev fell by 40 % on lugre and 3 % on asymmetric, adaptive-dob's rose by 13 % on lugre (30 s run; 4 % at 120 s).
#: With the sign observer of the feedforward and 50 stick samples (commit 88db4dc) adaptive-dob's rms_dev on lugre
#: rose from 1.4054e-3 to 1.6097e-3 rad/s (30 s run); paper and karnopp stay within 10 %.
#: With the lag margin and the determinacy test of the adaptive estimate (commit a42b9e9) adaptive-dob's rms_dev on
#: karnopp rose from 1.5969e-3 to 1.7661e-3 rad/s (30 s run, the start; +1.7 % over 120 s in variants.md);
#: paper (5.5059e-4) and lugre (1.5762e-3) stay within 3 %.
CASES = {"paper": (True, {"adaptive": 0.02, "adaptive-dob": 0.02}, 5.6650e-4), "lugre": (False, {}, 1.6097e-3),
         "karnopp": (False, {"adaptive": 0.02}, 1.7661e-3), "asymmetric": (True, {}, None)}


@pytest.mark.parametrize("name", list(CASES))
def test_adaptive_modes_are_not_beaten_on_each_friction_model(name):
    sliding, tau, dev = CASES[name]
    p = preset("paper") if name == "paper" else variant(name)
    c = compare(p, duration=30.0, seed=0, modes=MODES, progress=False)
    best_peer = max(c.eta["fixed"], c.eta["dob"])
    print(name, {m: round(c.eta[m], 4) for m in c.eta}, {m: c.rms_dev[m] for m in MODES},
          {m: (c.results[m].estimate.tau if c.results[m].estimate else None) for m in ("adaptive", "adaptive-dob")})
    assert c.eta["adaptive-dob"] >= best_peer - 0.02
    if sliding:
        assert c.eta["adaptive"] >= best_peer - 0.02
    for m, t in tau.items():
        assert c.results[m].estimate.tau == pytest.approx(t, rel=0.05), m
    assert c.t_ff_on["adaptive-dob"] == 0.0  # the start acts from the first period
    assert c.rms_dev["adaptive-dob"] < c.rms_dev["dob"]
    if dev is not None:
        assert c.rms_dev["adaptive-dob"] == pytest.approx(dev, rel=0.10)
