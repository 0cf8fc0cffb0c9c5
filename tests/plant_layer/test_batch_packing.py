"""Tests of the vectorised packing behind run_batch: plant_rows, plant_states, integrable_rows, build_modes
equal their one-plant/one-run counterparts bit for bit (metrics_columns: tests/controllers_layer/test_metrics.py); a bad plant in a
batch is named by index."""

import math

import numpy as np
import pytest

from controllers.simulation.batch import run_batch
from controllers.simulation.closed_loop import LoopConfig
from controllers.simulation.compensators import build_mode, build_modes
from plant.errors import ParameterError
from plant.excitation import multisine_reference
from plant.friction import preset
from plant.lugre import LuGreParams
from plant._cplant import ffi, lib
from plant.rows import (LUGRE_STIFF_MAX, check_integrable, integrable_rows, plant_params, plant_rows, plant_state,
                        plant_states, stack_params, stack_states)
from plant.variant_plants import variant

DT = 1e-3


def _zoo():
    """Every model class, with and without lag, rising and falling maps, and one object twice."""
    p = preset("paper")
    k, a = variant("karnopp"), variant("asymmetric")
    return [p, p.replace(tau=0.0), p.replace(Fs=0.5 * p.Fc, delta=-0.5), p.replace(delta=1.7, sigma=0.0),
            variant("lugre"), k, k.replace(tau=0.0), a, a.replace(tau=0.0), p]


def _bits(x):
    return np.asarray(x, dtype=float).view(np.int64)


def _bytes(x) -> bytes:
    """The bytes of a cffi struct or array."""
    return bytes(ffi.buffer(x))


def test_plant_rows_and_states_equal_the_one_plant_functions_bit_for_bit():
    zoo = _zoo()
    rows = plant_rows(zoo)
    assert ffi.typeof(rows).item is ffi.typeof("plant_params") and len(rows) == len(zoo)
    assert _bytes(rows) == b"".join(_bytes(plant_params(p)) for p in zoo)
    assert len(plant_rows([])) == 0
    assert _bytes(stack_params([plant_params(p) for p in zoo])) == _bytes(rows)
    assert _bytes(stack_params([rows[b] for b in range(len(zoo))])) == _bytes(rows)  # structs or pointers
    for w0 in (0.0, -0.0, 0.05, -0.3, 1e-6, -40.0):
        st = plant_states(rows, w0)
        assert _bytes(st) == b"".join(_bytes(plant_state(p, w0)) for p in zoo)
        assert _bytes(stack_states([plant_state(p, w0) for p in zoo])) == _bytes(st)
        for p, s in zip(zoo, st):  # the state of steady motion: F(w0) of the class (LuGre: its deflection)
            assert s.w == w0 and s.s == p.initial_state(w0)
    # the eq. 3 cache field holds the struct's key exactly for the lagged models without lag
    st = plant_states(rows, 0.2)
    cached = [r.model != lib.PLANT_LUGRE and r.tau == 0.0 for r in rows]
    assert [s.aux == r.key for s, r in zip(st, rows)] == cached and sum(cached) == 3
    assert all(math.isnan(s.aux) for s, c in zip(st, cached) if not c)
    with pytest.raises(ParameterError, match="w0"):
        plant_states(rows, math.nan)
    with pytest.raises(TypeError, match="frozen"):
        plant_rows([zoo[0], {"J": 1.0}])
    with pytest.raises(TypeError, match="plant_params"):
        plant_states(np.zeros((2, 24)), 0.0)
    with pytest.raises(TypeError, match="plant_state"):
        stack_states([rows[0]])


#: Fields that must be finite in a lagged model (check_integrable's docstring), as paths into plant_params.
_CHECKED = ("pos.Vs", "pos.delta", "neg.Vs", "neg.delta", "pos.Fc", "pos.dF", "pos.sigma", "neg.Fc", "neg.dF",
            "neg.sigma", "Fs_stick", "dv")


def _get(r, path):
    for name in path.split("."):
        r = getattr(r, name)
    return r


def _set(r, path, value):
    head, _, last = path.rpartition(".")
    setattr(_get(r, head) if head else r, last, value)


def _scalar_ok(row, dt):
    """Independent scalar statement of the integrability conditions (plant.rows.check_integrable's docstring)."""
    J, tau = row.J, row.tau
    if row.model == lib.PLANT_LUGRE:
        ratio = row.sigma0 / J if J != 0.0 else math.inf
        return (math.sqrt(ratio) if ratio >= 0.0 else math.nan) * dt <= LUGRE_STIFF_MAX
    levels = [_get(row, f) for f in _CHECKED]
    return J > 0.0 and math.isfinite(J) and 0.0 <= tau < math.inf and all(map(math.isfinite, levels))


def test_integrable_rows_equals_the_scalar_conditions_and_check_integrable_names_the_first_bad_row():
    rng = np.random.default_rng(4)
    good = plant_rows(_zoo())
    lugre = plant_params(LuGreParams(J=1e-2, Fc=1.0, Fs=2.0, Vs=0.01, delta=2.0, sigma0=1.0, sigma1=0.0,
                                     sigma2=0.0))
    edge = (LUGRE_STIFF_MAX / DT) ** 2 * 1e-2  # sqrt(sigma0/J)*dt == LUGRE_STIFF_MAX: accepted
    table = [ffi.new("plant_params *", lugre[0]) for _ in range(8)]
    for j, s0 in enumerate((edge, edge * (1 + 1e-12), 1e14, -1.0, 0.0, math.nan, math.inf, 1.0)):
        table[j].sigma0 = s0
    table[-1].J = 0.0  # LuGre with J = 0: infinite frequency
    bad = []
    for field, value in [("J", 0.0), ("J", -1.0), ("J", math.inf), ("J", math.nan), ("tau", -1e-3),
                         ("tau", math.inf), ("tau", math.nan), ("pos.Vs", math.nan), ("neg.delta", math.inf),
                         ("pos.dF", math.nan), ("neg.dF", -math.inf), ("Fs_stick", math.nan), ("dv", math.inf),
                         ("neg.sigma", math.nan), ("rate", math.nan)]:  # rate is not checked
        r = ffi.new("plant_params *", good[int(rng.integers(len(good)))])
        if r.model == lib.PLANT_LUGRE:
            r = ffi.new("plant_params *", good[0])
        _set(r, field, value)
        bad.append(r)
    rows = stack_params([*good, *table, *bad])
    ok = integrable_rows(rows, DT)
    assert ok.dtype == bool and ok.tolist() == [_scalar_ok(r, DT) for r in rows]
    assert ok[:len(good) + 1].all() and not ok[len(good) + 1] and ok[-1]
    for j in np.flatnonzero(~ok).tolist():  # each bad row alone and at the end of a good table: named by row
        with pytest.raises(ParameterError, match=r"row 0\b"):
            check_integrable(rows + j, DT)
        with pytest.raises(ParameterError, match=r"row 0\b"):
            check_integrable(rows[j], DT)
        with pytest.raises(ParameterError, match=rf"row {len(good)}\b"):
            check_integrable(stack_params([*good, rows[j]]), DT)
    check_integrable(good, DT)


def test_a_bad_plant_in_a_batch_is_named_by_its_index():
    ref = multisine_reference(0.2, rng=np.random.default_rng(0))
    o = LoopConfig.from_flat(Kp=1.0, Ki=1.0, u_max=5.0)
    absurd = LuGreParams(J=1e-4, Fc=1.0, Fs=2.0, Vs=0.01, delta=2.0, sigma0=1e14, sigma1=0.0, sigma2=0.0)
    p = preset("paper")
    with pytest.raises(ParameterError, match=r"plants\[3\]: LuGre plant \(row 0\): the pre-sliding frequency"):
        run_batch([p, p, variant("lugre"), absurd, absurd], ref, "none", o)
    with pytest.raises(TypeError, match="frozen"):
        run_batch([p, "paper"], ref, "none", o)


def test_build_modes_equals_build_mode_with_one_controller_per_options_object():
    p = preset("paper")
    plants = [p, p.replace(J=2 * p.J), p]
    o1 = LoopConfig.from_flat(Kp=2.0, Ki=40.0, u_max=5.0, Vs=p.Vs, delta=p.delta)
    o2 = LoopConfig.from_flat(Kp=3.0, Ki=40.0, u_max=5.0, Vs=p.Vs, delta=p.delta)
    for mode in ("none", "frictionless", "adaptive", "dob"):
        run_plants, ctrls, comps = build_modes(plants, mode, [o1, o2, o1])
        assert ctrls[0] is ctrls[2] and ctrls[1] is not ctrls[0]
        for b, (q, o) in enumerate(zip(plants, (o1, o2, o1))):
            rp, c, comp = build_mode(q, mode, o)
            assert rp == run_plants[b]
            assert c.struct_bytes() == ctrls[b].struct_bytes()  # the PI's C struct (gains, limit, state)
            if comp is None:
                assert comps[b] is None
            else:
                assert comp.struct_bytes() == comps[b].struct_bytes()
        assert mode in ("none", "frictionless") or len({id(c) for c in comps}) == 3
    with pytest.raises(ParameterError, match="mode"):
        build_modes(plants, "magic", [o1] * 3)
    with pytest.raises(ParameterError, match="options"):
        build_modes(plants, "none", [o1, "o2", o1])
