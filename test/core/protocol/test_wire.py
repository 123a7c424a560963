"""Tests of the wire protocol: encoding, decoding, rejection of corrupt frames and resync."""

import binascii
import struct
import zlib

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from skin_driver.core.protocol.wire import (
    DecoderStats, encode_frame, Frame, frame_size, FrameDecoder, header_crc, HEADER_SIZE,
    PROTOCOL_VERSION, SYNC)


def layers(shape, seed=0):
    rng = np.random.default_rng(seed)
    return (rng.integers(0, 4096, shape, dtype=np.uint16),
            rng.integers(0, 4096, shape, dtype=np.uint16))


def frame_bytes(seq, shape=(16, 16), time_us=None):
    top, bottom = layers(shape, seed=seq)
    return encode_frame(seq, seq * 10_000 if time_us is None else time_us, top, bottom)


def reseal(raw):
    """Recompute both CRCs of an edited frame so that only the edit is wrong."""
    body = raw[:18] + struct.pack('<H', binascii.crc_hqx(raw[:18], 0xFFFF)) + raw[20:-4]
    return body + struct.pack('<I', zlib.crc32(body))


def fake_header(rows, cols, valid_check=True):
    """Return a frame header (no payload) such as garbage might contain."""
    head = SYNC + bytes([1, 0]) + bytes(12) + bytes([rows, cols])
    check = binascii.crc_hqx(head, 0xFFFF) if valid_check else 0x3333
    return head + struct.pack('<H', check)


def test_layout_of_a_known_frame():
    top = np.arange(6, dtype=np.uint16).reshape(2, 3)
    bottom = np.full((2, 3), 4095, dtype=np.uint16)
    raw = encode_frame(0x01020304, 0x1122334455667788, top, bottom)
    assert len(raw) == frame_size(2, 3) == HEADER_SIZE + 24 + 4 == 48
    assert raw[:2] == b'\xa5\x5a'
    assert raw[2] == PROTOCOL_VERSION == 1
    assert raw[3] == 0
    assert raw[4:8] == b'\x04\x03\x02\x01'
    assert raw[8:16] == bytes.fromhex('8877665544332211')
    assert raw[16:18] == b'\x02\x03'
    assert struct.unpack('<H', raw[18:20])[0] == binascii.crc_hqx(raw[:18], 0xFFFF)
    assert raw[20:22] == b'\x00\x00' and raw[30:32] == b'\x05\x00'
    assert raw[32:34] == b'\xff\x0f'
    assert struct.unpack('<I', raw[-4:])[0] == zlib.crc32(raw[:-4])


def test_crc_test_vectors():
    # docs/protocol.md quotes these check values of CRC-16/CCITT-FALSE and CRC-32/ISO-HDLC.
    assert header_crc(b'123456789') == binascii.crc_hqx(b'123456789', 0xFFFF) == 0x29B1
    assert zlib.crc32(b'123456789') == 0xCBF43926


def test_round_trip_returns_equal_read_only_maps():
    top, bottom = layers((16, 16))
    dec = FrameDecoder()
    (frame,) = dec.feed(encode_frame(7, 123_456, top, bottom))
    assert (frame.seq, frame.device_time_us, frame.rows, frame.cols) == (7, 123_456, 16, 16)
    assert frame.top.dtype == np.uint16 and frame.top.shape == (16, 16)
    np.testing.assert_array_equal(frame.top, top)
    np.testing.assert_array_equal(frame.bottom, bottom)
    assert not frame.top.flags.writeable and not frame.bottom.flags.writeable
    assert frame == Frame(7, 123_456, 16, 16, top, bottom)
    assert frame != Frame(7, 123_456, 16, 16, top, top)
    assert dec.stats == DecoderStats(frames=1)


def test_frames_keep_their_counts_whatever_is_fed_after_them():
    top, bottom = layers((16, 16))
    first, second = encode_frame(1, 10, top, bottom), encode_frame(2, 20, bottom, top)
    dec = FrameDecoder(expected_shape=(16, 16))
    # Whole frames are decoded from the bytes given, split ones from the decoder's buffer.
    (whole,) = dec.feed(first)
    assert dec.feed(second[:700]) == []
    (split,) = dec.feed(bytearray(second[700:]) + first[:300])
    dec.feed(b'\x00' * 5000 + first)
    np.testing.assert_array_equal(whole.top, top)
    np.testing.assert_array_equal(split.top, bottom)
    np.testing.assert_array_equal(split.bottom, top)
    assert not split.top.flags.writeable


def test_extreme_header_values_and_non_square_shapes():
    top, bottom = layers((1, 128))
    dec = FrameDecoder()
    (frame,) = dec.feed(encode_frame(2 ** 32 - 1, 2 ** 64 - 1, top, bottom))
    assert frame.seq == 2 ** 32 - 1 and frame.device_time_us == 2 ** 64 - 1
    assert (frame.rows, frame.cols) == (1, 128)
    np.testing.assert_array_equal(frame.bottom, bottom)


def test_128_by_128_frame_round_trips():
    top, bottom = layers((128, 128))
    raw = encode_frame(1, 2, top, bottom)
    assert len(raw) == 20 + 4 * 128 * 128 + 4
    dec = FrameDecoder()
    frames = dec.feed(raw + raw[:100])
    assert len(frames) == 1
    np.testing.assert_array_equal(frames[0].top, top)
    np.testing.assert_array_equal(frames[0].bottom, bottom)


def test_encoder_does_not_modify_inputs_and_accepts_other_integer_dtypes():
    top = np.full((4, 4), 4095, dtype=np.int64)
    bottom = np.zeros((4, 4), dtype=np.int32)
    before = top.copy()
    raw = encode_frame(0, 0, top, bottom)
    np.testing.assert_array_equal(top, before)
    (frame,) = FrameDecoder().feed(raw)
    assert frame.top.dtype == np.uint16 and int(frame.top.max()) == 4095


@pytest.mark.parametrize('kwargs, message', [
    ({'seq': -1}, 'seq'),
    ({'seq': 2 ** 32}, 'seq'),
    ({'seq': 1.0}, 'seq'),
    ({'device_time_us': -5}, 'device_time_us'),
    ({'device_time_us': 2 ** 64}, 'device_time_us'),
    ({'top': np.full((4, 4), 4096)}, 'top counts'),
    ({'bottom': np.full((4, 4), -1)}, 'bottom counts'),
    ({'top': np.zeros((4, 4), dtype=float)}, 'integer dtype'),
    ({'top': np.zeros(16, dtype=np.uint16)}, '2-D'),
    ({'top': np.zeros((4, 5), dtype=np.uint16)}, 'same shape'),
    ({'top': np.zeros((256, 1), np.uint16), 'bottom': np.zeros((256, 1), np.uint16)}, '255'),
    ({'top': np.zeros((0, 4), np.uint16), 'bottom': np.zeros((0, 4), np.uint16)}, '1..255'),
])
def test_encoder_rejects_bad_input(kwargs, message):
    args = {'seq': 0, 'device_time_us': 0, 'top': np.zeros((4, 4), np.uint16),
            'bottom': np.zeros((4, 4), np.uint16)}
    args.update(kwargs)
    with pytest.raises(ValueError, match=message):
        encode_frame(**args)


def test_byte_by_byte_feeding_yields_every_frame_once():
    stream = b''.join(frame_bytes(s, (3, 5)) for s in range(4))
    dec = FrameDecoder()
    frames = []
    for i in range(len(stream)):
        frames += dec.feed(stream[i:i + 1])
    assert [f.seq for f in frames] == [0, 1, 2, 3]
    assert dec.stats == DecoderStats(frames=4)
    assert dec.buffered_bytes == 0


def test_split_at_every_position_yields_the_frame():
    raw = frame_bytes(3, (2, 2))
    for cut in range(len(raw) + 1):
        dec = FrameDecoder()
        frames = dec.feed(raw[:cut]) + dec.feed(raw[cut:])
        assert [f.seq for f in frames] == [3], cut


def corrupt_frames():
    good = frame_bytes(1)
    flipped = bytearray(good)
    flipped[HEADER_SIZE + 10] ^= 0x01
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0x80
    bad_header = bytearray(good)
    bad_header[5] ^= 0x40  # seq byte: only the header check can tell
    bad_rows = bytearray(good)
    bad_rows[16] = 128  # would announce a frame eight times longer
    version = bytearray(good)
    version[2] = 3
    flags = bytearray(good)
    flags[3] = 1
    rows0 = bytearray(good)
    rows0[16] = 0
    cols_big = bytearray(good)
    cols_big[17] = 200
    over_range = bytearray(good)
    over_range[HEADER_SIZE + 1] = 0x10  # first top count becomes >= 4096
    return {
        'payload bit flip': (bytes(flipped), 'crc_errors'),
        'crc bit flip': (bytes(bad_crc), 'crc_errors'),
        'header bit flip': (bytes(bad_header), 'crc_errors'),
        'rows changed, header check not updated': (bytes(bad_rows), 'crc_errors'),
        'truncated frame': (good[:-7], None),
        'unknown version 3 even with a valid crc': (reseal(bytes(version)), 'version_errors'),
        'non-zero flags': (reseal(bytes(flags)), 'version_errors'),
        'zero rows': (reseal(bytes(rows0)), 'size_errors'),
        'cols above max_cols': (reseal(bytes(cols_big)), 'size_errors'),
        'count above 4095 with a valid crc': (reseal(bytes(over_range)), 'crc_errors'),
    }


@pytest.mark.parametrize('name', list(corrupt_frames()))
def test_corrupt_frame_is_rejected_counted_and_the_next_frame_survives(name):
    bad, counter = corrupt_frames()[name]
    dec = FrameDecoder()
    frames = dec.feed(frame_bytes(0) + bad + frame_bytes(2) + frame_bytes(3))
    assert [f.seq for f in frames] == [0, 2, 3]
    stats = dec.stats
    errors = {k: getattr(stats, k) for k in ('crc_errors', 'size_errors', 'version_errors')}
    if counter is None:
        # A truncated frame swallows the start of the next one and fails its CRC.
        assert errors == {'crc_errors': 1, 'size_errors': 0, 'version_errors': 0}
    else:
        assert errors[counter] == 1 and sum(errors.values()) == 1
    assert stats.bytes_discarded == len(bad)
    assert stats.frames == 3


def test_frame_of_unexpected_shape_is_a_size_error():
    dec = FrameDecoder(expected_shape=(16, 16))
    frames = dec.feed(frame_bytes(0) + frame_bytes(1, (8, 8)) + frame_bytes(2))
    assert [f.seq for f in frames] == [0, 2]
    assert dec.stats.size_errors == 1


def test_decoder_limits_validate():
    with pytest.raises(ValueError, match='max_rows'):
        FrameDecoder(max_rows=0)
    with pytest.raises(ValueError, match='expected_shape'):
        FrameDecoder(expected_shape=(16, 200))
    with pytest.raises(ValueError, match='expected_shape'):
        FrameDecoder(expected_shape=(16,))


def test_feed_rejects_non_bytes_objects():
    with pytest.raises(TypeError):
        FrameDecoder().feed('not bytes')


def test_resync_inside_garbage_that_starts_like_a_frame():
    # A fake but well-formed header claiming a 16 x 16 frame swallows the real frame that follows;
    # the real frame must still be found because the search resumes right after the fake marker.
    fake = fake_header(16, 16) + b'\x99' * 30
    dec = FrameDecoder()
    frames = dec.feed(frame_bytes(0) + fake + frame_bytes(1) + frame_bytes(2))
    assert [f.seq for f in frames] == [0, 1, 2]
    assert dec.stats.crc_errors == 1
    assert dec.stats.bytes_discarded == len(fake)


def test_false_marker_with_a_broken_header_check_does_not_delay_the_next_frame():
    # Without the header check this would wait for 65 kB of a 128 x 128 frame.
    dec = FrameDecoder()
    assert [f.seq for f in dec.feed(fake_header(128, 128, valid_check=False) + frame_bytes(1))] \
        == [1]
    assert dec.stats.crc_errors == 1 and dec.buffered_bytes == 0


def test_garbage_costs_nothing_when_it_falls_between_frames():
    rng = np.random.default_rng(5)
    parts = []
    for seq in range(50):
        parts.append(frame_bytes(seq, (4, 4)))
        junk = rng.integers(0, 256, rng.integers(0, 200), dtype=np.uint8).tobytes()
        parts.append(junk + SYNC * int(rng.integers(0, 3)))
    dec = FrameDecoder(max_rows=16, max_cols=16)
    stream = b''.join(parts)
    frames = []
    for i in range(0, len(stream), 97):
        frames += dec.feed(stream[i:i + 97])
    assert [f.seq for f in frames] == list(range(50))
    assert dec.stats.frames_missed == 0


def test_damaged_frame_costs_only_itself():
    raw = [frame_bytes(s) for s in range(5)]
    damaged = raw[2][:300] + b'\x00\xff\xa5' + raw[2][303:]
    dec = FrameDecoder(expected_shape=(16, 16))
    frames = dec.feed(b''.join(raw[:2]) + damaged + b''.join(raw[3:]))
    assert [f.seq for f in frames] == [0, 1, 3, 4]
    assert dec.stats.seq_gaps == 1 and dec.stats.frames_missed == 1


def test_sequence_gaps_wrap_and_device_restart():
    dec = FrameDecoder()
    seqs = [2 ** 32 - 2, 2 ** 32 - 1, 0, 3, 4, 9, 1, 2]
    # A 1 kHz scan: the device clock moves on with the frames, lost ones included.
    times = [0, 1000, 2000, 5000, 6000, 11000, 1000, 2000]
    for s, t in zip(seqs, times):
        dec.feed(frame_bytes(s, (2, 2), time_us=t))
    # Gaps: 0 -> 3 (2 missed), 4 -> 9 (4 missed); the wrap is continuous; 9 -> 1 is a restart.
    assert (dec.stats.seq_gaps, dec.stats.frames_missed) == (2, 6)
    assert dec.stats.seq_implausible == 0


def test_a_corrupt_but_valid_sequence_number_is_not_billions_of_dropped_frames():
    dec = FrameDecoder()
    # Frame 3 arrives with seq 2**31 - 10 and passing checks; the device clock moved 1 ms.
    for s, t in [(1, 1000), (2, 2000), (2 ** 31 - 10, 3000), (4, 4000), (5, 5000)]:
        dec.feed(frame_bytes(s, (2, 2), time_us=t))
    assert dec.stats.frames == 5
    assert (dec.stats.seq_gaps, dec.stats.frames_missed, dec.stats.seq_implausible) == (0, 0, 1)
    # A real gap stays one: 5 -> 9 with the clock 4 ms on.
    dec.feed(frame_bytes(9, (2, 2), time_us=9000))
    assert (dec.stats.seq_gaps, dec.stats.frames_missed) == (1, 3)


def test_reset_forgets_partial_frame_and_last_seq_but_keeps_stats():
    dec = FrameDecoder()
    dec.feed(frame_bytes(0, (2, 2)))
    dec.feed(frame_bytes(1, (2, 2))[:10])
    dec.reset()
    assert dec.buffered_bytes == 0
    frames = dec.feed(frame_bytes(100, (2, 2)))
    assert [f.seq for f in frames] == [100]
    assert dec.stats.frames == 2
    assert dec.stats.seq_gaps == 0
    assert dec.stats.bytes_discarded == 10


def test_buffer_stays_bounded_under_endless_headers_and_floods():
    dec = FrameDecoder()
    bound = dec.max_buffer_bytes
    assert bound == 2 * frame_size(128, 128)
    # A valid-looking header of a 128 x 128 frame, then a flood without another marker.
    dec.feed(fake_header(128, 128))
    peak = 0
    for _ in range(40):
        dec.feed(b'\x00' * 10_000)
        peak = max(peak, dec.buffered_bytes)
    assert peak <= bound
    assert dec.stats.crc_errors == 1
    # One huge call is sliced internally as well.
    dec.feed(b'\x01' * (5 * bound))
    assert dec.buffered_bytes <= bound
    (frame,) = dec.feed(frame_bytes(9))
    assert frame.seq == 9


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=3000), st.integers(1, 400))
def test_never_raises_on_random_bytes_and_finds_the_trailing_frame(noise, chunk):
    dec = FrameDecoder(max_rows=16, max_cols=16)
    stream = noise + frame_bytes(77, (4, 4)) + frame_bytes(78, (4, 4))
    frames = []
    for i in range(0, len(stream), chunk):
        frames += dec.feed(stream[i:i + chunk])
        assert dec.buffered_bytes <= dec.max_buffer_bytes
    assert [f.seq for f in frames][-2:] == [77, 78]


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_any_single_byte_corruption_is_never_accepted(data):
    raw = frame_bytes(5, (3, 3))
    index = data.draw(st.integers(0, len(raw) - 1))
    value = data.draw(st.integers(0, 255).filter(lambda v: v != raw[index]))
    bad = raw[:index] + bytes([value]) + raw[index + 1:]
    dec = FrameDecoder()
    frames = dec.feed(bad + frame_bytes(6, (3, 3)))
    assert [f.seq for f in frames] == [6]
