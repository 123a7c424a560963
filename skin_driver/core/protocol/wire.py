"""
Binary wire protocol between the skin's microcontroller and the host (see docs/protocol.md).

One frame carries one scan of both layers; all integers are little-endian:

    offset  size  field
    0       2     sync marker 0xA5 0x5A
    2       1     protocol version (1)
    3       1     flags, 0 in version 1
    4       4     sequence number, uint32, wraps at 2**32
    8       8     device time in microseconds, uint64
    16      1     rows (1..255)
    17      1     cols (1..255)
    18      2     header check: CRC-16/CCITT-FALSE of bytes 0..17
    20      2*n   top layer, n = rows*cols counts, row-major, uint16 (0..4095)
    20+2n   2*n   bottom layer, same layout
    20+4n   4     frame check: CRC-32 (zlib, ISO-HDLC) of bytes 0 .. 20+4n-1

Counts are 12-bit, so the high byte of every count is 0x00..0x0F.  Neither sync byte is in that
range, hence the marker never appears inside a payload, only in a header or a CRC.  The header
check lets the decoder reject a false marker before waiting for the payload its bogus header
announces, so it resynchronises within the next intact frame.
"""

from __future__ import annotations

import binascii
from dataclasses import dataclass
import struct
import zlib

import numpy as np

PROTOCOL_VERSION = 1
SYNC = b'\xa5\x5a'
HEADER = struct.Struct('<2sBBIQBB')
HEADER_CHECK = struct.Struct('<H')
HEADER_SIZE = HEADER.size + HEADER_CHECK.size
CRC_SIZE = 4
MAX_COUNT = 4095
MAX_SEQ = 2 ** 32 - 1
MAX_DEVICE_TIME_US = 2 ** 64 - 1
# No scan of both layers takes less than a microsecond of the device's clock: a forward jump of
# the sequence number by more frames than microseconds passed is a corrupt number, not a loss.
MIN_SCAN_US = 1
_CRC = struct.Struct('<I')
_COUNTS = np.dtype('<u2')


def header_crc(data) -> int:
    """Return the CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) of the given bytes."""
    return binascii.crc_hqx(data, 0xFFFF)


def frame_size(rows: int, cols: int) -> int:
    """Return the number of bytes of a frame with the given shape."""
    return HEADER_SIZE + 4 * rows * cols + CRC_SIZE


@dataclass(frozen=True, eq=False)
class Frame:
    """One decoded scan: both layers as read-only uint16 (rows, cols) ADC count maps."""

    seq: int
    device_time_us: int
    rows: int
    cols: int
    top: np.ndarray
    bottom: np.ndarray

    def __eq__(self, other: object) -> bool:
        """Compare header fields and both maps count for count."""
        if not isinstance(other, Frame):
            return NotImplemented
        return (self.seq == other.seq and self.device_time_us == other.device_time_us
                and self.rows == other.rows and self.cols == other.cols
                and np.array_equal(self.top, other.top)
                and np.array_equal(self.bottom, other.bottom))

    __hash__ = None


def _check_int(name: str, value: int, high: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f'{name} must be an integer, got {type(value).__name__}')
    if not 0 <= value <= high:
        raise ValueError(f'{name} must be in 0..{high}, got {value}')
    return int(value)


def _check_layer(name: str, layer: np.ndarray) -> np.ndarray:
    layer = np.asarray(layer)
    if layer.ndim != 2:
        raise ValueError(f'{name} must be a 2-D (rows, cols) array, got shape {layer.shape}')
    if not np.issubdtype(layer.dtype, np.integer) or layer.dtype == np.bool_:
        raise ValueError(f'{name} must have an integer dtype, got {layer.dtype}')
    rows, cols = layer.shape
    if not (1 <= rows <= 255 and 1 <= cols <= 255):
        raise ValueError(f'{name} shape must be within 1..255 x 1..255, got {layer.shape}')
    if layer.size and (layer.min() < 0 or layer.max() > MAX_COUNT):
        raise ValueError(f'{name} counts must be in 0..{MAX_COUNT}, '
                         f'got {layer.min()}..{layer.max()}')
    return layer


def encode_frame(seq: int, device_time_us: int, top: np.ndarray, bottom: np.ndarray) -> bytes:
    """
    Encode one scan of both layers as a frame.

    Raise ValueError when seq is outside uint32, the time outside uint64, the layers differ in
    shape, are not 2-D integer arrays of at most 255 x 255, or hold counts outside 0..4095.
    """
    return frame_with_counts(seq, device_time_us, *encode_counts(top, bottom))


def encode_counts(top: np.ndarray, bottom: np.ndarray) -> tuple:
    """
    Return (rows, cols, the counts of both layers as a frame carries them), checked.

    A board that sends the same scan again (a replay) encodes its counts once and each frame
    with :func:`frame_with_counts`. Raises ValueError as :func:`encode_frame` does.
    """
    top = _check_layer('top', top)
    bottom = _check_layer('bottom', bottom)
    if top.shape != bottom.shape:
        raise ValueError(f'top and bottom must have the same shape, got {top.shape} and '
                         f'{bottom.shape}')
    rows, cols = top.shape
    counts = (np.ascontiguousarray(top, dtype=_COUNTS).tobytes()
              + np.ascontiguousarray(bottom, dtype=_COUNTS).tobytes())
    return rows, cols, counts


def frame_with_counts(seq: int, device_time_us: int, rows: int, cols: int,
                      counts: bytes) -> bytes:
    """Return the frame of counts from :func:`encode_counts` with this sequence and time."""
    seq = _check_int('seq', seq, MAX_SEQ)
    device_time_us = _check_int('device_time_us', device_time_us, MAX_DEVICE_TIME_US)
    body = bytearray(HEADER.pack(SYNC, PROTOCOL_VERSION, 0, seq, device_time_us, rows, cols))
    body += HEADER_CHECK.pack(header_crc(body))
    body += counts
    body += _CRC.pack(zlib.crc32(body))
    return bytes(body)


@dataclass
class DecoderStats:
    """Counters of what the decoder accepted and rejected since it was created."""

    frames: int = 0
    crc_errors: int = 0       # header or frame CRC mismatch, or a count above 4095
    size_errors: int = 0      # rows/cols of 0, above the maximum or unlike expected_shape
    version_errors: int = 0   # unknown protocol version or non-zero flags
    bytes_discarded: int = 0  # bytes that were not part of an accepted frame
    seq_gaps: int = 0         # times the sequence number jumped forwards by more than one
    frames_missed: int = 0    # frames skipped by those jumps
    seq_implausible: int = 0  # forward jumps the device clock cannot explain (corrupt seq)


class FrameDecoder:
    """
    Incremental frame decoder: feed it bytes as they arrive, get whole checked frames back.

    After garbage it resynchronises on the next sync marker; a rejected candidate resumes the
    search at the byte after its marker, so an intact frame that starts inside the candidate's
    bytes is still found.  The buffer holds less than two maximum-size frames at any time.
    """

    def __init__(self, max_rows: int = 128, max_cols: int = 128,
                 expected_shape: tuple[int, int] | None = None):
        """Accept frames of at most max_rows x max_cols, or exactly expected_shape if given."""
        self._max_rows = _check_int('max_rows', max_rows, 255)
        self._max_cols = _check_int('max_cols', max_cols, 255)
        if self._max_rows < 1 or self._max_cols < 1:
            raise ValueError(f'max_rows and max_cols must be at least 1, got {max_rows}, '
                             f'{max_cols}')
        if expected_shape is not None:
            if len(expected_shape) != 2:
                raise ValueError(f'expected_shape must be (rows, cols), got {expected_shape!r}')
            rows = _check_int('expected_shape rows', expected_shape[0], self._max_rows)
            cols = _check_int('expected_shape cols', expected_shape[1], self._max_cols)
            if rows < 1 or cols < 1:
                raise ValueError(f'expected_shape must be at least 1 x 1, got {expected_shape}')
            expected_shape = (rows, cols)
            self._max_frame = frame_size(rows, cols)
        else:
            self._max_frame = frame_size(self._max_rows, self._max_cols)
        self._expected = expected_shape
        self._buf = bytearray()
        self._last: tuple[int, int] | None = None  # (seq, device time) of the newest frame
        self.stats = DecoderStats()
        # (rows, cols) of the newest frame refused for its size, for diagnostics.
        self.last_rejected_shape: tuple[int, int] | None = None

    @property
    def max_buffer_bytes(self) -> int:
        """Return the most bytes the decoder ever holds between calls to feed."""
        return 2 * self._max_frame

    @property
    def buffered_bytes(self) -> int:
        """Return how many bytes are waiting for the rest of their frame."""
        return len(self._buf)

    def reset(self) -> None:
        """Drop buffered bytes and forget the last sequence number; keep the statistics."""
        self.stats.bytes_discarded += len(self._buf)
        self._buf = bytearray()
        self._last = None

    def feed(self, data: bytes) -> list[Frame]:
        """
        Consume received bytes and return the frames they complete, oldest first.

        No byte content makes this raise; an object that is not bytes-like raises TypeError.
        """
        frames: list[Frame] = []
        view = memoryview(data).cast('B')
        if not self._buf and type(data) is bytes:
            # Nothing pending (the usual read of whole frames): decode in place, the layers are
            # views of the caller's immutable bytes, and only an unfinished tail is kept. That
            # tail is shorter than one frame, as _scan stops only inside a frame.
            pos = self._scan(data, view, frames, copy=False)
            self._buf += view[pos:]
            return frames
        # Feeding in slices of one frame keeps the buffer below two frames whatever arrives.
        step = self._max_frame
        for start in range(0, len(view), step):
            self._buf += view[start:start + step]
            self._parse(frames)
        return frames

    def _parse(self, frames: list[Frame]) -> None:
        buf = self._buf
        with memoryview(buf) as view:
            pos = self._scan(buf, view, frames, copy=True)
        if pos:
            del buf[:pos]

    def _scan(self, buf, view: memoryview, frames: list[Frame], copy: bool) -> int:
        """
        Decode what buf (bytes or bytearray) holds; return how many leading bytes are used up.

        copy: the layers are copied out of buf (a buffer that changes later), else they view it.
        """
        stats = self.stats
        pos = 0
        end = len(buf)
        while True:
            found = buf.find(SYNC, pos)
            if found < 0:
                # Keep a trailing first sync byte: its partner may arrive with the next chunk.
                keep = 1 if end > pos and buf[end - 1] == SYNC[0] else 0
                stats.bytes_discarded += end - keep - pos
                pos = end - keep
                break
            stats.bytes_discarded += found - pos
            pos = found
            if end - pos < HEADER_SIZE:
                break
            _, version, flags, seq, time_us, rows, cols = HEADER.unpack_from(buf, pos)
            if version != PROTOCOL_VERSION or flags != 0:
                stats.version_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            (check,) = HEADER_CHECK.unpack_from(buf, pos + HEADER.size)
            if header_crc(view[pos:pos + HEADER.size]) != check:
                stats.crc_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            if not self._shape_ok(rows, cols):
                stats.size_errors += 1
                self.last_rejected_shape = (rows, cols)
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            n = rows * cols
            size = HEADER_SIZE + 4 * n + CRC_SIZE
            if end - pos < size:
                break
            crc_at = pos + size - CRC_SIZE
            (crc,) = _CRC.unpack_from(buf, crc_at)
            if zlib.crc32(view[pos:crc_at]) != crc:
                stats.crc_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            counts = np.frombuffer(buf, dtype=_COUNTS, count=2 * n, offset=pos + HEADER_SIZE)
            if copy:
                counts = counts.copy()
                counts.flags.writeable = False
            if counts.max() > MAX_COUNT:
                stats.crc_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            if counts.dtype != np.uint16:  # big-endian host
                counts = counts.astype(np.uint16)
                counts.flags.writeable = False
            layers = counts.reshape(2, rows, cols)
            self._count_seq(seq, time_us)
            frames.append(Frame(seq, time_us, rows, cols, layers[0], layers[1]))
            stats.frames += 1
            pos += size
        return pos

    def _shape_ok(self, rows: int, cols: int) -> bool:
        if self._expected is not None:
            return (rows, cols) == self._expected
        return 1 <= rows <= self._max_rows and 1 <= cols <= self._max_cols

    def _count_seq(self, seq: int, time_us: int) -> None:
        last = self._last
        self._last = (seq, time_us)
        if last is None:
            return
        step = (seq - last[0]) & MAX_SEQ
        # A backward jump or a repeat means the device restarted: nothing is known to be missed.
        if 1 < step <= MAX_SEQ // 2:
            if (step - 1) * MIN_SCAN_US > time_us - last[1]:
                self.stats.seq_implausible += 1
                return
            self.stats.seq_gaps += 1
            self.stats.frames_missed += step - 1
