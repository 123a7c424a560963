"""The simulated board's pty: whole frames queued, each with one fate the line can name."""

import os

from skin_driver.core.sim.pty_line import PtyLine


def _read_all(port: str) -> bytes:
    fd = os.open(port, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    try:
        return os.read(fd, 65536)
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
        assert _read_all(port) == b'xyAAAABBBBCCCC'
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
