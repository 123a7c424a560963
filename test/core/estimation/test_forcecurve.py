"""Tests of the stored counts-to-force curve: its checks, its reading and its file form."""

import pytest
from skin_driver.core.estimation.forcecurve import ForceCurve


def test_a_curve_must_rise_from_zero():
    with pytest.raises(ValueError, match='monotone'):
        ForceCurve((0.0, 100.0, 200.0), (0.0, 2.0, 1.0))
    with pytest.raises(ValueError, match='starts at 0'):
        ForceCurve((10.0, 100.0), (0.0, 2.0))
    curve = ForceCurve((0.0, 100.0), (0.0, 2.0))
    assert curve.counts_to_force([50.0, 200.0]).tolist() == [1.0, 4.0]  # the last slope goes on
    assert ForceCurve.from_dict(curve.to_dict()) == curve
    censored = ForceCurve((0.0, 100.0), (0.0, 2.0), 90.0, 1.5)
    assert ForceCurve.from_dict(censored.to_dict()) == censored
    with pytest.raises(ValueError, match='both'):
        ForceCurve((0.0, 100.0), (0.0, 2.0), 90.0, 0.0)
