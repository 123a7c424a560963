"""
Tests of the read that is one whole frame, as a driver at 1 kHz gets it (one read per frame).

A clean version-2 frame read by itself takes a shorter way through the decoder than the rest.
These tests hold it to what the decoder does with the same bytes read together: the same frames
with the same counts, the same counters, and every frame it must reject rejected and counted.
"""

import binascii
import struct
import zlib

import numpy as np
import pytest

from skin_driver.core.protocol.wire import (
    encode_frame, encode_info, Frame, FrameDecoder, INFO_SYNC, SYNC)

SHAPE = (16, 16)
SIZE = 800  # a version-2 frame of 16 x 16


def frame(seq, shape=SHAPE, **extra):
    """Return a version-2 frame of seeded counts in which no marker occurs past its own."""
    return sent(seq, shape, **extra)[0]


def sent(seq, shape=SHAPE, **extra):
    """Return (the frame, its top, its bottom) of :func:`frame`."""
    for salt in range(100):
        rng = np.random.default_rng((seq, salt))
        top, bottom = (rng.integers(0, 4096, shape, dtype=np.uint16) for _ in range(2))
        raw = encode_frame(seq, 1000 * seq, top, bottom, version=2, **extra)
        if SYNC not in raw[1:] and INFO_SYNC not in raw[1:]:
            return raw, top, bottom
    raise AssertionError('no seed gives a frame without a marker inside')


def reseal(raw):
    """Recompute both checks of an edited version-2 frame so that only the edit is wrong."""
    head = raw[:18] + struct.pack('<H', binascii.crc_hqx(raw[:18], 0xFFFF))
    body = head + raw[20:-4]
    return body + struct.pack('<I', zlib.crc32(body))


def crc32_resealed(raw):
    """Recompute the CRC-32 of an edited frame alone."""
    return raw[:-4] + struct.pack('<I', zlib.crc32(raw[:-4]))


def edited(raw, at, value):
    out = bytearray(raw)
    out[at] = value
    assert SYNC not in out[1:] and INFO_SYNC not in out[1:]
    return bytes(out)


def decode_apart_and_together(reads, **options):
    """Return (frames one read each, frames of one read of all, both decoders)."""
    apart, together = FrameDecoder(**options), FrameDecoder(**options)
    frames = [f for data in reads for f in apart.feed(data)]
    return frames, together.feed(b''.join(reads)), apart, together


def assert_same(frames, others, decoder, other):
    assert len(frames) == len(others)
    for a, b in zip(frames, others):
        assert a == b and a.version == b.version
        assert not a.top.flags.writeable and not a.bottom.flags.writeable
    assert decoder.stats == other.stats
    assert (decoder.last_shape, decoder.last_version, decoder.last_faults) == (
        other.last_shape, other.last_version, other.last_faults)


def test_clean_frames_read_one_by_one_carry_their_counts_and_sequence():
    reads = [frame(seq) for seq in (0, 1, 2, 6, 7)]
    frames, together, dec, other = decode_apart_and_together(reads, expected_shape=SHAPE)
    assert [f.seq for f in frames] == [0, 1, 2, 6, 7]
    assert [f.device_time_us for f in frames] == [0, 1000, 2000, 6000, 7000]
    np.testing.assert_array_equal(frames[3].top, sent(6)[1])
    np.testing.assert_array_equal(frames[4].bottom, sent(7)[2])
    assert (dec.stats.frames, dec.stats.seq_gaps, dec.stats.frames_missed) == (5, 1, 3)
    assert (dec.last_shape, dec.last_version, dec.last_faults) == (SHAPE, 2, 0)
    assert dec.buffered_bytes == 0
    assert_same(frames, together, dec, other)


@pytest.mark.parametrize('grid', [(1, 1), (16, 16), (48, 48)])  # 48 x 48: unpacked in two views
def test_the_counts_of_a_frame_read_by_itself_are_those_sent(grid):
    dec = FrameDecoder()
    for seq in range(3):
        raw, top, bottom = sent(seq, grid)
        (got,) = dec.feed(raw)
        np.testing.assert_array_equal(got.top, top)
        np.testing.assert_array_equal(got.bottom, bottom)
        assert got.top.dtype == np.uint16 and not got.top.flags.writeable


# Each read is one frame's length; the one named is what the decoder must make of it.
BAD_READS = {
    # A count's bit flipped: the CRC-32 fails.
    'payload_bit_flip': (lambda raw: edited(raw, 400, raw[400] ^ 0x01), 'crc_errors'),
    # The frame's CRC-32 itself damaged.
    'frame_check_flip': (lambda raw: edited(raw, SIZE - 2, raw[SIZE - 2] ^ 0x10), 'crc_errors'),
    # A bit of seq flipped: the header check and the CRC-32 fail.
    'header_bit_flip': (lambda raw: edited(raw, 5, raw[5] ^ 0x04), 'crc_errors'),
    # The header check damaged, the CRC-32 made to match: the header check alone fails.
    'header_check_only': (lambda raw: crc32_resealed(edited(raw, 18, raw[18] ^ 0x01)),
                          'crc_errors'),
    # Both checks pass, a padding byte is not zero: the board's encoder is broken.
    'padding_set': (lambda raw: reseal(edited(raw, SIZE - 5, 0x01)), 'crc_errors'),
    # Both checks pass, fault bits set though the flags say none.
    'faults_unflagged': (lambda raw: reseal(edited(raw, 20, 0x02)), 'crc_errors'),
    # Both checks pass, a row marked not sampled though the flags say every row was.
    'row_unflagged': (lambda raw: reseal(edited(raw, 22, 0xFE)), 'crc_errors'),
    # A flag version 2 does not have.
    'unknown_flag': (lambda raw: reseal(edited(raw, 3, 0x04)), 'version_errors'),
}


@pytest.mark.parametrize('case', sorted(BAD_READS))
def test_a_bad_frame_read_by_itself_is_rejected_and_counted(case):
    edit, counter = BAD_READS[case]
    reads = [frame(0), frame(1), edit(frame(2)), frame(3)]
    frames, together, dec, other = decode_apart_and_together(reads, expected_shape=SHAPE)
    assert [f.seq for f in frames] == [0, 1, 3]
    assert getattr(dec.stats, counter) == 1
    assert (dec.stats.frames, dec.stats.seq_gaps, dec.stats.frames_missed) == (3, 1, 1)
    assert_same(frames, together, dec, other)


def test_a_flagged_frame_read_by_itself_keeps_its_faults_and_rows():
    valid = np.ones((2, SHAPE[0]), dtype=bool)
    valid[0, 5] = False
    reads = [frame(0), frame(1, faults=0x0009, row_valid=valid), frame(2)]
    frames, together, dec, other = decode_apart_and_together(reads, expected_shape=SHAPE)
    assert [(f.seq, f.faults) for f in frames] == [(0, 0), (1, 0x0009), (2, 0)]
    np.testing.assert_array_equal(frames[1].row_valid, valid)
    assert frames[0].row_valid is None and frames[2].row_valid is None
    assert (dec.stats.fault_frames, dec.stats.rows_flagged) == (1, 1)
    assert_same(frames, together, dec, other)


@pytest.mark.parametrize('grid, other_grid', [
    ((16, 16), (17, 15)),  # both 800 bytes
    ((1, 4), (1, 3)),      # both 40 bytes, with the same fault bits, row map and padding bytes
])
def test_a_frame_of_another_grid_and_the_same_length_is_decoded_as_that_grid(grid, other_grid):
    reads = [frame(0, grid), frame(1, other_grid), frame(2, grid)]
    assert len(reads[0]) == len(reads[1])
    frames, together, dec, other = decode_apart_and_together(reads)
    assert [(f.seq, f.top.shape) for f in frames] == [(0, grid), (1, other_grid), (2, grid)]
    assert_same(frames, together, dec, other)
    # A decoder told the grid refuses it.
    frames, together, dec, other = decode_apart_and_together(reads, expected_shape=grid)
    assert [f.seq for f in frames] == [0, 2] and dec.stats.size_errors == 1
    assert dec.last_rejected_shape == other_grid
    assert_same(frames, together, dec, other)


def test_frames_cut_by_reads_and_info_frames_between_them_decode_as_one_read():
    info = encode_info('board=sim;uid=53494d000000000000000000;fw=0.1.0;grid=16x16;'
                       'pitch_um=5000;rate_hz=1000')
    first, second = frame(1), frame(2)
    reads = [frame(0), info, first[:300], first[300:] + second[:500], second[500:], frame(3),
             frame(4) + frame(5)]
    frames, together, dec, other = decode_apart_and_together(reads, expected_shape=SHAPE)
    assert [f.seq for f in frames] == [0, 1, 2, 3, 4, 5]
    assert dec.stats.info_frames == 1 and dec.board_info.board == 'sim'
    assert dec.stats.bytes_discarded == 0 and dec.buffered_bytes == 0
    assert_same(frames, together, dec, other)


def test_a_frame_read_into_a_buffer_the_caller_reuses_keeps_its_counts():
    dec = FrameDecoder(expected_shape=SHAPE)
    dec.feed(frame(0))
    buffer = bytearray(frame(1))
    (got,) = dec.feed(buffer)
    buffer[:] = bytes(SIZE)
    assert got == FrameDecoder().feed(frame(1))[0]


def test_a_frame_read_after_a_reset_starts_the_sequence_anew():
    dec = FrameDecoder(expected_shape=SHAPE)
    dec.feed(frame(0))
    dec.feed(frame(1)[:100])
    dec.reset()
    (got,) = dec.feed(frame(9))
    assert isinstance(got, Frame) and got.seq == 9
    assert (dec.stats.frames, dec.stats.seq_gaps, dec.stats.bytes_discarded) == (2, 0, 100)
