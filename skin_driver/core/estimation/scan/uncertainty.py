"""
The uncertainty of a contact's shift, from the contact's own data (Python description).

Each taxel's count noise (measured by the tare) gives the noise of each imprint's centroid; an
imprint narrower than a taxel adds the pixel-locking error of its sampled centroid, whose size
follows from the imprint's measured width (a Gaussian profile of variance ``v - 1/12`` sampled on
unit cells has a first harmonic of amplitude ``exp(-2 pi^2 (v - 1/12)) / pi`` taxels); a contact
sharing the bottom load with others adds the spread its share's centroid would have were each
bottom taxel's load its own with the mixture's probability (a taxel wholly its own or wholly
another's adds nothing); an imprint cut by the map's edge adds the shift method's own
uncertainty of its cut profiles (``taxel_fit``: how far the centre follows the width,
:func:`taxelfit.cell_fit_shift`; at least a fifth of a taxel for a contact sharing the bottom
load with others), else a fifth of a taxel; the calibration adds the spread of its zero about
the normal presses and its standard error (the zero a new press meets, :mod:`pipeline`). The
root sum of squares is ``sigma``, one axis of the shift (see :mod:`pipeline`). The compiled
kernel's ``sigma.c`` does the same; the tests hold it to this.
"""

from __future__ import annotations

from functools import lru_cache
import math

import numpy as np

from .contacts import LayerPair

__all__ = ['shift_sigma']

# Less load than this (counts) on a layer gives a contact no measurable shift.
_MIN_MASS_COUNTS = 1.0
# Extra shift uncertainty (taxels) of an imprint cut by the edge of the map, for a shift method
# that gives none of its own.
_BORDER_SIGMA = 0.2


@lru_cache(maxsize=256)
def _axis_basis(shape: tuple) -> np.ndarray:
    """Return the (h * w, 5) columns 1, row, col, row**2, col**2 of a window's taxels."""
    rr, cc = np.indices(shape, dtype=np.float64)
    basis = np.stack((np.ones(rr.size), rr.ravel(), cc.ravel(), rr.ravel() ** 2,
                      cc.ravel() ** 2), axis=1)
    basis.flags.writeable = False
    return basis


def shift_sigma(pair: LayerPair, maps: np.ndarray, noise: np.ndarray, alone: bool,
                calibration_variance: float, cut_variance: float = 0.0) -> float:
    """
    Return the 1-sigma uncertainty of one axis of a contact's shift, in taxels (module doc).

    ``maps`` are the scan's touch counts, ``noise`` each taxel's count noise, both (2, rows,
    cols); ``alone``: the only contact of its scan; ``calibration_variance`` the calibration's
    share of sigma**2 (taxels**2); ``cut_variance`` the shift method's own for imprints cut by
    the map's edge (taxels**2, :class:`shift.ShiftEstimate`), 0 for the flat rule.
    """
    r0, c0 = pair.origin
    h, w = pair.maps.shape[1:]
    # Only the taxels over the threshold enter a centroid, with their noise.
    err2 = np.where(pair.maps > 0, noise[:, r0:r0 + h, c0:c0 + w] ** 2, 0.0)
    if not alone:
        # A contact's share of a layer carries the same share of that layer's noise.
        full = maps[:, r0:r0 + h, c0:c0 + w]
        share = np.divide(pair.maps, full, out=np.zeros_like(full), where=full > 0)
        err2 *= share * share
        # Its bottom share is a guess: each taxel's load is its own with the mixture's
        # probability, a Bernoulli variance of the load times the share's complement.
        err2[1] += full[1] * full[1] * share[1] * (1.0 - share[1])
    basis = _axis_basis((h, w))
    moments = (pair.maps.reshape(2, -1) @ basis).tolist()
    noises = (err2.reshape(2, -1) @ basis).tolist()
    total = 0.0
    for m, e in zip(moments, noises):
        mass = m[0]
        # A share of a few counts (a far neighbour's tail in the mixture) has no centroid.
        if not mass > _MIN_MASS_COUNTS:
            return math.inf
        for first, second in ((1, 3), (2, 4)):
            centre = m[first] / mass
            var = max(m[second] / mass - centre * centre, 0.0)
            # sum e^2 (x - c)^2 = sum e^2 x^2 - 2 c sum e^2 x + c^2 sum e^2
            spread = (e[second] - 2.0 * centre * e[first] + centre * centre * e[0]) / (
                mass * mass)
            lock = math.exp(-2.0 * math.pi ** 2 * max(var - 1.0 / 12.0, 0.0)) / math.pi
            # Half of both axes: ``sigma`` stands for one axis of the shift.
            total += 0.5 * (max(spread, 0.0) + 0.5 * lock * lock)
    if cut_variance > 0.0:
        # A contact sharing the bottom load fits the mixture's share, which at the edge may be
        # a neighbour's load (docs/estimation.md): its fit bounds nothing below the flat rule.
        total += cut_variance if alone else max(cut_variance, _BORDER_SIGMA ** 2)
    elif pair.at_border:
        # No profile loaded at the edge, or a method without an uncertainty of its own: what
        # the map lost lies below the touch threshold.
        total += _BORDER_SIGMA ** 2
    return math.sqrt(total + calibration_variance)
