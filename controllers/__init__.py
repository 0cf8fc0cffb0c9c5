"""Velocity control with friction compensation: PI design (python-control), closed-loop runner, comparison, CLI.

The top layer: imports :mod:`adaptive_ff` and :mod:`plant`.
"""

from controllers.simulation.batch import BATCH_MODES, BatchResult, run_batch
from controllers.peers.canudas import CanudasCompensator
from controllers.peers.dob import DisturbanceObserver
from controllers.testing import TrackingBoundError, assert_tracking_bound, velocity_faults
from controllers.simulation.closed_loop import (ENGINES, ESTIMATORS, MODES, ClosedLoopResult, LoopMetrics, kernel_supported,
                                      loop_metrics, run_closed_loop)
from controllers.experiments.compare import FIXED_METHODS, Comparison, compare, eta, friction_scale, prefit_stribeck
from controllers.report.figures import plot_comparison
from controllers.design.loop_analysis import LoopAnalysis, analyse_design
from controllers.experiments.paper_figures import identification_figures, paper_figures
from controllers.report.html import compare_report, identify_report, report_html, write_report
from controllers.experiments.synthetic_logs import closed_loop_response, quasi_static_log
from controllers.design.pi import PIController, PIDesign, closed_loop_step, design_pi
from controllers.experiments.quasi_static import QuasiStaticData, bidirectional_velocities, quasi_static_runs

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
