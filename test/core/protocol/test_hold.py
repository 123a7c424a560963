"""Rows a version-2 board did not sample: held at their last valid counts, never used as sent."""

import numpy as np
from skin_driver.core.protocol.hold import RowHold
from skin_driver.core.protocol.wire import encode_frame, FrameDecoder

ROWS, COLS = 4, 3


def frame(seq, value, invalid=()):
    """Return the decoded frame whose counts are all ``value``, the (layer, row)s invalid."""
    row_valid = np.ones((2, ROWS), bool)
    for layer, row in invalid:
        row_valid[layer, row] = False
    counts = np.full((ROWS, COLS), value)
    raw = encode_frame(seq, 1000 * seq, counts, counts + 1, 2, row_valid=row_valid)
    return FrameDecoder().feed(raw)[0]


def test_an_invalid_row_carries_the_last_counts_sampled_for_it():
    hold = RowHold()
    out = hold.apply([frame(0, 100), frame(1, 200, [(0, 2)]), frame(2, 300, [(0, 2), (1, 0)])])
    assert [f.seq for f in out] == [0, 1, 2]
    assert out[1].top[2].tolist() == [100] * COLS and out[1].top[1].tolist() == [200] * COLS
    assert out[1].bottom.tolist() == [[201] * COLS] * ROWS
    # Held twice: still the counts of frame 0; the other layer's row 0 holds frame 1's.
    assert out[2].top[2].tolist() == [100] * COLS
    assert out[2].bottom[0].tolist() == [201] * COLS and out[2].bottom[1].tolist() == [301] * 3
    # The frame still says which rows were sampled; the held maps are read-only.
    assert not out[2].row_valid[0, 2] and not out[2].top.flags.writeable
    assert (hold.rows_held, hold.frames_flagged) == (3, 0)


def test_a_frame_whose_invalid_row_was_never_sampled_is_dropped_and_counted():
    hold = RowHold()
    out = hold.apply([frame(0, 100, [(1, 3)]), frame(1, 200, [(1, 3)]), frame(2, 300),
                      frame(3, 400, [(1, 3)])])
    assert [f.seq for f in out] == [2, 3]
    assert out[1].bottom[3].tolist() == [301] * COLS
    assert (hold.rows_held, hold.frames_flagged) == (1, 2)


def test_valid_rows_of_a_dropped_frame_are_held_for_later():
    hold = RowHold()
    out = hold.apply([frame(0, 100, [(0, 0)]), frame(1, 200, [(0, 1)])])
    # Frame 0 had nothing for top row 0; frame 1 has it, and top row 1 comes from frame 0.
    assert [f.seq for f in out] == [1]
    assert out[0].top[1].tolist() == [100] * COLS and out[0].top[0].tolist() == [200] * COLS


def test_frames_with_every_row_sampled_pass_unchanged():
    hold = RowHold()
    frames = [frame(0, 100), frame(1, 200)]
    assert all(a is b for a, b in zip(hold.apply(frames), frames))
    assert (hold.rows_held, hold.frames_flagged) == (0, 0)


def test_reset_forgets_the_held_counts_but_not_the_counters():
    hold = RowHold()
    hold.apply([frame(0, 100), frame(1, 200, [(0, 0)])])
    hold.reset()
    assert hold.apply([frame(2, 300, [(0, 0)])]) == []
    assert (hold.rows_held, hold.frames_flagged) == (1, 1)
