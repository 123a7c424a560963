"""The simulated board's pty: whole frames queued, each with one fate the line can name."""

import os
import time

from skin_driver.core.sim.pty_line import PtyLine


def _read_exactly(fd: int, count: int) -> bytes:
    """Read count bytes from a blocking descriptor, however the pty hands them over."""
    data = b''
    while len(data) < count:
        data += os.read(fd, count - len(data))
    return data


def _read_all(port: str, count: int) -> bytes:
    """Read the count bytes written into the pty at port, however the pty hands them over."""
    fd = os.open(port, os.O_RDONLY | os.O_NOCTTY)
    try:
        return _read_exactly(fd, count)
    finally:
        os.close(fd)


def test_an_unplugged_line_takes_no_frame():
    line = PtyLine(None, max_pending=1024)
    assert not line.has_room()
    assert not line.queue(b'frame', 1, False, False)
    assert line.frames_sent == line.frames_dropped == 0


def test_sent_frames_are_counted_by_fate_and_arrive_after_their_junk():
    line = PtyLine(None, max_pending=1024)
    port = line.plug()
    try:
        assert line.queue(b'AAAA', 7, damaged=False, wrong_shape=False, junk=b'xy')
        assert line.queue(b'BBBB', 8, damaged=True, wrong_shape=False)
        assert line.queue(b'CCCC', 9, damaged=False, wrong_shape=True)
        line.flush()
        assert _read_all(port, 14) == b'xyAAAABBBBCCCC'
        assert (line.frames_sent, line.frames_damaged, line.frames_wrong_shape) == (3, 1, 1)
        assert line.first_tag_since_plug == 7
    finally:
        line.unplug()
    assert line.port is None and line.frames_unread == 0


def test_a_pull_counts_held_frames_as_dropped_and_sent_unread_ones_as_unread():
    line = PtyLine(None, max_pending=1024)
    line.plug()
    line.queue(b'sent', 1, False, False)
    line.flush()  # written into the pty, never read by anyone
    line.hold(60.0)
    line.queue(b'held', 2, False, False)
    line.flush()  # the burst holds it back
    assert line.has_pending()
    line.unplug()
    assert (line.frames_sent, line.frames_unread, line.frames_dropped) == (1, 1, 1)
    assert not line.has_pending()


def test_every_sent_frame_nobody_read_is_unread_at_the_pull_however_many_wait():
    # More than the 4 KB the pty's own input count (FIONREAD) stops at: the count was short.
    line = PtyLine(None, max_pending=65536)
    line.plug()
    for tag in range(8):
        line.queue(bytes([tag]) * 1000, tag, False, False)
    # The pty takes them as the kernel moves earlier bytes on (about 15 KB fit unread).
    deadline = time.monotonic() + 10.0
    while line.has_pending():
        assert time.monotonic() < deadline, f'the pty took only {line.frames_sent} frames'
        line.flush()
        time.sleep(0.001)
    assert line.frames_sent == 8
    line.unplug()
    assert (line.frames_unread, line.frames_dropped) == (8, 0)


def test_frames_the_reader_took_are_not_unread_at_the_pull():
    line = PtyLine(None, max_pending=65536)
    port = line.plug()
    fd = os.open(port, os.O_RDONLY | os.O_NOCTTY)
    try:
        line.queue(b'A' * 100, 1, False, False)
        line.flush()
        assert _read_exactly(fd, 100) == b'A' * 100
        line.queue(b'B' * 100, 2, False, False)
        line.flush()
        assert _read_exactly(fd, 60) == b'B' * 60  # the pull comes in the middle of it
        line.unplug()
    finally:
        os.close(fd)
    assert (line.frames_sent, line.frames_unread) == (2, 1)
