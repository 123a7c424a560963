"""
Tests of reads that hold many frames: the decoder unpacks clean version-2 frames together.

Whatever the read's size, each frame comes out once, in the order sent, with its own counts,
and keeps them whatever the caller does with the buffer it fed afterwards.
"""

import numpy as np
import pytest

from skin_driver.core.protocol.wire import encode_frame, FrameDecoder

SHAPE = (16, 16)


def scan(seq):
    rng = np.random.default_rng(seq)
    return (rng.integers(0, 4096, SHAPE, dtype=np.uint16),
            rng.integers(0, 4096, SHAPE, dtype=np.uint16))


def mixed_stream():
    """
    Return (stream, what each frame carries): 40 frames, mostly clean version 2.

    Seq 10 is flagged (a row not sampled, a fault), seq 25 is version 1, and junk sits before
    seq 30: each ends a run of clean frames that follow each other.
    """
    stream, sent = b'', []
    for seq in range(40):
        top, bottom = scan(seq)
        version, faults, valid = (1 if seq == 25 else 2), 0, None
        if seq == 10:
            faults, valid = 0x0009, np.ones((2, SHAPE[0]), dtype=bool)
            valid[1, 3] = False
        if seq == 30:
            stream += b'\x00\xa5\x13junk'
        stream += encode_frame(seq, 1000 * seq, top, bottom, version=version, faults=faults,
                               row_valid=valid)
        sent.append((seq, version, faults, valid, top, bottom))
    return stream, sent


def decode(stream, read):
    dec = FrameDecoder(expected_shape=SHAPE)
    frames = []
    for i in range(0, len(stream), read):
        frames += dec.feed(stream[i:i + read])
    return frames, dec.stats


@pytest.mark.parametrize('read', [800, 1000, 4096, 65536])
def test_every_frame_of_a_read_comes_out_once_in_order_with_its_own_counts(read):
    stream, sent = mixed_stream()
    frames, stats = decode(stream, read)
    assert [f.seq for f in frames] == list(range(40))
    for frame, (seq, version, faults, valid, top, bottom) in zip(frames, sent):
        assert (frame.device_time_us, frame.version, frame.faults) == (1000 * seq, version,
                                                                       faults)
        np.testing.assert_array_equal(frame.top, top)
        np.testing.assert_array_equal(frame.bottom, bottom)
        assert not frame.top.flags.writeable and not frame.bottom.flags.writeable
        if valid is None:
            assert frame.row_valid is None
        else:
            np.testing.assert_array_equal(frame.row_valid, valid)
    assert (stats.frames, stats.rows_flagged, stats.fault_frames) == (40, 1, 1)
    assert stats.bytes_discarded == len(b'\x00\xa5\x13junk')
    assert stats.crc_errors == stats.seq_gaps == 0


def test_a_frame_keeps_its_counts_when_the_buffer_it_came_in_changes():
    stream, sent = mixed_stream()
    buffer = bytearray(stream)
    frames = FrameDecoder(expected_shape=SHAPE).feed(buffer)
    buffer[:] = bytes(len(buffer))
    for frame, (_, _, _, _, top, bottom) in zip(frames, sent):
        np.testing.assert_array_equal(frame.top, top)
        np.testing.assert_array_equal(frame.bottom, bottom)
    assert len(frames) == 40


def test_a_damaged_frame_inside_a_run_costs_only_itself():
    stream, _ = mixed_stream()
    size = 800  # version 2, 16 x 16
    damaged = bytearray(stream)
    damaged[3 * size + 400] ^= 0x40  # a count of seq 3, inside the first run
    frames, stats = decode(bytes(damaged), 65536)
    assert [f.seq for f in frames] == [s for s in range(40) if s != 3]
    assert (stats.crc_errors, stats.seq_gaps, stats.frames_missed) == (1, 1, 1)
