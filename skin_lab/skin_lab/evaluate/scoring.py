"""
Scoring of direction estimators on a dataset: Table 1 of the seed paper and the family's figures.

The single normal presses calibrate (x_p, y_p); every single tilted press's strongest contact is
compared with the ground-truth azimuth; frames with several presses are matched press by press
(docs/dataset.md). With a ``split`` array (dataset format 2) only the calibration frames
(split = 1) calibrate, and more fully
(:mod:`skin_driver.core.estimation.calibration.prepared`); only split = 0 frames are scored.
ROS-free.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import time

import numpy as np

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.data.dataset import Dataset
from skin_driver.core.estimation.scan.pipeline import EstimatorConfig
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD
from skin_lab.oracle import ORACLE, oracle_run

__all__ = ['PAPER_TABLE', 'MethodRun', 'summarise', 'angle_error_deg', 'run_method',
           'score_run', 'evaluate_method', 'evaluate', 'match_presses', 'direction_errors']

# Table 1 of the seed paper (Sensors 2019, 19, 4697): beta -> (mean error, std), degrees.
PAPER_TABLE = {0.0: (0.96, 0.64), 45.0: (1.75, 1.13), 90.0: (5.65, 0.96), 135.0: (3.98, 1.13),
               180.0: (3.07, 4.74), 225.0: (2.87, 0.64), 270.0: (6.31, 0.66),
               315.0: (7.21, 13.34), 'summary': (3.72, 4.73)}
# A contact stands for a press when it lies within this many taxels of it.
MATCH_RADIUS_TAXELS = 1.5
# Presses at least this many taxels apart must come out as separate contacts.
SEPARATE_TAXELS = 3.0


def angle_error_deg(estimate_rad: float, truth_deg: float) -> float:
    """Return the absolute difference of two azimuths in degrees, in [0, 180]."""
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
            err = angle_error_deg(math.radians(est), float(gt))
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


def run_method(data: Dataset, method: str, config: EstimatorConfig = None) -> MethodRun:
    """
    Run estimator ``method`` (made ready by :func:`prepared.prepared_estimator`) over the data.

    Its contacts are those of the scored frames (``data.scored_frames()``), frame by frame.
    """
    est, notes = prepared_estimator(data, method, config)
    data = data.select(data.scored_frames())
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
            err = (angle_error_deg(c.azimuth_rad, press['azimuth_deg'])
                   if c is not None and c.direction_valid else None)
            out.append((i, k, err, c))
    return out


def nearest_contacts(presses: list, contacts: list, pitch_m: float) -> list:
    """
    Return, for each press, the index of the nearest contact within the match radius (or None).

    Unlike :func:`match_presses` two presses may share a contact: one that stands for a close
    pair of presses is still apart from a third press far from both.
    """
    out = []
    for p in presses:
        near = [(math.hypot(c.x_m - p['x_m'], c.y_m - p['y_m']), j)
                for j, c in enumerate(contacts)]
        d, j = min(near, default=(math.inf, None))
        out.append(j if d <= MATCH_RADIUS_TAXELS * pitch_m else None)
    return out


def _pair_stats(data: Dataset, run: MethodRun, frames) -> dict:
    """
    Return how pairs of presses far apart (>= 3 taxels) and close (2..3) were separated.

    A pair is separate when each press lies near a contact (:func:`nearest_contacts`) and the
    two contacts differ.
    """
    counts = dict.fromkeys(('far', 'far_separate', 'far_merged', 'close', 'close_separate'), 0)
    for i in frames:
        presses = data.presses(i)
        contacts = run.contacts[i]
        near = nearest_contacts(presses, contacts, data.pitch_m)
        for a in range(len(presses)):
            for b in range(a + 1, len(presses)):
                pa, pb = presses[a], presses[b]
                gap = math.hypot(pa['x_m'] - pb['x_m'], pa['y_m'] - pb['y_m']) / data.pitch_m
                kind = 'far' if gap >= SEPARATE_TAXELS else 'close'
                counts[kind] += 1
                separate = near[a] is not None and near[b] is not None and near[a] != near[b]
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
    frames = np.flatnonzero(data.press_counts() >= 2)
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
    tilted = np.flatnonzero((data.alpha_deg > 0) & (data.press_counts() == 1))
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
    return score_run(data.select(data.scored_frames()), run_method(data, method, config))


def _ratios(mine: dict, oracle: dict) -> dict:
    """Return mean error / the oracle's, over the single tilted presses and the multi ones."""
    def ratio(a, b):
        return a / b if a is not None and b else None
    return {'single': ratio(mine['summary']['mean_error_deg'],
                            oracle['summary']['mean_error_deg']),
            'multi': ratio(mine['presses'] and mine['presses']['mean_error_deg'],
                           oracle['presses'] and oracle['presses']['mean_error_deg'])}


def _seed_like(data: Dataset) -> bool:
    """Return whether the single tilted presses are the paper's (alpha = 45 deg, eight betas)."""
    tilted = (data.alpha_deg > 0) & (data.press_counts() == 1)
    return bool(tilted.any() and np.allclose(data.alpha_deg[tilted], 45.0)
                and set(np.round(data.azimuth_deg[tilted], 6)) <= set(PAPER_TABLE))


def evaluate(data: Dataset, method: str = DEFAULT_METHOD, config: EstimatorConfig = None,
             runs: dict = None, truth: tuple = None) -> dict:
    """
    Return the figures of ``method`` and of ``seed`` on ``data`` as one JSON-ready dict.

    ``runs`` (a dict), when given, receives each :class:`MethodRun` by method name. ``truth``
    ``(model, presses of each scored frame)`` adds the oracle's figures (``skin_lab.oracle``)
    and each method's ``ratio_to_oracle`` (its mean error over the oracle's).
    """
    names = [method] if method == 'seed' else [method, 'seed']
    scored = data.select(data.scored_frames())
    methods = {}
    for n in names:
        run = run_method(data, n, config)
        if runs is not None:
            runs[n] = run
        methods[n] = score_run(scored, run)
    if truth is not None:
        contacts, us = oracle_run(truth[0], truth[1], scored)
        run = MethodRun(ORACLE, Calibration(), contacts, us)
        if runs is not None:
            runs[ORACLE] = run
        methods[ORACLE] = score_run(scored, run)
        for n in names:
            methods[n]['ratio_to_oracle'] = _ratios(methods[n], methods[ORACLE])
    single = scored.press_counts() == 1
    return {
        'frames': data.frames, 'shape': list(data.shape), 'pitch_m': data.pitch_m,
        'seed_experiment': _seed_like(scored),
        'normal_frames': int(((scored.alpha_deg == 0) & single).sum()),
        'tilted_frames': int(((scored.alpha_deg > 0) & single).sum()),
        'multi_press_frames': int((~single).sum()),
        'calibration_frames': 0 if data.split is None else int((data.split > 0).sum()),
        'methods': methods,
    }
