"""Tests of the evaluator on the skin family: --skin, --params, --contacts, multi-press scoring."""

import csv
import json
import math

import numpy as np
import pytest
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.data.dataset import Dataset
from skin_driver.core.estimation.scan.pipeline import Contact, EstimatorConfig
from skin_driver.core.sim.skins import skin_names
from skin_driver.ros.estimator_params import estimator_config, load_direction_parameters
from skin_lab.evaluate import cli, scoring
import yaml

COLUMNS = ['frame', 'rank', 'x_m', 'y_m', 'force_n', 'azimuth_deg', 'alpha_deg',
           'direction_valid', 'confidence', 'shift_x_m', 'shift_y_m', 'azimuth_sigma_deg']


def test_skin_scene_json_and_contacts_csv(tmp_path, capsys):
    out = tmp_path / 'contacts.csv'
    argv = ['--skin', 'default', '--scene', 'multi', '--size', '10', '--json',
            '--contacts', str(out), '--method', 'centroid']
    assert cli.main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['dataset'].startswith('skin default, scene multi')
    assert report['multi_press_frames'] == 8  # one frame in five is a normal press
    presses = report['methods']['centroid']['presses']
    assert presses['frames'] == 8 and presses['presses'] >= 16
    for key in ('found_share', 'separate_share_far', 'merged_share_far', 'valid_share'):
        assert presses[key] is None or 0.0 <= presses[key] <= 1.0
    with open(out) as f:
        rows = list(csv.reader(f))
    assert rows[0] == COLUMNS and len(rows) > 10
    frames = [int(r[0]) for r in rows[1:]]
    assert frames == sorted(frames) and 0 <= min(frames) and max(frames) < 10
    for r in rows[1:]:
        assert r[7] in ('0', '1') and all(math.isfinite(float(v)) for v in r)


def test_list_skins_names_every_skin(capsys):
    assert cli.main(['--list-skins']) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == skin_names() + ['held_out:N', 'NAME@N']
    with pytest.raises(SystemExit):
        cli.main(['--skin', 'no_such_skin'])
    assert 'the family has default' in capsys.readouterr().err


def test_params_file_configures_the_evaluator_as_the_node(tmp_path, capsys):
    params = tmp_path / 'skin.yaml'
    params.write_text(yaml.safe_dump({'/**/skin_direction': {'ros__parameters': {
        'method': 'centroid', 'min_shift': 0.1, 'skin': {'fill_factor': 0.8}}}}))
    assert cli.main(['--skin', 'default', '--size', '1', '--json',
                     '--params', str(params)]) == 0
    report = json.loads(capsys.readouterr().out)
    summary = report['methods']['centroid']['summary']
    # A 100 mm no-shear floor leaves no press with a direction.
    assert summary['valid_share'] == 0.0
    bad = tmp_path / 'other.yaml'
    bad.write_text(yaml.safe_dump({'skin_driver': {'ros__parameters': {'port': 'x'}}}))
    assert cli.main(['--skin', 'default', '--params', str(bad)]) == 2
    assert "no parameters for node 'skin_direction'" in capsys.readouterr().err


def test_the_shipped_parameter_file_gives_the_core_defaults():
    values = load_direction_parameters('config/skin.yaml')
    assert estimator_config(values, 0.005) == EstimatorConfig(min_contact_force_n=0.2)


def _contact(x, y, azimuth_deg=0.0, valid=True):
    return Contact(x_m=x, y_m=y, force_n=5.0, area_m2=1e-4, shift_m=(0.0, 0.0),
                   azimuth_rad=math.radians(azimuth_deg), azimuth_sigma_rad=0.1,
                   alpha_rad=0.5, force_xyz_n=(0.0, 0.0, -5.0), confidence=1.0,
                   direction_valid=valid)


def _pair_dataset():
    # Two tilted presses 4 taxels apart: beta 90 and 180 deg.
    return Dataset(top=np.zeros((1, 16, 16)), bottom=np.zeros((1, 16, 16)), pitch_m=0.005,
                   azimuth_deg=[90.0], alpha_deg=[30.0],
                   press_x_m=[[0.02, 0.04]], press_y_m=[[0.03, 0.03]],
                   press_force_n=[[10.0, 6.0]], press_azimuth_deg=[[90.0, 180.0]],
                   press_alpha_deg=[[30.0, 30.0]], press_shift_m=[[0.002, 0.001]])


@pytest.mark.parametrize('contacts, separate, merged, errors', [
    # Both found where they are: apart, each with its own direction error.
    ([_contact(0.0405, 0.03, 170.0), _contact(0.0201, 0.03, 93.0)], 1.0, 0.0, [3.0, 10.0]),
    # One contact half way: the pair is merged and neither press is found.
    ([_contact(0.03, 0.03, 120.0)], 0.0, 1.0, []),
    # Only the stronger press found; the weaker one missed, not merged.
    ([_contact(0.02, 0.031, 80.0)], 0.0, 0.0, [10.0]),
])
def test_presses_are_matched_by_location(contacts, separate, merged, errors):
    data = _pair_dataset()
    run = scoring.MethodRun('poc', Calibration(), [contacts], 1.0)
    scored = scoring.score_presses(data, run)
    assert scored['pairs_far'] == 1 and scored['pairs_close'] == 0
    assert scored['separate_share_far'] == separate and scored['merged_share_far'] == merged
    found = sorted(e for _, _, e, _ in scoring.direction_errors(data, run) if e is not None)
    assert found == pytest.approx(errors)


def test_a_press_merged_with_a_close_neighbour_is_still_apart_from_a_far_third():
    # A and C 2 taxels apart are one contact between them; B is 6 taxels from both.
    data = Dataset(top=np.zeros((1, 16, 16)), bottom=np.zeros((1, 16, 16)), pitch_m=0.005,
                   azimuth_deg=[90.0], alpha_deg=[30.0],
                   press_x_m=[[0.02, 0.05, 0.02]], press_y_m=[[0.03, 0.03, 0.04]],
                   press_force_n=[[10.0, 6.0, 8.0]], press_azimuth_deg=[[90.0, 180.0, 0.0]],
                   press_alpha_deg=[[30.0, 30.0, 30.0]],
                   press_shift_m=[[0.002, 0.001, 0.001]])
    contacts = [_contact(0.02, 0.035), _contact(0.05, 0.03)]
    scored = scoring.score_presses(data, scoring.MethodRun('poc', Calibration(), [contacts], 1.0))
    assert (scored['pairs_far'], scored['pairs_close']) == (2, 1)
    assert scored['separate_share_far'] == 1.0 and scored['separate_share_close'] == 0.0
    # Found press by press, one to one: the merged contact stands for one of A and C only.
    assert scored['found_share'] == pytest.approx(2 / 3)
