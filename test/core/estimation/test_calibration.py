"""Tests of calibration from normal presses, compliance and YAML storage."""

import os

import numpy as np
import pytest
from skin_driver.core.estimation.calibration import calibrate_from_shifts, Calibration
from skin_driver.core.estimation.calibration import compliance_from_presses
from skin_driver.core.estimation.forcecurve import ForceCurve


def test_mean_and_spread_of_normal_presses():
    shifts = [(1e-4, -2e-4), (3e-4, -2e-4), (2e-4, -2e-4)]
    cal = calibrate_from_shifts(shifts)
    assert (cal.x_p_m, cal.y_p_m) == pytest.approx((2e-4, -2e-4))
    assert cal.std_x_m == pytest.approx(np.std([1e-4, 3e-4, 2e-4]))
    assert cal.std_y_m == pytest.approx(0.0, abs=1e-18)
    assert cal.presses == 3


def test_no_presses_or_too_much_spread_are_refused():
    with pytest.raises(ValueError, match='no normal presses'):
        calibrate_from_shifts(np.zeros((0, 2)))
    with pytest.raises(ValueError, match='spread too much'):
        calibrate_from_shifts([(0.0, 0.0), (0.01, 0.0)], max_std_m=1e-3)
    with pytest.raises(ValueError, match='NaN or inf'):
        calibrate_from_shifts([(np.nan, 0.0)])
    with pytest.raises(ValueError, match='K x 2'):
        calibrate_from_shifts([1.0, 2.0, 3.0])


def test_compliance_fit():
    t = np.array([1.0, 2.0, 4.0])
    shifts = np.stack([7e-4 * t + 1e-4, np.full(3, -1e-4)], axis=1)
    assert compliance_from_presses(shifts, t, (1e-4, -1e-4)) == pytest.approx(7e-4)
    with pytest.raises(ValueError, match='all zero'):
        compliance_from_presses(shifts, np.zeros(3))


def test_yaml_round_trip_is_atomic(tmp_path):
    cal = Calibration(1e-4, -2e-4, 1e-5, 2e-5, 12, 7e-4)
    path = tmp_path / 'cal.yaml'
    path.write_text('old')
    cal.save_yaml(path)
    assert Calibration.load_yaml(path) == cal
    assert sorted(os.listdir(tmp_path)) == ['cal.yaml']


@pytest.mark.parametrize('text, message', [
    ('[1, 2]', 'mapping'),
    ('x_p_m: 0.0\n', 'missing fields'),
    ('{x_p_m: .nan, y_p_m: 0, std_x_m: 0, std_y_m: 0, presses: 1, compliance_m_per_n: 0}',
     'finite'),
    ('{x_p_m: 0, y_p_m: 0, std_x_m: -1, std_y_m: 0, presses: 1, compliance_m_per_n: 0}',
     'non-negative'),
    ('{x_p_m: a, y_p_m: 0, std_x_m: 0, std_y_m: 0, presses: 1, compliance_m_per_n: 0}',
     'must be a number'),
    ('x: [', 'not valid YAML'),
])
def test_yaml_validation(tmp_path, text, message):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        Calibration.load_yaml(path)


def test_version_2_round_trip_with_curves_and_gains_and_version_1_still_loads(tmp_path):
    curves = (ForceCurve((0.0, 500.0, 3000.0), (0.0, 0.5, 9.0)),
              ForceCurve((0.0, 800.0, 3500.0), (0.0, 0.7, 12.0)))
    gains = (np.full((2, 3), 1.1), np.full((2, 3), 0.9))
    cal = Calibration(1e-4, -2e-4, 1e-5, 2e-5, 12, 7e-4, force_curves=curves, gains=gains,
                      force_presses=16, compliance_presses=16, made_utc='2026-11-22T05:00:00Z')
    path = tmp_path / 'cal.yaml'
    cal.save_yaml(path)
    assert 'version: 2' in path.read_text()
    back = Calibration.load_yaml(path)
    assert back == cal
    np.testing.assert_array_equal(back.gain_maps()[0], gains[0])
    assert 'made 2026-11-22T05:00:00Z' in back.describe()
    old = tmp_path / 'v1.yaml'
    old.write_text('format: skin_driver/calibration\nversion: 1\nx_p_m: 0.0003\n'
                   'y_p_m: -0.0001\nstd_x_m: 0.0\nstd_y_m: 0.0\npresses: 5\n'
                   'compliance_m_per_n: 0.0\n')
    assert Calibration.load_yaml(old) == Calibration(x_p_m=0.0003, y_p_m=-0.0001, presses=5)
    old.write_text(old.read_text().replace('version: 1', 'version: 3'))
    with pytest.raises(ValueError, match='unsupported calibration version 3'):
        Calibration.load_yaml(old)
