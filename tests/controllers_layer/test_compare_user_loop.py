"""The user's loop in ``compare``: the PI of ``design`` (``--controller``) and the design of ``design --from``
(``--from``), the given gains' margins against a closed form, the gains printed in ``design``'s units."""

import argparse
import json
import math
import re

import numpy as np
import pytest

from controllers.cli import compare as cli_compare
from controllers.cli import design as cli_design
from controllers.design.controller_file import read_controller
from controllers.design.pi import analyse_gains, design_pi
from controllers.experiments.compare import CompareOptions, compare
from plant.errors import ParameterError
from plant.friction import preset

ID = {"method": "sliding", "J": 4.103424729656735, "Fc": 24.950807390864934, "Fs": 37.21688646402248,
      "sigma": 40.130682711238826, "tau": 0.020772473265106176, "offset": 0.001, "Vs": 0.02, "delta": 1.0,
      "std": {}, "excitation": {"noise_std": 0.001, "n_reversals": 8, "low_speed_fraction": 0.05},
      "warnings": [], "notes": []}


def loop_gain(Kp, Ki, J, sigma, Tc, w):
    """L(exp(j w Tc)) from the closed forms: ZOH of 1/(J s + sigma) is b/(z - a), a = exp(-sigma Tc/J),
    b = (1 - a)/sigma (Tc/J for sigma = 0); C(z) = Kp + Ki Tc z/(z - 1)."""
    z = np.exp(1j * w * Tc)
    if sigma > 0:
        a = math.exp(-sigma * Tc / J)
        P = (1 - a) / sigma / (z - a)
    else:
        P = Tc / (J * (z - 1))
    return (Kp + Ki * Tc * z / (z - 1)) * P


def crossover_by_bisection(Kp, Ki, J, sigma, Tc):
    lo, hi = 1e-3, 0.999 * math.pi / Tc
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if abs(loop_gain(Kp, Ki, J, sigma, Tc, mid)) > 1:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)


@pytest.mark.parametrize("Kp, Ki, J, sigma", [(70.9, 1500.0, 4.1, 40.0), (3.0, 20.0, 0.05, 0.0), (51.0, 1505.5, 4.1,
                                                                                                    40.13)])
def test_margins_of_given_gains_against_the_closed_form(Kp, Ki, J, sigma):
    Tc = 1e-3
    d = analyse_gains(Kp, Ki, J=J, sigma=sigma, Tc=Tc)
    wc = crossover_by_bisection(Kp, Ki, J, sigma, Tc)
    assert d.Kp == Kp and d.Ki == Ki
    assert d.crossover == pytest.approx(wc, rel=1e-7)
    L = loop_gain(Kp, Ki, J, sigma, Tc, wc)
    assert d.phase_margin == pytest.approx(180.0 + math.degrees(np.angle(L)), abs=1e-5)
    # the phase reaches -180 deg at the Nyquist frequency (z = -1): GM = 1/|L(-1)|
    assert d.gain_margin == pytest.approx(1.0 / abs(loop_gain(Kp, Ki, J, sigma, Tc, math.pi / Tc)), rel=1e-6)


def test_given_gains_of_a_design_give_back_its_margins():
    d = design_pi(4.1, sigma=40.0, crossover=20.0, phase_margin=60.0)
    a = analyse_gains(d.Kp, d.Ki, J=4.1, sigma=40.0)
    assert (a.crossover, a.phase_margin, a.gain_margin) == pytest.approx((20.0, 60.0, d.gain_margin), rel=1e-7)


def test_unstable_gains_and_bad_files_are_refused_by_name(tmp_path):
    with pytest.raises(ParameterError, match=r"Kp = 10000\.0 .*unstable"):
        analyse_gains(1e4, 0.0, J=1.0, Tc=1e-3)  # the loop pole at 1 - Kp*Tc/J = -9
    for text, match in (('{"Ki": 1, "Tc": 0.001, "J": 1}', r"c\.json: no 'Kp'"),
                        ('{"Kp": "1.0", "Ki": 1, "Tc": 0.001, "J": 1}', r"c\.json: 'Kp' must be a finite number"),
                        ('{"Kp": 1, "Ki": 1, "Tc": 0.001, "J": -1}', r"c\.json: J must be"),
                        ('[1, 2]', r"c\.json: a controller file is a JSON object")):
        (tmp_path / "c.json").write_text(text)
        with pytest.raises(ParameterError, match=match):
            read_controller(tmp_path / "c.json")
    d = design_pi(4.0, crossover=20.0, phase_margin=60.0)
    with pytest.raises(ParameterError, match=r"controller: its period Tc = 0\.001 s differs from the loop's Tc = "
                                             r"0\.002 s"):
        CompareOptions.from_flat(controller=d, Tc=2e-3, Ts=0.01)


def test_compare_runs_the_given_pi():
    p = preset("paper")
    given = analyse_gains(30.0, 600.0, J=p.J, sigma=0.0)
    c = compare(p, duration=4.0, modes=("none",), controller=given, progress=False)
    own = compare(p, duration=4.0, modes=("none",), progress=False)
    assert (c.design.Kp, c.design.Ki) == (30.0, 600.0)
    assert own.design.Kp == pytest.approx(design_pi(own.J_design, crossover=20.0, phase_margin=60.0).Kp, rel=1e-12)
    # the loop ran the given gains: the frictionless loop's error differs from the own design's
    r_given, r_own = c.results["frictionless"].metrics.rms, own.results["frictionless"].metrics.rms
    assert abs(r_given - r_own) > 0.05 * r_own


def _cli(module, argv, capsys):
    ap = argparse.ArgumentParser(prog="adaptive-ff")
    module.register(ap.add_subparsers(dest="command", required=True))
    args = ap.parse_args(argv)
    status = args.func(args)
    return status, capsys.readouterr()


def test_the_workflow_closes_design_from_then_compare(tmp_path, capsys):
    """``design --from id.json`` and ``compare --from id.json`` run the same PI and print it in the same units;
    ``compare --controller design.json`` runs the file's gains."""
    ident = tmp_path / "id.json"
    ident.write_text(json.dumps(ID))
    status, out = _cli(cli_design, ["design", "--from", str(ident), "--no-figures"], capsys)
    assert status == 0
    designed = re.search(r"Kp = (\S+) N·m·s/deg, Ki = (\S+) N·m/deg", out.out).groups()
    status, out = _cli(cli_compare, ["compare", "--from", str(ident), "--duration", "4", "--modes", "none",
                                     "--no-figures", "--quiet"], capsys)
    assert status == 0
    assert re.search(r"PI: Kp = (\S+) N·m·s/deg, Ki = (\S+) N·m/deg", out.out).groups() == designed
    assert f"design inertia J_design=4.10342 kg·m² (from {ident})" in out.out  # where the inertia came from
    assert "plant: the joint identified in" in out.out

    status, out = _cli(cli_design, ["design", "--from", str(ident), "--no-figures", "--json"], capsys)
    design_file = tmp_path / "design.json"
    design_file.write_text(out.out)
    d = json.loads(out.out)
    status, out = _cli(cli_compare, ["compare", "--preset", "paper", "--controller", str(design_file), "--duration",
                                     "4", "--modes", "none", "--no-figures", "--quiet", "--json"], capsys)
    assert status == 0
    got = json.loads(out.out)["controller"]
    assert (got["Kp"], got["Ki"]) == (d["Kp"], d["Ki"])
    with pytest.raises(ParameterError, match="--crossover cannot be combined with --controller"):
        _cli(cli_compare, ["compare", "--controller", str(design_file), "--crossover", "30"], capsys)


def test_from_refuses_an_identification_with_warnings(tmp_path, capsys):
    bad = dict(ID, warnings=[{"code": "implausible", "parameter": "J", "message": "J at its bound"}])
    (tmp_path / "id.json").write_text(json.dumps(bad))
    status, out = _cli(cli_compare, ["compare", "--from", str(tmp_path / "id.json"), "--duration", "4",
                                     "--no-figures", "--quiet"], capsys)
    assert status == 3
    assert "implausible warning on J" in out.err and "--accept-warnings" in out.err


def test_an_eta_above_one_is_explained_in_the_notes():
    from types import SimpleNamespace

    from controllers.experiments.comparison import beyond_frictionless_notes, eta

    def run(rms):
        return SimpleNamespace(metrics=SimpleNamespace(rms_second_half=rms), info={})

    results = {"none": run(0.05), "fixed": run(0.0098), "adaptive": run(0.01), "dob": run(0.02),
               "frictionless": run(0.01)}
    etas = {m: eta(0.05, r.metrics.rms_second_half, 0.01) for m, r in results.items()}
    notes = beyond_frictionless_notes(etas, results)
    assert etas["fixed"] == pytest.approx(1.005)
    assert len(notes) == 1 and notes[0].startswith("fixed: eta 1.005 > 1: it tracks better than the frictionless "
                                                   "loop (second-half RMS 0.0098 against 0.01 rad/s)")
