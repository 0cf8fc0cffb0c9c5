"""The supervisor's tracking test (aff_supervisor.c, FeedforwardSupervisorConfig(Kp=, Ki=)).

Its statistics against a state-space computation written from the loop's equations (scipy's dlsim), a candidate
that the torque test keeps but that raises the loop's velocity error backed off, and a good compensator kept.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import dlsim, lfilter

from adaptive_ff.compensation.supervisor import FeedforwardSupervisor, FeedforwardSupervisorConfig
from plant.errors import ParameterError



def _supervisor(Tc, J_n, omega, **settings):
    """A supervisor with the settings ``settings`` (fields of :class:`FeedforwardSupervisorConfig`)."""
    return FeedforwardSupervisor(Tc=Tc, J_n=J_n, omega=omega, config=FeedforwardSupervisorConfig(**settings))

def _loop_response(d, *, Kp, Ki, Tc, J_n):
    """The nominal loop's velocity after each period's torque d(k) enters (a PI on -y whose integrator is updated
    first, then J_n*dy/dt over Tc), as a state-space system x = (y, I): y' = (1 - Tc/J_n*(Kp + Ki*Tc))*y +
    Tc/J_n*I + Tc/J_n*d, I' = I - Ki*Tc*y; the output is the state after the step, C*(A x + B d)."""
    g = Tc / J_n
    A = np.array([[1.0 - g * (Kp + Ki * Tc), g], [-Ki * Tc, 1.0]])
    B = np.array([[g], [0.0]])
    C = np.array([[1.0, 0.0]])
    _, y, _ = dlsim((A, B, C @ A, C @ B, 1.0), np.asarray(d, dtype=float))
    return y[:, 0]


def _plant_samples(f, u, *, Tc, J_n):
    """Velocity samples of J_n*dw/dt = u - f with u, f held over each period (the supervisor's disturbance sample is
    then f exactly)."""
    w = np.zeros(u.shape[0])
    w[1:] = np.cumsum(Tc / J_n * (u[:-1] - f[:-1]))
    return w


def test_tracking_statistics_equal_a_state_space_computation():
    rng = np.random.default_rng(11)
    Tc, J_n, Kp, Ki, n = 1e-3, 0.8, 24.0, 180.0, 4000
    t = np.arange(n) * Tc
    f = 1.5 * np.sign(np.sin(2 * np.pi * 1.3 * t)) + rng.normal(0.0, 0.2, n)
    u_c = 0.8 * f + rng.normal(0.0, 0.1, n)
    u = u_c + rng.normal(0.0, 0.3, n)
    w = _plant_samples(f, u, Tc=Tc, J_n=J_n)
    kw = dict(Tc=Tc, J_n=J_n, omega=Kp / J_n, window=0.3, settle=0.1)
    s = _supervisor(**kw, Kp=Kp, Ki=Ki)
    e0, e1, m0, m1 = (np.empty(n) for _ in range(4))
    for k in range(n):
        s.apply(u_c[k])
        s.observe(u[k], w[k])
        e0[k], e1[k] = s.cdata.y_a, s.cdata.y_a - s.cdata.y_c
        m0[k], m1[k] = s.ms_error_none, s.ms_error_comp
    # independent: v(k) = f(k-1) from period 1 on (period 0 only starts the difference), the loop by dlsim
    v = np.concatenate([[0.0], f[:-1]])
    c = np.concatenate([[0.0], u_c[:-1]])
    want0 = np.concatenate([[0.0], _loop_response(v[1:], Kp=Kp, Ki=Ki, Tc=Tc, J_n=J_n)])
    want1 = want0 - np.concatenate([[0.0], _loop_response(c[1:], Kp=Kp, Ki=Ki, Tc=Tc, J_n=J_n)])
    np.testing.assert_allclose(e0, want0, rtol=0, atol=1e-12 * np.max(np.abs(want0)))
    np.testing.assert_allclose(e1, want1, rtol=0, atol=1e-12 * np.max(np.abs(want1)))
    b = 1.0 - math.exp(-Tc / kw["window"])
    n0 = math.ceil(5.0 / (kw["omega"] * Tc))
    for e, m in ((want0, m0), (want1, m1)):
        want = np.zeros(n)
        want[n0:] = lfilter([b], [1.0, -(1.0 - b)], e[n0:] ** 2)
        np.testing.assert_allclose(m, want, rtol=1e-9, atol=1e-15)
    assert m1[-1] < 0.2 * m0[-1]  # a candidate of 0.8 times the friction leaves a fifth of its error or less


def test_a_candidate_that_raises_the_tracking_error_is_backed_off_where_the_torque_test_keeps_it():
    # friction: a large constant (which the loop's integrator rejects: no tracking error) and a ripple at the loop's
    # bandwidth; the candidate cancels the constant and triples the ripple. In torque, what it leaves (twice the
    # ripple) is smaller than the friction; in velocity error, twice the friction's.
    Tc, J_n, Kp, Ki, n = 1e-3, 0.5, 20.0, 100.0, 8000
    t = np.arange(n) * Tc
    wb = Kp / J_n
    ripple = 0.5 * np.sin(wb * t)
    f = 5.0 + ripple
    u_c = 5.0 + 3.0 * ripple
    w = _plant_samples(f, u_c, Tc=Tc, J_n=J_n)
    kw = dict(Tc=Tc, J_n=J_n, omega=wb, window=0.5, settle=0.5)
    torque_only = _supervisor(**kw)
    torque_only.run(u_c, u_c, w)
    assert torque_only.n_backoff == 0 and torque_only.on
    assert torque_only.ms_residual < 0.1 * torque_only.ms_friction
    both = _supervisor(**kw, Kp=Kp, Ki=Ki)
    got = both.run(u_c, u_c, w)
    assert both.n_backoff == 1 and both.n_backoff_tracking == 1 and not both.on
    assert both.ms_error_comp == pytest.approx(4.0 * both.ms_error_none, rel=0.05)
    # not before its first decision (n_start + settle), and within 2.5 s: the constant's transient through the
    # loop (the integrator rejects it with the time constant Kp/Ki = 0.2 s) weighs in the friction's mean square first
    k_off = int(np.argmax(~got["on"]))
    assert math.ceil(5.0 / (wb * Tc)) + round(kw["settle"] / Tc) <= k_off < 2500


def test_a_candidate_that_cancels_the_friction_is_kept_by_both_tests():
    Tc, J_n, Kp, Ki, n = 1e-3, 0.5, 20.0, 100.0, 8000
    t = np.arange(n) * Tc
    rng = np.random.default_rng(3)
    f = 2.0 * np.sign(np.sin(2 * np.pi * 0.7 * t)) + 0.3 * np.sin(Kp / J_n * t)
    u_c = f + rng.normal(0.0, 0.05, n)
    w = _plant_samples(f, u_c, Tc=Tc, J_n=J_n)
    s = FeedforwardSupervisor(Tc=Tc, J_n=J_n, omega=Kp / J_n,
                              config=FeedforwardSupervisorConfig(window=0.5, settle=0.5, Kp=Kp, Ki=Ki))
    got = s.run(u_c, u_c, w)
    assert got["on"].all() and s.n_backoff == 0
    assert s.ms_error_comp < 0.01 * s.ms_error_none


@pytest.mark.parametrize("kw, name", [(dict(Kp=-1.0), "Kp"), (dict(Kp=1.0, Ki=-1.0), "Ki"),
                                      (dict(Kp=math.inf), "Kp"), (dict(Kp=1.0, Ki=math.nan), "Ki")])
def test_bad_loop_gains_are_refused(kw, name):
    with pytest.raises(ParameterError, match=name):
        _supervisor(Tc=1e-3, J_n=1.0, omega=20.0, **kw)


def test_a_zero_Kp_is_no_tracking_test():
    """Kp 0 (the C default) is the sentinel of no tracking test, not an error."""
    s = _supervisor(Tc=1e-3, J_n=1.0, omega=20.0, Kp=0.0, Ki=5.0)
    assert not s.cdata.track
