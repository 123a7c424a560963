"""A new board's stream through the driver's own link and decoder, gathered by device time."""

from __future__ import annotations

from dataclasses import asdict
import threading
import time

from skin_driver.core.protocol.link import SerialLink
from skin_driver.core.protocol.wire import FrameDecoder

# Bounds a board that stops sending: the windows themselves end on device time, not wall time.
QUIET_S = 10.0


class BoardReader:
    """Read frames off a port; each read's last frame is kept with its host receive time."""

    def __init__(self, port: str, baud: int = 921600):
        """Prepare a reader of port; start() opens it."""
        self.port, self.baud = port, baud
        self.decoder = FrameDecoder()
        self.frames = []          # every frame since start, in order
        self.clock = []           # (device_time_us, host monotonic s) of each read's last frame
        self._changed = threading.Condition()
        self.link = None

    def start(self) -> None:
        """Open the port in the link's thread."""
        self.link = SerialLink(self.port, self.baud, self.decoder, self._on_frames,
                               stall_timeout_s=QUIET_S)
        self.link.start()

    def stop(self) -> None:
        """Close the port (the frames stay)."""
        if self.link is not None:
            self.link.stop()

    def _on_frames(self, frames, now: float) -> None:
        with self._changed:
            self.frames.extend(frames)
            self.clock.append((frames[-1].device_time_us, now))
            self._changed.notify_all()

    def window(self, seconds: float) -> list:
        """
        Return the frames of the next ``seconds`` of device time, from the next frame on.

        Raise RuntimeError when no frame comes for QUIET_S of wall time.
        """
        start = len(self.frames)
        with self._changed:
            while True:
                got = self.frames[start:]
                if got and (got[-1].device_time_us - got[0].device_time_us) >= seconds * 1e6:
                    return got
                count = len(self.frames)
                self._changed.wait(QUIET_S)
                if len(self.frames) == count:
                    raise RuntimeError(f'no frame from {self.port} in {QUIET_S:.0f} s '
                                       f'({self.link.state}: {self.link.stats.last_error or "-"})')

    def counters(self) -> dict:
        """Return the decoder's and the link's counters now."""
        return {**asdict(self.decoder.stats), 'bytes_read': self.link.stats.bytes_read,
                'host_s': time.monotonic()}


def link_quality(before: dict, after: dict, frames: list) -> dict:
    """Return the rate and the losses of the link between two counters() snapshots."""
    span = after['host_s'] - before['host_s']
    delta = {k: after[k] - before[k] for k in before if k != 'host_s'}
    device_s = (frames[-1].device_time_us - frames[0].device_time_us) / 1e6 if frames else 0.0
    return {'host_s': span, 'device_s': device_s,
            'frames_per_s': delta['frames'] / span if span > 0 else 0.0,
            'bytes_per_s': delta['bytes_read'] / span if span > 0 else 0.0,
            'frames_per_device_s': (len(frames) - 1) / device_s if device_s > 0 else 0.0,
            **{k: delta[k] for k in ('frames', 'seq_gaps', 'frames_missed', 'crc_errors',
                                     'size_errors', 'version_errors', 'bytes_discarded',
                                     'info_errors')}}
