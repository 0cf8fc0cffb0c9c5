"""Velocity control with friction compensation: PI design (python-control), closed-loop runner, comparison, CLI.

The top layer: imports :mod:`adaptive_ff` and :mod:`plant`.

The names below are imported lazily (``lazy_loader``, Scientific Python SPEC 1):
``import controllers`` is cheap, and ``controllers.design_pi`` or
``from controllers import run_closed_loop`` imports the module that defines it
(and python-control, matplotlib as that module needs them) on first use.
"""

import lazy_loader

__getattr__, __dir__, _ = lazy_loader.attach(__name__, submod_attrs={
    "design.pi": ["PIController", "PIDesign", "closed_loop_step", "design_pi", "pi_step"],
    "design.loop_analysis": ["LoopAnalysis", "analyse_design"],
    "simulation.batch": ["BATCH_MODES", "BatchResult", "run_batch"],
    "simulation.metrics": ["MotionMetrics", "motion_metrics"],
    "simulation.closed_loop": ["ESTIMATORS", "MODES", "LoopConfig", "ClosedLoopResult", "LoopMetrics",
                               "loop_metrics", "run_closed_loop", "run_mode", "run_own"],
    "simulation.user_compensator": ["CompensatorContext", "CompensatorError", "UserCompensator"],
    "simulation.compensators": ["TrueFriction", "build_mode"],
    "peers.canudas": ["CanudasCompensator"],
    "peers.dob": ["DisturbanceObserver"],
    "peers.adaptive_dob": ["AdaptiveDOBCompensator", "ResidualSwitchIn"],
    "experiments.compare": ["FIXED_METHODS", "CompareOptions", "compare", "friction_scale", "prefit_stribeck"],
    "experiments.comparison": ["Comparison", "eta"],
    "experiments.scenario": ["Scenario", "ScenarioError", "load_scenario"],
    "experiments.paper_figures": ["identification_figures", "paper_figures", "PaperFigureOptions"],
    "experiments.synthetic_logs": ["closed_loop_response", "quasi_static_log"],
    "experiments.quasi_static": ["QuasiStaticData", "bidirectional_velocities", "quasi_static_runs"],
    "report.figures": ["plot_comparison"],
    "report.html": ["ReportPage", "compare_report", "identify_report", "report_html", "write_report"],
    "testing": ["TrackingBoundError", "assert_tracking_bound", "velocity_faults"],
})

__all__ = [
    "PIDesign", "design_pi", "PIController", "closed_loop_step", "pi_step",
    "QuasiStaticData", "quasi_static_runs", "bidirectional_velocities",
    "MODES", "LoopMetrics", "MotionMetrics", "motion_metrics", "ClosedLoopResult", "run_closed_loop", "loop_metrics", "LoopConfig", "run_mode", "run_own",
    "CompensatorContext", "CompensatorError", "UserCompensator",
    "TrueFriction", "build_mode",
    "Comparison", "CompareOptions", "compare", "eta", "plot_comparison", "Scenario", "ScenarioError", "load_scenario",
    "LoopAnalysis", "analyse_design", "paper_figures", "identification_figures", "PaperFigureOptions",
    "ReportPage", "report_html", "write_report", "identify_report", "compare_report",
    "quasi_static_log", "closed_loop_response",
    "ESTIMATORS", "FIXED_METHODS", "friction_scale", "prefit_stribeck",
    "BATCH_MODES", "BatchResult", "run_batch",
    "CanudasCompensator", "DisturbanceObserver", "AdaptiveDOBCompensator", "ResidualSwitchIn", "assert_tracking_bound",
    "TrackingBoundError", "velocity_faults",
]
