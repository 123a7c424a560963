"""
A contact's censored taxels, in the Python description of the per-scan algorithm.

A taxel at its force curve's censoring counts (the film's resistance floor) or read at the ADC's
full scale only says its load is at least that much: such a layer's force sum is filled in from
its rims (:meth:`ForceCurve.imprint_force`), an unsaturated layer's sum gets its curve's rim load,
and the shift's fit takes the censored taxels as lower bounds (:func:`censored_taxels`).
"""

from __future__ import annotations

from dataclasses import replace
import math

import numpy as np

from .conditioning import mark_clipped
from .contacts import LayerPair


def force_window(pair: LayerPair, maps: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Return the pair's window of the force maps, its share of each taxel as in its counts."""
    r0, c0 = pair.origin
    h, w = pair.maps.shape[1:]
    counts = maps[:, r0:r0 + h, c0:c0 + w]
    share = np.divide(pair.maps, counts, out=np.zeros_like(pair.maps), where=counts > 0)
    return force[:, r0:r0 + h, c0:c0 + w] * share


def marked_counts(pair: LayerPair, clipped: np.ndarray, full_scale: float) -> np.ndarray:
    """
    Return the pair's counts with the taxels ``clipped`` marks at ``full_scale`` (or as is).

    ``clipped`` marks the taxels of the whole maps read at the ADC's full scale (or None):
    censored whatever their tared counts (:func:`conditioning.mark_clipped`).
    """
    if clipped is None:
        return pair.maps
    r0, c0 = pair.origin
    h, w = pair.maps.shape[1:]
    return mark_clipped(pair.maps, clipped[:, r0:r0 + h, c0:c0 + w], full_scale)


def censored_taxels(marked: np.ndarray, curves) -> np.ndarray:
    """Return 1.0 where a taxel of the marked counts is saturated (a lower bound), else 0.0."""
    ceilings = [c.censor_counts if c is not None and c.censor_counts else math.inf
                for c in (curves or (None, None))]
    return np.stack([own >= ceiling for own, ceiling in zip(marked, ceilings)]).astype(np.float64)


def with_censored_sums(pair: LayerPair, marked: np.ndarray, window: np.ndarray,
                       curves) -> LayerPair:
    """
    Return ``pair`` with its layers' force sums as the censoring curves read them.

    ``marked`` are its counts from :func:`marked_counts`, ``window`` its share of the force maps
    (:func:`force_window`): a saturated layer's sum is filled in from its rims, rim load
    included; an unsaturated one's gets its curve's rim load.
    """
    saturated = [bool(c.censor_counts and own.max() >= c.censor_counts)
                 for own, c in zip(marked, curves)]
    sums = [curve.imprint_force(own, force) if hit else float(curve.with_rim(total))
            for own, force, hit, total, curve in zip(
                marked, window, saturated, (pair.top_force_n, pair.bottom_force_n), curves)]
    return replace(pair, top_force_n=sums[0], bottom_force_n=sums[1])
