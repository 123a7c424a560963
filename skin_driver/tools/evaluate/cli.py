"""
Evaluate direction estimators on an offline dataset and print the seed's Table 1.

Usage::

    python -m skin_driver.evaluate DATA.npz [--method NAME] [--params FILE] [--contacts OUT.csv]
                                            [--json]
    python -m skin_driver.evaluate --skin NAME [--scene KIND] [--size N] [--seed N] [...]
    python -m skin_driver.evaluate --generate KIND OUT.npz [--skin NAME] [--size N] [--seed N]
    python -m skin_driver.evaluate --list-skins | --list-methods

The single normal presses calibrate (x_p, y_p); every single tilted press's strongest contact is
compared with the ground-truth azimuth; frames with several presses are matched press by press
(docs/dataset.md). With a ``split`` array (dataset format 2) only the calibration frames
(split = 1) calibrate, and more fully: alpha = 0 frames with ``force_n`` give (x_p, y_p) and the
force curves, tilted ones with ``force_n`` the compliance; only split = 0 frames are scored.
``--calibration-frames`` adds such frames to a generated dataset. ROS-free.
"""

from __future__ import annotations

import argparse
import csv
from dataclasses import dataclass
import json
import math
import sys
import time

import numpy as np

from skin_driver.core.estimation.atomic import write_atomically
from skin_driver.core.estimation.calibration import calibrate_from_shifts, Calibration
from skin_driver.core.estimation.dataset import Dataset, load_dataset, PRESS_FIELDS, save_dataset
from skin_driver.core.estimation.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.estimation.session import CalibrationRefused, CalibrationSession
from skin_driver.core.estimation.shift import DEFAULT_METHOD, method_names
from skin_driver.core.sim.experiments import add_calibration_frames, make_scene, SCENE_KINDS
from skin_driver.core.sim.skins import family_skin, HELD_OUT, skin_names
from skin_driver.ros.estimator_params import estimator_config, load_direction_parameters

__all__ = ['PAPER_TABLE', 'CONTACT_COLUMNS', 'MethodRun', 'summarise', 'calibrated_estimator',
           'run_method', 'score_run', 'evaluate_method', 'evaluate', 'match_presses',
           'direction_errors', 'write_contacts', 'format_table', 'main']

# Table 1 of the seed paper (Sensors 2019, 19, 4697): beta -> (mean error, std), degrees.
PAPER_TABLE = {0.0: (0.96, 0.64), 45.0: (1.75, 1.13), 90.0: (5.65, 0.96), 135.0: (3.98, 1.13),
               180.0: (3.07, 4.74), 225.0: (2.87, 0.64), 270.0: (6.31, 0.66),
               315.0: (7.21, 13.34), 'summary': (3.72, 4.73)}
# A contact stands for a press when it lies within this many taxels of it.
MATCH_RADIUS_TAXELS = 1.5
# Presses at least this many taxels apart must come out as separate contacts.
SEPARATE_TAXELS = 3.0


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


@dataclass(frozen=True)
class MethodRun:
    """One estimator run over the scored frames of a dataset: its calibration and contacts."""

    method: str
    calibration: Calibration
    contacts: list
    us_per_frame: float
    notes: tuple = ()


def press_counts(data: Dataset) -> np.ndarray:
    """Return the number of presses of each frame (1 where the dataset has no press arrays)."""
    if data.press_x_m is None:
        return np.ones(data.frames, dtype=int)
    return np.isfinite(data.press_x_m).sum(axis=1)


def scored_part(data: Dataset) -> Dataset:
    """Return the frames of ``data`` that are scored: all, or those with split = 0."""
    if data.split is None:
        return data
    keep = np.flatnonzero(data.split == 0)
    per_frame = ('top', 'bottom', 'azimuth_deg', 'alpha_deg', 'force_n', 'x_m', 'y_m',
                 *PRESS_FIELDS)
    fields = {k: (None if getattr(data, k) is None else getattr(data, k)[keep])
              for k in per_frame}
    return Dataset(pitch_m=data.pitch_m, tare_top=data.tare_top, tare_bottom=data.tare_bottom,
                   **fields)


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


def calibrate_from_frames(est: ContactEstimator, data: Dataset, frames: np.ndarray) -> list:
    """
    Calibrate ``est`` fully from the calibration ``frames`` of ``data``; return a note per part.

    (x_p, y_p) and, with ``force_n``, the force curves from the alpha = 0 frames, the compliance
    from the tilted ones. A refused part is noted and the estimator keeps what it had.
    """
    normal = frames[data.alpha_deg[frames] == 0]
    tilted = frames[data.alpha_deg[frames] > 0]
    notes = [_run_session(est, data, normal, 'offset', max_std_m=math.inf)]
    if data.force_n is not None:
        known = normal[data.force_n[normal] > 0]
        notes.append(_run_session(est, data, known, 'force', forces_n=data.force_n[known]))
        tilted = tilted[data.force_n[tilted] > 0]
        notes.append(_run_session(est, data, tilted, 'compliance',
                                  forces_n=data.force_n[tilted],
                                  alphas_rad=np.radians(data.alpha_deg[tilted])))
    return notes


def calibrated_estimator(data: Dataset, method: str, config: EstimatorConfig = None,
                         notes: list = None, **override) -> ContactEstimator:
    """
    Return estimator ``method`` (``config`` gives its other settings) made ready for ``data``.

    Tared from the dataset's tare frames. With a ``split``, calibrated fully from the split = 1
    frames (:func:`calibrate_from_frames`, its notes appended to ``notes``); without, (x_p, y_p)
    from the single normal presses (none: uncalibrated). ``override`` goes to
    :class:`ContactEstimator` (the benchmark swaps in reference shift methods that are not
    registered).
    """
    base = config or EstimatorConfig(pitch_m=data.pitch_m)
    cfg = EstimatorConfig(**{**base.__dict__, 'method': method, 'pitch_m': data.pitch_m})
    est = ContactEstimator(cfg, **override)
    if data.tare_top is not None:
        est.tare(data.tare_top, data.tare_bottom)
    if data.split is not None:
        found = calibrate_from_frames(est, data, np.flatnonzero(data.split == 1))
        if notes is not None:
            notes.extend(found)
    else:
        normal = np.flatnonzero((data.alpha_deg == 0) & (press_counts(data) == 1))
        shifts = []
        for i in normal:
            s = est.measure_shifts(data.top[i], data.bottom[i])
            if s:
                shifts.append(s[0])
        # Without a single normal press the layers are taken as aligned (calibration.presses 0).
        calibration = (calibrate_from_shifts(np.array(shifts).reshape(-1, 2),
                                             max_std_m=math.inf)
                       if shifts else Calibration())
        est = ContactEstimator(cfg, calibration, est.conditioner, **override)
    est.process(data.top[0], data.bottom[0])  # warm the per-shape caches
    return est


def run_method(data: Dataset, method: str, config: EstimatorConfig = None) -> MethodRun:
    """
    Run estimator ``method`` (see :func:`calibrated_estimator`) over the scored frames.

    Its contacts are those of :func:`scored_part` ``(data)``, frame by frame.
    """
    notes = []
    est = calibrated_estimator(data, method, config, notes)
    data = scored_part(data)
    start = time.perf_counter()
    contacts = [est.process(data.top[i], data.bottom[i]) for i in range(data.frames)]
    elapsed = time.perf_counter() - start
    return MethodRun(method, est.calibration, contacts, elapsed / data.frames * 1e6, tuple(notes))


def match_presses(presses: list, contacts: list, pitch_m: float) -> list:
    """
    Return, for each press, the index of its contact (or None), matched one to one by location.

    Closest pairs first, within ``MATCH_RADIUS_TAXELS`` taxels of the press.
    """
    pairs = sorted((math.hypot(c.x_m - p['x_m'], c.y_m - p['y_m']), i, j)
                   for i, p in enumerate(presses) for j, c in enumerate(contacts))
    out = [None] * len(presses)
    used = set()
    for d, i, j in pairs:
        if d <= MATCH_RADIUS_TAXELS * pitch_m and out[i] is None and j not in used:
            out[i] = j
            used.add(j)
    return out


def _between(pa: dict, pb: dict, contacts: list, pitch_m: float) -> bool:
    """
    Return whether a contact lies between two presses, off both ends: it stands for both.

    A merged contact's centroid moves from the stronger press towards the weaker one by the
    weaker one's share of the force; a contact at one end is that press's alone.
    """
    ax, ay, bx, by = pa['x_m'], pa['y_m'], pb['x_m'], pb['y_m']
    length2 = (bx - ax) ** 2 + (by - ay) ** 2
    if length2 == 0:
        return False
    for c in contacts:
        t = ((c.x_m - ax) * (bx - ax) + (c.y_m - ay) * (by - ay)) / length2
        off_line = math.hypot(c.x_m - ax - t * (bx - ax), c.y_m - ay - t * (by - ay))
        if 0.1 <= t <= 0.9 and off_line <= MATCH_RADIUS_TAXELS * pitch_m:
            return True
    return False


def direction_errors(data: Dataset, run: MethodRun, frames=None) -> list:
    """
    Return (frame, press index, error in degrees or None, contact) for every tilted press.

    The contact is the one matched by location (None when none is); the error is None when it
    has no valid direction. ``frames`` limits the frames looked at (default all).
    """
    out = []
    for i in range(data.frames) if frames is None else frames:
        presses = data.presses(i)
        contacts = run.contacts[i]
        if len(presses) == 1:
            # One press: its contact is the strongest, wherever it is (the Table 1 rule).
            matched = [0 if contacts else None]
        else:
            matched = match_presses(presses, contacts, data.pitch_m)
        for k, (press, j) in enumerate(zip(presses, matched)):
            if not press['alpha_deg'] > 0:
                continue
            c = None if j is None else contacts[j]
            err = (_angle_error_deg(c.azimuth_rad, press['azimuth_deg'])
                   if c is not None and c.direction_valid else None)
            out.append((i, k, err, c))
    return out


def _pair_stats(data: Dataset, run: MethodRun, frames) -> dict:
    """Return how pairs of presses far apart (>= 3 taxels) and close (2..3) were separated."""
    counts = dict.fromkeys(('far', 'far_separate', 'far_merged', 'close', 'close_separate'), 0)
    for i in frames:
        presses = data.presses(i)
        contacts = run.contacts[i]
        matched = match_presses(presses, contacts, data.pitch_m)
        for a in range(len(presses)):
            for b in range(a + 1, len(presses)):
                pa, pb = presses[a], presses[b]
                gap = math.hypot(pa['x_m'] - pb['x_m'], pa['y_m'] - pb['y_m']) / data.pitch_m
                kind = 'far' if gap >= SEPARATE_TAXELS else 'close'
                counts[kind] += 1
                separate = matched[a] is not None and matched[b] is not None
                counts[kind + '_separate'] += separate
                if kind == 'far' and not separate:
                    counts['far_merged'] += _between(pa, pb, contacts, data.pitch_m)
    share = (lambda k, n: counts[k] / counts[n] if counts[n] else None)
    return {'pairs_far': counts['far'], 'separate_share_far': share('far_separate', 'far'),
            'merged_share_far': share('far_merged', 'far'), 'pairs_close': counts['close'],
            'separate_share_close': share('close_separate', 'close')}


def score_presses(data: Dataset, run: MethodRun) -> dict:
    """
    Return the multi-press figures over the frames holding two or more presses (or None).

    Keys are documented in docs/dataset.md (``methods.NAME.presses``).
    """
    frames = np.flatnonzero(press_counts(data) >= 2)
    if frames.size == 0:
        return None
    found = total = 0
    for i in frames:
        matched = match_presses(data.presses(i), run.contacts[i], data.pitch_m)
        total += len(matched)
        found += sum(j is not None for j in matched)
    rows = direction_errors(data, run, frames)
    errors = [e for _, _, e, _ in rows if e is not None]
    weaker = [e for _, k, e, _ in rows if e is not None and k > 0]
    mean, std = _stats(errors)
    return {
        'frames': int(frames.size), 'presses': total,
        'found_share': found / total if total else None,
        **_pair_stats(data, run, frames),
        'tilted_presses': len(rows), 'valid_share': len(errors) / len(rows) if rows else None,
        'mean_error_deg': mean, 'std_error_deg': std,
        'max_error_deg': float(max(errors)) if errors else None,
        'weaker_mean_error_deg': _stats(weaker)[0],
    }


def _large_shift_valid(data: Dataset, run: MethodRun, frames: np.ndarray) -> dict:
    """Return the valid share of the single tilted presses whose true shift is >= 1 taxel."""
    if data.press_shift_m is None:
        return {'large_shift_frames': None, 'large_shift_valid_share': None}
    large = [i for i in frames if data.press_shift_m[i, 0] >= data.pitch_m]
    valid = sum(bool(run.contacts[i] and run.contacts[i][0].direction_valid) for i in large)
    return {'large_shift_frames': len(large),
            'large_shift_valid_share': valid / len(large) if large else None}


def score_run(data: Dataset, run: MethodRun) -> dict:
    """Return the figures of one run: Table 1 over the single tilted presses, then the rest."""
    tilted = np.flatnonzero((data.alpha_deg > 0) & (press_counts(data) == 1))
    results = [run.contacts[i] for i in tilted]
    estimates = [math.degrees(c[0].azimuth_rad) if c and c[0].direction_valid else math.nan
                 for c in results]
    report = summarise(data.azimuth_deg[tilted], estimates)
    report['summary']['us_per_frame'] = run.us_per_frame
    report['summary'].update(_force_errors(data, tilted, results))
    report['summary'].update(_large_shift_valid(data, run, tilted))
    return {'method': run.method, 'calibration': run.calibration.to_dict(),
            'calibration_notes': list(run.notes), **report, 'presses': score_presses(data, run)}


def evaluate_method(data: Dataset, method: str, config: EstimatorConfig = None) -> dict:
    """Return the figures of one estimator on ``data`` (see docs/dataset.md)."""
    return score_run(scored_part(data), run_method(data, method, config))


def _seed_like(data: Dataset) -> bool:
    """Return whether the single tilted presses are the paper's (alpha = 45 deg, eight betas)."""
    tilted = (data.alpha_deg > 0) & (press_counts(data) == 1)
    return bool(tilted.any() and np.allclose(data.alpha_deg[tilted], 45.0)
                and set(np.round(data.azimuth_deg[tilted], 6)) <= set(PAPER_TABLE))


def evaluate(data: Dataset, method: str = DEFAULT_METHOD, config: EstimatorConfig = None,
             runs: dict = None) -> dict:
    """
    Return the figures of ``method`` and of ``seed`` on ``data`` as one JSON-ready dict.

    ``runs`` (a dict), when given, receives each :class:`MethodRun` by method name.
    """
    names = [method] if method == 'seed' else [method, 'seed']
    scored = scored_part(data)
    methods = {}
    for n in names:
        run = run_method(data, n, config)
        if runs is not None:
            runs[n] = run
        methods[n] = score_run(scored, run)
    single = press_counts(scored) == 1
    return {
        'frames': data.frames, 'shape': list(data.shape), 'pitch_m': data.pitch_m,
        'seed_experiment': _seed_like(scored),
        'normal_frames': int(((scored.alpha_deg == 0) & single).sum()),
        'tilted_frames': int(((scored.alpha_deg > 0) & single).sum()),
        'multi_press_frames': int((~single).sum()),
        'calibration_frames': 0 if data.split is None else int(data.split.sum()),
        'methods': methods,
    }


CONTACT_COLUMNS = ('frame', 'rank', 'x_m', 'y_m', 'force_n', 'azimuth_deg', 'alpha_deg',
                   'direction_valid', 'confidence', 'shift_x_m', 'shift_y_m',
                   'azimuth_sigma_deg')


def write_contacts(path, run: MethodRun) -> int:
    """Write one CSV row per reported contact of every frame (atomically); return the rows."""
    rows = []
    for frame, contacts in enumerate(run.contacts):
        for rank, c in enumerate(contacts):
            rows.append((frame, rank, c.x_m, c.y_m, c.force_n, math.degrees(c.azimuth_rad),
                         math.degrees(c.alpha_rad), int(c.direction_valid), c.confidence,
                         c.shift_m[0], c.shift_m[1], math.degrees(c.azimuth_sigma_rad)))

    def write(f):
        out = csv.writer(f, lineterminator='\n')
        out.writerow(CONTACT_COLUMNS)
        for row in rows:
            out.writerow([v if isinstance(v, int) else f'{v:.9g}' for v in row])
    write_atomically(path, write)
    return len(rows)


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
        multi = report.get('multi_press_frames')
        cal = report.get('calibration_frames')
        lines += [f'frames {report["frames"]} ({report["normal_frames"]} normal, '
                  f'{report["tilted_frames"]} tilted'
                  + (f', {multi} with several presses' if multi else '')
                  + (f'; {cal} more calibrate, the others are scored' if cal else '')
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
    if rows:
        lines.append(line)
    else:
        lines[-1] = 'no frame holds a single tilted press: no Table 1'
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
        lines += _extra_lines(n, report['methods'][n])
        for note in report['methods'][n].get('calibration_notes', []):
            lines.append(f'{n} calibration, {note}')
    if paper:
        lines.append('paper: Klimaszewski et al., Sensors 2019, 19, 4697, Table 1 '
                     '(real skin, Fanuc robot, alpha = 45 deg)')
    return '\n'.join(lines)


def _pct(v) -> str:
    return '-' if v is None else f'{100 * v:.1f} %'


def _extra_lines(name: str, method: dict) -> list:
    """Return the text lines of the large-shift valid share and the multi-press figures."""
    lines = []
    s = method['summary']
    if s.get('large_shift_frames'):
        lines.append(f'{name}: valid on {_pct(s["large_shift_valid_share"])} of the '
                     f'{s["large_shift_frames"]} single presses shifting >= 1 taxel')
    p = method.get('presses')
    if p:
        lines.append(f'{name}: {p["frames"]} frames with several presses: '
                     f'{_pct(p["found_share"])} of {p["presses"]} presses found; pairs >= '
                     f'{SEPARATE_TAXELS:g} taxels apart separate {_pct(p["separate_share_far"])} '
                     f'(merged {_pct(p["merged_share_far"])}, {p["pairs_far"]} pairs), '
                     f'closer {_pct(p["separate_share_close"])} ({p["pairs_close"]} pairs)')
        lines.append(f'{" " * len(name)}  per-press azimuth error {_fmt(p["mean_error_deg"])} '
                     f'deg (std {_fmt(p["std_error_deg"])}, weaker presses '
                     f'{_fmt(p["weaker_mean_error_deg"])}) on {_pct(p["valid_share"])} of '
                     f'{p["tilted_presses"]} tilted presses')
    return lines


def _json_safe(obj):
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='python -m skin_driver.evaluate',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('data', nargs='?', help='dataset .npz to evaluate')
    parser.add_argument('--method', default=None, choices=method_names(),
                        help=f"estimator (default: the --params file's, else {DEFAULT_METHOD})")
    parser.add_argument('--params', metavar='FILE',
                        help="the direction node's parameter file (config/skin.yaml format): "
                             'the estimator is configured as the node would be')
    parser.add_argument('--contacts', metavar='OUT.csv',
                        help="write every reported contact of every frame (the --method's)")
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--skin', metavar='NAME',
                        help='generate the data from this skin of the family (see --list-skins; '
                             'held_out:N for one drawn at random, seed N)')
    parser.add_argument('--scene', default='paper', choices=SCENE_KINDS,
                        help='scene kind rendered with --skin (default paper)')
    parser.add_argument('--size', type=int, default=None,
                        help='repeats (paper) or frames (other scenes) to render')
    parser.add_argument('--generate', nargs=2, metavar=('KIND', 'OUT'),
                        help=f'write a simulated dataset (KIND one of {", ".join(SCENE_KINDS)}) '
                             'of --skin (default: default) and exit')
    parser.add_argument('--seed', type=int, default=0, help='random seed for generated data')
    parser.add_argument('--calibration-frames', action='store_true',
                        help='with --generate: put 16 normal presses over 5-60 N and 16 tilted '
                        'presses of known load in front, as calibration frames (split = 1)')
    parser.add_argument('--list-skins', action='store_true', help='list the family and exit')
    parser.add_argument('--list-methods', action='store_true', help='list estimators and exit')
    return parser


def _config(args) -> EstimatorConfig:
    """Return the estimator settings of --params (pitch set per dataset later) or None."""
    if not args.params:
        return None
    values = load_direction_parameters(args.params)
    config = estimator_config(values, EstimatorConfig().pitch_m)
    if args.method is None:
        args.method = config.method
    return config


def main(argv=None) -> int:
    """Run the command line; return the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.list_skins:
        for name in skin_names():
            print(f'{name:12s} {family_skin(name).description}')
        print(f'{HELD_OUT + "N":12s} a skin drawn at random within these ranges (seed N)')
        return 0
    if args.list_methods:
        print('\n'.join(method_names()))
        return 0
    if args.skin:
        try:
            family_skin(args.skin)
        except ValueError as err:
            parser.error(str(err))
    rng = np.random.default_rng(args.seed)
    if args.generate:
        kind, out = args.generate
        if kind not in SCENE_KINDS:
            parser.error(f'--generate KIND must be one of {", ".join(SCENE_KINDS)}, got {kind!r}')
        data = make_scene(kind, args.skin or 'default', rng, args.size)
        if args.calibration_frames:
            data = add_calibration_frames(data, family_skin(args.skin or 'default').model, rng)
        save_dataset(out, data)
        print(f'wrote {data.frames} frames to {out}')
        return 0
    if bool(args.data) == bool(args.skin):
        parser.error('give a dataset .npz or --skin NAME (not both)')
    try:
        config = _config(args)
        if args.skin:
            data = make_scene(args.scene, args.skin, rng, args.size)
            source = f'skin {args.skin}, scene {args.scene}, seed {args.seed}'
        else:
            data = load_dataset(args.data)
            source = args.data
    except (OSError, ValueError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    method = args.method or DEFAULT_METHOD
    runs = {}
    report = evaluate(data, method, config, runs)
    if args.contacts:
        rows = write_contacts(args.contacts, runs[method])
        print(f'wrote {rows} contacts of {method} to {args.contacts}', file=sys.stderr)
    if args.json:
        print(json.dumps(_json_safe({'dataset': source, **report})))
    else:
        print(source)
        print(format_table(report))
    return 0


if __name__ == '__main__':
    sys.exit(main())
