"""
Scans as a robot saw them, gathered into an offline dataset (docs/dataset.md).

Both ways of recording a skin end here: live ``frame`` messages (``ros2 run skin_driver record``)
and a rosbag2 bag of them (``bag_to_dataset``). A recording has no ground truth of its own: its
frames are unlabelled (azimuth NaN, alpha 0) unless the caller knows the press it recorded (a
robot pressing at a known direction, as in the seed paper) and labels them. The first
``tare_frames`` scans, taken with nothing on the skin, become the dataset's tare, as ``~/tare``
would average them. When the board said who it is (the driver's board_info, docs/protocol.md),
the dataset is stamped with it (``board_info``); a recording holds one board, as it holds one
grid.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np

from .dataset import Dataset
from ...common.boardinfo import BoardInfo

__all__ = ['Labels', 'Recording', 'layers_of']


def layers_of(rows: int, cols: int, top, bottom) -> tuple:
    """Return the (top, bottom) count maps of one scan sent as row-major sequences."""
    rows, cols = int(rows), int(cols)
    top = np.asarray(top, dtype=np.uint16)
    bottom = np.asarray(bottom, dtype=np.uint16)
    n = rows * cols
    if n == 0 or top.size != n or bottom.size != n:
        raise ValueError(f'a {rows}x{cols} scan carries {top.size} top and {bottom.size} bottom '
                         f'counts; expected {n} each')
    return top.reshape(rows, cols), bottom.reshape(rows, cols)


@dataclass(frozen=True)
class Labels:
    """The press every recorded (non-tare) frame shows, when the recorder knows it."""

    azimuth_deg: float = math.nan
    alpha_deg: float = 0.0
    force_n: Optional[float] = None


class Recording:
    """Scans of one skin, in arrival order; one grid and one pitch throughout."""

    def __init__(self, tare_frames: int = 0):
        if tare_frames < 0:
            raise ValueError(f'tare frames must be 0 or more, got {tare_frames}')
        self.tare_frames = int(tare_frames)
        self._top, self._bottom = [], []
        self.pitch_m = None
        self.board = None  # the BoardInfo of the board recorded, None while it said nothing

    def set_board(self, text) -> None:
        """
        Stamp the recording with the board that says who it is (its information text).

        Raise ValueError when the text does not parse, or names another board (uid) than the
        one the recording is stamped with: a recording holds one board.
        """
        info = BoardInfo.parse(text)
        if self.board is not None and info.uid != self.board.uid:
            raise ValueError(f'board {info.board} uid {info.uid} now sends; the recording is of '
                             f'board {self.board.board} uid {self.board.uid}')
        self.board = info

    @property
    def scans(self) -> int:
        """Return how many scans were added (tare included)."""
        return len(self._top)

    def add(self, pitch_m: float, top: np.ndarray, bottom: np.ndarray) -> None:
        """Append one scan; a scan of another grid or pitch than the first is refused."""
        pitch_m = float(pitch_m)
        if self.pitch_m is None:
            self.pitch_m = pitch_m
        # SkinFrame carries the pitch as float32: only a real change is another skin.
        elif not math.isclose(pitch_m, self.pitch_m, rel_tol=1e-5):
            raise ValueError(f'scan {self.scans} has pitch {pitch_m} m; the recording has '
                             f'{self.pitch_m} m')
        if self._top and top.shape != self._top[0].shape:
            raise ValueError(f'scan {self.scans} is {top.shape[0]}x{top.shape[1]}; the '
                             f'recording is {self._top[0].shape[0]}x{self._top[0].shape[1]}')
        self._top.append(np.array(top, dtype=np.uint16))
        self._bottom.append(np.array(bottom, dtype=np.uint16))

    def dataset(self, labels: Labels = Labels()) -> Dataset:
        """Return the recording as a dataset: tare first, every later scan one frame."""
        k = self.tare_frames
        if self.scans <= k:
            raise ValueError(f'{self.scans} scans recorded; the dataset needs more than the '
                             f'{k} tare scans')
        n = self.scans - k
        tare = {}
        if k:
            tare = {'tare_top': np.stack(self._top[:k]), 'tare_bottom': np.stack(self._bottom[:k])}
        force = None if labels.force_n is None else np.full(n, float(labels.force_n))
        return Dataset(top=np.stack(self._top[k:]), bottom=np.stack(self._bottom[k:]),
                       pitch_m=self.pitch_m, azimuth_deg=np.full(n, float(labels.azimuth_deg)),
                       alpha_deg=np.full(n, float(labels.alpha_deg)), force_n=force,
                       board_info=self.board.text if self.board else None, **tare)
