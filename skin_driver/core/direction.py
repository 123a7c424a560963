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
    """A registered estimator; ``whole_map`` methods get the full raw count maps."""

    name: str
    function: Callable
    whole_map: bool = False
    description: str = ''


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
    return {'ph': ph, 'pw': pw, 'u': u, 'v': v, 'mult': mult, 'band': band,
            'oy': (ph - h) // 2, 'ox': (pw - w) // 2,
            'hann': cv2.createHanningWindow((pw, ph), cv2.CV_64F),
            'ey': ey, 'ex': ex, 'keep': keep, 'bu': bu[keep], 'bv': bv[keep],
            'bmult': bmult[keep],
            'iu1': int(np.flatnonzero((bu[keep] == 1.0 / pw) & (bv[keep] == 0))[0]),
            'iv1': int(np.flatnonzero((bu[keep] == 0) & (bv[keep] == 1.0 / ph))[0]),
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


def _fit_plane(cross: np.ndarray, weight: np.ndarray, u: np.ndarray, v: np.ndarray,
               sx: float, sy: float, iterations: int = 2) -> ShiftEstimate:
    """Fit the cross-power phase with the plane -2 pi (u sx + v sy) by weighted least squares."""
    total = float(weight.sum())
    if total <= _EPS:
        return NO_SHIFT
    wu, wv = weight * u, weight * v
    a11, a22, a12 = float(wu @ u), float(wv @ v), float(wu @ v)
    det = a11 * a22 - a12 * a12
    if det <= 1e-9 * max(a11 * a22, _EPS):
        return NO_SHIFT
    two_pi = 2.0 * math.pi
    phase = np.angle(cross)
    tu, tv = two_pi * u, two_pi * v
    for _ in range(iterations):
        # Remove the current estimate so that the residual phase stays far from wrapping.
        residual = np.remainder(phase + tu * sx + tv * sy + math.pi, two_pi) - math.pi
        b1 = -float(wu @ residual) / two_pi
        b2 = -float(wv @ residual) / two_pi
        sx += (a22 * b1 - a12 * b2) / det
        sy += (a11 * b2 - a12 * b1) / det
    if not (math.isfinite(sx) and math.isfinite(sy)):
        return NO_SHIFT
    residual = phase + tu * sx + tv * sy
    coherence = math.hypot(float(weight @ np.cos(residual)), float(weight @ np.sin(residual)))
    return ShiftEstimate(float(sx), float(sy), min(max(coherence / total, 0.0), 1.0))


def _band_cross(top: np.ndarray, bottom: np.ndarray, plan: dict) -> np.ndarray:
    ey, ex = plan['ey'], plan['ex']
    t = (ey @ top @ ex)[plan['keep']]
    b = (ey @ bottom @ ex)[plan['keep']]
    return b * np.conj(t)


def _phase_plane(cross: np.ndarray, plan: dict, sx: float, sy: float) -> ShiftEstimate:
    sel = plan['band']
    u, v = np.broadcast_arrays(plan['u'], plan['v'])
    c = cross[sel]
    return _fit_plane(c, np.abs(c) * np.broadcast_to(plan['mult'], sel.shape)[sel],
                      u[sel], v[sel], sx, sy)


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
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    cross = _band_cross(top, bottom, plan)
    sx = -math.atan2(cross[plan['iu1']].imag, cross[plan['iu1']].real) * plan['pw'] / (2 * math.pi)
    sy = -math.atan2(cross[plan['iv1']].imag, cross[plan['iv1']].real) * plan['ph'] / (2 * math.pi)
    return _fit_plane(cross, np.abs(cross) * plan['bmult'], plan['bu'], plan['bv'], sx, sy)


def poc_centroid_weighted(top: np.ndarray, bottom: np.ndarray) -> ShiftEstimate:
    """Estimate the shift like ``poc`` with the phase weighted by the squared magnitude."""
    if not _usable(top, bottom):
        return NO_SHIFT
    plan = _plan(top.shape)
    cross = _band_cross(top, bottom, plan)
    sx, sy, _ = _centroid_shift(top, bottom, plan)
    mag = np.abs(cross)
    return _fit_plane(cross, mag * mag * plan['bmult'], plan['bu'], plan['bv'], sx, sy)


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
    Method('poc', poc, False, 'band-limited phase-plane POC seeded by the centroids (default)'),
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
