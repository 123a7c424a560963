"""
How a simulated indenter loads the skin and how each taxel collects that load.

The pressure under a tip and the taxel's pad are sampled on a fine grid (``sub`` samples a
taxel). The cover and the elastic layer spread the load by a Gaussian, and each taxel adds up
what lands on its active pad. Spread and pad sum are linear and act on each axis on its own, so
on one axis they make one matrix and a layer's per-taxel load is ``A_y @ fine @ A_x.T``.
"""

from __future__ import annotations

from functools import lru_cache
import math

import numpy as np

__all__ = ['hertz_pressure', 'pad_sum', 'spread', 'taxel_operator']


def hertz_pressure(xs: np.ndarray, ys: np.ndarray, centre: tuple, radius: float,
                   aspect: float = 1.0, turn: float = 0.0) -> np.ndarray:
    """
    Return the shape ``sqrt(1 - rho**2)`` of a Hertz contact's pressure on the grid ys by xs.

    ``rho`` is the distance from ``centre`` in units of the contact's semi-axes: ``radius`` along
    the direction ``turn`` from +x, ``radius * aspect`` across it. Zero outside the contact.
    """
    dx = np.asarray(xs, dtype=np.float64) - centre[0]
    dy = np.asarray(ys, dtype=np.float64) - centre[1]
    if aspect == 1.0:
        rho2 = (dx[None, :] ** 2 + dy[:, None] ** 2) / (radius * radius)
    else:
        along = (dx[None, :] * math.cos(turn) + dy[:, None] * math.sin(turn)) / radius
        across = (dy[:, None] * math.cos(turn) - dx[None, :] * math.sin(turn)) / (radius * aspect)
        rho2 = along ** 2 + across ** 2
    return np.sqrt(np.clip(1.0 - rho2, 0.0, None))


@lru_cache(maxsize=512)
def pad_sum(cells: int, sub: int, fill: float) -> np.ndarray:
    """
    Return the (cells x cells*sub) matrix adding each taxel's fine samples over its pad.

    The pad is the centred ``fill`` share of the taxel; a fine sample the pad's edge cuts
    counts by the share of it the pad covers.
    """
    pad = (0.5 - fill / 2.0, 0.5 + fill / 2.0)
    lo = np.arange(sub) / sub
    hi = np.arange(1, sub + 1) / sub
    covered = np.clip(np.minimum(hi, pad[1]) - np.maximum(lo, pad[0]), 0.0, None) * sub
    out = np.kron(np.eye(cells), covered)
    out.flags.writeable = False
    return out


@lru_cache(maxsize=512)
def spread(n: int, sigma: float) -> np.ndarray:
    """
    Return the (n x n) matrix spreading each of ``n`` fine samples by a Gaussian of ``sigma``.

    The Gaussian is cut past about four sigma and normalised over what is kept; load spread
    past either end of the axis is lost.
    """
    reach = (int(round(8.0 * sigma + 1.0)) | 1) // 2
    taps = np.exp(-0.5 * (np.arange(-reach, reach + 1) / sigma) ** 2)
    taps = taps / taps.sum()
    # The weight by distance in samples: the Gaussian's right half, then nothing.
    by_distance = np.append(taps[reach:], 0.0)
    distance = np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    out = by_distance[np.minimum(distance, reach + 1)]
    out.flags.writeable = False
    return out


@lru_cache(maxsize=512)
def taxel_operator(cells: int, sub: int, fill: float, sigma: float) -> np.ndarray:
    """Return the (cells x cells*sub) matrix that spreads a fine axis, then sums it per pad."""
    if sigma <= 0:
        return pad_sum(cells, sub, fill)
    out = pad_sum(cells, sub, fill) @ spread(cells * sub, sigma)
    out.flags.writeable = False
    return out
