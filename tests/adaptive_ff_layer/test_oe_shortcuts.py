"""The output-error paths that save CPU time without changing the numbers, and the input-delay profile of the form
selection.

* The local quadratic fits of ``velocity_noise_std_irregular`` depend on the stamps only: ``noise_fit_weights``
  computes them once and the bootstrap's replicates (the same stamps) reuse them. Checked against the
  Savitzky-Golay weights of a uniform grid (an independent closed form) and bit for bit against the computation
  without them.
* ``select_form`` profiles the input delay as ``fit_physical`` does (``delay_profile_search``) where it is not given.
* ``identify --method auto``, answering by output error, shows the bootstrap's progress bar unless ``--quiet``.
"""

import json
import math

import numpy as np
import pytest

import adaptive_ff.identification.identify as identify_module
import adaptive_ff.identification.model_forms as model_forms
import adaptive_ff.identification.physical_id as physical_id
from adaptive_ff.identification.delay_profile import delay_profile_search
from adaptive_ff.identification.diagnostics import noise_fit_weights, velocity_noise_std_irregular
from adaptive_ff.identification.model_forms import select_form
from adaptive_ff.io.data import MeasuredData
from controllers.cli.main import main
from plant import bandlimited_noise, irregular_sample_times, preset, sample, simulate
from plant.errors import ParameterError

P = preset("paper")


def _record(seed=3, duration=4.0, times=None):
    """The paper joint driven by the Sec. IV-A torque, read out at 10 ms with 1 % velocity noise (seeded)."""
    rng = np.random.default_rng(seed)
    _, u = bandlimited_noise(duration, dt=1e-3, cutoff=1.0, std=1.2 * (P.Fs + P.sigma * math.radians(20.0)), rng=rng)
    resp = simulate(P, u, dt=1e-3)
    return sample(resp, Ts=0.01, times=times, noise_std=0.01 * float(np.max(np.abs(resp.w))), rng=rng)


def test_noise_weights_of_a_uniform_grid_are_the_savitzky_golay_weights():
    # the least-squares quadratic through 5 equally spaced points, at the centre: (-3, 12, 17, 12, -3)/35
    # (Savitzky & Golay, Anal. Chem. 36(8), 1964, table I); the centre's leverage is its own weight 17/35
    t = 0.01 * np.arange(50)
    row, scale = noise_fit_weights(t)
    assert row.shape == (46, 5) and scale.shape == (46,)
    np.testing.assert_allclose(row, np.tile(np.array([-3, 12, 17, 12, -3]) / 35.0, (46, 1)), atol=1e-14)
    np.testing.assert_allclose(scale, math.sqrt(1.0 - 17.0 / 35.0), rtol=1e-13)


def test_noise_with_the_weights_is_the_noise_without_them_bit_for_bit():
    rng = np.random.default_rng(7)
    t = np.cumsum(rng.uniform(0.005, 0.02, 400))
    weights = noise_fit_weights(t)
    for k in range(3):
        w = np.sin(3.0 * t) + 0.01 * (k + 1) * rng.standard_normal(t.shape[0])
        assert velocity_noise_std_irregular(t, w, weights=weights) == velocity_noise_std_irregular(t, w)
    with pytest.raises(ParameterError, match="weights must be noise_fit_weights"):
        velocity_noise_std_irregular(t[:-1], w[:-1], weights=weights)


def test_the_bootstrap_refits_compute_the_noise_weights_once(monkeypatch):
    m = _record()
    calls = []

    def spy(t):
        calls.append(t.shape[0])
        return noise_fit_weights(t)

    monkeypatch.setattr(physical_id, "noise_fit_weights", spy)
    kw = dict(Vs=P.Vs, delta=P.delta, n_bootstrap=2, bootstrap_workers=1, input_delay=0.0)
    f = physical_id.fit_physical(m.t, m.u, m.w, **kw)
    # one computation for the fit and its two refits (each refit used to compute its own)
    assert calls == [m.t.shape[0]]
    assert f.info["noise_std"] == velocity_noise_std_irregular(m.t, m.w) and f.info["bootstrap"]["n_valid"] == 2


def test_select_form_profiles_the_delay_where_it_is_not_given(monkeypatch):
    m = _record(seed=5)
    data = MeasuredData(m.t, m.u, m.w)
    profiles = []

    def spy(*args, **kwargs):
        out = delay_profile_search(*args, **kwargs)
        profiles.append(out[1])
        return out

    monkeypatch.setattr(model_forms, "delay_profile_search", spy)
    forms = ["coulomb_viscous", "coulomb_viscous_lag"]
    sel = select_form(data, folds=2, forms=forms)
    assert len(profiles) == 1
    prof = sel.input_delay_profile
    assert prof is profiles[0] and prof["form"] in forms and sel.input_delay == prof["chosen"]
    # the delay chosen is the profile's lowest cost, sub-sample (0 .. one median stamp interval and the vertex)
    assert prof["cost"][prof["delay"].index(prof["chosen"])] == min(prof["cost"])
    assert 0.0 <= sel.input_delay <= float(np.median(np.diff(m.t)))
    d = json.loads(json.dumps(sel.to_dict(), allow_nan=False))
    assert d["input_delay"] == sel.input_delay and d["input_delay_profile"]["form"] == prof["form"]
    given = select_form(data, folds=2, forms=forms, input_delay=0.0)
    assert len(profiles) == 1 and given.input_delay == 0.0 and given.input_delay_profile is None
    with pytest.raises(ParameterError, match=r"input_delay must be >= 0 s \(or None: profiled\)"):
        select_form(data, folds=2, forms=forms, input_delay=-1e-3)


@pytest.mark.parametrize("quiet, progress", [(False, None), (True, False)])
def test_cli_auto_answering_by_output_error_shows_the_bootstrap_progress(tmp_path, monkeypatch, capsys, quiet,
                                                                         progress):
    # the Fig. 10 readout scaled to 10 ms: the default answers it by output error (identify.choose_method)
    times = irregular_sample_times(3.9, base=0.01, outlier=0.02, jitter=1e-3, dt=1e-3,
                                   rng=np.random.default_rng(2))
    m = _record(seed=2, times=times)
    path = tmp_path / "log.csv"
    np.savetxt(path, np.column_stack([m.t, m.u, m.w]), delimiter=",", header="t,u,w", comments="")
    seen = []

    def spy(*args, **kwargs):
        seen.append((kwargs.get("method"), kwargs.get("progress", "absent")))
        return physical_id.fit_physical(*args, **kwargs)

    monkeypatch.setattr(identify_module, "fit_physical", spy)
    argv = ["identify", str(path), "--Vs", str(P.Vs), "--delta", str(P.delta), "--lag", "--bootstrap", "0",
            "--input-delay", "0", "--json", "--yes"] + (["--quiet"] if quiet else [])
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out)["method"] == "output_error"
    assert seen == [("output_error", progress)]
