"""The floor: the Cramér–Rao bound on beta of the simulator's own model."""

from dataclasses import replace
import math

import numpy as np
import pytest
from skin_driver.core.sim.physics import Press
from skin_driver.core.sim.skins import family_skin
from skin_lab.floor import beta_bounds, mean_bound_deg

TILTED = Press(0.0372, 0.0411, 10.0, math.radians(30.0), 0.7, 0.003)
NORMAL = Press(0.02, 0.02, 10.0, 0.0, 0.0, 0.003)


def test_the_bound_follows_the_noise_and_a_normal_press_has_none():
    model = family_skin('default').model
    (bound,) = beta_bounds(model, [TILTED])
    quiet = beta_bounds(replace(model, noise_counts=model.noise_counts / 2.0), [TILTED])[0]
    assert bound.stable and quiet.stable
    # sigma**2 is (noise**2 + 1/12) over the information: halving the noise about halves it.
    assert quiet.sigma_deg == pytest.approx(bound.sigma_deg / 2.0, rel=0.05)
    assert 0.0 < bound.sigma_deg < 1.0
    assert beta_bounds(model, [NORMAL, TILTED])[0] is None


def test_a_larger_tilt_is_easier():
    model = family_skin('default').model
    steep = replace(TILTED, alpha_rad=math.radians(60.0))
    assert beta_bounds(model, [steep])[0].sigma_deg < beta_bounds(model, [TILTED])[0].sigma_deg


def test_the_floor_of_frames_counts_the_tilted_presses():
    model = family_skin('default').model
    floor = mean_bound_deg(model, [[TILTED], [NORMAL], []])
    assert floor['presses'] == 1 and floor['stable_share'] == 1.0
    sigma = beta_bounds(model, [TILTED])[0].sigma_deg
    assert floor['mean_abs_error_deg'] == pytest.approx(math.sqrt(2 / math.pi) * sigma)
    assert mean_bound_deg(model, [[NORMAL]])['mean_abs_error_deg'] is None
    assert np.isfinite(floor['median_sigma_deg'])
