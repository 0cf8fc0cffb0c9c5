"""Roles and units of drive-log columns (standard library only, so the command line can list them cheaply).

Used by :func:`adaptive_ff.io.logs.load_log` (which re-exports these names) and by
the ``adaptive-ff`` data options (:mod:`controllers.cli.data`), whose ``--help``
must not import numpy or scipy.
"""

from __future__ import annotations

import math

__all__ = ["ROLES", "TIME_UNITS", "VELOCITY_UNITS", "POSITION_UNITS", "KALMAN_MODELS"]

#: Roles of the signals of a drive log and their meaning.
ROLES = {
    "t": "time stamps",
    "u": "input torque (motor current with current_to_torque)",
    "w": "velocity",
    "q": "position",
}

#: Time units and their factor to s.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: Velocity units and their factor to rad/s ("rad/s" is also the unit for m/s: no conversion).
VELOCITY_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0}
#: Position units and their factor to rad ("counts" needs counts_per_rev).
POSITION_UNITS = ("rad", "deg", "counts")
#: Kalman models for velocity from position (name: state dimension): constant velocity, constant acceleration.
KALMAN_MODELS = {"cv": 2, "ca": 3}
