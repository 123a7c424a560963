"""
Fuzzing of the frame decoder: mutated valid streams, random bytes and a regression corpus.

Whatever arrives, the decoder must not raise, must accept only frames that were encoded, must
find every frame that the damage did not touch (resync within the next intact frame) and must
keep its buffer within max_buffer_bytes.  The corpus in corpus/ beside this file holds small
streams, each named for what it exercises, with the expected outcome in corpus/expected.yaml;
rebuild it with ``python test/core/protocol/test_wire_fuzz.py`` after a deliberate protocol
change.
"""

import binascii
import pathlib
import struct
import sys
import zlib

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from skin_driver.core.protocol.wire import (BoardInfo, encode_frame, encode_info, frame_size,
                                            FrameDecoder, SYNC)
import yaml

CORPUS = pathlib.Path(__file__).resolve().parent / 'corpus'
# The board the corpus's info frames name.
INFO = BoardInfo('corpus', '0039001e3438510b34313939', '0.1.0', 2, 3, 0.005, 1000)
MAX_SHAPE = 16
# Bytes that settle a candidate still waiting for its payload at the end of a stream.
SETTLE = b'\x00' * frame_size(MAX_SHAPE, MAX_SHAPE)
MUTATIONS = ('bit flip', 'drop', 'duplicate', 'insert', 'truncate', 'absurd size',
             'wrong version', 'junk between')


def reference_frame(seq, shape=(2, 3), version=1, flagged=False):
    """
    Return the encoded frame with this seq: its counts are a function of seq alone.

    flagged (version 2): some rows invalid and fault bits set, also a function of seq alone.
    """
    rng = np.random.default_rng(seq)
    top = rng.integers(0, 4096, shape, dtype=np.uint16)
    bottom = rng.integers(0, 4096, shape, dtype=np.uint16)
    if not flagged:
        return encode_frame(seq, seq * 1000 + 7, top, bottom, version=version)
    row_valid = rng.random((2, shape[0])) < 0.7
    row_valid[0, 0] = False
    return encode_frame(seq, seq * 1000 + 7, top, bottom, version=version,
                        faults=int(rng.integers(1, 0x10000)), row_valid=row_valid)


def reseal_header(raw):
    """Recompute the header check of an edited header so that only the edit is wrong."""
    raw = bytearray(raw)
    raw[18:20] = struct.pack('<H', binascii.crc_hqx(bytes(raw[:18]), 0xFFFF))
    return bytes(raw)


def reseal(raw):
    """Recompute both checks of an edited frame."""
    raw = bytearray(reseal_header(raw))
    raw[-4:] = struct.pack('<I', zlib.crc32(bytes(raw[:-4])))
    return bytes(raw)


def reseal_info(raw):
    """Recompute the CRC of an edited board information frame."""
    return raw[:-2] + struct.pack('<H', binascii.crc_hqx(raw[:-2], 0xFFFF))


def mutate(raw, kind, rng):
    """Return raw with one mutation of the given kind at a place drawn from rng."""
    data = bytearray(raw)
    at = int(rng.integers(len(data)))
    if kind == 'bit flip':
        data[at] ^= 1 << int(rng.integers(8))
    elif kind == 'drop':
        del data[at]
    elif kind == 'duplicate':
        data.insert(at, data[at])
    elif kind == 'insert':
        data[at:at] = rng.integers(0, 256, int(rng.integers(1, 40)), dtype=np.uint8).tobytes()
    elif kind == 'truncate':
        del data[max(at, 1):]
    elif kind == 'absurd size':
        data[16], data[17] = int(rng.integers(0, 256)), int(rng.integers(0, 256))
        data = bytearray(reseal_header(data)) if rng.random() < 0.7 else data
    elif kind == 'wrong version':
        data[2 + int(rng.integers(2))] = int(rng.integers(2, 256))
        data = bytearray(reseal(data)) if rng.random() < 0.7 else data
    return bytes(data)


class Fuzzer:
    """Build a stream of frames, damage some, feed it in chunks and check the decoder."""

    def __init__(self, rng, frames=12, expected_shape=None):
        self.rng = rng
        shapes = [expected_shape] if expected_shape else [(1, 1), (2, 3), (4, 4), (16, 16)]
        self.originals = {}
        self.untouched = set()
        parts = []
        for seq in range(frames):
            shape = shapes[int(rng.integers(len(shapes)))]
            # Both versions mixed on one stream, as after a board's firmware update.
            version = int(rng.integers(1, 3))
            raw = reference_frame(seq, shape, version, version == 2 and rng.random() < 0.3)
            self.originals[seq] = FrameDecoder().feed(raw)[0]
            wire = raw
            if rng.random() < 0.5:
                kind = MUTATIONS[int(rng.integers(len(MUTATIONS)))]
                if kind == 'junk between':
                    junk = rng.integers(0, 256, int(rng.integers(1, 80)), dtype=np.uint8)
                    parts.append(junk.tobytes() + SYNC * int(rng.integers(0, 3)))
                else:
                    wire = mutate(raw, kind, rng)
            # Damage at the very end can leave the frame whole, followed by junk.
            if wire[:len(raw)] == raw:
                self.untouched.add(seq)
            parts.append(wire)
        self.stream = b''.join(parts)
        self.decoder = FrameDecoder(max_rows=MAX_SHAPE, max_cols=MAX_SHAPE,
                                    expected_shape=expected_shape)

    def run(self):
        """Feed the stream in random chunks and check every promise; return the frames."""
        decoded = []
        pos = 0
        while pos < len(self.stream):
            step = int(self.rng.integers(1, 600))
            decoded += self.decoder.feed(self.stream[pos:pos + step])
            pos += step
            assert self.decoder.buffered_bytes <= self.decoder.max_buffer_bytes
        decoded += self.decoder.feed(SETTLE)
        assert self.decoder.buffered_bytes <= self.decoder.max_buffer_bytes
        for frame in decoded:
            assert frame == self.originals[frame.seq], f'accepted a corrupt frame {frame.seq}'
        seqs = [f.seq for f in decoded]
        assert len(seqs) == len(set(seqs)), 'a frame was accepted twice'
        assert self.untouched <= set(seqs), 'an intact frame was lost'
        assert self.decoder.stats.frames == len(decoded)
        return decoded


def test_ten_thousand_mutated_streams():
    rng = np.random.default_rng(2024)
    accepted = 0
    for _ in range(10_000):
        accepted += len(Fuzzer(rng, frames=int(rng.integers(1, 8))).run())
    assert accepted > 10_000  # most frames survive: the test is not vacuous


def test_mutated_streams_with_an_expected_shape():
    rng = np.random.default_rng(7)
    for _ in range(2_000):
        Fuzzer(rng, frames=6, expected_shape=(4, 4)).run()


@settings(max_examples=400, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(1, 20))
def test_hypothesis_mutated_streams(seed, frames):
    Fuzzer(np.random.default_rng(seed), frames=frames).run()


FAKE_HEADER_255 = reseal_header(SYNC + bytes([1, 0]) + bytes(12) + bytes([255, 255, 0, 0]))
PIECES = st.one_of(st.binary(max_size=200),
                   st.integers(0, 50).map(lambda s: reference_frame(s, (2, 2))),
                   st.sampled_from([SYNC, SYNC[:1], SYNC * 8, FAKE_HEADER_255]))


@settings(max_examples=300, deadline=None)
@given(st.lists(PIECES, max_size=30), st.integers(1, 300))
def test_hypothesis_arbitrary_pieces_never_yield_a_foreign_frame(pieces, chunk):
    originals = {s: FrameDecoder().feed(reference_frame(s, (2, 2)))[0] for s in range(51)}
    stream = b''.join(pieces)
    decoder = FrameDecoder(max_rows=MAX_SHAPE, max_cols=MAX_SHAPE)
    for i in range(0, len(stream), chunk):
        for frame in decoder.feed(stream[i:i + chunk]):
            assert frame == originals[frame.seq]
        assert decoder.buffered_bytes <= decoder.max_buffer_bytes


def test_absurd_declared_sizes_never_hold_the_buffer():
    # Every rows/cols pair with a valid header check, followed by a real frame.
    decoder = FrameDecoder(max_rows=MAX_SHAPE, max_cols=MAX_SHAPE)
    head = SYNC + bytes([1, 0]) + bytes(12)
    found = 0
    for rows in range(256):
        for cols in range(0, 256, 15):
            fake = reseal_header(head + bytes([rows, cols, 0, 0]))
            frames = decoder.feed(fake + reference_frame(rows, (2, 2)) + SETTLE)
            assert decoder.buffered_bytes <= decoder.max_buffer_bytes
            found += sum(f.seq == rows for f in frames)
    assert found == 256 * 18


# ---- regression corpus ------------------------------------------------------------------------

def _corpus_cases():
    """Return {name: (stream, expected)}: the corpus as this protocol version writes it."""
    f = [reference_frame(s) for s in range(4)]

    def edit(raw, at, value):
        data = bytearray(raw)
        data[at] = value
        return bytes(data)

    head = SYNC + bytes([1, 0]) + bytes(12)
    info_text = INFO.text.encode('ascii')
    info = encode_info(INFO)
    cases = {
        'intact_three_frames': (f[0] + f[1] + f[2], [0, 1, 2], {}),
        'bit_flip_in_payload': (f[0] + edit(f[1], 25, f[1][25] ^ 4) + f[2], [0, 2],
                                {'crc_errors': 1}),
        'bit_flip_in_header_seq': (f[0] + edit(f[1], 4, f[1][4] ^ 1) + f[2], [0, 2],
                                   {'crc_errors': 1}),
        'bit_flip_in_frame_crc': (f[0] + edit(f[1], len(f[1]) - 1, f[1][-1] ^ 128) + f[2],
                                  [0, 2], {'crc_errors': 1}),
        'dropped_byte_mid_frame': (f[0] + f[1][:30] + f[1][31:] + f[2], [0, 2],
                                   {'crc_errors': 1}),
        'duplicated_byte_mid_frame': (f[0] + f[1][:30] + f[1][29:] + f[2], [0, 2],
                                      {'crc_errors': 1}),
        'inserted_bytes_mid_frame': (f[0] + f[1][:22] + b'\xa5\x5a\x01' + f[1][22:] + f[2],
                                     [0, 2], {'crc_errors': 1, 'version_errors': 1}),
        'truncated_frame': (f[0] + f[1][:-9] + f[2], [0, 2], {'crc_errors': 1}),
        'truncated_header': (f[0] + f[1][:11] + f[2], [0, 2], {'crc_errors': 1}),
        'absurd_size_255x255_valid_header_check': (
            f[0] + reseal_header(edit(edit(f[1], 16, 255), 17, 255)) + f[2], [0, 2],
            {'size_errors': 1}),
        'zero_rows_valid_header_check': (f[0] + reseal_header(edit(f[1], 16, 0)) + f[2],
                                         [0, 2], {'size_errors': 1}),
        'claims_16x16_swallows_next_frames': (
            f[0] + reseal_header(head + bytes([16, 16, 0, 0])) + f[1] + f[2] + SETTLE,
            [0, 1, 2], {'crc_errors': 1}),
        'wrong_version_3_valid_checks': (f[0] + reseal(edit(f[1], 2, 3)) + f[2], [0, 2],
                                         {'version_errors': 1}),
        'nonzero_flags_valid_checks': (f[0] + reseal(edit(f[1], 3, 0x80)) + f[2], [0, 2],
                                       {'version_errors': 1}),
        'count_above_4095_valid_checks': (f[0] + reseal(edit(f[1], 21, 0x10)) + f[2], [0, 2],
                                          {'crc_errors': 1}),
        # Each marker is followed by 0xA5 where the version belongs.
        'sync_marker_flood': (SYNC * 300 + f[3], [3], {'version_errors': 300}),
        'half_marker_flood': (b'\xa5' * 500 + f[3], [3], {}),
        'random_junk_between_frames': (
            f[0] + np.random.default_rng(3).integers(0, 256, 300, dtype=np.uint8).tobytes()
            + f[1], [0, 1], None),
        'sequence_gap_and_restart': (reference_frame(0) + reference_frame(5)
                                     + reference_frame(2), [0, 5, 2],
                                     {'seq_gaps': 1, 'frames_missed': 4}),
        'trailing_first_sync_byte': (f[0] + SYNC[:1], [0], {}),
        # Board information frames (docs/protocol.md): never returned, counted, the newest kept.
        'info_frame_intact': (info + f[0] + f[1], [0, 1], {'info_frames': 1}),
        'info_between_frames': (info + f[0] + info + f[1] + info + f[2], [0, 1, 2],
                                {'info_frames': 3}),
        'info_with_bad_crc': (f[0] + edit(info, len(info) - 1, info[-1] ^ 0x10) + f[1],
                              [0, 1], {'crc_errors': 1}),
        # Replayed in 7-byte feeds as every stream is: 3 bytes ahead put both ends of the info
        # frame (92 bytes) inside a feed, so each feed ends mid-frame.
        'info_split_across_feeds': (b'\x00' * 3 + info + f[0], [0], {'info_frames': 1}),
        'info_text_with_a_non_ascii_byte': (
            f[0] + encode_info(info_text.replace(b'board=corpus', b'board=corp\xfcs')) + f[1],
            [0, 1], {'info_errors': 1}),
        'info_wrong_version_valid_crc': (f[0] + reseal_info(edit(info, 2, 2)) + f[1], [0, 1],
                                         {'version_errors': 1}),
        # The board's word on its grid is reported, not enforced by the decoder.
        'info_grid_disagrees_with_frames': (encode_info(info_text.replace(b'2x3', b'16x16'))
                                            + f[0] + f[1], [0, 1], {'info_frames': 1}),
    }
    cases.update(_corpus_cases_v2(edit))
    for name, (stream, seqs, counters) in cases.items():
        if seqs == [0, 2]:
            # The damaged frame 1 shows as a sequence gap.
            counters.update(seq_gaps=1, frames_missed=1)
    out = {}
    for name, (stream, seqs, counters) in cases.items():
        expected = {'frames': seqs, 'counters': counters}
        board = FrameDecoder(max_rows=MAX_SHAPE, max_cols=MAX_SHAPE)
        board.feed(stream)
        if name.startswith('info_') and board.board_info is not None:
            expected['board_info'] = board.board_info.text
        out[name] = (stream, expected)
    return out


def fake_header_frame(seq):
    """
    Return a 4 x 4 version-2 frame whose payload holds a fake header.

    The packed counts begin with a whole version-2 header (valid header check) of a 16 x 16
    frame: packed counts can hold any bytes.
    """
    fake = reseal_header(SYNC + bytes([2, 0]) + bytes(12) + bytes([16, 16, 0, 0]))
    payload = fake + bytes(range(48 - len(fake)))
    counts = np.empty(32, dtype=np.uint16)
    for k in range(16):  # two counts in three bytes, little-endian
        word = int.from_bytes(payload[3 * k:3 * k + 3], 'little')
        counts[2 * k], counts[2 * k + 1] = word & 0xFFF, word >> 12
    return encode_frame(seq, seq * 1000 + 7, counts[:16].reshape(4, 4),
                        counts[16:].reshape(4, 4), version=2)


def _corpus_cases_v2(edit):
    """Return the version-2 cases: {name: (stream, sequence numbers accepted, counters)}."""
    f = [reference_frame(s) for s in range(4)]
    g = [reference_frame(s, version=2) for s in range(4)]
    flagged = reference_frame(1, version=2, flagged=True)
    pad_at = len(g[1]) - 5  # 2 x 3: 42 bytes of body, 2 of padding, the CRC
    fake = fake_header_frame(1)
    return {
        'v2_intact_three_frames': (g[0] + g[1] + g[2], [0, 1, 2], {}),
        'v1_and_v2_mixed': (f[0] + g[1] + f[2] + g[3], [0, 1, 2, 3], {}),
        'v2_bit_flip_in_payload': (g[0] + edit(g[1], 30, g[1][30] ^ 4) + g[2], [0, 2],
                                   {'crc_errors': 1}),
        'v2_bit_flip_in_row_map': (g[0] + edit(g[1], 22, g[1][22] ^ 1) + g[2], [0, 2],
                                   {'crc_errors': 1}),
        'v2_truncated_mid_payload': (g[0] + g[1][:26] + g[2], [0, 2], {'crc_errors': 1}),
        'v2_truncated_then_v1': (g[0] + g[1][:-3] + f[2], [0, 2], {'crc_errors': 1}),
        'v2_rows_invalid_and_faults': (g[0] + flagged + g[2], [0, 1, 2],
                                       {'rows_flagged': 1, 'fault_frames': 1}),
        'v2_unknown_flag_valid_checks': (g[0] + reseal(edit(g[1], 3, 0x80)) + g[2], [0, 2],
                                         {'version_errors': 1}),
        'v2_flags_disagree_with_body_valid_checks': (
            g[0] + reseal(edit(g[1], 3, 1)) + g[2], [0, 2], {'crc_errors': 1}),
        'v2_nonzero_padding_valid_checks': (g[0] + reseal(edit(g[1], pad_at, 1)) + g[2],
                                            [0, 2], {'crc_errors': 1}),
        # The frame's own header is damaged: the search runs into its payload, meets a whole
        # fake header there, waits for the 16 x 16 frame it announces, fails its CRC and
        # resumes after the fake marker: every intact frame behind it is still found.
        'v2_fake_header_in_a_damaged_payload': (
            g[0] + edit(fake, 5, fake[5] ^ 1) + g[2] + g[3] + SETTLE, [0, 2, 3],
            {'crc_errors': 2, 'seq_gaps': 1, 'frames_missed': 1}),
    }


def write_corpus():
    """(Re)write test/core/protocol/corpus/ from _corpus_cases()."""
    CORPUS.mkdir(exist_ok=True)
    expected = {}
    for name, (stream, outcome) in sorted(_corpus_cases().items()):
        (CORPUS / f'{name}.bin').write_bytes(stream)
        expected[name] = outcome
    header = ('# Expected outcome of replaying each <name>.bin through FrameDecoder(max_rows=16,\n'
              '# max_cols=16): the accepted sequence numbers in order, the decoder counters\n'
              '# that must hold exactly (null: not checked) and the text of the newest board\n'
              '# info (absent: none). Written by test_wire_fuzz.py.\n')
    (CORPUS / 'expected.yaml').write_text(header + yaml.safe_dump(expected, sort_keys=True))


def _corpus():
    path = CORPUS / 'expected.yaml'
    # A missing corpus leaves nothing to replay; the next test fails on it.
    return sorted(yaml.safe_load(path.read_text()).items()) if path.exists() else []


def test_corpus_files_and_expectations_match():
    names = {p.stem for p in CORPUS.glob('*.bin')}
    assert names == {name for name, _ in _corpus()}
    assert len(names) >= 15


@pytest.mark.parametrize('name, expected', _corpus(), ids=[n for n, _ in _corpus()])
@pytest.mark.parametrize('chunk', [1, 7, 10_000])
def test_corpus_replays_to_its_expected_outcome(name, expected, chunk):
    stream = (CORPUS / f'{name}.bin').read_bytes()
    decoder = FrameDecoder(max_rows=MAX_SHAPE, max_cols=MAX_SHAPE)
    frames = []
    for i in range(0, len(stream), chunk):
        frames += decoder.feed(stream[i:i + chunk])
        assert decoder.buffered_bytes <= decoder.max_buffer_bytes
    assert [f.seq for f in frames] == expected['frames']
    for frame in frames:
        flagged = frame.row_valid is not None
        assert frame == FrameDecoder().feed(reference_frame(frame.seq, (2, 3), frame.version,
                                                            flagged))[0]
    stats = decoder.stats
    counters = expected['counters']
    if counters is not None:
        for key in ('crc_errors', 'size_errors', 'version_errors', 'seq_gaps', 'frames_missed',
                    'info_frames', 'info_errors', 'rows_flagged', 'fault_frames'):
            assert getattr(stats, key) == counters.get(key, 0), key
    info = decoder.board_info
    assert (info.text if info else None) == expected.get('board_info')


if __name__ == '__main__':
    write_corpus()
    sys.exit(0)
