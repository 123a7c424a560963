"""
Per-taxel gains: taxels that read more or less than their neighbours under the same pressure.

FSR films, their printing and the matrix wiring leave some taxels more sensitive than others: a
fixed gain pattern. Under a pattern, a contact's centroid leans towards the sensitive taxels and
the top and bottom imprints deform differently, so location and direction are biased.

What the user does, either way:

* **Uniform load**: lay a flat rigid plate over the whole skin and put a weight on it (or press
  it with a robot); one press, held for a second, is enough. The plate must cover every taxel
  with a margin (for the seed's 16 x 16 skin at 5 mm, 80 x 80 mm: a plate of 90 x 90 mm or
  more, rigid, e.g. 5 mm aluminium) and the load must put each taxel in the middle of its range,
  not near its threshold nor its saturation: about 1 N per taxel with the assumed FSR, so
  ``1 N x rows x cols / fill_factor**2`` in all: 1 x 256 / 0.81 = 316 N (a 32 kg weight, plate
  included) on that skin. A plate that does not cover the skin leaves its edge taxels with
  little load next to fully loaded ones: their gains come out at the limit (``GAIN_RANGE``) and
  the fit says where (:func:`limits_note`); move or enlarge the plate and repeat.
* **Presses spread over the skin**: press with a fingertip or an indenter at many places, evenly
  over the whole skin, until every taxel has been under a press several times (about ten
  presses per taxel: 100 or more on a 16 x 16 skin).

Either way the force each taxel sensed is summed over the presses. Where the load was even, the
sum varies slowly from taxel to taxel, while a gain pattern varies from one taxel to the next; so
a taxel's gain is its sum divided by the median over its neighbourhood, and the correction is the
inverse. Taxels that never sensed a force keep gain 1.
"""

from __future__ import annotations

import numpy as np

__all__ = ['gains_from_force_sums', 'limits_note', 'without_crosstalk', 'MIN_COVERED_SHARE',
           'GAIN_RANGE']

MIN_COVERED_SHARE = 0.5
GAIN_RANGE = (0.2, 5.0)
_NEIGHBOURHOOD = 3  # taxels either side: a 7 x 7 median


def _local_median(sums: np.ndarray, covered: np.ndarray) -> np.ndarray:
    rows, cols = sums.shape
    out = np.zeros_like(sums)
    r = _NEIGHBOURHOOD
    for i in range(rows):
        for j in range(cols):
            block = sums[max(i - r, 0):i + r + 1, max(j - r, 0):j + r + 1]
            mask = covered[max(i - r, 0):i + r + 1, max(j - r, 0):j + r + 1]
            out[i, j] = np.median(block[mask]) if mask.any() else 0.0
    return out


def gains_from_force_sums(sums: np.ndarray, presses: int) -> tuple:
    """
    Return (gains, covered) for both layers from summed force maps (2 x rows x cols).

    ``sums`` is what each taxel sensed, summed over ``presses`` presses, with no gains applied.
    The gains multiply the taxel forces so that an even load reads even. Raises ValueError when
    fewer than ``MIN_COVERED_SHARE`` of a layer's taxels sensed anything.
    """
    sums = np.asarray(sums, dtype=np.float64)
    if sums.ndim != 3 or sums.shape[0] != 2 or not np.isfinite(sums).all():
        raise ValueError(f'force sums must be finite 2 x rows x cols, got {sums.shape}')
    if presses < 1:
        raise ValueError('no press to take gains from')
    gains = np.ones_like(sums)
    covered = sums > 0
    for layer, name in enumerate(('top', 'bottom')):
        share = covered[layer].mean()
        if share < MIN_COVERED_SHARE:
            raise ValueError(
                f'the {name} layer sensed {presses} press{"es" if presses != 1 else ""} on only '
                f'{100 * share:.0f} % of its taxels; press evenly over the whole skin (or lay a '
                f'plate over it) until at least {100 * MIN_COVERED_SHARE:.0f} % are covered')
        local = _local_median(sums[layer], covered[layer])
        ok = covered[layer] & (local > 0)
        gains[layer][ok] = np.clip(local[ok] / sums[layer][ok], *GAIN_RANGE)
    return gains, covered


def _span(indices: np.ndarray) -> str:
    lo, hi = int(indices.min()), int(indices.max())
    return str(lo) if lo == hi else f'{lo}-{hi}'


def limits_note(gains: np.ndarray, covered: np.ndarray) -> str:
    """
    Return where the gains (2 x rows x cols) reached ``GAIN_RANGE``, or '' when nowhere.

    A gain at its limit is a taxel the load did not reach as evenly as its neighbours: the edge
    of a plate smaller than the skin, or a taxel pressed far less often than the others.
    """
    parts = []
    for layer, name in enumerate(('top', 'bottom')):
        for limit, side in zip(GAIN_RANGE, ('low', 'high')):
            at = covered[layer] & np.isclose(gains[layer], limit)
            if at.any():
                rows, cols = np.nonzero(at)
                parts.append(f'{name} layer: {int(at.sum())} taxels at the {side} limit '
                             f'{limit:g} (rows {_span(rows)}, cols {_span(cols)})')
    if not parts:
        return ''
    return ('gains at their limits, ' + '; '.join(parts) + ': the load did not cover those '
            'taxels evenly (a plate smaller than the skin, or too few presses there); cover '
            'the whole skin and repeat')


def without_crosstalk(counts: np.ndarray, share: float) -> np.ndarray:
    """
    Return a (layers, rows, cols) stack of tared counts with a known line ``share`` taken out.

    A load that covers whole lines (a plate for the gains) is left alone by the per-scan
    clean-up, whose medians would take it for crosstalk; with the skin's crosstalk known (the
    share a force calibration's presses showed along their lines), each taxel's own reading
    ``c`` follows from ``counts = c + share * (row sum + column sum - 2 c)`` (sums of ``c``).
    Summed over a line, and over the map, that gives the lines' own sums first.
    """
    m = np.asarray(counts, dtype=np.float64)
    if share <= 0:
        return m.copy()
    rows, cols = m.shape[1:]
    keep = 1.0 - 2.0 * share
    total = m.sum(axis=(1, 2), keepdims=True) / (keep + share * (rows + cols))
    row = (m.sum(axis=2, keepdims=True) - share * total) / (keep + share * cols)
    col = (m.sum(axis=1, keepdims=True) - share * total) / (keep + share * rows)
    return (m - share * (row + col)) / keep
