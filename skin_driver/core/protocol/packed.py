"""
The body of a version-2 frame (docs/protocol.md): fault bits, row map, packed 12-bit counts.

After the 20-byte header (as version 1's, with version 2): the board's fault bits (uint16), the
row map (one bit per row and layer, 1: the row was sampled), the 2n counts of both layers packed
two in three bytes, zero padding to a whole number of 32-bit words, then the CRC-32.
The counts are unpacked by precomputed offsets into the payload, no per-count Python, and the
counts of consecutive frames by the same calls, one axis more.
"""

from __future__ import annotations

from functools import lru_cache
import struct

import numpy as np

HEADER_SIZE = 20
FAULTS = struct.Struct('<H')
CRC_SIZE = 4
MAX_COUNT = 4095
_WORD = np.dtype('<u2')
_NATIVE = _WORD == np.dtype(np.uint16)  # a little-endian host
_MASK = np.uint16(MAX_COUNT)  # a numpy scalar: the ufunc converts no Python int per call
# From about this many counts in one call, two strided views unpack faster than one take: their
# extra calls cost less than the take's work per count.
MANY_COUNTS = 4096

# Flags of a version-2 header: what the body says, readable before the body arrives.
FLAG_ROWS_INVALID = 0x01  # a row of either layer was not sampled (the row map has a 0)
FLAG_FAULT = 0x02         # the fault bits are not zero
FLAGS_V2 = FLAG_ROWS_INVALID | FLAG_FAULT

# The board's fault bits (a summary of this scan; the board's counters are in its information
# frame). Bits not named here are shown by number.
FAULT_NAMES = {0: 'row failed', 1: 'scan overrun', 2: 'adc', 3: 'clock', 4: 'watchdog reset'}


def map_bytes(rows: int) -> int:
    """Return the bytes of one layer's row map."""
    return (rows + 7) // 8


def body_layout(rows: int, cols: int) -> tuple:
    """Return (row map offset, counts offset, padding offset, frame size) of a version-2 frame."""
    at_map = HEADER_SIZE + FAULTS.size
    at_counts = at_map + 2 * map_bytes(rows)
    at_pad = at_counts + 3 * rows * cols
    return at_map, at_counts, at_pad, (at_pad + 3) // 4 * 4 + CRC_SIZE


@lru_cache(maxsize=256)
def clean_body(rows: int, cols: int) -> tuple:
    """
    Return (layout, clean head, padding) of a version-2 frame of this grid.

    The clean head is the bytes from the fault bits to the counts of a scan with no fault and
    every row sampled, the padding its zero bytes: a clean frame is checked by two compares.
    """
    layout = body_layout(rows, cols)
    at_map, at_counts, at_pad, size = layout
    return layout, FAULTS.pack(0) + all_valid_map(rows), bytes(size - CRC_SIZE - at_pad)


def fault_names(bits: int) -> list:
    """Return the names of the set fault bits, lowest first."""
    return [FAULT_NAMES.get(bit, f'bit {bit}') for bit in range(16) if bits >> bit & 1]


def pack_counts(counts: np.ndarray) -> bytes:
    """Return the 12-bit counts (uint16, an even number of them) packed two in three bytes."""
    pairs = np.asarray(counts, dtype=np.uint32).reshape(-1, 2)
    word = pairs[:, 0] | pairs[:, 1] << 12
    out = np.empty((len(word), 3), dtype=np.uint8)
    out[:, 0] = word & 0xFF
    out[:, 1] = word >> 8 & 0xFF
    out[:, 2] = word >> 16
    return out.tobytes()


def unpack_counts(buf, offset: int, count: int, shape: tuple | None = None) -> np.ndarray:
    """
    Return ``count`` (even) counts packed at buf[offset:] as a new read-only uint16 array.

    Count 2k is the little-endian uint16 at byte 3k, low 12 bits; count 2k+1 the uint16 at byte
    3k + 1, shifted right by 4 (:func:`unpack_frames`). ``shape``: the array's (count,
    default), e.g. (2, rows, cols) for a frame's layers.
    """
    return _unpack(buf, offset, count, (), ()).reshape(shape or count)


def unpack_frames(buf, offset: int, count: int, frames: int, stride: int) -> np.ndarray:
    """
    Return the counts of ``frames`` frames ``stride`` bytes apart as read-only (frames, count).

    ``offset`` is where the first frame's packed counts start; a frame's count 2k is the
    little-endian uint16 at its byte 3k, low 12 bits, count 2k + 1 the uint16 at byte 3k + 1,
    shifted right by 4. Few counts (one small frame, a read at 1 kHz): a copy of the view of
    every pair's two uint16, one shift and one mask, the fewest numpy calls. Many: a view of the
    even and of the odd counts' uint16 (stride 3) and one ufunc each into the output, which
    costs more calls but less per count. Either way no per-count or per-frame Python.
    """
    return _unpack(buf, offset, count, (frames,), (stride,)).reshape(frames, count)


def _unpack(buf, offset: int, count: int, frames: tuple, stride: tuple) -> np.ndarray:
    """
    Return the counts as read-only (*frames, pairs, 2): frames is () or (frames,), as stride.

    Few counts: the view of pair k's uint16 at byte 3k and 3k + 1 is copied first, because the
    ufuncs run unbuffered on the copy (aligned, contiguous) and buffered on the unaligned view.
    The constructors are given positional arguments and a dtype object: no keyword and no type
    string to parse, a fixed cost that weighs when a call unpacks one small frame.
    """
    pairs = count // 2
    if count * (frames[0] if frames else 1) < MANY_COUNTS:
        out = np.ndarray(frames + (pairs, 2), _WORD, buf, offset, stride + (3, 1)).copy()
        if not _NATIVE:
            out = out.astype(np.uint16)
        np.right_shift(out, _shifts(pairs), out=out)
        np.bitwise_and(out, _MASK, out=out)
    else:
        even = np.ndarray(frames + (pairs,), _WORD, buf, offset, stride + (3,))
        odd = np.ndarray(frames + (pairs,), _WORD, buf, offset + 1, stride + (3,))
        out = np.empty(frames + (pairs, 2), dtype=np.uint16)
        np.bitwise_and(even, _MASK, out=out[..., 0])
        np.right_shift(odd, 4, out=out[..., 1])
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def _shifts(pairs: int) -> np.ndarray:
    """Return the (pairs, 2) shifts that bring a pair's two uint16 down to its counts."""
    shifts = np.tile(np.array([0, 4], dtype=np.uint16), (pairs, 1))
    shifts.flags.writeable = False
    return shifts


def encode_row_map(row_valid, rows: int) -> bytes:
    """Return the row map of ``row_valid`` ((2, rows) booleans; None: every row valid)."""
    if row_valid is None:
        valid = np.ones((2, rows), dtype=bool)
    else:
        valid = np.asarray(row_valid, dtype=bool)
        if valid.shape != (2, rows):
            raise ValueError(f'row_valid must have shape (2, {rows}), got {valid.shape}')
    return np.packbits(valid, axis=1, bitorder='little').tobytes()


@lru_cache(maxsize=None)
def all_valid_map(rows: int) -> bytes:
    """Return the row map of a scan whose rows were all sampled."""
    return encode_row_map(None, rows)


def decode_row_map(raw: bytes, rows: int) -> np.ndarray:
    """Return the (2, rows) read-only booleans of a row map (its spare bits ignored)."""
    bits = np.unpackbits(np.frombuffer(raw, dtype=np.uint8).reshape(2, -1), axis=1,
                         bitorder='little')[:, :rows].astype(bool)
    bits.flags.writeable = False
    return bits
