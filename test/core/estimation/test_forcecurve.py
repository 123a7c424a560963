"""Tests of the stored counts-to-force curve: its checks, its reading and its file form."""

import pytest
from skin_driver.core.estimation.model.forcecurve import ForceCurve


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


def test_a_curve_keeps_its_activation_and_refuses_a_negative_one():
    # The activation, the force every conducting taxel carries, is no part of a saturated
    # imprint's bump (the kernel fills in with it: test_kernel); the file keeps it.
    curve = ForceCurve((0.0, 100.0), (0.0, 2.0), 90.0, 0.6, activation_n=0.1)
    assert ForceCurve.from_dict(curve.to_dict()) == curve
    with pytest.raises(ValueError, match='activation_n'):
        ForceCurve((0.0, 100.0), (0.0, 2.0), activation_n=-0.1)
