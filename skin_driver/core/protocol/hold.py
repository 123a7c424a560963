"""
What the host does with a row the board says it did not sample (protocol version 2).

Its counts are meaningless, so no estimator sees them: the row carries the last counts the
board did sample for it (held), and the frame goes on with its ``row_valid`` as received. A
frame with an invalid row that was never valid since the link (re)connected has nothing to
hold: it is dropped and counted as board-flagged. Why hold rather than zero or drop: a zeroed
row reads as an unloaded one (a press vanishes, then comes back: a false release and a false
contact); dropping every flagged frame makes one broken row blind the whole skin; a held row is
stale for as long as the board cannot sample it, and the driver's diagnostics say so.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np


class RowHold:
    """Replace the counts of invalid rows with the newest valid ones, frame by frame."""

    def __init__(self):
        """Start with nothing held; the counters start at zero."""
        self.rows_held = 0       # rows (of either layer) that carried held counts
        self.frames_flagged = 0  # frames dropped: an invalid row with no valid counts yet
        self._last = None        # (top, bottom) of the newest frame delivered or absorbed
        self._seen = None        # (2, rows) booleans: rows valid at least once since reset

    def reset(self) -> None:
        """Forget the held counts (a reconnect: the board may be another one); keep counters."""
        self._last = self._seen = None

    def apply(self, frames: list) -> list:
        """Return the frames with invalid rows held, without those that have nothing to hold."""
        out = []
        for frame in frames:
            valid = frame.row_valid
            if valid is None:
                self._last = (frame.top, frame.bottom)
                self._seen = None  # every row is valid in _last
                out.append(frame)
                continue
            last, seen = self._last, self._seen
            if last is None or last[0].shape != frame.top.shape:
                last = (np.zeros_like(frame.top), np.zeros_like(frame.bottom))
                seen = np.zeros(valid.shape, dtype=bool)
            elif seen is None:
                seen = np.ones(valid.shape, dtype=bool)
            top = np.where(valid[0][:, None], frame.top, last[0])
            bottom = np.where(valid[1][:, None], frame.bottom, last[1])
            top.flags.writeable = bottom.flags.writeable = False
            self._last, self._seen = (top, bottom), seen | valid
            if not (seen | valid).all():
                self.frames_flagged += 1
                continue
            self.rows_held += int((~valid).sum())
            out.append(replace(frame, top=top, bottom=bottom))
        return out
