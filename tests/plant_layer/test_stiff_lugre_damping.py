"""LuGre joints with critically damped (and over-damped) bristles: simulated at the 1 ms step, accepted end to end.

A LuGre joint with ``sigma1 = 2*sqrt(sigma0*J)`` (critical damping of the pre-sliding oscillator, the textbook
choice) has a bristle time constant ``J/sigma1`` far below the step; it is stiff, not implausible. The package's
step (:func:`plant.dynamics.plant_step`: RK4 sub-steps chosen from the linearised eigenvalues, the implicit
:func:`plant.dynamics.lugre_stiff_step` beyond them) is checked here against an independent solution of the
textbook equations (Canudas de Wit, Olsson, Åström, Lischinsky, IEEE TAC 40(3), 1995, eqs. 2-5) by scipy's Radau
IIA at tight tolerances; ``adaptive-ff compare --plant`` runs such a joint; meaningless LuGre parameters are refused
in physical words.
"""

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from controllers.cli.main import main
from plant.dynamics import plant_params, plant_simulate, plant_state
from plant.errors import ParameterError
from plant.lugre import LuGreParams
from plant.models import check_plausible, load_plant, plant_from_dict

DT = 1e-3
J, SIGMA0 = 0.8, 1e6  # kg·m², N·m/rad
CRITICAL = 2.0 * math.sqrt(SIGMA0 * J)  # 1788.9 N·m·s/rad
JOINT = {"model": "lugre", "J": J, "Fc": 5.0, "Fs": 7.5, "Vs": 0.02, "delta": 2.0, "sigma0": SIGMA0,
         "sigma1": 1800.0, "sigma2": 8.0}


def _textbook(d: dict, u: np.ndarray, damping: str = "bristle") -> np.ndarray:
    """Velocity (rad/s) after every step of ``u`` (N·m, held over each DT) from rest: Radau IIA, rtol 1e-10.

    Canudas de Wit et al. (1995): ``dz/dt = w - sigma0*|w|/g(w)*z``, ``g(w) = Fc + (Fs - Fc)*exp(-|w/Vs|**delta)``,
    ``F = sigma0*z + sigma1*dz/dt + sigma2*w``, ``J*dw/dt = u - F``. ``damping="viscous"`` is the misreading of
    ``sigma1`` as a viscous coefficient (``sigma1*w`` instead of ``sigma1*dz/dt``), ``"none"`` leaves the damping out:
    the mutations that show the tolerance sees a wrong damping term.
    """
    Jd, Fc, Fs, Vs, delta = d["J"], d["Fc"], d["Fs"], d["Vs"], d["delta"]
    s0, s1, s2 = d["sigma0"], d["sigma1"], d["sigma2"]

    def f(t, y, uk):
        w, z = y
        g = Fc + (Fs - Fc) * math.exp(-abs(w / Vs) ** delta)
        zd = w - s0 * abs(w) / g * z
        F = s0 * z + {"bristle": s1 * zd, "viscous": s1 * w, "none": 0.0}[damping] + s2 * w
        return [(uk - F) / Jd, zd]

    y = np.zeros(2)
    W = [0.0]
    for uk in u.tolist():
        r = solve_ivp(f, (0.0, DT), y, method="Radau", rtol=1e-10, atol=[1e-12, 1e-16], args=(uk,))
        assert r.success
        y = r.y[:, -1]
        W.append(y[0])
    return np.array(W)


def _package(p, u: np.ndarray) -> np.ndarray:
    st = plant_state(p, 0.0)
    W = np.empty(u.size + 1)
    S = np.empty(u.size + 1)
    plant_simulate(plant_params(p), st, np.ascontiguousarray(u), DT, W, S)
    return W


def _torque() -> np.ndarray:
    """300 ms: 30 ms at 6 N·m (below Fs = 7.5 N·m: pre-sliding), a step to 12 N·m, a reversal to -12 N·m at 150 ms."""
    t = np.arange(300) * DT
    return np.where(t < 0.03, 6.0, np.where(t < 0.15, 12.0, -12.0))


@pytest.mark.parametrize("sigma1", [1800.0, 2.0 * CRITICAL])  # critical (1788.9 N·m·s/rad), twice critical
def test_critically_damped_lugre_matches_the_textbook_equations_by_radau(sigma1):
    d = {**JOINT, "sigma1": sigma1}
    p = plant_from_dict(d)
    check_plausible(p)  # accepted at the 1 ms step (was: "not a plausible joint")
    assert J / p.sigma1 < DT / 2  # the bristle time constant the former check refused
    u = _torque()
    W = _package(p, u)
    Wo = _textbook(d, u)
    peak = float(np.max(np.abs(Wo)))
    # the joint pre-slides (|w| tiny), breaks away, slides and reverses
    assert np.max(np.abs(Wo[:30])) < 0.5 * d["Vs"] and peak > 0.5 and Wo[150] > 0.5 and Wo[-1] < -0.5
    tol = 1e-4 * peak
    np.testing.assert_allclose(W, Wo, rtol=0.0, atol=tol)
    # the tolerance sees a wrong damping term: sigma1 read as a viscous coefficient, or the damping left out
    for wrong in (_textbook(d, u, damping="viscous"), _textbook(d, u, damping="none")):
        assert np.max(np.abs(wrong - Wo)) > 10 * tol


@pytest.mark.parametrize("zeta", [0.1, 1.0, 2.0, 10.0])
def test_the_step_rate_bounds_the_pre_sliding_eigenvalues_with_the_damping(zeta):
    # linearised at rest, J*l**2 + (sigma1 + sigma2)*l + sigma0 = 0; the packed rate the sub-steps are chosen from
    # (plant.rows: (sigma1 + sigma2)/J + sqrt(sigma0/J)) is at least the largest |l|, the damping included
    p = plant_from_dict({**JOINT, "sigma1": zeta * CRITICAL})
    lam = np.roots([p.J, p.sigma1 + p.sigma2, p.sigma0])
    assert plant_params(p).base_rate >= np.max(np.abs(lam)) * (1 - 1e-12)
    if zeta >= 2.0:  # over-damped: the fast root is near (sigma1 + sigma2)/J, beyond sqrt(sigma0/J)
        assert np.max(np.abs(lam)) > 3.0 * math.sqrt(p.sigma0 / p.J)


def test_compare_cli_runs_a_critically_damped_lugre_joint(tmp_path, capsys):
    f = tmp_path / "lugre.json"
    f.write_text(json.dumps(JOINT))
    assert main(["compare", "--plant", str(f), "--duration", "4", "--modes", "adaptive,dob", "--no-figures",
                 "--quiet", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["plant"]["model"] == "lugre" and d["plant"]["sigma1"] == 1800.0
    assert set(d["modes"]) == {"none", "adaptive", "dob", "frictionless"}
    for m in d["modes"].values():
        assert all(math.isfinite(m[k]) for k in ("rms", "max", "rms_reversal", "eta")) and not m.get("diverged")
    # the table itself (no JSON): every mode's row, finite numbers
    assert main(["compare", "--plant", str(f), "--duration", "4", "--modes", "adaptive", "--no-figures"]) == 0
    rows = [ln.split() for ln in capsys.readouterr().out.splitlines() if ln.split()[:1] in (["none"], ["adaptive"],
                                                                                            ["frictionless"])]
    assert len(rows) == 3 and all(math.isfinite(float(x)) for r in rows for x in r[1:])


@pytest.mark.parametrize("key, value, message", [
    ("sigma1", -5.0, "sigma1 must be >= 0, got -5.0 N·m·s/rad: the bristle damping of a LuGre joint cannot be "
                     "negative"),
    ("sigma0", 0.0, "sigma0 must be > 0, got 0.0 N·m/rad: the bristle stiffness of a LuGre joint is positive"),
    ("sigma2", -1.0, "sigma2 must be >= 0, got -1.0 N·m·s/rad: the viscous friction coefficient"),
    ("J", 0.0, "J must be > 0, got 0.0 kg·m²: the joint inertia"),
])
def test_meaningless_lugre_parameters_are_refused_in_physical_words(tmp_path, capsys, key, value, message):
    with pytest.raises(ParameterError) as exc:
        plant_from_dict({**JOINT, key: value})
    assert message in str(exc.value)
    f = tmp_path / "bad.json"
    f.write_text(json.dumps({**JOINT, key: value}))
    with pytest.raises(ParameterError, match=key):
        load_plant(f)
    assert main(["compare", "--plant", str(f), "--no-figures", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(f) in err and message in err and "Traceback" not in err


def test_non_finite_lugre_parameter_names_its_unit():
    with pytest.raises(ParameterError, match=r"sigma1 must be finite, got inf N·m·s/rad \(the bristle damping"):
        LuGreParams(J=J, Fc=5.0, Fs=7.5, Vs=0.02, delta=2.0, sigma0=SIGMA0, sigma1=math.inf, sigma2=0.0)


def test_lagged_models_keep_their_viscous_time_constant_check():
    # sigma is a viscous coefficient there: J/sigma below dt/2 is a unit slip, refused with the time constant
    p = plant_from_dict({"J": 4.0, "Fc": 25.0, "Fs": 35.0, "Vs": 0.02, "delta": 1.0, "sigma": 1e9, "tau": 0.02})
    with pytest.raises(ParameterError, match="mechanical time constant J/sigma"):
        check_plausible(p)
    # a LuGre joint whose pre-sliding frequency is beyond the stiff integrator is refused for that reason
    absurd = plant_from_dict({**JOINT, "J": 1e-4, "sigma0": 1e9 * 0.999})
    check_plausible(absurd)  # sqrt(1e9/1e-4)*dt = 3.2e3 <= 1e4: accepted
    with pytest.raises(ParameterError, match="pre-sliding frequency"):
        check_plausible(absurd, dt=1e-2)
