"""The benchmark's pieces on tiny inputs: structure of the results, the JSON and the report."""

import json
import math
import os

import numpy as np
import pytest
from skin_driver.tools.bench import (
    cli as bench, end_to_end as bench_ros, estimators as bench_core, scoring)

# matplotlib's tick labels go through a deprecated pyparsing API; not this project's concern.
pytestmark = pytest.mark.filterwarnings('ignore::DeprecationWarning')


@pytest.fixture(scope='module')
def results():
    methods = ['poc', 'seed', bench_core.SKIMAGE]
    rows = bench_core.accuracy_speed([16], [1.0], [6.0], 2, methods, log=lambda s: None)
    return {
        'machine': bench.machine(), 'quick': True, 'config': bench.QUICK,
        'accuracy': {'grids': [16], 'shifts_taxels': [1.0], 'noise_counts': [6.0],
                     'frames': 2, 'methods': methods, 'skimage_upsample': 100, 'rows': rows,
                     'summary': bench_core.pareto_summary(rows, methods, [16])},
        'seed': bench_core.seed_experiment(1, 12),
        'scaling': bench_core.scaling([16], [1, 2], ['poc', 'seed'], 1, 1,
                                      log=lambda s: None),
        'family': bench_core.family({'paper': 1, 'random': 5, 'border': 5, 'multi': 6},
                                    bench_core.family_methods(False), skins=['default', 'soft'],
                                    log=lambda s: None),
        'how': {'command': 'test', 'pinned_cpu': 0, 'repetitions': 'tiny'},
        'elapsed_s': 1.0, 'generated_utc': 'now',
    }


def test_accuracy_rows_cover_every_method_and_hold_finite_figures(results):
    rows = results['accuracy']['rows']
    assert sorted(r['method'] for r in rows) == sorted(['poc', 'seed', bench_core.SKIMAGE])
    for r in rows:
        assert r['frames'] == 2 and 0 <= r['valid'] <= 2
        assert math.isfinite(r['median_us']) and r['median_us'] > 0
        assert r['mean_error_deg'] is None or 0 <= r['mean_error_deg'] <= 180


def test_skimage_reference_reports_the_displacement_of_the_bottom_map():
    top = np.zeros((16, 16))
    top[6:9, 5:9] = 1.0
    top[7, 6] = 3.0
    bottom = np.roll(top, (1, 2), axis=(0, 1))
    dx, dy, conf = bench_core.skimage_shift(np.stack((top, bottom)))
    assert (dx, dy, conf) == pytest.approx((2.0, 1.0, 1.0), abs=0.02)
    assert bench_core.skimage_shift(np.stack((top, np.zeros_like(top)))).confidence == 0.0


def test_scaling_has_a_point_per_grid_contact_count_and_method(results):
    scale = results['scaling']
    assert {(r['grid'], r['method']) for r in scale['by_grid']} == {(16, 'poc'), (16, 'seed')}
    assert {(r['contacts'], r['method']) for r in scale['by_contacts']} >= {
        (1, 'poc'), (2, 'poc'), (1, 'seed'), (2, 'seed')}
    assert all(r['median_us'] > 0 for r in scale['by_grid'] + scale['by_contacts'])


def test_targets_name_each_figure_with_its_limit(results):
    names = [t['name'] for t in scoring.targets(results)]
    assert any('seed-like mean azimuth error' in n for n in names)
    assert any('random presses valid share' in n for n in names)
    assert any('16x16' in n and 'cost' in n for n in names)
    assert any(n.startswith('family') and 'centroid' in n for n in names)
    assert any(n.startswith('family') and 'apart' in n for n in names)
    assert all({'measured', 'limit', 'met', 'note'} <= set(t) for t in scoring.targets(results))


def test_write_produces_json_markdown_and_plots(results, tmp_path):
    res = dict(results)
    res['machine'] = dict(res['machine'], load_after=[0.0, 0.0, 0.0])
    res['targets'] = scoring.targets(res)
    bench.write(res, str(tmp_path))
    data = json.loads((tmp_path / 'benchmarks.json').read_text())
    assert {'machine', 'accuracy', 'seed', 'scaling', 'targets', 'images'} <= set(data)
    assert data['machine']['cpu_model'] and data['machine']['numpy'] == np.__version__
    text = (tmp_path / 'benchmarks.md').read_text()
    for heading in ('## Machine and method', '## Targets', '## 1. Accuracy against speed',
                    "## 2. The seed's experiment", '## 4. Scale', '## Headline: worst case',
                    '## 5. The skin family'):
        assert heading in text
    assert 'paper mean' in text
    for path in data['images'].values():
        assert path in text
        assert os.path.getsize(tmp_path / path) > 1000


def test_family_scores_every_skin_scene_and_method_and_names_the_worst(results):
    fam = results['family']
    methods = ['poc', 'seed', 'plain_centroid']
    assert fam['methods'] == methods
    assert {(r['skin'], r['scene'], r['method']) for r in fam['rows']} == {
        (s, k, m) for s in ('default', 'soft') for k in ('paper', 'random', 'border', 'multi')
        for m in methods}
    assert {(c['skin'], c['method']) for c in fam['costs']} == {
        (s, m) for s in ('default', 'soft') for m in methods}
    for m in methods:
        worst = fam['worst'][m]['random']
        errors = {r['skin']: r['mean_error_deg'] for r in fam['rows']
                  if r['method'] == m and r['scene'] == 'random'}
        assert worst['mean_error_deg'] == max(errors.values())
        assert errors[worst['error_skin']] == worst['mean_error_deg']
    assert all(s > 0 and 0 <= e <= 180 for s, e, _, _ in fam['sigma_vs_error'])


def test_cpu_seconds_of_this_process_and_of_a_missing_one():
    assert bench_ros.cpu_seconds(os.getpid()) > 0
    assert bench_ros.cpu_seconds(2 ** 22 + 12345) == 0.0


def _e2e_run(layout, rate, lost, p99, cpu):
    latency = {'p50': p99 / 2, 'p99': p99, 'max': p99 * 2}
    return {'layout': layout, 'rate_hz': rate, 'seconds': 60.0, 'expected_scans': int(60 * rate),
            'sim_frames_sent': int(60 * rate), 'sim_frames_dropped': 0, 'received':
            int(60 * rate) - lost, 'lost': lost, 'sequence_gaps': lost,
            'received_rate_hz': rate, 'latency_ms': latency,
            'latency_from_device_time_ms': latency, 'board_to_driver_ms': latency,
            'scans_with_contact': 0.9, 'cpu_percent': {}, 'cpu_us_per_scan': cpu,
            'driver_decoded_hz': rate, 'driver_sequence_gaps': 0, 'estimated_hz': rate,
            'estimator_mean_us': 80.0}


def test_end_to_end_targets_and_report_cover_both_layouts_at_each_rate(results, tmp_path):
    e2e = {'seconds': 60.0, 'warmup_s': 3.0, 'cores': 2, 'load': [1, 1, 1],
           'load_before': [1, 1, 1], 'stage_costs_us': {'estimator.process (1 contact)': 80.0},
           'runs': [_e2e_run('split', 1000.0, 12, 3.0,
                             {'sim': 150, 'driver': 90, 'direction': 400, 'probe': 120}),
                    _e2e_run('fused', 1000.0, 0, 1.5, {'sim': 150, 'driver': 200, 'probe': 120})]}
    e2e['why'] = scoring.why_e2e(e2e)
    e2e['tradeoffs'] = scoring.tradeoffs(e2e)
    targets = {t['name']: t for t in scoring.e2e_targets(e2e)}
    assert not targets['split at 1 kHz: scans lost in 60 s']['met']
    assert targets['fused at 1 kHz: scans lost in 60 s']['met']
    assert targets['split at 1 kHz: p99 latency, last byte -> subscriber']['note'] == \
        '1.5 x the limit'
    # Driver and direction node together are the split layout's hot path; the probe is not.
    assert targets['split at 1 kHz: hot path CPU per scan']['measured'] == '490'
    assert targets['fused at 1 kHz: hot path CPU per scan']['met']
    assert any('0.41 x' in line for line in e2e['tradeoffs'])
    res = dict(results, e2e=e2e, machine=dict(results['machine'], load_after=[0.0, 0.0, 0.0]))
    res['targets'] = scoring.targets(res)
    bench.write(res, str(tmp_path))
    text = (tmp_path / 'benchmarks.md').read_text()
    assert '## 3. End to end through ROS: split against fused' in text
    assert '| fused | 1000 | 60000 | 60000 | 0 | 0.75 / 1.50 / 3.00 |' in text
    assert '### Which layout when' in text
