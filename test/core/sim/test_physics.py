"""Tests of the simulation physics (FSR divider, pressure profile, shift, electronics)."""

import dataclasses
import math

import numpy as np
import pytest

from skin_driver.core.estimation.model.fsr import FsrModel
from skin_driver.core.sim.fsr import FsrFilm
from skin_driver.core.sim.physics import layer_shift_m, Press, render, render_force, \
    render_plate, SkinModel, taxel_spread


def test_fsr_round_trip_and_monotonic():
    fsr = FsrFilm()
    force = np.array([0.0, 0.05, 0.2, 1.0, 5.0, 10.0, 19.0])
    counts = fsr.force_to_counts(force)
    assert np.all(np.diff(counts) > 0)
    assert counts[0] == 0.0
    np.testing.assert_allclose(fsr.counts_to_force(counts), force, rtol=1e-9, atol=1e-12)


def test_fsr_resistance_range_matches_seed():
    fsr = FsrFilm()
    # R = r_max at force_at_r_max_n: counts = full * Rs / (Rs + r_max).
    expected = fsr.full_scale * 1000.0 / (1000.0 + 3500.0)
    assert fsr.force_to_counts(np.array([fsr.force_at_r_max_n + fsr.activation_n]))[0] == \
        pytest.approx(expected)
    assert fsr.resistance_ohm(np.array([0.0, fsr.activation_n]))[0] == np.inf
    assert fsr.force_to_counts(np.array([1e3]))[0] == pytest.approx(fsr.saturation_counts)
    assert fsr.counts_to_force(np.array([4095.0]))[0] == pytest.approx(
        fsr.force_at_r_min_n + fsr.activation_n)


def test_fsr_rejects_bad_parameters():
    with pytest.raises(ValueError, match='r_min_ohm < r_max_ohm'):
        FsrFilm(r_min_ohm=4000.0)
    with pytest.raises(ValueError, match='finite and positive'):
        FsrFilm(r_series_ohm=float('nan'))
    with pytest.raises(TypeError, match='FsrFilm'):
        SkinModel(fsr=FsrModel())


@pytest.mark.parametrize('film', [FsrFilm(), FsrFilm(r_series_ohm=2200.0, r_min_ohm=250.0,
                                                     force_at_r_max_n=0.3,
                                                     force_at_r_min_n=12.0)],
                         ids=['default', 'other'])
def test_the_drivers_assumed_film_is_the_true_one_when_told_its_numbers(film):
    """
    The simulator's film and the driver's assumed one share one law, written twice on purpose.

    The bench tells the estimator a skin's true film by its numbers, and the simulated skin's
    default film is the driver's default assumption; both need the two laws to agree.
    """
    assumed = FsrModel(**dataclasses.asdict(film))
    force = np.concatenate([[0.0, film.activation_n], np.geomspace(1e-3, 100.0, 200)])
    np.testing.assert_allclose(film.force_to_counts(force), assumed.force_to_counts(force),
                               rtol=1e-12, atol=1e-9)
    counts = np.linspace(0.0, film.full_scale, 400)
    np.testing.assert_allclose(film.counts_to_force(counts), assumed.counts_to_force(counts),
                               rtol=1e-12)
    assert dataclasses.asdict(FsrFilm()) == dataclasses.asdict(FsrModel())


def test_normal_force_is_conserved_in_the_interior():
    model = SkinModel(fill_factor=1.0, noise_counts=0.0)
    press = Press(0.0375, 0.0375, 10.0, math.radians(30), 0.0, 0.0025)
    top, bottom = render_force(model, [press])
    assert top.sum() == pytest.approx(10.0 * math.cos(math.radians(30)), rel=1e-3)
    assert bottom.sum() == pytest.approx(top.sum(), rel=1e-3)


def test_bottom_is_displaced_along_the_tangential_force():
    model = SkinModel(noise_counts=0.0)
    press = Press(0.0375, 0.0375, 10.0, math.radians(45), math.radians(90), 0.0025)
    sx, sy = layer_shift_m(model, press)
    assert sx == pytest.approx(0.0, abs=1e-12)
    assert sy == pytest.approx(7e-4 * 10 * math.sin(math.radians(45)))
    top, bottom = render_force(model, [press])
    rows = np.arange(model.rows)
    cy_top = (top.sum(axis=1) @ rows) / top.sum()
    cy_bottom = (bottom.sum(axis=1) @ rows) / bottom.sum()
    assert cy_bottom - cy_top == pytest.approx(sy / model.pitch_m, abs=0.1)


def test_defaults_are_plausible_for_the_seed_skin():
    model = SkinModel()
    assert (model.rows, model.cols, model.pitch_m) == (16, 16, 0.005)
    shift = layer_shift_m(model, Press(0.04, 0.04, 10.0, math.radians(45), 0.0))
    assert 0.7 < math.hypot(*shift) / model.pitch_m < 1.3
    top, _ = render(model, [Press(0.0375, 0.0375, 10.0)], np.random.default_rng(0))
    assert top.dtype == np.uint16
    assert top.max() < 0.9 * model.fsr.saturation_counts


def test_sub_taxel_motion_changes_the_map():
    model = SkinModel(noise_counts=0.0)
    a, _ = render_force(model, [Press(0.0375, 0.0375, 10.0)])
    b, _ = render_force(model, [Press(0.0385, 0.0375, 10.0)])
    assert not np.allclose(a, b)


def test_counts_clip_dead_taxels_and_crosstalk():
    rng = np.random.default_rng(1)
    model = SkinModel(dead_taxels=((7, 7), (1, 3, 4)), crosstalk=0.01, noise_counts=0.0)
    top, bottom = render(model, [Press(0.035, 0.035, 80.0, radius_m=0.004)], rng)
    assert top[7, 7] == 0 and bottom[7, 7] == 0
    assert bottom[3, 4] == 0 and top[3, 4] > 0
    assert top.max() <= 4095
    quiet, _ = render(SkinModel(noise_counts=0.0), [Press(0.035, 0.035, 80.0, radius_m=0.004)],
                      rng)
    assert top[7, 0] > quiet[7, 0]


def test_render_is_reproducible_and_noise_has_the_configured_spread():
    model = SkinModel(noise_counts=5.0, baseline_counts=100.0)
    a = render(model, [], np.random.default_rng(3))
    b = render(model, [], np.random.default_rng(3))
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert np.std(a[0].astype(float)) == pytest.approx(5.0, rel=0.25)


def test_press_validation():
    with pytest.raises(ValueError, match='alpha_rad'):
        Press(0.0, 0.0, 1.0, alpha_rad=2.0)
    with pytest.raises(ValueError, match='finite'):
        Press(float('nan'), 0.0, 1.0)
    with pytest.raises(ValueError, match='non-negative'):
        Press(0.0, 0.0, -1.0)


def test_a_plate_larger_than_the_skin_loads_it_as_on_a_larger_skin():
    # The pressure past the blur's reach off the skin is not evaluated (a plate renders in
    # time for every frame); what the skin feels is the same as where the skin goes on.
    small = SkinModel(noise_counts=0.0)
    large = SkinModel(rows=64, cols=64, noise_counts=0.0)
    offset = 24 * small.pitch_m  # the small skin sits at taxels 24..39 of the large one
    plate = Press(0.0375, 0.0375, 1200.0, 0.0, 0.0, 0.1)
    shifted = Press(0.0375 + offset, 0.0375 + offset, 1200.0, 0.0, 0.0, 0.1)
    for on_small, on_large in zip(render_force(small, [plate]), render_force(large, [shifted])):
        np.testing.assert_allclose(on_small, on_large[24:40, 24:40], rtol=1e-3)


def test_a_plate_loads_every_taxel_alike_and_a_film_reads_it_only_past_its_turn_on():
    rng = np.random.default_rng(0)
    even = SkinModel(noise_counts=0.0)
    top, bottom = render_plate(even, 2.0, rng)
    assert (top == top[0, 0]).all() and (bottom == top).all() and top[0, 0] > 1000
    # Taxels of different gains read it differently: the gain calibration's input.
    uneven = SkinModel(noise_counts=0.0, gain_spread=0.1, seed=3)
    top, _ = render_plate(uneven, 2.0, rng)
    sensitivity, _ = taxel_spread(uneven)
    assert np.corrcoef(top.ravel(), sensitivity[0].ravel())[0, 1] > 0.99
    # 2 N on a 4.5 mm pad is 99 kPa: a film that turns on at 150 kPa stays open.
    top, bottom = render_plate(SkinModel(noise_counts=0.0, turn_on_pa=1.5e5), 2.0, rng)
    assert (top == even.baseline_counts).all() and (bottom == even.baseline_counts).all()
