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
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .validate import check_number, check_stack

__all__ = ['LayerPair', 'find_contacts', 'pair_layers']

# A second peak of one connected top group is another contact only if the load between them
# drops below this share of the lower peak, and the peaks are at least MIN_PEAK_DISTANCE apart.
SADDLE_RATIO = 0.7
MIN_PEAK_DISTANCE = 2
_MIXTURE_ITERATIONS = 4
# Bottom load below this share of a contact's peak share is not part of its window.
_WINDOW_SHARE = 0.02
_DILATE = np.ones((3, 3), np.uint8)


@dataclass(frozen=True, eq=False)
class LayerPair:
    """
    One contact: its window of both layers and its summary figures (taxel units unless said).

    ``maps`` is a (2, h, w) float64 array: the contact's own top force and its share of the bottom
    force inside the window whose top-left taxel is ``origin`` (row, col). ``top_force_n`` and
    ``bottom_force_n`` are the sums of the two layers; ``row``/``col`` the top centroid in the full
    map; ``taxels`` the loaded top taxels; ``at_border`` is True when either imprint reaches the
    edge of the map (part of it may be cut off).
    """

    maps: np.ndarray
    origin: tuple
    row: float
    col: float
    top_force_n: float
    bottom_force_n: float
    taxels: int
    at_border: bool


def find_contacts(maps, pitch_m: float = 0.005, min_force_n: float = 0.0,
                  max_contacts: int = 32, dead=None) -> list:
    """
    Return the contacts in a (2, rows, cols) stack of top and bottom force maps, as LayerPairs.

    ``dead`` marks top taxels whose reading was filled in from their neighbours (see
    :meth:`conditioning.Conditioner.dead_masks`): a dip there does not separate two peaks.
    Checks its input (finite, non-negative) and does the work of :func:`pair_layers`.
    """
    stack = check_stack(maps, 'maps')
    if stack.shape[0] != 2:
        raise ValueError(f'maps must stack the top and the bottom layer, got {stack.shape[0]}')
    check_number(pitch_m, 'pitch_m', positive=True)
    check_number(min_force_n, 'min_force_n', non_negative=True)
    if dead is not None:
        dead = np.asarray(dead, dtype=bool)
        if dead.shape != stack.shape[1:]:
            raise ValueError(f'dead has shape {dead.shape}, the maps {stack.shape[1:]}')
    return pair_layers(stack.astype(np.float64), float(min_force_n), int(max_contacts), dead)


def pair_layers(maps: np.ndarray, min_force_n: float, max_contacts: int,
                dead: np.ndarray = None) -> list:
    """Do the work of :func:`find_contacts` on a checked float64 stack."""
    top, bottom = maps
    loaded = (top > 0).view(np.uint8)
    n, labels = cv2.connectedComponents(loaded, connectivity=8, ltype=cv2.CV_32S)
    if n <= 1:
        return []
    labels, n = _split_peaks(top, labels, n, dead)
    rows, cols = top.shape
    flat = labels.ravel()
    masses = np.bincount(flat, weights=top.ravel(), minlength=n)
    keep = [k for k in range(1, n) if masses[k] > 0]
    # The strongest top imprints first; the pipeline orders by the force it reports.
    keep.sort(key=lambda k: -masses[k])
    keep = keep[:max(int(max_contacts), 0)]
    if not keep:
        return []
    rr, cc = np.indices(top.shape, dtype=np.float64)
    tops = [np.where(labels == k, top, 0.0) for k in keep]
    shares = _share_bottom(tops, bottom, rr, cc)
    pairs = []
    for t, b in zip(tops, shares):
        pair = _pair(t, b, rr, cc, rows, cols)
        if max(pair.top_force_n, pair.bottom_force_n) >= min_force_n:
            pairs.append(pair)
    return pairs


def _split_peaks(top: np.ndarray, labels: np.ndarray, n: int, dead) -> tuple:
    """Give each clear peak of a connected top group its own label; nearest peak wins a taxel."""
    peaks = (top >= cv2.dilate(top, _DILATE)) & (top > 0)
    pr, pc = np.nonzero(peaks)
    if pr.size <= n - 1:
        return labels, n
    heights = top[pr, pc]
    order = np.argsort(-heights, kind='stable')
    kept = {}
    for i in order.tolist():
        r, c, k = int(pr[i]), int(pc[i]), int(labels[pr[i], pc[i]])
        mine = kept.setdefault(k, [])
        if all(_separate(top, (r, c), q, dead) for q in mine):
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


def _separate(top: np.ndarray, p: tuple, q: tuple, dead) -> bool:
    """Return True when the peak ``p`` stands apart from the higher peak ``q``."""
    steps = max(abs(p[0] - q[0]), abs(p[1] - q[1]))
    if steps < MIN_PEAK_DISTANCE:
        return False
    t = np.linspace(0.0, 1.0, steps + 1)
    r = np.rint(p[0] + (q[0] - p[0]) * t).astype(np.intp)
    c = np.rint(p[1] + (q[1] - p[1]) * t).astype(np.intp)
    path = top[r, c]
    if dead is not None:
        path = path[~dead[r, c]]
    return bool(path.size) and float(path.min()) < SADDLE_RATIO * float(top[p])


def _share_bottom(tops: list, bottom: np.ndarray, rr: np.ndarray, cc: np.ndarray) -> list:
    """Return each top imprint's share of the bottom map (shares sum to the bottom map)."""
    if len(tops) == 1:
        return [bottom]
    total_b = bottom.sum()
    if total_b <= 0:
        return [np.zeros_like(bottom) for _ in tops]
    mass = np.array([t.sum() for t in tops])
    centre = np.array([[(t * rr).sum(), (t * cc).sum()] for t in tops]) / mass[:, None]
    top_all = mass.sum()
    # Presses made by one hand or tool mostly share their tangential direction: start every
    # bottom imprint where the common shift of the whole maps puts it.
    common = np.array([(bottom * rr).sum() / total_b - (centre[:, 0] * mass).sum() / top_all,
                       (bottom * cc).sum() / total_b - (centre[:, 1] * mass).sum() / top_all])
    mean = centre + common
    var = np.array([_spread(t, c) for t, c in zip(tops, centre)]) + 1.0
    weight = mass / top_all
    loaded = bottom > 0
    br, bc, bv = rr[loaded], cc[loaded], bottom[loaded]
    for _ in range(_MIXTURE_ITERATIONS):
        d2 = (br[None, :] - mean[:, 0:1]) ** 2 + (bc[None, :] - mean[:, 1:2]) ** 2
        logp = np.log(weight)[:, None] - np.log(var)[:, None] - 0.5 * d2 / var[:, None]
        logp -= logp.max(axis=0, keepdims=True)
        resp = np.exp(logp)
        resp /= resp.sum(axis=0, keepdims=True)
        w = resp * bv[None, :]
        got = w.sum(axis=1)
        ok = got > 1e-12 * total_b
        if not ok.all():
            break
        mean = np.stack((w @ br, w @ bc), axis=1) / got[:, None]
        d2 = (br[None, :] - mean[:, 0:1]) ** 2 + (bc[None, :] - mean[:, 1:2]) ** 2
        var = np.maximum((w * d2).sum(axis=1) / (2.0 * got), 0.25)
        weight = got / got.sum()
    shares = []
    for k in range(len(tops)):
        s = np.zeros_like(bottom)
        s[loaded] = resp[k] * bv
        shares.append(s)
    return shares


def _spread(t: np.ndarray, centre) -> float:
    m = t.sum()
    rr, cc = np.indices(t.shape)
    return float((t * ((rr - centre[0]) ** 2 + (cc - centre[1]) ** 2)).sum() / (2.0 * m))


def _pair(t: np.ndarray, b: np.ndarray, rr, cc, rows: int, cols: int) -> LayerPair:
    mt, mb = float(t.sum()), float(b.sum())
    row = float((t * rr).sum() / mt) if mt > 0 else 0.0
    col = float((t * cc).sum() / mt) if mt > 0 else 0.0
    tr, tc = np.nonzero(t > 0)
    own = b > _WINDOW_SHARE * b.max() if mb > 0 else np.zeros_like(t, dtype=bool)
    br, bc = np.nonzero(own)
    all_r = np.concatenate((tr, br))
    all_c = np.concatenate((tc, bc))
    r0, r1 = int(all_r.min()), int(all_r.max()) + 1
    c0, c1 = int(all_c.min()), int(all_c.max()) + 1
    border = r0 == 0 or c0 == 0 or r1 == rows or c1 == cols
    r0, r1 = max(r0 - 1, 0), min(r1 + 1, rows)
    c0, c1 = max(c0 - 1, 0), min(c1 + 1, cols)
    window = np.empty((2, r1 - r0, c1 - c0))
    window[0] = t[r0:r1, c0:c1]
    window[1] = np.where(own[r0:r1, c0:c1], b[r0:r1, c0:c1], 0.0)
    return LayerPair(window, (r0, c0), row, col, mt, float(window[1].sum()), int(tr.size),
                     bool(border))
