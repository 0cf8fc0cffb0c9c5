"""The rows choice of :func:`adaptive_ff.arm.fit.identify_arm` (its ``rows``, ``identify-arm --rows``): the names,
the default and the sliding rows' rest window, in a module that imports nothing, so that the command line's help
reads them without loading the fit (the module docstring of :mod:`adaptive_ff.arm.fit` gives the method)."""

__all__ = ["ROWS", "DEFAULT_ROWS", "REST_WINDOW"]

#: The rows of :func:`adaptive_ff.arm.fit.identify_arm`: ``"moving"`` (the default) the filtered velocity's own,
#: each holding the share of the samples where the joint moves alone; ``"sliding"`` those where the joint slides.
ROWS = ("moving", "sliding")
#: ``identify_arm``'s ``rows`` unless given: the rows with which every joint of the planar example arm keeps its
#: Stribeck term (``compare-arm`` and ``export-c`` need each joint's ``Vs``), a 10 ms lag is read inside its
#: intervals and the TX40's ``Fc`` agrees with its reference; the intervals of both are calibrated on simulated
#: arms (``docs/your_arm.md``, "Rows", "Intervals").
DEFAULT_ROWS = "moving"
#: Rows (``rows="sliding"``) within this many cutoff periods of where a joint sticks or reverses are left out: the
#: forward-backward 4th-order Butterworth carries 2 % of a torque step one period from it, 0.5 % at 1.5 periods.
REST_WINDOW = 1.5
