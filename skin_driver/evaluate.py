"""
Evaluate direction estimators on an offline dataset and print the seed's Table 1.

Usage::

    python -m skin_driver.evaluate DATA.npz [--method NAME] [--json]
    python -m skin_driver.evaluate --generate seed|random OUT.npz [--seed N]

The alpha = 0 frames calibrate (x_p, y_p); every other frame's strongest contact is compared
with the ground-truth azimuth. With a ``split`` array (dataset format 2) only the calibration
frames (split = 1) calibrate, and more fully: alpha = 0 frames with ``force_n`` give (x_p, y_p)
and the force curves, tilted ones with ``force_n`` the compliance; only split = 0 frames are
scored. ``--calibration-frames`` adds such frames to a generated dataset. ROS-free.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from .core.estimation.dataset import Dataset, load_dataset, save_dataset
from .core.estimation.pipeline import ContactEstimator, EstimatorConfig
from .core.estimation.session import CalibrationRefused, CalibrationSession
from .core.estimation.shift import DEFAULT_METHOD, method_names
from .core.sim.experiments import (add_calibration_frames, make_random_experiment,
                                   make_seed_experiment)
from .core.sim.physics import SkinModel

__all__ = ['PAPER_TABLE', 'summarise', 'evaluate_method', 'evaluate', 'format_table', 'main']

# Table 1 of the seed paper (Sensors 2019, 19, 4697): beta -> (mean error, std), degrees.
PAPER_TABLE = {0.0: (0.96, 0.64), 45.0: (1.75, 1.13), 90.0: (5.65, 0.96), 135.0: (3.98, 1.13),
               180.0: (3.07, 4.74), 225.0: (2.87, 0.64), 270.0: (6.31, 0.66),
               315.0: (7.21, 13.34), 'summary': (3.72, 4.73)}


def _angle_error_deg(estimate_rad: float, truth_deg: float) -> float:
    return abs((math.degrees(estimate_rad) - truth_deg + 180.0) % 360.0 - 180.0)


def _groups(truth: np.ndarray) -> np.ndarray:
    """Return the group label (degrees) of each tilted frame: exact beta or the nearest 45."""
    unique = np.unique(np.round(truth, 6))
    if unique.size <= 16:
        return np.round(truth, 6)
    return (np.round(truth / 45.0) % 8) * 45.0


def _stats(errors: list) -> tuple:
    if not errors:
        return None, None
    e = np.asarray(errors)
    return float(e.mean()), float(e.std())


def summarise(truth_deg, estimate_deg) -> dict:
    """
    Return Table 1 figures from ground-truth and estimated azimuths in degrees.

    An estimate of NaN means no valid direction: it counts against the valid share only.
    Returns {'per_beta': [...], 'summary': {...}} with the keys documented in docs/dataset.md.
    """
    truth = np.asarray(truth_deg, dtype=np.float64)
    estimate = np.asarray(estimate_deg, dtype=np.float64)
    if truth.shape != estimate.shape or truth.ndim != 1:
        raise ValueError(f'truth and estimates must be two 1-D arrays of one length, got '
                         f'{truth.shape} and {estimate.shape}')
    groups = _groups(truth) if truth.size else truth
    per_group = {}
    errors_all = []
    for gt, est, g in zip(truth, estimate, groups):
        entry = per_group.setdefault(float(g), {'frames': 0, 'errors': []})
        entry['frames'] += 1
        if math.isfinite(est):
            err = _angle_error_deg(math.radians(est), float(gt))
            entry['errors'].append(err)
            errors_all.append(err)
    table = []
    for g in sorted(per_group):
        mean, std = _stats(per_group[g]['errors'])
        table.append({'beta_deg': g, 'frames': per_group[g]['frames'],
                      'valid': len(per_group[g]['errors']),
                      'mean_error_deg': mean, 'std_error_deg': std})
    mean, std = _stats(errors_all)
    valid = len(errors_all)
    return {
        'per_beta': table,
        'summary': {
            'frames': int(truth.size), 'valid': valid,
            'valid_share': valid / truth.size if truth.size else None,
            'mean_error_deg': mean, 'std_error_deg': std,
            'max_error_deg': float(max(errors_all)) if errors_all else None,
        },
    }


def _force_errors(data: Dataset, frames: np.ndarray, results: list) -> dict:
    """Return alpha and force-magnitude error statistics over the frames with a direction."""
    alpha_err, force_err = [], []
    for i, contacts in zip(frames, results):
        if not (contacts and contacts[0].direction_valid):
            continue
        c = contacts[0]
        alpha_err.append(math.degrees(c.alpha_rad) - float(data.alpha_deg[i]))
        if data.force_n is not None and data.force_n[i] > 0:
            magnitude = math.sqrt(sum(v * v for v in c.force_xyz_n))
            force_err.append(100.0 * (magnitude / float(data.force_n[i]) - 1.0))
    out = {}
    for key, unit, errors in (('alpha', 'deg', alpha_err), ('force', 'pct', force_err)):
        e = np.asarray(errors)
        out[f'{key}_mean_error_{unit}'] = float(np.abs(e).mean()) if e.size else None
        out[f'{key}_std_error_{unit}'] = float(np.abs(e).std()) if e.size else None
        out[f'{key}_bias_{unit}'] = float(e.mean()) if e.size else None
    return out


def _run_session(est: ContactEstimator, data: Dataset, frames: np.ndarray, kind: str,
                 **session_args) -> str:
    """Calibrate ``kind`` from single frames at full load; put it in force; return a note."""
    try:
        session = CalibrationSession(est, kind, presses=frames.size, **session_args)
    except CalibrationRefused as err:
        return f'{kind}: refused: {err}'
    for i in frames:
        top, bottom = data.top[i], data.bottom[i]
        session.add_press(session.record(top, bottom, est.process(top, bottom)))
    try:
        outcome = session.finish()
    except CalibrationRefused as err:
        return f'{kind}: refused: {err}'
    est.calibration = outcome.calibration
    return f'{kind}: {outcome.message}'


def calibrate_from_frames(est: ContactEstimator, data: Dataset, frames: np.ndarray,
                          full: bool) -> list:
    """
    Calibrate ``est`` from ``frames`` of ``data``; return one note per part.

    Always (x_p, y_p) from the alpha = 0 frames; with ``full`` and ``force_n`` also the force
    curves from them and the compliance from the tilted frames. A refused part is noted and
    the estimator keeps what it had.
    """
    normal = frames[data.alpha_deg[frames] == 0]
    tilted = frames[data.alpha_deg[frames] > 0]
    notes = [_run_session(est, data, normal, 'offset', max_std_m=math.inf)]
    if full and data.force_n is not None:
        known = normal[data.force_n[normal] > 0]
        notes.append(_run_session(est, data, known, 'force', forces_n=data.force_n[known]))
        tilted = tilted[data.force_n[tilted] > 0]
        notes.append(_run_session(est, data, tilted, 'compliance',
                                  forces_n=data.force_n[tilted],
                                  alphas_rad=np.radians(data.alpha_deg[tilted])))
    return notes


def evaluate_method(data: Dataset, method: str, config: EstimatorConfig = None) -> dict:
    """Return the Table 1 figures of one estimator on ``data`` (see docs/dataset.md)."""
    base = config or EstimatorConfig(pitch_m=data.pitch_m)
    cfg = EstimatorConfig(**{**base.__dict__, 'method': method, 'pitch_m': data.pitch_m})
    est = ContactEstimator(cfg)
    if data.tare_top is not None:
        est.tare(data.tare_top, data.tare_bottom)
    everything = np.arange(data.frames)
    if data.split is None:
        notes = calibrate_from_frames(est, data, everything, full=False)
        scored = everything
    else:
        notes = calibrate_from_frames(est, data, everything[data.split == 1], full=True)
        scored = everything[data.split == 0]
    tilted = scored[data.alpha_deg[scored] > 0]
    if tilted.size:
        est.process(data.top[tilted[0]], data.bottom[tilted[0]])  # warm the per-shape caches
    start = time.perf_counter()
    results = [est.process(data.top[i], data.bottom[i]) for i in tilted]
    elapsed = time.perf_counter() - start
    estimates = [math.degrees(c[0].azimuth_rad) if c and c[0].direction_valid else math.nan
                 for c in results]
    report = summarise(data.azimuth_deg[tilted], estimates)
    report['summary']['us_per_frame'] = elapsed / tilted.size * 1e6 if tilted.size else None
    report['summary'].update(_force_errors(data, tilted, results))
    return {'method': method, 'calibration': est.calibration.to_dict(),
            'calibration_notes': notes, **report}


def evaluate(data: Dataset, method: str = DEFAULT_METHOD) -> dict:
    """Return the figures of ``method`` and of ``seed`` on ``data`` as one JSON-ready dict."""
    names = [method] if method == 'seed' else [method, 'seed']
    scored = np.ones(data.frames, dtype=bool) if data.split is None else data.split == 0
    tilted = (data.alpha_deg > 0) & scored
    # The paper's Table 1 is the eight azimuths at alpha = 45 deg: compare only like with like.
    seed_like = bool(tilted.any() and np.allclose(data.alpha_deg[tilted], 45.0)
                     and set(np.round(data.azimuth_deg[tilted], 6)) <= set(PAPER_TABLE))
    return {
        'frames': data.frames, 'shape': list(data.shape), 'pitch_m': data.pitch_m,
        'seed_experiment': seed_like,
        'normal_frames': int((data.alpha_deg == 0).sum()),
        'tilted_frames': int((data.alpha_deg > 0).sum()),
        'calibration_frames': 0 if data.split is None else int(data.split.sum()),
        'methods': {n: evaluate_method(data, n) for n in names},
    }


def _fmt(v, spec='.2f') -> str:
    return '-' if v is None else format(v, spec)


def format_table(report: dict) -> str:
    """
    Return the side-by-side text table of an :func:`evaluate` report.

    When the directions are the paper's eight, its published Table 1 stands in the last column.
    """
    names = list(report['methods'])
    lines = []
    if 'frames' in report:
        cal = report.get('calibration_frames')
        lines += [f'frames {report["frames"]} ({report["normal_frames"]} normal, '
                  f'{report["tilted_frames"]} tilted'
                  + (f'; {cal} of them calibrate, the rest are scored' if cal else '')
                  + f'), map {report["shape"][0]}x{report["shape"][1]}', '']
    betas = {r['beta_deg'] for n in names for r in report['methods'][n]['per_beta']}
    paper = report.get('seed_experiment', True) and betas and betas <= set(PAPER_TABLE)
    head = f'{"beta [deg]":>10}' + ''.join(f'{n + " mean":>16}{"std":>8}{"valid":>8}'
                                           for n in names)
    lines.append(head + (f'{"paper mean":>13}{"std":>8}' if paper else ''))
    rows = {}
    for n in names:
        for r in report['methods'][n]['per_beta']:
            rows.setdefault(r['beta_deg'], {})[n] = r
    for beta in sorted(rows):
        line = f'{beta:>10.1f}'
        for n in names:
            r = rows[beta].get(n)
            line += (f'{_fmt(r and r["mean_error_deg"]):>16}{_fmt(r and r["std_error_deg"]):>8}'
                     f'{(str(r["valid"]) + "/" + str(r["frames"])) if r else "-":>8}')
        if paper:
            line += f'{PAPER_TABLE[beta][0]:>13.2f}{PAPER_TABLE[beta][1]:>8.2f}'
        lines.append(line)
    line = f'{"summary":>10}'
    for n in names:
        s = report['methods'][n]['summary']
        line += f'{_fmt(s["mean_error_deg"]):>16}{_fmt(s["std_error_deg"]):>8}' \
                f'{_fmt(s["valid_share"] and 100 * s["valid_share"], ".1f") + "%":>8}'
    if paper:
        line += f'{PAPER_TABLE["summary"][0]:>13.2f}{PAPER_TABLE["summary"][1]:>8.2f}'
    lines.append(line)
    lines.append('')
    for n in names:
        s = report['methods'][n]['summary']
        cost = (f', {_fmt(s["us_per_frame"], ".1f")} us per frame (contacts included)'
                if s.get('us_per_frame') is not None else '')
        lines.append(f'{n}: max error {_fmt(s["max_error_deg"])} deg{cost}')
        if s.get('alpha_mean_error_deg') is not None:
            force = ''
            if s.get('force_mean_error_pct') is not None:
                force = (f'; |force| error {_fmt(s["force_mean_error_pct"])} % '
                         f'(std {_fmt(s["force_std_error_pct"])}, '
                         f'bias {_fmt(s["force_bias_pct"], "+.2f")})')
            lines.append(f'{" " * len(n)}  alpha error {_fmt(s["alpha_mean_error_deg"])} deg '
                         f'(std {_fmt(s["alpha_std_error_deg"])}, '
                         f'bias {_fmt(s["alpha_bias_deg"], "+.2f")}){force}')
    for n in names:
        for note in report['methods'][n].get('calibration_notes', [])[1:]:
            lines.append(f'{n} calibration, {note}')
    if paper:
        lines.append('paper: Klimaszewski et al., Sensors 2019, 19, 4697, Table 1 '
                     '(real skin, Fanuc robot, alpha = 45 deg)')
    return '\n'.join(lines)


def _json_safe(obj):
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def main(argv=None) -> int:
    """Run the command line; return the exit status."""
    parser = argparse.ArgumentParser(prog='python -m skin_driver.evaluate',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('data', nargs='?', help='dataset .npz to evaluate')
    parser.add_argument('--method', default=DEFAULT_METHOD, choices=method_names())
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--generate', nargs=2, metavar=('KIND', 'OUT'),
                        help='write a simulated dataset (KIND seed or random) and exit')
    parser.add_argument('--seed', type=int, default=0, help='random seed for --generate')
    parser.add_argument('--calibration-frames', action='store_true',
                        help='with --generate: put 16 normal presses over 5-60 N and 16 tilted '
                        'presses of known load in front, as calibration frames (split = 1)')
    args = parser.parse_args(argv)
    if args.generate:
        kind, out = args.generate
        rng = np.random.default_rng(args.seed)
        if kind == 'seed':
            data = make_seed_experiment(rng=rng)
        elif kind == 'random':
            data = make_random_experiment(rng=rng)
        else:
            parser.error(f'--generate KIND must be seed or random, got {kind!r}')
        if args.calibration_frames:
            data = add_calibration_frames(data, SkinModel(misalignment_m=(3e-4, -2e-4)), rng)
        save_dataset(out, data)
        print(f'wrote {data.frames} frames to {out}')
        return 0
    if not args.data:
        parser.error('give a dataset .npz (or --generate KIND OUT)')
    try:
        data = load_dataset(args.data)
    except (OSError, ValueError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    report = evaluate(data, args.method)
    if args.json:
        print(json.dumps(_json_safe({'dataset': args.data, **report})))
    else:
        print(format_table(report))
    return 0


if __name__ == '__main__':
    sys.exit(main())
