"""
Remove the passive-matrix crosstalk of a scan: load leaking along rows and columns.

A passive FSR matrix reads each taxel through its row and column lines, so part of the load on a
line shows up on every taxel of that line: a faint cross through each press, strong enough on
some skins to rise above the touch threshold and join presses that lie on one line. The leak is
the same for every taxel of a row (and of a column), while presses cover only a few taxels of
each line. So the median of a line is its leak: one sweep of median polish (rows, then columns)
takes the row and column terms out of the tared counts without knowing the skin's leak factor.

A leak is a few per cent of the load on its line: a median that is more than ``MAX_LEAK`` of
what the line carries above it is a load that covers most of the line (a palm, a uniform weight
for the gain calibration), and is left alone. The peak is no measure of it: on a fine grid a
press covers dozens of taxels of a line, whose leak then reaches a third of the peak, and more
where the ADC cut the peak. A press's lines tell the leak as a share of a line's load
(:func:`leak_share`), which a force calibration keeps; with it the gain calibration takes the
leak off its plate (:func:`without_leak`).

The polish runs only on scans where a line is lifted: most of its taxels over a gate. After a
tare the gate is ``LEAK_SIGMAS`` times each taxel's measured noise, so a leak under the touch
threshold still comes off. Before a tare neither the noise nor the rest reading is known (the
counts still hold the rest reading, about 20 counts on the simulated skins, which a noise guess
would take for leak on most scans): the only level known to lie above the rest is the touch
threshold, which gates until a tare (:func:`leak_gate`).
"""

from __future__ import annotations

import numpy as np

__all__ = ['remove_line_leak', 'leak_gate', 'leak_share', 'without_leak', 'MAX_LEAK',
           'LEAK_SIGMAS']

# Largest median, as a share of the line's load above it, that is taken for leak.
MAX_LEAK = 0.05
# After a tare, a line is lifted by leak when most of its taxels read this many noise sigmas.
LEAK_SIGMAS = 3.0


def leak_gate(noise: np.ndarray, threshold: np.ndarray, tared: bool) -> np.ndarray:
    """
    Return each taxel's count over which it counts as lifted (module docstring).

    ``LEAK_SIGMAS`` times its ``noise`` once ``tared``, its touch ``threshold`` before.
    """
    return LEAK_SIGMAS * noise if tared else threshold


def remove_line_leak(counts: np.ndarray, gate: np.ndarray) -> tuple:
    """
    Subtract from a (layers, rows, cols) stack of tared counts, in place, each line's leak.

    ``gate`` (same shape, :func:`leak_gate`): a scan is cleaned as soon as one line is mostly
    at its gate or over, since a leak under the touch threshold still adds to every loaded
    taxel of its lines; scans where none is are left as they are, at the cost of one comparison.
    Returns each line's leak as a share of its load, (rows, cols) per layer (0 where a line
    leaked nothing), or None for a scan left as it was.
    """
    over = counts >= gate
    half = 0.5 * min(counts.shape[1:])
    if not ((over.sum(axis=2) >= half).any() or (over.sum(axis=1) >= half).any()):
        return None
    # The leak is a sum of a row term and a column term: one sweep of each removes both.
    leaks = []
    for axis in (2, 1):
        leaks.append(_leak(counts, axis))
        counts -= np.expand_dims(leaks[-1], axis)
    # A taxel leaks onto the others of its lines, not onto itself: the lines' leak took a share
    # (the line's leak over its load) of its own count too much, which is given back.
    share = [_share(leak, counts.sum(axis=axis)) for leak, axis in zip(leaks, (2, 1))]
    counts /= 1.0 - share[0][:, :, None] - share[1][:, None, :]
    return tuple(share)


def leak_share(counts: np.ndarray, gate: np.ndarray) -> float:
    """
    Return the skin's leak, as a share of a line's load, that a scan of one press shows (NaN).

    The median over the lines that leaked (:func:`remove_line_leak` on a copy of the tared
    ``counts``); NaN when no line did. A press leaks along its own rows and columns only, onto
    taxels that carry no load of their own, so its lines tell the matrix's leak apart from
    the load: what a plate over the whole skin cannot (:func:`without_leak`).
    """
    shares = remove_line_leak(np.array(counts, dtype=np.float64), gate)
    if shares is None:
        return float('nan')
    leaked = np.concatenate([s[s > 0] for s in shares])
    return float(np.median(leaked)) if leaked.size else float('nan')


def without_leak(counts: np.ndarray, share: float) -> np.ndarray:
    """
    Return a (layers, rows, cols) stack of tared counts with a known line ``share`` taken out.

    A load that covers whole lines (a plate for the gains) is left alone by the per-scan
    clean-up, whose medians would take it for leak; with the skin's leak known, each taxel's
    own reading ``c`` follows from ``counts = c + share * (row sum + column sum - 2 c)`` (sums
    of ``c``). Summed over a line, and over the map, that gives the lines' own sums first.
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


def _leak(counts: np.ndarray, axis: int) -> np.ndarray:
    median = _median(counts, axis)
    # A negative median is the noise of an untouched line: leak only ever adds counts. A median
    # that is not a small share of the line's load above it is a load spread along the line.
    leak = np.maximum(median, 0.0)
    above = counts.sum(axis=axis) - counts.shape[axis] * median
    leak[median > MAX_LEAK * above] = 0.0
    return leak


def _share(leak: np.ndarray, load: np.ndarray) -> np.ndarray:
    """Return each line's leak as a share of its load (0 on a line without either)."""
    share = np.divide(leak, load, out=np.zeros_like(leak), where=load > 0)
    return np.minimum(share, MAX_LEAK)


def _median(a: np.ndarray, axis: int) -> np.ndarray:
    # np.median's general machinery costs more than sorting lines of a few dozen taxels.
    s = np.sort(a, axis=axis)
    n = a.shape[axis]
    lo = np.take(s, (n - 1) // 2, axis=axis)
    return lo if n % 2 else 0.5 * (lo + np.take(s, n // 2, axis=axis))
