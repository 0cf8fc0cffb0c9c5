"""``compare --json``'s ``offline_ls`` block says whether the fixed mode's offline fit was accepted."""

import json
from types import SimpleNamespace

from adaptive_ff.identification.regression import FrictionEstimate, RegressionModel
from controllers.design.pi import design_pi
from controllers.experiments.compare import Comparison
from plant import preset


def _comparison(notes: tuple) -> Comparison:
    est = FrictionEstimate(J=-3.0, tau=0.02, sigma=40.0, Fc=25.0, Fs=900.0, offset=0.0, Vs=0.02, delta=1.0,
                           J_alt=float("nan"))
    return Comparison(plant=preset("paper"), design=design_pi(4.0, crossover=20.0, phase_margin=60.0, Tc=1e-3),
                      results={}, eta={}, prefit=None, offline=SimpleNamespace(estimate=est),
                      model=RegressionModel(0.02, 1.0, lag=True), notes=notes)


def test_offline_ls_rejected_under_a_fallback_is_marked():
    note = ("fixed: the offline fit of the identification run was rejected (J = -3 kg·m², ...); the pre-fit's "
            "static map is used instead")
    d = _comparison(("a pre-fit note", note)).to_dict()
    json.dumps(d, allow_nan=False)
    assert d["offline_ls"]["J"] == -3.0 and d["offline_ls"]["accepted"] is False
    assert d["offline_ls"]["reason"] == note


def test_offline_ls_accepted():
    d = _comparison(("a pre-fit note",)).to_dict()
    assert d["offline_ls"]["accepted"] is True and d["offline_ls"]["reason"] is None
