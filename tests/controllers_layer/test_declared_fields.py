"""The fields a component declares with plant.component.struct_field's matrix, scale and choice forms read the C
struct: RecursiveIV.P (a (p, p) view), FeedforwardSupervisor.t_off/t_rest (steps times Tc), Sensor.velocity and
Sensor.gain (a name of the C flag; the Kalman gain, None for the difference)."""

import numpy as np
import pytest

from adaptive_ff.compensation.ivrls import RecursiveIV
from adaptive_ff.compensation.supervisor import FeedforwardSupervisor
from controllers.simulation.sensor_drive import Sensor


def test_ivrls_P_is_a_square_view_of_the_struct():
    r = RecursiveIV(3, P0=100.0)
    P = r.P
    assert P.shape == (3, 3)
    np.testing.assert_array_equal(P, 100.0 * np.eye(3))  # P0 * I, the struct's first p*p entries row-major
    P[0, 1] = 7.0
    assert r.P[0, 1] == 7.0 and np.shares_memory(P, r.P)
    with pytest.raises(AttributeError):
        r.P = np.eye(3)


def test_supervisor_times_are_steps_times_Tc():
    s = FeedforwardSupervisor(Tc=2e-3, J_n=1.0, omega=50.0)
    c = s.cdata
    c.n_off, c.n_rest = 250, 7
    assert s.t_off == 250 * 2e-3 and s.t_rest == 7 * 2e-3  # exact: one product of the two C values
    with pytest.raises(AttributeError):
        s.t_off = 1.0


def test_sensor_velocity_and_gain():
    d = Sensor(Tc=1e-3)
    assert d.velocity == "difference" and d.gain is None
    k = Sensor(Tc=1e-3, counts_per_rev=4096, velocity="kalman")
    assert k.velocity == "kalman"
    np.testing.assert_array_equal(k.gain, np.asarray(k.filter.K, dtype=float))  # the gain set into the struct
    g = k.gain
    g[0] = 0.0
    assert k.gain[0] == k.filter.K[0]  # a copy
