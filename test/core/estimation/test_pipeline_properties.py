"""Property-based tests over random blobs, shifts, noise and grid sizes."""

import math

from hypothesis import given, settings, strategies as st
import numpy as np

from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.sim.physics import Press, render, SkinModel

FAST = settings(max_examples=25, deadline=None)


@FAST
@given(rows=st.integers(6, 40), cols=st.integers(6, 40), fx=st.floats(0.2, 0.8),
       fy=st.floats(0.2, 0.8), force=st.floats(0.5, 60.0), alpha=st.floats(0.0, 1.3),
       beta=st.floats(-math.pi, math.pi), radius=st.floats(0.001, 0.006),
       noise=st.floats(0.0, 20.0), seed=st.integers(0, 2 ** 16))
def test_pipeline_output_is_always_finite_and_sane(
        rows, cols, fx, fy, force, alpha, beta, radius, noise, seed):
    model = SkinModel(rows=rows, cols=cols, noise_counts=noise)
    press = Press(fx * (cols - 1) * 0.005, fy * (rows - 1) * 0.005, force, alpha, beta, radius)
    top, bottom = render(model, [press], np.random.default_rng(seed))
    for c in ContactEstimator().process(top, bottom):
        values = [c.x_m, c.y_m, c.force_n, c.area_m2, *c.shift_m, c.azimuth_rad, c.alpha_rad,
                  *c.force_xyz_n, c.confidence]
        assert all(math.isfinite(v) for v in values)
        assert 0.0 <= c.confidence <= 1.0 and c.force_n > 0 and c.area_m2 > 0
        assert 0.0 <= c.alpha_rad < math.pi / 2
        assert c.force_xyz_n[2] == -c.force_n
