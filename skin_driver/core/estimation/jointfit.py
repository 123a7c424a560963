"""
Share the bottom load among several contacts by a joint forward fit of their bottom imprints.

The mixture of :mod:`contacts` places each bottom imprint by the load it sees on the map; two
presses a few taxels apart pushed different ways, or a press whose bottom imprint is shifted
partly off the map, hand it the wrong load. Here the bottom force map is modelled as what the
top imprints make of it: each contact's top force imprint, blurred by the elastic layer (a
Gaussian of width ``sigma`` integrated over the taxel cells), shifted by its own continuous
``s_k`` and scaled by the bottom/top force ratio ``a``, summed over the contacts:

    model(r, c) = a * sum_k sum_ij T_k(i, j) g(r - i - sy_k) g(c - j - sx_k),
    g(d) = Phi((d + 1/2) / sigma) - Phi((d - 1/2) / sigma).

The model is compared on the map only, so a shifted imprint's mass may leave it. ``sigma`` and
``a`` are the skin's (one layer, one load seen twice) and are fitted per frame with the shifts,
by Levenberg-Marquardt from the mixture's shifts and from every other pairing of the mixture's
components with the tops; the lowest misfit wins. Each contact's share of a bottom taxel is then
its part of the fitted model there.
"""

from __future__ import annotations

from itertools import permutations
import math

import numpy as np

from .taxelfit import _normal_cdf

__all__ = ['joint_shares']

_INV_SQRT2PI = 1.0 / math.sqrt(2.0 * math.pi)
_ITERATIONS = 20
_MIN_SIGMA = 0.25
# Another pairing replaces the mixture's only when it explains the bottom map clearly better:
# two presses of near equal force fit either way round, and the mixture's pairing is the prior.
_BETTER = 0.8
_NEAR = float(__import__('os').environ.get('MF_NEAR', '2.5'))
_ROUNDS = 3
_TOLERANCE = 1e-6
DEBUG = []
TRUTH = []


def _cells(n: int, shift: float, sigma: float) -> tuple:
    """Return G[r, i] = g(r - i - shift) (n x n) and its derivatives by shift and sigma."""
    d = np.arange(n, dtype=np.float64)[:, None] - np.arange(n, dtype=np.float64)[None, :] - shift
    hi, lo = (d + 0.5) / sigma, (d - 0.5) / sigma
    p_hi, p_lo = np.exp(-0.5 * hi * hi) * _INV_SQRT2PI, np.exp(-0.5 * lo * lo) * _INV_SQRT2PI
    return (_normal_cdf(hi) - _normal_cdf(lo), -(p_hi - p_lo) / sigma,
            -(hi * p_hi - lo * p_lo) / sigma)


def _model(tops: np.ndarray, params: np.ndarray, jacobian: bool):
    """Return the per-contact models (K, R, C) and, if asked, the Jacobian (R * C, 2 + 2K)."""
    k, rows, cols = tops.shape
    a, sigma = params[0], params[1]
    parts = np.empty(tops.shape)
    jac = np.zeros((rows * cols, 2 + 2 * k)) if jacobian else None
    for i in range(k):
        gy, gy_s, gy_w = _cells(rows, params[2 + 2 * i], sigma)
        gx, gx_s, gx_w = _cells(cols, params[3 + 2 * i], sigma)
        left = gy @ tops[i]
        unit = left @ gx.T
        parts[i] = a * unit
        if jacobian:
            right = tops[i] @ gx.T
            jac[:, 0] += unit.ravel()
            jac[:, 1] += a * (gy_w @ right + left @ gx_w.T).ravel()
            jac[:, 2 + 2 * i] = a * (gy_s @ right).ravel()
            jac[:, 3 + 2 * i] = a * (left @ gx_s.T).ravel()
    return parts, jac


def _fit(tops: np.ndarray, bottom: np.ndarray, params: np.ndarray) -> tuple:
    """Return (params, misfit) of Levenberg-Marquardt from ``params`` (a, sigma, sy, sx ...)."""
    target = bottom.ravel()
    parts, jac = _model(tops, params, True)
    residual = target - parts.sum(axis=0).ravel()
    cost = float(residual @ residual)
    damping = 1e-3
    for _ in range(_ITERATIONS):
        normal = jac.T @ jac
        rhs = jac.T @ residual
        scale = np.diag(normal) + 1e-12
        step = np.linalg.solve(normal + damping * np.diag(scale), rhs)
        trial = params + step
        trial[1] = max(trial[1], _MIN_SIGMA)
        trial[0] = max(trial[0], 0.0)
        t_parts, t_jac = _model(tops, trial, True)
        t_residual = target - t_parts.sum(axis=0).ravel()
        t_cost = float(t_residual @ t_residual)
        if t_cost < cost:
            moved = float(np.abs(trial[2:] - params[2:]).max())
            params, parts, jac, residual = trial, t_parts, t_jac, t_residual
            done = cost - t_cost <= _TOLERANCE * cost or moved < _TOLERANCE
            cost = t_cost
            damping = max(damping * 0.3, 1e-9)
            if done:
                break
        else:
            damping *= 10.0
            if damping > 1e8:
                break
    return params, cost, parts


def _peaks(bottom: np.ndarray) -> np.ndarray:
    """Return the (row, col) of the bottom map's local maxima above a tenth of its peak."""
    padded = np.pad(bottom, 1)
    rows, cols = bottom.shape
    around = np.max([padded[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols]
                     for dr in (-1, 0, 1) for dc in (-1, 0, 1)], axis=0)
    top = (bottom >= around) & (bottom > 0.1 * bottom.max())
    return np.argwhere(top).astype(np.float64)


def _moves(params: np.ndarray, centre: np.ndarray, peaks: np.ndarray) -> list:
    """Return starts that move one bottom imprint onto a peak or swap two imprints' places."""
    k = centre.shape[0]
    where = params[2:].reshape(k, 2) + centre
    out = []
    for i in range(k):
        for j in range(i + 1, k):
            moved = where.copy()
            moved[[i, j]] = moved[[j, i]]
            out.append(moved)
        for p in peaks:
            if np.abs(where[i] - p).max() > 1.0:
                moved = where.copy()
                moved[i] = p
                out.append(moved)
    return [np.concatenate((params[:2], (m - centre).ravel())) for m in out]


def joint_shares(tops: np.ndarray, bottom: np.ndarray, means: np.ndarray,
                 fallback: np.ndarray) -> np.ndarray:
    """
    Return each contact's share (K, rows, cols; summing to 1 where loaded) of the bottom map.

    ``tops``: the contacts' top force imprints (K, rows, cols); ``bottom``: the bottom force
    map; ``means``: the mixture's bottom centres (K, 2: row, col), component k paired with top
    k; ``fallback``: the mixture's shares, kept where the fitted model carries no load.
    """
    if __import__('os').environ.get('MF_OFF'):
        return fallback
    k, rows, cols = tops.shape
    mass = tops.sum(axis=(1, 2))
    if not (mass > 0).all() or not bottom.sum() > 0:
        return fallback
    rr, cc = np.indices((rows, cols), dtype=np.float64)
    centre = np.stack(((tops * rr).sum(axis=(1, 2)), (tops * cc).sum(axis=(1, 2))), 1)
    centre /= mass[:, None]
    ratio = bottom.sum() / mass.sum()
    first = _fit(tops, bottom, np.concatenate(([ratio, 1.0], (means - centre).ravel())))
    found = [first]
    for order in list(permutations(range(k)))[1:]:
        found.append(_fit(tops, bottom, np.concatenate(([ratio, 1.0],
                                                        (means[list(order)] - centre).ravel()))))
    found += [_fit(tops, bottom, s) for s in _moves(first[0], centre, _peaks(bottom))]
    floor = min(f[1] for f in found)
    near = [f for f in found if f[1] <= _NEAR * floor]
    mode = __import__('os').environ.get('MF_MODE', 'max')
    if mode == 'max':
        best = min(near, key=lambda f: np.abs(f[0][2:]).max())
    elif mode == 'sum2':
        best = min(near, key=lambda f: float(f[0][2:] @ f[0][2:]))
    else:
        w = float(mode)
        best = min(found, key=lambda f: f[1] / floor + w * float(f[0][2:] @ f[0][2:]) / k)
    keep = float(__import__('os').environ.get('MF_KEEP', '1'))
    if first[1] <= (1.0 - keep) * float((bottom * bottom).sum()):
        best = first
    if TRUTH:
        def miss(f):
            total = 0.0
            for i in range(k):
                t = min(TRUTH, key=lambda t: (t[0] - centre[i][0]) ** 2 + (t[1] - centre[i][1]) ** 2)
                total += abs(f[0][2 + 2 * i] - t[2]) + abs(f[0][3 + 2 * i] - t[3])
            return total
        best = min(found, key=miss)
    DEBUG.append(((), centre, best[0], best[1]))
    parts = np.maximum(best[2], 0.0)
    total = parts.sum(axis=0)
    explained = total > 1e-9 * max(total.max(), 1e-300)
    shares = np.where(explained, parts / np.where(explained, total, 1.0), fallback)
    return shares * (bottom > 0)
