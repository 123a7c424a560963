"""The heatmap's colour scale and orientation, as the rviz images use them."""

import math

import numpy as np
import pytest
from skin_driver.core.estimation.scan.heatmap import display_scale, top_down


def test_the_scale_reaches_the_strongest_taxel_of_either_map_and_never_falls_below_its_floor():
    light, heavy = np.full((2, 2), 0.1), np.array([[0.0, 3.0], [math.nan, math.inf]])
    assert display_scale(0.4, light) == 0.4  # idle or light: the floor
    assert display_scale(0.4, light, heavy) == 3.0  # a dead taxel (NaN, inf) sets no scale
    assert display_scale(0.4) == 0.4
    with pytest.raises(ValueError, match='floor must be > 0'):
        display_scale(0.0, light)


def test_top_down_puts_the_largest_y_in_row_0_and_keeps_x_left_to_right():
    grid = np.arange(6).reshape(2, 3)  # row r is y = r * pitch, column c is x = c * pitch
    assert top_down(grid).tolist() == [[3, 4, 5], [0, 1, 2]]
    assert top_down(grid).flags.c_contiguous
