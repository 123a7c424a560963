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
(:mod:`forcecurve`), so the bump is the one the presses of known force showed, blur of the
layers and size of the indenter included: presses with a much smaller or larger indenter than
the calibration's are filled in with the calibration's bump.
"""

from __future__ import annotations

import numpy as np

__all__ = ['bump', 'censored_force']


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


def censored_force(counts: np.ndarray, force: np.ndarray, censor_counts: float,
                   spread_taxels: float, power: float = 2.0) -> float:
    """
    Return the summed force of one imprint (2-D maps of counts and of taxel forces).

    Taxels at ``censor_counts`` or more are censored; without any, or without a bump
    (``spread_taxels`` 0), the plain sum.
    """
    counts = np.asarray(counts, dtype=np.float64)
    force = np.asarray(force, dtype=np.float64)
    censored = counts >= censor_counts
    if not (spread_taxels > 0 and censor_counts > 0 and censored.any()):
        return float(force.sum())
    free = (counts > 0) & ~censored
    phi = bump(counts, spread_taxels, power)
    weight = float(phi[free] @ phi[free])
    if not weight > 0:
        return float(force.sum())
    height = float(force[free] @ phi[free]) / weight
    return float(force[free].sum() + np.maximum(force[censored], height * phi[censored]).sum())
