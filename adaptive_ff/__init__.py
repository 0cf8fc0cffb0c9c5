"""Identification of sliding dynamic friction and adaptive friction feedforward (Ruderman's method).

The middle layer: imports :mod:`plant`, never :mod:`controllers`. The package
exceptions are defined in :mod:`plant.errors` and re-exported here.

The names below are imported lazily (PEP 562): ``import adaptive_ff`` is cheap,
and ``adaptive_ff.fit_ls`` or ``from adaptive_ff import fit_ls`` imports the
module that defines it (and its dependencies: scipy, numba, filterpy) on first use.
"""

from __future__ import annotations

import importlib
import sys
import types

#: module -> the public names this package re-exports from it
_EXPORTS = {
    "plant.errors": ("ExcitationError", "FrictionError", "ParameterError", "SignalError"),
    "adaptive_ff.io.data": ("MeasuredData", "is_uniform", "load_csv", "load_emps", "load_measurements", "to_uniform"),
    "adaptive_ff.io.logs": ("VelocityEstimate", "load_log", "parse_column_map", "read_columns",
                            "velocity_from_position", "LogUnits", "KalmanSettings"),
    "adaptive_ff.compensation.feedforward": ("FrictionFeedforward", "project_estimate"),
    "adaptive_ff.compensation.adaptive_feedforward": ("RobustAdaptiveFeedforward",),
    "adaptive_ff.compensation.eq4_feedforward": ("AdaptiveFrictionFeedforward",),
    "adaptive_ff.compensation.gate": ("OutlierGate", "RangeGate"),
    "adaptive_ff.compensation.sliding_estimator": ("SLIDING_NAMES", "SlidingFit", "SlidingFrictionEstimator",
                                                   "fit_sliding", "sliding_regressors"),
    "adaptive_ff.identification.diagnostics": ("ExcitationReport", "excitation_report", "velocity_noise_std"),
    "adaptive_ff.identification.emps_validation": ("EMPSRecord", "EMPSValidation", "exact_step", "is_emps_record",
                                                   "read_emps_record", "simulate_emps_loop", "validate_emps"),
    "adaptive_ff.identification.identify": ("CrossValidation", "IdentificationReport", "cross_validate", "identify"),
    "adaptive_ff.identification.idim": ("IDIMFit", "RigidAxisModel", "fit_idim", "idim_force_error",
                                        "relative_error"),
    "adaptive_ff.identification.ls": ("LSResult", "fit_ls"),
    "adaptive_ff.identification.physical_id": ("METHODS", "PHYSICAL_NAMES", "PhysicalFit", "fit_physical"),
    "adaptive_ff.identification.regression": ("THETA_NAMES", "FrictionEstimate", "RegressionModel", "g_regressor",
                                              "h_regressor", "nrmse_fit", "theta_from_physical",
                                              "theta_from_physical_printed"),
    "adaptive_ff.identification.online_ukf": ("FilterDivergedError", "OnlineUKF", "OnlineUKFResult",
                                              "convergence_time", "run_online_ukf"),
    "adaptive_ff.identification.rls": ("FORGETTING", "RecursiveLeastSquares"),
    "adaptive_ff.identification.simulator": ("simulate_sampled",),
    "adaptive_ff.identification.steady_state": ("SupportPoints", "binned_steady_state", "constant_velocity_segments",
                                                "support_points"),
    "adaptive_ff.identification.stribeck_fit": ("StribeckFit", "fit_stribeck", "plot_stribeck_fit"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = [
    "FrictionError", "ParameterError", "SignalError", "ExcitationError",
    "g_regressor", "h_regressor", "RegressionModel", "FrictionEstimate", "THETA_NAMES",
    "theta_from_physical", "theta_from_physical_printed", "nrmse_fit",
    "LSResult", "fit_ls", "RecursiveLeastSquares",
    "StribeckFit", "fit_stribeck", "plot_stribeck_fit",
    "FrictionFeedforward", "AdaptiveFrictionFeedforward", "project_estimate",
    "MeasuredData", "load_csv", "load_emps", "load_measurements", "is_uniform", "to_uniform",
    "IdentificationReport", "identify",
    "load_log", "read_columns", "parse_column_map", "velocity_from_position", "VelocityEstimate",
    "LogUnits", "KalmanSettings",
    "SupportPoints", "support_points", "constant_velocity_segments", "binned_steady_state",
    "RobustAdaptiveFeedforward", "OutlierGate", "RangeGate", "FORGETTING",
    "SlidingFrictionEstimator", "SlidingFit", "fit_sliding", "sliding_regressors", "SLIDING_NAMES",
    "excitation_report", "ExcitationReport", "velocity_noise_std",
    "CrossValidation", "cross_validate",
    "fit_idim", "IDIMFit", "RigidAxisModel", "idim_force_error", "relative_error",
    "validate_emps", "EMPSValidation", "simulate_emps_loop", "read_emps_record", "EMPSRecord", "exact_step",
    "is_emps_record",
    "fit_physical", "PhysicalFit", "METHODS", "PHYSICAL_NAMES", "simulate_sampled",
    "OnlineUKF", "OnlineUKFResult", "run_online_ukf", "FilterDivergedError", "convergence_time",
]


def __getattr__(name: str):
    """Import the module of a re-exported ``name`` on first access (PEP 562) and cache the value here."""
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """This package's module type: a submodule never shadows a re-exported name of the same spelling.

    Importing a submodule binds it on its package (``setattr(package, "name", module)``);
    where a re-exported object has that name (``plant.stribeck`` the function and
    ``plant/stribeck.py`` the module), the object wins, as with eager imports.
    """

    def __setattr__(self, name, value):
        if name in _WHERE and isinstance(value, types.ModuleType) and value.__name__ == f"{__name__}.{name}":
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
