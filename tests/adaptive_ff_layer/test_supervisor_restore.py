"""The supervisor switches a backed-off compensation back on only while the joint moves with the reference.

A friction feedforward evaluated at a joint that sticks at a reversal takes the sign of the sensor's noise; switched
on there, the bumpless transfer moves one noise-signed sample into the PI's integrator and the next period's flips
the command (a zoo joint of the linear axis scenario: 3 times `none`'s largest error). Here: the statistics clear
the restore while the joint is stuck; the restore waits until it moves in the reference's direction at half its
speed or more, and comes at once then.
"""

from __future__ import annotations

import numpy as np

from adaptive_ff.compensation.supervisor import FeedforwardSupervisor, FeedforwardSupervisorConfig



def _supervisor(Tc, J_n, omega, **settings):
    """A supervisor with the settings ``settings`` (fields of :class:`FeedforwardSupervisorConfig`)."""
    return FeedforwardSupervisor(Tc=Tc, J_n=J_n, omega=omega, config=FeedforwardSupervisorConfig(**settings))

def _log(Tc=1e-3, J_n=0.5):
    n = 6000
    t = np.arange(n) * Tc
    f = 2.0 + 0.5 * np.sin(2 * np.pi * 1.3 * t)                        # the disturbance
    w = np.interp(t, [0.0, 2.0, 2.05, 4.0, 4.2, 6.0], [1.0, 1.0, 0.0, 0.0, 1.0, 1.0])  # moving, stuck, moving
    u = np.empty(n)
    u[:-1] = J_n * np.diff(w) / Tc + f[1:]                                # J_n*dw/dt = u - f
    u[-1] = u[-2]
    u_c = np.where(t < 2.0, -2.0, 1.0) * np.roll(f, -1)                   # harmful, then the friction itself
    return t, u_c, u, w


def test_the_restore_waits_until_the_joint_moves_with_the_reference():
    Tc, J_n = 1e-3, 0.5
    t, u_c, u, w = _log(Tc, J_n)
    kw = dict(Tc=Tc, J_n=J_n, omega=40.0, window=0.2, margin=0.1, settle=0.05)
    blind = _supervisor(**kw).run(u_c, u, w)                   # no reference: "moving" throughout
    s = _supervisor(**kw)
    got = s.run(u_c, u, w, np.full(t.shape[0], 1.0))
    k_blind = int(np.argmax(blind["on"] & (t > 2.0)))
    k = int(np.argmax(got["on"] & (t > 2.0)))
    assert not blind["on"][(t > 1.0) & (t < 2.0)].any() and not got["on"][(t > 1.0) & (t < 2.0)].any()
    assert 2.05 < t[k_blind] < 3.0                     # the statistics alone clear it while the joint is stuck
    assert not got["on"][(t > 2.0) & (t < 4.0)].any()  # not while stuck
    # at once when the joint reaches half the reference's speed in its direction (w = 0.5 at t = 4.1 s)
    assert t[k] == np.min(t[(t > 4.0) & (w >= 0.5)])
    assert s.n_restore == 1 and s.on


def test_against_the_reference_it_stays_off():
    Tc, J_n = 1e-3, 0.5
    t, u_c, u, w = _log(Tc, J_n)
    s = FeedforwardSupervisor(Tc=Tc, J_n=J_n, omega=40.0,
                              config=FeedforwardSupervisorConfig(window=0.2, margin=0.1, settle=0.05))
    got = s.run(u_c, u, w, np.full(t.shape[0], -1.0))  # the joint moves against the reference
    assert s.n_backoff == 1 and s.n_restore == 0 and not got["on"][t > 1.0].any()
