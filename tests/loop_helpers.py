"""Test helper: one named mode in the keyword style of the tests (settings -> LoopConfig -> run_mode)."""

from controllers.simulation.closed_loop import LoopConfig, run_mode


def run_named(p, reference, *, mode, rng=None, faults=None, **options):
    """``run_mode(p, reference, mode, LoopConfig.from_flat(**options), rng=rng, faults=faults)``."""
    return run_mode(p, reference, mode, LoopConfig.from_flat(**options), rng=rng, faults=faults)
