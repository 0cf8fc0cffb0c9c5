"""
The main job's figures: a reversal, errors, Stribeck map, parameters, eta
=========================================================================

The main job (``adaptive-ff compare``: the ``paper`` preset, a robot base joint with lagged
Stribeck friction, eqs. 1-3 of the paper, 120 s in the PI velocity loop, seed 0) run in every
compensation mode, and the five figures the package draws of it
(:func:`controllers.report.figures.plot_comparison`, the same PNG files the command writes).
Friction hurts most where the velocity reverses: without compensation the joint sticks, then
breaks away late.

    python examples/plot_compare_modes.py                    # show the figures
    python examples/plot_compare_modes.py docs/_static       # write them (the README's reversal.png, compare_*.png)
"""

# %%
# Run every mode on one scenario (same reference, same noise): the settings of ``adaptive-ff compare``.
import shutil
import sys
from pathlib import Path

import matplotlib.pyplot as plt

from controllers import compare
from controllers.report import figures
from plant import preset

comp = compare(preset("paper"), progress=False)
print(comp.table())

# %%
# A reversal up close: the reference reversal of the metrics window (second half) with the largest
# error without compensation; reference, ``none``, ``fixed``, ``adaptive`` and ``frictionless``, and
# their tracking errors. Above it, the whole run.
tracking = figures.plot_tracking(comp)

# %%
# The tracking error of every mode as small multiples on one shared scale (min/max envelopes over
# display bins; Okabe-Ito colours, one per mode in every figure).
error = figures.plot_error(comp)

# %%
# The adaptive estimator's friction as a Stribeck map (torque over velocity) at a few times of the
# run, against the true steady-state curve.
friction = figures.plot_friction(comp)

# %%
# Every parameter of the adaptive estimator with its unit, the true value dashed (cf. the paper's
# Fig. 12).
convergence = figures.plot_rls_convergence(comp)

# %%
# The compensation efficiency ``eta = (RMS_none - RMS_mode) / (RMS_none - RMS_frictionless)`` and
# ``rms_dev``, the RMS of the velocity's deviation from the frictionless loop, per mode.
eta = figures.plot_eta(comp)

# %%
# With a directory argument the figures are written as the command writes them; the README shows
# ``reversal.png`` (the tracking figure).
if len(sys.argv) > 1:
    out = Path(sys.argv[1])
    for path in figures.plot_comparison(comp, out, dpi=80):
        target = out / ("reversal.png" if path.stem == "tracking" else f"compare_{path.name}")
        shutil.move(path, target)
        print(f"wrote {target}")
elif plt.get_backend().lower() != "agg":
    plt.show()
