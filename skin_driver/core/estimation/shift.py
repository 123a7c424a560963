"""
Estimators of the shift between the top and bottom maps of a contact, selectable by name.

Every estimator takes two float maps of equal shape (``top``, ``bottom``) and returns a
:class:`ShiftEstimate` ``(dx, dy, confidence)``: the displacement of ``bottom`` relative to
``top`` in taxels (dx along columns, dy along rows; the seed's convention, the same as
``cv2.phaseCorrelate(top, bottom)``) and a confidence in [0, 1].

Registered names (stable, the benchmark compares them):

* ``seed`` -- ``cv2.phaseCorrelate`` on the whole raw maps, no window, exactly as the paper.
* ``hann`` -- ``cv2.phaseCorrelate`` with a Hann window on the zero-padded contact window.
* ``poc_peak`` -- zero-padded phase-only correlation, surface upsampled twice, quadratic peak fit.
* ``blpoc`` -- band-limited phase-only correlation (low quarter of the spectrum), upsampled
  surface and quadratic peak fit.
* ``upsampled`` -- upsampled cross-correlation (matrix-multiply DFT around the coarse peak,
  1/100 taxel), own numpy implementation.
* ``centroid`` -- difference of the force-weighted centroids.
* ``poc`` (default) -- phase-plane POC: the integer part from the phase-only correlation peak,
  the sub-taxel part from a weighted least-squares fit of the cross-power phase, which is linear
  in the shift (Fourier shift theorem). Weighting by the cross-power magnitude keeps the noisy
  frequencies that whitening would amplify out of the fit; fitting the phase plane avoids the
  pixel-locking bias of interpolating a correlation peak.
* ``poc_centroid`` -- the same phase-plane fit started from the centroid difference (no inverse
  transform).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
import math
from typing import Callable, NamedTuple

import cv2
import numpy as np

__all__ = ['ShiftEstimate', 'Method', 'METHODS', 'DEFAULT_METHOD', 'get_method',
           'method_names', 'estimate_shift']

_EPS = 1e-12
# Largest band DFT (taxels x bins) done as one dense product; beyond it the separable row and
# column products are cheaper (and the cached matrix would grow past 400 kB).
_DENSE_DFT_ENTRIES = 24576
# Cycles per taxel kept by the phase-plane fit: above it aliasing of the sharp top map dominates.
_BAND = 0.2


class ShiftEstimate(NamedTuple):
    """Shift of bottom relative to top in taxels, with a confidence in [0, 1]."""

    dx: float
    dy: float
    confidence: float


NO_SHIFT = ShiftEstimate(0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Method:
    """
    A registered estimator; ``whole_map`` methods get the full raw count maps.

    ``stacked``, when set, does the work of ``function`` on both maps stacked in one
    (2, rows, cols) float64 array, which the pipeline already holds; it saves a copy and lets
    both layers go through each numpy call together.
    """

    name: str
    function: Callable
    whole_map: bool = False
    description: str = ''
    stacked: Callable = None


def _pad_size(n: int) -> int:
    return max(8, 1 << int(math.ceil(math.log2(max(2 * n, 2)))))


@lru_cache(maxsize=64)
def _plan(shape: tuple) -> dict:
    """Return padded size, frequency grids and band DFT matrices for one window shape (cached)."""
    h, w = int(shape[0]), int(shape[1])
    ph, pw = _pad_size(h), _pad_size(w)
    v = np.fft.fftfreq(ph)[:, None]
    u = np.fft.rfftfreq(pw)[None, :]
    # Half-plane columns other than 0 and Nyquist stand for two conjugate bins.
    mult = np.full(u.shape, 2.0)
    mult[0, 0] = 1.0
    if pw % 2 == 0:
        mult[0, -1] = 1.0
    band = (np.abs(u) <= _BAND) & (np.abs(v) <= _BAND)
    band = band & ~((u == 0) & (v == 0))
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
    fu, fv = np.broadcast_arrays(u, v)
    dense = None
    if h * w * bu.size <= _DENSE_DFT_ENTRIES:
        # One matrix from the window's taxels to the band bins, real and imaginary parts
        # interleaved so that a real product viewed as complex gives the spectra in one call.
        full = np.einsum('iy,xj->ijyx', ey, ex).reshape(-1, h * w)[keep.ravel()]
        dense = np.ascontiguousarray(full.T).view(np.float64)
    return {'ph': ph, 'pw': pw, 'fft_mult': np.broadcast_to(mult, band.shape)[band],
            'band': band, 'oy': (ph - h) // 2, 'ox': (pw - w) // 2,
            'hann': cv2.createHanningWindow((pw, ph), cv2.CV_64F),
            'ey': ey, 'ex': ex, 'keep': np.flatnonzero(keep.ravel()), 'dense': dense,
            'bmult': bmult[keep],
            'band_fit': _PlaneBasis(bu, bv), 'fft_fit': _PlaneBasis(fu[band], fv[band]),
            # Bins of the lowest non-zero frequency along x and along y: the start of the fit.
            'start': [int(np.flatnonzero((bu == 1.0 / pw) & (bv == 0))[0]),
                      int(np.flatnonzero((bu == 0) & (bv == 1.0 / ph))[0])],
            'rows': np.arange(h, dtype=np.float64),
            'cols': np.arange(w, dtype=np.float64)}


def _embed(a: np.ndarray, plan: dict) -> np.ndarray:
    out = np.zeros((plan['ph'], plan['pw']))
    out[plan['oy']:plan['oy'] + a.shape[0], plan['ox']:plan['ox'] + a.shape[1]] = a
    return out


def _usable(top: np.ndarray, bottom: np.ndarray) -> bool:
    return bool(top.any() and bottom.any())


def _signed(i: int, n: int) -> int:
    return i - n if i > n // 2 else i


def _cross_power(top: np.ndarray, bottom: np.ndarray, plan: dict) -> np.ndarray:
    t = np.fft.rfft2(top, s=(plan['ph'], plan['pw']))
    b = np.fft.rfft2(bottom, s=(plan['ph'], plan['pw']))
    return b * np.conj(t)


def _poc_peak_integer(cross: np.ndarray, plan: dict) -> tuple:
    surface = np.fft.irfft2(cross / (np.abs(cross) + _EPS), s=(plan['ph'], plan['pw']))
    iy, ix = np.unravel_index(int(np.argmax(surface)), surface.shape)
    return float(_signed(ix, plan['pw'])), float(_signed(iy, plan['ph']))


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


def _phase_plane(cross: np.ndarray, plan: dict, sx: float, sy: float) -> ShiftEstimate:
    c = cross[plan['band']]
    return _fit_plane(c, np.abs(c) * plan['fft_mult'], plan['fft_fit'], sx, sy)


def poc_fft(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift by phase-plane POC seeded by the integer peak of the full POC."""
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    cross = _cross_power(top, bottom, plan)
    sx, sy = _poc_peak_integer(cross, plan)
    return _phase_plane(cross, plan, sx, sy)


def _centroid_shift(top: np.ndarray, bottom: np.ndarray, plan: dict = None) -> tuple:
    if plan is None:
        plan = _plan(top.shape)
    rows, cols = plan['rows'], plan['cols']
    tc, bc = top.sum(axis=0), bottom.sum(axis=0)
    mt, mb = float(tc.sum()), float(bc.sum())
    dx = (bc @ cols) / mb - (tc @ cols) / mt
    dy = (bottom.sum(axis=1) @ rows) / mb - (top.sum(axis=1) @ rows) / mt
    return float(dx), float(dy), min(mt, mb) / max(mt, mb)


def poc(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """
    Estimate the shift by band-limited phase-plane POC.

    The start comes from the phase of the lowest non-zero frequency on each axis (unambiguous
    for shifts below half the padded window, which is twice the contact window).
    """
    return poc_stacked(np.stack((top, bottom)))


def poc_stacked(maps: np.ndarray) -> ShiftEstimate:
    """Do the work of :func:`poc` on the (2, h, w) stack of top and bottom."""
    plan = _plan(maps.shape[1:])
    cross = _band_cross(maps, plan)
    # An empty layer gives a zero cross-power spectrum, which the fit rejects (no shift).
    cx, cy = cross[plan['start']].tolist()
    scale = -1.0 / (2 * math.pi)
    sx = math.atan2(cx.imag, cx.real) * plan['pw'] * scale
    sy = math.atan2(cy.imag, cy.real) * plan['ph'] * scale
    return _fit_plane(cross, np.abs(cross) * plan['bmult'], plan['band_fit'], sx, sy)


def poc_centroid_weighted(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift like ``poc`` with the phase weighted by the squared magnitude."""
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    cross = _band_cross(np.stack((top, bottom)), plan)
    sx, sy, _ = _centroid_shift(top, bottom, plan)
    mag = np.abs(cross)
    return _fit_plane(cross, mag * mag * plan['bmult'], plan['band_fit'], sx, sy)


def centroid(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift as the difference of the force-weighted centroids."""
    if not _usable(top, bottom):
        return NO_SHIFT
    dx, dy, ratio = _centroid_shift(top, bottom)
    return ShiftEstimate(dx, dy, ratio)


def seed(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift with ``cv2.phaseCorrelate`` and no window, as the seed paper does."""
    if not _usable(top, bottom):
        return NO_SHIFT
    (dx, dy), response = cv2.phaseCorrelate(np.ascontiguousarray(top, dtype=np.float64),
                                            np.ascontiguousarray(bottom, dtype=np.float64))
    if not (math.isfinite(dx) and math.isfinite(dy)):
        return NO_SHIFT
    conf = response if math.isfinite(response) else 0.0
    return ShiftEstimate(float(dx), float(dy), min(max(float(conf), 0.0), 1.0))


def hann(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift with ``cv2.phaseCorrelate`` and a Hann window on the padded window."""
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    (dx, dy), response = cv2.phaseCorrelate(_embed(top, plan), _embed(bottom, plan),
                                            window=plan['hann'])
    if not (math.isfinite(dx) and math.isfinite(dy)):
        return NO_SHIFT
    conf = response if math.isfinite(response) else 0.0
    return ShiftEstimate(float(dx), float(dy), min(max(float(conf), 0.0), 1.0))


def _centred_spectrum_surface(spectrum: np.ndarray, factor: int) -> np.ndarray:
    """Return the real correlation surface of a full spectrum upsampled by ``factor``."""
    ph, pw = spectrum.shape
    big = np.zeros((ph * factor, pw * factor), dtype=complex)
    shifted = np.fft.fftshift(spectrum)
    oy, ox = (ph * factor - ph) // 2, (pw * factor - pw) // 2
    big[oy:oy + ph, ox:ox + pw] = shifted
    return np.fft.ifft2(np.fft.ifftshift(big)).real


def _quadratic_peak(surface: np.ndarray, factor: int, ideal: float) -> ShiftEstimate:
    h, w = surface.shape
    iy, ix = np.unravel_index(int(np.argmax(surface)), surface.shape)
    peak = surface[iy, ix]
    offsets = []
    for lo, hi in ((surface[iy, (ix - 1) % w], surface[iy, (ix + 1) % w]),
                   (surface[(iy - 1) % h, ix], surface[(iy + 1) % h, ix])):
        den = lo - 2.0 * peak + hi
        offsets.append(0.5 * (lo - hi) / den if den < 0 else 0.0)
    dx = (_signed(ix, w) + offsets[0]) / factor
    dy = (_signed(iy, h) + offsets[1]) / factor
    # ``ideal`` is the peak of a perfect match: all unit phasors adding up in phase.
    conf = float(peak / max(ideal, _EPS))
    return ShiftEstimate(float(dx), float(dy), min(max(conf, 0.0), 1.0))


def _full_normalised_cross(top, bottom, plan, band=None):
    t = np.fft.fft2(top, s=(plan['ph'], plan['pw']))
    b = np.fft.fft2(bottom, s=(plan['ph'], plan['pw']))
    cross = b * np.conj(t)
    cross = cross / (np.abs(cross) + _EPS)
    if band is not None:
        v = np.fft.fftfreq(plan['ph'])[:, None]
        u = np.fft.fftfreq(plan['pw'])[None, :]
        cross = cross * ((np.abs(u) <= band) & (np.abs(v) <= band))
    return cross


def poc_peak(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift by zero-padded POC with a quadratic sub-pixel peak fit."""
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    cross = _full_normalised_cross(top, bottom, plan)
    surface = _centred_spectrum_surface(cross, 2)
    return _quadratic_peak(surface, 2, float(np.abs(cross).sum()) / surface.size)


def blpoc(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift by band-limited POC with a quadratic sub-pixel peak fit."""
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    cross = _full_normalised_cross(top, bottom, plan, 0.25)
    surface = _centred_spectrum_surface(cross, 4)
    return _quadratic_peak(surface, 4, float(np.abs(cross).sum()) / surface.size)


def upsampled(top: np.ndarray, bottom: np.ndarray, factor: int = 100) -> ShiftEstimate:
    """Estimate the shift by upsampled cross-correlation (matrix DFT around the coarse peak)."""
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    ph, pw = plan['ph'], plan['pw']
    cross = _full_normalised_cross(top, bottom, plan)
    coarse = np.fft.ifft2(cross).real
    iy, ix = np.unravel_index(int(np.argmax(coarse)), coarse.shape)
    sy0, sx0 = float(_signed(iy, ph)), float(_signed(ix, pw))
    half = int(math.ceil(1.5 * factor / 2))
    offs = np.arange(-half, half + 1) / factor
    ky = np.fft.fftfreq(ph) * ph
    kx = np.fft.fftfreq(pw) * pw
    ey = np.exp(2j * math.pi * np.outer(sy0 + offs, ky) / ph)
    ex = np.exp(2j * math.pi * np.outer(kx, sx0 + offs) / pw)
    fine = (ey @ cross @ ex).real
    jy, jx = np.unravel_index(int(np.argmax(fine)), fine.shape)
    conf = float(fine[jy, jx] / max(float(np.abs(cross).sum()), _EPS))
    return ShiftEstimate(sx0 + offs[jx], sy0 + offs[jy], min(max(conf, 0.0), 1.0))


METHODS = {m.name: m for m in (
    Method('seed', seed, True, 'cv2.phaseCorrelate on the whole raw maps, no window (paper)'),
    Method('hann', hann, False, 'cv2.phaseCorrelate with a Hann window on the contact window'),
    Method('poc', poc, False, 'band-limited phase-plane POC seeded by the centroids (default)',
           poc_stacked),
    Method('poc_fft', poc_fft, False, 'phase-plane POC seeded by the full POC peak'),
    Method('poc_weighted', poc_centroid_weighted, False,
           'like poc, phase weighted by the squared cross-power magnitude'),
    Method('poc_peak', poc_peak, False, 'zero-padded POC, quadratic peak fit'),
    Method('blpoc', blpoc, False, 'band-limited POC, quadratic peak fit'),
    Method('upsampled', upsampled, False, 'upsampled cross-correlation, 1/100 taxel'),
    Method('centroid', centroid, False, 'difference of force-weighted centroids'),
)}

DEFAULT_METHOD = 'poc'


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
    """Return the shift of ``bottom`` relative to ``top`` with the named estimator."""
    from .validate import check_pair
    t, b = check_pair(top, bottom, None)
    return get_method(method).function(np.asarray(t, dtype=np.float64),
                                       np.asarray(b, dtype=np.float64))
