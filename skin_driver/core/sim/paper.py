"""
The seed paper's protocol (Sensors 2019, section 4), defined once.

At one spot near the centre, normal presses and one alpha = 45 deg press at each beta = 0, 45,
..., 315 deg, with a 4 mm indenter radius: the simulator's ``seed`` scene plays it
(:mod:`.scene`, ``generator: {kind: paper}``), the demo and the lab's ``paper`` scene too.
"""

from __future__ import annotations

import math

import numpy as np

from .physics import Press, SkinModel

__all__ = ['PAPER_ALPHA_DEG', 'PAPER_BETAS_DEG', 'PAPER_FORCE_N', 'PAPER_RADIUS_M',
           'paper_presses', 'taxel_span']

PAPER_ALPHA_DEG = 45.0
PAPER_BETAS_DEG = tuple(float(b) for b in range(0, 360, 45))
PAPER_FORCE_N = 10.0
PAPER_RADIUS_M = 0.004
# Near the centre, off the taxel centres on purpose: a realistic, unaligned placement.
PAPER_SPOT = (0.49, 0.51)


def taxel_span(model: SkinModel) -> tuple:
    """Return the (x, y) extent of the taxel centres in metres."""
    return (model.cols - 1) * model.pitch_m, (model.rows - 1) * model.pitch_m


def paper_presses(model: SkinModel, force_n: float = PAPER_FORCE_N, repeats: int = 1, *,
                  leading_normal: int = 0, normal_per_repeat: int = 1,
                  rng: np.random.Generator = None, jitter_m: float = 5e-5,
                  force_jitter: float = 0.05) -> list:
    """
    Return the physics presses of the paper's protocol, in the order they are made.

    ``leading_normal`` normal presses first (a calibration), then per repeat
    ``normal_per_repeat`` normal presses and one alpha = 45 deg press at each of the eight betas,
    all at one spot with a 4 mm indenter radius. With ``rng`` each press gets the robot's
    repeatability (``jitter_m``) and a force within +-``force_jitter``.
    """
    width, height = taxel_span(model)
    spot = (width * PAPER_SPOT[0], height * PAPER_SPOT[1])
    angles = [None] * int(leading_normal)
    for _ in range(int(repeats)):
        angles += [None] * int(normal_per_repeat) + list(PAPER_BETAS_DEG)
    presses = []
    for beta in angles:
        x, y, f = spot[0], spot[1], force_n
        if rng is not None:
            x += rng.normal(0.0, jitter_m)
            y += rng.normal(0.0, jitter_m)
            f *= rng.uniform(1.0 - force_jitter, 1.0 + force_jitter)
        alpha = 0.0 if beta is None else math.radians(PAPER_ALPHA_DEG)
        presses.append(Press(x, y, f, alpha, math.radians(beta or 0.0), PAPER_RADIUS_M))
    return presses
