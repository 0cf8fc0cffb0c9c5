"""Velocity control with friction compensation: PI design (python-control), closed-loop runner, comparison, CLI.

The top layer: imports :mod:`adaptive_ff` and :mod:`plant`.
"""

from controllers.closed_loop import MODES, ClosedLoopResult, LoopMetrics, loop_metrics, run_closed_loop
from controllers.compare import Comparison, compare, eta
from controllers.figures import plot_comparison
from controllers.pi import PIController, PIDesign, closed_loop_step, design_pi
from controllers.quasi_static import QuasiStaticData, bidirectional_velocities, quasi_static_runs

__all__ = [
    "PIDesign", "design_pi", "PIController", "closed_loop_step",
    "QuasiStaticData", "quasi_static_runs", "bidirectional_velocities",
    "MODES", "LoopMetrics", "ClosedLoopResult", "run_closed_loop", "loop_metrics",
    "Comparison", "compare", "eta", "plot_comparison",
]
