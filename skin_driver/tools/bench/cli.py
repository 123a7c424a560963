"""
`make bench`: error against speed, the seed's experiment, end to end, scale, the skin family.

Usage::

    python -m skin_driver.tools.bench.cli [--quick] [--out DIR] [--skip-ros] [--no-profile]

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

from skin_driver.core.estimation.shift import DEFAULT_METHOD
from skin_driver.tools.bench import estimators as bench_core, report as bench_report
from skin_driver.tools.bench.report import label
from skin_driver.tools.evaluate.tables import json_safe

DOCS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), 'docs')

FULL = {
    'grids': [16, 32, 64, 128], 'shifts': [0.2, 0.5, 1.0, 2.0, 3.0], 'noises': [0.0, 6.0, 20.0],
    'frames': 24, 'seed_repeats': 20, 'random_frames': 400,
    'scale_grids': [16, 32, 64, 128], 'contacts': [1, 2, 3, 4, 5, 6, 7, 8],
    'scale_frames': 10, 'scale_repeats': 5,
    'rates': [1000.0, 2000.0], 'e2e_seconds': 60.0, 'e2e_warmup': 3.0, 'priorities': [0, 50],
    'stage_repeats': 1000,
    'family_sizes': {'paper': 8, 'random': 150, 'border': 80, 'multi': 80},
    'family_all_methods': True,
}
QUICK = {
    'grids': [16, 32], 'shifts': [0.5, 2.0], 'noises': [6.0], 'frames': 3,
    'seed_repeats': 3, 'random_frames': 50,
    'scale_grids': [16, 32], 'contacts': [1, 4], 'scale_frames': 3, 'scale_repeats': 2,
    'rates': [1000.0, 2000.0], 'e2e_seconds': 3.0, 'e2e_warmup': 1.0, 'stage_repeats': 100,
    'priorities': [0],
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
        out += e2e_targets(res['e2e'])
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
        out.append(_target(f'family {kind}: error default / plain centroid (worst skin)', r,
                           '<= 1',
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


# CPU per scan allowed to the hot path at 16 x 16 with one press, and the latency limit.
HOT_PATH_US = 250.0
P99_MS = 2.0


def e2e_targets(e2e) -> list:
    """Return the real-time targets per layout and rate: nothing lost, p99, hot-path CPU."""
    out = []
    for r in e2e['runs']:
        name = f'{label(r)} at {r["rate_hz"] / 1000:g} kHz'
        lost = r['lost']
        out.append(_target(f'{name}: scans lost in {r["seconds"]:g} s', lost, '0', lost == 0,
                           f'of {r["expected_scans"]} ({100 * lost / r["expected_scans"]:.2f} %)'
                           if lost else '', '.0f'))
        p99 = r['latency_ms']['p99']
        out.append(_target(f'{name}: p99 latency, last byte -> subscriber', p99,
                           f'<= {P99_MS:g} ms', p99 is not None and p99 <= P99_MS,
                           f'{p99 / P99_MS:.1f} x the limit' if p99 and p99 > P99_MS else '',
                           '.2f'))
        cpu = hot_path_us(r)
        out.append(_target(f'{name}: hot path CPU per scan', cpu, f'<= {HOT_PATH_US:g} us',
                           cpu <= HOT_PATH_US, f'{cpu / HOT_PATH_US:.2f} x the limit'
                           if cpu > HOT_PATH_US else 'whole process', '.0f'))
    return out


def hot_path_us(run) -> float:
    """Return the CPU per scan of the processes a scan passes through on its way to contacts."""
    return sum(v for k, v in run['cpu_us_per_scan'].items() if k in ('driver', 'direction'))


def why_e2e(e2e) -> list:
    """Return where the time goes, from the measured figures, for every missed target."""
    stage = e2e['stage_costs_us']
    estimator = stage.get('estimator.process (1 contact)', 0.0)
    host = stage.get('EstimationHost.process (estimate + publish all three, reused messages)',
                     0.0)
    frame = stage.get('driver: skin_frame_to_msg + publish SkinFrame', 0.0)
    decode = stage.get('driver: decode', 0.0) + stage.get('driver: stamp + header', 0.0)
    lines = [
        f'In process, one core, least of five rounds: the estimator takes {estimator:.0f} us per '
        f'scan; EstimationHost.process (estimator, three messages filled and published) '
        f'{host:.0f} us; decoding and stamping {decode:.0f} us; building and publishing the '
        f'SkinFrame {frame:.0f} us. That is {decode + host + frame:.0f} us of work per scan in '
        "the fused driver before the kernel (pty reads) and the interpreter's thread switches.",
    ]
    for r in e2e['runs']:
        cpu = r['cpu_us_per_scan']
        total = sum(cpu.values())
        lines.append(
            f'{label(r)} at {r["rate_hz"]:g} Hz: CPU per scan '
            + ', '.join(f'{k} {v:.0f} us' for k, v in cpu.items())
            + f'; together {total * r["rate_hz"] / 1e4:.0f} % of one core of the '
            f'{e2e["cores"] * 100} % the machine has (load average {e2e["load"]}, other jobs '
            'included). ' + _losses(r))
    return lines


def tradeoffs(e2e) -> list:
    """Return what each layout costs and buys, with this run's figures."""
    runs = {(r['layout'], r['rate_hz'], r.get('priority', 0)): r for r in e2e['runs']}
    lines = []
    for rate, priority in sorted({(r['rate_hz'], r.get('priority', 0)) for r in e2e['runs']}):
        split, fused = runs.get(('split', rate, priority)), runs.get(('fused', rate, priority))
        if not (split and fused):
            continue
        how = f' (SCHED_FIFO {priority})' if priority else ''
        lines.append(
            f'At {rate:g} Hz{how} the fused driver used {hot_path_us(fused):.0f} us of CPU per '
            f'scan against {hot_path_us(split):.0f} us for driver + direction node split '
            f'({hot_path_us(fused) / max(hot_path_us(split), 1e-9):.2f} x); p99 '
            f'{_f(fused["latency_ms"]["p99"])} ms against {_f(split["latency_ms"]["p99"])} ms; '
            f'lost {fused["lost"]} against {split["lost"]} scans.')
    lines += [
        'Fused saves, per scan, the SkinFrame message (built, serialised, sent, received, '
        "deserialised) and one wake-up of rclpy's Python executor, which dominated the split "
        'layout; the contacts leave the process as soon as the estimate is done.',
        'Fused costs: estimation runs on the thread that reads the port, so a slow scan delays '
        'the reads behind it (the kernel and the board buffer them: a 64 kB pty or USB buffer '
        'holds ~60 scans at 16 x 16); a crash in estimation takes the link down with it; and '
        "the driver process needs the estimator's dependencies (OpenCV, numpy).",
        'Split is for recorded frames (`ros2 bag play` of `frame`), for running the estimator '
        'on another machine than the serial port, and for rates up to a few hundred hertz, '
        'where its cost does not matter; the direction node and the fused driver share one '
        'implementation (`skin_driver/estimation_host.py`), so parameters, `~/tare`, '
        '`~/calibrate`, diagnostics and topic names are the same either way.',
        'Both skip the serialisation of topics nobody subscribes to (frame, contact, wrench, '
        'contacts are each checked per scan): the CPU figures above have one subscriber, on '
        '`contacts`; a controller on `wrench` as well adds the "publish contact + wrench" '
        'stage cost, a recorder on `frame` the SkinFrame stage cost.',
    ]
    return lines


def _f(v, spec='.2f') -> str:
    return '-' if v is None else format(v, spec)


def _losses(r) -> str:
    """Return where the lost scans of one run went, from the nodes' own counters."""
    if not r['lost']:
        return 'Nothing lost.'
    parts = [f'{r["lost"]} scans lost']
    if r['sim_frames_dropped']:
        parts.append(f'the simulator could not write {r["sim_frames_dropped"]} (pty full: the '
                     'driver did not read in time)')
    if r['driver_decoded_hz'] is not None:
        parts.append(f'the driver decoded {r["driver_decoded_hz"]:.0f} Hz')
    if r['estimated_hz'] is not None:
        parts.append(f'the estimation ran at {r["estimated_hz"]:.0f} Hz')
    parts.append(f'the subscriber received {r["received_rate_hz"]:.0f} Hz (its sensor-data '
                 'queue keeps 5: a subscriber not scheduled for 5 scan periods loses the oldest)')
    return '; '.join(parts) + '.'


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
        'command': 'python -m skin_driver.tools.bench.cli' + (' --quick' if args.quick else '')
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
    from skin_driver.tools.bench import end_to_end as bench_ros
    workdir = tempfile.mkdtemp(prefix='skin_bench_')
    try:
        load = [round(v, 2) for v in os.getloadavg()]
        runs = []
        for priority in cfg['priorities']:
            runs += bench_ros.end_to_end(cfg['rates'], cfg['e2e_seconds'], cfg['e2e_warmup'],
                                         workdir, log=log, priority=priority)[0]
        out = {'seconds': cfg['e2e_seconds'], 'warmup_s': cfg['e2e_warmup'], 'runs': runs,
               'cores': os.cpu_count(), 'load_before': load,
               'load': [round(v, 2) for v in os.getloadavg()]}
        log('   stage costs')
        out['stage_costs_us'] = bench_ros.stage_costs(cfg['stage_repeats'])
        if args.profile:
            log('   profiled split run at 2 kHz')
            _, profiles = bench_ros.end_to_end([2000.0], min(cfg['e2e_seconds'] / 2, 15.0), 1.0,
                                               workdir, layouts=('split',), profile=True,
                                               log=log)
            out['profiles'] = profiles
        out['why'] = why_e2e(out)
        out['tradeoffs'] = tradeoffs(out)
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
        json.dump(json_safe(res), f, indent=1, default=float)
        f.write('\n')
    with open(os.path.join(out_dir, 'benchmarks.md'), 'w') as f:
        f.write(bench_report.markdown(res, images))


def main(argv=None) -> int:
    """Run the benchmark from the command line."""
    parser = argparse.ArgumentParser(prog='python -m skin_driver.tools.bench.cli',
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
