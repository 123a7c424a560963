"""
The force a saturated imprint carries: censored taxels filled in from the rest of the imprint.

A taxel whose FSR has saturated reads its ceiling under any heavier load: its reading is a
lower bound on its force, not a value. The rest of the imprint still tells the force: the rim
taxels read below the ceiling, and an imprint is a smooth bump whose height the rim fixes. The
bump is ``exp(-(d / spread_taxels) ** power / 2)`` at distance ``d`` (taxels) from the imprint's
centroid of counts (a saturated plateau is symmetric about it too): a Gaussian for power 2,
flatter-topped above (an indenter's dome, resolved by a fine grid). Its height is the
least-squares fit to the unsaturated taxels, and each censored taxel carries the larger of the
bump and its own reading.

A force calibration fits the spread and the power together with the layer's curve
(:mod:`forcefit`), so the bump is the one the presses of known force showed, blur of the
layers and size of the indenter included. Another indenter makes another bump: a smaller one a
narrower imprint whose rim carries a smaller share of its force. Where the calibration's bump
is a taxel wide or more, the rim samples its shape over several taxels, so each imprint's own
spread is fitted (within ``SPREAD_RANGE`` of the calibration's, which keeps a bump the rim
cannot pin down from running off): the spread whose bump best fits the unsaturated taxels
without falling below a censored taxel's reading. A narrower bump is sampled by one ring of
taxels at most, too few for a width: there the calibration's spread is kept.

The compiled kernel fills in each scan's saturated imprints the same way
(``skin_kernel/src/saturated_force.c``); the force calibration fits its curves with this
module's bump.
"""

from __future__ import annotations

import numpy as np

__all__ = ['bump', 'censored_force', 'MIN_FITTED_SPREAD', 'SPREAD_RANGE']

# The narrowest calibrated bump (spread, taxels) whose width each imprint's rim can tell.
MIN_FITTED_SPREAD = 1.0
# The spreads tried for one imprint, as factors of the calibration's (log steps).
SPREAD_RANGE = (0.5, 2.0)
_SPREAD_STEPS = 13
# Rounds of a finer grid around the best spread: an imprint's force moves with its spread.
_REFINE_ROUNDS = 3


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


def _fill(counts: np.ndarray, force: np.ndarray, censored: np.ndarray, free: np.ndarray,
          spread_taxels: float, power: float):
    """Return (misfit, height, bump) of one spread: least squares on the free taxels."""
    phi = bump(counts, spread_taxels, power)
    weight = float(phi[free] @ phi[free])
    if not weight > 0:
        return None
    height = float(force[free] @ phi[free]) / weight
    misfit = force[free] - height * phi[free]
    # A bump below a censored taxel's reading contradicts it (the reading is a lower bound).
    below = np.minimum(height * phi[censored] - force[censored], 0.0)
    return float(misfit @ misfit + below @ below), height, phi


def _best_spread(counts, force, censored, free, spread_taxels: float, power: float):
    """Return the best :func:`_fill` over the spreads of ``SPREAD_RANGE``: a grid, then finer."""
    grid = spread_taxels * np.geomspace(*SPREAD_RANGE, _SPREAD_STEPS)
    step = float(grid[1] / grid[0])
    best = None
    for _ in range(_REFINE_ROUNDS + 1):
        for spread in grid:
            fill = _fill(counts, force, censored, free, float(spread), power)
            if fill is not None and (best is None or fill[0] < best[0][0]):
                best = (fill, float(spread))
        if best is None:
            return None
        step = step ** 0.5
        grid = best[1] * np.array([1.0 / step, step])
    return best[0]


def censored_force(counts: np.ndarray, force: np.ndarray, censor_counts: float,
                   spread_taxels: float, power: float = 2.0, activation: float = 0.0) -> float:
    """
    Return the summed force of one imprint (2-D maps of counts and of taxel forces).

    Taxels at ``censor_counts`` or more are censored; without any, or without a bump
    (``spread_taxels`` 0), the plain sum. The spread is the imprint's own where the bump is
    wide enough for its rim to tell it (module docstring). ``activation``, the force every
    conducting taxel carries, is no part of the bump: it is fitted to the free taxels' force
    above it, and a censored taxel carries the activation plus the bump.
    """
    counts = np.asarray(counts, dtype=np.float64)
    force = np.asarray(force, dtype=np.float64)
    censored = counts >= censor_counts
    if not (spread_taxels > 0 and censor_counts > 0 and censored.any()):
        return float(force.sum())
    free = (counts > 0) & ~censored
    above = force - activation
    if spread_taxels >= MIN_FITTED_SPREAD:
        best = _best_spread(counts, above, censored, free, spread_taxels, power)
    else:
        best = _fill(counts, above, censored, free, spread_taxels, power)
    if best is None:
        return float(force.sum())
    _, height, phi = best
    return float(force[free].sum()
                 + np.maximum(force[censored], activation + height * phi[censored]).sum())
