"""Tests of the zero of the shift that follows the normal force (calibration.calibrate_zero)."""

import math

import numpy as np
import pytest

from skin_driver.core.estimation.calibration import calibrate_zero, Calibration


def test_zero_follows_the_normal_force_only_when_it_measurably_does():
    rng = np.random.default_rng(1)
    forces = np.linspace(5.0, 60.0, 16)
    sloped = np.stack((2e-4 + 1e-5 * forces, -1e-4 + 0.0 * forces), axis=1)
    cal = calibrate_zero(sloped + rng.normal(0.0, 2e-5, sloped.shape), forces, math.inf)
    assert cal.zero_slope_m_per_n[0] == pytest.approx(1e-5, rel=0.1)
    assert cal.zero_slope_m_per_n[1] == 0.0
    assert cal.zero_m(cal.zero_ref_n) == pytest.approx((cal.x_p_m, cal.y_p_m))
    assert cal.zero_m(60.0)[0] == pytest.approx(2e-4 + 6e-4, abs=5e-5)
    flat = calibrate_zero(rng.normal(0.0, 2e-5, (16, 2)), forces, math.inf)
    assert flat.zero_slope_m_per_n == (0.0, 0.0)


def test_zero_slope_survives_the_calibration_file(tmp_path):
    cal = Calibration(1e-4, 2e-4, presses=5, zero_slope_m_per_n=(1e-5, -3e-6), zero_ref_n=20.0)
    cal.save_yaml(tmp_path / 'c.yaml')
    again = Calibration.load_yaml(tmp_path / 'c.yaml')
    assert again.zero_slope_m_per_n == (1e-5, -3e-6) and again.zero_ref_n == 20.0
