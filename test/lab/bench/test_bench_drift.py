"""Section 9 of the benchmark: a skin over hours, and the cost of a scan's time."""

from skin_lab.bench import tables
from skin_lab.bench.drift import drift_bench, drift_section
from skin_lab.bench.scoring import targets


def test_the_hours_section_reports_every_mode_the_targets_and_the_cost_side_by_side():
    res = drift_bench(['default'], 1.0, 60.0, 1, log=lambda s: None)
    names = {t['name']: t for t in targets({'drift': res})}
    phantoms = next(t for n, t in names.items() if n.startswith('phantom contacts'))
    assert phantoms['met'] and phantoms['measured'] == '0'
    force = next(t for n, t in names.items() if n.startswith('force (magnitude) after 60 min'))
    assert 'uncorrected' in force['note'] and 'default creep' in force['note']
    cost = next(t for n, t in names.items() if n.startswith("cost of a scan's time"))
    assert 'without' in cost['note'] and cost['limit'] == '<= 2 us'
    text = '\n'.join(drift_section(res))
    for mode in ('off', 'tracking', 'default', 'calibrated'):
        assert f'| default | 8 % | {mode} |' in text
    assert 'Creep calibration: default' in text
    assert '## 9. Hours' in tables.markdown(
        {'machine': dict.fromkeys(('cpu_model', 'cores', 'cores_usable', 'load_before',
                                   'load_after', 'python', 'numpy', 'opencv', 'rclpy',
                                   'skimage', 'rmw'), ''),
         'how': {'command': 'test', 'pinned_cpu': 0, 'repetitions': 'tiny'},
         'elapsed_s': 1.0, 'generated_utc': 'now', 'targets': [], 'drift': res}, {})
