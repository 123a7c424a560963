"""What the link says when no usable frame arrives: silence, or frames of another grid size."""

import os
import pty
import threading
import time
import tty

import numpy as np
import pytest
import serial
from skin_driver.core.protocol.link import reader, SerialLink, STALLED
from skin_driver.core.protocol.wire import BoardInfo, encode_frame, encode_info, FrameDecoder

# Generous: only bounds a hung test on a loaded machine.
WAIT_S = 10.0


class FakePort:
    """A board that sends one frame of the given shape per read, or nothing when shape is None."""

    def __init__(self, shape):
        self._shape = shape
        self._seq = 0
        self.in_waiting = 0

    def read(self, size):
        time.sleep(0.005)
        if self._shape is None:
            return b''
        self._seq += 1
        counts = np.zeros(self._shape, np.uint16)
        return encode_frame(self._seq, self._seq * 5000, counts, counts)

    def close(self):
        pass


def _stall_detail(shape):
    stalled = threading.Event()
    details = []

    def on_state(state, detail):
        if state == STALLED:
            details.append(detail)
            stalled.set()
    link = SerialLink('fake', 921600, FrameDecoder(expected_shape=(16, 16)),
                      lambda frames, now: None, on_state, stall_timeout_s=0.1,
                      open_port=lambda: FakePort(shape))
    link.start()
    try:
        assert stalled.wait(WAIT_S), 'the link never reported a stall'
    finally:
        link.stop()
    return details[0]


def test_a_silent_board_is_stalled_with_no_frame():
    assert _stall_detail(None).startswith('no frame from fake for')


def test_a_board_sending_only_another_grid_size_is_not_called_silent():
    detail = _stall_detail((8, 12))
    assert 'no frame' not in detail
    assert detail.startswith('only frames of the wrong grid size 8x12 from fake for')


def test_a_device_gives_every_waiting_byte_in_one_read_and_a_hangup_is_an_error():
    master, slave = pty.openpty()
    tty.setraw(slave)
    port = serial.Serial(os.ttyname(slave), timeout=0.05)
    try:
        read = reader(port, 0.05)
        counts = np.ones((16, 16), np.uint16)
        burst = b''.join(encode_frame(i, i * 1000, counts, counts) for i in range(3))
        os.write(master, burst)
        # The pty passes the bytes on asynchronously: wait until all of them are waiting.
        deadline = time.monotonic() + WAIT_S
        while port.in_waiting < len(burst):
            assert time.monotonic() < deadline, 'the pty never passed the burst on'
            time.sleep(0.005)
        assert read() == burst
        assert read() == b''  # nothing within the timeout
        os.close(master)
        with pytest.raises((OSError, serial.SerialException)):
            read()
    finally:
        port.close()
        os.close(slave)


def test_a_pyserial_url_without_a_descriptor_keeps_pyserials_read():
    port = serial.serial_for_url('loop://', timeout=0.05)
    try:
        port.write(b'\xa5\x5a\x01')
        read = reader(port, 0.05)
        assert read() + read() == b'\xa5\x5a\x01'
    finally:
        port.close()


class AnnouncingPort(FakePort):
    """A board that sends its identity ahead of every frame, another one from frame 6 on."""

    def __init__(self, infos):
        super().__init__((16, 16))
        self._infos = infos

    def read(self, size):
        info = self._infos[0 if self._seq < 5 else 1]
        return encode_info(info) + super().read(size)


def test_the_link_hands_over_each_new_identity_once_before_its_frames():
    first = BoardInfo('nucleo-f446re', '0039001e3438510b34313939', '0.1.0', 16, 16, 0.005, 1000)
    second = BoardInfo('qemu', '0' * 24, '0.1.0', 16, 16, 0.005, 1000)
    events = []
    done = threading.Event()

    def on_frames(frames, now):
        events.append(('frames', frames[0].seq))
        if frames[0].seq >= 12:
            done.set()
    link = SerialLink('fake', 921600, FrameDecoder(expected_shape=(16, 16)), on_frames,
                      open_port=lambda: AnnouncingPort([first, second]),
                      on_board_info=lambda info: events.append(('info', info)))
    link.start()
    try:
        assert done.wait(WAIT_S), 'the link never delivered 12 frames'
    finally:
        link.stop()
    infos = [(i, e[1]) for i, e in enumerate(events) if e[0] == 'info']
    assert [info for _, info in infos] == [first, second]
    assert infos[0][0] == 0  # before the first frame
    assert events[infos[1][0] + 1] == ('frames', 6)  # before the first frame it came with


def test_a_port_that_is_a_regular_file_is_refused_naming_the_file(tmp_path):
    """Issue #47: it gave "Could not configure port: (25, 'Inappropriate ioctl for device')"."""
    port = tmp_path / 'skin0'
    port.write_bytes(b'not a device')
    details = []
    refused = threading.Event()

    def on_state(state, detail):
        details.append(detail)
        refused.set()
    link = SerialLink(str(port), 921600, FrameDecoder(expected_shape=(16, 16)),
                      lambda frames, now: None, on_state)
    link.start()
    try:
        assert refused.wait(WAIT_S), 'the link never said why it cannot open the port'
    finally:
        link.stop()
    assert details[0] == (f'cannot open {port}: {port} is a regular file, not a serial port or '
                          "pty; name the board's device (e.g. /dev/ttyACM0) or the link the "
                          'simulated skin makes')


class ScriptedPort:
    """A port that gives one scripted read at a time, then nothing."""

    def __init__(self, reads):
        self._reads = list(reads)
        self.in_waiting = 0

    def read(self, size):
        time.sleep(0.001)
        return self._reads.pop(0) if self._reads else b''

    def close(self):
        pass


def test_the_link_hands_over_invalid_rows_held_and_drops_what_it_cannot_hold():
    def frame(seq, value, bad_row=None):
        valid = np.ones((2, 4), bool)
        if bad_row is not None:
            valid[0, bad_row] = False
        counts = np.full((4, 3), value)
        return encode_frame(seq, 1000 * seq, counts, counts, 2, faults=0, row_valid=valid)

    # Frame 1 has a bad row before any was sampled; frame 3's bad row is held from frame 2.
    reads = [frame(1, 10, bad_row=0), frame(2, 20) + frame(3, 30, bad_row=1)]
    got, done = [], threading.Event()

    def on_frames(frames, now):
        got.extend(frames)
        if len(got) >= 2:
            done.set()
    link = SerialLink('fake', 921600, FrameDecoder(expected_shape=(4, 3)), on_frames,
                      open_port=lambda: ScriptedPort(reads))
    link.start()
    try:
        assert done.wait(WAIT_S)
    finally:
        link.stop()
    assert [f.seq for f in got] == [2, 3]
    assert got[1].top[1].tolist() == [20] * 3 and got[1].top[0].tolist() == [30] * 3
    assert (link.hold.rows_held, link.hold.frames_flagged) == (1, 1)
