"""controllers.report.html: one self-contained HTML page from the pieces of a run."""

import base64
import re

import numpy as np
import pytest
from matplotlib.figure import Figure

from adaptive_ff.io.data import MeasuredData
from adaptive_ff.identification.identify import identify
from adaptive_ff.identification.regression import RegressionModel, theta_from_physical
from adaptive_ff.identification.stribeck_fit import fit_stribeck
from controllers.experiments.compare import compare
from controllers.design.loop_analysis import analyse_design
from controllers.design.pi import design_pi
from controllers.report.html import ReportPage, compare_report, figure_png, identify_report, report_html, write_report
from plant import bandlimited_noise, preset

P = preset("paper")
PNG = b"\x89PNG\r\n\x1a\n"


def _images(html):
    return [base64.b64decode(m) for m in re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)]


@pytest.fixture(scope="module")
def identified():
    Ts = 0.01
    _, u = bandlimited_noise(20.0, dt=Ts, cutoff=1.0, std=50.0, rng=np.random.default_rng(2))
    model = RegressionModel(stribeck=False, lag=True, offset=True)
    full = dict(zip(("a1", "a2", "b0", "b1", "c1", "d1", "o1"),
                    theta_from_physical(P.replace(Fs=P.Fc), Ts, offset=1.5)))
    w = model.simulate([full[k] for k in model.names], u, [0.0, 0.0])
    data = MeasuredData(np.arange(u.size) * Ts, u, w, source="sim <script>alert(1)</script>.csv",
                        notes=("simulated by the discrete model",))
    return data, identify(data, lag=True, method="paper")


def test_identification_report_holds_the_table_values_and_images(identified, tmp_path):
    data, rep = identified
    path = identify_report(tmp_path, rep, data, design=design_pi(rep.estimate.J, crossover=30.0))
    html = path.read_text()
    assert path.name == "report.html"
    for name in ("J", "sigma", "Fc", "tau", "offset"):
        assert f"<td>{getattr(rep.estimate, name):.6g}</td>" in html, name
        assert f"<td>{rep.std[name]:.3g}</td>" in html, name
    assert f"<td>{rep.estimate.J:.6g}</td>" in html and rep.estimate.J == pytest.approx(P.J, rel=1e-6)
    assert "<script>" not in html and "&lt;script&gt;" in html  # file names are escaped
    assert html.count("simulated by the discrete model") == 1  # data notes are not repeated
    imgs = _images(html)
    assert len(imgs) == 4 and all(b.startswith(PNG) for b in imgs)
    assert "Controller design" in html and "http" not in html.split("<body>")[1]  # no external resources


def test_pieces_stribeck_design_comparison_tables(tmp_path):
    w = np.concatenate([-np.geomspace(0.004, 0.4, 8)[::-1], np.geomspace(0.004, 0.4, 8)])
    fit = fit_stribeck(w, P.friction(w))
    a = analyse_design(design_pi(P.J, crossover=20.0))
    comp = compare(P, duration=3.0, seed=0, modes=("none",), prefit=False, progress=False)
    fig = Figure()
    fig.add_subplot().plot([0, 1], [0, 1])
    png_path = tmp_path / "x.png"
    fig.savefig(png_path)
    html = report_html(ReportPage(title="T & co", stribeck=fit, design=a, comparison=comp,
                                  tables=[("extra", ["a", "b"], [["row", 1.23456789]])],
                                  figures=[("from Figure", fig), ("from path", png_path),
                                           ("from bytes", png_path.read_bytes())]))
    assert "<title>T &amp; co</title>" in html
    assert f"<td>{fit.Vs:.6g}</td>" in html and f">{a.design.Kp:.6g}</td>" in html
    assert f">{a.bandwidth:.5g}</td>" in html
    for row in comp.rows():
        assert f"<td>{np.rad2deg(row['rms']):.4f}</td>" in html
    assert "<td>1.23457</td>" in html
    assert len(_images(html)) == 3
    out = compare_report(tmp_path / "cmp", comp, figures=[png_path])
    assert "x" in out.read_text() and len(_images(out.read_text())) == 1


def test_bad_figures():
    with pytest.raises(ValueError, match="not PNG"):
        figure_png(b"GIF89a....")
    with pytest.raises(TypeError, match="matplotlib Figure"):
        figure_png(3)


def test_write_report_creates_directory(tmp_path):
    path = write_report(tmp_path / "a" / "b", title="x", notes=["n1"])
    assert path.read_text().startswith("<!DOCTYPE html>") and "n1" in path.read_text()
