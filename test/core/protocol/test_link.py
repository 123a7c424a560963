"""What the link says when no usable frame arrives: silence, or frames of another grid size."""

import threading
import time

import numpy as np
from skin_driver.core.protocol.link import SerialLink, STALLED
from skin_driver.core.protocol.wire import encode_frame, FrameDecoder

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
