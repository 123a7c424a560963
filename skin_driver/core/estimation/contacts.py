"""Segment conditioned force maps into contacts with sub-taxel location, force, area and window."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from .validate import check_number, check_pair

__all__ = ['Segment', 'find_contacts', 'segment', 'segment_stacked', 'contact_windows',
           'window_stack']


@dataclass(frozen=True)
class Segment:
    """
    One contact found in the maps; positions in metres, window as taxel index bounds.

    ``row``/``col`` are the force-weighted centroid on the top layer in (fractional) taxels;
    ``window`` is ``(r0, r1, c0, c1)``, half-open, covering the contact on both layers plus a
    margin, where the shift between the layers is measured. ``bottom_force_n``,
    ``bottom_row``/``bottom_col`` and ``bottom_spread`` (variance along rows plus along columns,
    taxels squared) describe the contact on the bottom layer (the top centroid and 0 when the
    bottom layer carries nothing). ``at_border`` is True when the contact's taxels reach the
    map edge.
    """

    label: int
    row: float
    col: float
    x_m: float
    y_m: float
    force_n: float
    area_m2: float
    taxels: int
    window: tuple
    bottom_force_n: float = 0.0
    bottom_row: float = 0.0
    bottom_col: float = 0.0
    bottom_spread: float = 0.0
    at_border: bool = False


def find_contacts(top_force, bottom_force, pitch_m: float, min_force_n: float = 0.05,
                  margin: int = 1, connectivity: int = 8) -> tuple:
    """
    Return (segments sorted by force descending, label map) for two conditioned force maps.

    A contact is a connected group of taxels loaded on either layer (so the bottom imprint of a
    shifted touch joins its top imprint) that carries at least ``min_force_n`` on the top layer.
    The label map (int32, 0 = background) lets callers isolate each contact in its window.
    """
    top, bottom = check_pair(top_force, bottom_force)
    pitch = check_number(pitch_m, 'pitch_m', positive=True)
    check_number(min_force_n, 'min_force_n', non_negative=True)
    if connectivity not in (4, 8):
        raise ValueError(f'connectivity must be 4 or 8, got {connectivity}')
    if int(margin) < 0:
        raise ValueError(f'margin must be non-negative, got {margin}')
    return segment(top, bottom, pitch, float(min_force_n), int(margin), connectivity)


@lru_cache(maxsize=16)
def _grids(shape: tuple) -> tuple:
    rr, cc = np.indices(shape)
    rr = rr.ravel().astype(np.float64)
    cc = cc.ravel().astype(np.float64)
    return np.stack((np.ones_like(rr), rr, cc, rr * rr + cc * cc)), np.arange(64)[:, None]


# Few labels: one matrix product with the one-hot label matrix beats eight bincounts.
_ONE_HOT_LABELS = 16


def _moments(top: np.ndarray, bottom: np.ndarray, labels: np.ndarray, n: int) -> np.ndarray:
    """
    Return per-label sums (8 x n) over the taxels of each label.

    Rows: top force, top force * row, top force * col, bottom force, bottom force * row,
    bottom force * col, bottom force * (row**2 + col**2), loaded top taxels.
    """
    basis, label_ids = _grids(top.shape)
    w = top.ravel()
    weights = np.empty((8, w.size))
    np.multiply(w, basis[:3], out=weights[:3])
    np.multiply(bottom.ravel(), basis, out=weights[3:7])
    np.greater(w, 0, out=weights[7])
    flat = labels.ravel()
    if n <= _ONE_HOT_LABELS:
        return weights @ (flat == label_ids[:n]).T.astype(np.float64)
    return np.stack([np.bincount(flat, weights=row, minlength=n) for row in weights])


def _single_moments(maps: np.ndarray) -> list:
    """
    Return the sums of :func:`_moments` for a map pair holding one contact, as [background, it].

    With a single component every loaded taxel belongs to it and, the maps being non-negative
    (checked), every other taxel is 0 on both layers, so the sums over the whole maps are its
    sums: one matrix product, no label test.
    """
    basis, _ = _grids(maps.shape[1:])
    (mass, mass_b), (sum_r, sum_rb), (sum_c, sum_cb), (_, sum_sq_b) = (
        basis @ maps.reshape(2, -1).T).tolist()
    count = int(np.count_nonzero(maps[0] > 0))
    return [None, [mass, sum_r, sum_c, mass_b, sum_rb, sum_cb, sum_sq_b, count]]


def segment(top: np.ndarray, bottom: np.ndarray, pitch: float, min_force_n: float,
            margin: int, connectivity: int = 8) -> tuple:
    """Do the work of :func:`find_contacts` on maps already checked (no validation)."""
    maps = np.empty((2,) + top.shape)
    maps[0], maps[1] = top, bottom
    segments, labels, _ = segment_stacked(maps, pitch, min_force_n, margin, connectivity)
    return segments, labels


def segment_stacked(maps: np.ndarray, pitch: float, min_force_n: float, margin: int,
                    connectivity: int = 8) -> tuple:
    """
    Do the work of :func:`segment` on the (2, rows, cols) float64 stack of top and bottom.

    Returns (segments, label map, number of components including the background); with two
    components the maps hold a single contact, which :func:`window_stack` can use.
    """
    top, bottom = maps
    mask = np.logical_or(top > 0, bottom > 0).view(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=connectivity,
                                                           ltype=cv2.CV_32S)
    if n <= 1:
        return [], labels, n
    if n == 2:
        moments = _single_moments(maps)
    else:
        moments = _moments(top, bottom, labels, n).T.tolist()
    rows, cols = top.shape
    threshold = max(float(min_force_n), 1e-12)
    boxes = stats[:, :4].tolist()
    segments = []
    for k in range(1, n):
        m, sum_r, sum_c, mb, sum_rb, sum_cb, sum_sq_b, count = moments[k]
        if not m >= threshold:
            continue
        x0, y0, ww, hh = boxes[k]
        window = (max(y0 - margin, 0), min(y0 + hh + margin, rows),
                  max(x0 - margin, 0), min(x0 + ww + margin, cols))
        r = sum_r / m
        c = sum_c / m
        n_taxels = int(round(count))
        if mb > 0:
            rb = sum_rb / mb
            cb = sum_cb / mb
            spread = max(sum_sq_b / mb - rb * rb - cb * cb, 0.0)
        else:
            rb, cb, spread = r, c, 0.0
        border = x0 == 0 or y0 == 0 or x0 + ww == cols or y0 + hh == rows
        segments.append(Segment(k, r, c, c * pitch, r * pitch, m, n_taxels * pitch * pitch,
                                n_taxels, window, mb, rb, cb, spread, border))
    segments.sort(key=lambda s: -s.force_n)
    return segments, labels, n


def contact_windows(top_force: np.ndarray, bottom_force: np.ndarray, labels: np.ndarray,
                    segment: Segment) -> tuple:
    """Return copies of both layers inside the segment's window with other contacts zeroed."""
    r0, r1, c0, c1 = segment.window
    own = labels[r0:r1, c0:c1] == segment.label
    return (np.where(own, top_force[r0:r1, c0:c1], 0.0),
            np.where(own, bottom_force[r0:r1, c0:c1], 0.0))


def window_stack(maps: np.ndarray, labels: np.ndarray, segment: Segment,
                 alone: bool = False) -> np.ndarray:
    """
    Return a (2, h, w) copy of :func:`contact_windows` from the stacked maps.

    ``alone`` says the maps hold no other component (see :func:`segment_stacked`): the window
    then has nothing to zero and is copied as it is.
    """
    r0, r1, c0, c1 = segment.window
    window = maps[:, r0:r1, c0:c1]
    if alone:
        return window.copy()
    return np.where(labels[r0:r1, c0:c1] == segment.label, window, 0.0)
