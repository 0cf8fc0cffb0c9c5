"""``--units {deg,rad}`` on identify, design and paper-figures: deg/s by default, rad/s exactly SI, units in headers."""

import argparse
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from controllers.cli.main import build_parser, main

DEG = math.pi / 180.0  # a coefficient per rad/s times this is the coefficient per deg/s


def _row(text: str, name: str, nth: int = 0) -> list[str]:
    rows = [line.split() for line in text.splitlines() if line.split()[:1] == [name]]
    return rows[nth]


@pytest.mark.parametrize("command", ["identify", "design", "paper-figures", "stribeck", "compare", "sweep"])
def test_every_table_command_has_units_deg_by_default(command):
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    parser = sub.choices[command]
    assert "--units {deg,rad}" in parser.format_help()
    positional = {"identify": ["x.csv"], "stribeck": ["x.csv"], "sweep": ["s.json"]}.get(command, [])
    assert parser.parse_args(positional).units == "deg"


@pytest.fixture(scope="module")
def stribeck_log(tmp_path_factory):
    """A 1 kHz closed-loop-like record of the paper's joint (sliding method: sigma and Vs in the tables)."""
    from plant import preset, simulate

    p = preset("paper")
    t = np.arange(0.0, 8.0, 1e-3)
    u = 45.0 * np.sin(2 * np.pi * 0.5 * t) + 10.0 * np.sin(2 * np.pi * 3.1 * t)
    w = simulate(p, u, dt=1e-3).w[:-1]
    path = tmp_path_factory.mktemp("log") / "log.csv"
    np.savetxt(path, np.column_stack([t, u, w]), delimiter=",", header="t,u,w", comments="")
    return path


def test_identify_tables_in_deg_and_rad(stribeck_log, capsys):
    from adaptive_ff.identification.identify import identify
    from adaptive_ff.io.logs import load_log

    base = ["identify", str(stribeck_log), "--Vs", "0.02", "--delta", "1", "--method", "paper", "--quiet"]
    assert main(base + ["--units", "rad"]) == 0
    rad = capsys.readouterr().out
    assert main(base) == 0
    deg = capsys.readouterr().out
    report = identify(load_log(stribeck_log), Vs=0.02, delta=1.0, method="paper")
    # --units rad is the report's own summary with the rotary axis's units (no "(linear)" alternatives)
    assert report.summary().replace(" (kg)", "").replace(" (N·s/m)", "").replace(" (N)", "").replace(
        " (m/s)", "") in rad
    s_rad, s_deg = _row(rad, "sigma"), _row(deg, "sigma")
    assert s_rad[-1] == "N·m·s/rad" and s_deg[-1] == "N·m·s/deg"
    assert "(m/s)" not in rad + deg and "(kg)" not in rad + deg and "(N)" not in rad + deg
    truth = (report.estimate.sigma, report.stderr["sigma"], report.rls_estimate.sigma)  # value, std error, RLS
    for i, (v, rel) in enumerate(zip(truth, (1e-5, 5e-3, 1e-5)), start=1):  # printed with 6, 3, 6 digits
        assert float(s_rad[i]) == pytest.approx(v, rel=rel)
        assert float(s_deg[i]) == pytest.approx(DEG * v, rel=rel)
    v_deg = _row(deg, "Vs")
    assert float(v_deg[1]) == pytest.approx(math.degrees(0.02), rel=1e-5) and v_deg[-1] == "deg/s"
    assert _row(deg, "J") == _row(rad, "J") and _row(deg, "Fc") == _row(rad, "Fc")  # J, torques unchanged


def test_identify_axis_linear_prints_si_of_a_prismatic_axis(stribeck_log, capsys):
    base = ["identify", str(stribeck_log), "--Vs", "0.02", "--delta", "1", "--method", "paper", "--quiet"]
    assert main(base + ["--units", "rad"]) == 0
    rot = capsys.readouterr().out
    assert main(base + ["--axis", "linear"]) == 0
    lin = capsys.readouterr().out
    assert _row(lin, "J")[-1] == "kg" and _row(rot, "J")[-1] == "kg·m²"
    assert _row(lin, "sigma")[-1] == "N·s/m" and _row(lin, "Fc")[-1] == "N" and _row(lin, "Vs")[-1] == "m/s"
    assert _row(lin, "J")[1:-1] == _row(rot, "J")[1:-1] and _row(lin, "sigma")[1:-1] == _row(rot, "sigma")[1:-1]
    assert "velocity noise" in lin and "rad/s" not in lin.split("note: excitation")[1].split("\n")[0]
    assert "units: --axis linear; its tables stay in SI (N, m/s)" in lin  # --units deg (the default) ignored
    # the JSON notes carry the axis's velocity unit, as the text report
    for axis, unit in (("linear", "m/s"), ("rotary", "rad/s")):
        assert main(base + ["--axis", axis, "--json"]) == 0
        notes = json.loads(capsys.readouterr().out)["notes"]
        exc_note = next(n for n in notes if n.startswith("excitation: "))
        assert "velocity noise " in exc_note and exc_note.split("velocity noise ")[1].split()[1] == unit
        assert not any("(m/s)" in n for n in notes)
    with pytest.raises(SystemExit) as exc:  # argparse's usage error
        main(base + ["--axis", "spherical"])
    assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err


def test_design_axis_linear(capsys):
    base = ["design", "--J", "4", "--sigma", "40", "--crossover", "20", "--no-figures"]
    assert main(base + ["--units", "rad"]) == 0
    rot = capsys.readouterr().out
    assert main(base + ["--axis", "linear"]) == 0
    lin = capsys.readouterr().out
    assert "J = 4 kg, sigma = 40 N·s/m" in lin and "Kp = 49.2849 N·s/m, Ki = 1482.9 N/m" in lin
    assert "peak force 69.35 N per m/s" in lin and "crossover 20 rad/s" in lin  # a frequency stays rad/s
    assert "Kp = 49.2849 N·m·s/rad, Ki = 1482.9 N·m/rad" in rot and "N·m" not in lin


def test_design_gains_per_degree(capsys):
    from controllers.design.loop_analysis import analyse_design
    from controllers.design.pi import design_pi

    base = ["design", "--J", "4", "--sigma", "40", "--crossover", "20", "--no-figures"]
    assert main(base + ["--units", "rad"]) == 0
    rad = capsys.readouterr().out
    assert main(base) == 0
    deg = capsys.readouterr().out
    a = analyse_design(design_pi(4.0, sigma=40.0, crossover=20.0, phase_margin=60.0, Tc=1e-3))
    assert a.summary() in rad
    d = a.design
    assert f"Kp = {DEG * d.Kp:.6g} N·m·s/deg, Ki = {DEG * d.Ki:.6g} N·m/deg" in deg
    assert f"sigma = {DEG * 40.0:.6g} N·m·s/deg" in deg
    assert f"peak torque {DEG * a.peak_torque:.4g} N·m per deg/s" in deg
    assert f"crossover {d.crossover:.5g} rad/s" in deg  # a frequency: stays in rad/s
    assert "N·m·s/rad" not in deg


def test_paper_figures_estimates_table():
    from controllers.cli.paper_figures import estimates_table

    est = {"J": 4.0, "tau": 0.02, "sigma": 40.0, "Fc": 25.0, "Fs": 35.0}
    numbers = {"plant": est, "simulation": {"ls_estimate": est},
               "experiment": {"ls_estimate": {**est, "sigma": 9.0}, "rls_estimate": {**est, "sigma": -3.0}}}
    deg = estimates_table(numbers, SimpleNamespace(units="deg")).splitlines()
    rad = estimates_table(numbers, SimpleNamespace(units="rad")).splitlines()
    assert "sigma [N·m·s/deg]" in deg[0] and "sigma [N·m·s/rad]" in rad[0]
    assert "J [kg·m²]" in deg[0] and "tau [s]" in deg[0] and "Fc [N·m]" in deg[0]
    assert [r.split()[0] for r in deg[2:]] == ["true", "LS", "LS", "RLS"]
    for line_deg, line_rad, sigma in zip(deg[2:], rad[2:], (40.0, 40.0, 9.0, -3.0)):
        assert float(line_rad.split()[-3]) == pytest.approx(sigma, rel=1e-4)
        assert float(line_deg.split()[-3]) == pytest.approx(DEG * sigma, rel=1e-3)
        assert line_deg.split()[-2:] == line_rad.split()[-2:]


def test_identify_physical_and_asymmetric_tables(stribeck_log, capsys):
    base = ["identify", str(stribeck_log), "--Vs", "0.02", "--delta", "1", "--asymmetric", "--quiet"]
    assert main(base + ["--units", "rad"]) == 0
    rad = capsys.readouterr().out
    assert main(base) == 0
    deg = capsys.readouterr().out
    assert "method 'sliding': lagged Stribeck" in deg.splitlines()[1] and "\nbaselines: the paper's eq. 4" in deg
    ph_rad, ph_deg = _row(rad, "sigma", 0), _row(deg, "sigma", 0)  # the answer's (sliding) table comes first
    assert ph_deg[-1] == "N·m·s/deg" and float(ph_deg[1]) == pytest.approx(DEG * float(ph_rad[1]), rel=2e-5)
    for label in ("sigma+", "sigma-"):
        a_rad, a_deg = _row(rad, label), _row(deg, label)
        assert a_rad[-1] == "N·m·s/rad" and a_deg[-1] == "N·m·s/deg"
        assert float(a_deg[2]) == pytest.approx(DEG * float(a_rad[2]), rel=2e-5)
        assert a_deg[4] == a_rad[4]  # relative std error: unit-free
