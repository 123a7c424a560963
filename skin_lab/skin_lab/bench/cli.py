"""
`make bench`: error against speed, the seed's experiment, end to end, scale, the skin family.

Usage::

    python -m skin_lab.bench.cli [--quick] [--out DIR] [--json PATH] [--skip-ros]
        [--no-profile] [--e2e-only] [--e2e-seconds S] [--method M] [--only PARTS]

Writes DIR/benchmarks.md and DIR/img/*.png (DIR defaults to docs/) from runs made on the spot,
with the machine and versions they ran on, and every raw number to PATH (default
build/bench/benchmarks.json for the report in docs/, which is not committed whole; else
DIR/benchmarks.json). ``--quick`` takes a few minutes; the full run most of an hour on two cores.
``--only PARTS`` re-measures those parts into the report whose raw numbers are in PATH and says
so in it.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shutil
import sys
import tempfile
import time

import cv2
import numpy as np

from skin_driver.core.common.atomic import write_atomically
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD
from skin_driver.core.sim.board import BATCH_S
from skin_driver.core.sim.skins import HELD_OUT, skin_names
from skin_lab.bench import estimators as bench_core, plots, tables
from skin_lab.bench.calibration import calibration_accuracy
from skin_lab.bench.direction import direction_learning
from skin_lab.bench.drift import drift_bench
from skin_lab.bench.scoring import label, targets, tradeoffs, why_e2e
from skin_lab.evaluate.tables import json_safe

# The repository's root and its docs/: this file is skin_lab/skin_lab/bench/cli.py.
ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                     '..', '..', '..'))
DOCS = os.path.join(ROOT, 'docs')
# Where the raw numbers of the report in docs/ go: generated, never committed whole.
DOCS_JSON = os.path.join(ROOT, 'build', 'bench', 'benchmarks.json')

FULL = {
    'grids': [16, 32, 64, 128], 'shifts': [0.2, 0.5, 1.0, 2.0, 3.0], 'noises': [0.0, 6.0, 20.0],
    'frames': 24, 'seed_repeats': 20, 'random_frames': 400,
    'scale_grids': [16, 32, 64, 128], 'contacts': [1, 2, 3, 4, 5, 6, 7, 8],
    'scale_frames': 10, 'scale_repeats': 5,
    'rates': [1000.0, 2000.0], 'e2e_seconds': 60.0, 'e2e_warmup': 3.0, 'priorities': [0, 50],
    'stage_repeats': 1000,
    'family_sizes': {'paper': 8, 'random': 150, 'border': 80, 'multi': 80},
    'family_all_methods': True, 'calibration_frames': 150,
    'forward_frames': 40, 'forward_skins': None,
    'direction': {'skins': ['default', 'soft', 'sharp', 'loaded', 'saturating', 'film',
                            'held_out:0', 'held_out:1', 'held_out:2', 'held_out:3'],
                  'sizes': {'paper': 4, 'random': 150}, 'presses': [0, 30, 60, 120, 240]},
    'drift_skins': None, 'drift_held_out': 6, 'drift_hours': 8.0, 'drift_step_s': 10.0,
    'drift_cost_repeats': 10,
}
QUICK = {
    'grids': [16, 32], 'shifts': [0.5, 2.0], 'noises': [6.0], 'frames': 3,
    'seed_repeats': 3, 'random_frames': 50,
    'scale_grids': [16, 32], 'contacts': [1, 4], 'scale_frames': 3, 'scale_repeats': 2,
    'rates': [1000.0, 2000.0], 'e2e_seconds': 3.0, 'e2e_warmup': 1.0, 'stage_repeats': 100,
    'priorities': [0],
    'family_sizes': {'paper': 1, 'random': 15, 'border': 10, 'multi': 10},
    'family_all_methods': False, 'calibration_frames': 15,
    'forward_frames': 4, 'forward_skins': ['default'],
    'direction': {'skins': ['default', 'held_out:2'], 'sizes': {'paper': 1, 'random': 20},
                  'presses': [0, 60]},
    'drift_skins': ['default', 'harsh'], 'drift_held_out': 1, 'drift_hours': 8.0,
    'drift_step_s': 30.0, 'drift_cost_repeats': 2,
}


def _cpu_model() -> str:
    try:
        with open('/proc/cpuinfo') as f:
            for line in f:
                if line.startswith('model name'):
                    return line.split(':', 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or 'unknown'


def _version(module: str) -> str:
    try:
        from importlib.metadata import version
        return version(module)
    except Exception:  # noqa: B902 - any failure means "not known"
        pass
    if module == 'rclpy':
        try:
            from ament_index_python.packages import get_package_share_directory
            import xml.etree.ElementTree as ET
            path = os.path.join(get_package_share_directory('rclpy'), 'package.xml')
            return ET.parse(path).getroot().findtext('version') or 'unknown'
        except Exception:  # noqa: B902
            return 'unknown'
    return 'unknown'


def machine() -> dict:
    """Return what the benchmark runs on."""
    import skimage
    return {
        'cpu_model': _cpu_model(), 'cores': os.cpu_count(),
        'cores_usable': len(os.sched_getaffinity(0)),
        'python': platform.python_version(), 'numpy': np.__version__,
        'opencv': cv2.__version__, 'rclpy': _version('rclpy'), 'skimage': skimage.__version__,
        'rmw': os.environ.get('RMW_IMPLEMENTATION', 'default'),
        'platform': platform.platform(),
        'load_before': [round(v, 2) for v in os.getloadavg()],
    }


def _pin() -> int:
    cpus = sorted(os.sched_getaffinity(0))
    cpu = cpus[-1]
    os.sched_setaffinity(0, {cpu})
    return cpu


def run(args) -> dict:
    """Run the parts asked for; return the results dictionary."""
    cfg = QUICK if args.quick else FULL
    started = time.monotonic()
    log = (lambda s: print(s, file=sys.stderr, flush=True))
    res = {'machine': machine(), 'quick': bool(args.quick), 'config': cfg}
    everything = os.sched_getaffinity(0)
    cpu = _pin()
    try:
        if not args.e2e_only:
            _in_process(cfg, args, res, log, args.only or PARTS)
    finally:
        # The ROS processes must not inherit the pin: they share the machine as deployed.
        os.sched_setaffinity(0, everything)
    if not args.skip_ros and 'e2e' in (args.only or PARTS):
        log('3. end to end through ROS')
        res['e2e'] = _e2e(cfg, args, log)
    res['how'] = {
        'command': 'python -m skin_lab.bench.cli' + (' --quick' if args.quick else '')
        + (' --skip-ros' if args.skip_ros else '') + ('' if args.profile else ' --no-profile')
        + (' --e2e-only' if args.e2e_only else '')
        + (f' --e2e-seconds {args.e2e_seconds:g}' if args.e2e_seconds else '')
        + (f' --method {args.method}' if args.method else '')
        + (f' --only {",".join(args.only)}' if args.only else ''),
        'pinned_cpu': cpu,
        'repetitions': (f'{cfg["frames"]} frames per accuracy cell; scale: '
                        f'{cfg["scale_frames"]} frames x {cfg["scale_repeats"]} repeats per '
                        f'point; seed experiment {cfg["seed_repeats"]} repeats; '
                        f'{cfg["random_frames"]} random presses; family scenes per skin '
                        f'{cfg["family_sizes"]} (paper: repeats of 9 frames)'),
    }
    res['machine']['load_after'] = [round(v, 2) for v in os.getloadavg()]
    res['targets'] = targets(res)
    res['elapsed_s'] = time.monotonic() - started
    res['generated_utc'] = datetime.datetime.now(datetime.timezone.utc).strftime(
        '%Y-%m-%d %H:%M')
    return res


def _accuracy(cfg, args, log) -> dict:
    methods = bench_core.bench_methods()
    rows = bench_core.accuracy_speed(cfg['grids'], cfg['shifts'], cfg['noises'],
                                     cfg['frames'], methods, seed=args.noise_seed, log=log)
    return {'grids': cfg['grids'], 'shifts_taxels': cfg['shifts'],
            'noise_counts': cfg['noises'], 'frames': cfg['frames'],
            'methods': methods, 'skimage_upsample': bench_core.SKIMAGE_UPSAMPLE,
            'rows': rows, 'summary': bench_core.pareto_summary(rows, methods, cfg['grids'])}


# The parts measured in this process, in the order they run: (name, heading, runner).
IN_PROCESS = (
    ('accuracy', '1. accuracy against speed', _accuracy),
    ('seed', "2. the seed's experiment",
     lambda cfg, args, log: bench_core.seed_experiment(cfg['seed_repeats'], cfg['random_frames'],
                                                       seed=args.noise_seed)),
    ('family', '5. the skin family',
     lambda cfg, args, log: bench_core.family(
         cfg['family_sizes'], bench_core.family_methods(cfg['family_all_methods']),
         seed=args.noise_seed, log=log)),
    ('forward', '7. the forward model beside the oracle',
     lambda cfg, args, log: bench_core.forward_family(cfg['forward_frames'],
                                                      cfg['forward_skins'], seed=args.noise_seed,
                                                      log=log)),
    ('direction', '8. direction learned from presses of known direction, beside the floor',
     lambda cfg, args, log: direction_learning(cfg['direction']['skins'],
                                               cfg['direction']['sizes'],
                                               cfg['direction']['presses'], seed=args.noise_seed,
                                               log=log)),
    ('drift', '9. drift and creep over hours',
     lambda cfg, args, log: drift_bench(
         (cfg['drift_skins'] or skin_names())
         + [f'{HELD_OUT}{i}' for i in range(cfg['drift_held_out'])], cfg['drift_hours'],
         cfg['drift_step_s'], cfg['drift_cost_repeats'], seed=args.noise_seed, log=log)),
    ('calibration', '6. force calibration on the family',
     lambda cfg, args, log: calibration_accuracy(cfg['calibration_frames'], seed=args.noise_seed,
                                                 log=log)),
    ('scaling', '4. scale',
     lambda cfg, args, log: bench_core.scaling(cfg['scale_grids'], cfg['contacts'],
                                               [DEFAULT_METHOD, 'seed'], cfg['scale_frames'],
                                               cfg['scale_repeats'], seed=args.noise_seed,
                                               log=log)),
)
PARTS = tuple(name for name, _, _ in IN_PROCESS) + ('e2e',)


def _in_process(cfg, args, res, log, wanted=PARTS) -> None:
    """Run the parts measured in this process (accuracy, seed, family, scale, ...) into res."""
    for name, heading, runner in IN_PROCESS:
        if name in wanted:
            log(heading)
            res[name] = runner(cfg, args, log)


def _e2e(cfg, args, log) -> dict:
    from skin_lab.bench import end_to_end as bench_ros
    workdir = tempfile.mkdtemp(prefix='skin_bench_')
    try:
        load = [round(v, 2) for v in os.getloadavg()]
        runs = []
        seconds = args.e2e_seconds or cfg['e2e_seconds']
        for priority in cfg['priorities']:
            # The rclpy floor is a reference at normal priority, beside both layouts.
            layouts = bench_ros.LAYOUTS + (() if priority else (bench_ros.FLOOR,))
            runs += bench_ros.end_to_end(cfg['rates'], seconds, cfg['e2e_warmup'], workdir,
                                         layouts=layouts, log=log, priority=priority,
                                         method=args.method)[0]
        out = {'seconds': seconds, 'warmup_s': cfg['e2e_warmup'], 'runs': runs,
               'method': args.method or DEFAULT_METHOD, 'sim_batch_s': BATCH_S,
               'cores': os.cpu_count(), 'load_before': load,
               'load': [round(v, 2) for v in os.getloadavg()]}
        log('   stage costs')
        out['stage_costs_us'] = bench_ros.stage_costs(cfg['stage_repeats'])
        if args.profile:
            log('   profiled split run at 2 kHz')
            _, profiles = bench_ros.end_to_end([2000.0], min(seconds / 2, 15.0), 1.0,
                                               workdir, layouts=('split',), profile=True,
                                               log=log, method=args.method)
            out['profiles'] = profiles
        out['why'] = why_e2e(out)
        out['tradeoffs'] = tradeoffs(out)
        return out
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def merge(report: dict, res: dict, parts) -> dict:
    """
    Return the earlier report with ``parts`` as measured in ``res`` (a run with ``--only``).

    The other parts stay as measured before; the report lists each later run and its parts, so
    that no figure is passed off as measured in a run it was not. A quick run never goes into a
    full report, nor the other way round: their sample sizes differ.
    """
    if bool(report.get('quick')) != bool(res['quick']):
        raise ValueError('--only adds to a report of the same size: the report in --out was '
                         f'{"" if report.get("quick") else "not "}made with --quick')
    # The new parts as the report's JSON holds them (text keys, None for NaN), like the others.
    res = json.loads(json.dumps(json_safe(res), default=float))
    merged = dict(report)
    merged.update({p: res[p] for p in parts if p in res})
    earlier = [dict(u, parts=[p for p in u['parts'] if p not in parts])
               for u in report.get('updates', ())]
    merged['updates'] = [u for u in earlier if u['parts']] + [{
        'parts': list(parts), 'command': res['how']['command'],
        'generated_utc': res['generated_utc'], 'elapsed_s': res['elapsed_s'],
        'load_before': res['machine']['load_before'],
        'load_after': res['machine']['load_after']}]
    merged['targets'] = targets(merged)
    return merged


def _earlier_report(json_path) -> dict:
    try:
        with open(json_path) as f:
            return json.load(f)
    except (OSError, ValueError) as err:
        raise ValueError(f'--only adds to the report whose raw numbers are {json_path}, which '
                         f'cannot be read ({err}): run the whole benchmark first') from None


def json_path_for(out_dir: str) -> str:
    """Return where the raw numbers of a report in out_dir go by default."""
    if os.path.abspath(out_dir) == os.path.abspath(DOCS):
        return DOCS_JSON
    return os.path.join(out_dir, 'benchmarks.json')


def _shown(json_path: str, out_dir: str) -> str:
    """Return how the report names its raw numbers: a link beside it, else a path."""
    json_path, out_dir = os.path.abspath(json_path), os.path.abspath(out_dir)
    if os.path.dirname(json_path) == out_dir:
        name = os.path.basename(json_path)
        return f'[{name}]({name})'
    inside = os.path.commonpath([json_path, ROOT]) == ROOT
    return f'`{os.path.relpath(json_path, ROOT) if inside else json_path}` (not committed)'


def write(res, out_dir, json_path: str = None) -> None:
    """Write the plots and the Markdown report into out_dir, the raw numbers to json_path."""
    json_path = json_path or json_path_for(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    images = {}
    if 'accuracy' in res:
        images['pareto'] = plots.plot_pareto(res['accuracy']['summary'], out_dir)
    if 'seed' in res:
        images['seed_shifts'] = plots.plot_seed_shifts(res['seed']['raw_shifts_taxels'],
                                                       out_dir)
    if 'scaling' in res:
        images['scaling'] = plots.plot_scaling(res['scaling'], out_dir)
    if 'family' in res:
        images['sigma'] = plots.plot_sigma(res['family']['sigma_vs_error'], out_dir)
    if 'e2e' in res:
        images['e2e'] = plots.plot_e2e(res['e2e']['runs'], out_dir)
    res['images'] = images

    def raw(f):
        json.dump(json_safe(res), f, indent=1, default=float)
        f.write('\n')
    write_atomically(json_path, raw, make_parents=True)
    text = tables.markdown(res, images, _shown(json_path, out_dir))
    write_atomically(os.path.join(out_dir, 'benchmarks.md'), lambda f: f.write(text))


def _family_only(args) -> int:
    """Score the family on a few skins (a small run on a shared machine); print its rows."""
    n = max(args.family_size, 2)
    sizes = {'paper': max(n // 10, 1), 'random': n, 'border': n // 2, 'multi': n // 2}
    everything = os.sched_getaffinity(0)
    _pin()  # its costs on one core, as in the whole benchmark
    try:
        fam = bench_core.family(sizes, bench_core.family_methods(True),
                                args.family_only.split(','), seed=args.noise_seed,
                                log=lambda s: print(s, file=sys.stderr, flush=True))
    finally:
        os.sched_setaffinity(0, everything)
    fig = tables.figure
    for kind in tables.SCENES:
        print(f'{kind}: mean error deg (valid %)')
        for skin in fam['skins']:
            cells = [(r['method'], r['mean_error_deg'], r['valid_share']) for r in fam['rows']
                     if (r['skin'], r['scene']) == (skin, kind)]
            shown = [f'{m} {fig(e, ".2f")} ({fig(v and 100 * v, ".0f")})' for m, e, v in cells]
            print(f'  {skin:12s}  ' + '  '.join(shown))
    for m, w in fam['worst'].items():
        print(f'{m} worst: ' + '; '.join(
            f'{k} {fig(w[k]["mean_error_deg"], ".2f")} ({w[k]["error_skin"]}), / oracle '
            f'{fig(w[k]["ratio_to_oracle"], ".2f")} ({w[k]["ratio_to_oracle_skin"]}), / centroid '
            f'{fig(w[k]["ratio_to_centroid"], ".2f")} ({w[k]["ratio_to_centroid_skin"]})'
            for k in tables.SCENES))
    for c in fam['costs']:
        if 'alone' in c:
            a = c['alone']
            print(f'{c["skin"]} cost of {c["method"]} back to back: median '
                  f'{fig(a["median_us"])} us (' + ', '.join(
                      f'{k} {fig(v["median_us"])} us, {fig(v["contacts"], ".2f")} contacts'
                      for k, v in a['scenes'].items())
                  + f'); interleaved {fig(c["median_us"])} us')
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, 'family.json'), 'w') as f:
            json.dump(json_safe(fam), f, indent=1, default=float)
    return 0


def _parts(text: str) -> list:
    parts = [p.strip() for p in text.split(',') if p.strip()]
    unknown = [p for p in parts if p not in PARTS]
    if unknown or not parts:
        raise argparse.ArgumentTypeError(f'unknown part {", ".join(unknown) or text!r}: the '
                                         f'parts are {", ".join(PARTS)}')
    return parts


def main(argv=None) -> int:
    """Run the benchmark from the command line."""
    parser = argparse.ArgumentParser(prog='python -m skin_lab.bench.cli',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='about a minute, small samples')
    parser.add_argument('--out', default=None,
                        help='output directory (default: docs/, or log/bench-quick with --quick '
                             'so that a quick run never replaces the committed report)')
    parser.add_argument('--json', default=None, metavar='PATH',
                        help='file of the raw numbers, which --only adds to (default: '
                             'build/bench/benchmarks.json for the report in docs/, else '
                             'OUT/benchmarks.json)')
    parser.add_argument('--skip-ros', action='store_true', help='leave out the ROS chain')
    parser.add_argument('--no-profile', dest='profile', action='store_false',
                        help='leave out the profiled 2 kHz run')
    parser.add_argument('--noise-seed', type=int, default=0,
                        help='seed of the random data and noise (0)')
    parser.add_argument('--e2e-seconds', type=float, default=None,
                        help='seconds measured per end-to-end run (default 60, --quick 3)')
    parser.add_argument('--e2e-only', action='store_true',
                        help='only the end-to-end part (layouts, floor, stage costs)')
    parser.add_argument('--method', default=None,
                        help='estimator of the end-to-end nodes and floor (default: the '
                             "shipped config's)")
    parser.add_argument('--only', metavar='PARTS', type=_parts,
                        help='measure only these comma-separated parts (' + ', '.join(PARTS)
                        + ') and put them into the report in --out and its raw numbers in '
                        '--json, the others as measured before')
    parser.add_argument('--family-only', metavar='SKINS',
                        help='run only the skin family on these comma-separated skins (names or '
                             'held_out:N), every method and the oracle, and print its rows')
    parser.add_argument('--family-size', type=int, default=40,
                        help='with --family-only: random frames per skin (border and multi '
                             'half, paper a tenth, in repeats)')
    args = parser.parse_args(argv)
    if args.family_only:
        return _family_only(args)
    if args.quick:
        args.profile = False
    if args.out is None:
        quick_out = os.path.join(os.path.dirname(DOCS), 'log', 'bench-quick')
        args.out = quick_out if args.quick else DOCS
    args.json = args.json or json_path_for(args.out)
    try:
        earlier = _earlier_report(args.json) if args.only else None
        res = run(args)
        took = res['elapsed_s']
        if earlier is not None:
            res = merge(earlier, res, args.only)
    except (RuntimeError, ValueError) as err:
        # A layout or the simulated board that did not come up, or no report to add to:
        # nothing measured to report.
        print(f'bench: {err}', file=sys.stderr)
        return 1
    write(res, args.out, args.json)
    print(f'wrote {os.path.join(args.out, "benchmarks.md")} and {args.json} after {took:.0f} s')
    for t in res['targets']:
        print(f'  {"ok  " if t["met"] else "MISS"} {t["name"]}: {t["measured"]} ({t["limit"]})')
    silent = broken_runs(res)
    for name in silent:
        print(f'bench: {name} delivered no contacts at all: the pipeline is broken',
              file=sys.stderr)
    return 1 if silent else 0


def broken_runs(res) -> list:
    """Return the end-to-end runs (by name) whose subscriber received nothing."""
    return [f'{label(r)} at {r["rate_hz"]:g} Hz' for r in res.get('e2e', {}).get('runs', ())
            if not r['received']]


if __name__ == '__main__':
    sys.exit(main())
