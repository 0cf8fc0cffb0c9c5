"""EMPS closed-loop re-simulation, cross-validation and the identify CLI options --asymmetric / --validate."""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.io import savemat

from adaptive_ff.io.data import load_emps
from adaptive_ff.identification.emps_validation import (EMPSRecord, exact_step, is_emps_record, read_emps_record,
                                         simulate_emps_loop, validate_emps)
from adaptive_ff.identification.identify import cross_validate, identify
from adaptive_ff.identification.idim import RigidAxisModel, fit_idim, relative_error
from controllers.cli.main import main
from plant.errors import ParameterError, SignalError

ROOT = Path(__file__).resolve().parents[2]
EMPS = ROOT / "data" / "emps" / "DATA_EMPS.mat"
PULSES = ROOT / "data" / "emps" / "DATA_EMPS_PULSES.mat"
REF = RigidAxisModel.symmetric(95.1089, 203.5034, 20.3935, -3.1648)   # published reference model


@pytest.fixture(scope="module")
def record():
    return read_emps_record(EMPS)


@pytest.fixture(scope="module")
def report():
    return identify(load_emps(EMPS), method="paper")


# ------------------------------------------------------------------ the exact plant step


def _ivp_region(q, w, force, h, m, s):
    """solve_ivp in one direction of motion s, stopping where w reaches 0."""
    Fc, b = (m.Fc_pos, m.sigma_pos) if s > 0 else (m.Fc_neg, m.sigma_neg)

    def rhs(_, x):
        return [x[1], (force - m.offset - s * Fc - b * x[1]) / m.J]

    def zero(_, x):
        return x[1]

    zero.terminal = True
    zero.direction = -s      # only a crossing back through zero (a start at rest is no event)
    sol = solve_ivp(rhs, (0.0, h), [q, w], events=zero, rtol=1e-12, atol=1e-14, method="DOP853")
    return sol.y[0, -1], sol.y[1, -1], sol.t[-1]


@pytest.mark.parametrize("w0, force, asym", [
    (0.05, 30.0, False),     # accelerating forwards
    (0.05, -400.0, False),   # braking through zero, then moving backwards (|force - offset| > Fc)
    (-0.002, 150.0, True),   # backwards, through zero, forwards, asymmetric friction
    (0.0, 100.0, True),      # breaking away from rest
])
def test_exact_step_matches_solve_ivp(w0, force, asym):
    m = (RigidAxisModel(J=95.0, Fc_pos=20.0, Fc_neg=21.0, sigma_pos=170.0, sigma_neg=240.0, offset=-3.0)
         if asym else REF)
    h = 0.05
    q1, w1 = exact_step(0.3, w0, force, h, m)
    # independent: solve_ivp region by region (direction at rest from the sign of force - offset)
    q, w, left = 0.3, w0, h
    for _ in range(4):
        if left <= 1e-15:
            break
        s = np.sign(w) if w != 0 else np.sign(force - m.offset)
        q, w, used = _ivp_region(q, w, force, left, m, s)
        left -= used
        if left > 1e-15:
            w = 0.0
    assert q1 == pytest.approx(q, abs=1e-12) and w1 == pytest.approx(w, abs=1e-10)


def test_exact_step_sticks_inside_the_coulomb_band():
    m = RigidAxisModel(J=1.0, Fc_pos=2.0, Fc_neg=3.0, sigma_pos=1.0, sigma_neg=1.0, offset=0.5)
    assert exact_step(1.0, 0.0, 2.4, 0.1, m) == (1.0, 0.0)     # 2.4 - 0.5 < Fc_pos
    assert exact_step(1.0, 0.0, -2.4, 0.1, m) == (1.0, 0.0)    # -2.9 > -Fc_neg
    # moving slowly against a force inside the band: decelerates to zero and stays
    q, w = exact_step(1.0, 0.01, 0.5, 1.0, m)
    assert w == 0.0 and q == pytest.approx(1.0 + 0.01 * 0.5 * 0.01 / 2.0, rel=0.05)  # ~ w0^2/(2*decel), decel ~ 2
    # no viscous friction: constant deceleration, stop at w0/(Fc/J)
    m0 = RigidAxisModel(J=1.0, Fc_pos=2.0, Fc_neg=2.0, sigma_pos=0.0, sigma_neg=0.0)
    q, w = exact_step(0.0, 1.0, 0.0, 1.0, m0)
    assert w == 0.0 and q == pytest.approx(0.25, rel=1e-12)


# ------------------------------------------------------------------ the loop on EMPS


def test_logged_controller_output_matches_the_controller_law(record):
    # vir(k) = kv*(kp*(qg(k) - qm(k)) - qdot(k)), qdot the backward difference of 0.5*(qm(k) + qm(k-1))
    qa = 0.5 * record.qm[1:] + 0.5 * record.qm[:-1]
    qdot = np.diff(qa) / np.diff(record.t[1:])
    nu = record.kv * (record.kp * (record.qg[2:] - record.qm[2:]) - qdot)
    assert np.sqrt(np.mean((record.vir[2:] - nu) ** 2)) < 0.01       # measured 3.7e-3 V of a 4.3 V range
    p = read_emps_record(PULSES)
    qa = 0.5 * p.qm[1:] + 0.5 * p.qm[:-1]
    nu = p.kv * (p.kp * (p.qg[2:] - p.qm[2:]) - np.diff(qa) / np.diff(p.t[1:]))
    extra = p.vir[2:] - nu
    # the pulses_N record (0/5) is added to the voltage (not 5 N to the force): fitted gain 1.014
    gain = float(extra @ p.pulses[2:] / (p.pulses[2:] @ p.pulses[2:]))
    assert gain == pytest.approx(1.0, abs=0.02)


def test_reference_model_reproduces_the_published_closed_loop_errors(record):
    v = validate_emps(REF, EMPS, record=record)
    # published (Janot et al. 2019, data README): 0.23 % velocity, 5.85 % force; measured 0.229 %, 5.854 %
    assert v.velocity_error == pytest.approx(0.23, abs=0.01)
    assert v.force_error == pytest.approx(5.85, abs=0.02)
    assert v.idim_force_error == pytest.approx(4.08, abs=0.05)        # published 4.08; measured 4.040 (4.124 tail=0)
    # independent recomputation of the definitions from the simulated signals
    d = load_emps(EMPS)
    sim = v.simulation
    assert v.velocity_error == pytest.approx(100 * np.linalg.norm(d.w - sim.w[49:]) / np.linalg.norm(d.w), rel=1e-12)
    f = record.gtau * record.vir[49:]
    assert v.force_error == pytest.approx(100 * np.linalg.norm(f - sim.force[49:]) / np.linalg.norm(f), rel=1e-12)
    # the simulated position follows the measured one to a few micrometres (0.0016 % of ||qm||)
    assert np.max(np.abs(sim.q - record.qm)) < 2e-4 and v.position_error < 0.01
    # without the unit delay the loop is too good on force: 4.57 % (evidence for the delay)
    nodelay = simulate_emps_loop(REF, record, delay=0)
    assert relative_error(f, nodelay.force[49:]) < 5.0


def test_loop_matches_an_independent_solve_ivp_loop():
    """First 0.4 s of the pulses record (pulses from 0.343 s): controller written out again, plant by solve_ivp."""
    rec = read_emps_record(PULSES)
    sim = simulate_emps_loop(REF, rec)
    n = 400
    q, w = rec.qm[0], 0.0
    qs, ws = [q], [w]
    q_prev, qa_prev, nu_prev = q, q, 0.0
    for k in range(n - 1):
        qa = 0.5 * (q + q_prev)
        qdot = (qa - qa_prev) / (rec.t[k] - rec.t[k - 1]) if k else 0.0
        nu = rec.kv * (rec.kp * (rec.qg[k] - q) - qdot)
        force = rec.gtau * (nu_prev + rec.pulses[k])
        assert sim.force[k] == pytest.approx(force, rel=1e-9, abs=1e-9)
        q_prev, qa_prev, nu_prev = q, qa, nu
        left = rec.t[k + 1] - rec.t[k]
        for _ in range(4):
            if left <= 1e-15:
                break
            s = np.sign(w) if w != 0 else np.sign(force - REF.offset)
            if s == 0 or (w == 0 and abs(force - REF.offset) <= REF.Fc_pos):
                break          # sticking: nothing moves for the rest of the sample
            q, w, used = _ivp_region(q, w, force, left, REF, s)
            left -= used
            if left > 1e-15:
                w = 0.0
        qs.append(q)
        ws.append(w)
    assert np.max(np.abs(sim.q[:n] - qs)) < 1e-10
    assert np.max(np.abs(sim.w[:n] - ws)) < 1e-8
    assert np.ptp(sim.w[:n]) > 0.01                      # the axis actually moves in this stretch


def test_reference_model_on_the_validation_record():
    v = validate_emps(REF, PULSES)
    # published: 0.48 % velocity, 8.94 % force (simulation), 5.98 % (IDIM); measured here 0.378 %, 8.20 %, 5.955 %
    # (6.002 % with tail=0: the filters' end transient).
    # The benchmark's pulse block is not documented; bounds: the published figures.
    assert v.velocity_error < 0.48 and v.force_error < 8.94
    assert v.idim_force_error == pytest.approx(5.98, abs=0.1)


def test_identified_model_in_closed_loop(report, record):
    m = report.rigid_axis_model()
    est = validate_emps(m, EMPS, record=record)
    val = validate_emps(m, PULSES)
    # the identify() model (J +0.43 %, sigma -1.67 %, Fc +1.18 %) measured: 0.230 % / 5.953 % on the estimation
    # record, 0.374 % / 8.359 % (simulation) and 6.045 % (IDIM; 6.092 % with tail=0) on the validation record.
    # Bounds: within
    # 0.02 and 0.2 points of the reference model's own figures above.
    assert est.velocity_error < 0.25 and est.force_error < 6.05
    assert val.velocity_error < 0.40 and val.force_error < 8.5
    assert val.idim_force_error < 6.2
    dv = load_emps(PULSES)
    f = val.simulation.force[49:]
    fm = read_emps_record(PULSES).force[49:]
    assert val.velocity_error == pytest.approx(100 * np.linalg.norm(dv.w - val.simulation.w[49:]) / np.linalg.norm(dv.w),
                                               rel=1e-12)
    assert val.force_error == pytest.approx(100 * np.linalg.norm(fm - f) / np.linalg.norm(fm), rel=1e-12)
    cv = cross_validate(report, load_emps(PULSES))
    assert cv.idim_force_error == pytest.approx(val.idim_force_error, rel=1e-12)
    assert cv.fit_one_step > 99.0 and cv.fit_free_run > 85.0   # measured 99.93 %, 92.4 %
    # the asymmetric model does better on force in both records (measured 5.23 % and 7.79 %)
    am = fit_idim(load_emps(EMPS), asymmetric=True).model
    assert validate_emps(am, EMPS, record=record).force_error < est.force_error
    assert validate_emps(am, PULSES).force_error < val.force_error


def test_record_reader_errors(tmp_path):
    assert is_emps_record(EMPS) and is_emps_record(PULSES)
    assert not is_emps_record(tmp_path / "missing.mat")
    m = read_emps_record(EMPS)
    assert isinstance(m, EMPSRecord) and np.all(m.pulses == 0) and m.gtau == pytest.approx(35.1507, abs=1e-4)
    bad = tmp_path / "bad.mat"
    savemat(bad, {"t": m.t, "qm": m.qm, "vir": m.vir, "gtau": m.gtau, "kp": m.kp, "kv": m.kv})
    assert not is_emps_record(bad)
    with pytest.raises(SignalError, match="qg"):
        read_emps_record(bad)
    with pytest.raises(FileNotFoundError):
        read_emps_record(tmp_path / "missing.mat")
    with pytest.raises(ParameterError, match="delay"):
        simulate_emps_loop(REF, m, delay=2)
    with pytest.raises(TypeError, match="RigidAxisModel"):
        simulate_emps_loop({"J": 1}, m)


# ------------------------------------------------------------------ CLI


def test_cli_identify_asymmetric_validate_json(capsys):
    assert main(["identify", str(EMPS), "--asymmetric", "--validate", str(PULSES), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    fit = fit_idim(load_emps(EMPS), asymmetric=True)
    for k, v in fit.params.items():
        assert d["asymmetric"][k] == pytest.approx(v, rel=1e-12)
        assert d["asymmetric"]["std"][k] == pytest.approx(fit.stderr[k], rel=1e-12)
    rep = identify(load_emps(EMPS), method="auto")  # the CLI's default: IDIM-LS on the encoder axis
    assert rep.method == "idim" and d["method"] == "idim"
    loop = validate_emps(rep.rigid_axis_model(), EMPS)
    assert d["closed_loop"]["velocity_error_percent"] == pytest.approx(loop.velocity_error, rel=1e-12)
    assert d["closed_loop"]["force_error_percent"] == pytest.approx(loop.force_error, rel=1e-12)
    assert d["validation"]["closed_loop"]["force_error_percent"] < 8.5
    # the default (the IDIM-LS; the eq. 4 LS scores 6.045 % here): the benchmark's own figure, <= 5.98 %
    assert d["validation"]["idim_force_error_percent"] == pytest.approx(5.953, abs=0.002)
    assert d["asymmetric"]["validation"]["velocity_error_percent"] < 0.4
    for k, v in (("J", 95.1089), ("sigma", 203.5034), ("Fc", 20.3935)):
        assert d[k] == pytest.approx(v, rel=0.02)
        lo, hi = d["interval95"][k]
        assert lo < v < hi, k  # the published value inside the answer's 95 % interval
    # the only warnings: the model-error check's, on the coloured residuals of the filtered log (not J)
    assert {w["code"] for w in d["warnings"]} == {"model_form"} and d["excitation"]["n_reversals"] == 7
    assert sorted(w["parameter"] for w in d["warnings"]) == ["Fc", "offset", "sigma"]


def test_cli_identify_text_output(capsys):
    assert main(["identify", str(EMPS), "--asymmetric"]) == 0
    out = capsys.readouterr().out
    fit = fit_idim(load_emps(EMPS), asymmetric=True)
    row = next(x for x in out.splitlines() if x.startswith("sigma- (Fv-)"))
    assert float(row.split()[2]) == pytest.approx(fit.params["sigma_neg"], rel=1e-5)
    assert float(row.split()[3]) == pytest.approx(fit.stderr["sigma_neg"], rel=1e-2)
    assert "closed loop (EMPS PD loop" in out and "closed loop, asymmetric model" in out
    assert "cond" in out and "std error" in out


def test_cli_validate_csv(tmp_path, capsys):
    # a generic (non-EMPS) validation record: fits and the inverse-model force error, no closed loop
    d = load_emps(PULSES)
    csv = tmp_path / "val.csv"
    np.savetxt(csv, np.column_stack([d.t, d.u, d.w]), delimiter=",", header="t,u,w", comments="")
    assert main(["identify", str(EMPS), "--validate", str(csv), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "closed_loop" not in out["validation"]
    # the default on EMPS is the IDIM-LS (the eq. 4 LS: 6.09 ± 0.05 %)
    assert out["validation"]["idim_force_error_percent"] == pytest.approx(5.953, abs=0.002)
