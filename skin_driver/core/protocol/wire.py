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

Between two frames the board may send a board information frame (its identity, see
:class:`BoardInfo`): marker 0xA5 0x69, info version (1), text length L (1..200), L bytes of
ASCII text ``key=value;...``, CRC-16/CCITT-FALSE of all bytes before it.  A host that only knows
version 1 finds no 0xA5 0x5A in it and discards it as junk between frames.

Version 2 (core.protocol.packed) keeps the header, with version 2 and two flags, and carries the
board's fault bits, a map of the rows it sampled and the counts packed two in three bytes: 800
bytes for 16 x 16 instead of 1 048.  The decoder takes both versions, mixed on one stream.

The encoder here (:func:`encode_frame`, :func:`encode_info`) is the host's own reading of
docs/protocol.md, for the decoder's tests and tools that write test streams. No board frames with
it: the firmware and the simulated board share the firmware core's framing (the simulator through
its host build, core.sim.firmware), which the tests hold byte for byte against this one.
"""

from __future__ import annotations

import binascii
from binascii import crc_hqx
from dataclasses import dataclass
from functools import lru_cache
import struct
import zlib

import numpy as np

from . import packed
from ..common.boardinfo import BoardInfo, INFO_MAX_TEXT

PROTOCOL_VERSION = 1  # what encode_frame writes unless told otherwise
PROTOCOL_VERSIONS = (1, 2)
LATEST_VERSION = 2
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
_HEAD = struct.Struct('<2sBBIQBBH')  # the header and its check, read by one call
# Clean version-2 frames that follow each other are unpacked together, up to this many counts:
# a frame a consumer keeps keeps the whole run's array (its layers view it), 16 kB at most.
RUN_COUNTS = 8192
_COUNTS = np.dtype('<u2')
# The CRC-32 of a frame with its own little-endian CRC-32 appended, whatever the frame: a frame
# read whole is checked by one zlib.crc32 of all of it (equal exactly when its CRC matches, as
# the register's update by the appended 32 bits is one-to-one), no slice and no unpack.
CRC32_RESIDUE = 0x2144DF1C

# Board information frame: marker, info version, text length, text, CRC-16 of all before it.
INFO_SYNC = b'\xa5\x69'
INFO_VERSION = 1
INFO_HEAD_SIZE = 4
INFO_MAX_SIZE = INFO_HEAD_SIZE + INFO_MAX_TEXT + HEADER_CHECK.size


def header_crc(data) -> int:
    """Return the CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) of the given bytes."""
    return binascii.crc_hqx(data, 0xFFFF)


def frame_size(rows: int, cols: int, version: int = 1) -> int:
    """Return the number of bytes of a frame with the given shape in protocol ``version``."""
    if version == 2:
        return packed.body_layout(rows, cols)[3]
    return HEADER_SIZE + 4 * rows * cols + CRC_SIZE


@dataclass(frozen=True, eq=False)
class Frame:
    """
    One decoded scan: both layers as read-only uint16 (rows, cols) ADC count maps.

    ``version`` is the protocol version that carried it. A version-2 board also says which rows
    it sampled: ``row_valid`` is None when it sampled them all (and always in version 1), else
    read-only (2, rows) booleans (top, bottom); an invalid row's counts are meaningless.
    ``faults`` are the board's fault bits (packed.FAULT_NAMES), 0 in version 1.
    """

    seq: int
    device_time_us: int
    rows: int
    cols: int
    top: np.ndarray
    bottom: np.ndarray
    version: int = 1
    faults: int = 0
    row_valid: np.ndarray | None = None

    def __eq__(self, other: object) -> bool:
        """Compare the scans: header fields, rows sampled, faults, both maps count for count."""
        if not isinstance(other, Frame):
            return NotImplemented
        # The version is how the scan travelled, not what it is.
        valid = (self.row_valid is None and other.row_valid is None) or np.array_equal(
            self.valid_rows(), other.valid_rows())
        return (self.seq == other.seq and self.device_time_us == other.device_time_us
                and self.rows == other.rows and self.cols == other.cols
                and self.faults == other.faults and valid
                and np.array_equal(self.top, other.top)
                and np.array_equal(self.bottom, other.bottom))

    def valid_rows(self) -> np.ndarray:
        """Return the (2, rows) booleans of the rows the board sampled."""
        if self.row_valid is None:
            return np.ones((2, self.rows), dtype=bool)
        return self.row_valid

    __hash__ = None


_new = object.__new__


def _frame(seq: int, device_time_us: int, rows: int, cols: int, top: np.ndarray,
           bottom: np.ndarray, version: int, faults: int, row_valid) -> Frame:
    """
    Return Frame(seq, device_time_us, ...) as the decoder makes one per frame it accepts.

    The frozen dataclass's __init__ sets each field by a call to object.__setattr__; one update
    of the instance's dict does the same with a single call.
    """
    frame = _new(Frame)
    frame.__dict__.update(seq=seq, device_time_us=device_time_us, rows=rows, cols=cols,
                          top=top, bottom=bottom, version=version, faults=faults,
                          row_valid=row_valid)
    return frame


@lru_cache(maxsize=16)
def _one_plan(rows: int, cols: int) -> tuple:
    """
    Return how :meth:`FrameDecoder._feed_one` reads a clean version-2 frame of this grid.

    (frame size, a Struct of the header and of the constant bytes around the counts, the
    values those must have, the counts' offset, count, layers' shape).
    """
    (_, at_counts, at_pad, size), head, zeros = packed.clean_body(rows, cols)
    fields = struct.Struct(f'<4sIQ2sH{len(head)}s{at_pad - at_counts}x{len(zeros)}s')
    expect = (SYNC + bytes((2, 0)), bytes((rows, cols)), head, zeros)
    return size, fields, expect, at_counts, 2 * rows * cols, (2, rows, cols)


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


def encode_frame(seq: int, device_time_us: int, top: np.ndarray, bottom: np.ndarray,
                 version: int = PROTOCOL_VERSION, faults: int = 0, row_valid=None) -> bytes:
    """
    Encode one scan of both layers as a frame of protocol ``version`` (1 or 2).

    Version 2 also carries ``faults`` (uint16 fault bits) and ``row_valid`` ((2, rows)
    booleans, None: every row sampled); version 1 has neither. Raise ValueError when seq is
    outside uint32, the time outside uint64, the layers differ in shape, are not 2-D integer
    arrays of at most 255 x 255, or hold counts outside 0..4095, or version 1 is given faults
    or an invalid row.
    """
    return frame_with_counts(seq, device_time_us, *encode_counts(top, bottom, version),
                             version=version, faults=faults, row_valid=row_valid)


def encode_counts(top: np.ndarray, bottom: np.ndarray, version: int = PROTOCOL_VERSION) -> tuple:
    """
    Return (rows, cols, the counts of both layers as a ``version`` frame carries them), checked.

    A board that sends the same scan again (a replay) encodes its counts once and each frame
    with :func:`frame_with_counts`. Raises ValueError as :func:`encode_frame` does.
    """
    _check_version(version)
    top = _check_layer('top', top)
    bottom = _check_layer('bottom', bottom)
    if top.shape != bottom.shape:
        raise ValueError(f'top and bottom must have the same shape, got {top.shape} and '
                         f'{bottom.shape}')
    rows, cols = top.shape
    if version == 2:
        return rows, cols, packed.pack_counts(np.concatenate((top.ravel(), bottom.ravel())))
    counts = (np.ascontiguousarray(top, dtype=_COUNTS).tobytes()
              + np.ascontiguousarray(bottom, dtype=_COUNTS).tobytes())
    return rows, cols, counts


def _check_version(version: int) -> None:
    if version not in PROTOCOL_VERSIONS:
        raise ValueError(f'protocol version must be one of {PROTOCOL_VERSIONS}, got {version!r}')


def frame_with_counts(seq: int, device_time_us: int, rows: int, cols: int, counts: bytes,
                      version: int = PROTOCOL_VERSION, faults: int = 0,
                      row_valid=None) -> bytes:
    """
    Return the frame of counts from :func:`encode_counts` with this sequence and time.

    ``version`` must be the one the counts were encoded for; ``faults`` and ``row_valid`` as
    :func:`encode_frame` takes them.
    """
    _check_version(version)
    seq = _check_int('seq', seq, MAX_SEQ)
    device_time_us = _check_int('device_time_us', device_time_us, MAX_DEVICE_TIME_US)
    faults = _check_int('faults', faults, 0xFFFF)
    clean = packed.all_valid_map(rows)
    # A board that sampled every row (nearly every scan) builds no map: the cached one is it.
    row_map = clean if row_valid is None else packed.encode_row_map(row_valid, rows)
    if version == 1:
        if faults or row_map != clean:
            raise ValueError('version 1 carries no fault bits and no invalid rows')
        flags, extra = 0, b''
    else:
        flags = ((packed.FLAG_ROWS_INVALID if row_map != clean else 0)
                 | (packed.FLAG_FAULT if faults else 0))
        extra = packed.FAULTS.pack(faults) + row_map
    body = bytearray(HEADER.pack(SYNC, version, flags, seq, device_time_us, rows, cols))
    body += HEADER_CHECK.pack(header_crc(body))
    body += extra
    body += counts
    body += bytes(-len(body) % 4 if version == 2 else 0)
    body += _CRC.pack(zlib.crc32(body))
    return bytes(body)


def encode_info(info) -> bytes:
    """
    Return the board information frame of ``info`` (a BoardInfo, or its text as str or bytes).

    Text is sent as given (a test may send text no host accepts); ValueError when it is not 1..200
    bytes or, as str, not ASCII.
    """
    text = info.text if isinstance(info, BoardInfo) else info
    raw = text.encode('ascii') if isinstance(text, str) else bytes(text)
    if not 1 <= len(raw) <= INFO_MAX_TEXT:
        raise ValueError(f'info text must be 1..{INFO_MAX_TEXT} bytes, got {len(raw)}')
    body = INFO_SYNC + bytes([INFO_VERSION, len(raw)]) + raw
    return body + HEADER_CHECK.pack(header_crc(body))


@dataclass
class DecoderStats:
    """Counters of what the decoder accepted and rejected since it was created."""

    frames: int = 0
    # header, frame or info CRC mismatch, a count above 4095 (version 1), or a version-2 body
    # that disagrees with its flags or has a non-zero spare bit
    crc_errors: int = 0
    size_errors: int = 0      # rows/cols of 0, above the maximum or unlike expected_shape
    version_errors: int = 0   # unknown protocol or info version, or flags it does not have
    bytes_discarded: int = 0  # bytes that were not part of an accepted frame
    seq_gaps: int = 0         # times the sequence number jumped forwards by more than one
    frames_missed: int = 0    # frames skipped by those jumps
    seq_implausible: int = 0  # forward jumps the device clock cannot explain (corrupt seq)
    info_frames: int = 0      # board information frames accepted
    info_errors: int = 0      # info frames of a length outside 1..200 or text that does not parse
    rows_flagged: int = 0     # frames with a row the board says it did not sample (version 2)
    fault_frames: int = 0     # frames whose fault bits are not zero (version 2)


class FrameDecoder:
    """
    Incremental frame decoder: feed it bytes as they arrive, get whole checked frames back.

    After garbage it resynchronises on the next sync marker; a rejected candidate resumes the
    search at the byte after its marker, so an intact frame that starts inside the candidate's
    bytes is still found.  The buffer holds less than two maximum-size frames at any time.

    Board information frames between the frames are checked and parsed, never returned:
    ``board_info`` is the newest one accepted (None while the stream has sent none, as a
    version-1 board never does).
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
            self._max_frame = max(frame_size(rows, cols, v) for v in PROTOCOL_VERSIONS)
        else:
            # Version 1 is the longer but for the smallest grids (28 against 32 bytes for 1 x 1).
            self._max_frame = max(frame_size(self._max_rows, self._max_cols, v)
                                  for v in PROTOCOL_VERSIONS)
        # An info frame may be longer than the smallest frames (206 bytes against 28 for 1 x 1).
        self._max_frame = max(self._max_frame, INFO_MAX_SIZE)
        self._expected = expected_shape
        self._buf = bytearray()
        self._last: tuple[int, int] | None = None  # (seq, device time) of the newest frame
        self.stats = DecoderStats()
        # (rows, cols) of the newest frame refused for its size, for diagnostics.
        self.last_rejected_shape: tuple[int, int] | None = None
        # (rows, cols) of the newest frame accepted, to compare with the board's own word.
        self.last_shape: tuple[int, int] | None = None
        # The protocol version of the newest frame accepted (None: none yet), for diagnostics.
        self.last_version: int | None = None
        self.last_faults = 0  # the fault bits of the newest frame accepted (version 2)
        self.board_info: BoardInfo | None = None
        self._info_text = b''  # the text of board_info as sent: a repeat is not parsed again
        # _one_plan of the newest clean version-2 frame's grid (None: none yet), for the read
        # that is one whole frame of it.
        self._one: tuple | None = None

    @property
    def max_buffer_bytes(self) -> int:
        """Return the most bytes the decoder ever holds between calls to feed."""
        return 2 * self._max_frame

    @property
    def buffered_bytes(self) -> int:
        """Return how many bytes are waiting for the rest of their frame."""
        return len(self._buf)

    def reset(self) -> None:
        """
        Drop buffered bytes and forget the last sequence number; keep the statistics.

        ``board_info`` stays: a board that boots announces itself before its first frame and a
        running one within a second, so a stale identity lasts no longer than a missing one
        would, and a reconnect to the same board does not make it anonymous meanwhile.
        """
        self.stats.bytes_discarded += len(self._buf)
        self._buf = bytearray()
        self._last = None

    def feed(self, data: bytes) -> list[Frame]:
        """
        Consume received bytes and return the frames they complete, oldest first.

        No byte content makes this raise; an object that is not bytes-like raises TypeError.
        """
        one = self._one
        if one is not None and len(data) == one[0] and not self._buf and type(data) is bytes:
            frames = self._feed_one(data, one)
            if frames is not None:
                return frames
        frames = []
        view = memoryview(data).cast('B')
        if type(data) is not bytes:
            # The layers of version-1 frames view what they were decoded from: not a buffer the
            # caller may change.
            data = view.tobytes()
            view = memoryview(data)
        start = 0
        buf = self._buf
        # An unfinished frame waits: it is completed in the buffer, in slices of one frame so
        # that the buffer holds less than two frames whatever arrives, until what is left came
        # with this call. The rest of the read is decoded in place, every frame of it in one
        # pass, the layers views of the caller's immutable bytes; only an unfinished tail is
        # kept, shorter than one frame as _scan stops only inside a frame.
        step = self._max_frame
        while buf and start < len(view):
            held = len(buf)
            buf += view[start:start + step]
            with memoryview(buf) as buf_view:
                pos = self._scan(buf, buf_view, frames, copy=True)
            if pos >= held and start + step < len(view):
                # What is left came with this read, and more of the read follows: in place.
                start += pos - held
                del buf[:]
                break
            del buf[:pos]
            start += step
        if not buf and start < len(view):
            pos = self._scan(data, view, frames, False, start)
            if pos < len(view):
                buf += view[pos:]
        return frames

    def _feed_one(self, data: bytes, plan: tuple) -> list[Frame] | None:
        """
        Return [the Frame] of a read that is one whole clean version-2 frame, else None.

        The usual read at 1 kHz, where a driver wakes per frame. The checks are rule 3's as
        :meth:`_scan` makes them (header, header check, flags, shape, the clean head and
        padding, CRC-32), fewer calls: None (not this case, or a frame to reject) leaves the
        read to :meth:`_scan`, which counts what it rejects.
        """
        size, fields, expect, at_counts, count, shape = plan
        prefix, seq, time_us, grid, check, head, pad = fields.unpack_from(data)
        if ((prefix, grid, head, pad) != expect
                or crc_hqx(data[:HEADER.size], 0xFFFF) != check  # as header_crc
                or zlib.crc32(data) != CRC32_RESIDUE):
            return None
        _, rows, cols = shape
        self._accept(seq, time_us, rows, cols, 2, 0, None)
        layers = packed.unpack_counts(data, at_counts, count, shape)
        return [_frame(seq, time_us, rows, cols, layers[0], layers[1], 2, 0, None)]

    def _scan(self, buf, view: memoryview, frames: list[Frame], copy: bool,
              start: int = 0) -> int:
        """
        Decode what buf (bytes or bytearray) holds from start; return where it stopped.

        copy: the layers are copied out of buf (a buffer that changes later), else they view it.
        Clean version-2 frames (no flag) that follow each other are checked one by one and
        unpacked together (:meth:`_unpack_run`); any other frame first unpacks those before it,
        so the frames come out in the order they were sent.
        """
        stats = self.stats
        expected = self._expected
        pos = start
        end = len(buf)
        run: list = []  # (seq, device time) of the clean version-2 frames not yet unpacked
        run_at = run_end = 0  # where the run's first frame starts and its last one ends
        run_shape = (0, 0, 0, 0)  # rows, cols, counts offset and size of the run's frames
        # Where the next info marker is: one search per info frame, not one per frame (-1: none
        # up to the end, which does not move within this call).
        info_at = buf.find(INFO_SYNC, pos)
        while pos < end:
            found = buf.find(SYNC, pos)
            if info_at >= 0:
                if info_at < pos:
                    info_at = buf.find(INFO_SYNC, pos)
                if 0 <= info_at and (found < 0 or info_at < found):
                    stats.bytes_discarded += info_at - pos
                    pos = info_at
                    taken = self._info(buf, view, pos, end)
                    if taken < 0:
                        break
                    pos += taken
                    continue
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
            _, version, flags, seq, time_us, rows, cols, check = _HEAD.unpack_from(buf, pos)
            if flags & ~(packed.FLAGS_V2 if version == 2 else 0) or version not in (1, 2):
                stats.version_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            if crc_hqx(view[pos:pos + HEADER.size], 0xFFFF) != check:  # as header_crc
                stats.crc_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            if (rows, cols) != expected and not self._shape_ok(rows, cols):
                stats.size_errors += 1
                self.last_rejected_shape = (rows, cols)
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            n = rows * cols
            if version == 1:
                size = HEADER_SIZE + 4 * n + CRC_SIZE
            else:
                clean = packed.clean_body(rows, cols)
                size = clean[0][3]
            if end - pos < size:
                break
            crc_at = pos + size - CRC_SIZE
            (crc,) = _CRC.unpack_from(buf, crc_at)
            if zlib.crc32(view[pos:crc_at]) != crc:
                stats.crc_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            if version == 2 and not flags:  # the usual scan: no fault, every row sampled
                (_, at_counts, at_pad, _), clean_head, zeros = clean
                if (buf[pos + HEADER_SIZE:pos + at_counts] != clean_head
                        or buf[pos + at_pad:crc_at] != zeros):
                    stats.crc_errors += 1
                    stats.bytes_discarded += len(SYNC)
                    pos += len(SYNC)
                    continue
                self._accept(seq, time_us, rows, cols, 2, 0, None)
                if run and (pos != run_end or run_shape[:2] != (rows, cols)
                            or 2 * n * len(run) >= RUN_COUNTS):
                    self._unpack_run(buf, run_at, run, run_shape, frames)
                    run = []
                if not run:
                    run_at, run_shape = pos, (rows, cols, at_counts, size)
                    self._one = _one_plan(rows, cols)
                run.append((seq, time_us))
                pos = run_end = pos + size
                continue
            if version == 1:
                body = self._body_v1(buf, pos, n, copy)
            else:
                body = self._body_v2(buf, pos, rows, clean, flags)
            if body is None:
                stats.crc_errors += 1
                stats.bytes_discarded += len(SYNC)
                pos += len(SYNC)
                continue
            if run:
                self._unpack_run(buf, run_at, run, run_shape, frames)
                run = []
            counts, faults, row_valid = body
            layers = counts.reshape(2, rows, cols)
            self._accept(seq, time_us, rows, cols, version, faults, row_valid)
            frames.append(_frame(seq, time_us, rows, cols, layers[0], layers[1], version, faults,
                                 row_valid))
            pos += size
        if run:
            self._unpack_run(buf, run_at, run, run_shape, frames)
        return pos

    def _accept(self, seq: int, time_us: int, rows: int, cols: int, version: int, faults: int,
                row_valid) -> None:
        """Count an accepted frame and follow its sequence number."""
        self._count_seq(seq, time_us)
        self.last_shape = (rows, cols)
        self.last_version = version
        self.last_faults = faults
        stats = self.stats
        if faults:
            stats.fault_frames += 1
        if row_valid is not None:
            stats.rows_flagged += 1
        stats.frames += 1

    @staticmethod
    def _unpack_run(buf, start: int, heads: list, shape: tuple, frames: list) -> None:
        """
        Append the Frames of the clean version-2 frames that follow each other from start.

        shape: (rows, cols, offset of the counts in a frame, frame size).
        """
        rows, cols, at_counts, size = shape
        count = len(heads)
        counts = packed.unpack_frames(buf, start + at_counts, 2 * rows * cols, count, size)
        if count == 1:
            top, bottom = counts.reshape(2, rows, cols)
            (seq, time_us), = heads
            frames.append(_frame(seq, time_us, rows, cols, top, bottom, 2, 0, None))
            return
        layers = counts.reshape(count, 2, rows, cols)
        for (seq, time_us), top, bottom in zip(heads, layers[:, 0], layers[:, 1]):
            frames.append(_frame(seq, time_us, rows, cols, top, bottom, 2, 0, None))

    @staticmethod
    def _body_v1(buf, pos: int, n: int, copy: bool):
        """Return (counts, 0, None) of the version-1 frame at pos, None if a count is corrupt."""
        counts = np.frombuffer(buf, dtype=_COUNTS, count=2 * n, offset=pos + HEADER_SIZE)
        if copy:
            counts = counts.copy()
            counts.flags.writeable = False
        if counts.max() > MAX_COUNT:
            return None
        if counts.dtype != np.uint16:  # big-endian host
            counts = counts.astype(np.uint16)
            counts.flags.writeable = False
        return counts, 0, None

    @staticmethod
    def _body_v2(buf, pos: int, rows: int, clean: tuple, flags: int):
        """
        Return (counts, faults, row_valid or None) of a checked, flagged version-2 frame at pos.

        None if its body disagrees with its flags, or a spare or padding bit is set. (A frame
        with no flag is checked and unpacked in :meth:`_scan`.)
        """
        (at_map, at_counts, at_pad, size), clean_head, zeros = clean
        if buf[pos + at_pad:pos + size - CRC_SIZE] != zeros:
            return None
        (faults,) = packed.FAULTS.unpack_from(buf, pos + HEADER_SIZE)
        row_map = bytes(buf[pos + at_map:pos + at_counts])
        all_valid = row_map == clean_head[packed.FAULTS.size:]
        if (bool(flags & packed.FLAG_FAULT) != bool(faults)
                or bool(flags & packed.FLAG_ROWS_INVALID) == all_valid):
            return None
        row_valid = None
        if not all_valid:
            row_valid = packed.decode_row_map(row_map, rows)
            if packed.encode_row_map(row_valid, rows) != row_map:  # a spare bit set
                return None
        counts = packed.unpack_counts(buf, pos + at_counts, (at_pad - at_counts) * 2 // 3)
        return counts, faults, row_valid

    def _info(self, buf, view: memoryview, pos: int, end: int) -> int:
        """
        Check the info frame candidate at pos; return the bytes it uses up, -1 to wait for more.

        A rejected candidate uses up its marker alone, as a rejected frame does.
        """
        stats = self.stats
        if end - pos < INFO_HEAD_SIZE:
            return -1
        version, length = buf[pos + 2], buf[pos + 3]
        if version != INFO_VERSION:
            stats.version_errors += 1
        elif not 1 <= length <= INFO_MAX_TEXT:
            stats.info_errors += 1
        else:
            size = INFO_HEAD_SIZE + length + HEADER_CHECK.size
            if end - pos < size:
                return -1
            crc_at = pos + size - HEADER_CHECK.size
            (check,) = HEADER_CHECK.unpack_from(buf, crc_at)
            if header_crc(view[pos:crc_at]) != check:
                stats.crc_errors += 1
            else:
                text = bytes(view[pos + INFO_HEAD_SIZE:crc_at])
                if text != self._info_text:
                    try:
                        info = BoardInfo.parse(text)
                    except ValueError:
                        info = None
                    if info is None:
                        stats.info_errors += 1
                        stats.bytes_discarded += len(INFO_SYNC)
                        return len(INFO_SYNC)
                    self.board_info, self._info_text = info, text
                stats.info_frames += 1
                return size
        stats.bytes_discarded += len(INFO_SYNC)
        return len(INFO_SYNC)

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
