"""Tests of the fit of a monotone counts-to-force curve to presses of known force."""

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.forcefit import fit_force_curve
from skin_driver.core.estimation.model.fsr import FsrModel

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
    assert fit.censored == 0 and fit.curve.censor_counts == 0
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
    with pytest.raises(ValueError, match='too few presses agree'):
        fit_force_curve(counts, gains, sensed[::-1], known[::-1])


def bumps(forces, skin, spread=1.2, size=9, fill=0.9):
    """Return (maps of counts, gain maps, sensed, known): Gaussian imprints of each force."""
    rows, cols = np.indices((size, size))
    shape = np.exp(-((rows - 4.3) ** 2 + (cols - 3.8) ** 2) / (2 * spread ** 2))
    shape /= shape.sum()
    forces = np.asarray(forces, dtype=np.float64)
    counts = []
    for f in forces:
        c = skin.force_to_counts(f * fill * fill * shape)
        counts.append(np.where(c > 40, c, 0.0))
    return counts, [np.ones((size, size))] * len(forces), forces * fill * fill, forces


def test_saturated_taxels_are_censored_and_the_rims_carry_the_force():
    # This film saturates at 3 N a taxel: the centre of every press above ~15 N reads its
    # ceiling, but the rims still grow with the force.
    soft = FsrModel(r_min_ohm=200.0, r_max_ohm=6000.0, force_at_r_max_n=0.1,
                    force_at_r_min_n=3.0)
    fit = fit_force_curve(*bumps(np.linspace(5.0, 60.0, 16), soft))
    assert fit.curve.censor_counts > 0 and fit.censored >= 8
    assert max(abs(r) / f for r, f in zip(fit.residuals_n, np.linspace(5.0, 60.0, 16))) < 0.05


def test_a_press_off_the_curve_is_left_out_by_name():
    """Issue #37: one press of a wrong known force no longer spoils the calibration."""
    counts, gains, sensed, known = bumps(np.linspace(5.0, 60.0, 16), SKIN)
    clean = fit_force_curve(counts, gains, sensed, known)
    known, sensed = known.copy(), sensed.copy()
    known[6] *= 3.0  # press 7: a known force typed wrong
    sensed[6] *= 3.0
    fit = fit_force_curve(counts, gains, sensed, known)
    assert fit.left_out == (6,)
    assert fit.fitted_n[6] < 0.5 * known[6]
    kept = [k for k in range(16) if k != 6]
    assert max(abs(fit.residuals_n[k]) / known[k] for k in kept) < 0.05
    grid = np.linspace(200.0, 3000.0, 15)
    np.testing.assert_allclose(fit.curve.counts_to_force(grid), clean.curve.counts_to_force(grid),
                               rtol=0.02)


def test_presses_judged_by_another_layer_are_left_out_and_no_other():
    counts, gains, sensed, known = bumps(np.linspace(5.0, 60.0, 16), SKIN)
    known, sensed = known.copy(), sensed.copy()
    known[6] *= 3.0
    sensed[6] *= 3.0
    # Told press 7 is wrong, the fit leaves it out without being asked to look for it.
    fit = fit_force_curve(counts, gains, sensed, known, left_out=(6,), may_leave_out=False)
    assert fit.left_out == (6,)
    assert max(abs(fit.residuals_n[k]) / known[k] for k in range(16) if k != 6) < 0.05
    # Not told, and not allowed to leave any out, the fit is refused naming the press.
    with pytest.raises(ValueError, match='press 7 of'):
        fit_force_curve(counts, gains, sensed, known, may_leave_out=False)


def test_several_presses_off_the_curve_are_left_out_while_most_agree():
    counts, gains, sensed, known = bumps(np.linspace(5.0, 60.0, 16), SKIN)
    known, sensed = known.copy(), sensed.copy()
    for k, factor in ((2, 2.5), (9, 0.3), (13, 3.0)):
        known[k] *= factor
        sensed[k] *= factor
    assert sorted(fit_force_curve(counts, gains, sensed, known).left_out) == [2, 9, 13]


def test_a_calibration_where_most_presses_disagree_is_refused():
    counts, gains, sensed, known = bumps(np.linspace(5.0, 60.0, 8), SKIN)
    rng = np.random.default_rng(0)
    factors = rng.choice([0.3, 3.0], size=8)
    with pytest.raises(ValueError, match='too few presses agree with one curve'):
        fit_force_curve(counts, gains, sensed * factors, known * factors)


def test_load_at_the_rims_that_no_taxel_reads_is_learned_per_imprint():
    counts, gains, sensed, known = bumps(np.linspace(5.0, 60.0, 16), SKIN)
    # The rim under the touch threshold (40 counts) is unread already; a film that turns on at
    # a pressure leaves more of every imprint's rim unread: here 0.5 N of sensed force more per
    # press (the imprints grow with the force, so a load per imprint is no load per taxel).
    plain = fit_force_curve(counts, gains, sensed, known)
    fit = fit_force_curve(counts, gains, sensed + 0.5, known + 0.5 / 0.81)
    assert plain.curve.rim_load_n > 0
    assert fit.curve.rim_load_n - plain.curve.rim_load_n == pytest.approx(0.5, rel=0.05)
    assert max(abs(r) / f for r, f in zip(fit.residuals_n, known)) < 0.01


def test_a_skin_whose_curve_matches_the_assumed_one_keeps_it():
    fit = fit_force_curve(*presses(np.linspace(5.0, 60.0, 16), skin=FsrModel()))
    # Over the counts pressed (past them the curve goes on straight).
    counts = np.linspace(50.0, fit.curve.counts[-1], 30)
    np.testing.assert_allclose(fit.curve.counts_to_force(counts),
                               FsrModel().counts_to_force(counts), rtol=0.01)
    assert fit.curve.rim_load_n == pytest.approx(0.0, abs=1e-3)


def test_taxels_clipped_at_full_scale_are_always_censored_and_read_the_highest_unclipped_count():
    # The ADC clipped the centre of the heavier presses (crosstalk on top of the film): the
    # conditioning puts those taxels at full scale. They are lower bounds: the fit censors
    # them whatever fits best, and the curve is flat from the highest count read below full
    # scale (the assumed law run on to full scale would give them hundreds of newtons).
    skin = FsrModel(r_min_ohm=150.0, r_max_ohm=6000.0, force_at_r_min_n=40.0)
    counts, gains, sensed, known = bumps(np.linspace(5.0, 60.0, 16), skin, spread=1.5)
    full = skin.full_scale
    cut = 0.8 * max(c.max() for c in counts)
    counts = [np.where(c >= cut, float(full), c) for c in counts]
    fit = fit_force_curve(counts, gains, sensed, known)
    highest = max(c[c < full].max() for c in counts)
    assert 0 < fit.curve.censor_counts < full and fit.censored >= 4
    # Flat past the knot after the highest uncut count (the knots are 1/128 of the range apart).
    assert fit.curve.counts_to_force(full) == pytest.approx(
        fit.curve.counts_to_force(highest + full / 128), abs=1e-12)
    assert fit.curve.counts_to_force(full) == pytest.approx(
        fit.curve.counts_to_force(highest), rel=0.02)
    assert max(abs(r) / f for r, f in zip(fit.residuals_n, known)) < 0.1
