"""
The firmware core's frames are byte for byte wire.encode_frame's.

For every grid and seq, in both protocol versions.
"""

import struct
import subprocess

import numpy as np
import pytest
from skin_driver.core.protocol.wire import encode_frame, frame_size, MAX_SEQ

RECORD = struct.Struct('<BBIQ')


def _records(cases, rng):
    """Yield (rows, cols, seq, time, top, bottom) with random counts, extremes included."""
    for rows, cols, seq, time_us in cases:
        top = rng.integers(0, 4096, (rows, cols), dtype=np.uint16)
        bottom = rng.integers(0, 4096, (rows, cols), dtype=np.uint16)
        top.flat[0], bottom.flat[-1] = 4095, 0
        yield rows, cols, seq, time_us, top, bottom


VERSIONS = pytest.mark.parametrize('version', [1, 2])


def _dump(frame_dump, records, version=2) -> bytes:
    data = b''.join(RECORD.pack(r, c, s, t) + top.astype('<u2').tobytes()
                    + bottom.astype('<u2').tobytes() for r, c, s, t, top, bottom in records)
    done = subprocess.run([str(frame_dump), str(version)], input=data, capture_output=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr.decode()
    return done.stdout


def _compare(frame_dump, cases, seed, version):
    records = list(_records(cases, np.random.default_rng(seed)))
    out = _dump(frame_dump, records, version)
    assert len(out) == sum(frame_size(r, c, version) for r, c, *_ in records)
    at = 0
    for rows, cols, seq, time_us, top, bottom in records:
        size = frame_size(rows, cols, version)
        assert out[at:at + size] == encode_frame(seq, time_us, top, bottom, version), (
            f'{rows}x{cols} seq {seq} time {time_us}')
        at += size


@VERSIONS
def test_named_grids(frame_dump, version):
    grids = [(1, 1), (1, 128), (128, 1), (16, 16), (128, 128), (2, 3), (127, 128)]
    _compare(frame_dump, [(r, c, 1000 + i, 123_456_789 + i) for i, (r, c) in enumerate(grids)],
             seed=1, version=version)


@VERSIONS
def test_random_grids(frame_dump, version):
    rng = np.random.default_rng(2)
    cases = [(int(rng.integers(1, 129)), int(rng.integers(1, 129)),
              int(rng.integers(0, MAX_SEQ + 1)), int(rng.integers(0, 2 ** 63)))
             for _ in range(40)]
    _compare(frame_dump, cases, seed=3, version=version)


@VERSIONS
@pytest.mark.parametrize('grid', [(16, 16), (1, 1), (5, 128), (9, 7)])
def test_seq_wrap_and_time_extremes(frame_dump, grid, version):
    rows, cols = grid
    cases = [(rows, cols, MAX_SEQ - 1, 2 ** 32 - 2), (rows, cols, MAX_SEQ, 2 ** 32 - 1),
             (rows, cols, 0, 2 ** 32), (rows, cols, 1, 2 ** 32 + 1),
             (rows, cols, 2, 2 ** 64 - 1), (rows, cols, 3, 0)]
    _compare(frame_dump, cases, seed=4, version=version)


def test_bad_record_is_refused(frame_dump):
    done = subprocess.run([str(frame_dump)], input=RECORD.pack(0, 3, 0, 0), capture_output=True,
                          timeout=10)
    assert done.returncode != 0
    assert done.stdout == b''
