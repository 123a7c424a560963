"""
Presses of known direction rendered from the skin's own taxel model, to teach the direction.

A robot's calibration run gives a few hundred presses of known azimuth; the correction the
direction learns from them (:mod:`.direction`) is a function of where an imprint sits on the
taxel grid, and a few hundred presses sample that function thinly. The same presses also hold
the skin's physics: :func:`taxellearn.learn_taxel_model` learns its blurs, pads and film from
them. Rendered through that model, presses at any place, force, shift and tip are as many as
the fit wants, and each has its whole shift known. Each rendered press is read as a live
press would be: on the skin's baseline, with its measured noise, by an estimator of the same
settings and calibration (the correction not applied), so the correction learns what the
estimator does to the skin the model describes.

How far that helps depends on how well the model describes the skin: the robot's presses judge
it (:func:`direction.learn_direction` keeps a map learned from renders only when it lowers the
error on them).
"""

from __future__ import annotations

from dataclasses import replace
import math
from typing import Sequence

import numpy as np

from .direction import KnownPress
from ..model.taxelmodel import render_counts, sub_for, TaxelModel

__all__ = ['render_known_presses', 'RENDERED_PRESSES']

# As many as the ridge over 20 features x 2 wants without the renders' cost mattering (a few
# seconds of the calibration's thread).
RENDERED_PRESSES = 1500
# The quantiles of the presses' places, forces and shift lengths the renders span.
SPAN = (0.05, 0.95)


def render_known_presses(estimator, model: TaxelModel, presses: Sequence[KnownPress],
                         radii_taxels: Sequence[float], count: int = RENDERED_PRESSES,
                         seed: int = 0) -> list:
    """
    Return ``count`` presses rendered from ``model`` as ``estimator`` reads them (KnownPress).

    They span what the real ``presses`` span: places over the same rows and columns, normal
    forces as read, shifts as long as theirs (the calibrated shift, the zero at the press's
    force added back: where the bottom imprint is), any azimuth, and tip radii over the span
    of those the model's learning fitted to them (``radii_taxels``). They are read by a copy
    of ``estimator`` with its direction correction off (the live one's per-scan state is its
    reader's). Renders the estimator finds no contact in are dropped.
    """
    if not presses or not radii_taxels:
        return []
    reader = estimator.with_calibration(replace(estimator.calibration, direction=None))
    cal = reader.calibration
    pitch = reader.config.pitch_m
    conditioning = reader.conditioning
    shape = conditioning.shape
    if shape is None:
        return []
    state = conditioning.state(shape)
    sensitivity = conditioning.sensitivity_maps()
    full_scale = float(conditioning.config.fsr.full_scale)
    # The spans of the presses, the few that slipped or misread left out.
    col, row, force, length = (np.quantile(v, SPAN) for v in zip(*(
        (p.col, p.row, p.force_n, math.hypot(*p.shift)) for p in presses)))
    # Tips between the robot's: a few tips alone would teach the map those tips only.
    radius = np.quantile(radii_taxels, SPAN)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(int(count)):
        normal = rng.uniform(*force)
        azimuth = rng.uniform(-math.pi, math.pi)
        shift = rng.uniform(*length)
        zero = cal.zero_m(normal)
        u = np.array((rng.uniform(*col), rng.uniform(*row), math.log(normal),
                      shift * math.cos(azimuth) + zero[0] / pitch,
                      shift * math.sin(azimuth) + zero[1] / pitch,
                      math.log(rng.uniform(*radius)), 0.0, 0.0))
        counts = render_counts(model, shape, u, sub_for(u), sensitivity)
        raw = state.baseline + counts + state.noise * rng.standard_normal(counts.shape)
        raw = np.clip(np.rint(raw), 0.0, full_scale)
        found = reader.process(raw[0], raw[1])
        if not found:
            continue
        c = found[0]
        zero = cal.zero_m(c.force_n)
        sx, sy = c.shift_m[0] / pitch, c.shift_m[1] / pitch
        out.append(KnownPress(c.x_m / pitch, c.y_m / pitch, (sx, sy), c.force_n, azimuth,
                              (sx + zero[0] / pitch, sy + zero[1] / pitch)))
    return out
