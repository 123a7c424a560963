"""Tests of the evaluator's oracle column and of --contacts numbering with a split."""

import csv
import json

import numpy as np

from skin_driver.core.estimation.data.dataset import save_dataset
from skin_lab.evaluate import cli
from skin_lab.experiments import calibrated_scene


def test_evaluator_scores_the_oracle_beside_the_methods(capsys):
    assert cli.main(['--skin', 'default', '--scene', 'random', '--size', '10', '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    oracle = report['methods']['oracle']['summary']
    default = report['methods']['taxel_fit']
    assert oracle['valid_share'] == 1.0
    assert oracle['mean_error_deg'] < default['summary']['mean_error_deg']
    assert default['ratio_to_oracle']['single'] > 1.0
    assert cli.main(['--skin', 'default', '--scene', 'random', '--size', '10', '--no-oracle',
                     '--json']) == 0
    assert 'oracle' not in json.loads(capsys.readouterr().out)['methods']


def test_the_paper_scene_after_calibration_frames_scores_the_tilted_presses_against_the_oracle(
        capsys, tmp_path):
    args = ['--skin', 'film', '--scene', 'paper', '--size', '1', '--calibration-frames']
    assert cli.main(args + ['--json']) == 0
    report = json.loads(capsys.readouterr().out)
    # 16 plate frames, 32 calibration presses and the paper's normal press, which re-takes the
    # offset at its spot.
    assert report['calibration_frames'] == 49 and report['tilted_frames'] == 8
    assert report['methods']['oracle']['summary']['valid_share'] == 1.0
    notes = report['methods']['taxel_fit']['calibration_notes']
    assert notes[-1].startswith('offset: offset from 1 normal presses')
    # The file written by --generate holds the same frames: the evaluator scores it alike.
    path = tmp_path / 'paper.npz'
    assert cli.main(['--generate', 'paper', str(path), '--skin', 'film', '--size', '1',
                     '--calibration-frames']) == 0
    capsys.readouterr()
    assert cli.main([str(path), '--json']) == 0
    again = json.loads(capsys.readouterr().out)['methods']['taxel_fit']
    assert again['summary'] == report['methods']['taxel_fit']['summary'] | {
        'us_per_frame': again['summary']['us_per_frame']}


def test_contacts_are_numbered_by_their_frame_in_the_dataset(tmp_path):
    rng = np.random.default_rng(0)
    data = calibrated_scene('random', 'default', rng, 6)
    path, out = tmp_path / 'd.npz', tmp_path / 'c.csv'
    save_dataset(path, data)
    assert cli.main([str(path), '--contacts', str(out)]) == 0
    with open(out) as f:
        frames = {int(row['frame']) for row in csv.DictReader(f)}
    scored = set(np.flatnonzero(data.split == 0).tolist())
    assert frames and frames <= scored and min(frames) >= 48
