"""
Remove the passive-matrix crosstalk of a scan: load leaking along rows and columns.

A passive FSR matrix reads each taxel through its row and column lines, so part of the load on a
line shows up on every taxel of that line: a faint cross through each press, strong enough on
some skins to rise above the touch threshold and join presses that lie on one line. The leak is
the same for every taxel of a row (and of a column), while presses cover only a few taxels of
each line. So the median of a line is its leak: one sweep of median polish (rows, then columns)
takes the row and column terms out of the tared counts without knowing the skin's leak factor.
A load that covers most of a line (a palm, a uniform weight for the gain calibration) has a
median close to its peak and is left alone.
"""

from __future__ import annotations

import numpy as np

__all__ = ['remove_line_leak', 'LEAK_SHARE']

# Largest median, as a share of the line's highest reading, that is taken for leak.
LEAK_SHARE = 0.25


def remove_line_leak(counts: np.ndarray, threshold: np.ndarray) -> None:
    """
    Subtract from a (layers, rows, cols) stack of tared counts, in place, each line's leak.

    Only a leak that lifts lines over the touch ``threshold`` (same shape) matters; below it
    the threshold zeroes the leak anyway, so scans where no line is mostly over it are left as
    they are, at the cost of one comparison.
    """
    over = counts >= threshold
    half = 0.5 * min(counts.shape[1:])
    if not ((over.sum(axis=2) >= half).any() or (over.sum(axis=1) >= half).any()):
        return
    # The leak is a sum of a row term and a column term: one sweep of each removes both.
    for axis in (2, 1):
        counts -= np.expand_dims(_leak(counts, axis), axis)


def _leak(counts: np.ndarray, axis: int) -> np.ndarray:
    median = _median(counts, axis)
    # A negative median is the noise of an untouched line: leak only ever adds counts. A median
    # near the line's peak is a load spread along the line (a palm, a uniform weight), not a
    # leak, which is a few per cent of the line's load.
    leak = np.maximum(median, 0.0)
    leak[median > LEAK_SHARE * counts.max(axis=axis)] = 0.0
    return leak


def _median(a: np.ndarray, axis: int) -> np.ndarray:
    # np.median's general machinery costs more than sorting lines of a few dozen taxels.
    s = np.sort(a, axis=axis)
    n = a.shape[axis]
    lo = np.take(s, (n - 1) // 2, axis=axis)
    return lo if n % 2 else 0.5 * (lo + np.take(s, n // 2, axis=axis))
