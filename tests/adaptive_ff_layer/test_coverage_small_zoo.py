"""The default identify's 95 % intervals on two seeded joints of the coverage zoo (benchmarks/coverage_zoo.py).

Each joint (eqs. 1-3 drawn around the ``paper`` preset, driven open loop by the Sec. IV-A torque for 15 s, read out
with 1 % velocity noise, a 0.6 N·m torque quantum and the Fig. 10 sampling scaled to 10 ms, each torque stamped at
the end of its 1 ms hold) is rebuilt here from the plant's own functions, as the benchmark draws it. The default
answers them by output error with the input delay profiled. Its bootstrap worlds read the torque with the quantum
the log shows (0.6 N·m); its intervals are centred on the estimate less the refits' mean shift (where it exceeds a
quarter of the standard error), with the refits' spread and the delay's share
(:func:`adaptive_ff.identification.delay_profile.delay_spread`) added in quadrature. Each of the three is needed on one of these joints (measured, in half-widths of the default's
interval): on seed 1 Fc lies -1.11 half-widths from the estimate (-0.88 from the centre), on seed 4 J -1.15 of the
refits' own half-widths from the estimate; with all three every parameter of both joints is inside its interval.
"""

import math

import pytest

from adaptive_ff.identification.covariance import bootstrap_t_quantile
from adaptive_ff.identification.identify import identify
from adaptive_ff.io.data import MeasuredData
from coverage_zoo_joints import zoo_joint

pytestmark = pytest.mark.slow  # two output-error fits with 20 bootstrap refits each (about 90 s of CPU)

KEYS = ("J", "tau", "sigma", "Fc", "Fs")


@pytest.fixture(scope="module", params=[1, 4])
def fitted(request):
    """``(seed, p, report)``: the joint of the seed and the default identify of its readout."""
    p, m = zoo_joint(request.param)
    d = MeasuredData(m.t, m.u, m.w, source=f"zoo joint {request.param}")
    rep = identify(d, Vs=p.Vs, delta=p.delta, lag=True, method="auto", method_options={"bootstrap_workers": 1})
    return request.param, p, rep


def test_every_parameter_of_the_joint_is_inside_its_interval(fitted):
    seed, p, rep = fitted
    assert rep.method == "output_error" and rep.physical.info["input_delay_profile"] is not None
    assert rep.physical.info["bootstrap"]["input_quantum"] == pytest.approx(0.6, rel=1e-9)
    outside = {k: (getattr(p, k), rep.interval95[k]) for k in KEYS
               if not rep.interval95[k][0] <= getattr(p, k) <= rep.interval95[k][1]}
    assert not outside


def _textbook_interval(value, bias, rms, share, n):
    """The interval this test expects, from its parts: centred on the estimate with the RMS deviation and t_n where
    the refits' shift is below a quarter of the standard error (Efron & Tibshirani 1993, Sec. 10.6), else centred
    less the shift with the refits' sample standard deviation about their mean, times sqrt(1 + 1/n), and t_{n-1}
    (the prediction interval of a normal sample); the delay's share in quadrature either way."""
    from scipy.stats import t as student_t

    se = math.sqrt(rms ** 2 + share ** 2)
    if abs(bias) <= 0.25 * se:
        return value, se, student_t.ppf(0.975, n)
    sd2 = (rms ** 2 - bias ** 2) * n / (n - 1)
    return value - bias, math.sqrt(sd2 * (n + 1) / n + share ** 2), student_t.ppf(0.975, n - 1)


def test_the_interval_is_the_centre_and_the_spreads_each_joint_needs(fitted):
    seed, p, rep = fitted
    boot = rep.physical.info["bootstrap"]
    q = bootstrap_t_quantile(boot["n_valid"], 0.95)
    for k in KEYS:
        centre, se, t = _textbook_interval(rep.params[k], boot["bias"][k], boot["stderr_refits"][k],
                                           boot["stderr_delay"][k], boot["n_valid"])
        assert rep.stderr[k] == pytest.approx(se, rel=1e-12)
        assert rep.interval95[k] == pytest.approx([centre - t * se, centre + t * se], rel=1e-12)
    if seed == 1:  # centred on the estimate, Fc's interval would miss: the refits' shift is on the error's side
        err = rep.params["Fc"] - p.Fc
        se = math.hypot(boot["stderr_refits"]["Fc"], boot["stderr_delay"]["Fc"])
        assert abs(err) > q * se and err * boot["bias"]["Fc"] > 0
    else:  # with the refits' spread alone J's interval would miss: the delay's share widens it
        assert abs(rep.params["J"] - p.J) > q * boot["stderr_refits"]["J"]
