"""Tests of the simulated contact: the Hertz pressure and how the taxels collect it."""

import math

import numpy as np
import pytest
from skin_driver.core.sim.contact import hertz_pressure, pad_sum, taxel_operator


@pytest.mark.parametrize('aspect, turn', [(1.0, 0.0), (0.5, 0.7)], ids=['round', 'ellipse'])
def test_the_hertz_pressure_integrates_to_two_thirds_of_its_ellipse(aspect, turn):
    h = 1e-5
    xs = np.arange(-0.004, 0.004, h) + h / 2
    shape = hertz_pressure(xs, xs, (0.0003, -0.0002), 0.002, aspect, turn)
    assert shape.max() == pytest.approx(1.0, abs=1e-3)
    assert shape.sum() * h * h == pytest.approx(2.0 / 3.0 * math.pi * 0.002 ** 2 * aspect,
                                                rel=1e-3)


def test_a_pad_takes_the_share_of_each_fine_sample_it_covers():
    # Four samples a taxel, a pad of 0.6: the middle two whole, the outer two a fifth each.
    np.testing.assert_allclose(pad_sum(2, 4, 0.6),
                               [[0.2, 1, 1, 0.2, 0, 0, 0, 0], [0, 0, 0, 0, 0.2, 1, 1, 0.2]])


def test_the_axis_operators_equal_blurring_the_image_and_summing_each_pad():
    # The blur is a 2-D Gaussian cut past four sigma, load past the skin's ends lost.
    cells, sub, fill, sigma = 5, 6, 0.8, 2.5
    fine = np.random.default_rng(1).uniform(0.0, 1.0, (cells * sub, cells * sub))
    reach = (int(round(8 * sigma + 1)) | 1) // 2
    taps = np.exp(-0.5 * (np.arange(-reach, reach + 1) / sigma) ** 2)
    taps /= taps.sum()
    along = np.apply_along_axis(np.convolve, 0, fine, taps, 'same')
    blurred = np.apply_along_axis(np.convolve, 1, along, taps, 'same')
    pads = pad_sum(cells, sub, fill)
    op = taxel_operator(cells, sub, fill, sigma)
    np.testing.assert_allclose(op @ fine @ op.T, pads @ blurred @ pads.T, rtol=1e-12)
