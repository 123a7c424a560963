"""Tests of counts-to-force conditioning: tare, threshold, gain, dead taxels."""

import numpy as np
import pytest
from skin_driver.core.estimation.model.fsr import FsrModel
from skin_driver.core.estimation.scan.conditioning import Conditioner, ConditioningConfig
from skin_driver.core.estimation.scan.crosstalk import without_leak
from skin_driver.core.sim.physics import Press, render, render_plate, SkinModel
from skin_driver.core.sim.skins import family_skin


def _tared(model=None, rng=None):
    model = model or SkinModel()
    rng = rng or np.random.default_rng(0)
    frames = [render(model, [], rng) for _ in range(20)]
    cond = Conditioner()
    cond.tare(np.stack([t for t, _ in frames]), np.stack([b for _, b in frames]))
    return cond, model, rng


def test_no_touch_gives_zero_force():
    cond, model, rng = _tared()
    top, bottom = render(model, [], rng)
    tf, bf = cond.condition(top, bottom)
    assert not tf.any() and not bf.any()


def test_force_recovered_through_the_fsr_model():
    fsr = FsrModel()
    force = np.zeros((4, 4))
    force[1, 2] = 3.0
    counts = np.rint(fsr.force_to_counts(force)).astype(np.uint16)
    tf, _ = Conditioner().condition(counts, counts)
    assert tf[1, 2] == pytest.approx(3.0, rel=0.01)
    assert tf.sum() == pytest.approx(3.0, rel=0.01)


def test_press_total_force_close_to_rendered():
    cond, model, rng = _tared()
    top, bottom = render(model, [Press(0.0375, 0.0375, 10.0)], rng)
    tf, _ = cond.condition(top, bottom)
    # The taxels cover fill_factor**2 of the area, so part of the force falls into the gaps.
    assert 0.6 * 10.0 < tf.sum() < 1.02 * 10.0


def test_gain_multiplies_force():
    counts = np.full((3, 3), 1000, dtype=np.uint16)
    cond = Conditioner()
    plain, _ = cond.condition(counts, counts)
    cond.set_gain(np.full((3, 3), 2.0), None)
    doubled, same = cond.condition(counts, counts)
    np.testing.assert_allclose(doubled, 2 * plain)
    np.testing.assert_allclose(same, plain)


def test_dead_taxel_found_by_tare_and_filled_from_neighbours():
    model = SkinModel(dead_taxels=((5, 5),))
    cond, model, rng = _tared(model)
    dead_top, dead_bottom = cond.dead_masks()
    assert dead_top[5, 5] and dead_bottom[5, 5] and dead_top.sum() == 1
    top, bottom = render(model, [Press(0.025, 0.025, 10.0, radius_m=0.004)], rng)
    tf, _ = cond.condition(top, bottom)
    assert tf[5, 5] > 0


def test_stuck_taxel_is_masked():
    rng = np.random.default_rng(2)
    frames = rng.normal(50, 5, (10, 6, 6)).clip(0).astype(np.uint16)
    frames[:, 2, 3] = 700
    cond = Conditioner()
    cond.tare(frames, frames)
    assert cond.dead_masks()[0][2, 3]


def test_threshold_zeroes_small_readings():
    cond = Conditioner(ConditioningConfig(threshold_counts=100.0))
    counts = np.array([[99, 101]], dtype=np.uint16)
    tf, _ = cond.condition(counts, counts)
    assert tf[0, 0] == 0 and tf[0, 1] > 0


def test_inputs_are_not_modified_and_errors_are_clear():
    cond = Conditioner()
    top = np.full((4, 4), 500.0)
    keep = top.copy()
    cond.condition(top, top)
    np.testing.assert_array_equal(top, keep)
    with pytest.raises(ValueError, match='NaN'):
        cond.condition(np.full((4, 4), np.nan), top)
    with pytest.raises(ValueError, match='shape'):
        cond.condition(np.zeros((5, 4)), np.zeros((5, 4)))
    with pytest.raises(ValueError, match='negative'):
        Conditioner().condition(-top, top)
    with pytest.raises(ValueError, match='boolean'):
        cond.set_dead(np.zeros((4, 4)), np.zeros((4, 4)))


def test_force_lookup_equals_interpolation_of_the_fsr_model_at_every_count_bit_for_bit():
    counts = np.concatenate([[0.0, 0.25, 1.0, 1.5, 39.99, 40.0, 4094.0, 4094.5, 4095.0, 5000.0],
                             np.random.default_rng(3).uniform(0.0, 4095.0, 500)])
    cond = Conditioner(shape=(1, counts.size))
    fsr = cond.config.fsr
    grid = np.arange(fsr.full_scale + 1, dtype=np.float64)
    expected = np.interp(counts, grid, fsr.counts_to_force(grid))
    force = cond.force_of(np.stack((counts, counts))[:, None, :])
    np.testing.assert_array_equal(force[0, 0], expected)
    np.testing.assert_array_equal(force[1, 0], expected)
    assert force[0, 0, 0] == 0.0  # untouched taxels are left at 0 N


def test_stacked_maps_match_the_pair_with_gain_and_dead_taxels():
    cond, model, rng = _tared()
    cond.set_gain(np.full((16, 16), 1.5), None)
    dead = np.zeros((16, 16), dtype=bool)
    dead[7, 8] = True
    cond.set_dead(dead, np.zeros((16, 16), dtype=bool))
    top, bottom = render(model, [Press(0.04, 0.04, 10.0)], rng)
    stacked = cond.force_of(cond.touch_counts(top, bottom))
    tf, bf = cond.condition(top, bottom)
    assert stacked.shape == (2, 16, 16)
    np.testing.assert_array_equal(stacked[0], tf)
    np.testing.assert_array_equal(stacked[1], bf)
    assert tf[7, 8] > 0  # the dead taxel is filled from its neighbours
    plain, _, _ = _tared()  # the same tare, no gain and no dead taxel
    raw_top = plain.condition(top, bottom)[0]
    loaded = raw_top > 0
    loaded[6:9, 7:10] = False
    assert loaded.any()
    np.testing.assert_array_equal(tf[loaded], 1.5 * raw_top[loaded])


def test_a_heavy_press_on_a_fine_grid_leaves_no_line_of_leak_and_its_cut_taxels_censored():
    # 128 x 128 taxels with 1.1 % crosstalk: a 50 N press leaks several hundred counts onto
    # every taxel of its rows and columns, about a third of its peak, and drives its centre to
    # the ADC's full scale. The leak comes off (no stripe of loaded taxels across the map);
    # the cut taxels keep a level shape, the layer's highest count, and read the force at full
    # scale (a lower bound, which a censoring force curve fills in).
    model = family_skin('held_out:2@128').model
    rng = np.random.default_rng(1)
    frames = [render(model, [], rng) for _ in range(5)]
    cond = Conditioner()
    cond.tare(np.stack([t for t, _ in frames]), np.stack([b for _, b in frames]))
    top, bottom = render(model, [Press(0.04, 0.04, 50.0, radius_m=0.003)], rng)
    counts = cond.touch_counts(top, bottom)
    clipped = cond.clipped(top, bottom)
    assert clipped[1].sum() > 50
    rows, cols = np.nonzero(counts[1])
    assert np.ptp(rows) < 40 and np.ptp(cols) < 40
    assert (counts[1][clipped[1]] == counts[1].max()).all()
    force = cond.force_of(counts, clipped)
    full_scale_force = cond.force_of(np.full(counts.shape, float(model.fsr.full_scale)))
    np.testing.assert_array_equal(force[clipped], full_scale_force[clipped])
    assert cond.clipped(*render(model, [], rng)) is None


def test_a_leak_under_the_touch_threshold_comes_off_the_loaded_taxels():
    # 0.6 % crosstalk lifts the lines through a press by 20-40 counts, under the 40-count
    # threshold but well over the noise: left on, it adds to every loaded taxel of those lines.
    plain, leaky = SkinModel(noise_counts=4.0), SkinModel(noise_counts=4.0, crosstalk=0.006)
    press = [Press(0.0412, 0.0388, 25.0, radius_m=0.004)]
    read = []
    for model in (plain, leaky):
        cond, _, rng = _tared(model)
        read.append(sum(f.sum() for f in cond.condition(*render(model, press, rng))))
    assert read[1] == pytest.approx(read[0], rel=0.02)


def test_before_a_tare_the_rest_reading_is_taken_for_no_line_leak():
    # Untared, every taxel still reads its rest counts (about 20 on this skin, 2.5 times the
    # noise guessed before a tare) under the 40-count touch threshold: the leak gate stays
    # shut, and rest frames and a press read the same with the leak removal on or off.
    model = family_skin('default').model
    rng = np.random.default_rng(0)
    frames = [render(model, [], rng) for _ in range(3)]
    frames.append(render(model, [Press(0.035, 0.04, 10.0, radius_m=0.004)], rng))
    on, off = Conditioner(), Conditioner(ConditioningConfig(remove_crosstalk=False))
    for top, bottom in frames:
        np.testing.assert_array_equal(on.touch_counts(top, bottom), off.touch_counts(top, bottom))
    assert on.touch_counts(*frames[-1]).any()


def test_before_a_tare_a_leak_over_the_touch_threshold_still_comes_off():
    # 1.1 % crosstalk on a 64 x 64 grid: untared, a 50 N press lifts nearly every taxel over
    # the touch threshold (leak plus rest counts); the leak comes off and leaves the imprint.
    model = family_skin('held_out:2@64').model
    top, bottom = render(model, [Press(0.04, 0.04, 50.0, radius_m=0.003)],
                         np.random.default_rng(1))
    off = Conditioner(ConditioningConfig(remove_crosstalk=False)).touch_counts(top, bottom)
    assert (off[1] > 0).sum() > 2000
    rows, cols = np.nonzero(Conditioner().touch_counts(top, bottom)[1])
    assert np.ptp(rows) < 20 and np.ptp(cols) < 20


def test_a_press_shows_the_matrix_leak_and_a_plate_is_cleared_of_it_once_it_is_known():
    # 1.2 % of a line's load leaks onto each of its taxels: a press shows it along its lines.
    leaky = SkinModel(noise_counts=4.0, crosstalk=0.012)
    cond, _, rng = _tared(leaky)
    share = cond.leak_share(*render(leaky, [Press(0.0412, 0.0388, 25.0, radius_m=0.004)], rng))
    assert share == pytest.approx(0.012, rel=0.1)
    # No press, no leak to see.
    assert np.isnan(cond.leak_share(*render(leaky, [], rng)))
    # A plate loads whole lines: the per-scan clean-up leaves it alone (its medians are load),
    # and each taxel reads about a third more than its own load. With the leak known, what
    # is left is the taxel's own reading.
    quiet = SkinModel(noise_counts=0.0, crosstalk=0.012)
    cond, _, rng = _tared(quiet)
    plate = cond.touch_counts(*render_plate(quiet, 1.0, rng))
    own = Conditioner()
    own.tare(*[np.stack([f] * 2) for f in render(SkinModel(noise_counts=0.0), [], rng)])
    alone = own.touch_counts(*render_plate(SkinModel(noise_counts=0.0), 1.0, rng))
    assert plate.mean() > 1.3 * alone.mean()
    np.testing.assert_allclose(without_leak(plate, 0.012), alone, atol=1.0)
