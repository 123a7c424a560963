"""Tests of the board information frame: its layout, parsing, and the decoder around it."""

import binascii
import struct

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from skin_driver.core.protocol.wire import (BoardInfo, DecoderStats, encode_frame, encode_info,
                                            FrameDecoder, INFO_MAX_SIZE, INFO_SYNC, SYNC)

TEXT = ('board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=16x16;pitch_um=5000;'
        'rate_hz=1000')
NUCLEO = BoardInfo('nucleo-f446re', '0039001e3438510b34313939', '0.1.0', 16, 16, 0.005, 1000)


def frame(seq, shape=(16, 16)):
    rng = np.random.default_rng(seq)
    top = rng.integers(0, 4096, shape, dtype=np.uint16)
    bottom = rng.integers(0, 4096, shape, dtype=np.uint16)
    return encode_frame(seq, 1000 * seq, top, bottom)


def reseal(raw):
    """Recompute the CRC of an edited info frame so that only the edit is wrong."""
    raw = bytearray(raw)
    raw[-2:] = struct.pack('<H', binascii.crc_hqx(bytes(raw[:-2]), 0xFFFF))
    return bytes(raw)


def decode(stream, chunk=None, **kwargs):
    dec = FrameDecoder(**kwargs)
    chunk = chunk or max(1, len(stream))
    frames = []
    for i in range(0, len(stream), chunk):
        frames += dec.feed(stream[i:i + chunk])
        assert dec.buffered_bytes <= dec.max_buffer_bytes
    return dec, frames


def test_layout_of_the_example_info_frame():
    raw = encode_info(NUCLEO)
    assert NUCLEO.text == TEXT
    assert raw[:2] == b'\xa5\x69' == INFO_SYNC
    assert raw[2] == 1 and raw[3] == len(TEXT)
    assert raw[4:-2] == TEXT.encode('ascii')
    assert struct.unpack('<H', raw[-2:])[0] == binascii.crc_hqx(raw[:-2], 0xFFFF)
    assert encode_info(TEXT) == raw


def test_parse_reads_every_field_and_keeps_unknown_keys():
    info = BoardInfo.parse(TEXT + ';adc=3x12bit;note=a=b')
    assert (info.board, info.uid, info.fw, info.rows, info.cols, info.rate_hz) == (
        'nucleo-f446re', '0039001e3438510b34313939', '0.1.0', 16, 16, 1000)
    assert info.pitch_m == pytest.approx(0.005) and info.pitch_um == 5000
    assert info.extra == (('adc', '3x12bit'), ('note', 'a=b'))
    assert BoardInfo.parse(info.text) == info
    # Keys in another order mean the same board.
    assert BoardInfo.parse(';'.join(reversed(TEXT.split(';')))) == NUCLEO


@pytest.mark.parametrize('text, problem', [
    (TEXT.replace('uid=0039001e3438510b34313939', 'uid=0039001E3438510B34313939'), 'uid'),
    (TEXT.replace('uid=0039001e3438510b34313939', 'uid=0039'), 'uid'),
    (TEXT.replace('fw=0.1.0', 'fw=0.1'), 'fw'),
    (TEXT.replace('grid=16x16', 'grid=16*16'), 'grid'),
    (TEXT.replace('grid=16x16', 'grid=0x16'), 'grid'),
    (TEXT.replace('grid=16x16', 'grid=256x16'), 'rows'),
    (TEXT.replace('pitch_um=5000', 'pitch_um=-5'), 'pitch_um'),
    (TEXT.replace('rate_hz=1000', 'rate_hz=1e3'), 'rate_hz'),
    (TEXT.replace('board=nucleo-f446re', 'board='), 'board'),
    (TEXT.replace(';rate_hz=1000', ''), 'lacks rate_hz'),
    (TEXT + ';fw=0.2.0', 'repeats'),
    (TEXT + ';', 'not key=value'),
    (TEXT + ';junk', 'not key=value'),
    (TEXT.encode('ascii').replace(b'nucleo', b'nucl\xe9o'), 'printable'),
    (TEXT.encode('ascii').replace(b'nucleo', b'nucl\x00o'), 'printable'),
    (TEXT + ';x=' + 'y' * 200, 'at most 200'),
])
def test_malformed_text_is_refused_with_the_field_named(text, problem):
    with pytest.raises(ValueError, match=problem):
        BoardInfo.parse(text)


def test_encode_info_refuses_what_no_frame_can_carry():
    with pytest.raises(ValueError, match='1..200'):
        encode_info('')
    with pytest.raises(ValueError, match='1..200'):
        encode_info('x' * 201)
    with pytest.raises(ValueError, match='uid'):
        BoardInfo('sim', 'nothex', '0.1.0', 16, 16, 0.005, 100)
    with pytest.raises(ValueError, match='at most 200'):
        BoardInfo('b' * 180, '0' * 24, '0.1.0', 16, 16, 0.005, 100)
    with pytest.raises(ValueError, match='extra'):
        BoardInfo('sim', '0' * 24, '0.1.0', 16, 16, 0.005, 100, (('uid', 'again'),))


def test_decoder_exposes_the_info_and_returns_the_frames_alone():
    dec, frames = decode(encode_info(NUCLEO) + frame(0) + frame(1) + encode_info(NUCLEO)
                         + frame(2), expected_shape=(16, 16))
    assert [f.seq for f in frames] == [0, 1, 2]
    assert dec.board_info == NUCLEO
    assert dec.stats == DecoderStats(frames=3, info_frames=2)


def test_a_version_1_stream_has_no_board_info():
    dec, frames = decode(frame(0) + frame(1))
    assert len(frames) == 2 and dec.board_info is None
    assert dec.stats.info_frames == dec.stats.info_errors == 0


def test_the_newest_info_wins_and_survives_a_reset():
    other = BoardInfo('qemu', '0' * 24, '0.1.0', 16, 16, 0.005, 1000)
    dec, _ = decode(encode_info(NUCLEO) + frame(0) + encode_info(other) + frame(1))
    assert dec.board_info == other
    dec.reset()
    assert dec.board_info == other


def test_info_with_a_bad_crc_counts_as_a_crc_error_and_is_skipped():
    bad = bytearray(encode_info(NUCLEO))
    bad[-1] ^= 0x40
    dec, frames = decode(frame(0) + bytes(bad) + frame(1))
    assert [f.seq for f in frames] == [0, 1]
    assert dec.board_info is None
    assert (dec.stats.crc_errors, dec.stats.info_frames) == (1, 0)
    assert dec.stats.bytes_discarded == len(bad)


@pytest.mark.parametrize('edit, counter', [
    (lambda raw: raw[:2] + b'\x02' + raw[3:], 'version_errors'),
    (lambda raw: raw[:3] + b'\x00' + raw[4:], 'info_errors'),
    (lambda raw: raw[:3] + b'\xc9' + raw[4:], 'info_errors'),
    # The text edits keep the length byte right (encode_info sends any bytes it is given).
    (lambda raw: encode_info(TEXT.encode('ascii').replace(b'nucleo', b'nucl\xe9o')),
     'info_errors'),
    (lambda raw: encode_info(TEXT.replace(';fw=0.1.0', ';fw=one')), 'info_errors'),
])
def test_a_refused_info_frame_costs_its_marker_and_no_frame(edit, counter):
    bad = reseal(edit(encode_info(NUCLEO)))
    for chunk in (1, 5, None):
        dec, frames = decode(frame(0) + bad + frame(1) + frame(2), chunk=chunk)
        assert [f.seq for f in frames] == [0, 1, 2]
        assert dec.board_info is None
        assert getattr(dec.stats, counter) == 1
        assert dec.stats.info_frames == 0


def test_a_bad_info_frame_keeps_the_previous_info():
    bad = encode_info(TEXT.replace('fw=0.1.0', 'fw=0.1.x'))
    dec, _ = decode(encode_info(NUCLEO) + frame(0) + bad + frame(1))
    assert dec.board_info == NUCLEO
    assert (dec.stats.info_frames, dec.stats.info_errors) == (1, 1)


def test_info_split_across_every_feed_boundary():
    info = encode_info(NUCLEO)
    stream = frame(0) + info + frame(1)
    for cut in range(len(frame(0)), len(frame(0)) + len(info) + 1):
        dec = FrameDecoder(expected_shape=(16, 16))
        frames = dec.feed(stream[:cut]) + dec.feed(stream[cut:])
        assert [f.seq for f in frames] == [0, 1]
        assert dec.board_info == NUCLEO and dec.stats.info_frames == 1


def test_an_info_frame_longer_than_the_smallest_frames_stays_within_the_buffer_bound():
    long_info = encode_info(BoardInfo('b' * 100, '0' * 24, '1.2.3', 1, 1, 0.005, 10,
                                      (('pad', 'p' * 17),)))
    assert len(long_info) == INFO_MAX_SIZE
    dec, frames = decode(long_info + frame(0, (1, 1)) + long_info + frame(1, (1, 1)), chunk=3,
                         expected_shape=(1, 1))
    assert [f.seq for f in frames] == [0, 1] and dec.board_info.board == 'b' * 100


def test_a_truncated_info_frame_does_not_swallow_the_next_frame():
    info = encode_info(NUCLEO)
    dec, frames = decode(frame(0) + info[:40] + frame(1) + frame(2), chunk=64)
    assert [f.seq for f in frames] == [0, 1, 2]
    assert dec.stats.crc_errors == 1 and dec.board_info is None


def test_the_decoder_tells_the_grid_of_its_newest_frame():
    dec, _ = decode(encode_info(NUCLEO) + frame(0, (8, 8)))
    assert dec.last_shape == (8, 8)
    assert (dec.board_info.rows, dec.board_info.cols) == (16, 16)


INFOS = st.builds(
    BoardInfo, st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E,
                                     blacklist_characters=';'), min_size=1, max_size=40),
    st.text('0123456789abcdef', min_size=24, max_size=24),
    st.from_regex(r'(0|[1-9][0-9]{0,2})\.(0|[1-9][0-9]{0,2})\.(0|[1-9][0-9]{0,2})',
                  fullmatch=True),
    st.integers(1, 255), st.integers(1, 255), st.integers(1, 100_000).map(lambda u: u * 1e-6),
    st.integers(1, 100_000))


@settings(max_examples=300, deadline=None)
@given(INFOS, st.integers(1, 64))
def test_info_frames_change_nothing_a_version_1_host_decodes(info, chunk):
    # What a version-1 host sees: the marker of a frame occurs nowhere in an info frame but,
    # rarely, in its CRC, where its version byte is the next frame's 0xA5 (rejected).
    raw = encode_info(info)
    assert BoardInfo.parse(raw[4:-2]) == info
    assert raw[:-2].find(SYNC) < 0 and raw.find(SYNC) in (-1, len(raw) - 2)
    frames = [frame(s, (2, 3)) for s in range(3)]
    plain_dec, plain = decode(b''.join(frames), chunk=chunk)
    dec, mixed = decode(raw + frames[0] + raw + frames[1] + frames[2] + raw, chunk=chunk)
    assert mixed == plain
    assert dec.board_info == info and dec.stats.info_frames == 3
    assert dec.stats.crc_errors == dec.stats.info_errors == dec.stats.bytes_discarded == 0


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.binary(max_size=120),
                          st.sampled_from([INFO_SYNC, INFO_SYNC + b'\x01', INFO_SYNC * 4,
                                           INFO_SYNC + b'\x01\xc8', encode_info(NUCLEO)[:50]]),
                          st.just(encode_info(NUCLEO)), st.integers(0, 9).map(frame)),
                max_size=20),
       st.integers(1, 300))
def test_feed_never_raises_and_accepts_only_real_info(pieces, chunk):
    dec, frames = decode(b''.join(pieces), chunk=chunk)
    assert dec.board_info in (None, NUCLEO)
    for f in frames:
        assert FrameDecoder().feed(frame(f.seq)) == [f]
