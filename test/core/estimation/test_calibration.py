"""Tests of calibration from normal presses, compliance and YAML storage."""

import os

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.calibration import calibrate_from_shifts, Calibration
from skin_driver.core.estimation.calibration.calibration import (CalibrationMismatch,
                                                                 compliance_from_presses)
from skin_driver.core.estimation.calibration.calibration import SkinIdentity, SkinMount
from skin_driver.core.estimation.calibration.creep import CreepFit
from skin_driver.core.estimation.calibration.direction import DirectionCorrection
from skin_driver.core.estimation.model.forcecurve import ForceCurve
from skin_driver.core.estimation.model.taxelmodel import TaxelModel
from skin_driver.core.estimation.scan.kernel import DIRECTION_FEATURES
import yaml

MODEL = TaxelModel(pitch_m=0.005, fill_factor=0.88, cover_spread_m=0.001, layer_spread_m=0.002,
                   film_scale=0.67, film_exponent=0.53, film_ceiling=3.3, film_activation_n=0.01,
                   presses=16, misfit_counts=2.3)


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


def test_round_trip_with_curves_gains_skin_and_part_times_and_older_versions_still_load(
        tmp_path):
    curves = (ForceCurve((0.0, 500.0, 3000.0), (0.0, 0.5, 9.0)),
              ForceCurve((0.0, 800.0, 3500.0), (0.0, 0.7, 12.0), 3300.0, 1.2))
    gains = (np.full((2, 3), 1.1), np.full((2, 3), 0.9))
    cal = Calibration(1e-4, -2e-4, 1e-5, 2e-5, 12, 7e-4, force_curves=curves, gains=gains,
                      force_presses=16, compliance_presses=16, made_utc='2026-11-22T05:00:00Z',
                      skin=SkinIdentity(2, 3, 0.005, 'left palm'),
                      part_utc=('2026-11-20T01:00:00Z', '2026-11-22T05:00:00Z', '', ''))
    path = tmp_path / 'cal.yaml'
    cal.save_yaml(path)
    assert 'version: 3' in path.read_text()
    back = Calibration.load_yaml(path, SkinIdentity(2, 3, 0.005, 'left palm'))
    assert back == cal
    assert back.made('offset') == '2026-11-20T01:00:00Z' and back.made('gains') == ''
    np.testing.assert_array_equal(back.gain_maps()[0], gains[0])
    assert 'made 2026-11-22T05:00:00Z' in back.describe()
    assert 'for 2 x 3 taxels at 5.000 mm pitch, board left palm' in back.describe()
    old = tmp_path / 'v1.yaml'
    old.write_text('format: skin_driver/calibration\nversion: 1\nx_p_m: 0.0003\n'
                   'y_p_m: -0.0001\nstd_x_m: 0.0\nstd_y_m: 0.0\npresses: 5\n'
                   'compliance_m_per_n: 0.0\n')
    # An old file names no skin: it loads on any.
    assert Calibration.load_yaml(old, SkinIdentity(16, 16, 0.005)) == Calibration(
        x_p_m=0.0003, y_p_m=-0.0001, presses=5)
    old.write_text(old.read_text().replace('version: 1', 'version: 4'))
    with pytest.raises(ValueError, match='unsupported calibration version 4'):
        Calibration.load_yaml(old)


def test_a_learned_taxel_model_is_kept_in_the_file_and_a_bad_one_refused(tmp_path):
    cal = Calibration(1e-4, -2e-4, presses=12).updated(taxel_model=MODEL)
    assert cal.made('force') and 'taxel model (16 presses)' in cal.describe()
    path = tmp_path / 'cal.yaml'
    cal.save_yaml(path)
    assert Calibration.load_yaml(path) == cal
    path.write_text(path.read_text().replace('fill_factor: 0.88', 'fill_factor: 1.5'))
    with pytest.raises(ValueError, match='cal.yaml: taxel model fill_factor must be in'):
        Calibration.load_yaml(path)


def test_the_matrix_crosstalk_is_kept_in_the_file_with_the_force_part(tmp_path):
    cal = Calibration().updated(crosstalk_share=0.012)
    assert cal.made('force') and not cal.made('gains')
    path = tmp_path / 'cal.yaml'
    cal.save_yaml(path)
    assert Calibration.load_yaml(path).crosstalk_share == 0.012
    with pytest.raises(ValueError, match='crosstalk_share'):
        Calibration(crosstalk_share=-0.01)
    # Hard case: a file written before the key was renamed (leak_share) keeps its share.
    path.write_text(path.read_text().replace('crosstalk_share:', 'leak_share:'))
    assert Calibration.load_yaml(path).crosstalk_share == 0.012


@pytest.mark.parametrize('skin, message', [
    (SkinIdentity(64, 64, 0.00125), 'made for 16 x 16 taxels at 5.000 mm pitch, board left '
                                    'palm, this skin is 64 x 64 taxels at 1.250 mm pitch'),
    (SkinIdentity(16, 16, 0.004), 'this skin is 16 x 16 taxels at 4.000 mm pitch'),
    (SkinIdentity(16, 16, 0.005, 'right palm'), 'board left palm, this skin is 16 x 16 '
                                                'taxels at 5.000 mm pitch, board right palm'),
])
def test_a_calibration_for_another_skin_is_refused_on_load(tmp_path, skin, message):
    path = tmp_path / 'cal.yaml'
    mine = SkinIdentity(16, 16, 0.005, 'left palm')
    Calibration(x_p_m=1e-4, presses=3, skin=mine).save_yaml(path)
    with pytest.raises(CalibrationMismatch, match=message):
        Calibration.load_yaml(path, skin)
    # The same grid and pitch with no board named is the same skin.
    assert Calibration.load_yaml(path, SkinIdentity(16, 16, 0.005)).x_p_m == 1e-4


def test_gains_of_another_grid_are_refused_even_without_a_skin():
    cal = Calibration(gains=(np.ones((2, 3)), np.ones((2, 3))))
    assert 'gains are 2 x 3' in cal.check_skin(SkinIdentity(16, 16, 0.005))


def test_an_update_stamps_only_the_parts_it_changes():
    cal = Calibration(part_utc=('a', 'b', 'c', 'd')).updated(compliance_m_per_n=1e-3)
    assert cal.part_utc[:2] == ('a', 'b') and cal.part_utc[3] == 'd'
    assert cal.made('compliance') == cal.made_utc != 'c'


def test_every_part_is_stamped_and_listed_with_its_date_direction_creep_and_mount_too(tmp_path):
    """Issue #47: after direction, creep and mount calibrations only [offset, force] showed."""
    direction = DirectionCorrection(True, 10.0, (0.0,) * DIRECTION_FEATURES,
                                    (0.0,) * DIRECTION_FEATURES, 12, 4, 9.0, 5.0)
    mount = SkinMount('base_link', (0.1, 0.0, 0.05), (0.0, 0.0, 0.0), 0.001, 6)
    cal = Calibration(x_p_m=1e-4, presses=8, part_utc=('2026-11-20T01:00:00Z',))
    cal = cal.updated(direction=direction).updated(creep=CreepFit(0.02, 0.5))
    cal = cal.updated(mount=mount)
    parts = dict(cal.parts_in_force())
    assert list(parts) == ['offset', 'direction', 'creep', 'mount']
    assert parts['offset'] == '2026-11-20T01:00:00Z'
    assert all(parts[p] for p in ('direction', 'creep', 'mount'))
    path = tmp_path / 'cal.yaml'
    cal.save_yaml(path)
    made = yaml.safe_load(path.read_text())['made']
    # Every part made, with its date; one never made names no key (an older reader's file).
    assert list(made) == ['offset', 'direction', 'creep', 'mount']
    assert made['mount'] == parts['mount'] and made['creep'] == parts['creep']
    assert Calibration.load_yaml(path) == cal


def test_a_part_in_a_file_that_gives_no_time_for_it_is_listed_with_its_own_or_none():
    mount = SkinMount('base_link', (0.1, 0.0, 0.05), (0.0, 0.0, 0.0), 0.001, 6,
                      '2026-11-21T00:00:00Z')
    # As an older file reads: the mount's own time, the compliance's unknown.
    cal = Calibration(compliance_m_per_n=1e-3, mount=mount)
    assert cal.parts_in_force() == (('compliance', ''), ('mount', ''))
    assert Calibration().parts_in_force() == ()
