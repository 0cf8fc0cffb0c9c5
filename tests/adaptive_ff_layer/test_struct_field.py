"""``struct_field``, the one accessor of the C-struct wrappers: read-only by default, settable with the C field
converted, and a field guarded by a ``has_*`` flag read as None while the flag is clear."""

from __future__ import annotations

import pytest

from adaptive_ff.compensation.gate import OutlierGate
from controllers.design.pi import PIController


def test_a_flagged_settable_field_reads_none_until_set_and_clears_its_flag_on_none():
    g = OutlierGate()
    assert g.last is None and g.cdata.has_last == 0
    g.last = 2.5
    assert g.last == 2.5 and g.cdata.has_last == 1 and g.cdata.last == 2.5
    assert g.check(2.6) and g.last == 2.6  # the C step sees the preloaded value
    g.last = None
    assert g.last is None and g.cdata.has_last == 0
    g.scale = 0.25
    assert g.scale == 0.25 and g.cdata.scale == 0.25


def test_a_settable_flag_field_stores_zero_or_one_and_a_read_only_one_refuses_a_write():
    pi = PIController(Kp=2.0, Ki=1.0, Tc=1e-3, u_max=1.0)
    pi.saturated = True
    assert pi.saturated is True and pi.cdata.saturated == 1
    pi.saturated = 0
    assert pi.saturated is False and pi.cdata.saturated == 0
    assert pi.Kp == 2.0 and type(pi.Kp) is float and "Proportional gain" in type(pi).Kp.__doc__
    with pytest.raises(AttributeError):
        pi.Kp = 3.0
    with pytest.raises(AttributeError):
        OutlierGate().n_rejected = 1
