"""
A skin over hours: the force of a press held an hour, a re-press, phantom contacts while idle.

Scenes of :mod:`skin_driver.core.sim.hold` (simulated hours, rendered at the frames scored and a
sparse trail), each scanned by the estimator four ways, all tared at time 0 and all with the
user's calibration in force (gains, force curves, offset and compliance from the family's
calibration frames, as every scene of the evaluator has: :func:`user_calibration`); a force
read through the assumed film's curve bends with the load, so a creep it does not see would
turn the azimuth of a press held an hour:

* ``off``: scans without a time (the driver before it had one): the tare is believed forever.
* ``tracking``: the baselines of untouched taxels follow their drift; no creep correction.
* ``default``: tracking and the creep correction with the estimator's defaults (the family's
  middle).
* ``calibrated``: tracking and the creep fitted to this skin by a creep calibration (a load
  held three minutes, taken off for one and put back, :mod:`..calibration.creep`) on a hold of
  its own (another seed).

Reported: ``|F|`` after 1, 10 and 60 minutes and at a re-press (1 s into a press made two
minutes after an hour's hold ended) as the change from its value 1 s into the first press; the
change in azimuth (deg) and location (mm) over the hour, beside the azimuth's spread over the
frames of one label (each label's figures are the mean of its frames); phantom contacts
(contacts reported on a skin that nothing touches) over ``idle_hours``.
"""

from __future__ import annotations

from dataclasses import replace
import math

import numpy as np

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.creep import CreepError, CreepSession
from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.hold import HOLD_LABELS, hold_scene, idle_scene
from skin_driver.core.sim.skins import family_skin
from skin_lab.experiments import calibrated_scene

__all__ = ['MODES', 'hold_report', 'idle_report', 'calibrate_creep', 'drift_report',
           'format_drift', 'user_calibration']

MODES = ('off', 'tracking', 'default', 'calibrated')
LATER = ('1min', '10min', '60min', 'repress')
# The creep calibration's hold (s): "a few minutes"; then a rest and the load put back.
CALIBRATION_HOLD_S = 180.0
CALIBRATION_REST_S = 60.0


def _configs(base: EstimatorConfig) -> dict:
    return {'off': base, 'tracking': replace(base, creep_per_decade=0.0),
            'default': base, 'calibrated': base}


def user_calibration(skin: str, seed: int = 0, config: EstimatorConfig = None) -> Calibration:
    """
    Return the calibration a user makes of ``skin`` before using it (no creep part).

    Gains, force curves, offset and compliance from the family's calibration frames
    (:func:`experiments.calibrated_scene`), as the evaluator's other scenes calibrate.
    """
    data = calibrated_scene('random', family_skin(skin), np.random.default_rng([0xCA1, seed]), 1)
    estimator, _ = prepared_estimator(data, (config or EstimatorConfig()).method, config)
    return estimator.calibration


def calibrate_creep(skin: str, seed: int = 0, config: EstimatorConfig = None,
                    calibration: Calibration = None):
    """
    Return the creep a creep calibration fits on ``skin`` (a hold of its own), or its error.

    ``calibration`` is what is in force while it runs (the user's force curves: the creep is
    fitted on the newtons they give).
    """
    member = family_skin(skin)
    config = replace(config or EstimatorConfig(pitch_m=member.model.pitch_m),
                     creep_per_decade=0.0)
    scene = hold_scene(member, seed=10_000 + seed, lead_s=60.0,
                       hold_s=CALIBRATION_HOLD_S + 30.0, rest_s=CALIBRATION_REST_S, step_s=10.0)
    estimator = ContactEstimator(config, calibration).with_tare(scene.tare_top, scene.tare_bottom)
    session = CreepSession(CALIBRATION_HOLD_S, member.model.pitch_m, config.creep_recovery_s,
                           CALIBRATION_REST_S)
    for frame in scene.frames:
        contacts = estimator.process(frame.top, frame.bottom, frame.time_s)
        if session.done:
            break
        try:
            session.add(frame.time_s, contacts)
        except CreepError as err:
            return None, str(err)
    try:
        return session.finish(), ''
    except CreepError as err:
        return None, str(err)


def _mean_contact(found) -> dict:
    """Return the mean of a label's contacts, None when a frame had none."""
    if not found or any(c is None for c in found):
        return None
    angles = np.array([c.azimuth_rad for c in found])
    mean = math.atan2(np.sin(angles).mean(), np.cos(angles).mean())
    spread = np.degrees(np.std(np.remainder(angles - mean + math.pi, 2 * math.pi) - math.pi))
    return {'force_n': float(np.mean([c.force_n for c in found])), 'azimuth_rad': mean,
            'azimuth_spread_deg': float(spread), 'x_m': float(np.mean([c.x_m for c in found])),
            'y_m': float(np.mean([c.y_m for c in found])), 'held_s': found[-1].held_s}


def hold_report(skin: str, seed: int = 0, config: EstimatorConfig = None,
                creep=None, calibration: Calibration = None) -> dict:
    """
    Return each mode's figures of the hold scene of ``skin`` (module doc).

    ``calibration`` is in force in every mode, with ``creep`` in it in ``calibrated``.
    """
    member = family_skin(skin)
    base = config or EstimatorConfig(pitch_m=member.model.pitch_m)
    scene = hold_scene(member, seed=seed)
    out = {'skin': skin, 'creep_48h': member.model.drift.over_48_hours(),
           'creep_fit': None if creep is None else creep.to_dict()}
    for mode, cfg in _configs(base).items():
        if mode == 'calibrated' and creep is None:
            continue
        in_force = calibration or Calibration()
        if mode == 'calibrated':
            in_force = replace(in_force, creep=creep)
        estimator = ContactEstimator(cfg, in_force).with_tare(scene.tare_top, scene.tare_bottom)
        seen = {}
        for frame in scene.frames:
            contacts = estimator.process(frame.top, frame.bottom,
                                         None if mode == 'off' else frame.time_s)
            if frame.label:
                seen.setdefault(frame.label, []).append(contacts[0] if contacts else None)
        marks = {label: _mean_contact(found) for label, found in seen.items()}
        first = marks.get('1s')
        row = {}
        for label in LATER:
            c = marks.get(label)
            row[f'force_{label}'] = (math.nan if c is None or first is None
                                     else c['force_n'] / first['force_n'] - 1.0)
        last = marks.get('60min')
        if first is not None and last is not None:
            turn = math.degrees(last['azimuth_rad'] - first['azimuth_rad'])
            row['azimuth_deg'] = (turn + 180.0) % 360.0 - 180.0
            row['azimuth_spread_deg'] = first['azimuth_spread_deg']
            row['location_mm'] = 1e3 * math.hypot(last['x_m'] - first['x_m'],
                                                  last['y_m'] - first['y_m'])
            row['held_s'] = last['held_s']
        else:
            row['azimuth_deg'] = row['location_mm'] = row['held_s'] = math.nan
            row['azimuth_spread_deg'] = math.nan
        row['force_1s_n'] = math.nan if first is None else first['force_n']
        out[mode] = row
    return out


def idle_report(skin: str, seed: int = 0, hours: float = 8.0, step_s: float = 10.0,
                config: EstimatorConfig = None, calibration: Calibration = None) -> dict:
    """
    Return the phantom contacts on ``skin`` left idle ``hours``, without and with tracking.

    ``calibration`` is in force (none by default).
    """
    member = family_skin(skin)
    base = config or EstimatorConfig(pitch_m=member.model.pitch_m)
    scene = idle_scene(member, seed=seed, duration_s=hours * 3600.0, step_s=step_s)
    out = {'skin': skin, 'hours': hours, 'frames': len(scene.frames)}
    for mode in ('off', 'tracking'):
        estimator = ContactEstimator(base, calibration).with_tare(scene.tare_top,
                                                                  scene.tare_bottom)
        phantoms, first = 0, math.nan
        for frame in scene.frames:
            found = len(estimator.process(frame.top, frame.bottom,
                                          None if mode == 'off' else frame.time_s))
            if found and not phantoms:
                first = frame.time_s / 3600.0
            phantoms += found
        drift = estimator.drift()
        out[mode] = {'phantoms': phantoms, 'first_h': first,
                     'drift_max_counts': float(max(drift[1]))}
    return out


def drift_report(skins, seed: int = 0, hours: float = 8.0, step_s: float = 10.0,
                 config: EstimatorConfig = None, log=None) -> dict:
    """
    Return :func:`hold_report` (with a creep calibration) and :func:`idle_report` per skin.

    Each skin is first calibrated as its user would (:func:`user_calibration`).
    """
    holds, idles = [], []
    for name in skins:
        if log:
            log(f'drift: {name}')
        calibration = user_calibration(name, seed, config)
        creep, error = calibrate_creep(name, seed, config, calibration)
        report = hold_report(name, seed, config, creep, calibration)
        report['calibration_error'] = error
        holds.append(report)
        idles.append(idle_report(name, seed, hours, step_s, config, calibration))
    return {'holds': holds, 'idles': idles, 'hours': hours, 'step_s': step_s,
            'labels_s': HOLD_LABELS}


def _pct(v: float) -> str:
    return '-' if not np.isfinite(v) else f'{100 * v:+.1f}'


def format_drift(report: dict) -> str:
    """Return the report as Markdown tables: |F| change by mode, then phantoms."""
    lines = ['| skin | creep 48 h | mode | 1 min | 10 min | 60 min | re-press | azimuth deg '
             '(spread) | location mm |', '|---|---|---|---|---|---|---|---|---|']
    for h in report['holds']:
        for mode in MODES:
            row = h.get(mode)
            if row is None:
                continue
            lines.append(
                f"| {h['skin']} | {100 * h['creep_48h']:.0f} % | {mode} | "
                + ' | '.join(_pct(row[f'force_{label}']) for label in LATER)
                + f" | {row['azimuth_deg']:+.2f} ({row['azimuth_spread_deg']:.2f}) | "
                f"{row['location_mm']:.2f} |")
    lines += ['', f"| skin | phantom contacts over {report['hours']:g} h, tare only | "
              'with tracking | largest tracked drift, counts |', '|---|---|---|---|']
    for i in report['idles']:
        lines.append(f"| {i['skin']} | {i['off']['phantoms']} | {i['tracking']['phantoms']} | "
                     f"{i['tracking']['drift_max_counts']:.0f} |")
    return '\n'.join(lines)
