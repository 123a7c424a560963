"""
The shift estimators, selectable by name, and the references they are compared with.

A method estimates the shift between the top and bottom imprints of a contact: the
displacement of the bottom imprint relative to the top one in taxels (dx along columns, dy
along rows; the seed's convention, the same as ``cv2.phaseCorrelate(top, bottom)``) and the
method's own confidence in [0, 1]. The registered methods run in the compiled kernel
(``skin_kernel``, :mod:`..scan.kernel`); this module names them and says what each needs.

Registered names (stable; the benchmark compares them on the whole family of simulated skins):

* ``taxel_fit`` (default) -- a forward model of the taxels: each layer's marginal profiles,
  linearised by the layer's force curve, fitted by Gaussians integrated over the taxel cells,
  so the centres carry no sampling bias (pixel locking). Chosen by measurement over the family
  and its held-out draws (docs/estimation.md): the lowest error on most skins and scenes.
* ``poc`` -- band-limited phase-only correlation with a weighted fit of the cross-power phase
  plane (Fourier shift theorem) on the contact's window; its band is in cycles per taxel, so
  it fails on fine grids (imprints tens of taxels wide).
* ``centroid`` -- difference of the weighted centroids of the two imprints: no assumption about
  the imprint's shape, a little less accurate on most skins.
* ``model_fit`` -- the skin's own forward model of the taxels (:mod:`..model.taxelmodel`),
  learned by the force calibration from its presses, fitted to the window's counts from
  ``taxel_fit``'s estimate; milliseconds a contact. Without a learned model it gives
  ``taxel_fit``'s estimate.

Reference, for comparison only (``REFERENCES``; a node cannot select it): ``seed`` --
``cv2.phaseCorrelate`` on the whole raw maps, no window, exactly as the paper. A reference is
Python: the estimator runs it inside the kernel's pipeline, which takes only its shift.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Callable, NamedTuple

import cv2
import numpy as np

__all__ = ['ShiftEstimate', 'Method', 'METHODS', 'DEFAULT_METHOD', 'REFERENCES', 'get_method',
           'method_names', 'resolve', 'paper_phase_correlation']


class ShiftEstimate(NamedTuple):
    """
    Shift of bottom relative to top in taxels, with a confidence in [0, 1].

    ``cut_variance``: the method's own uncertainty (taxels**2, one axis) of a shift whose
    imprints the map's edge cut; 0 when none is cut or the method has none.
    """

    dx: float
    dy: float
    confidence: float
    cut_variance: float = 0.0


NO_SHIFT = ShiftEstimate(0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Method:
    """
    An estimator, registered (run by the kernel, ``function`` None) or a reference.

    A reference's ``function`` maps a (2, h, w) top/bottom stack of counts to a ShiftEstimate.

    ``whole_map`` references get the whole raw count maps instead of one contact's window.
    ``linear`` methods fit the window's force maps (counts linearised by each layer's force
    curve) and know its censored taxels; ``modelled`` ones also need the calibration's
    :class:`taxelmodel.TaxelModel`.
    ``caution`` is what a live host must say when it runs the method ('' when nothing).
    ``every_scan`` False: the method takes longer than a scan of a live skin, so a live host
    estimates the newest scan it can instead of every one (:attr:`ContactEstimator.every_scan`).
    """

    name: str
    function: Callable = None
    whole_map: bool = False
    description: str = ''
    linear: bool = False
    modelled: bool = False
    caution: str = ''
    every_scan: bool = True


def paper_phase_correlation(maps: np.ndarray) -> ShiftEstimate:
    """Estimate the shift with ``cv2.phaseCorrelate`` on the whole maps, as the seed paper does."""
    top, bottom = maps
    if not (top.any() and bottom.any()):
        return NO_SHIFT
    (dx, dy), response = cv2.phaseCorrelate(np.ascontiguousarray(top, dtype=np.float64),
                                            np.ascontiguousarray(bottom, dtype=np.float64))
    if not (math.isfinite(dx) and math.isfinite(dy)):
        return NO_SHIFT
    conf = response if math.isfinite(response) else 0.0
    return ShiftEstimate(float(dx), float(dy), min(max(float(conf), 0.0), 1.0))


METHODS = {m.name: m for m in (
    Method('poc', None, False, 'band-limited phase-plane POC on the contact window'),
    Method('centroid', None, False,
           "difference of the layers' weighted centroids in the contact's window"),
    Method('taxel_fit', None, False,
           'cell-integrated profiles fitted to the linearised window (default)', linear=True),
    Method('model_fit', None, False,
           "the skin's learned taxel model fitted to the window's counts (slow)",
           linear=True, modelled=True,
           caution=('model_fit fits each contact in milliseconds (tens on a film that turns '
                    'on): contacts come from the newest scan each time a fit ends, not from '
                    'every scan'),
           every_scan=False),
)}

DEFAULT_METHOD = 'taxel_fit'

# References the evaluator, the benchmark and the demo compare with, never run by a node: the
# paper's method (named for the seed paper) is worse than every registered one everywhere.
REFERENCES = {m.name: m for m in (
    Method('seed', paper_phase_correlation, True,
           "the paper's cv2.phaseCorrelate on the whole raw maps, no window"),
)}


def resolve(name: str) -> tuple:
    """
    Return (registered method to configure, shift override or None) for an estimator name.

    A reference runs in the default's pipeline with only its shift swapped in.
    """
    if name in REFERENCES:
        return DEFAULT_METHOD, REFERENCES[name]
    get_method(name)
    return name, None


def method_names() -> list:
    """Return the registered estimator names, default first."""
    return [DEFAULT_METHOD] + sorted(n for n in METHODS if n != DEFAULT_METHOD)


def get_method(name: str) -> Method:
    """Return the registered estimator called ``name`` or raise ValueError listing the names."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise ValueError(f'unknown direction method {name!r}; known: '
                         f'{", ".join(method_names())}') from None
