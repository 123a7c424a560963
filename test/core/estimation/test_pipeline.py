"""Tests of the contact estimation pipeline."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.calibration import calibrate_from_shifts, Calibration
from skin_driver.core.estimation.calibration.taxellearn import film_start
from skin_driver.core.estimation.model.fsr import FsrModel
from skin_driver.core.estimation.model.taxelmodel import TaxelModel
from skin_driver.core.estimation.scan.pipeline import Contact, ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.shift.methods import resolve
from skin_driver.core.sim.physics import layer_shift_m, Press, render, SkinModel, taxel_spread


SPOT = (0.037, 0.038)


def make(model=None, method='poc', calibration=None, seed=0, calibrate=True):
    """Return a tared estimator calibrated with normal presses at SPOT, as the seed does."""
    model = model or SkinModel()
    rng = np.random.default_rng(seed)
    registered, reference = resolve(method)
    config = EstimatorConfig(method=registered, pitch_m=model.pitch_m)
    est = ContactEstimator(config, calibration, shift=reference)
    frames = [render(model, [], rng) for _ in range(10)]
    est = est.with_tare(np.stack([t for t, _ in frames]), np.stack([b for _, b in frames]))
    if calibrate and calibration is None:
        shifts = [est.measure_shifts(*render(model, [Press(*SPOT, 10.0)], rng))[0]
                  for _ in range(5)]
        est = est.with_calibration(calibrate_from_shifts(shifts))
    return est, model, rng


def test_tilted_press_gives_location_direction_alpha_and_force_vector():
    est, model, rng = make()
    press = Press(0.037, 0.038, 10.0, math.radians(45), math.radians(60), 0.0025)
    contacts = est.process(*render(model, [press], rng))
    assert len(contacts) == 1
    c = contacts[0]
    assert isinstance(c, Contact) and c.direction_valid
    assert (c.x_m, c.y_m) == pytest.approx((0.037, 0.038), abs=0.001)
    assert math.degrees(c.azimuth_rad) == pytest.approx(60.0, abs=2.0)
    assert math.degrees(c.alpha_rad) == pytest.approx(45.0, abs=2.0)
    fx, fy, fz = c.force_xyz_n
    assert fz == -c.force_n < 0
    assert math.atan2(fy, fx) == pytest.approx(c.azimuth_rad)


def test_normal_press_has_no_direction():
    est, model, rng = make()
    c = est.process(*render(model, [Press(0.037, 0.038, 10.0)], rng))[0]
    assert not c.direction_valid
    assert c.alpha_rad == 0.0 and c.azimuth_rad == 0.0
    assert c.force_xyz_n[:2] == (0.0, 0.0)


def test_calibration_offset_is_removed():
    model = SkinModel(misalignment_m=(0.002, 0.0))
    raw, model, rng = make(model, calibrate=False)
    shift = raw.measure_shifts(*render(model, [Press(*SPOT, 10.0)], rng))[0]
    assert shift[0] == pytest.approx(0.002, abs=5e-4)
    assert raw.process(*render(model, [Press(*SPOT, 10.0)], rng))[0].direction_valid
    est, _, _ = make(model, calibration=Calibration(shift[0], shift[1], 0, 0, 1))
    c = est.process(*render(model, [Press(*SPOT, 10.0)], rng))[0]
    assert not c.direction_valid


@pytest.mark.parametrize('method', ['seed', 'centroid', 'poc'])
def test_every_method_runs_through_the_pipeline(method):
    est, model, rng = make(method=method)
    press = Press(0.037, 0.038, 10.0, math.radians(45), math.radians(180), 0.0025)
    c = est.process(*render(model, [press], rng))[0]
    assert c.direction_valid
    assert abs((math.degrees(c.azimuth_rad) - 180 + 180) % 360 - 180) < 20


def test_config_validation():
    with pytest.raises(ValueError, match='unknown direction method'):
        EstimatorConfig(method='magic')
    with pytest.raises(ValueError, match='pitch_m must be positive'):
        EstimatorConfig(pitch_m=0.0)
    with pytest.raises(ValueError, match='min_confidence'):
        EstimatorConfig(min_confidence=2.0)


def test_normal_force_and_alpha_are_accurate():
    # The taxels sense fill_factor**2 of the area: without that the normal force reads ~19 % low
    # and alpha ~6 deg high at 10 N, 45 deg.
    est, model, rng = make()
    for beta in (0.0, 2.0):
        press = Press(0.037, 0.038, 10.0, math.radians(45), beta, 0.0025)
        c = est.process(*render(model, [press], rng))[0]
        assert c.force_n == pytest.approx(10.0 * math.cos(math.radians(45)), rel=0.05)
        assert math.degrees(c.alpha_rad) == pytest.approx(45.0, abs=2.0)
        assert math.hypot(*c.force_xyz_n) == pytest.approx(10.0, rel=0.05)


def test_new_config_fields_are_validated():
    with pytest.raises(ValueError, match='fill_factor'):
        EstimatorConfig(fill_factor=0.0)


def test_contacts_come_strongest_first_by_the_force_they_report():
    est, model, rng = make()
    presses = [Press(0.02, 0.025, 8.0, math.radians(40), 1.0, 0.003),
               Press(0.055, 0.05, 12.0, math.radians(30), -2.0, 0.0025),
               Press(0.02, 0.06, 10.0, math.radians(20), 2.5, 0.004)]
    contacts = est.process(*render(model, presses, rng))
    assert len(contacts) == 3 and all(c.direction_valid for c in contacts)
    forces = [c.force_n for c in contacts]
    assert forces == sorted(forces, reverse=True)


def test_a_shift_within_its_noise_has_no_direction():
    # A 1 N press tilted by 5 deg shifts the layers by 0.01 taxel: below three sigmas of its own
    # noise. Expected: a contact without direction whose sigma says so (pi).
    est, model, rng = make(SkinModel(noise_counts=8.0))
    c = est.process(*render(model, [Press(0.037, 0.038, 1.0, math.radians(5), 0.5)], rng))[0]
    assert not c.direction_valid and c.azimuth_sigma_rad == math.pi
    strong = Press(0.037, 0.038, 12.0, math.radians(45), 0.5)
    c = est.process(*render(model, [strong], rng))[0]
    assert c.direction_valid and 0.0 < c.azimuth_sigma_rad < math.radians(10)


def test_reported_sigma_grows_as_the_shift_shrinks():
    est, model, rng = make()
    sigmas = []
    for alpha in (60, 40, 20):
        press = Press(0.037, 0.038, 10.0, math.radians(alpha), 1.0, 0.0025)
        sigmas.append(est.process(*render(model, [press], rng))[0].azimuth_sigma_rad)
    assert sigmas == sorted(sigmas)


def test_a_shift_of_five_taxels_keeps_its_direction():
    # A soft layer: 35 N at 45 deg shifts the layers by ~5 taxels; the bottom imprint no longer
    # touches the top one. Expected: one contact, direction within 2 deg.
    model = SkinModel(compliance_m_per_n=1.0e-3)
    est, model, rng = make(model)
    press = Press(0.03, 0.04, 35.0, math.radians(45), math.radians(30), 0.003)
    contacts = est.process(*render(model, [press], rng))
    assert len(contacts) == 1 and contacts[0].direction_valid
    assert math.degrees(contacts[0].azimuth_rad) == pytest.approx(30.0, abs=2.0)


def test_sigma_holds_the_spread_of_the_zero_however_many_presses_made_it():
    # The normal presses scattered by 0.1 taxel about the zero: a new press at another spot
    # meets that scatter, which a thousand presses do not average away. Expected: the sigma of
    # a zero scattered by 0.1 taxel is at least 0.1 taxel (azimuth sigma >= atan(0.1 / |s|)),
    # and larger than that of a zero without scatter, on the same frame.
    est, model, rng = make()
    frame = render(model, [Press(0.037, 0.038, 10.0, math.radians(45), 1.0, 0.0025)], rng)
    pitch = model.pitch_m
    sigmas = []
    for std in (0.0, 0.1 * pitch):
        cal = Calibration(std_x_m=std, std_y_m=std, presses=1000)
        c = est.with_calibration(cal).process(*frame)[0]
        assert c.direction_valid
        sigmas.append(c.azimuth_sigma_rad)
        shift_taxels = math.hypot(*c.shift_m) / pitch
    assert sigmas[1] > sigmas[0]
    assert sigmas[1] >= math.atan2(0.1, shift_taxels)


@pytest.mark.parametrize('press', [Press(0.0312, 0.0277, 25.0, 0.5, 2.0, radius_m=0.004),
                                   Press(0.041, 0.037, 15.0, 0.6, -1.0, radius_m=0.003)])
def test_the_model_fit_renders_each_taxel_with_its_calibrated_gain(press):
    # Taxels up to 10 % apart; the taxel model is the simulator's own skin, so what is left
    # once the gains are in the calibration is the fit's own error.
    skin = SkinModel(gain_spread=0.1, noise_counts=0.0, baseline_counts=0.0, seed=4)
    model = TaxelModel(skin.pitch_m, skin.fill_factor, skin.cover_spread_m, skin.spread_m,
                       *film_start(FsrModel()))
    sensitivity, _ = taxel_spread(skin)
    top, bottom = render(skin, [press], np.random.default_rng(0))
    truth = np.divide(layer_shift_m(skin, press), skin.pitch_m)
    errors = []
    for gains in (None, tuple(1.0 / sensitivity)):
        cal = Calibration(0.0, 0.0).updated(taxel_model=model, gains=gains)
        est = ContactEstimator(EstimatorConfig(method='model_fit')).with_calibration(cal)
        (contact,) = est.process(top, bottom)
        errors.append(np.abs(np.divide(contact.shift_m, skin.pitch_m) - truth).max())
    assert errors[1] < 1e-3 < 5e-3 < errors[0]


@pytest.mark.parametrize('method, model, expected', [
    ('taxel_fit', None, True),
    ('model_fit', None, True),      # nothing to fit with: it is taxel_fit
    ('model_fit', TaxelModel(0.005, 0.9, 0.001, 0.002, 0.67, 0.53, 3.3), False),
])
def test_only_a_fit_of_the_taxel_model_cannot_keep_up_with_every_scan(method, model, expected):
    est = ContactEstimator(EstimatorConfig(method=method), Calibration(taxel_model=model))
    assert est.every_scan is expected
