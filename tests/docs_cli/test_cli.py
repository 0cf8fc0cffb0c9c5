"""The ``adaptive-ff`` console script: compare and identify, JSON outputs, errors."""

import json
from pathlib import Path

import numpy as np
import pytest

from adaptive_ff.identification.regression import RegressionModel, theta_from_physical
from controllers.cli.main import main
from plant import bandlimited_noise, preset

ROOT = Path(__file__).resolve().parents[2]
EMPS = ROOT / "data" / "emps" / "DATA_EMPS.mat"


def test_compare_json_and_figures(tmp_path, capsys):
    plant_file = tmp_path / "plant.json"
    plant_file.write_text(json.dumps(preset("paper").replace(Fc=20.0, Fs=30.0).to_dict()))
    out = tmp_path / "figs"
    assert main(["compare", "--plant", str(plant_file), "--duration", "15", "--seed", "2", "--out", str(out),
                 "--json", "--quiet"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["modes"]) == {"none", "fixed", "adaptive", "adaptive-dob", "canudas", "dob", "oracle", "frictionless"}
    for m in d["modes"].values():
        assert {"rms", "max", "rms_reversal", "eta"} <= set(m)
    assert d["modes"]["none"]["eta"] == 0.0 and d["modes"]["frictionless"]["eta"] == 1.0
    assert d["plant"]["Fc"] == 20.0 and d["plant"]["model"] == "lagged-stribeck"
    for name in ("tracking", "error", "friction", "rls_convergence"):
        png = out / f"{name}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compare_table(tmp_path, capsys):
    assert main(["compare", "--duration", "10", "--no-figures", "--quiet", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    for mode in ("none", "fixed", "adaptive", "canudas", "dob", "oracle", "frictionless"):
        assert f"\n{mode} " in text
    assert "eta" in text and "phase margin" in text


@pytest.mark.parametrize("model", ["lugre", "karnopp", "asymmetric"])
def test_compare_accepts_plant_variants_by_model_key(tmp_path, capsys, model):
    from plant.models import plant_to_dict
    from plant.variant_plants import variant

    name = {"lugre": "lugre", "karnopp": "karnopp", "asymmetric": "asymmetric"}[model]
    d_in = plant_to_dict(variant(name))
    d_in["drift"] = {"Fc_change": 0.2, "t_end": 4.0}
    plant_file = tmp_path / "plant.json"
    plant_file.write_text(json.dumps(d_in))
    assert main(["compare", "--plant", str(plant_file), "--duration", "8", "--modes", "adaptive,dob", "--json",
                 "--quiet", "--no-figures"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["modes"]) == {"none", "adaptive", "dob", "frictionless"}
    assert d["plant"]["model"] == model and d["plant"]["drift"]["Fc_change"] == 0.2
    assert d["plant"]["J"] == d_in["J"]
    assert all(np.isfinite(m["rms"]) and not m.get("diverged") for m in d["modes"].values())


def test_compare_rejects_unknown_model_and_mode(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text('{"model": "dahl", "J": 1}')
    assert main(["compare", "--plant", str(bad), "--quiet"]) == 2
    assert "unknown friction model 'dahl'" in capsys.readouterr().err
    assert main(["compare", "--modes", "adaptive,magic", "--quiet", "--no-figures"]) == 2
    assert "unknown mode(s) ['magic']" in capsys.readouterr().err


def test_identify_emps_json_within_ten_percent(capsys):
    assert main(["identify", str(EMPS), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert {"J", "sigma", "Fc", "Fs", "tau", "offset", "fit_percent"} <= set(d)
    assert d["J"] == pytest.approx(95.1089, rel=0.10)
    assert d["sigma"] == pytest.approx(203.5034, rel=0.10)
    assert d["Fc"] == pytest.approx(20.3935, rel=0.10)


def test_identify_csv_recovers_discrete_model(tmp_path, capsys):
    p = preset("paper")
    Ts = 0.01
    model = RegressionModel(stribeck=False, offset=True, lag=True)
    _, u = bandlimited_noise(40.0, dt=Ts, cutoff=1.0, std=50.0, rng=np.random.default_rng(5))
    full = dict(zip(("a1", "a2", "b0", "b1", "c1", "d1", "o1"), theta_from_physical(p.replace(Fs=p.Fc), Ts, offset=2.0)))
    w = model.simulate([full[k] for k in model.names], u, [0.0, 0.0])
    csv = tmp_path / "log.csv"
    np.savetxt(csv, np.column_stack([np.arange(u.size) * Ts, u, w]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(csv), "--lag", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for k, v in (("J", p.J), ("sigma", p.sigma), ("Fc", p.Fc), ("tau", p.tau), ("offset", 2.0)):
        assert d[k] == pytest.approx(v, rel=1e-6), k


def test_errors_are_reported_without_traceback(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text('{"J": -1, "Fc": 1, "Fs": 1, "Vs": 0.1, "delta": 1, "sigma": 0, "tau": 0}')
    assert main(["compare", "--plant", str(bad), "--quiet"]) == 2
    assert "J must be > 0, got -1.0" in capsys.readouterr().err
    assert main(["identify", str(tmp_path / "missing.csv")]) == 2


def test_compare_and_identify_write_html_reports(tmp_path, capsys):
    assert main(["compare", "--duration", "8", "--quiet", "--no-figures", "--report", str(tmp_path / "c"),
                 "--out", str(tmp_path)]) == 0
    html = (tmp_path / "c" / "report.html").read_text()
    assert "Friction compensation comparison" in html and "adaptive" in html
    assert main(["identify", str(EMPS), "--quiet", "--report", str(tmp_path / "i"), "--plot", str(tmp_path / "p")]) == 0
    html = (tmp_path / "i" / "report.html").read_text()
    assert "data:image/png;base64," in html and "95.5" in html  # J of EMPS in the parameter table
    assert any(p.suffix == ".png" for p in (tmp_path / "p").iterdir())


def test_compare_no_prefit_given_factors_and_design_inertia(tmp_path, capsys):
    base = ["compare", "--duration", "2", "--quiet", "--no-figures", "--out", str(tmp_path)]
    assert main(base + ["--modes", "adaptive", "--no-prefit"]) == 2
    assert "need Vs and delta" in capsys.readouterr().err
    assert main(base + ["--modes", "none,dob"]) == 0
    assert "Stribeck pre-fit" not in capsys.readouterr().out
    assert main(base + ["--modes", "adaptive", "--Vs", "0.02", "--delta", "1", "--J-design", "2", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert "prefit" not in d and d["J_design"] == 2.0
    assert main(base + ["--modes", "adaptive", "--J-design", "4", "--json"]) == 0
    d4 = json.loads(capsys.readouterr().out)
    assert d["controller"]["Kp"] == pytest.approx(0.5 * d4["controller"]["Kp"], rel=1e-12)  # PI designed for J_design


def test_write_plot_draws_one_png_into_the_plot_folder_and_lists_it(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from controllers.cli.data import write_plot

    out = {"a": 1}
    assert write_plot(out, None, "x.png", lambda: pytest.fail("drawn without --plot")) == {"a": 1}
    fig = plt.figure()
    new = write_plot(out, tmp_path / "p", "x.png", lambda: fig)
    plt.close(fig)
    assert new == {"a": 1, "figures": [str(tmp_path / "p" / "x.png")]} and out == {"a": 1}
    png = (tmp_path / "p" / "x.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 1000
