"""
The grid and pitch a skin's scans are read with: the board's word, or parameters overriding it.

A board says its grid in every frame's header and its grid and pitch in its board information
frame (docs/protocol.md), sent before its first frame and once a second after; a host that
connects to a running board may read a second of frames before it. So the grid is known from
the first frame, the pitch from the first information frame. A value set by the user (not 0)
overrides the board's; one that the board contradicts stops the scans' use, with an error
naming both: a skin read at a pitch or grid it does not have gives contacts in the wrong place.
A board that never says (version 1) needs ``pitch`` set.
"""

from __future__ import annotations

__all__ = ['SkinGrid']

# What a refusal asks of the user.
_FIX = "scans are not used (set the parameter to the board's value, or to 0 to take its word)"


class SkinGrid:
    """What a driver knows of its skin's grid and pitch, and from whom."""

    def __init__(self, rows: int = 0, cols: int = 0, pitch_m: float = 0.0):
        """Start from the user's settings; 0 leaves a value to the board."""
        self.set = {'rows': int(rows), 'cols': int(cols), 'pitch': float(pitch_m)}
        self.rows = int(rows) or None
        self.cols = int(cols) or None
        self.pitch_m = float(pitch_m) or None
        # Why the scans are not used (the board contradicts a setting); '' while they are.
        self.refusal = ''

    @property
    def shape(self):
        """Return (rows, cols) when both are known, else None."""
        return (self.rows, self.cols) if self.rows and self.cols else None

    @property
    def ready(self) -> bool:
        """Return whether scans can be used: grid and pitch known, nothing contradicted."""
        return bool(self.shape and self.pitch_m and not self.refusal)

    def waiting_for(self) -> str:
        """Return what is still unknown, for a person ('' when nothing is)."""
        missing = [name for name, known in (('grid', self.shape), ('pitch', self.pitch_m))
                   if not known]
        if not missing:
            return ''
        return (f"waiting for the board's {' and '.join(missing)} (its board information "
                "frame; a version-1 board sends none: set the 'pitch' parameter)")

    def hear_board(self, info) -> str:
        """
        Take the grid and pitch of a board information frame (a BoardInfo); return the refusal.

        A setting the board contradicts is a refusal, naming both; it stands until the grid is
        started afresh (the driver's cleanup and configure).
        """
        problems = []
        for name, said in (('rows', info.rows), ('cols', info.cols)):
            if self.set[name] and self.set[name] != said:
                problems.append(f"parameter '{name}' is {self.set[name]}")
        if problems:
            problems[-1] += f' but board {info.board} says its grid is {info.rows}x{info.cols}'
        # The board states whole micrometres.
        if self.set['pitch'] and abs(self.set['pitch'] - info.pitch_m) > 0.5e-6:
            problems.append(f"parameter 'pitch' is {1000 * self.set['pitch']:.3f} mm but board "
                            f'{info.board} says its pitch is {1000 * info.pitch_m:.3f} mm')
        if problems and not self.refusal:
            self.refusal = '; '.join(problems) + f': {_FIX}'
        if not self.refusal:
            self.rows = self.rows or info.rows
            self.cols = self.cols or info.cols
            self.pitch_m = self.pitch_m or info.pitch_m
        return self.refusal

    def see_frame(self, rows: int, cols: int) -> str:
        """Take the grid of a frame's header while it is not known yet; return the refusal."""
        if self.shape is None and not self.refusal:
            problems = [f"parameter '{name}' is {self.set[name]}"
                        for name, seen in (('rows', rows), ('cols', cols))
                        if self.set[name] and self.set[name] != seen]
            if problems:
                self.refusal = (' and '.join(problems) + ' but the board sends frames of '
                                f'{rows}x{cols}: {_FIX}')
                return self.refusal
            self.rows = self.rows or rows
            self.cols = self.cols or cols
        return self.refusal
