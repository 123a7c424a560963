"""
Tests of a scan's conditioning, read through the estimator and the kernel it builds.

Tare, touch threshold, dead-taxel fill, crosstalk removal, a clipped plateau levelled, counts to
force through the curves and gains, and bad input refused: each as the scans do it (the
kernel's conditioning is the only one; the calibration reads it from a kernel of its own).
"""

import math

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.gains import without_crosstalk
from skin_driver.core.estimation.calibration.session import crosstalk_share_of
from skin_driver.core.estimation.model.forcecurve import ForceCurve
from skin_driver.core.estimation.model.fsr import FsrModel
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.physics import Press, render, render_plate, SkinModel
from skin_driver.core.sim.skins import family_skin


def _tared(model=None, rng=None, frames=20, config=None):
    model = model or SkinModel()
    rng = rng or np.random.default_rng(0)
    rest = [render(model, [], rng) for _ in range(frames)]
    est = ContactEstimator(config).with_tare(np.stack([t for t, _ in rest]),
                                             np.stack([b for _, b in rest]))
    return est, model, rng


def _kernel(est, shape=(16, 16)):
    return est.conditioning_kernel(*shape)


def test_a_tare_zeroes_the_rest_reading():
    est, model, rng = _tared()
    top, bottom = render(model, [], rng)
    assert top.max() > 40  # the rest reading alone is over the untared touch threshold
    tf, bf = est.maps_of(top, bottom)
    assert not tf.any() and not bf.any()
    assert not _kernel(est).condition(top, bottom).counts.any()


def test_the_force_of_one_taxel_is_read_back_through_the_fsr_model():
    fsr = FsrModel()
    force = np.zeros((4, 4))
    force[1, 2] = 3.0
    counts = np.rint(fsr.force_to_counts(force)).astype(np.uint16)
    tf, _ = ContactEstimator().maps_of(counts, counts)
    assert tf[1, 2] == pytest.approx(3.0, rel=0.01)
    assert tf.sum() == pytest.approx(3.0, rel=0.01)


def test_a_press_reads_the_force_that_falls_on_the_taxels():
    est, model, rng = _tared()
    tf, _ = est.maps_of(*render(model, [Press(0.0375, 0.0375, 10.0)], rng))
    # The taxels cover fill_factor**2 of the area, so part of the force falls into the gaps.
    assert 0.6 * 10.0 < tf.sum() < 1.02 * 10.0


def test_the_touch_threshold_zeroes_smaller_readings():
    est = ContactEstimator(EstimatorConfig(threshold_counts=100.0))
    counts = np.array([[99, 101]], dtype=np.uint16)
    tf, _ = est.maps_of(counts, counts)
    assert tf[0, 0] == 0 and tf[0, 1] > 0


def test_counts_to_force_interpolates_the_fsr_model_at_every_count():
    counts = np.concatenate([[0.0, 0.25, 1.0, 1.5, 39.99, 40.0, 4094.0, 4094.5, 4095.0, 5000.0],
                             np.random.default_rng(3).uniform(0.0, 4095.0, 500)])
    kernel = _kernel(ContactEstimator(), (1, counts.size))
    fsr = FsrModel()
    grid = np.arange(fsr.full_scale + 1, dtype=np.float64)
    expected = np.interp(counts, grid, fsr.counts_to_force(grid))
    force = kernel.force(np.stack((counts, counts))[:, None, :])
    np.testing.assert_allclose(force[:, 0], [expected, expected], rtol=1e-12, atol=0.0)
    assert force[0, 0, 0] == 0.0  # untouched taxels are left at 0 N
    # Past full scale a reading is at the last force; a count below zero has none.
    assert force[0, 0, 9] == force[0, 0, 8]
    assert not kernel.force(np.full((2, 1, counts.size), -3.7)).any()


def test_fitted_curves_and_gains_convert_each_layer():
    # Straight curves: 2 N per 100 counts on the top layer, 1 N on the bottom; gains of 3 on
    # the top layer.
    curves = (ForceCurve(counts=(0.0, 4095.0), force_n=(0.0, 81.9)),
              ForceCurve(counts=(0.0, 4095.0), force_n=(0.0, 40.95)))
    gains = (np.full((3, 3), 3.0), np.ones((3, 3)))
    est = ContactEstimator(calibration=Calibration(force_curves=curves, gains=gains))
    counts = np.full((3, 3), 1000, dtype=np.uint16)
    top, bottom = est.maps_of(counts, counts)
    np.testing.assert_allclose(top, 60.0, rtol=1e-12)
    np.testing.assert_allclose(bottom, 10.0, rtol=1e-12)
    # Given tared counts, the kernel reads them the same way.
    np.testing.assert_allclose(est.conditioning_kernel(3, 3).force(np.full((2, 3, 3), 1000.0)),
                               np.stack((top, bottom)), rtol=1e-12)


def test_a_dead_taxel_found_by_the_tare_is_filled_from_its_live_neighbours():
    model = SkinModel(dead_taxels=((5, 5),))
    est, model, rng = _tared(model)
    dead_top, dead_bottom = est.dead_masks()
    assert dead_top[5, 5] and dead_bottom[5, 5] and dead_top.sum() == 1
    top, bottom = render(model, [Press(0.025, 0.025, 10.0, radius_m=0.004)], rng)
    counts = _kernel(est).condition(top, bottom).counts
    around = counts[0, 4:7, 4:7].copy()
    around[1, 1] = 0.0
    assert counts[0, 5, 5] > 0
    assert counts[0, 5, 5] == pytest.approx(around.sum() / 8, rel=1e-12)


def test_without_fill_dead_a_dead_taxel_reads_nothing_and_a_new_threshold_still_applies():
    # The estimator's one config conditions the scans: fill_dead off leaves the dead taxel at
    # 0 under the same press; a higher threshold_counts is applied to the tare kept.
    model = SkinModel(dead_taxels=((5, 5),))
    est, model, rng = _tared(model)
    plain = est.with_config(EstimatorConfig(fill_dead=False, threshold_counts=60.0))
    top, bottom = render(model, [Press(0.025, 0.025, 10.0, radius_m=0.004)], rng)
    counts = _kernel(plain).condition(top, bottom).counts
    assert counts[0, 5, 5] == 0.0 and counts[0, 4, 5] > 0
    assert plain.conditioning.state((16, 16)).threshold.min() == 60.0
    assert est.conditioning.state((16, 16)).threshold.min() == 40.0


def test_a_stuck_taxel_is_taken_for_dead():
    rng = np.random.default_rng(2)
    frames = rng.normal(50, 5, (10, 6, 6)).clip(0).astype(np.uint16)
    frames[:, 2, 3] = 700
    est = ContactEstimator().with_tare(frames, frames)
    assert est.dead_masks()[0][2, 3] and est.dead_masks()[0].sum() == 1


def test_bad_maps_are_refused_and_good_ones_left_as_they_were():
    est = ContactEstimator().with_tare(np.full((3, 4, 4), 20.0), np.full((3, 4, 4), 20.0))
    top = np.full((4, 4), 500.0)
    keep = top.copy()
    est.maps_of(top, top)
    np.testing.assert_array_equal(top, keep)
    with pytest.raises(ValueError, match='NaN'):
        est.maps_of(np.full((4, 4), np.nan), top)
    with pytest.raises(ValueError, match='shape'):
        est.maps_of(np.zeros((5, 4)), np.zeros((5, 4)))
    with pytest.raises(ValueError, match='negative'):
        est.maps_of(-top, top)
    kernel = _kernel(est, (4, 4))
    with pytest.raises(ValueError, match='negative'):
        kernel.condition(-top, top)
    with pytest.raises(ValueError, match='not a number'):
        kernel.force(np.full((2, 4, 4), np.nan))
    with pytest.raises(ValueError, match='shape'):
        kernel.force(np.zeros((4, 4)))


def test_a_heavy_press_on_a_fine_grid_leaves_no_line_of_crosstalk_and_its_clipped_plateau_level():
    # 128 x 128 taxels with 1.1 % crosstalk: a 50 N press leaks several hundred counts onto
    # every taxel of its rows and columns, about a third of its peak, and drives its centre to
    # the ADC's full scale. The crosstalk comes off (no stripe of loaded taxels across the map);
    # the clipped taxels keep a level shape, the layer's highest count, and read the force at
    # full scale (a lower bound, which a censoring force curve fills in).
    model = family_skin('held_out:2@128').model
    est, _, rng = _tared(model, np.random.default_rng(1), frames=5)
    kernel = _kernel(est, (128, 128))
    scan = kernel.condition(*render(model, [Press(0.04, 0.04, 50.0, radius_m=0.003)], rng))
    assert scan.clipped[1].sum() > 50
    rows, cols = np.nonzero(scan.counts[1])
    assert np.ptp(rows) < 40 and np.ptp(cols) < 40
    assert (scan.counts[1][scan.clipped[1]] == scan.counts[1].max()).all()
    full_scale = kernel.force(np.full(scan.counts.shape, float(model.fsr.full_scale)))
    np.testing.assert_array_equal(scan.force[scan.clipped], full_scale[scan.clipped])
    np.testing.assert_array_equal(kernel.force(scan.counts, scan.clipped), scan.force)
    assert not kernel.condition(*render(model, [], rng)).clipped.any()


def test_a_leak_under_the_touch_threshold_comes_off_the_loaded_taxels():
    # 0.6 % crosstalk lifts the lines through a press by 20-40 counts, under the 40-count
    # threshold but well over the noise: left on, it adds to every loaded taxel of those lines.
    plain, leaky = SkinModel(noise_counts=4.0), SkinModel(noise_counts=4.0, crosstalk=0.006)
    press = [Press(0.0412, 0.0388, 25.0, radius_m=0.004)]
    read = []
    for model in (plain, leaky):
        est, _, rng = _tared(model)
        read.append(sum(f.sum() for f in est.maps_of(*render(model, press, rng))))
    assert read[1] == pytest.approx(read[0], rel=0.02)


def test_before_a_tare_the_rest_reading_is_taken_for_no_crosstalk():
    # Untared, every taxel still reads its rest counts (about 20 on this skin, 2.5 times the
    # noise guessed before a tare) under the 40-count touch threshold: the leak gate stays
    # shut, and neither rest frames nor a press have their lines touched.
    model = family_skin('default').model
    rng = np.random.default_rng(0)
    frames = [render(model, [], rng) for _ in range(3)]
    frames.append(render(model, [Press(0.035, 0.04, 10.0, radius_m=0.004)], rng))
    kernel = _kernel(ContactEstimator())
    scans = [kernel.condition(top, bottom) for top, bottom in frames]
    assert not any(s.crosstalk.any() for s in scans)
    assert scans[-1].counts.any()
    np.testing.assert_array_equal(scans[-1].counts[1] > 0, frames[-1][1] >= 40)


def test_before_a_tare_a_leak_over_the_touch_threshold_still_comes_off():
    # 1.1 % crosstalk on a 64 x 64 grid: untared, a 50 N press lifts nearly every taxel over
    # the touch threshold (leak plus rest counts); the leak comes off and leaves the imprint.
    model = family_skin('held_out:2@64').model
    top, bottom = render(model, [Press(0.04, 0.04, 50.0, radius_m=0.003)],
                         np.random.default_rng(1))
    assert (bottom >= 40).sum() > 2000
    scan = _kernel(ContactEstimator(), (64, 64)).condition(top, bottom)
    rows, cols = np.nonzero(scan.counts[1])
    assert np.ptp(rows) < 20 and np.ptp(cols) < 20
    assert scan.crosstalk.max() > 0


def test_a_press_shows_the_matrix_leak_and_a_plate_is_cleared_of_it_once_it_is_known():
    # 1.2 % of a line's load leaks onto each of its taxels: a press shows it along its lines.
    leaky = SkinModel(noise_counts=4.0, crosstalk=0.012)
    est, _, rng = _tared(leaky)
    kernel = _kernel(est)
    press = kernel.condition(*render(leaky, [Press(0.0412, 0.0388, 25.0, radius_m=0.004)], rng))
    assert crosstalk_share_of(press.crosstalk) == pytest.approx(0.012, rel=0.1)
    # No press, no leak to see.
    assert math.isnan(crosstalk_share_of(kernel.condition(*render(leaky, [], rng)).crosstalk))
    # A plate loads whole lines: the per-scan clean-up leaves it alone (its medians are load),
    # and each taxel reads about a third more than its own load. With the leak known, what
    # is left is the taxel's own reading.
    quiet = SkinModel(noise_counts=0.0, crosstalk=0.012)
    est, _, rng = _tared(quiet, frames=2)
    plate = _kernel(est).condition(*render_plate(quiet, 1.0, rng))
    assert not plate.crosstalk.any()
    alone_est, _, rng = _tared(SkinModel(noise_counts=0.0), rng, frames=2)
    alone = _kernel(alone_est).condition(*render_plate(SkinModel(noise_counts=0.0), 1.0, rng))
    assert plate.counts.mean() > 1.3 * alone.counts.mean()
    np.testing.assert_allclose(without_crosstalk(plate.counts, 0.012), alone.counts, atol=1.0)
