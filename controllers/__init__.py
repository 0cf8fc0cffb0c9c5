"""Velocity control with friction compensation: PI design (python-control), closed-loop runner, comparison, CLI.

The top layer: imports :mod:`adaptive_ff` and :mod:`plant`.

The names below are imported lazily (PEP 562): ``import controllers`` is cheap,
and ``controllers.design_pi`` or ``from controllers import run_closed_loop``
imports the module that defines it (and python-control, numba, matplotlib as
that module needs them) on first use.
"""

from __future__ import annotations

import importlib
import sys
import types

#: module -> the public names this package re-exports from it
_EXPORTS = {
    "controllers.design.pi": ("PIController", "PIDesign", "closed_loop_step", "design_pi", "pi_step"),
    "controllers.design.loop_analysis": ("LoopAnalysis", "analyse_design"),
    "controllers.simulation.batch": ("BATCH_MODES", "BatchResult", "run_batch"),
    "controllers.simulation.closed_loop": ("ESTIMATORS", "MODES", "ModeOptions", "ClosedLoopResult", "LoopMetrics",
                                           "loop_metrics", "run_closed_loop", "run_mode"),
    "controllers.simulation.compensators": ("TrueFriction", "build_mode"),
    "controllers.peers.canudas": ("CanudasCompensator",),
    "controllers.peers.dob": ("DisturbanceObserver",),
    "controllers.peers.adaptive_dob": ("AdaptiveDOBCompensator",),
    "controllers.experiments.compare": ("FIXED_METHODS", "Comparison", "CompareOptions", "compare", "eta",
                                        "friction_scale", "prefit_stribeck"),
    "controllers.experiments.paper_figures": ("identification_figures", "paper_figures", "PaperFigureOptions"),
    "controllers.experiments.synthetic_logs": ("closed_loop_response", "quasi_static_log"),
    "controllers.experiments.quasi_static": ("QuasiStaticData", "bidirectional_velocities", "quasi_static_runs"),
    "controllers.report.figures": ("plot_comparison",),
    "controllers.report.html": ("compare_report", "identify_report", "report_html", "write_report"),
    "controllers.testing": ("TrackingBoundError", "assert_tracking_bound", "velocity_faults"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = [
    "PIDesign", "design_pi", "PIController", "closed_loop_step", "pi_step",
    "QuasiStaticData", "quasi_static_runs", "bidirectional_velocities",
    "MODES", "LoopMetrics", "ClosedLoopResult", "run_closed_loop", "loop_metrics", "ModeOptions", "run_mode",
    "TrueFriction", "build_mode",
    "Comparison", "CompareOptions", "compare", "eta", "plot_comparison",
    "LoopAnalysis", "analyse_design", "paper_figures", "identification_figures", "PaperFigureOptions",
    "report_html", "write_report", "identify_report", "compare_report",
    "quasi_static_log", "closed_loop_response",
    "ESTIMATORS", "FIXED_METHODS", "friction_scale", "prefit_stribeck",
    "BATCH_MODES", "BatchResult", "run_batch",
    "CanudasCompensator", "DisturbanceObserver", "AdaptiveDOBCompensator", "assert_tracking_bound",
    "TrackingBoundError", "velocity_faults",
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
