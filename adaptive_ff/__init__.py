"""Identification of sliding dynamic friction and adaptive friction feedforward (Ruderman's method).

The middle layer: imports :mod:`plant`, never :mod:`controllers`. The package
exceptions are defined in :mod:`plant.errors` and re-exported here.

The names below are imported lazily (``lazy_loader``, Scientific Python SPEC 1):
``import adaptive_ff`` is cheap, and ``adaptive_ff.fit_ls`` or ``from adaptive_ff import fit_ls``
imports the module that defines it (and its dependencies: scipy, filterpy) on first use.
"""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(__name__, submod_attrs={
    "errors": ["ExcitationError", "FrictionError", "ParameterError", "SignalError"],
    "io.data": ["MeasuredData", "is_uniform", "load_csv", "load_emps", "load_measurements", "to_uniform"],
    "io.logs": ["VelocityEstimate", "load_log", "parse_column_map", "read_columns", "velocity_from_position",
                "LogUnits", "KalmanSettings"],
    "io.references": ["load_reference"],
    "compensation.feedforward": ["FrictionFeedforward", "project_estimate"],
    "compensation.adaptive_feedforward": ["RobustAdaptiveFeedforward"],
    "compensation.eq4_feedforward": ["AdaptiveFrictionFeedforward"],
    "compensation.gate": ["OutlierGate", "RangeGate"],
    "compensation.export_c": ["CExport", "export_c"],
    "compensation.sliding_estimator": ["SLIDING_NAMES", "SlidingFit", "SlidingFrictionEstimator", "fit_sliding",
                                       "sliding_regressors"],
    "identification.diagnostics": ["ExcitationReport", "excitation_report", "velocity_noise_std"],
    "identification.emps_validation": ["EMPSRecord", "EMPSValidation", "exact_step", "is_emps_record",
                                       "read_emps_record", "simulate_emps_loop", "validate_emps"],
    "identification.identify": ["identify"],
    "identification.identification_report": ["IdentificationReport"],
    "identification.cross_validation": ["CrossValidation", "cross_validate"],
    "identification.model_forms": ["select_form"],
    "identification.form_results": ["FormCandidate", "FormSelection"],
    "identification.idim": ["IDIMFit", "RigidAxisModel", "fit_idim", "idim_force_error", "relative_error"],
    "identification.ls": ["LSResult", "fit_ls"],
    "identification.physical_id": ["METHODS", "PHYSICAL_NAMES", "PhysicalFit", "fit_physical"],
    "identification.result_file": ["IdentificationFileError", "IdentifiedJoint", "read_identification"],
    "identification.regression": ["THETA_NAMES", "FrictionEstimate", "RegressionModel", "g_regressor",
                                  "h_regressor", "nrmse_fit", "theta_from_physical", "theta_from_physical_printed"],
    "identification.online_ukf": ["FilterDivergedError", "OnlineUKF", "OnlineUKFResult", "convergence_time",
                                  "run_online_ukf"],
    "identification.rls": ["FORGETTING", "RecursiveLeastSquares"],
    "identification.simulator": ["simulate_sampled"],
    "identification.steady_state": ["SupportPoints", "binned_steady_state", "constant_velocity_segments",
                                    "support_points"],
    "identification.steady_state_check": ["SteadyStateCheck", "steady_state_check"],
    "identification.stribeck_fit": ["StribeckFit", "fit_stribeck", "plot_stribeck_fit"],
})

__all__ = [
    "FrictionError", "ParameterError", "SignalError", "ExcitationError",
    "g_regressor", "h_regressor", "RegressionModel", "FrictionEstimate", "THETA_NAMES",
    "theta_from_physical", "theta_from_physical_printed", "nrmse_fit",
    "LSResult", "fit_ls", "RecursiveLeastSquares",
    "StribeckFit", "fit_stribeck", "plot_stribeck_fit",
    "FrictionFeedforward", "AdaptiveFrictionFeedforward", "project_estimate",
    "MeasuredData", "load_csv", "load_emps", "load_measurements", "is_uniform", "to_uniform",
    "IdentificationReport", "identify", "read_identification", "IdentifiedJoint", "IdentificationFileError",
    "select_form", "FormCandidate", "FormSelection",
    "load_log", "load_reference", "read_columns", "parse_column_map", "velocity_from_position", "VelocityEstimate",
    "LogUnits", "KalmanSettings",
    "SupportPoints", "support_points", "constant_velocity_segments", "binned_steady_state",
    "SteadyStateCheck", "steady_state_check",
    "RobustAdaptiveFeedforward", "OutlierGate", "RangeGate", "FORGETTING", "export_c", "CExport",
    "SlidingFrictionEstimator", "SlidingFit", "fit_sliding", "sliding_regressors", "SLIDING_NAMES",
    "excitation_report", "ExcitationReport", "velocity_noise_std",
    "CrossValidation", "cross_validate",
    "fit_idim", "IDIMFit", "RigidAxisModel", "idim_force_error", "relative_error",
    "validate_emps", "EMPSValidation", "simulate_emps_loop", "read_emps_record", "EMPSRecord", "exact_step",
    "is_emps_record",
    "fit_physical", "PhysicalFit", "METHODS", "PHYSICAL_NAMES", "simulate_sampled",
    "OnlineUKF", "OnlineUKFResult", "run_online_ukf", "FilterDivergedError", "convergence_time",
]
