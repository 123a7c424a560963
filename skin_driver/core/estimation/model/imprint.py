"""
The bump a saturated imprint's force is filled in with: its shape, shared by calibration and scan.

A taxel whose FSR has saturated reads its ceiling under any heavier load: its reading is a
lower bound on its force, not a value. The rest of the imprint still tells the force: the rim
taxels read below the ceiling, and an imprint is a smooth bump whose height the rim fixes. The
bump is ``exp(-(d / spread_taxels) ** power / 2)`` at distance ``d`` (taxels) from the imprint's
centroid of counts (a saturated plateau is symmetric about it too): a Gaussian for power 2,
flatter-topped above (an indenter's dome, resolved by a fine grid).

A force calibration fits the spread and the power together with the layer's curve
(:mod:`forcefit`), so the bump is the one the presses of known force showed, blur of the
layers and size of the indenter included. Each scan's saturated imprints are filled in by the
compiled kernel (``skin_kernel/src/saturated_force.c``): the bump's height is the
least-squares fit to the unsaturated taxels, and each censored taxel carries the larger of the
bump and its own reading. Another indenter makes another bump: a smaller one a narrower imprint
whose rim carries a smaller share of its force. Where the calibration's bump is
``MIN_FITTED_SPREAD`` taxels wide or more, the rim samples its shape over several taxels, so the
kernel fits each imprint's own spread (within half to twice the calibration's, which keeps a
bump the rim cannot pin down from running off): the spread whose bump best fits the unsaturated
taxels without falling below a censored taxel's reading. A narrower bump is sampled by one ring
of taxels at most, too few for a width: there the calibration's spread is kept, and the
calibration fits the curve with that fixed bump.
"""

from __future__ import annotations

import numpy as np

__all__ = ['bump', 'MIN_FITTED_SPREAD']

# The narrowest calibrated bump (spread, taxels) whose width each imprint's rim can tell
# (saturated_force.c's MIN_FITTED_SPREAD: the kernel fits each imprint's own spread from it).
MIN_FITTED_SPREAD = 1.0


def bump(counts: np.ndarray, spread_taxels: float, power: float = 2.0) -> np.ndarray:
    """Return the unit bump over a 2-D map of counts, centred on its centroid."""
    counts = np.asarray(counts, dtype=np.float64)
    rows, cols = np.indices(counts.shape)
    mass = counts.sum()
    if not mass > 0:
        return np.zeros(counts.shape)
    r0 = float((rows * counts).sum() / mass)
    c0 = float((cols * counts).sum() / mass)
    d2 = ((rows - r0) ** 2 + (cols - c0) ** 2) / (spread_taxels * spread_taxels)
    return np.exp(-0.5 * d2 ** (0.5 * power))
