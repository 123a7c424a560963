"""Tiny benchmark results shared by the benchmark's tests (computed once per run)."""

import fcntl
import os
import pickle

import pytest
from skin_lab.bench import cli as bench, estimators as bench_core
from skin_lab.bench.calibration import calibration_accuracy


def _once(tmp_path_factory, name, make):
    """
    Return ``make()``, computed by the first pytest-xdist worker that asks and read by the rest.

    A session fixture is per worker: the benchmark's cost half a minute on each. The workers
    share their base temporary folder's parent (pytest-xdist's own recipe); a lock makes the
    others wait for the first, which writes the pickle atomically.
    """
    if os.environ.get('PYTEST_XDIST_WORKER') is None:
        return make()
    root = tmp_path_factory.getbasetemp().parent
    path = root / f'{name}.pickle'
    with open(root / f'{name}.lock', 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if path.exists():
            return pickle.loads(path.read_bytes())
        value = make()
        part = root / f'{name}.pickle.part'
        part.write_bytes(pickle.dumps(value))
        os.replace(part, path)
        return value


@pytest.fixture(scope='session')
def results(tmp_path_factory):
    return _once(tmp_path_factory, 'bench_results', _results)


def _results():
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
        'calibration': calibration_accuracy(10, skins=['saturating'], log=lambda s: None),
        'how': {'command': 'test', 'pinned_cpu': 0, 'repetitions': 'tiny'},
        'elapsed_s': 1.0, 'generated_utc': 'now',
    }


@pytest.fixture(scope='session')
def forward():
    """Return section 7's rows: apart from ``results``, as learning the skin costs most."""
    return bench_core.forward_family(2, ['default'], log=lambda s: None)


def _e2e_run(layout, rate, lost, p99, cpu, where=None):
    latency = {'p50': p99 / 2, 'p99': p99, 'max': p99 * 2}
    where = where or {'never decoded': 0, 'not delivered': 0, 'subscriber queue': lost}
    return {'layout': layout, 'rate_hz': rate, 'seconds': 60.0, 'expected_scans': int(60 * rate),
            'sim_frames_sent': int(60 * rate), 'sim_frames_dropped': 0, 'received':
            int(60 * rate) - lost, 'lost': lost, 'sequence_gaps': lost,
            'audit_lost': lost - where['subscriber queue'], 'audit_depth': 10000,
            'lost_where': where, 'received_rate_hz': rate, 'latency_ms': latency,
            'published_ms': {k: 0.6 * v for k, v in latency.items()},
            'published_first_ms': {k: 0.4 * v for k, v in latency.items()},
            'behind_in_read': 0.05,
            'latency_from_device_time_ms': latency, 'board_to_driver_ms': latency,
            'scans_with_contact': 0.9, 'cpu_percent': {}, 'cpu_us_per_scan': cpu,
            'driver_decoded_hz': rate, 'driver_sequence_gaps': 0, 'estimated_hz': rate,
            'estimator_mean_us': 80.0,
            'threads_us_per_scan': {name: {'executor': 10.0, 'reader': cpu[name] - 10}
                                    for name in ('driver', 'floor') if name in cpu},
            'reader_stages_us': {'read': 10.0, 'decode': 8.0}, 'estimation_stages_us': {}}


@pytest.fixture
def e2e():
    """Return both layouts and the rclpy floor at 1 kHz: split loses scans, fused does not."""
    return {'seconds': 60.0, 'warmup_s': 3.0, 'cores': 2, 'load': [1, 1, 1],
            'load_before': [1, 1, 1],
            'stage_costs_us': {'estimator.process (1 contact)': 80.0},
            'runs': [_e2e_run('split', 1000.0, 12, 3.0,
                              {'sim': 150, 'driver': 90, 'direction': 400, 'probe': 120},
                              {'never decoded': 1, 'not delivered': 3, 'subscriber queue': 8}),
                     _e2e_run('fused', 1000.0, 0, 1.5,
                              {'sim': 150, 'driver': 140, 'probe': 120}),
                     _e2e_run('floor', 1000.0, 0, 1.2,
                              {'sim': 150, 'floor': 100, 'probe': 120})]}
