"""
Compensation modes at a velocity reversal
=========================================

The ``paper`` preset (a robot base joint with lagged Stribeck friction, eqs. 1-3 of the paper) in
the PI velocity loop, run without compensation, with the fixed (offline) and the adaptive friction
feedforward, and without friction (the limit). Friction hurts most where the velocity reverses:
the joint sticks, then breaks away late. The figure zooms into a reversal in the second half of the
run.

    python examples/plot_compare_modes.py                          # show the figure
    python examples/plot_compare_modes.py docs/_static/reversal.png  # the README's figure
"""

# %%
# Run every mode on one scenario (same reference, same noise), 30 s here.
import sys

import matplotlib.pyplot as plt
import numpy as np

from controllers import compare
from plant import preset

comp = compare(preset("paper"), duration=30.0, seed=0, modes=("none", "fixed", "adaptive", "frictionless"),
               progress=False)
print(comp.table())

# %%
# Zoom into a reversal of the reference in the second half of the run: 0.8 s either side.
ref = comp.results["none"]
crossings = np.flatnonzero(np.diff(np.sign(ref.w_ref)) != 0)
k = crossings[(ref.t[crossings] > 0.6 * ref.t[-1]) & (ref.t[crossings] < ref.t[-1] - 1.0)][0]
window = (ref.t > ref.t[k] - 0.8) & (ref.t < ref.t[k] + 0.8)

fig, ax = plt.subplots(figsize=(7.0, 3.6))
ax.plot(ref.t[window], np.rad2deg(ref.w_ref[window]), "k--", lw=1.2, label="reference")
for mode, style in (("none", "C3"), ("fixed", "C0"), ("adaptive", "C2"), ("frictionless", "0.5")):
    r = comp.results[mode]
    ax.plot(r.t[window], np.rad2deg(r.w[window]), color=style, lw=1.0, label=mode)
ax.set_xlabel("time [s]")
ax.set_ylabel("velocity [deg/s]")
ax.set_title("a velocity reversal, paper preset")
ax.legend(loc="best", fontsize=8)
fig.tight_layout()
if len(sys.argv) > 1:
    fig.savefig(sys.argv[1], dpi=110)
else:
    plt.show()
