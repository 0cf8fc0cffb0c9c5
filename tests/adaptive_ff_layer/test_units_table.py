"""One table of parameter units (adaptive_ff.io.units) used by the report, the figures and the command line."""

import numpy as np

from adaptive_ff.identification.diagnostics import excitation_report
from adaptive_ff.io import units
from plant.friction import preset
from plant.models import plant_to_dict
from plant.variant_plants import variants


def test_one_definition_imported_by_the_others():
    from adaptive_ff.identification import identify
    from controllers.cli import data
    from controllers.report import figures

    assert identify.PARAM_UNITS is units.PARAM_UNITS
    assert figures.PARAMETER_UNITS is units.PARAMETER_UNITS
    assert data.TABLE_UNITS is units.TABLE_UNITS
    # the identification report's labels: rotary SI, the linear axis's in parentheses (unchanged strings)
    assert units.PARAM_UNITS == {"J": "kg·m² (kg)", "sigma": "N·m·s/rad (N·s/m)", "Fc": "N·m (N)",
                                 "Fs": "N·m (N)", "tau": "s", "offset": "N·m (N)"}
    assert units.TABLE_UNITS["deg"] == (180.0 / np.pi, "deg/s") and units.VELOCITY_LABEL == "rad/s (m/s)"


def test_every_plant_parameter_has_a_unit():
    for p in [preset("paper"), *variants().values()]:
        names = [k for k, v in plant_to_dict(p).items() if isinstance(v, float)]
        assert names and all(k in units.PARAMETER_UNITS for k in names), (type(p).__name__, names)


def test_plant_line_gives_si_units():
    assert units.parameter_text(plant_to_dict(preset("paper"))) == (
        "model=lagged-stribeck, J=4 kg·m², Fc=25 N·m, Fs=35 N·m, Vs=0.02 rad/s, delta=1, "
        "sigma=40 N·m·s/rad, tau=0.02 s")
    assert units.parameter_text({"J": 2.5, "drift": {"Fc_change": 0.5}, "x": 1.0}) == "J=2.5 kg·m², x=1"


def test_low_speed_warning_names_the_velocity_unit_of_either_axis():
    rng = np.random.default_rng(0)
    t = np.arange(4000) * 1e-3
    w = 0.5 * np.sin(2 * np.pi * 0.5 * t) + 1e-4 * rng.standard_normal(t.shape)  # fast: few low-speed samples
    rep = excitation_report(np.cos(t) + rng.standard_normal(t.shape), w, Vs=1e-4)
    msg = [str(x) for x in rep.warnings if x.parameter == "Fs"]
    assert len(msg) == 1 and "3*Vs = 0.0003 rad/s (m/s)" in msg[0]
