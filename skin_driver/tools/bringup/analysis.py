"""
What a new board's frames say about it: pure functions on count stacks, no I/O (docs/firmware.md).

Stacks are (frames, rows, cols) counts of one layer; maps are (rows, cols). The criteria, stated
once here and in the report:

- dead: a taxel whose counts never change while nothing touches the skin (zero variance over the
  idle window): an open line or a channel that reads a constant;
- stuck: a taxel whose idle mean is within STUCK_MARGIN of full scale (clipped with nothing on
  it): a short to the supply or a failed divider;
- a row or column is dead or stuck when every one of its taxels is;
- shorted: two rows (or columns) of live taxels that read alike, their mean absolute difference
  under SHORT_FRACTION of their noise (independent noise differs by about 1.13 sigma on average);
- ghost: the counts a press puts on the rows beside it at its column, as a fraction of the
  press's own; carry: the row sampled next minus the row before (what a row sampled before its
  line has settled carries over, the press's symmetric spread cancelled).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FULL_SCALE = 4095
STUCK_MARGIN = 40
SHORT_FRACTION = 0.25
# A press must rise this many times the idle noise (or counts, if quieter) to be one.
PRESS_SIGMAS = 10
# Stretches of the clock window whose earliest arrivals the clock line goes through.
CLOCK_PIECES = 10

__all__ = ['Faults', 'clock_ppm', 'faults', 'ghost_fraction', 'noise', 'orientation', 'peak',
           'press_peak']


def clock_ppm(device_us, host_s, pieces: int = CLOCK_PIECES) -> dict:
    """
    Return the board's clock against the host's from (device time, host receive time) pairs.

    A frame reaches the host late, never early (USB polling, the reader's scheduling, a backlog
    queued before the port was read), so the line is fitted through the earliest arrival of each
    of ``pieces`` stretches of the window, a lower envelope the delays do not bias. ``ppm`` is how
    much faster the board's clock runs (positive: it gains); ``late_ms`` the median delay of
    all reads above that line.
    """
    device = np.asarray(device_us, float) / 1e6
    host = np.asarray(host_s, float)
    if device.shape != host.shape or device.size < 3 or np.ptp(host) <= 0:
        raise ValueError(f'a clock fit needs 3 or more (device, host) times over a span, got '
                         f'{device.size}')
    host = host - host[0]
    device = device - device[0]
    late = host - device
    chunks = np.array_split(np.arange(device.size), min(pieces, device.size))
    earliest = np.array([chunk[np.argmin(late[chunk])] for chunk in chunks if chunk.size])
    # The median of the pairwise slopes (Theil-Sen): a stretch that was all backlog, whose
    # earliest read is still late, moves it little.
    i, j = np.triu_indices(earliest.size, 1)
    di, dj = earliest[i], earliest[j]
    keep = host[dj] > host[di]
    di, dj = di[keep], dj[keep]
    slope = float(np.median((device[dj] - device[di]) / (host[dj] - host[di])))
    offset = float(np.median(device[earliest] - slope * host[earliest]))
    behind = (slope * host + offset - device) / slope
    return {'ppm': float((slope - 1.0) * 1e6), 'late_ms': float(np.median(behind) * 1e3),
            'span_s': float(host[-1]), 'points': int(device.size)}


def noise(stack) -> dict:
    """Return the idle noise of one layer: mean and std maps and a summary of the std."""
    stack = np.asarray(stack, float)
    if stack.ndim != 3 or len(stack) < 2:
        raise ValueError(f'noise needs 2 or more (rows, cols) frames, got shape {stack.shape}')
    mean, std = stack.mean(axis=0), stack.std(axis=0)
    return {'mean': mean, 'std': std, 'mean_counts': float(mean.mean()),
            'std_median': float(np.median(std)), 'std_max': float(std.max()),
            'noisiest': tuple(int(v) for v in np.unravel_index(np.argmax(std), std.shape))}


@dataclass
class Faults:
    """The faulty taxels and lines of one layer, by the module's criteria."""

    dead_taxels: list = field(default_factory=list)
    stuck_taxels: list = field(default_factory=list)
    dead_rows: list = field(default_factory=list)
    dead_cols: list = field(default_factory=list)
    stuck_rows: list = field(default_factory=list)
    stuck_cols: list = field(default_factory=list)
    shorted_rows: list = field(default_factory=list)
    shorted_cols: list = field(default_factory=list)

    def count(self) -> int:
        """Return how many findings there are."""
        return sum(len(v) for v in vars(self).values())


def _lines(mask: np.ndarray) -> tuple:
    return ([int(r) for r in np.flatnonzero(mask.all(axis=1))],
            [int(c) for c in np.flatnonzero(mask.all(axis=0))])


def _alike(lines: np.ndarray, live: np.ndarray, sigma: float) -> list:
    """Return the pairs (i, j) of lines (frames, line, taxels) that read alike."""
    pairs = []
    for i in range(lines.shape[1]):
        for j in range(i + 1, lines.shape[1]):
            if live[i] and live[j] and (
                    np.abs(lines[:, i] - lines[:, j]).mean() < SHORT_FRACTION * sigma):
                pairs.append((i, j))
    return pairs


def faults(stack) -> Faults:
    """Return the dead, stuck and shorted taxels and lines of one layer's idle frames."""
    stack = np.asarray(stack, float)
    stats = noise(stack)
    stuck = stats['mean'] >= FULL_SCALE - STUCK_MARGIN
    dead = (stats['std'] == 0) & ~stuck
    found = Faults()
    found.dead_rows, found.dead_cols = _lines(dead)
    found.stuck_rows, found.stuck_cols = _lines(stuck)
    for mask, rows, cols, out in ((dead, found.dead_rows, found.dead_cols, found.dead_taxels),
                                  (stuck, found.stuck_rows, found.stuck_cols,
                                   found.stuck_taxels)):
        for r, c in zip(*np.nonzero(mask)):
            if r not in rows and c not in cols:
                out.append((int(r), int(c)))
    live = ~(dead | stuck)
    if live.any():
        sigma = float(np.median(stats['std'][live]))
        found.shorted_rows = _alike(stack, live.any(axis=1), sigma)
        found.shorted_cols = _alike(stack.transpose(0, 2, 1), live.any(axis=0), sigma)
    return found


def peak(idle_mean, pressed) -> tuple:
    """Return (row, col, counts) of the strongest rise of pressed frames over the idle mean."""
    rise = np.asarray(pressed, float).mean(axis=0) - np.asarray(idle_mean, float)
    r, c = np.unravel_index(np.argmax(rise), rise.shape)
    return int(r), int(c), float(rise[r, c])


def press_peak(idle: dict, pressed) -> tuple:
    """Return peak() of pressed frames over a noise() result; ValueError when nothing rose."""
    r, c, rise = peak(idle['mean'], pressed)
    floor = PRESS_SIGMAS * max(idle['std_median'], 1.0)
    if rise < floor:
        raise ValueError(f'no press seen: the largest rise, {rise:.0f} counts at ({r}, {c}), '
                         f'is under {floor:.0f}')
    return r, c, rise


def _corner(r: int, c: int, shape: tuple) -> tuple:
    rows, cols = shape
    return (0 if r < rows / 2 else rows - 1), (0 if c < cols / 2 else cols - 1)


def orientation(origin: tuple, x_end: tuple, shape: tuple) -> dict:
    """
    Return how the image maps to the skin frame from two presses' peaks (row, col).

    ``origin`` is where a press at the skin's origin corner (x = 0, y = 0) shows, ``x_end``
    where one at the corner along +x (x = max, y = 0) shows. In the skin frame a taxel (r, c)
    sits at x = c * pitch, y = r * pitch, so a board wired as the skin expects shows them at
    (0, 0) and (0, cols - 1). The result says what turns the image into the skin frame:
    transpose first, then flip rows and/or columns. Raise ValueError when the two presses do
    not land on adjacent corners.
    """
    o, x = _corner(*origin[:2], shape), _corner(*x_end[:2], shape)
    if o[0] == x[0] and o[1] != x[1]:
        transpose = False
    elif o[1] == x[1] and o[0] != x[0]:
        transpose = True
    else:
        raise ValueError(f'the presses show at corners {o} and {x}: not two adjacent corners '
                         '(press the origin corner, then the corner along +x)')
    if transpose:
        o = (o[1], o[0])
    flip_rows, flip_cols = o[0] != 0, o[1] != 0
    steps = (['transpose'] if transpose else []) + (['flip rows'] if flip_rows else []) + (
        ['flip columns'] if flip_cols else [])
    return {'transpose': transpose, 'flip_rows': bool(flip_rows), 'flip_cols': bool(flip_cols),
            'ok': not steps,
            'text': 'as the skin frame expects' if not steps else
                    'the image needs: ' + ', then '.join(steps)}


def ghost_fraction(idle_mean, pressed) -> dict:
    """
    Return the press's peak, its ghost and its carry-over, as fractions of its rise.

    ``ghost``: the larger rise of the two rows beside the press, at its column (the press's own
    spread and any carry-over). ``carry``: the row sampled next (r + 1: scan.c samples rows in
    order) minus the row before, the part a row settling too briefly adds, which a press that
    spreads alike both ways cancels from; None at the first or last row.
    """
    rise = np.asarray(pressed, float).mean(axis=0) - np.asarray(idle_mean, float)
    r, c, top = peak(idle_mean, pressed)
    if top <= 0:
        raise ValueError('no press: nothing rose above the idle mean')
    beside = [rise[i, c] for i in (r - 1, r + 1) if 0 <= i < rise.shape[0]]
    inside = 0 < r < rise.shape[0] - 1
    return {'row': r, 'col': c, 'press_counts': top,
            'ghost': float(max(beside) / top) if beside else 0.0,
            'carry': float((rise[r + 1, c] - rise[r - 1, c]) / top) if inside else None}
