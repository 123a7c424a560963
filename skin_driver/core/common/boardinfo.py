"""
Who a board says it is: the text of its board information frame (docs/protocol.md).

The frame itself (marker, length, CRC) is the protocol's (core.protocol.wire); the text and what
it means are here, where the calibration file and the recordings use them too.
"""

from __future__ import annotations

from dataclasses import dataclass
import re

import numpy as np

from .boardhealth import HEALTH_KEYS

__all__ = ['BoardInfo', 'INFO_KEYS', 'INFO_MAX_TEXT', 'UID_PATTERN']

# The longest text an information frame carries (its length is one byte, 1..200).
INFO_MAX_TEXT = 200
# The keys every version-1 info text holds, in the order the board sends them.
INFO_KEYS = ('board', 'uid', 'fw', 'grid', 'pitch_um', 'rate_hz')
UID_PATTERN = re.compile(r'[0-9a-f]{24}')
_FW = re.compile(r'(0|[1-9][0-9]{0,4})\.(0|[1-9][0-9]{0,4})\.(0|[1-9][0-9]{0,4})')
_GRID = re.compile(r'([1-9][0-9]{0,2})x([1-9][0-9]{0,2})')
_POSITIVE = re.compile(r'[1-9][0-9]{0,8}')
# Any printable ASCII but the separators, so that a later version's keys parse.
_KEY = re.compile(r'[ -:<>-~]+')


def _check_int(name: str, value, high: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f'{name} must be an integer, got {type(value).__name__}')
    if not 0 <= value <= high:
        raise ValueError(f'{name} must be in 0..{high}, got {value}')
    return int(value)


@dataclass(frozen=True)
class BoardInfo:
    """
    Who the board says it is, from its board information frame (docs/protocol.md).

    ``uid`` is the MCU's 96-bit unique ID as 24 lowercase hex digits, ``fw`` the firmware version
    (major.minor.patch), ``rows`` x ``cols`` its grid, ``pitch_m`` its taxel pitch, ``rate_hz`` its
    scan rate. ``extra`` holds the (key, value) pairs of keys this host does not know, in the
    order sent. Building one checks every field as the decoder does (ValueError).
    """

    board: str
    uid: str
    fw: str
    rows: int
    cols: int
    pitch_m: float
    rate_hz: int
    extra: tuple = ()

    def __post_init__(self):
        """Reject a field that the info text could not carry."""
        for name in ('board', 'uid', 'fw'):
            value = getattr(self, name)
            if not isinstance(value, str) or not value or not _printable(value, ';'):
                raise ValueError(f'{name} must be non-empty printable ASCII without ";", '
                                 f'got {value!r}')
        if not UID_PATTERN.fullmatch(self.uid):
            raise ValueError(f'uid must be 24 lowercase hex digits, got {self.uid!r}')
        if not _FW.fullmatch(self.fw):
            raise ValueError(f'fw must be major.minor.patch, got {self.fw!r}')
        for name in ('rows', 'cols'):
            _check_int(name, getattr(self, name), 255)
            if getattr(self, name) < 1:
                raise ValueError(f'{name} must be in 1..255, got {getattr(self, name)}')
        _check_int('rate_hz', self.rate_hz, 999_999_999)
        if self.rate_hz < 1:
            raise ValueError(f'rate_hz must be positive, got {self.rate_hz}')
        pitch = self.pitch_m
        if isinstance(pitch, bool) or not isinstance(pitch, (int, float, np.floating)) or not (
                0 < pitch < 1000):
            raise ValueError(f'pitch_m must be positive metres, got {pitch!r}')
        extra = tuple((str(k), str(v)) for k, v in self.extra)
        for key, value in extra:
            if not _KEY.fullmatch(key) or key in INFO_KEYS or not _printable(value, ';'):
                raise ValueError(f'extra key {key!r} with value {value!r} cannot be sent')
        if len({key for key, _ in extra}) != len(extra):
            raise ValueError('extra keys must be distinct')
        object.__setattr__(self, 'rows', int(self.rows))
        object.__setattr__(self, 'cols', int(self.cols))
        object.__setattr__(self, 'rate_hz', int(self.rate_hz))
        # The frame carries whole micrometres: keep what it can say, so that a round trip is
        # equal.
        object.__setattr__(self, 'pitch_m', round(float(pitch) * 1e6) * 1e-6)
        if self.pitch_um < 1:
            raise ValueError(f'pitch_m must be at least one micrometre, got {pitch!r}')
        object.__setattr__(self, 'extra', extra)
        if len(self.text) > INFO_MAX_TEXT:
            raise ValueError(f'info text is {len(self.text)} bytes, at most {INFO_MAX_TEXT}')

    @property
    def pitch_um(self) -> int:
        """Return the pitch in whole micrometres, as the frame carries it."""
        return round(self.pitch_m * 1e6)

    @property
    def text(self) -> str:
        """Return the info text as the board sends it: the known keys first, then the others."""
        fields = [('board', self.board), ('uid', self.uid), ('fw', self.fw),
                  ('grid', f'{self.rows}x{self.cols}'), ('pitch_um', str(self.pitch_um)),
                  ('rate_hz', str(self.rate_hz)), *self.extra]
        return ';'.join(f'{k}={v}' for k, v in fields)

    @property
    def identity(self) -> 'BoardInfo':
        """Return who the board is: this info without its health (core.common.boardhealth)."""
        extra = tuple((k, v) for k, v in self.extra if k not in HEALTH_KEYS)
        return self if extra == self.extra else BoardInfo(
            self.board, self.uid, self.fw, self.rows, self.cols, self.pitch_m, self.rate_hz, extra)

    def describe(self) -> str:
        """Return e.g. 'nucleo-f446re uid 0039001e3438510b34313939, fw 0.1.0, 16x16 ...'."""
        return (f'{self.board} uid {self.uid}, fw {self.fw}, {self.rows}x{self.cols} taxels at '
                f'{1000 * self.pitch_m:.3f} mm pitch, {self.rate_hz} scans/s')

    @classmethod
    def parse(cls, text) -> 'BoardInfo':
        """
        Return the board info of an info text (str or bytes), keys in any order.

        Raise ValueError when a byte is outside 0x20..0x7E, a field is not ``key=value``, a key
        repeats, a known key is missing or its value is malformed. Unknown keys are kept in
        ``extra``.
        """
        if isinstance(text, (bytes, bytearray, memoryview)):
            raw = bytes(text)
            if not raw or not all(0x20 <= b <= 0x7E for b in raw):
                raise ValueError('info text must be 1.. bytes of printable ASCII (0x20..0x7E)')
            text = raw.decode('ascii')
        elif not isinstance(text, str) or not text or not _printable(text, ''):
            raise ValueError('info text must be non-empty printable ASCII')
        if len(text) > INFO_MAX_TEXT:
            raise ValueError(f'info text is {len(text)} bytes, at most {INFO_MAX_TEXT}')
        fields = {}
        for field in text.split(';'):
            key, sep, value = field.partition('=')
            if not sep or not _KEY.fullmatch(key):
                raise ValueError(f'info field {field!r} is not key=value')
            if key in fields:
                raise ValueError(f'info key {key!r} repeats')
            fields[key] = value
        missing = [k for k in INFO_KEYS if k not in fields]
        if missing:
            raise ValueError(f'info text lacks {", ".join(missing)}')
        grid = _GRID.fullmatch(fields['grid'])
        if not grid:
            raise ValueError(f'info grid {fields["grid"]!r} is not <rows>x<cols>')
        for key in ('pitch_um', 'rate_hz'):
            if not _POSITIVE.fullmatch(fields[key]):
                raise ValueError(f'info {key} {fields[key]!r} is not a positive integer')
        return cls(fields['board'], fields['uid'], fields['fw'], int(grid[1]), int(grid[2]),
                   int(fields['pitch_um']) * 1e-6, int(fields['rate_hz']),
                   tuple((k, v) for k, v in fields.items() if k not in INFO_KEYS))


def _printable(text: str, forbidden: str) -> bool:
    return all(' ' <= ch <= '~' and ch not in forbidden for ch in text)
