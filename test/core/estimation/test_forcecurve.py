"""Tests of the stored counts-to-force curve: its checks, its reading and its file form."""

import numpy as np
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


def test_a_saturated_imprint_carries_the_activation_besides_its_bump():
    # Four rim taxels of 0.1 + 0.5 N around a saturated one that reads 0.6 N: the bump is
    # fitted to the 0.5 N above the activation, not to 0.6 N, and the saturated taxel carries
    # 0.1 N plus the bump's height. The activation is stored with the curve.
    curve = ForceCurve((0.0, 100.0), (0.0, 2.0), 90.0, 0.6, activation_n=0.1)
    assert ForceCurve.from_dict(curve.to_dict()) == curve
    counts = np.array([[0.0, 50.0, 0.0], [50.0, 95.0, 50.0], [0.0, 50.0, 0.0]])
    force = np.where(counts > 0, 0.6, 0.0)
    without = ForceCurve((0.0, 100.0), (0.0, 2.0), 90.0, 0.6).imprint_force(counts, force)
    with_activation = curve.imprint_force(counts, force)
    phi_rim = np.exp(-0.5 / 0.36)
    assert without == pytest.approx(2.4 + 0.6 / phi_rim)
    assert with_activation == pytest.approx(2.4 + 0.1 + 0.5 / phi_rim)
    with pytest.raises(ValueError, match='activation_n'):
        ForceCurve((0.0, 100.0), (0.0, 2.0), activation_n=-0.1)
