"""Tests of learning a skin's taxel model from presses of known force (simulated skins)."""

import math

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.taxellearn import (film_start, learn_taxel_model,
                                                                LearningPress)
from skin_driver.core.estimation.model.fsr import FsrModel
from skin_driver.core.estimation.model.taxelmodel import (
    DX, DY, LOG_FORCE, LOG_RADIUS, render_counts, X, Y)
from skin_driver.core.sim.fsr import FsrFilm
from skin_driver.core.sim.physics import layer_shift_m, Press, render_expected, SkinModel

FORCES = np.linspace(5.0, 45.0, 8)


def tared(counts):
    return np.where(counts > 40.0, counts, 0.0)  # the driver's touch threshold


def presses_on(skin, rng):
    places = rng.uniform(0.02, 0.055, (FORCES.size, 2))
    out = []
    for (x, y), f in zip(places, FORCES):
        counts = render_expected(skin, [Press(x, y, f, radius_m=0.004)])
        out.append(LearningPress(tared(counts), None, float(f), (0.0, 0.0)))
    return out


@pytest.mark.parametrize('skin', [
    # Hard cases: a sharp skin (narrow pads, little blur) and a soft, blurred one with another
    # film; the learning starts from the driver's assumed FSR on both.
    SkinModel(baseline_counts=0.0, noise_counts=0.0, spread_m=0.0006, cover_spread_m=0.0002,
              fill_factor=0.8),
    SkinModel(baseline_counts=0.0, noise_counts=0.0, spread_m=0.003, cover_spread_m=0.0015,
              fill_factor=0.85, fsr=FsrFilm(r_series_ohm=1000.0, r_min_ohm=250.0,
                                            r_max_ohm=3000.0, force_at_r_min_n=30.0)),
], ids=['sharp', 'soft_other_film'])
def test_the_skin_is_learned_from_its_presses_of_known_force(skin):
    radii = []
    learned = learn_taxel_model(presses_on(skin, np.random.default_rng(3)), skin.pitch_m,
                                film_start(FsrModel()), 4095.0, radii_out=radii)
    # each press's tip, fitted with the skin (the presses' 4 mm)
    assert np.array(radii) * skin.pitch_m == pytest.approx(np.full(FORCES.size, 0.004), rel=0.1)
    assert learned.layer_spread_m == pytest.approx(skin.spread_m, rel=0.03)
    assert learned.cover_spread_m == pytest.approx(skin.cover_spread_m, rel=0.1, abs=5e-5)
    # The pads' fill trades with the film's scale (both set how much of a load a taxel reads),
    # so what must be right is what the model renders: an unseen, tilted press, as the driver
    # reads it.
    unseen = Press(0.0312, 0.0277, 25.0, 0.5, 2.0, radius_m=0.004)
    u = np.zeros(8)
    u[X], u[Y] = unseen.x_m / skin.pitch_m, unseen.y_m / skin.pitch_m
    u[LOG_FORCE] = math.log(unseen.normal_force_n)
    u[LOG_RADIUS] = math.log(unseen.radius_m / skin.pitch_m)
    u[DX], u[DY] = np.divide(layer_shift_m(skin, unseen), skin.pitch_m)
    rendered = render_counts(learned, (skin.rows, skin.cols), u, 24)
    truth = tared(render_expected(skin, [unseen]))
    assert np.sqrt(np.mean((rendered - truth) ** 2)) < 4.0  # below the 6 counts of noise
    assert np.abs(rendered - truth).max() < 40.0
    assert learned.presses == FORCES.size
    assert learned.misfit_counts < 5.0


def test_presses_without_load_on_both_layers_teach_nothing():
    empty = LearningPress(np.zeros((2, 16, 16)), None, 10.0, (0.0, 0.0))
    with pytest.raises(ValueError, match='no press loaded both layers'):
        learn_taxel_model([empty], 0.005, film_start(FsrModel()), 4095.0)


def test_a_film_that_steps_on_at_a_turn_on_pressure_is_learned_with_its_step():
    # Hard case: a film open below 20 kPa whose resistance steps to 4 kOhm as it turns on, so
    # every imprint's rim is a cliff of ~800 counts; the smooth law cannot follow it.
    skin = SkinModel(baseline_counts=0.0, noise_counts=0.0, turn_on_pa=20000.0,
                     turn_on_ohm=4000.0)
    learned = learn_taxel_model(presses_on(skin, np.random.default_rng(5)), skin.pitch_m,
                                film_start(FsrModel()), 4095.0)
    assert learned.turn_on_pa == pytest.approx(20000.0, rel=0.15)
    assert learned.film_step == pytest.approx(1000.0 / 4000.0, rel=0.05)
    assert learned.layer_spread_m == pytest.approx(skin.spread_m, rel=0.05)
