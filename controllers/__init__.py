"""Velocity control with friction compensation: PI design (python-control), closed-loop runner, comparison, CLI.

The top layer: imports :mod:`adaptive_ff` and :mod:`plant`.
"""

from controllers.batch import BATCH_MODES, BatchResult, run_batch
from controllers.canudas import CanudasCompensator
from controllers.dob import DisturbanceObserver
from controllers.testing import TrackingBoundError, assert_tracking_bound, velocity_faults
from controllers.closed_loop import (ENGINES, ESTIMATORS, MODES, ClosedLoopResult, LoopMetrics, kernel_supported,
                                      loop_metrics, run_closed_loop)
from controllers.compare import FIXED_METHODS, Comparison, compare, eta, friction_scale, prefit_stribeck
from controllers.figures import plot_comparison
from controllers.loop_analysis import LoopAnalysis, analyse_design
from controllers.paper_figures import identification_figures, paper_figures
from controllers.report import compare_report, identify_report, report_html, write_report
from controllers.synthetic_logs import closed_loop_response, quasi_static_log
from controllers.pi import PIController, PIDesign, closed_loop_step, design_pi
from controllers.quasi_static import QuasiStaticData, bidirectional_velocities, quasi_static_runs

__all__ = [
    "PIDesign", "design_pi", "PIController", "closed_loop_step",
    "QuasiStaticData", "quasi_static_runs", "bidirectional_velocities",
    "MODES", "LoopMetrics", "ClosedLoopResult", "run_closed_loop", "loop_metrics", "ENGINES", "kernel_supported",
    "Comparison", "compare", "eta", "plot_comparison",
    "LoopAnalysis", "analyse_design", "paper_figures", "identification_figures",
    "report_html", "write_report", "identify_report", "compare_report",
    "quasi_static_log", "closed_loop_response",
    "ESTIMATORS", "FIXED_METHODS", "friction_scale", "prefit_stribeck",
    "BATCH_MODES", "BatchResult", "run_batch",
    "CanudasCompensator", "DisturbanceObserver", "assert_tracking_bound", "TrackingBoundError", "velocity_faults",
]
