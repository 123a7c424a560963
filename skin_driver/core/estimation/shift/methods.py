"""
Estimators of the shift between the top and bottom imprints of a contact, selectable by name.

Every estimator takes one (2, h, w) float stack of the top and bottom touch counts (a
contact's window, see :class:`contacts.LayerPair`; ``linear`` ones get its force maps too) and
returns a :class:`ShiftEstimate`
``(dx, dy, confidence)``: the displacement of the bottom imprint relative to the top one in
taxels (dx along columns, dy along rows; the seed's convention, the same as
``cv2.phaseCorrelate(top, bottom)``) and the method's own confidence in [0, 1].

Registered names (stable; the benchmark compares them on the whole family of simulated skins):

* ``taxel_fit`` (default) -- a forward model of the taxels (:mod:`taxelfit`): each layer's
  marginal profiles, linearised by the layer's force curve, fitted by Gaussians integrated over
  the taxel cells, so the centres carry no sampling bias (pixel locking). Chosen by measurement
  over the family and its held-out draws (docs/estimation.md): the lowest error on most skins
  and scenes, and the only registered estimator no worse than the centroid difference on 16
  to 128 taxels a side over the same patch.
* ``poc`` -- band-limited phase-only correlation with a weighted fit of the cross-power phase
  plane (Fourier shift theorem) on the contact's window: the previous default; its band is in
  cycles per taxel, so it fails on fine grids (imprints tens of taxels wide).
* ``centroid`` -- difference of the weighted centroids of the two imprints: no assumption about
  the imprint's shape, about two thirds of the cost, a little less accurate on most skins.
* ``model_fit`` -- the skin's own forward model of the taxels (:mod:`taxelmodel`), learned by
  the force calibration from its presses, fitted to the window's counts from ``taxel_fit``'s
  estimate. Near the oracle's floor where the model holds the skin's physics
  (docs/estimation.md, "The forward model"), but Python only: milliseconds a contact, not yet
  for a live driver's every scan. Without a learned model it gives ``taxel_fit``'s estimate.

Reference, for comparison only (``REFERENCES``; a node cannot select it): ``seed`` --
``cv2.phaseCorrelate`` on the whole raw maps, no window, exactly as the paper.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
import math
from typing import Callable, NamedTuple

import cv2
import numpy as np

from .taxelfit import cell_fit_shift
from ..model.taxelmodel import DX, DY, fit_contact, start_of, TaxelModel
from ...common.validate import check_pair

__all__ = ['ShiftEstimate', 'Method', 'METHODS', 'DEFAULT_METHOD', 'REFERENCES', 'get_method',
           'method_names', 'resolve', 'estimate_shift']

_EPS = 1e-12
# Largest band DFT (taxels x bins) done as one dense product; beyond it the separable row and
# column products are cheaper (and the cached matrix would grow past 400 kB).
_DENSE_DFT_ENTRIES = 24576
# Cycles per taxel kept by the phase-plane fit: above it aliasing of the sharp top map dominates.
_BAND = 0.2


class ShiftEstimate(NamedTuple):
    """
    Shift of bottom relative to top in taxels, with a confidence in [0, 1].

    ``cut_variance``: the method's own uncertainty (taxels**2, one axis) of a shift whose
    imprints the map's edge cut (``taxel_fit``'s, :func:`taxelfit.cell_fit_shift`); 0 when none
    is cut or the method has none: the uncertainty then takes a flat rule (:mod:`uncertainty`).
    """

    dx: float
    dy: float
    confidence: float
    cut_variance: float = 0.0


NO_SHIFT = ShiftEstimate(0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Method:
    """
    A registered estimator: ``function`` maps a (2, h, w) top/bottom stack to a ShiftEstimate.

    ``whole_map`` methods get the whole raw count maps instead of one contact's window;
    ``linear`` ones get a (6, h, w) stack: the window's force maps (counts linearised by each
    layer's force curve), its counts, then 1 where a taxel is saturated (its reading a lower
    bound: at its force curve's censoring counts or cut by the ADC), else 0. ``modelled`` ones
    also get the calibration's :class:`taxelmodel.TaxelModel` (or None) and the window's taxel
    sensitivity (the inverse of the calibrated gains, (2, h, w), or None without gains).
    ``caution`` is what a live host must say when it runs the method ('' when nothing).
    ``every_scan`` False: the method takes longer than a scan of a live skin, so a live host
    estimates the newest scan it can instead of every one (:attr:`ContactEstimator.every_scan`).
    """

    name: str
    function: Callable
    whole_map: bool = False
    description: str = ''
    linear: bool = False
    modelled: bool = False
    caution: str = ''
    every_scan: bool = True


def _pad_size(n: int) -> int:
    return max(8, 1 << int(math.ceil(math.log2(max(2 * n, 2)))))


@lru_cache(maxsize=64)
def _plan(shape: tuple) -> dict:
    """Return padded size and band DFT matrices for one window shape (cached)."""
    h, w = int(shape[0]), int(shape[1])
    ph, pw = _pad_size(h), _pad_size(w)
    v = np.fft.fftfreq(ph)[:, None]
    u = np.fft.rfftfreq(pw)[None, :]
    # Direct DFT matrices for the few band bins: cheaper than a full FFT of the padded window.
    vb = v[np.abs(v[:, 0]) <= _BAND, 0]
    ub = u[0, np.abs(u[0]) <= _BAND]
    ey = np.exp(-2j * math.pi * np.outer(vb, np.arange(h)))
    ex = np.exp(-2j * math.pi * np.outer(np.arange(w), ub))
    bu = np.broadcast_to(ub[None, :], (vb.size, ub.size))
    bv = np.broadcast_to(vb[:, None], (vb.size, ub.size))
    keep = ~((bu == 0) & (bv == 0))
    bmult = np.where(bu > 0, 2.0, 1.0)
    bu, bv = bu[keep], bv[keep]
    dense = None
    if h * w * bu.size <= _DENSE_DFT_ENTRIES:
        # One matrix from the window's taxels to the band bins, real and imaginary parts
        # interleaved so that a real product viewed as complex gives the spectra in one call.
        full = np.einsum('iy,xj->ijyx', ey, ex).reshape(-1, h * w)[keep.ravel()]
        dense = np.ascontiguousarray(full.T).view(np.float64)
    return {'ph': ph, 'pw': pw,
            'ey': ey, 'ex': ex, 'keep': np.flatnonzero(keep.ravel()), 'dense': dense,
            'bmult': bmult[keep], 'band_fit': _PlaneBasis(bu, bv),
            # Bins of the lowest non-zero frequency along x and along y: the start of the fit.
            'start': [int(np.flatnonzero((bu == 1.0 / pw) & (bv == 0))[0]),
                      int(np.flatnonzero((bu == 0) & (bv == 1.0 / ph))[0])]}


class _PlaneBasis:
    """Frequencies of the bins a phase plane is fitted to, arranged for few numpy calls."""

    def __init__(self, u: np.ndarray, v: np.ndarray):
        # Rows 1, u, v: one product with the weighted copy gives the weight sum and the 2 x 2
        # normal matrix together.
        self.a = np.stack((np.ones_like(u), u, v))
        self.two_pi_uv = 2.0 * math.pi * np.stack((u, v))


def _fit_plane(cross: np.ndarray, weight: np.ndarray, basis: _PlaneBasis, sx: float, sy: float,
               iterations: int = 2) -> ShiftEstimate:
    """Fit the cross-power phase with the plane -2 pi (u sx + v sy) by weighted least squares."""
    weighted = basis.a * weight
    (total, _, _), (_, a11, a12), (_, _, a22) = (weighted @ basis.a.T).tolist()
    if total <= _EPS:
        return NO_SHIFT
    det = a11 * a22 - a12 * a12
    if det <= 1e-9 * max(a11 * a22, _EPS):
        return NO_SHIFT
    two_pi = 2.0 * math.pi
    # Rows 2 pi u, 2 pi v and the measured phase + pi: (sx, sy, 1) times it is the residual
    # phase + pi in one product, ready for a single wrap.
    plane = np.empty((3, cross.size))
    plane[:2] = basis.two_pi_uv
    np.arctan2(cross.imag, cross.real, out=plane[2])
    plane[2] += math.pi
    weighted_uv = weighted[1:]
    for _ in range(iterations):
        # Remove the current estimate so that the residual phase stays far from wrapping.
        residual = np.remainder(np.array((sx, sy, 1.0)) @ plane, two_pi)
        residual -= math.pi
        b1, b2 = (weighted_uv @ residual).tolist()
        b1, b2 = -b1 / two_pi, -b2 / two_pi
        sx += (a22 * b1 - a12 * b2) / det
        sy += (a11 * b2 - a12 * b1) / det
    if not (math.isfinite(sx) and math.isfinite(sy)):
        return NO_SHIFT
    # The extra pi turns every phasor around, which leaves the length of their sum unchanged.
    residual = np.array((sx, sy, 1.0)) @ plane
    coherence = math.hypot(weight @ np.cos(residual), weight @ np.sin(residual))
    return ShiftEstimate(sx, sy, min(max(coherence / total, 0.0), 1.0))


def _band_cross(maps: np.ndarray, plan: dict) -> np.ndarray:
    """Return the cross-power spectrum of a (2, h, w) top/bottom stack on the band bins."""
    if plan['dense'] is not None:
        spectra = (maps.reshape(2, -1) @ plan['dense']).view(np.complex128)
    else:
        spectra = (plan['ey'] @ maps @ plan['ex']).reshape(2, -1)[:, plan['keep']]
    return spectra[1] * spectra[0].conj()


def poc(maps: np.ndarray) -> ShiftEstimate:
    """
    Estimate the shift by band-limited phase-plane POC.

    The start comes from the phase of the lowest non-zero frequency on each axis (unambiguous
    for shifts below half the padded window, which is twice the contact window).
    """
    plan = _plan(maps.shape[1:])
    cross = _band_cross(maps, plan)
    # An empty layer gives a zero cross-power spectrum, which the fit rejects (no shift).
    cx, cy = cross[plan['start']].tolist()
    scale = -1.0 / (2 * math.pi)
    sx = math.atan2(cx.imag, cx.real) * plan['pw'] * scale
    sy = math.atan2(cy.imag, cy.real) * plan['ph'] * scale
    return _fit_plane(cross, np.abs(cross) * plan['bmult'], plan['band_fit'], sx, sy)


def centroid(maps: np.ndarray) -> ShiftEstimate:
    """Estimate the shift as the difference of the force-weighted centroids of the layers."""
    cols = maps.sum(axis=1)
    rows = maps.sum(axis=2)
    mass = cols.sum(axis=1)
    if not (mass[0] > 0 and mass[1] > 0):
        return NO_SHIFT
    cx = cols @ np.arange(maps.shape[2], dtype=np.float64) / mass
    cy = rows @ np.arange(maps.shape[1], dtype=np.float64) / mass
    return ShiftEstimate(float(cx[1] - cx[0]), float(cy[1] - cy[0]), 1.0)


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


def taxel_fit(maps: np.ndarray) -> ShiftEstimate:
    """
    Estimate the shift by cell-integrated profiles on linearised maps (:mod:`taxelfit`).

    ``maps`` is the (6, h, w) stack a ``linear`` method gets, or a plain (2, h, w) one.
    """
    linear = maps.shape[0] == 6
    found = cell_fit_shift(maps[:2], maps[2:4] if linear else None,
                           maps[4:] > 0 if linear else None)
    return NO_SHIFT if found is None else ShiftEstimate(*found)


def model_fit(maps: np.ndarray, model: TaxelModel = None,
              sensitivity: np.ndarray = None) -> ShiftEstimate:
    """
    Estimate the shift by fitting the skin's taxel model to the window's counts.

    ``maps`` is the (6, h, w) stack of a ``linear`` method; ``sensitivity`` the window's
    per-taxel sensitivity (the inverse of the calibrated gains) or None. The fit starts at
    ``taxel_fit``'s estimate and keeps its confidence and cut variance (the validity rule stays
    the default's).
    """
    first = taxel_fit(maps)
    if model is None or first is NO_SHIFT or maps.shape[0] != 6:
        return first
    fit = fit_contact(model, maps[2:4], maps[4:] > 0, start_of(maps[:2], first[:2], model),
                      sensitivity=sensitivity)
    return ShiftEstimate(float(fit.u[DX]), float(fit.u[DY]), first.confidence,
                         first.cut_variance)


METHODS = {m.name: m for m in (
    Method('poc', poc, False, 'band-limited phase-plane POC on the contact window'),
    Method('centroid', centroid, False,
           "difference of the layers' weighted centroids in the contact's window"),
    Method('taxel_fit', taxel_fit, False,
           'cell-integrated profiles fitted to the linearised window (default)', linear=True),
    Method('model_fit', model_fit, False,
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


def estimate_shift(top: np.ndarray, bottom: np.ndarray, method: str = DEFAULT_METHOD
                   ) -> ShiftEstimate:
    """Return the shift of ``bottom`` relative to ``top`` (checked maps): a method or reference."""
    t, b = check_pair(top, bottom, None)
    found = REFERENCES.get(method) or get_method(method)
    return found.function(np.stack((t, b)).astype(np.float64))
