"""
Shift by a forward model of the taxels: a continuous profile integrated over each taxel cell.

Where the information is lost: a taxel reports the load integrated over its cell, so the
centroid of a sampled imprint 2-3 taxels wide is pulled towards the nearest taxel centre by an
amount that depends on where the imprint sits within the taxel (sampling bias, "pixel
locking"), and the FSR's compressive curve, applied after the integration, distorts the cell
sums further. The sharp top imprint is hit hardest, so the shift inherits its bias as an offset
that follows the press's sub-taxel position, not noise.

What this estimator does instead, on maps already linearised by the layer's force curve (the
pipeline passes force maps to methods marked ``linear``; a layer flat at its peak, where the
force curve ends, is fitted on its counts instead):

* each layer's marginal profile along each axis (the window summed over the other axis) is
  modelled as a Gaussian of free centre, width and mass *integrated over unit taxel cells*,
  ``m_i = M * (Phi((i + 1/2 - mu) / s) - Phi((i - 1/2 - mu) / s))``, and fitted by
  Gauss-Newton from the centroid and the second moment;
* the shift is the difference of the fitted bottom and top centres.

Integrating the model over the cells is what removes the sampling bias: the fitted centre is a
continuous parameter of the profile, not a weighted mean of cell positions. The four fits
(two layers, two axes) are independent three-parameter problems, solved together.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ['fit_cell_profiles', 'cell_fit_shift']

_ITERATIONS = 8
# Centre steps below this (taxels) end the fit: a hundredth of the noise floor's shift error.
_TOLERANCE = 1e-4
_MIN_WIDTH = 0.25
_MIN_EXPLAINED = 0.5
# Profiles at least this wide (taxels, from the second moment) keep their centroid.
_WIDE = 1.5
# Taxels within this share of a layer's peak force sit on one plateau: the curve's cap.
_PLATEAU = 1e-9
_INV_SQRT2PI = 1.0 / math.sqrt(2.0 * math.pi)
# Abramowitz and Stegun 7.1.26: erf to 1.5e-7, far below the counts' noise.
_AS_P = 0.3275911
_AS = (0.254829592, -0.284496736, 1.421413741, -1.453152027, 1.061405429)


def _normal_cdf(u: np.ndarray) -> np.ndarray:
    """Return the standard normal CDF of ``u`` (numpy has no erf)."""
    x = np.abs(u) * (1.0 / math.sqrt(2.0))
    t = 1.0 / (1.0 + _AS_P * x)
    poly = t * (_AS[0] + t * (_AS[1] + t * (_AS[2] + t * (_AS[3] + t * _AS[4]))))
    half = 0.5 * poly * np.exp(-x * x)
    return np.where(u >= 0, 1.0 - half, half)


def fit_cell_profiles(profiles: np.ndarray, mask: np.ndarray) -> tuple:
    """
    Fit cell-integrated Gaussians to K marginal profiles (K x n; ``mask`` marks real cells).

    Returns (centres, widths, explained share of each profile's energy), cell units, centre 0 at
    the first cell's middle. A profile with no load gives NaN.
    """
    idx = np.arange(profiles.shape[1], dtype=np.float64)[None, :]
    # Cell i spans edges i and i + 1: one CDF per edge gives every cell's share.
    edges = np.arange(profiles.shape[1] + 1, dtype=np.float64)[None, :] - 0.5
    mass = profiles.sum(axis=1)
    safe = np.where(mass > 0, mass, 1.0)
    mu = (profiles @ idx[0]) / safe
    var = (profiles @ (idx[0] ** 2)) / safe - mu * mu
    s = np.sqrt(np.maximum(var - 1.0 / 12.0, _MIN_WIDTH ** 2))
    amp = mass.copy()
    start, start_width = mu.copy(), s.copy()
    # The centre stays within the cells the profile has (its loaded span and half a cell).
    low, high = -0.5, mask.sum(axis=1) - 0.5
    for _ in range(_ITERATIONS):
        u = (edges - mu[:, None]) / s[:, None]
        pdf = np.exp(-0.5 * u * u) * _INV_SQRT2PI
        cells = np.diff(_normal_cdf(u), axis=1) * mask
        d_mu = -np.diff(pdf, axis=1) * mask / s[:, None]
        d_s = -np.diff(u * pdf, axis=1) * mask / s[:, None]
        residual = profiles - amp[:, None] * cells
        jac = np.stack((cells, amp[:, None] * d_mu, amp[:, None] * d_s), axis=2)
        normal = np.einsum('kni,knj->kij', jac, jac) + 1e-12 * np.eye(3)
        rhs = np.einsum('kni,kn->ki', jac, residual)
        try:
            step = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            break
        # Damped: a step never moves the centre by more than a taxel nor the width by half.
        amp = amp + step[:, 0]
        mu = np.clip(mu + np.clip(step[:, 1], -1.0, 1.0), low, high)
        s = np.maximum(s + np.clip(step[:, 2], -0.5 * s, 0.5 * s), _MIN_WIDTH)
        if np.abs(step[:, 1]).max() < _TOLERANCE:
            break
    cells = np.diff(_normal_cdf((edges - mu[:, None]) / s[:, None]), axis=1) * mask
    residual = profiles - amp[:, None] * cells
    energy = (profiles * profiles).sum(axis=1)
    explained = 1.0 - (residual * residual).sum(axis=1) / np.where(energy > 0, energy, 1.0)
    # A fit that explains little of its profile (a shape far from any Gaussian, or a run-away
    # step) keeps the centroid it started from. So does a profile a taxel and a half wide: its
    # centroid's sampling bias, exp(-2 pi^2 s^2) / pi taxel, is nil, and the centroid takes
    # every cell as it is, where a Gaussian would misfit a flat or skewed imprint.
    keep = np.isfinite(mu) & (explained >= _MIN_EXPLAINED) & (start_width < _WIDE)
    mu = np.where(keep, mu, start)
    explained = np.where(np.isfinite(explained), explained, 0.0)
    bad = ~(mass > 0)
    mu = np.where(bad, np.nan, mu)
    return mu, s, np.where(bad, 0.0, np.maximum(explained, 0.0))


def _plateau(layer: np.ndarray) -> bool:
    """Return whether the layer's highest value is shared by several taxels (a clipped top)."""
    peak = layer.max()
    # Counts carry noise, so equal peak forces are the curve's cap (or, rarely, a tie: then the
    # layer is fitted on its counts, which costs a little accuracy and nothing else).
    return peak > 0 and int((layer >= peak * (1.0 - _PLATEAU)).sum()) >= 2


def cell_fit_shift(maps: np.ndarray, counts: np.ndarray = None):
    """
    Return (dx, dy, explained share) of a (2, h, w) linearised window, or None without load.

    dx, dy: the bottom's fitted centres less the top's, taxels; the explained share (the
    worst of the four fits) serves as the confidence. A layer whose linearised map is flat at
    its peak hit the end of the force curve: its force says nothing there, so that layer is
    fitted on its ``counts`` (same shape) when given. Each layer's centre is absolute, so the
    two layers need not be fitted on the same scale.
    """
    if counts is not None:
        maps = np.stack([c if _plateau(m) else m for m, c in zip(maps, counts)])
    h, w = maps.shape[1:]
    n = max(h, w)
    profiles = np.zeros((4, n))
    mask = np.zeros((4, n))
    # Rows 0, 1: top and bottom along x (columns); rows 2, 3: along y (rows).
    profiles[:2, :w] = maps.sum(axis=1)
    profiles[2:, :h] = maps.sum(axis=2)
    mask[:2, :w] = 1.0
    mask[2:, :h] = 1.0
    mu, _, explained = fit_cell_profiles(profiles, mask)
    if not np.isfinite(mu).all():
        return None
    return (float(mu[1] - mu[0]), float(mu[3] - mu[2]),
            float(min(max(explained.min(), 0.0), 1.0)))
