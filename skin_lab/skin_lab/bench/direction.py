"""
Section 8 of `make bench`: the direction learned from a robot's presses of known direction.

For each skin (the family's and held-out draws) and scene (``paper``, ``random``) the default
method is scored after the usual calibration frames (today's figure) and after as many presses
of known direction as the run asks for (dataset split 4, :func:`experiments.add_direction_frames`;
240 are a ten-minute robot run), on the same scored frames. Beside them the floor: the oracle
(the simulator's own model fitted to each frame from the truth) and the Cramér–Rao bound on beta
(:mod:`skin_lab.floor`, as a mean absolute error; the share of presses whose derivatives are
stable with it).
"""

from __future__ import annotations

import time

import numpy as np

from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD
from skin_driver.core.sim.skins import family_skin
from skin_lab.evaluate.scoring import MethodRun, score_run
from skin_lab.experiments import calibrated_scene, ROBOT_PRESS_S
from skin_lab.floor import mean_bound_deg
from skin_lab.oracle import ORACLE, oracle_run

__all__ = ['direction_learning', 'direction_targets', 'direction_markdown', 'SCENES']

SCENES = ('paper', 'random')
# Skins whose default error is, in good part, a function of the frames' cheap features: the
# issue's 0.5x target is theirs (on sharp and soft it is not; the gate keeps those as they were).
LEARNABLE = ('default', 'loaded', 'saturating', 'film')


def _run(member, kind: str, size: int, presses: int, seed: int) -> tuple:
    """Return (data, truth of every frame, the default's run: its median us per frame)."""
    truth = []
    data = calibrated_scene(kind, member, np.random.default_rng(seed), size, truth,
                            direction_presses=presses)
    # One calibration serves the scores and the cost: it costs far more than the scored frames.
    est, notes = prepared_estimator(data, DEFAULT_METHOD)
    scored = data.select(data.scored_frames())
    contacts = [est.process(scored.top[i], scored.bottom[i]) for i in range(scored.frames)]
    return data, truth, MethodRun(DEFAULT_METHOD, est.calibration, contacts,
                                  _back_to_back_us(est, scored), tuple(notes))


def _back_to_back_us(est, scored) -> float:
    """Return the estimator's median cost per scored frame (us), its scans back to back."""
    costs = []
    for i in range(scored.frames):
        top, bottom = scored.top[i], scored.bottom[i]
        start = time.perf_counter()
        est.process(top, bottom)
        costs.append(time.perf_counter() - start)
    return float(np.median(costs)) * 1e6


def _cell(member, kind: str, size: int, counts, seed: int, oracle: bool) -> dict:
    # Keyed by the number of presses as text: the report is read back from its JSON (--only).
    row = {'skin': member.name, 'scene': kind, 'learned': {}}
    for n in counts:
        data, truth, run = _run(member, kind, size, n, seed)
        scored = data.select(data.scored_frames())
        summary = score_run(scored, run)['summary']
        learned = run.calibration.direction
        row['learned'][str(n)] = {
            'mean_error_deg': summary['mean_error_deg'], 'valid_share': summary['valid_share'],
            'us_per_frame': run.us_per_frame,
            'applied': bool(learned is not None and learned.kept),
            'rendered': bool(learned is not None and learned.rendered),
            'cv_before_deg': learned.before_deg if learned else None,
            'cv_after_deg': learned.after_deg if learned else None}
    presses = [truth[i] for i in data.scored_frames()]
    if oracle:
        contacts, us = oracle_run(member.model, presses, scored)
        row['oracle_deg'] = score_run(scored, MethodRun(ORACLE, Calibration(), contacts, us))[
            'summary']['mean_error_deg']
    row['crb'] = mean_bound_deg(member.model, presses)
    today = row['learned'][str(counts[0])]['mean_error_deg']
    best = row['learned'][str(counts[-1])]['mean_error_deg']
    row['ratio'] = best / today if today and best is not None else None
    return row


def direction_learning(skins, sizes: dict, counts, seed: int = 0, oracle: bool = True,
                       log=print) -> dict:
    """
    Return section 8's rows: per skin and scene the default's error against known presses.

    ``counts`` are the numbers of known presses tried, the first 0 (today's calibration);
    ``sizes`` the scene sizes (paper: repeats of nine frames).
    """
    counts = sorted({int(n) for n in counts} | {0})
    rows = []
    for name in skins:
        member = family_skin(name)
        for kind in SCENES:
            row = _cell(member, kind, sizes[kind], counts, seed, oracle)
            log(f'  {name} {kind}: ' + ', '.join(
                f'{n} presses {v["mean_error_deg"] or 0:.2f} deg' for n, v in
                row['learned'].items()) + f'; CRB {row["crb"]["mean_abs_error_deg"] or 0:.3f}')
            rows.append(row)
    return {'counts': counts, 'sizes': sizes, 'robot_press_s': ROBOT_PRESS_S, 'rows': rows}


def _worse(learned: dict, today: dict) -> bool:
    """Return whether a cell's error with known presses is above today's."""
    after, before = learned['mean_error_deg'], today['mean_error_deg']
    return after is not None and before is not None and after > before


def direction_targets(res: dict, target) -> list:
    """Return the issue's targets of section 8, made by ``target`` (scoring._target)."""
    rows, top = res['rows'], res['counts'][-1]
    key = str(top)
    minutes = top * res['robot_press_s'] / 60.0
    random = [r for r in rows if r['scene'] == 'random']
    learnable = [r for r in random if r['skin'] in LEARNABLE or ':' in r['skin']]
    worst = max((r['ratio'] for r in learnable if r['ratio'] is not None), default=None)
    # Worse at any number of presses, not the largest alone: a run of 60 presses is a
    # calibration a user may make too. (Today's own cell is never above itself.)
    today = str(res['counts'][0])
    worse = [f'{r["skin"]} {r["scene"]} ({n})' for r in rows for n, v in r['learned'].items()
             if _worse(v, r['learned'][today])]
    paper = [r['learned'][key]['mean_error_deg'] for r in rows if r['scene'] == 'paper'
             and r['learned'][key]['mean_error_deg'] is not None]
    costs = [r['learned'][key]['us_per_frame'] for r in rows if r['skin'] == 'default']
    out = [target(f'random spots, default with {top} known presses / today (worst of '
                  f'{len(learnable)} learnable skins)', worst, '<= 0.50',
                  worst is not None and worst <= 0.5,
                  f'{worst / 0.5:.2f} x the limit' if worst and worst > 0.5 else ''),
           target('cells made worse by the known presses (any skin, scene, presses)',
                  len(worse), '0',
                  not worse, ', '.join(worse), spec='d'),
           target(f"paper's protocol with {top} known presses (worst skin)",
                  max(paper) if paper else None, '<= 0.5 deg', bool(paper) and max(paper) <= 0.5,
                  f'{max(paper) / 0.5:.2f} x the limit' if paper and max(paper) > 0.5 else ''),
           target('robot time of the calibration run [min]', minutes, '<= 15',
                  minutes <= 15.0, f'{top} presses at {res["robot_press_s"]} s', spec='.1f')]
    if costs:
        out.append(target(f'default with {top} known presses learned, 16 x 16, scans back to '
                          'back [us/frame, median]', max(costs), '<= 30', max(costs) <= 30.0))
    return out


def direction_markdown(res: dict, figure, table) -> list:
    """Return section 8's Markdown lines (``figure``, ``table``: tables.py's helpers)."""
    counts = res['counts']
    out = ['## 8. Direction learned from presses of known direction, beside the floor', '',
           f'The default (`{DEFAULT_METHOD}`) after the usual calibration frames and after N '
           'tilted presses of known azimuth (split 4: random spots, 3/5/7 mm round tips, the '
           f"skin's forces; {res['robot_press_s']} s of robot time each), on the same scored "
           f'frames (paper: {res["sizes"]["paper"]} repeats of 9 frames; random: '
           f'{res["sizes"]["random"]} frames). A correction is applied only when it lowers the '
           'error on presses it did not learn from (`applied`: learned from held-out folds of '
           "the known presses, or `renders`: from 1500 presses rendered from the skin's taxel "
           'model learned from them, judged on them all). Floor: the oracle (the '
           "simulator's model fitted from the truth) and the Cramér–Rao bound on beta as a mean "
           '|error| (sqrt(2/pi) sigma, over the presses whose derivatives are stable: `stable`; '
           'a few presses whose beta the frame barely holds carry the mean, hence the median '
           'sigma beside it).',
           '']
    head = (['skin', 'scene'] + [f'{n} presses [deg]' for n in counts]
            + ['applied', 'ratio', 'oracle [deg]', 'CRB [deg]', 'CRB median sigma [deg]',
               'stable'])
    rows = []
    for r in res['rows']:
        last = r['learned'][str(counts[-1])]
        rows.append([r['skin'], r['scene']]
                    + [figure(r['learned'][str(n)]['mean_error_deg'], '.2f') for n in counts]
                    + [('renders' if last.get('rendered') else 'yes') if last['applied']
                       else 'no', figure(r['ratio'], '.2f'),
                       figure(r.get('oracle_deg'), '.2f'),
                       figure(r['crb']['mean_abs_error_deg'], '.3f'),
                       figure(r['crb']['median_sigma_deg'], '.3f'),
                       figure(r['crb']['stable_share'] and 100 * r['crb']['stable_share'],
                              '.0f') + ' %'])
    return out + table(head, rows) + ['']
