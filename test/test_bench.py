"""The benchmark's pieces on tiny inputs: structure of the results, the JSON and the report."""

import json
import math
import os

import numpy as np
import pytest
from skin_driver import bench, bench_core, bench_ros
from skin_driver.core.sim.physics import SkinModel

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
        'scaling': bench_core.scaling([16], [1, 2], ['poc', 'seed'], 1, 1, log=lambda s: None),
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
    dx, dy, conf = bench_core.skimage_shift(top, bottom)
    assert (dx, dy, conf) == pytest.approx((2.0, 1.0, 1.0), abs=0.02)
    assert bench_core.skimage_shift(top, np.zeros_like(top)).confidence == 0.0


def test_finer_grids_cover_the_same_patch_and_read_the_same_pressure():
    coarse, fine = bench_core.skin_for_grid(16), bench_core.skin_for_grid(32)
    assert coarse.cols * coarse.pitch_m == pytest.approx(fine.cols * fine.pitch_m)
    assert fine.fsr.force_at_r_max_n == pytest.approx(coarse.fsr.force_at_r_max_n / 4)
    assert coarse == SkinModel(noise_counts=coarse.noise_counts)


def test_scaling_has_a_point_per_grid_contact_count_and_method(results):
    scale = results['scaling']
    assert {(r['grid'], r['method']) for r in scale['by_grid']} == {(16, 'poc'), (16, 'seed')}
    assert {(r['contacts'], r['method']) for r in scale['by_contacts']} >= {
        (1, 'poc'), (2, 'poc'), (1, 'seed'), (2, 'seed')}
    assert all(r['median_us'] > 0 for r in scale['by_grid'] + scale['by_contacts'])


def test_targets_name_each_figure_with_its_limit(results):
    names = [t['name'] for t in bench.targets(results)]
    assert any('seed-like mean azimuth error' in n for n in names)
    assert any('random presses valid share' in n for n in names)
    assert any('16x16' in n and 'cost' in n for n in names)
    assert all({'measured', 'limit', 'met', 'note'} <= set(t) for t in bench.targets(results))


def test_write_produces_json_markdown_and_plots(results, tmp_path):
    res = dict(results)
    res['machine'] = dict(res['machine'], load_after=[0.0, 0.0, 0.0])
    res['targets'] = bench.targets(res)
    bench.write(res, str(tmp_path))
    data = json.loads((tmp_path / 'benchmarks.json').read_text())
    assert {'machine', 'accuracy', 'seed', 'scaling', 'targets', 'images'} <= set(data)
    assert data['machine']['cpu_model'] and data['machine']['numpy'] == np.__version__
    text = (tmp_path / 'benchmarks.md').read_text()
    for heading in ('## Machine and method', '## Targets', '## 1. Accuracy against speed',
                    "## 2. The seed's experiment", '## 4. Scale'):
        assert heading in text
    assert 'paper mean' in text
    for path in data['images'].values():
        assert path in text
        assert os.path.getsize(tmp_path / path) > 1000


def test_cpu_seconds_of_this_process_and_of_a_missing_one():
    assert bench_ros.cpu_seconds(os.getpid()) > 0
    assert bench_ros.cpu_seconds(2 ** 22 + 12345) == 0.0
