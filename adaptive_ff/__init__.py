"""Identification of sliding dynamic friction and adaptive friction feedforward (Ruderman's method).

The middle layer: imports :mod:`plant`, never :mod:`controllers`. The package
exceptions are defined in :mod:`plant.errors` and re-exported here.
"""

from adaptive_ff.io.data import MeasuredData, is_uniform, load_csv, load_emps, load_measurements, to_uniform
from adaptive_ff.compensation.feedforward import (AdaptiveFrictionFeedforward, FrictionFeedforward, RobustAdaptiveFeedforward,
                                     project_estimate)
from adaptive_ff.compensation.gate import OutlierGate
from adaptive_ff.io.logs import VelocityEstimate, load_log, parse_column_map, read_columns, velocity_from_position
from adaptive_ff.identification.diagnostics import ExcitationReport, excitation_report, velocity_noise_std
from adaptive_ff.identification.emps_validation import (EMPSRecord, EMPSValidation, exact_step, is_emps_record, read_emps_record,
                                         simulate_emps_loop, validate_emps)
from adaptive_ff.identification.identify import CrossValidation, IdentificationReport, cross_validate, identify
from adaptive_ff.identification.idim import IDIMFit, RigidAxisModel, fit_idim, idim_force_error, relative_error
from adaptive_ff.identification.ls import LSResult, fit_ls
from adaptive_ff.identification.physical_id import METHODS, PHYSICAL_NAMES, PhysicalFit, fit_physical
from adaptive_ff.identification.regression import (THETA_NAMES, FrictionEstimate, RegressionModel, g_regressor, h_regressor,
                                    nrmse_fit, theta_from_physical, theta_from_physical_printed)
from adaptive_ff.identification.online_ukf import FilterDivergedError, OnlineUKF, OnlineUKFResult, convergence_time, run_online_ukf
from adaptive_ff.identification.rls import FORGETTING, RecursiveLeastSquares
from adaptive_ff.identification.simulator import simulate_sampled
from adaptive_ff.compensation.sliding_estimator import (SLIDING_NAMES, SlidingFit, SlidingFrictionEstimator, fit_sliding,
                                           sliding_regressors)
from adaptive_ff.identification.steady_state import SupportPoints, binned_steady_state, constant_velocity_segments, support_points
from adaptive_ff.identification.stribeck_fit import StribeckFit, fit_stribeck, plot_stribeck_fit
from plant.errors import ExcitationError, FrictionError, ParameterError, SignalError

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
    "SupportPoints", "support_points", "constant_velocity_segments", "binned_steady_state",
    "RobustAdaptiveFeedforward", "OutlierGate", "FORGETTING",
    "SlidingFrictionEstimator", "SlidingFit", "fit_sliding", "sliding_regressors", "SLIDING_NAMES",
    "excitation_report", "ExcitationReport", "velocity_noise_std",
    "CrossValidation", "cross_validate",
    "fit_idim", "IDIMFit", "RigidAxisModel", "idim_force_error", "relative_error",
    "validate_emps", "EMPSValidation", "simulate_emps_loop", "read_emps_record", "EMPSRecord", "exact_step",
    "is_emps_record",
    "fit_physical", "PhysicalFit", "METHODS", "PHYSICAL_NAMES", "simulate_sampled",
    "OnlineUKF", "OnlineUKFResult", "run_online_ukf", "FilterDivergedError", "convergence_time",
]
