"""Tests of the forward model of the taxels: its film and its rendering (its fit: test_kernel)."""

import math

import numpy as np
import pytest
from skin_driver.core.estimation.model.taxelmodel import (
    DX, DY, LOG_FORCE, LOG_RADIUS, render_counts, TaxelModel, X, Y)

MODEL = TaxelModel(pitch_m=0.005, fill_factor=0.9, cover_spread_m=0.001, layer_spread_m=0.002,
                   film_scale=0.67, film_exponent=0.53, film_ceiling=3.3, film_activation_n=0.01)
SHAPE = (12, 12)


def press(x=5.3, y=6.1, force=20.0, dx=0.4, dy=-0.7, radius=0.8):
    u = np.zeros(8)
    u[X], u[Y], u[LOG_FORCE], u[DX], u[DY], u[LOG_RADIUS] = x, y, math.log(force), dx, dy, \
        math.log(radius)
    return u


def test_the_film_is_open_below_its_activation_and_stops_at_its_resistance_floor():
    # A press lighter than one taxel's activation reads nothing; a crushing one reads the
    # resistance floor's counts at its centre; between them more force reads more.
    counts = [render_counts(MODEL, SHAPE, press(x=5.0, y=6.0, force=f), 24)[0]
              for f in (0.009, 2.0, 20.0, 1e7)]
    assert not counts[0].any()
    assert 0.0 < counts[1].max() < counts[2].max() < counts[3].max()
    assert counts[3][6, 5] == pytest.approx(4095.0 * 3.3 / 4.3)


def test_a_layer_shifted_by_whole_taxels_without_a_layer_blur_is_the_top_moved():
    flat = TaxelModel(0.005, 0.9, 0.001, 0.0, 0.67, 0.53, 3.3)
    top, bottom = render_counts(flat, SHAPE, press(dx=2.0, dy=-1.0), 24)
    np.testing.assert_allclose(bottom[:-1, 2:], top[1:, :-2], atol=1e-9)
    assert top.sum() > 0


def test_a_press_at_a_taxel_centre_renders_symmetric_maps():
    top, bottom = render_counts(MODEL, SHAPE, press(x=5.0, y=6.0, dx=0.0, dy=0.0), 24)
    np.testing.assert_allclose(top[:, 3:8], top[:, 3:8][:, ::-1], atol=1e-9)
    np.testing.assert_allclose(bottom[4:9, :], bottom[4:9, :][::-1, :], atol=1e-9)


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
