"""A film's forward model of the taxels and presses of it, for the tests of the model fit."""

import math

import numpy as np

from skin_driver.core.estimation.model.taxelmodel import (
    DX, DY, LOG_ASPECT, LOG_FORCE, LOG_RADIUS, ORIENTATION, TaxelModel, X, Y)

FILM = TaxelModel(pitch_m=0.005, fill_factor=0.9, cover_spread_m=0.001, layer_spread_m=0.002,
                  film_scale=0.67, film_exponent=0.53, film_ceiling=3.3, film_activation_n=0.01)


def press(dx, dy, force=20.0, radius=0.8, aspect=1.0, orientation=0.0) -> np.ndarray:
    """Return the model's parameters of a press at (4.3, 5.1) taxels shifted by (dx, dy)."""
    u = np.zeros(8)
    u[X], u[Y], u[DX], u[DY] = 4.3, 5.1, dx, dy
    u[LOG_FORCE], u[LOG_RADIUS] = math.log(force), math.log(radius)
    u[LOG_ASPECT], u[ORIENTATION] = math.log(aspect), orientation
    return u


def noisy(counts) -> np.ndarray:
    """Return counts with the ADC's noise (seeded): the misfit then has a clear least."""
    return counts + np.random.default_rng(0).normal(0.0, 5.0, counts.shape)
