"""A test's view of a simulated board's port: pyserial and the frame decoder, reopening on loss."""

import dataclasses
import threading
import time

import serial
from skin_driver.core.protocol.wire import DecoderStats, FrameDecoder

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
    """
    Read a port with pyserial, decode frames and reopen the port after it disappears.

    pyserial empties the input buffer on open, and the board may have written part of a frame
    by then: like the driver, the reader may join the stream mid-frame. What the decoder counted
    before the first whole frame (``lead_in``) is the join's, not the stream's;
    :meth:`stats_since_joined` leaves it out.
    """

    def __init__(self, port):
        self.port = port
        self.decoder = FrameDecoder(expected_shape=(16, 16))
        self.frames = []
        self.disconnects = 0
        self.lead_in = None  # the decoder's counts just after the first whole frame
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
            self._feed(data)

    def _feed(self, data):
        if self.lead_in is not None:
            self.frames += self.decoder.feed(data)
            return
        # Byte by byte up to the first whole frame, so that its counts hold the lead-in only.
        for at in range(len(data)):
            self.frames += self.decoder.feed(data[at:at + 1])
            if self.frames:
                self.lead_in = dataclasses.replace(self.decoder.stats)
                self.frames += self.decoder.feed(data[at + 1:])
                return

    def stats_since_joined(self) -> DecoderStats:
        """Return the decoder's counts from the first whole frame on."""
        now, before = self.decoder.stats, self.lead_in or DecoderStats()
        return DecoderStats(**{f.name: getattr(now, f.name) - getattr(before, f.name)
                               for f in dataclasses.fields(DecoderStats)})

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


def read_from(board, count):
    """Start a simulated board, read count frames from its port, stop it; return the reader."""
    reader = Reader(board.start())
    try:
        reader.read_frames(count)
    finally:
        reader.close()
        board.stop()
    return reader
