"""The benchmark's command line: what it writes, and that it fails when the pipeline does."""

import json
import os

import numpy as np
import pytest
from skin_lab.bench import cli as bench, end_to_end as bench_ros, scoring
from skin_lab.bench.estimators import family_methods

# matplotlib's tick labels go through a deprecated pyparsing API; not this project's concern.
pytestmark = pytest.mark.filterwarnings('ignore::DeprecationWarning')


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
                    '## 5. The skin family', '## 6. Force calibration on the skin family'):
        assert heading in text
    assert 'paper mean' in text
    # The default's cost back to back, per skin and scene, beside the interleaved one.
    assert 'run back to back, as a driver runs it' in text
    assert '| skin | all scenes | p90 | paper | random | border | multi | interleaved |' in text
    for path in data['images'].values():
        assert path in text
        assert os.path.getsize(tmp_path / path) > 1000


def test_the_raw_numbers_go_to_the_path_given_and_never_into_the_docs(results, tmp_path):
    res = dict(results)
    res['machine'] = dict(res['machine'], load_after=[0.0, 0.0, 0.0])
    res['targets'] = scoring.targets(res)
    out, raw = tmp_path / 'docs', tmp_path / 'build' / 'bench' / 'raw.json'
    bench.write(res, str(out), str(raw))
    assert json.loads(raw.read_text())['seed']['seed_like_text'] == res['seed']['seed_like_text']
    assert not (out / 'benchmarks.json').exists()
    assert f'Raw numbers: `{raw}` (not committed).' in (out / 'benchmarks.md').read_text()
    # The committed report (docs/) keeps its raw numbers under build/, which git ignores.
    assert bench.json_path_for(bench.DOCS) == os.path.join(bench.ROOT, 'build', 'bench',
                                                           'benchmarks.json')
    assert bench.json_path_for(str(out)) == os.path.join(str(out), 'benchmarks.json')


def test_end_to_end_section_shows_both_layouts_and_where_the_prose_lives(results, e2e,
                                                                         tmp_path):
    e2e['why'] = scoring.why_e2e(e2e)
    e2e['tradeoffs'] = scoring.tradeoffs(e2e)
    res = dict(results, e2e=e2e, machine=dict(results['machine'], load_after=[0.0, 0.0, 0.0]))
    res['targets'] = scoring.targets(res)
    bench.write(res, str(tmp_path))
    text = (tmp_path / 'benchmarks.md').read_text()
    assert '## 3. End to end through ROS: split against fused' in text
    assert '| fused | 1000 | 60000 | 60000 | 0 | - | 0.75 / 1.50 / 3.00 |' in text
    # Each lost scan is placed: the split run lost 12, four of them before the subscriber.
    assert ('| split | 1000 | 60000 | 59988 | 12 | never decoded 1, not delivered 3, '
            'subscriber queue 8 |') in text
    assert '### Which layout when' in text and '"Split or fused: which to use when"' in text
    assert 'docs/estimation.md, "Where the family targets fall short"' in text


def test_a_layout_that_does_not_come_up_fails_the_benchmark(monkeypatch, tmp_path, capsys):
    def not_up(args):
        raise RuntimeError('gave up waiting for the fused layout to come up after 30 s')

    monkeypatch.setattr(bench, 'run', not_up)
    assert bench.main(['--quick', '--out', str(tmp_path)]) == 1
    assert 'fused layout to come up' in capsys.readouterr().err
    assert not (tmp_path / 'benchmarks.md').exists()


def test_a_layout_that_delivers_nothing_fails_the_benchmark(
        results, e2e, monkeypatch, tmp_path, capsys):
    e2e['runs'][1].update(received=0, lost=60000)
    e2e['why'], e2e['tradeoffs'] = scoring.why_e2e(e2e), scoring.tradeoffs(e2e)
    res = dict(results, e2e=e2e, machine=dict(results['machine'], load_after=[0.0, 0.0, 0.0]))
    res['targets'] = scoring.targets(res)
    monkeypatch.setattr(bench, 'run', lambda args: res)
    assert bench.main(['--quick', '--out', str(tmp_path)]) == 1
    assert 'fused at 1000 Hz delivered no contacts' in capsys.readouterr().err
    # What was measured is still written, for the post-mortem.
    assert (tmp_path / 'benchmarks.md').exists()
    e2e['runs'][1].update(received=60000, lost=0)
    assert bench.main(['--quick', '--out', str(tmp_path)]) == 0


def test_the_default_report_goes_to_the_repositorys_docs():
    assert os.path.isfile(os.path.join(bench.DOCS, 'benchmarks.md'))
    assert os.path.isfile(os.path.join(bench.DOCS, '..', 'Makefile'))


def test_cpu_seconds_of_this_process_and_of_a_missing_one():
    assert bench_ros.cpu_seconds(os.getpid()) > 0
    assert bench_ros.cpu_seconds(2 ** 22 + 12345) == 0.0


# The benchmark pins itself to one core, which a busy machine shares: a bound on a hung test only.
@pytest.mark.timeout(400)
def test_family_only_prints_every_scene_and_the_worst_with_the_oracle(
        capsys, tmp_path, monkeypatch):
    # The default, the seed's and the plain centroid show every line; all the methods took CPU
    # minutes on that core (model_fit's calibration learns each scene's taxel model in Python):
    # ten minutes and more on a busy machine, where the faulthandler ended the worker.
    monkeypatch.setattr(bench.bench_core, 'family_methods',
                        lambda everything=True: family_methods(False))
    assert bench.main(['--family-only', 'default', '--family-size', '4',
                       '--out', str(tmp_path)]) == 0
    text = capsys.readouterr().out
    for kind in ('paper', 'random', 'border', 'multi'):
        assert f'{kind}: mean error deg' in text
    assert 'oracle' in text and 'taxel_fit worst:' in text and '/ oracle' in text
    assert 'default cost of taxel_fit back to back: median' in text
    assert (tmp_path / 'family.json').exists()


def test_the_forward_model_section_puts_model_fit_beside_the_default_and_the_oracle(
        results, forward, tmp_path):
    res = dict(results, forward=forward)
    res['machine'] = dict(res['machine'], load_after=[0.0, 0.0, 0.0])
    res['targets'] = scoring.targets(res)
    bench.write(res, str(tmp_path))
    text = (tmp_path / 'benchmarks.md').read_text()
    section = text[text.index('## 7. The forward model (`model_fit`) beside the oracle'):]
    assert ('| skin | `taxel_fit` | `model_fit` | oracle | `taxel_fit` / oracle | '
            '`model_fit` / oracle | `model_fit` ms/frame |') in section
    row = next(line for line in section.splitlines() if line.startswith('| `default` |'))
    # Every cell measured: the three errors, both ratios and the cost.
    assert all(cell.strip() not in ('', '-') for cell in row.split('|')[2:8])
    assert 'Worst `model_fit` / oracle: ' in section and '(`default`;' in section


def test_only_re_measures_the_named_part_into_the_earlier_report_and_says_so(
        results, monkeypatch, tmp_path):
    earlier = dict(results, machine=dict(results['machine'], load_after=[0.0, 0.0, 0.0]))
    earlier['targets'] = scoring.targets(earlier)
    bench.write(earlier, str(tmp_path))
    seed_before = json.loads((tmp_path / 'benchmarks.json').read_text())['seed']
    later = {'machine': dict(results['machine'], load_after=[0.5, 0.5, 0.5]), 'quick': True,
             'scaling': dict(results['scaling'], marker='re-measured'),
             'how': {'command': 'python -m skin_lab.bench.cli --quick --only scaling'},
             'generated_utc': 'later', 'elapsed_s': 7.0}

    def run(args):
        assert args.only == ['scaling']
        return later

    monkeypatch.setattr(bench, 'run', run)
    assert bench.main(['--quick', '--only', 'scaling', '--out', str(tmp_path)]) == 0
    data = json.loads((tmp_path / 'benchmarks.json').read_text())
    assert data['scaling']['marker'] == 're-measured'
    assert data['seed'] == seed_before  # the others as measured before
    assert [u['parts'] for u in data['updates']] == [['scaling']]
    text = (tmp_path / 'benchmarks.md').read_text()
    assert 'except scaling, measured by `python -m skin_lab.bench.cli --quick ' in text


def test_only_refuses_an_unknown_part_a_missing_report_and_a_report_of_another_size(
        results, tmp_path, capsys):
    with pytest.raises(SystemExit):
        bench.main(['--quick', '--only', 'everything', '--out', str(tmp_path)])
    assert 'unknown part' in capsys.readouterr().err
    assert bench.main(['--quick', '--only', 'seed', '--out', str(tmp_path)]) == 1
    assert 'cannot be read' in capsys.readouterr().err
    full = dict(results, quick=False)
    with pytest.raises(ValueError, match='same size'):
        bench.merge(full, dict(results, how={'command': 'x'}, generated_utc='now',
                               elapsed_s=1.0), ['seed'])
