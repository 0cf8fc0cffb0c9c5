"""The output-error fit profiles the input delay where it is not given (adaptive_ff.identification.delay_profile).

A joint of the coverage zoo (benchmarks/coverage_zoo.py, seed 1: the Fig. 10 readout scaled to 10 ms, each torque
sample stamped at the end of the 1 ms step it was held over, 0.5 ms after the middle of its hold) is rebuilt here
from the plant's own functions. Fitted with each torque taken at its stamp the fit missed Fs by +6.2 %; the profile
finds a delay between 0.5 and 1 ms and the miss shrinks.
"""

import json
import math

import numpy as np
import pytest

from adaptive_ff.identification.covariance import bootstrap_t_quantile
from adaptive_ff.identification.delay_profile import DELAY_FRACTIONS, delay_profile_search, delay_spread
from adaptive_ff.identification.oe_options import OutputErrorOptions
from adaptive_ff.identification.physical_id import fit_physical
from controllers.cli.main import main
from coverage_zoo_joints import zoo_joint
from plant.errors import ParameterError


class _Quadratic:
    """A stand-in problem whose refitted cost is a parabola in the delay: ``(d - d_min)**2`` plus 1, on stamps 10 ms
    apart."""

    def __init__(self, d_min):
        self.t = np.arange(0.0, 1.0, 0.01)
        self.input_delay, self.d_min, self.n_sim = 0.0, d_min, 0

    def set_delay(self, d):
        self.input_delay = float(d)

    def refit(self, x):
        self.n_sim += 1
        return 1.0 + (self.input_delay - self.d_min) ** 2 * 1e4, x + self.input_delay


@pytest.mark.parametrize("d_min", [0.0, 0.8e-3, 3.1e-3])
def test_the_grid_and_the_parabola_find_the_lowest_cost(d_min):
    pb = _Quadratic(d_min)
    (cost, x), det = delay_profile_search(pb, (5.0, np.zeros(2)), pb.refit)
    grid = [f * 0.01 for f in DELAY_FRACTIONS]
    # the grid (0, 0.625, 1.25, 2.5, 5, 10 ms) stops two points past its lowest, then the vertex between the lowest's
    # neighbours: the parabola's own minimum, exact for a parabola
    assert det["chosen"] == pytest.approx(d_min, abs=1e-12)
    assert pb.input_delay == det["chosen"] and cost == pytest.approx(1.0) and x[0] == pytest.approx(d_min)
    k = int(np.argmin([(d - d_min) ** 2 for d in grid]))
    assert det["delay"][:min(k + 3, len(grid))] == pytest.approx(grid[:min(k + 3, len(grid))])
    assert det["n_simulations"] == len(det["delay"])


def test_options_take_none_as_profiled_and_refuse_a_negative_delay():
    assert OutputErrorOptions().input_delay is None
    assert OutputErrorOptions(input_delay=5e-4).input_delay == 5e-4
    with pytest.raises(ParameterError, match=r"input_delay must be >= 0 s \(or None: profiled\), got -0.001"):
        OutputErrorOptions(input_delay=-1e-3)
    with pytest.raises(ParameterError, match="input_delay"):
        OutputErrorOptions(input_delay=float("nan"))


@pytest.fixture(scope="module")
def joint():
    return zoo_joint(1)  # benchmarks/coverage_zoo.py's joint of seed 1 and its 15 s readout


@pytest.fixture(scope="module")
def profiled(joint):
    """The fit with the delay profiled and 3 bootstrap refits (one worker), and every delay profile it ran: the
    fit's, then one per refit (spied on ``physical_id.delay_profile_search``). The bootstrap only adds the errors
    (the estimate is the one of ``n_bootstrap=0``), so both tests below read this one fit."""
    import adaptive_ff.identification.physical_id as physical_id

    p, m = joint
    profiles = []

    def profile_spy(*args, **kwargs):
        out = delay_profile_search(*args, **kwargs)
        profiles.append(out[1])
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(physical_id, "delay_profile_search", profile_spy)
        f = fit_physical(m.t, m.u, m.w, Vs=p.Vs, delta=p.delta, n_bootstrap=3, bootstrap_workers=1)
    return f, profiles


def test_the_fit_profiles_the_delay_and_reports_it(joint, profiled):
    p, m = joint
    f = profiled[0]
    at0 = fit_physical(m.t, m.u, m.w, Vs=p.Vs, delta=p.delta, n_bootstrap=0, input_delay=0.0)
    prof = json.loads(json.dumps(f.info["input_delay_profile"], allow_nan=False))
    # measured: 0.625 ms chosen (cost 75.35 against 80.36 at 0 ms), Fs +2.0 % against +6.2 % at 0 ms
    assert 0.5e-3 <= f.info["input_delay"] <= 1.0e-3 and prof["chosen"] == f.info["input_delay"]
    assert prof["cost"][prof["delay"].index(prof["chosen"])] == min(prof["cost"])
    assert at0.info["input_delay"] == 0.0 and at0.info["input_delay_profile"] is None
    err = lambda fit, k: abs(fit.params[k] / getattr(p, k) - 1.0)  # noqa: E731
    assert err(at0, "Fs") > 0.05 and err(f, "Fs") < 0.5 * err(at0, "Fs")
    assert err(f, "Fc") < err(at0, "Fc") and err(f, "sigma") < err(at0, "sigma")
    assert f.info["cost"] < at0.info["cost"]


@pytest.mark.parametrize("value", ["-0.001", "nan", "inf"])
def test_cli_input_delay_is_validated_before_the_log_is_read(value, capsys):
    assert main(["identify", "no-such-file.csv", "--input-delay", value]) == 2
    err = capsys.readouterr().err
    assert "--input-delay must be a finite time >= 0 in seconds" in err and "Traceback" not in err


def test_cli_input_delay_is_refused_where_no_output_error_fit_runs(tmp_path, capsys, joint):
    _, m = joint
    path = tmp_path / "log.csv"
    np.savetxt(path, np.column_stack([m.t, m.u, m.w]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(path), "--method", "paper", "--input-delay", "0.0005"]) == 2
    assert "--input-delay applies to the output-error fit of the log" in capsys.readouterr().err


def test_the_bootstrap_refits_hold_the_delay_the_fit_chose(profiled):
    f, profiles = profiled
    boot, prof, d = f.info["bootstrap"], f.info["input_delay_profile"], f.info["input_delay"]
    # the fit's profile, then one per refit with the fit's delay (0.625 ms) as its one point
    assert len(profiles) == 4 and profiles[0] == prof and 0.5e-3 <= d <= 1.0e-3 and boot["input_delay"] == d
    assert [r["delay"] for r in profiles[1:]] == [[d]] * 3 and [r["chosen"] for r in profiles[1:]] == [d] * 3
    # measured: the fit's profile 646 of its 2085 simulations (7 delays), each refit's 110-131 (one delay); the 3
    # refits 4758 simulations (1586 each) where they ran the whole profile again 6170 (2057 each)
    assert all(0 < r["n_simulations"] < 0.25 * prof["n_simulations"] for r in profiles[1:])
    assert boot["n_simulations"] / boot["n"] < f.info["n_simulations"] - 0.6 * prof["n_simulations"]
    # the fit's profile keeps the parameters at each delay; the refits' one-point profiles have no spread
    assert "params" in prof and len(prof["params"]) == len(prof["delay"]) and all("params" not in r
                                                                                   for r in profiles[1:])
    # the delay's share, recomputed here from the profile: the moves from the profile's refit at the chosen delay
    # to the tried delays nearest below and above it
    at = prof["params"][prof["delay"].index(d)]
    below = max((x for x in prof["delay"] if x < d), default=None)
    above = min((x for x in prof["delay"] if x > d), default=None)
    nb = [prof["params"][prof["delay"].index(x)] for x in (below, above) if x is not None]
    q = bootstrap_t_quantile(boot["n_valid"], 0.95)
    for k in ("J", "tau", "sigma", "Fc", "Fs", "offset"):
        share = math.sqrt(sum((v[k] - at[k]) ** 2 for v in nb) / len(nb))
        assert boot["stderr_delay"][k] == pytest.approx(share, rel=1e-12, abs=1e-15)
        # centred on the estimate with the refits' RMS deviation and the share in quadrature, t of n refits, where
        # the refits' mean shift is at most a quarter of that standard error; else centred less the shift, the
        # refits' sample variance about their mean times 1 + 1/n and the share in quadrature, t of n - 1
        b, rms, n = boot["bias"][k], boot["stderr_refits"][k], boot["n_valid"]
        se = math.sqrt(rms ** 2 + share ** 2)
        centre, t = f.params[k], q
        if abs(b) > 0.25 * se:
            centre, se = f.params[k] - b, math.sqrt((rms ** 2 - b ** 2) * (n + 1) / (n - 1) + share ** 2)
            t = bootstrap_t_quantile(n - 1, 0.95)
        assert f.stderr[k] == pytest.approx(se, rel=1e-12)
        assert f.info["interval95"][k] == pytest.approx([centre - t * se, centre + t * se], rel=1e-12)
    # measured on this joint: the delay's share 0.25-0.9 of the refits' spread in sigma and Fc
    assert all(boot["stderr_delay"][k] > 0.1 * boot["stderr_refits"][k] for k in ("sigma", "Fc"))


def test_delay_spread_is_the_rms_move_from_the_chosen_delay_to_its_neighbours():
    # delays tried in the profile's order (the grid, then the parabola's vertex 0.7 ms); chosen 0.625 ms (the
    # profile's refit there: J 2, Fc 11): its neighbours in time are 0 and 0.7 ms, not 1.25 ms
    det = {"delay": [0.0, 0.625e-3, 1.25e-3, 2.5e-3, 0.7e-3], "chosen": 0.625e-3,
           "params": [{"J": 1.0, "Fc": 10.0}, {"J": 2.0, "Fc": 11.0}, {"J": 9.0, "Fc": 90.0},
                      {"J": 9.0, "Fc": 90.0}, {"J": 4.0, "Fc": 11.0}]}
    out = delay_spread(det, ("J", "Fc"))
    assert out["J"] == pytest.approx(math.sqrt((1.0 + 4.0) / 2.0), rel=1e-15)
    assert out["Fc"] == pytest.approx(math.sqrt((1.0 + 0.0) / 2.0), rel=1e-15)
    # chosen at an end of the profile (0 ms: J 1, Fc 10): its one neighbour, 0.625 ms
    assert delay_spread(dict(det, chosen=0.0), ("J", "Fc")) == {"J": 1.0, "Fc": 1.0}
    # one delay (a bootstrap refit's profile) or no parameters kept: no share
    assert delay_spread({"delay": [1e-3], "chosen": 1e-3, "params": [{"J": 5.0}]}, ("J",)) == {"J": 0.0}
    assert delay_spread({"delay": [0.0, 1e-3], "chosen": 0.0}, ("J",)) == {"J": 0.0}
