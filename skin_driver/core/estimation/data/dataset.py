"""
Offline dataset format (.npz) of raw two-layer frames with ground truth.

Format (version 2, documented in docs/dataset.md): ``top``, ``bottom`` (N x rows x cols uint16
raw counts), ``pitch_m`` (scalar), ``azimuth_deg`` (N, NaN where undefined), ``alpha_deg`` (N,
0 for normal presses); optional ``force_n``, ``x_m``, ``y_m`` (N each) and ``tare_top``,
``tare_bottom`` (M x rows x cols no-touch frames); optional per-press ground truth ``press_*``
(N x K, NaN-padded, for frames with several presses) and ``split`` (N, uint8: 1 marks a
calibration frame, 2 a normal press at the place of use that re-takes the offset after them, 3 a
rigid plate loading the whole skin evenly (the per-taxel gains, taken first), 0 a scored frame;
without it every frame is scored); optional ``board_info`` (a string: the information text of
the board the frames came from, docs/protocol.md, when it said who it is); ``format_version`` =
2. Version 1 files (no ``press_*``, no ``split``) and files without ``board_info`` load
unchanged; readers that do not know ``board_info`` ignore it.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
import os
import zipfile

import numpy as np

from ...common.atomic import write_atomically
from ...common.boardinfo import BoardInfo
from ...common.validate import check_number, check_stack

__all__ = ['Dataset', 'save_dataset', 'load_dataset', 'FORMAT_VERSION', 'PRESS_FIELDS']

FORMAT_VERSION = 2
_READABLE_VERSIONS = (1, 2)
_OPTIONAL = ('force_n', 'x_m', 'y_m')
# Per-press ground truth, N x K: slot k of frame i holds a press when press_x_m[i, k] is finite.
PRESS_FIELDS = ('press_x_m', 'press_y_m', 'press_force_n', 'press_azimuth_deg',
                'press_alpha_deg', 'press_shift_m')


def _counts_stack(value, name: str) -> np.ndarray:
    arr = check_stack(value, name)
    if arr.dtype.kind == 'f':
        if (arr != np.round(arr)).any():
            raise ValueError(f'{name} must hold whole ADC counts')
    if arr.size and arr.max() > 65535:
        raise ValueError(f'{name} has counts above 65535')
    return np.ascontiguousarray(arr, dtype=np.uint16)


def _vector(value, name: str, n: int, allow_nan: bool = False) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind not in 'uif':
        raise ValueError(f'{name} must be numeric, got dtype {arr.dtype}')
    arr = arr.astype(np.float64)
    if arr.shape != (n,):
        raise ValueError(f'{name} must have shape ({n},), got {arr.shape}')
    if np.isinf(arr).any() or (not allow_nan and np.isnan(arr).any()):
        raise ValueError(f'{name} contains {"inf" if allow_nan else "NaN or inf"}')
    return arr


@dataclass(frozen=True, eq=False)
class Dataset:
    """Validated frames with ground truth; arrays are private copies."""

    top: np.ndarray
    bottom: np.ndarray
    pitch_m: float
    azimuth_deg: np.ndarray
    alpha_deg: np.ndarray
    force_n: np.ndarray = None
    x_m: np.ndarray = None
    y_m: np.ndarray = None
    tare_top: np.ndarray = None
    tare_bottom: np.ndarray = None
    press_x_m: np.ndarray = None
    press_y_m: np.ndarray = None
    press_force_n: np.ndarray = None
    press_azimuth_deg: np.ndarray = None
    press_alpha_deg: np.ndarray = None
    press_shift_m: np.ndarray = None
    split: np.ndarray = None
    board_info: str = None

    def __post_init__(self):
        """Validate shapes, dtypes and values, and freeze copies of the arrays."""
        top = _counts_stack(self.top, 'top')
        bottom = _counts_stack(self.bottom, 'bottom')
        if top.shape != bottom.shape:
            raise ValueError(f'top and bottom shapes differ: {top.shape} vs {bottom.shape}')
        n = top.shape[0]
        set_ = object.__setattr__
        set_(self, 'top', top.copy())
        set_(self, 'bottom', bottom.copy())
        set_(self, 'pitch_m', check_number(self.pitch_m, 'pitch_m', positive=True))
        alpha = _vector(self.alpha_deg, 'alpha_deg', n)
        if (alpha < 0).any() or (alpha >= 90).any():
            raise ValueError('alpha_deg must be in [0, 90)')
        azimuth = _vector(self.azimuth_deg, 'azimuth_deg', n, allow_nan=True)
        if np.isnan(azimuth[alpha > 0]).any():
            raise ValueError('azimuth_deg is NaN for a frame with alpha_deg > 0')
        set_(self, 'alpha_deg', alpha)
        set_(self, 'azimuth_deg', azimuth)
        for name in _OPTIONAL:
            if getattr(self, name) is not None:
                set_(self, name, _vector(getattr(self, name), name, n))
        if self.force_n is not None and (self.force_n < 0).any():
            raise ValueError('force_n must be non-negative')
        if self.split is not None:
            split = np.asarray(self.split)
            if split.shape != (n,) or split.dtype.kind not in 'uib' or not np.isin(
                    split, (0, 1, 2, 3, 4)).all():
                raise ValueError(f'split must be ({n},) integers 0 (scored), 1 (calibration), '
                                 '2 (offset at the place of use), 3 (plate for the gains) or 4 '
                                 '(a tilted press of known direction)')
            set_(self, 'split', split.astype(np.uint8))
        if (self.tare_top is None) != (self.tare_bottom is None):
            raise ValueError('tare_top and tare_bottom must be given together')
        if self.tare_top is not None:
            tt = _counts_stack(self.tare_top, 'tare_top')
            tb = _counts_stack(self.tare_bottom, 'tare_bottom')
            if tt.shape != tb.shape or tt.shape[1:] != top.shape[1:]:
                raise ValueError(f'tare frames must be M x {top.shape[1]} x {top.shape[2]} '
                                 f'on both layers, got {tt.shape} and {tb.shape}')
            set_(self, 'tare_top', tt.copy())
            set_(self, 'tare_bottom', tb.copy())
        _check_presses(self, n)
        if self.board_info is not None:
            try:
                set_(self, 'board_info', BoardInfo.parse(self.board_info).text)
            except ValueError as err:
                raise ValueError(f'board_info is not a board information text: {err}') from None
        for name in ('top', 'bottom', 'alpha_deg', 'azimuth_deg', 'tare_top', 'tare_bottom',
                     'split', *_OPTIONAL, *PRESS_FIELDS):
            arr = getattr(self, name)
            if arr is not None:
                arr.flags.writeable = False

    @property
    def frames(self) -> int:
        """Return the number of frames."""
        return int(self.top.shape[0])

    @property
    def shape(self) -> tuple:
        """Return (rows, cols) of one map."""
        return tuple(self.top.shape[1:])

    def press_counts(self) -> np.ndarray:
        """Return the number of presses of each frame (1 where there are no press arrays)."""
        if self.press_x_m is None:
            return np.ones(self.frames, dtype=int)
        return np.isfinite(self.press_x_m).sum(axis=1)

    def select(self, frames) -> 'Dataset':
        """Return the dataset of the given frame indices (tare and pitch unchanged, no split)."""
        keep = np.asarray(frames, dtype=int)
        per_frame = ('top', 'bottom', 'azimuth_deg', 'alpha_deg', *_OPTIONAL, *PRESS_FIELDS)
        fields = {k: (None if getattr(self, k) is None else getattr(self, k)[keep])
                  for k in per_frame}
        return Dataset(pitch_m=self.pitch_m, tare_top=self.tare_top,
                       tare_bottom=self.tare_bottom, board_info=self.board_info, **fields)

    def board(self):
        """Return the board the frames came from (a BoardInfo), None when it is not known."""
        return None if self.board_info is None else BoardInfo.parse(self.board_info)

    def scored_frames(self) -> np.ndarray:
        """Return the indices of the frames that are scored: all, or those with split = 0."""
        return (np.arange(self.frames) if self.split is None
                else np.flatnonzero(self.split == 0))

    def presses(self, frame: int) -> list:
        """
        Return the ground truth of every press of ``frame`` as dicts (x_m, y_m, ... keys).

        Without per-press arrays the frame's own truth stands for its one press.
        """
        if self.press_x_m is None:
            one = {'azimuth_deg': float(self.azimuth_deg[frame]),
                   'alpha_deg': float(self.alpha_deg[frame])}
            for name in _OPTIONAL:
                value = getattr(self, name)
                one[name] = math.nan if value is None else float(value[frame])
            one['shift_m'] = math.nan
            return [one]
        out = []
        for k in np.flatnonzero(np.isfinite(self.press_x_m[frame])):
            out.append({name[len('press_'):]: (math.nan if getattr(self, name) is None
                                               else float(getattr(self, name)[frame, k]))
                        for name in PRESS_FIELDS})
        return out


def _check_presses(data: Dataset, n: int) -> None:
    """Validate and freeze the optional N x K per-press arrays (press_x_m says which exist)."""
    given = [name for name in PRESS_FIELDS if getattr(data, name) is not None]
    if not given:
        return
    required = {'press_x_m', 'press_y_m', 'press_azimuth_deg', 'press_alpha_deg'}
    if not required <= set(given):
        raise ValueError(f'per-press arrays need all of {", ".join(sorted(required))}')
    first = np.asarray(data.press_x_m)
    if first.ndim != 2 or first.shape[0] != n:
        raise ValueError(f'press_x_m must have shape ({n}, K), got {first.shape}')
    arrays = {}
    for name in given:
        arr = np.asarray(getattr(data, name))
        if arr.dtype.kind not in 'uif':
            raise ValueError(f'{name} must be numeric, got dtype {arr.dtype}')
        arr = arr.astype(np.float64)
        if arr.shape != first.shape:
            raise ValueError(f'{name} must have shape {first.shape}, got {arr.shape}')
        if np.isinf(arr).any():
            raise ValueError(f'{name} contains inf')
        arrays[name] = arr
    present = np.isfinite(arrays['press_x_m'])
    for name, arr in arrays.items():
        if name == 'press_azimuth_deg':
            continue
        if (np.isfinite(arr) != present).any():
            raise ValueError(f'{name} must be finite exactly where press_x_m is (NaN padding)')
    alpha = arrays['press_alpha_deg']
    if ((alpha[present] < 0) | (alpha[present] >= 90)).any():
        raise ValueError('press_alpha_deg must be in [0, 90)')
    if (~np.isfinite(arrays['press_azimuth_deg']) & present & (alpha > 0)).any():
        raise ValueError('press_azimuth_deg is NaN for a press with press_alpha_deg > 0')
    if (np.isfinite(arrays['press_azimuth_deg']) & ~present).any():
        raise ValueError('press_azimuth_deg is set for a slot without a press')
    for name in ('press_force_n', 'press_shift_m'):
        if name in arrays and (arrays[name][present] < 0).any():
            raise ValueError(f'{name} must be non-negative')
    for name, arr in arrays.items():
        object.__setattr__(data, name, arr)


def save_dataset(path, data: Dataset) -> None:
    """Write ``data`` to ``path`` (.npz, compressed) atomically."""
    path = os.fspath(path)
    arrays = {'format_version': np.int64(FORMAT_VERSION), 'top': data.top,
              'bottom': data.bottom, 'pitch_m': np.float64(data.pitch_m),
              'azimuth_deg': data.azimuth_deg, 'alpha_deg': data.alpha_deg}
    for name in (*_OPTIONAL, 'tare_top', 'tare_bottom', 'split', *PRESS_FIELDS):
        if getattr(data, name) is not None:
            arrays[name] = getattr(data, name)
    if data.board_info is not None:
        arrays['board_info'] = np.array(data.board_info)  # 0-d unicode: no pickle
    write_atomically(path, lambda f: np.savez_compressed(f, **arrays), binary=True)


def load_dataset(path) -> Dataset:
    """Read and validate a dataset written by :func:`save_dataset` (or by hand, same keys)."""
    path = os.fspath(path)
    if os.path.isfile(path) and os.path.getsize(path) == 0:
        raise ValueError(f'{path}: cannot read as .npz: the file is empty')
    try:
        npz = np.load(path, allow_pickle=False)
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(f'{path}: cannot read as .npz: {exc}') from None
    except ValueError:
        # numpy takes what is not an array file for pickled data and names allow_pickle.
        raise ValueError(f'{path}: cannot read as .npz: not a NumPy zip archive') from None
    if not hasattr(npz, 'files'):
        raise ValueError(f'{path}: holds one array, not a .npz archive of named arrays')
    with npz:
        keys = set(npz.files)
        missing = {'top', 'bottom', 'pitch_m', 'azimuth_deg', 'alpha_deg'} - keys
        if missing:
            raise ValueError(f'{path}: missing arrays: {", ".join(sorted(missing))}')
        version = int(npz['format_version']) if 'format_version' in keys else FORMAT_VERSION
        if version not in _READABLE_VERSIONS:
            raise ValueError(f'{path}: unsupported format_version {version}')
        pitch = npz['pitch_m']
        if pitch.size != 1:
            raise ValueError(f'{path}: pitch_m must be a scalar')
        fields = {k: npz[k] for k in ('top', 'bottom', 'azimuth_deg', 'alpha_deg', *_OPTIONAL,
                                      'tare_top', 'tare_bottom', 'split', *PRESS_FIELDS)
                  if k in keys}
        if 'board_info' in keys:
            board = npz['board_info']
            if board.dtype.kind != 'U' or board.size != 1:
                raise ValueError(f'{path}: board_info must be one string, got {board.dtype} '
                                 f'of shape {board.shape}')
            fields['board_info'] = str(board.reshape(()))
    return Dataset(pitch_m=float(pitch.reshape(())), **fields)
