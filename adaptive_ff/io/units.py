"""Units: of drive-log columns, of the friction parameters, of printed tables (standard library only).

The one table of each: the log columns' units are used by :func:`adaptive_ff.io.logs.load_log` (which
re-exports these names) and by the ``adaptive-ff`` data options (:mod:`controllers.cli.data`), whose
``--help`` must not import numpy or scipy; the parameters' units by the identification report
(:data:`adaptive_ff.identification.identify.PARAM_UNITS`), the figures
(:data:`controllers.report.figures.PARAMETER_UNITS`) and the command line's ``--units deg|rad``
(:data:`TABLE_UNITS`).
"""

from __future__ import annotations

import math

__all__ = ["ROLES", "TIME_UNITS", "VELOCITY_UNITS", "POSITION_UNITS", "KALMAN_MODELS", "PARAMETER_UNITS",
           "LINEAR_UNITS", "PARAM_UNITS", "VELOCITY_LABEL", "TABLE_UNITS", "parameter_text"]

#: Roles of the signals of a drive log and their meaning.
ROLES = {
    "t": "time stamps",
    "u": "input torque (motor current with current_to_torque)",
    "w": "velocity",
    "q": "position",
}

#: Time units and their factor to s.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: Velocity units and their factor to rad/s ("rad/s" is also the unit for m/s: no conversion).
VELOCITY_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0}
#: Position units and their factor to rad ("counts" needs counts_per_rev).
POSITION_UNITS = ("rad", "deg", "counts")
#: Kalman models for velocity from position (name: state dimension): constant velocity, constant acceleration.
KALMAN_MODELS = {"cv": 2, "ca": 3}

#: SI units of the parameter symbols on a rotary joint: the physical parameters (eqs. 1-3; ``J_tau = J*tau`` of
#: the sliding estimator), the plant variants' (:mod:`plant.models`: LuGre ``sigma0..2``, Karnopp ``dv``,
#: asymmetric ``*_pos``/``*_neg``), the coefficients of the regression model (eq. 4, velocity in rad/s,
#: torque in N·m) and the PI velocity controller's gains ``Kp``, ``Ki``; "1" and "-" mark dimensionless ones.
PARAMETER_UNITS = {"J": "kg·m²", "J_tau": "kg·m²·s", "tau": "s", "Fc": "N·m", "Fs": "N·m", "sigma": "N·m·s/rad",
                   "offset": "N·m", "Vs": "rad/s", "delta": "1", "a1": "-", "a2": "-", "b0": "(rad/s)/(N·m)",
                   "b1": "(rad/s)/(N·m)", "c1": "rad/s", "d1": "rad/s", "o1": "rad/s",
                   "sigma0": "N·m/rad", "sigma1": "N·m·s/rad", "sigma2": "N·m·s/rad", "dv": "rad/s",
                   "Fc_pos": "N·m", "Fc_neg": "N·m", "Fs_pos": "N·m", "Fs_neg": "N·m", "sigma_pos": "N·m·s/rad",
                   "sigma_neg": "N·m·s/rad", "Kp": "N·m·s/rad", "Ki": "N·m/rad"}

#: The same on a linear (prismatic) axis, where they differ: velocity in m/s, force in N (e.g. the EMPS axis).
LINEAR_UNITS = {"J": "kg", "J_tau": "kg·s", "Fc": "N", "Fs": "N", "sigma": "N·s/m", "offset": "N", "Vs": "m/s",
                "Kp": "N·s/m", "Ki": "N/m"}

#: A velocity as printed where the axis may be rotary or linear (the identification's notes and warnings).
VELOCITY_LABEL = f"{PARAMETER_UNITS['Vs']} ({LINEAR_UNITS['Vs']})"

#: Units of the physical parameters as the identification report prints them: rotary, the linear axis's in
#: parentheses (``"kg·m² (kg)"``).
PARAM_UNITS = {name: (f"{PARAMETER_UNITS[name]} ({LINEAR_UNITS[name]})" if name in LINEAR_UNITS
                      else PARAMETER_UNITS[name]) for name in ("J", "sigma", "Fc", "Fs", "tau", "offset")}

#: Velocity units of printed tables (``--units``): name -> (factor from rad/s, label).
TABLE_UNITS = {"deg": (180.0 / math.pi, "deg/s"), "rad": (1.0, "rad/s")}


def parameter_text(params: dict) -> str:
    """Parameters as one line of ``name=value unit``, in SI (rotary joint): ``"J=4 kg·m², Fc=25 N·m, ..."``.

    Parameters
    ----------
    params : dict
        ``{name: value}``, e.g. :func:`plant.models.plant_to_dict` of a plant; numbers (SI, units of
        :data:`PARAMETER_UNITS`) are printed with ``:g`` and their unit (none where dimensionless or unknown),
        strings as they are (``model=lagged-stribeck``); nested dicts (a drift) are left out.

    Returns
    -------
    str
        The ``", "``-joined items, in the order of ``params``.
    """
    parts = []
    for name, value in params.items():
        if isinstance(value, dict):
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            parts.append(f"{name}={value}")
            continue
        unit = PARAMETER_UNITS.get(name, "")
        parts.append(f"{name}={value:g}" + (f" {unit}" if unit not in ("", "1", "-") else ""))
    return ", ".join(parts)
