"""Tests of the offline evaluator (Table 1 and JSON)."""

import json

import numpy as np
import pytest

from skin_driver.core.estimation.data.dataset import save_dataset
from skin_driver.core.sim.fsr import FsrFilm
from skin_driver.core.sim.physics import SkinModel
from skin_lab.evaluate import cli, scoring, tables
from skin_lab.experiments import (add_calibration_frames, make_random_experiment,
                                  make_seed_experiment)


def test_table_and_json(tmp_path, capsys):
    path = tmp_path / 'seed.npz'
    save_dataset(path, make_seed_experiment(repeats=3, rng=np.random.default_rng(0)))
    assert cli.main([str(path), '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report['methods']) == {'taxel_fit', 'seed'}
    poc = report['methods']['taxel_fit']
    assert [r['beta_deg'] for r in poc['per_beta']] == [float(b) for b in range(0, 360, 45)]
    assert all(r['frames'] == 3 for r in poc['per_beta'])
    summary = poc['summary']
    assert summary['valid_share'] == 1.0
    assert summary['mean_error_deg'] < report['methods']['seed']['summary']['mean_error_deg']
    assert summary['us_per_frame'] > 0
    assert poc['calibration']['presses'] == 3
    # 10 N at alpha 45 deg: the polar angle within a degree and |force| within 5 %.
    assert summary['alpha_mean_error_deg'] < 1.0 and summary['force_mean_error_pct'] < 5.0
    for key in ('alpha_std_error_deg', 'alpha_bias_deg', 'force_std_error_pct',
                'force_bias_pct'):
        assert isinstance(summary[key], float)
    assert cli.main([str(path), '--method', 'centroid']) == 0
    text = capsys.readouterr().out
    assert 'summary' in text and 'centroid mean' in text and 'seed mean' in text
    assert 'alpha error' in text and '|force| error' in text


def test_generate_and_errors(tmp_path, capsys):
    out = tmp_path / 'r.npz'
    assert cli.main(['--generate', 'random', str(out), '--size', '20']) == 0
    assert out.exists()
    bad = tmp_path / 'bad.npz'
    bad.write_bytes(b'x')
    assert cli.main([str(bad)]) == 2
    assert 'error' in capsys.readouterr().err


def test_the_papers_table_stands_beside_the_seed_experiment_only():
    rng = np.random.default_rng(4)
    seed_like = scoring.evaluate(make_seed_experiment(repeats=1, rng=rng), 'centroid')
    random = scoring.evaluate(make_random_experiment(frames=30, rng=rng), 'centroid')
    assert seed_like['seed_experiment'] and not random['seed_experiment']
    assert 'paper mean' in tables.format_table(seed_like)
    assert 'paper mean' not in tables.format_table(random)


def test_calibration_frames_make_force_and_alpha_right_on_another_skin():
    # Another FSR curve and three times the compliance: the assumed model is far off here.
    skin = SkinModel(misalignment_m=(3e-4, -2e-4), compliance_m_per_n=2.1e-3,
                     fsr=FsrFilm(r_series_ohm=2000.0, r_min_ohm=150.0, r_max_ohm=6000.0,
                                 force_at_r_min_n=40.0))
    rng = np.random.default_rng(5)
    scored = make_random_experiment(skin, frames=40, rng=rng, alpha_range_deg=(15.0, 40.0))
    plain = scoring.evaluate_method(scored, 'poc')['summary']
    assert plain['force_mean_error_pct'] > 30.0
    data = add_calibration_frames(scored, skin, rng)
    assert data.split.tolist() == [3] * 16 + [1] * 32 + [0] * 40
    report = scoring.evaluate_method(data, 'poc')
    summary = report['summary']
    assert summary['frames'] == 32  # only the scored tilted frames (one in five is normal)
    assert summary['force_mean_error_pct'] < 15.0 and summary['alpha_mean_error_deg'] < 5.0
    assert summary['valid_share'] >= 0.95
    calibration = report['calibration']
    assert calibration['force_presses'] == 16 and calibration['compliance_presses'] == 16
    assert calibration['compliance_m_per_n'] == pytest.approx(2.1e-3, rel=0.1)
