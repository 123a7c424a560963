"""Hard cases of the issue, each with its expected result."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.calibration.calibration import calibrate_from_shifts
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.physics import Press, render, SkinModel


def estimator(model, method='poc', spot=None, seed=0):
    """Return a tared estimator, calibrated with normal presses at ``spot`` when given."""
    rng = np.random.default_rng(seed)
    config = EstimatorConfig(method=method, pitch_m=model.pitch_m)
    est = ContactEstimator(config)
    frames = [render(model, [], rng) for _ in range(10)]
    est = est.with_tare(np.stack([t for t, _ in frames]), np.stack([b for _, b in frames]))
    if spot is not None:
        shifts = [est.measure_shifts(*render(model, [Press(*spot, 10.0)], rng))[0]
                  for _ in range(5)]
        est = ContactEstimator(config, calibrate_from_shifts(shifts), est.conditioning)
    return est, rng


def finite(contact):
    values = [contact.x_m, contact.y_m, contact.force_n, contact.area_m2, *contact.shift_m,
              contact.azimuth_rad, contact.alpha_rad, *contact.force_xyz_n, contact.confidence]
    return all(math.isfinite(v) for v in values)


def azimuth_error_deg(contact, beta_deg):
    return abs((math.degrees(contact.azimuth_rad) - beta_deg + 180) % 360 - 180)


def test_no_touch_gives_no_contact():
    est, rng = estimator(SkinModel())
    assert est.process(*render(SkinModel(), [], rng)) == []


def test_all_zero_maps_give_no_contact():
    est = ContactEstimator()
    zeros = np.zeros((16, 16), dtype=np.uint16)
    assert est.process(zeros, zeros) == []


def test_identical_maps_give_a_contact_without_direction():
    est = ContactEstimator()
    top, _ = render(SkinModel(noise_counts=0), [Press(0.04, 0.04, 10.0)], np.random.default_rng())
    contacts = est.process(top, top)
    assert len(contacts) == 1
    assert contacts[0].shift_m == pytest.approx((0.0, 0.0), abs=1e-9)
    assert not contacts[0].direction_valid and contacts[0].alpha_rad == 0.0


def test_alpha_zero_gives_no_direction_after_calibration():
    model = SkinModel()
    est, rng = estimator(model, spot=(0.04, 0.041))
    for _ in range(5):
        c = est.process(*render(model, [Press(0.04, 0.041, 10.0)], rng))[0]
        assert not c.direction_valid and c.alpha_rad == 0.0 and finite(c)


def test_saturated_plateau_still_gives_the_direction():
    model = SkinModel()
    est, rng = estimator(model, spot=(0.04, 0.04))
    press = Press(0.04, 0.04, 400.0, math.radians(1.2), math.radians(135), 0.008)
    top, bottom = render(model, [press], rng)
    assert (top >= model.fsr.saturation_counts - 30).sum() >= 4
    c = est.process(top, bottom)[0]
    assert c.direction_valid and finite(c)
    assert azimuth_error_deg(c, 135.0) < 10.0


def test_single_taxel_touch_is_located_on_that_taxel():
    top = np.zeros((16, 16), dtype=np.uint16)
    top[4, 11] = 2000
    c = ContactEstimator().process(top, top)
    assert len(c) == 1
    assert (c[0].x_m, c[0].y_m) == pytest.approx((11 * 0.005, 4 * 0.005))
    assert c[0].area_m2 == pytest.approx(0.005 ** 2)
    assert not c[0].direction_valid


def test_touch_at_the_border_gives_a_finite_roughly_right_direction():
    model = SkinModel()
    est, rng = estimator(model, spot=(0.0, 0.04))
    press = Press(0.0, 0.04, 10.0, math.radians(45), math.radians(90), 0.0025)
    c = est.process(*render(model, [press], rng))[0]
    assert finite(c) and c.direction_valid
    assert azimuth_error_deg(c, 90.0) < 10.0


def test_two_simultaneous_touches_give_two_contacts_with_their_own_directions():
    model = SkinModel()
    est, rng = estimator(model)
    presses = [Press(0.015, 0.015, 12.0, math.radians(45), 0.0, 0.0025),
               Press(0.06, 0.06, 8.0, math.radians(45), math.radians(180), 0.0025)]
    contacts = est.process(*render(model, presses, rng))
    assert len(contacts) == 2
    assert contacts[0].force_n > contacts[1].force_n
    assert contacts[0].x_m == pytest.approx(0.015, abs=0.002)
    assert azimuth_error_deg(contacts[0], 0.0) < 10.0
    assert azimuth_error_deg(contacts[1], 180.0) < 10.0


def test_shift_larger_than_half_the_grid_gives_no_direction():
    top = np.zeros((16, 16), dtype=np.uint16)
    bottom = np.zeros_like(top)
    top[2:4, 2:4] = 2000
    bottom[12:14, 12:14] = 2000
    contacts = ContactEstimator().process(top, bottom)
    assert len(contacts) == 1
    assert not contacts[0].direction_valid and finite(contacts[0])


def test_noise_only_gives_no_contact():
    est, rng = estimator(SkinModel())
    noisy = SkinModel(noise_counts=6.0)
    for _ in range(10):
        assert est.process(*render(noisy, [], rng)) == []


@pytest.mark.parametrize('dead', ['row', 'column'])
def test_dead_row_or_column_through_the_contact(dead):
    taxels = tuple((8, c) for c in range(16)) if dead == 'row' else \
        tuple((r, 8) for r in range(16))
    model = SkinModel(dead_taxels=taxels)
    est, rng = estimator(model, spot=(0.04, 0.04))
    press = Press(0.04, 0.04, 10.0, math.radians(45), math.radians(45), 0.003)
    contacts = est.process(*render(model, [press], rng))
    assert len(contacts) == 1
    assert contacts[0].direction_valid
    assert azimuth_error_deg(contacts[0], 45.0) < 10.0


@pytest.mark.parametrize('shape', [(12, 20), (64, 40), (128, 128)])
def test_non_square_and_larger_grids(shape):
    model = SkinModel(rows=shape[0], cols=shape[1])
    spot = (shape[1] * 0.005 * 0.4, shape[0] * 0.005 * 0.6)
    est, rng = estimator(model, spot=spot)
    press = Press(*spot, 10.0, math.radians(45), math.radians(300), 0.0025)
    contacts = est.process(*render(model, [press], rng))
    assert len(contacts) == 1
    assert azimuth_error_deg(contacts[0], 300.0) < 3.0


@pytest.mark.parametrize('top, message', [
    (np.full((16, 16), np.nan), 'NaN'),
    (np.full((16, 16), np.inf), 'inf'),
    (np.full((16, 16), -1.0), 'negative'),
    (np.zeros((16,)), '2-D'),
    (np.zeros((16, 16, 2)), '2-D'),
    (np.zeros((16, 15)), 'shapes differ'),
    (np.zeros((16, 16), dtype=bool), 'dtype'),
    (np.array([['a'] * 16] * 16), 'dtype'),
    (np.zeros((0, 16)), 'empty'),
])
def test_bad_input_raises_value_error_saying_what_is_wrong(top, message):
    with pytest.raises(ValueError, match=message):
        ContactEstimator().process(top, np.zeros((16, 16)))


def test_inputs_are_never_modified():
    model = SkinModel()
    est, rng = estimator(model)
    top, bottom = render(model, [Press(0.04, 0.04, 10.0, 0.5, 1.0)], rng)
    keep = top.copy(), bottom.copy()
    est.process(top, bottom)
    est.measure_shifts(top, bottom)
    assert np.array_equal(top, keep[0]) and np.array_equal(bottom, keep[1])


def test_a_press_without_bottom_load_next_to_one_with_it_has_no_direction():
    # Two presses on the top layer; the bottom layer carries only the first one's imprint, so
    # the mixture gives the second a vanishing share (1e-300 counts). Expected: two contacts,
    # the second without a direction, every value finite.
    top = np.zeros((16, 16), dtype=np.uint16)
    bottom = np.zeros_like(top)
    top[3:5, 3:5] = 2000
    top[12:14, 12:14] = 2000
    bottom[3:6, 4:7] = 1500
    contacts = ContactEstimator().process(top, bottom)
    assert len(contacts) == 2
    lone = min(contacts, key=lambda c: -c.x_m)
    assert not lone.direction_valid and all(finite(c) for c in contacts)
