"""
Find contacts in conditioned force maps and pair each top imprint with its bottom imprint.

A contact starts from the top layer, whose imprint is the sharp one: connected loaded taxels,
split where one group holds several clear peaks (two fingers close together). Its bottom imprint
is wherever the bottom layer carries load: it may sit anywhere the layer shift takes it, touching
the top imprint or not. With several contacts, the bottom load is shared among them by a small
Gaussian mixture whose centres start at each top centroid plus the common shift of the whole maps,
so neighbouring presses keep their own bottom imprints even when those overlap.

Each contact comes out as one :class:`LayerPair`: a window holding the contact's top taxels and
its share of the bottom load, ready for any shift estimator, plus the figures the pipeline needs.
The geometry is found on one pair of maps (the pipeline gives the tared counts, free of any
assumed FSR curve) and the forces are summed on another (the force maps) over the same taxels;
whether two peaks are two presses is judged on the force map, where the dip between them is.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

__all__ = ['LayerPair', 'pair_layers']

# A second peak of one connected top group is another contact only if the load (force) between
# them drops below this share of the lower peak, and they are at least MIN_PEAK_DISTANCE apart.
SADDLE_RATIO = 0.85
MIN_PEAK_DISTANCE = 2
_MIXTURE_ITERATIONS = 3
# Bottom load below this share of a contact's peak share is not part of its window.
_WINDOW_SHARE = 0.02
_DILATE = np.ones((3, 3), np.uint8)


@dataclass(frozen=True, eq=False)
class LayerPair:
    """
    One contact: its window of both layers and its summary figures (taxel units unless said).

    ``maps`` is a (2, h, w) float64 array: the contact's own top map and its share of the bottom
    map inside the window whose top-left taxel is ``origin`` (row, col). ``top_force_n`` and
    ``bottom_force_n`` are the contact's force sums on the two layers; ``row``/``col`` the top
    centroid in the full map; ``taxels`` the loaded top taxels; ``at_border`` is True when either
    imprint reaches the edge of the map (part of it may be cut off); ``bottom_cut`` when the
    bottom imprint's strongest line (row or column of its share) is the map's edge line: its
    centre is on or past the edge, so a real part of it is cut off (:func:`_cut_at_edge`).
    """

    maps: np.ndarray
    origin: tuple
    row: float
    col: float
    top_force_n: float
    bottom_force_n: float
    taxels: int
    at_border: bool
    bottom_cut: bool = False


def pair_layers(maps: np.ndarray, max_contacts: int = 32, dead: np.ndarray = None,
                force: np.ndarray = None) -> list:
    """
    Return the contacts in a (2, rows, cols) float64 stack of top and bottom maps, as LayerPairs.

    The maps are the tared counts, non-negative and finite (the conditioner's output). ``dead``
    marks top taxels whose reading was filled in from their neighbours (see
    :meth:`conditioning.Conditioner.dead_masks`): a dip there does not separate two peaks.
    ``force`` (same shape, loaded on the same taxels) gives the forces; ``maps`` by default.
    """
    if force is None:
        force = maps
    top, bottom = maps
    loaded = (top > 0).view(np.uint8)
    n, labels = cv2.connectedComponents(loaded, connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return []
    labels, n = _split_peaks(top, force[0], labels, n, dead)
    if max_contacts < 1:
        return []
    if n == 2:
        # One top imprint (the common case): it is the whole top map, no label to test.
        tops, top_forces = top[None], force[:1]
        shares, bottom_forces = bottom[None], force[1:]
    else:
        masses = np.bincount(labels.ravel(), weights=top.ravel(), minlength=n)
        # The strongest top imprints first; the pipeline orders by the force it reports.
        keep = sorted((k for k in range(1, n) if masses[k] > 0), key=lambda k: -masses[k])
        own = labels[None] == np.array(keep[:max_contacts])[:, None, None]
        tops, top_forces = top * own, force[0] * own
        fraction = _share_bottom(tops, bottom)
        shares, bottom_forces = fraction * bottom, fraction * force[1]
    return [_pair(t, b, tf, bf) for t, b, tf, bf in zip(tops, shares, top_forces, bottom_forces)]


def _split_peaks(top: np.ndarray, load: np.ndarray, labels: np.ndarray, n: int,
                 dead) -> tuple:
    """
    Give each clear peak of a connected top group its own label; nearest peak wins a taxel.

    The peaks are the readings' (``top``); whether two are apart is judged on the ``load``
    between them: the counts of a film near the end of its curve flatten the dip between two
    fingers close together (docs/estimation.md, "Contacts").
    """
    peaks = (top >= cv2.dilate(top, _DILATE)) & (top > 0)
    pr, pc = np.nonzero(peaks)
    if pr.size <= n - 1:
        return labels, n
    heights = top[pr, pc]
    order = np.argsort(-heights, kind='stable')
    values = load
    if dead is not None:
        # A filled-in taxel is no evidence of a dip: the path takes its higher neighbour.
        values = np.where(dead, cv2.dilate(load, _DILATE), load)
    kept = {}
    for i in order.tolist():
        r, c, k = int(pr[i]), int(pc[i]), int(labels[pr[i], pc[i]])
        mine = kept.setdefault(k, [])
        if all(_separate(load, values, (r, c), q) for q in mine):
            mine.append((r, c))
    if all(len(v) == 1 for v in kept.values()):
        return labels, n
    out = labels.copy()
    next_label = n
    for k, centres in kept.items():
        if len(centres) < 2:
            continue
        tr, tc = np.nonzero(labels == k)
        centre = np.array(centres, dtype=np.float64)
        d2 = (tr[:, None] - centre[None, :, 0]) ** 2 + (tc[:, None] - centre[None, :, 1]) ** 2
        nearest = np.argmin(d2, axis=1)
        ids = np.array([k] + list(range(next_label, next_label + len(centres) - 1)))
        out[tr, tc] = ids[nearest]
        next_label += len(centres) - 1
    return out, next_label


def _separate(load: np.ndarray, values: np.ndarray, p: tuple, q: tuple) -> bool:
    """
    Return True when the peaks ``p`` and ``q`` stand apart.

    The load (``values``: ``load`` with its dead taxels filled) is followed along the straight
    line between them, interpolated between taxels (a line between diagonal neighbours passes
    their shared corner, where two blobs that only touch at a corner meet low), and must drop
    below SADDLE_RATIO of the lower peak's ``load``.
    """
    steps = max(abs(p[0] - q[0]), abs(p[1] - q[1]))
    if steps < MIN_PEAK_DISTANCE:
        return False
    t = np.linspace(0.0, 1.0, 4 * steps + 1)
    r = p[0] + (q[0] - p[0]) * t
    c = p[1] + (q[1] - p[1]) * t
    r0 = np.clip(np.floor(r).astype(np.intp), 0, max(load.shape[0] - 2, 0))
    c0 = np.clip(np.floor(c).astype(np.intp), 0, max(load.shape[1] - 2, 0))
    r1 = np.minimum(r0 + 1, load.shape[0] - 1)
    c1 = np.minimum(c0 + 1, load.shape[1] - 1)
    fr, fc = r - r0, c - c0
    path = ((1 - fr) * (1 - fc) * values[r0, c0] + (1 - fr) * fc * values[r0, c1]
            + fr * (1 - fc) * values[r1, c0] + fr * fc * values[r1, c1])
    return float(path.min()) < SADDLE_RATIO * min(float(load[p]), float(load[q]))


def _share_bottom(tops: np.ndarray, bottom: np.ndarray) -> np.ndarray:
    """Return each top imprint's share (K, rows, cols; fractions summing to 1) of the bottom."""
    k, rows, cols = tops.shape
    shares = np.zeros(tops.shape)
    loaded = np.flatnonzero(bottom > 0)
    if loaded.size == 0:
        return shares
    basis = _basis((rows, cols))
    moments = tops.reshape(k, -1) @ basis
    mass = moments[:, 0]
    centre = moments[:, 1:3] / mass[:, None]
    spread = 0.5 * (moments[:, 3] / mass - (centre * centre).sum(axis=1))
    bv = bottom.ravel()[loaded]
    pos = basis[loaded, 1:3]
    pos_t = pos.T.copy()
    pos2 = basis[loaded, 3]
    # Presses made by one hand or tool mostly share their tangential direction: start every
    # bottom imprint where the common shift of the whole maps puts it, a taxel wider than the
    # top imprint (the elastic layer spreads it).
    common = bv @ pos / bv.sum() - mass @ centre / mass.sum()
    mean = centre + common
    var = np.maximum(spread, 0.0) + 1.0
    log_weight = np.log(mass / mass.sum())
    for _ in range(_MIXTURE_ITERATIONS):
        # Squared distances of every loaded taxel to every centre: |p|^2 - 2 p.m + |m|^2.
        d2 = pos2 - 2.0 * (mean @ pos_t) + (mean * mean).sum(axis=1)[:, None]
        logp = (log_weight - np.log(var))[:, None] - 0.5 * d2 / var[:, None]
        resp = np.exp(logp - logp.max(axis=0))
        resp /= resp.sum(axis=0)
        w = resp * bv
        m = w @ basis[loaded]
        got = m[:, 0]
        if not (got > 1e-12 * bv.sum()).all():
            break
        mean = m[:, 1:3] / got[:, None]
        var = np.maximum(0.5 * (m[:, 3] / got - (mean * mean).sum(axis=1)), 0.25)
        log_weight = np.log(got / got.sum())
    shares.reshape(k, -1)[:, loaded] = resp
    return shares


@lru_cache(maxsize=16)
def _basis(shape: tuple) -> np.ndarray:
    """Return the (rows * cols, 4) columns 1, row, col, row**2 + col**2 of every taxel."""
    rr, cc = np.indices(shape, dtype=np.float64)
    basis = np.stack((np.ones(rr.size), rr.ravel(), cc.ravel(),
                      rr.ravel() ** 2 + cc.ravel() ** 2), axis=1)
    basis.flags.writeable = False
    return basis


def _pair(t: np.ndarray, b: np.ndarray, tf: np.ndarray, bf: np.ndarray) -> LayerPair:
    rows, cols = t.shape
    basis = _basis((rows, cols))
    flat_t = t.ravel()
    mt, sum_r, sum_c, _ = (flat_t @ basis).tolist()
    row, col = (sum_r / mt, sum_c / mt) if mt > 0 else (0.0, 0.0)
    touched = np.flatnonzero(flat_t)
    flat_b = b.ravel()
    peak = flat_b.max()
    own = np.flatnonzero(flat_b > _WINDOW_SHARE * peak) if peak > 0 else touched[:0]
    both = np.concatenate((touched, own))
    lines, places = np.divmod(both, cols)
    r0, r1 = int(lines.min()), int(lines.max()) + 1
    c0, c1 = int(places.min()), int(places.max()) + 1
    border = r0 == 0 or c0 == 0 or r1 == rows or c1 == cols
    r0, r1 = max(r0 - 1, 0), min(r1 + 1, rows)
    c0, c1 = max(c0 - 1, 0), min(c1 + 1, cols)
    kept = np.zeros(rows * cols)
    kept[own] = 1.0
    kept = kept.reshape(rows, cols)[r0:r1, c0:c1]
    window = np.empty((2, r1 - r0, c1 - c0))
    window[0] = t[r0:r1, c0:c1]
    np.multiply(b[r0:r1, c0:c1], kept, out=window[1])
    bottom_force = float((bf[r0:r1, c0:c1] * kept).sum())
    cut = _cut_at_edge(window[1], (r0, c0), (r1 == rows, c1 == cols))
    return LayerPair(window, (r0, c0), row, col, float(tf.sum()), bottom_force,
                     int(touched.size), bool(border), cut)


def _cut_at_edge(share: np.ndarray, origin: tuple, at_end: tuple) -> bool:
    """
    Return True when the strongest line of a window's bottom share is the map's edge line.

    An imprint that only reaches the edge with its rim has lost a sliver; one whose strongest
    line is the edge has its centre there or past it and has lost a real part. The line sums are
    accumulated in order, line by line (the kernel does alike).
    """
    h, w = share.shape
    row_sums = np.zeros(h)
    for c in range(w):
        row_sums += share[:, c]
    col_sums = np.zeros(w)
    for r in range(h):
        col_sums += share[r]
    for sums, start, end in ((row_sums, origin[0] == 0, at_end[0]),
                             (col_sums, origin[1] == 0, at_end[1])):
        strongest = int(np.argmax(sums))  # the first of equal ones, as the kernel
        if (start and strongest == 0) or (end and strongest == sums.size - 1):
            return True
    return False
