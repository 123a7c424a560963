"""
An estimator made ready for recorded frames: tared and calibrated from the frames themselves.

The evaluator and the benchmark score an estimator on a dataset (:mod:`dataset`) as a user would
run it on that skin: tared from the dataset's no-touch frames, then calibrated through the same
:class:`session.CalibrationSession` that the live calibrations run. With a ``split`` (dataset
format 2) the split = 3 frames (a plate over the whole skin) give the per-taxel gains, in the
forces of curves fitted to the normal presses of known force; then the split = 1 frames
calibrate fully: alpha = 0 frames give (x_p, y_p) and, with
``force_n``, the force curves; tilted ones with ``force_n`` the compliance. Then the split = 2
frames, normal presses where the scored presses are made (the paper's protocol takes (x_p, y_p)
at its own spot), re-take (x_p, y_p) alone, in the newtons of the curves just fitted. Before
them the split = 4 frames, tilted presses of known azimuth (a robot's calibration run), learn
the direction's correction (:mod:`direction`), kept only when it gains on held-out presses. Without
a split the single normal presses give (x_p, y_p); with none, the layers are taken as aligned.
"""

from __future__ import annotations

import math

import numpy as np

from .session import CalibrationRefused, CalibrationSession
from ..data.dataset import Dataset
from ..scan.pipeline import ContactEstimator, EstimatorConfig
from ..shift.methods import resolve

__all__ = ['calibrate_from_frames', 'prepared_estimator']


def _session(est: ContactEstimator, data: Dataset, frames: np.ndarray, kind: str,
             **session_args) -> tuple:
    """Calibrate ``kind`` from single frames at full load; return (estimator, note)."""
    try:
        session = CalibrationSession(est, kind, presses=frames.size, **session_args)
        for i in frames:
            top, bottom = data.top[i], data.bottom[i]
            session.add_press(session.record(top, bottom, est.process(top, bottom)))
        outcome = session.finish()
    except CalibrationRefused as err:
        return est, f'{kind}: refused: {err}'
    return est.with_calibration(outcome.calibration), f'{kind}: {outcome.message}'


def calibrate_from_frames(est: ContactEstimator, data: Dataset, frames: np.ndarray,
                          full: bool = True) -> tuple:
    """
    Return (``est`` calibrated from the ``frames`` of ``data``, a note per part).

    (x_p, y_p) from the alpha = 0 frames; with ``full`` and ``force_n``, the force curves from
    them too and the compliance from the tilted ones. A refused part is noted and the estimator
    keeps what it had.
    """
    frames = np.asarray(frames, dtype=int)
    normal = frames[data.alpha_deg[frames] == 0]
    notes = []
    if full and data.force_n is not None:
        # The force curves before the offset: the zero's slope with the normal force
        # (calibration.calibrate_zero) is in the newtons they give.
        known = normal[data.force_n[normal] > 0]
        est, force_note = _session(est, data, known, 'force', forces_n=data.force_n[known])
        notes.append(force_note)
    est, note = _session(est, data, normal, 'offset', max_std_m=math.inf)
    notes.insert(0, note)
    if full and data.force_n is not None:
        tilted = frames[(data.alpha_deg[frames] > 0) & (data.force_n[frames] > 0)]
        est, note = _session(est, data, tilted, 'compliance', forces_n=data.force_n[tilted],
                             alphas_rad=np.radians(data.alpha_deg[tilted]))
        notes.append(note)
    return est, notes


def prepared_estimator(data: Dataset, method: str, config: EstimatorConfig = None,
                       shift=None) -> tuple:
    """
    Return (estimator ``method`` ready for ``data``, calibration notes).

    ``config`` gives its other settings; ``method`` may name a reference (``shift.REFERENCES``),
    and ``shift`` swaps in any other shift method that is not registered. See the module
    docstring for the tare and calibration.
    """
    if shift is None:
        method, shift = resolve(method)
    base = config or EstimatorConfig(pitch_m=data.pitch_m)
    cfg = EstimatorConfig(**{**base.__dict__, 'method': method, 'pitch_m': data.pitch_m})
    est = ContactEstimator(cfg, shift=shift)
    if data.tare_top is not None:
        est = est.with_tare(data.tare_top, data.tare_bottom)
    if data.split is not None:
        notes = []
        presses = np.flatnonzero(data.split == 1)
        plates = np.flatnonzero(data.split == 3)
        if plates.size:
            # A gain is the ratio of a taxel's force to its neighbours': only the skin's own
            # force curves give it (the assumed film's exponent would bend it), and they are
            # fitted again once the gains even the presses out.
            normal = presses[data.alpha_deg[presses] == 0]
            known = normal[data.force_n[normal] > 0] if data.force_n is not None else normal[:0]
            if known.size:
                est, _ = _session(est, data, known, 'force', forces_n=data.force_n[known])
            est, note = _session(est, data, plates, 'gains')
            notes.append(note)
        est, press_notes = calibrate_from_frames(est, data, presses)
        notes += press_notes
        known = np.flatnonzero((data.split == 4) & (data.alpha_deg > 0))
        if known.size:
            # Before the offset where the skin is used: that one is taken with it in force.
            est, note = _session(est, data, known, 'direction',
                                 azimuths_rad=np.radians(data.azimuth_deg[known]))
            notes.append(note)
        at_use = np.flatnonzero(data.split == 2)
        if at_use.size:
            est, offset_notes = calibrate_from_frames(est, data, at_use, full=False)
            notes += [f'{note} (at the place of use)' for note in offset_notes]
    else:
        single_normal = np.flatnonzero((data.alpha_deg == 0) & (data.press_counts() == 1))
        est, notes = calibrate_from_frames(est, data, single_normal, full=False)
        if not single_normal.size:
            notes = []
    est.process(data.top[0], data.bottom[0])  # warm the per-shape caches
    return est, notes
