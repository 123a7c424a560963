"""A test's view of a simulated board's port: pyserial and the frame decoder, reopening on loss."""

import threading
import time

import serial
from skin_driver.core.protocol.wire import FrameDecoder

# Generous deadlines only bound a hung test; no assertion depends on how fast anything runs.
DEADLINE_S = 10.0


class TapDecoder(FrameDecoder):
    """The driver's decoder, keeping a copy of every byte it is fed."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.raw = bytearray()

    def feed(self, data):
        self.raw += data
        return super().feed(data)


class Collector:
    """A link's on_frames callback keeping the frames; enough is set once count arrived."""

    def __init__(self, count):
        self.count = count
        self.frames = []
        self.enough = threading.Event()

    def __call__(self, frames, _now):
        self.frames.extend(frames)
        if len(self.frames) >= self.count:
            self.enough.set()


class Reader:
    """Read a port with pyserial, decode frames and reopen the port after it disappears."""

    def __init__(self, port):
        self.port = port
        self.decoder = FrameDecoder(expected_shape=(16, 16))
        self.frames = []
        self.disconnects = 0
        self.serial = serial.Serial(port, timeout=0.02)

    def read_until(self, done):
        end = time.monotonic() + DEADLINE_S
        while not done():
            assert time.monotonic() < end, 'timed out waiting for frames'
            if self.serial is None:
                self._reopen()
                continue
            try:
                data = self.serial.read(4096)
            except serial.SerialException:
                self.serial.close()
                self.serial = None
                self.disconnects += 1
                self.decoder.reset()
                continue
            self.frames += self.decoder.feed(data)

    def read_frames(self, count):
        target = len(self.frames) + count
        self.read_until(lambda: len(self.frames) >= target)

    def _reopen(self):
        try:
            self.serial = serial.Serial(self.port, timeout=0.02)
        except (serial.SerialException, OSError):
            time.sleep(0.01)

    def close(self):
        if self.serial is not None:
            self.serial.close()
