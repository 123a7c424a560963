"""
The force calibration's accuracy on the skin family: |F| and alpha after the user's calibration.

Issue #17's protocol: 16 normal and 16 tilted presses of known load calibrate the force curves,
the offset and the compliance (:func:`experiments.calibrated_scene`, the evaluator's
``--calibration-frames``); then the tilted presses of a scene are scored by the error of |F| (%)
and of alpha (deg). Two scenes tell apart what the calibration can learn and what it cannot:
``one_tip`` presses with the calibration's own indenter (the protocol of the issue: one tip),
``random`` with indenters of 3-7 mm, some elliptical, none of them the calibration's. On a skin
whose taxels saturate the rim of an imprint is all that tells its force, and how much load the
saturated centre carries depends on the indenter: another tip than the calibration's is a bias
the frames cannot undo on a coarse grid. The oracle (:mod:`skin_lab.oracle`) fits the
simulator's own model, indenter included, from the truth: the floor of each figure.
"""

from __future__ import annotations

import numpy as np

from skin_driver.core.estimation.calibration.prepared import prepared_estimator
from skin_driver.core.estimation.shift.methods import DEFAULT_METHOD
from skin_driver.core.sim.skins import family_skin, skin_names
from skin_lab.evaluate.scoring import MethodRun, score_run
from skin_lab.experiments import calibrated_scene
from skin_lab.oracle import ORACLE, oracle_run

__all__ = ['force_figures', 'calibration_accuracy', 'CALIBRATION_SCENES']

# The scenes scored: the calibration's own tip, then the random scene's mixed tips.
CALIBRATION_SCENES = ('one_tip', 'random')


def force_figures(summary: dict) -> dict:
    """Return the |F| and alpha errors of a scored run's summary (None without directions)."""
    return {'force_error_pct': summary.get('force_mean_error_pct'),
            'force_bias_pct': summary.get('force_bias_pct'),
            'alpha_error_deg': summary.get('alpha_mean_error_deg'),
            'alpha_bias_deg': summary.get('alpha_bias_deg')}


def _row(skin: str, kind: str, data, run: MethodRun) -> dict:
    return {'skin': skin, 'scene': kind, 'method': run.method,
            **force_figures(score_run(data, run)['summary'])}


def calibration_accuracy(size: int, skins: list = None, seed: int = 0, log=print) -> dict:
    """
    Return per (skin, scene) the default estimator's and the oracle's |F| and alpha errors.

    ``size`` frames per scene (one in five a normal press, not scored for alpha and |F|), after
    the user's 48 calibration frames. ``worst`` holds, per scene, the largest errors over the
    skins and where.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for skin in skins or skin_names():
        for kind in CALIBRATION_SCENES:
            truth = []
            data = calibrated_scene(kind, skin, rng, size, truth)
            est, _ = prepared_estimator(data, DEFAULT_METHOD)
            scored = data.scored_frames()
            presses = [truth[i] for i in scored]
            data = data.select(scored)
            contacts = [est.process(data.top[i], data.bottom[i]) for i in range(data.frames)]
            rows.append(_row(skin, kind, data, MethodRun(DEFAULT_METHOD, est.calibration,
                                                         contacts, 0.0)))
            found, us = oracle_run(family_skin(skin).model, presses, data)
            rows.append(_row(skin, kind, data, MethodRun(ORACLE, est.calibration, found, us)))
        log(f'  calibration: {skin} done')
    worst = {}
    for kind in CALIBRATION_SCENES:
        mine = [r for r in rows if (r['scene'], r['method']) == (kind, DEFAULT_METHOD)]
        for key in ('force_error_pct', 'alpha_error_deg'):
            rated = [(r[key], r['skin']) for r in mine if r[key] is not None]
            worst[f'{kind}_{key}'] = max(rated) if rated else (None, None)
    return {'size': size, 'scenes': list(CALIBRATION_SCENES), 'rows': rows, 'worst': worst}
