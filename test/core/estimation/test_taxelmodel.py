"""Tests of the forward model of the taxels: its film, its rendering and its fit of a contact."""

import math

import numpy as np
import pytest
from skin_driver.core.estimation.model.taxelmodel import (
    DX, DY, fit_contact, LOG_FORCE, LOG_RADIUS, render_counts, start_of, TaxelModel, X, Y)

MODEL = TaxelModel(pitch_m=0.005, fill_factor=0.9, cover_spread_m=0.001, layer_spread_m=0.002,
                   film_scale=0.67, film_exponent=0.53, film_ceiling=3.3, film_activation_n=0.01)
SHAPE = (12, 12)


def press(x=5.3, y=6.1, force=20.0, dx=0.4, dy=-0.7, radius=0.8):
    u = np.zeros(8)
    u[X], u[Y], u[LOG_FORCE], u[DX], u[DY], u[LOG_RADIUS] = x, y, math.log(force), dx, dy, \
        math.log(radius)
    return u


def test_the_film_is_open_below_its_activation_and_stops_at_its_resistance_floor():
    counts = MODEL.counts(np.array([0.0, 0.01, 0.02, 1.0, 1e4]))
    assert counts[0] == counts[1] == 0.0
    assert 0.0 < counts[2] < counts[3] < counts[4]
    assert counts[4] == pytest.approx(4095.0 * 3.3 / 4.3)


def test_a_layer_shifted_by_whole_taxels_without_a_layer_blur_is_the_top_moved():
    flat = TaxelModel(0.005, 0.9, 0.001, 0.0, 0.67, 0.53, 3.3)
    top, bottom = render_counts(flat, SHAPE, press(dx=2.0, dy=-1.0), 24)
    np.testing.assert_allclose(bottom[:-1, 2:], top[1:, :-2], atol=1e-9)
    assert top.sum() > 0


def test_a_press_at_a_taxel_centre_renders_symmetric_maps():
    top, bottom = render_counts(MODEL, SHAPE, press(x=5.0, y=6.0, dx=0.0, dy=0.0), 24)
    np.testing.assert_allclose(top[:, 3:8], top[:, 3:8][:, ::-1], atol=1e-9)
    np.testing.assert_allclose(bottom[4:9, :], bottom[4:9, :][::-1, :], atol=1e-9)


@pytest.mark.parametrize('dx, dy', [(0.5, 0.0), (0.25, -0.5), (1.3, 0.7)])
def test_the_fit_finds_a_sub_taxel_shift_where_pixel_locking_would_bias_it(dx, dy):
    # Hard case: half a taxel, where the imprint's sampling on cells biases a centroid most.
    truth = press(dx=dx, dy=dy)
    counts = render_counts(MODEL, SHAPE, truth, 24)
    force = counts / 100.0  # any map with the right centroid serves the start
    start = start_of(force, (dx + 0.3, dy - 0.3), MODEL)
    fit = fit_contact(MODEL, counts, None, start)
    assert fit.u[DX] == pytest.approx(dx, abs=0.01)
    assert fit.u[DY] == pytest.approx(dy, abs=0.01)
    assert fit.misfit < 1.0


def test_censored_taxels_count_only_where_the_model_reads_below_them():
    truth = press(force=200.0)
    counts = render_counts(MODEL, SHAPE, truth, 24)
    censored = counts >= 0.9 * counts.max()
    # The censored readings are lower bounds: cut them low, the fit must not follow.
    cut = np.where(censored, 0.9 * counts.max() - 50.0, counts)
    start = start_of(counts / 100.0, (0.7, -0.4), MODEL)
    fit = fit_contact(MODEL, cut, censored, start)
    assert fit.u[DX] == pytest.approx(0.4, abs=0.02)
    assert fit.u[DY] == pytest.approx(-0.7, abs=0.02)


def test_a_model_round_trips_through_its_mapping_and_rejects_what_no_skin_has():
    assert TaxelModel.from_dict(MODEL.to_dict()) == MODEL
    with pytest.raises(ValueError, match='fill_factor'):
        TaxelModel(0.005, 0.0, 0.001, 0.002, 0.67, 0.53, 3.3)
    with pytest.raises(ValueError, match='film_exponent'):
        TaxelModel(0.005, 0.9, 0.001, 0.002, 0.67, -0.5, 3.3)
    with pytest.raises(ValueError, match='unknown fields'):
        TaxelModel.from_dict({**MODEL.to_dict(), 'gain': 1.0})


def test_a_turn_on_film_reads_nothing_below_it_and_at_least_its_step_where_it_conducts():
    # A thick cover spreads the rims thin enough for the turn-on to open them.
    smooth = TaxelModel(0.005, 0.9, 0.003, 0.002, 0.67, 0.53, 3.3, 0.01)
    stepped = TaxelModel(0.005, 0.9, 0.003, 0.002, 0.67, 0.53, 3.3, 0.01, turn_on_pa=20000.0,
                         film_step=0.25)
    smooth_top, _ = render_counts(smooth, SHAPE, press(), 24)
    top, _ = render_counts(stepped, SHAPE, press(), 24)
    step = 4095.0 * 0.25 / 1.25
    assert ((top == 0) | (top >= step - 1e-9)).all()
    # The rims the smooth film reads faintly are open on the stepped one.
    assert ((smooth_top > 0) & (top == 0)).any()


def test_a_taxels_sensitivity_scales_its_load_before_the_film():
    # A smooth film's load is linear in the force: 1.25 times as sensitive everywhere reads as
    # a press of 1.25 times the force.
    even = np.full((2,) + SHAPE, 1.25)
    np.testing.assert_allclose(render_counts(MODEL, SHAPE, press(), 24, even),
                               render_counts(MODEL, SHAPE, press(force=25.0), 24), rtol=1e-12)


@pytest.mark.parametrize('dx, dy', [(0.5, 0.0), (0.25, -0.5), (1.3, 0.7)])
def test_the_fit_with_the_taxels_sensitivity_finds_the_shift_a_gain_pattern_would_bias(dx, dy):
    # Hard case: taxels 10 % apart in sensitivity (FSR films do), the calibrated gains given.
    pattern = np.random.default_rng(2).uniform(0.9, 1.1, (2,) + SHAPE)
    truth = press(dx=dx, dy=dy)
    counts = render_counts(MODEL, SHAPE, truth, 24, pattern)
    start = start_of(counts / 100.0, (dx + 0.3, dy - 0.3), MODEL)
    fit = fit_contact(MODEL, counts, None, start, sensitivity=pattern)
    assert fit.u[DX] == pytest.approx(dx, abs=1e-3)
    assert fit.u[DY] == pytest.approx(dy, abs=1e-3)
    # Without them the same fit is off by several thousandths of a taxel: the pattern's bias.
    blind = fit_contact(MODEL, counts, None, start)
    assert max(abs(blind.u[DX] - dx), abs(blind.u[DY] - dy)) > 3e-3
