"""
`make bench`: error against speed, the seed's experiment, end to end, scale, the skin family.

Usage::

    python -m skin_driver.bench [--quick] [--out DIR] [--skip-ros] [--no-profile]

Writes DIR/benchmarks.md, DIR/benchmarks.json and DIR/img/*.png (DIR defaults to docs/) from
runs made on the spot, with the machine and versions they ran on. ``--quick`` takes about a
minute; the full run about ten.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import shutil
import sys
import tempfile
import time

import cv2
import numpy as np

from . import bench_core, bench_report
from .core.estimation.shift import DEFAULT_METHOD
from .evaluate import _json_safe

DOCS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), 'docs')

FULL = {
    'grids': [16, 32, 64, 128], 'shifts': [0.2, 0.5, 1.0, 2.0, 3.0], 'noises': [0.0, 6.0, 20.0],
    'frames': 24, 'seed_repeats': 20, 'random_frames': 400,
    'scale_grids': [16, 32, 64, 128], 'contacts': [1, 2, 3, 4, 5, 6, 7, 8],
    'scale_frames': 10, 'scale_repeats': 5,
    'rates': [100.0, 1000.0, 2000.0], 'e2e_seconds': 15.0, 'e2e_warmup': 2.0,
    'stage_repeats': 1000,
    'family_sizes': {'paper': 8, 'random': 150, 'border': 80, 'multi': 80},
    'family_all_methods': True,
}
QUICK = {
    'grids': [16, 32], 'shifts': [0.5, 2.0], 'noises': [6.0], 'frames': 3,
    'seed_repeats': 3, 'random_frames': 50,
    'scale_grids': [16, 32], 'contacts': [1, 4], 'scale_frames': 3, 'scale_repeats': 2,
    'rates': [100.0, 2000.0], 'e2e_seconds': 3.0, 'e2e_warmup': 1.0, 'stage_repeats': 100,
    'family_sizes': {'paper': 1, 'random': 15, 'border': 10, 'multi': 10},
    'family_all_methods': False,
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


def _target(name, measured, limit, met, note='', spec='.2f') -> dict:
    shown = '-' if measured is None else format(measured, spec)
    return {'name': name, 'measured': shown, 'limit': limit, 'met': bool(met), 'note': note}


def _by(rows, **keys):
    return next((r for r in rows if all(r[k] == v for k, v in keys.items())), None)


def targets(res) -> list:
    """Return the issue's targets with the measured figure and whether each was met."""
    out = []
    if 'seed' in res:
        methods = res['seed']['seed_like']['methods']
        d = methods[DEFAULT_METHOD]['summary']['mean_error_deg']
        s = methods['seed']['summary']['mean_error_deg']
        out.append(_target('seed-like mean azimuth error (default)', d, '<= 0.5 deg',
                           d is not None and d <= 0.5,
                           f'{d / 0.5:.2f} x the limit' if d and d > 0.5 else ''))
        ratio = d / s if d is not None and s else None
        out.append(_target('seed-like error, default / seed (same frames)', ratio, '<= 0.20',
                           ratio is not None and ratio <= 0.2, f'seed {s:.2f} deg'))
        r = res['seed']['random']['methods'][DEFAULT_METHOD]['summary']
        out.append(_target('random presses mean error (default)', r['mean_error_deg'],
                           '<= 2 deg', (r['mean_error_deg'] or 99) <= 2.0))
        out.append(_target('random presses valid share (default)',
                           100 * (r['valid_share'] or 0), '>= 95 %',
                           (r['valid_share'] or 0) >= 0.95, spec='.1f'))
    if 'family' in res:
        out += family_targets(res['family']['worst'])
    if 'scaling' in res:
        rows = res['scaling']['by_grid']
        for n, limit in ((16, 100.0), (128, 1000.0)):
            row = _by(rows, grid=n, method=DEFAULT_METHOD)
            if row:
                v = row['median_us']
                out.append(_target(f'cost of the default at {n}x{n}, 1 contact, one core', v,
                                   f'<= {limit:g} us', v <= limit,
                                   f'{v / limit:.2f} x the limit' if v > limit else '', '.0f'))
        d16, s16 = _by(rows, grid=16, method=DEFAULT_METHOD), _by(rows, grid=16, method='seed')
        if d16 and s16:
            out.append(_target('cost ratio default / seed at 16x16 (side by side)',
                               d16['median_us'] / s16['median_us'], '<= 1 (no greater cost)',
                               d16['median_us'] <= s16['median_us']))
    if 'e2e' in res:
        run = next((r for r in res['e2e']['runs'] if r['rate_hz'] == 2000.0), None)
        if run:
            dropped = run['dropped_scans']
            out.append(_target('end to end 16x16 at 2 kHz: dropped scans', dropped, '0',
                               dropped == 0, f'of {run["expected_scans"]} scans in '
                               f'{run["seconds"]:g} s', '.0f'))
            p99 = run['latency_p99_ms']
            out.append(_target('end to end 16x16 at 2 kHz: p99 latency', p99, '<= 2 ms',
                               p99 is not None and p99 <= 2.0,
                               f'{p99 / 2.0:.1f} x the limit' if p99 and p99 > 2 else '', '.2f'))
    return out


def _share_target(name, share, skin, limit) -> dict:
    note = f'worst on {skin}' if skin else ''
    if share is not None and share < limit:
        note += f', {100 * (limit - share):.1f} points short'
    return _target(name, None if share is None else 100 * share, f'>= {100 * limit:g} %',
                   share is not None and share >= limit, note, '.1f')


def family_targets(worst) -> list:
    """Return the issue's targets over the whole family, each at its worst skin."""
    d = worst[DEFAULT_METHOD]
    out = [_share_target('family: valid share for shifts >= 1 taxel (default, worst skin)',
                         d['large_shift_valid_share'], d['large_shift_skin'], 0.95)]
    for kind in ('paper', 'random', 'border', 'multi'):
        r = d[kind]['ratio_to_centroid']
        out.append(_target(f'family {kind}: error default / centroid (worst skin)', r, '<= 1',
                           r is not None and r <= 1.0,
                           f'worst on {d[kind]["ratio_to_centroid_skin"]}' if r else ''))
    r = d['paper']['ratio_to_seed']
    out.append(_target("family paper's protocol: error default / seed (worst skin)", r, '<= 0.20',
                       r is not None and r <= 0.2,
                       f'worst on {d["paper"]["ratio_to_seed_skin"]}' if r else ''))
    out.append(_share_target('family: presses >= 3 taxels apart found apart (default, worst)',
                             d['separate_share_far'], d['separate_skin'], 0.98))
    v = d['median_us']
    out.append(_target("family: cost of the default per 16x16 frame pair (worst skin's median)",
                       v, '<= 100 us', v is not None and v <= 100.0,
                       f'worst on {d["cost_skin"]}' + (f', {v / 100:.2f} x the limit'
                                                       if v and v > 100 else ''), '.0f'))
    return out


def why_e2e(e2e) -> list:
    """Return the measured reasons for a missed end-to-end target."""
    run = next((r for r in e2e['runs'] if r['rate_hz'] == 2000.0), None)
    if run is None:
        return []
    stage = e2e['stage_costs_us']
    period_us = 1e6 / run['rate_hz']
    sim_us = stage.get('sim: physics.render (press on)', 0) + stage.get('sim: encode_frame', 0)
    direction_us = sum(v for k, v in stage.items() if k.startswith('direction'))
    cpu = run['cpu_percent']
    estimator_us = stage.get('direction: estimator.process (1 contact)', 0)
    lines = [
        f'Budget: at 2 kHz a scan arrives every {period_us:.0f} us. In process the direction '
        f"node alone needs {direction_us:.0f} us per scan before rclpy's own receive and "
        f'executor overhead (estimator {estimator_us:.0f}'
        ' us, message building and three publishes the rest); the simulator needs '
        f'{sim_us:.0f} us per scan with a press on.',
        f'Measured CPU over the window: sim {cpu["sim"]:.0f} %, driver {cpu["driver"]:.0f} %, '
        f'direction {cpu["direction"]:.0f} %, probe {cpu["probe"]:.0f} % of one core: '
        f'{sum(cpu.values()):.0f} % of the {e2e["cores"] * 100} % this machine has, shared '
        f'with other jobs (load average {e2e["load"]}).',
        _losses(run),
        _direction_overhead(run, stage),
        f'Where the latency accrues: device -> driver p50/p99 '
        f'{run["device_to_driver_p50_ms"]:.2f}/{run["device_to_driver_p99_ms"]:.2f} ms '
        '(the simulator writes in batches every 2 ms at rates above 500 Hz, so up to 1.5 ms '
        "of every scan's latency is the simulated board's own; the rest is the driver "
        'waiting for a core), driver -> contacts p50/p99 '
        f'{run["driver_to_contact_p50_ms"]:.2f}/{run["driver_to_contact_p99_ms"]:.2f} ms.',
    ]
    return lines


def _direction_overhead(run, stage) -> str:
    """Return the direction node's CPU per processed scan against its own work in process."""
    n = run.get('node_counters', {}).get('direction', {})
    if not n.get('rate_hz'):
        return "The direction node's counters were not available for this run."
    per_scan = run['cpu_percent']['direction'] / 100.0 / n['rate_hz'] * 1e6
    own = sum(v for k, v in stage.items() if k.startswith('direction'))
    return (f'The direction node spent {per_scan:.0f} us of CPU per processed scan, against '
            f"{own:.0f} us for its own work measured in process: the difference is rclpy's "
            'Python executor (rebuilding the wait set over every subscription, service, timer '
            'and parameter service on each wake-up) and message (de)serialisation. At 2 kHz '
            f'that is {per_scan * 2000 / 1e4:.0f} % of one core for this node alone: even with '
            f'a whole core to itself it would top out near {1e6 / per_scan:.0f} Hz; it got '
            f'{run["cpu_percent"]["direction"]:.0f} % and its input queue overflowed.')


def _losses(run) -> str:
    """Return where the scans of a run were lost, from the nodes' counters."""
    d = run.get('node_counters', {}).get('driver', {})
    n = run.get('node_counters', {}).get('direction', {})
    if 'rate_hz' not in d or 'rate_hz' not in n:
        return "The nodes' counters were not available for this run."
    return (f'Where scans are lost: the driver decoded {d["rate_hz"]:.0f} Hz of the '
            f'{run["rate_hz"]:.0f} Hz sent and saw {d.get("sequence gaps", 0)} sequence gaps '
            '(the simulator drops whole frames when its pty is full because the driver did not '
            f'read in time); the direction node processed {n["rate_hz"]:.0f} Hz (its '
            'sensor-data subscription keeps 5 scans: when it is not scheduled for 5 scan '
            'periods the oldest go); the subscriber received contacts at '
            f'{run["received_rate_hz"]:.0f} Hz. The direction node reported a mean estimator '
            f'cost of {n.get("mean_cost_us_last_period", float("nan")):.0f} us under this load '
            f'(max {n.get("max_cost_us_last_period", float("nan")):.0f} us).')


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
        methods = bench_core.bench_methods()
        log('1. accuracy against speed')
        rows = bench_core.accuracy_speed(cfg['grids'], cfg['shifts'], cfg['noises'],
                                         cfg['frames'], methods, seed=args.seed, log=log)
        res['accuracy'] = {'grids': cfg['grids'], 'shifts_taxels': cfg['shifts'],
                           'noise_counts': cfg['noises'], 'frames': cfg['frames'],
                           'methods': methods, 'skimage_upsample': bench_core.SKIMAGE_UPSAMPLE,
                           'rows': rows,
                           'summary': bench_core.pareto_summary(rows, methods, cfg['grids'])}
        log("2. the seed's experiment")
        res['seed'] = bench_core.seed_experiment(cfg['seed_repeats'], cfg['random_frames'],
                                                 seed=args.seed)
        log('5. the skin family')
        res['family'] = bench_core.family(cfg['family_sizes'],
                                          bench_core.family_methods(cfg['family_all_methods']),
                                          seed=args.seed, log=log)
        log('4. scale')
        res['scaling'] = bench_core.scaling(cfg['scale_grids'], cfg['contacts'],
                                            [DEFAULT_METHOD, 'seed'], cfg['scale_frames'],
                                            cfg['scale_repeats'], seed=args.seed, log=log)
    finally:
        # The ROS processes must not inherit the pin: they share the machine as deployed.
        os.sched_setaffinity(0, everything)
    if not args.skip_ros:
        log('3. end to end through ROS')
        res['e2e'] = _e2e(cfg, args, log)
    res['how'] = {
        'command': 'python -m skin_driver.bench' + (' --quick' if args.quick else '')
        + (' --skip-ros' if args.skip_ros else '') + ('' if args.profile else ' --no-profile'),
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


def _e2e(cfg, args, log) -> dict:
    from . import bench_ros
    workdir = tempfile.mkdtemp(prefix='skin_bench_')
    try:
        runs, _ = bench_ros.end_to_end(cfg['rates'], cfg['e2e_seconds'], cfg['e2e_warmup'],
                                       workdir, log=log)
        out = {'seconds': cfg['e2e_seconds'], 'warmup_s': cfg['e2e_warmup'], 'runs': runs,
               'cores': os.cpu_count(), 'load': [round(v, 2) for v in os.getloadavg()]}
        log('   stage costs')
        out['stage_costs_us'] = bench_ros.stage_costs(cfg['stage_repeats'])
        if args.profile:
            log('   profiled run at 2 kHz')
            _, profiles = bench_ros.end_to_end([2000.0], cfg['e2e_seconds'] / 2, 1.0, workdir,
                                               profile=True, log=log)
            out['profiles'] = profiles
        out['why'] = why_e2e(out)
        return out
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


def write(res, out_dir) -> None:
    """Write the JSON, the plots and the Markdown report into out_dir."""
    os.makedirs(out_dir, exist_ok=True)
    images = {}
    if 'accuracy' in res:
        images['pareto'] = bench_report.plot_pareto(res['accuracy']['summary'], out_dir)
    if 'seed' in res:
        images['seed_shifts'] = bench_report.plot_seed_shifts(res['seed']['raw_shifts_taxels'],
                                                              out_dir)
    if 'scaling' in res:
        images['scaling'] = bench_report.plot_scaling(res['scaling'], out_dir)
    if 'family' in res:
        images['sigma'] = bench_report.plot_sigma(res['family']['sigma_vs_error'], out_dir)
    if 'e2e' in res:
        images['e2e'] = bench_report.plot_e2e(res['e2e']['runs'], out_dir)
    res['images'] = images
    with open(os.path.join(out_dir, 'benchmarks.json'), 'w') as f:
        json.dump(_json_safe(res), f, indent=1, default=float)
        f.write('\n')
    with open(os.path.join(out_dir, 'benchmarks.md'), 'w') as f:
        f.write(bench_report.markdown(res, images))


def main(argv=None) -> int:
    """Run the benchmark from the command line."""
    parser = argparse.ArgumentParser(prog='python -m skin_driver.bench',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='about a minute, small samples')
    parser.add_argument('--out', default=None,
                        help='output directory (default: docs/, or log/bench-quick with --quick '
                             'so that a quick run never replaces the committed report)')
    parser.add_argument('--skip-ros', action='store_true', help='leave out the ROS chain')
    parser.add_argument('--no-profile', dest='profile', action='store_false',
                        help='leave out the profiled 2 kHz run')
    parser.add_argument('--seed', type=int, default=0, help='random seed (0)')
    args = parser.parse_args(argv)
    if args.quick:
        args.profile = False
    if args.out is None:
        quick_out = os.path.join(os.path.dirname(DOCS), 'log', 'bench-quick')
        args.out = quick_out if args.quick else DOCS
    res = run(args)
    write(res, args.out)
    print(f'wrote {os.path.join(args.out, "benchmarks.md")} in {res["elapsed_s"]:.0f} s')
    for t in res['targets']:
        print(f'  {"ok  " if t["met"] else "MISS"} {t["name"]}: {t["measured"]} ({t["limit"]})')
    return 0 if math.isfinite(res['elapsed_s']) else 1


if __name__ == '__main__':
    sys.exit(main())
