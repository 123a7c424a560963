"""Tests of the monotone counts-to-force curve fitted from presses of known force."""

import numpy as np
import pytest
from skin_driver.core.estimation.forcecurve import fit_force_curve, ForceCurve
from skin_driver.core.estimation.fsr import FsrModel

SKIN = FsrModel(r_min_ohm=150.0, r_max_ohm=6000.0, force_at_r_min_n=40.0)
SHARES = np.array([0.02, 0.05, 0.08, 0.12, 0.16, 0.14, 0.12, 0.1, 0.08, 0.06, 0.04, 0.03])


def presses(forces, skin=SKIN, fill=0.9):
    """Return (counts, gains, sensed, known) of presses spreading each force over 12 taxels."""
    forces = np.asarray(forces, dtype=np.float64)
    counts = [skin.force_to_counts(f * fill * fill * SHARES) for f in forces]
    return counts, [np.ones(SHARES.size)] * len(forces), forces * fill * fill, forces


def test_the_fit_recovers_another_skins_curve_over_the_range_pressed():
    fit = fit_force_curve(*presses(np.linspace(5.0, 60.0, 16)))
    assert max(abs(r) for r in fit.residuals_n) < 0.05 * 5.0
    # Where most of the force sits, between the peaks of a 15 N and the 60 N press, the curve
    # is the skin's own within 10 % (the presses pin sums over taxels, not single taxels).
    counts = np.linspace(SKIN.force_to_counts(15.0 * 0.81 * SHARES.max()),
                         SKIN.force_to_counts(60.0 * 0.81 * SHARES.max()), 20)
    np.testing.assert_allclose(fit.curve.counts_to_force(counts), SKIN.counts_to_force(counts),
                               rtol=0.10)
    assert fit.used == 16
    assert (np.diff(fit.curve.counts_to_force(np.arange(0, 4096, 7.0))) >= 0).all()


@pytest.mark.parametrize('forces, message', [
    (np.linspace(5.0, 60.0, 5), 'needs at least 6'),
    (np.linspace(10.0, 20.0, 16), 'span only 10.00 to 20.00 N'),
])
def test_too_few_presses_or_no_range_are_refused(forces, message):
    with pytest.raises(ValueError, match=message):
        fit_force_curve(*presses(forces))


def test_forces_that_fall_as_the_counts_rise_are_refused():
    counts, gains, sensed, known = presses(np.linspace(5.0, 60.0, 16))
    # The known forces given in the wrong order: no increasing curve fits them.
    with pytest.raises(ValueError, match='disagree'):
        fit_force_curve(counts, gains, sensed[::-1], known[::-1])


def test_presses_that_saturate_the_layer_are_left_out_of_the_curve():
    soft = FsrModel(force_at_r_min_n=5.0)
    fit = fit_force_curve(*presses(np.linspace(5.0, 60.0, 16), skin=soft))
    assert 6 <= fit.used < 16
    with pytest.raises(ValueError, match='saturates from'):
        fit_force_curve(*presses(np.linspace(20.0, 60.0, 16), skin=soft))


def test_a_curve_must_rise_from_zero():
    with pytest.raises(ValueError, match='monotone'):
        ForceCurve((0.0, 100.0, 200.0), (0.0, 2.0, 1.0))
    with pytest.raises(ValueError, match='starts at 0'):
        ForceCurve((10.0, 100.0), (0.0, 2.0))
    curve = ForceCurve((0.0, 100.0), (0.0, 2.0))
    assert curve.counts_to_force([50.0, 200.0]).tolist() == [1.0, 4.0]  # the last slope goes on
    assert ForceCurve.from_dict(curve.to_dict()) == curve
