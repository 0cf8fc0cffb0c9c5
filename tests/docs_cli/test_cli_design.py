"""``adaptive-ff design``: PI gains and margins against independent computations, figures and report."""

import argparse
import json
import math

import control
import numpy as np
import pytest

from controllers.cli import design as cli_design
from controllers.design.loop_analysis import analyse_design
from controllers.design.pi import design_pi
from plant.errors import ParameterError

PNG = b"\x89PNG\r\n\x1a\n"


def run(argv):
    ap = argparse.ArgumentParser(prog="adaptive-ff")
    cli_design.register(ap.add_subparsers(dest="command", required=True))
    args = ap.parse_args(["design", *argv])
    return args.func(args)


def test_margins_meet_targets_and_independent_checks(tmp_path, capsys):
    J, Tc = 4.0, 1e-3
    out = tmp_path / "fig"
    assert run(["--J", str(J), "--crossover", "20", "--phase-margin", "60", "--Tc", str(Tc), "--out", str(out),
                "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["crossover"] == pytest.approx(20.0, rel=1e-6)
    assert d["phase_margin"] == pytest.approx(60.0, abs=1e-4)
    # |L| = 1 and arg L = PM - 180 deg at the crossover, evaluated directly from the gains:
    z = np.exp(1j * d["crossover"] * Tc)
    L = (d["Kp"] + d["Ki"] * Tc * z / (z - 1)) * Tc / (J * (z - 1))  # ZOH of 1/(J s) is Tc/(J (z - 1))
    assert abs(L) == pytest.approx(1.0, rel=1e-6)
    assert math.degrees(np.angle(L)) + 180.0 == pytest.approx(60.0, abs=1e-4)
    # gain margin at the Nyquist frequency, z = -1: |L(-1)| = (2 Kp + Ki Tc) Tc / (4 J)
    assert d["gain_margin"] == pytest.approx(4 * J / ((2 * d["Kp"] + d["Ki"] * Tc) * Tc), rel=1e-9)
    assert d["gain_margin_db"] == pytest.approx(20 * math.log10(d["gain_margin"]), rel=1e-12)
    # closed-loop bandwidth: |T| = 1/sqrt(2) there
    zb = np.exp(1j * d["bandwidth"] * Tc)
    Lb = (d["Kp"] + d["Ki"] * Tc * zb / (zb - 1)) * Tc / (J * (zb - 1))
    assert abs(Lb / (1 + Lb)) == pytest.approx(1 / math.sqrt(2), rel=1e-6)
    # sensitivity peak = 1 / stability margin (python-control's)
    assert d["sensitivity_peak"] == pytest.approx(1 / d["stability_margin"], rel=1e-3)
    assert 0 < d["step"]["overshoot_percent"] < 40 and d["step"]["rise_time"] < d["step"]["settling_time"]
    assert d["step"]["peak_torque_per_rad_s"] == pytest.approx(d["Kp"] + d["Ki"] * Tc, rel=1e-9)
    for name in ("bode.png", "step.png"):
        assert (out / name).read_bytes()[:8] == PNG


def test_step_metrics_match_the_step_response():
    a = analyse_design(design_pi(1.2, sigma=6.0, crossover=60.0, phase_margin=50.0, Tc=1e-3), t_end=1.0)
    w = a.step.w
    assert w[-1] == pytest.approx(1.0, abs=1e-4)  # integral action: no steady-state error
    assert a.overshoot == pytest.approx(100 * (w.max() - 1.0), rel=1e-6)
    assert a.step.u[-1] == pytest.approx(6.0, rel=1e-3)  # steady torque = sigma * 1 rad/s
    info = control.step_info(w, T=a.step.t)
    assert a.settling_time == pytest.approx(info["SettlingTime"])


def test_from_identify_json_with_override_and_report(tmp_path, capsys):
    src = tmp_path / "id.json"
    src.write_text(json.dumps({"J": 2.0, "sigma": 3.0, "Fc": 5.0, "fit_percent": 99.0}))
    rep = tmp_path / "rep"
    assert run(["--from", str(src), "--crossover", "30", "--no-figures", "--report", str(rep), "--units", "rad"]) == 0
    text = capsys.readouterr().out
    ref = design_pi(2.0, sigma=3.0, crossover=30.0, phase_margin=60.0)
    assert f"Kp = {ref.Kp:.6g} N·m·s/rad" in text and f"J, sigma from {src}" in text
    html = (rep / "report.html").read_text()
    assert f"{ref.Kp:.6g}" in html and html.count("data:image/png;base64,") == 2
    assert run(["--from", str(src), "--J", "8", "--json", "--no-figures"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["J"] == 8.0 and d["sigma"] == 3.0


def test_errors(tmp_path):
    with pytest.raises(ParameterError, match="--J"):
        run(["--no-figures"])
    with pytest.raises(ParameterError, match="--phase-margin must be in \\(0, 90\\) degrees, got 95.0"):
        run(["--J", "1", "--phase-margin", "95", "--no-figures"])
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2]")
    with pytest.raises(ParameterError, match="numeric 'J'"):
        run(["--from", str(bad), "--no-figures"])


def test_help_of_the_new_subcommands_is_complete():
    from controllers.cli import paper_figures as cli_paper_figures, stribeck as cli_stribeck

    ap = argparse.ArgumentParser(prog="adaptive-ff")
    sub = ap.add_subparsers(dest="command", required=True)
    for m in (cli_design, cli_stribeck, cli_paper_figures):
        m.register(sub)
    for name, musts in (("design", ("--J", "--crossover", "--phase-margin", "--Tc", "--from", "bode.png")),
                        ("stribeck", ("--columns", "--current-to-torque", "--counts-per-rev", "--method",
                                      "--points", "fig08_stribeck.png", "Kalman")),
                        ("paper-figures", ("--out", "--save-data", "Fig. 10", "lambda = 0.85"))):
        text = sub.choices[name].format_help()
        for opt in musts + ("--json", "--quiet", "--report"):
            assert opt in text, (name, opt)
