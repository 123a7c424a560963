"""
The simulated board: streams protocol frames of a scene on a pseudo-terminal, like the real one.

Like a USB CDC board whose host stops reading, the simulator never blocks: frames that do not fit
into the pty and a small output queue are dropped whole, so the clock and the sequence numbers run
on and the reader sees a sequence gap.

Faults for reliability tests: unplug/replug, stall (the board stops for a while), burst (frames
held back and sent in one clump), line noise (damaged frames and junk between frames), sequence
gaps and frames of another grid size.  A looped board may replay (``replay``): it renders one pass
of the scene before it starts and sends those scans again with new sequence numbers and device
times, so that it costs next to nothing per scan (the benchmark's board shares the cores it
measures).  Every frame that leaves the board has exactly one fate the
board can name: intact, damaged by the line, of the wrong size, or still unread in the pty when
the cable was pulled (see the frames_* counters).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
import errno
import fcntl
import math
import os
import struct
import termios
import threading
import time
import tty

import numpy as np

from . import physics
from .line import damage, point_link, remove_link
from .scene import load_scene, Scene
from ..estimation.validate import check_int, check_number
from ..protocol.wire import encode_counts, encode_frame, frame_size, frame_with_counts, MAX_SEQ

# Below this period frames are written in batches: one wake-up per BATCH_S instead of per frame.
BATCH_S = 0.002
# Further behind than this (a stalled process) the clock skips frames instead of bursting them.
MAX_LAG_S = 0.5
# Sent frames remembered to tell, at an unplug, which of them the reader had not read yet.
SENT_HISTORY = 8192
UNPLUG_SETTLE_S = 0.01


@dataclass(frozen=True)
class FrameTruth:
    """What the simulator rendered into one frame."""

    seq: int
    device_time_us: int
    top: np.ndarray
    bottom: np.ndarray
    presses: tuple
    scene_time_s: float = 0.0
    press_indices: tuple = ()


@dataclass(frozen=True)
class _Scan:
    """One rendered scan: its scene time, presses, layers and counts as a frame carries them."""

    scene_time_s: float
    presses: tuple
    press_indices: tuple
    top: np.ndarray
    bottom: np.ndarray
    counts: tuple  # (rows, cols, bytes) of wire.encode_counts


def _as_scene(scene) -> Scene:
    return scene if isinstance(scene, Scene) else load_scene(scene)


def _frame_times(index: int, rate_hz: float) -> tuple:
    """Return (device time in us, seconds since start) of the frame with this index."""
    seconds = index / rate_hz
    return int(round(index * 1e6 / rate_hz)), seconds


class SimulatedSkin:
    """A virtual skin board on a pseudo-terminal, streaming frames rendered from a scene."""

    def __init__(self, scene, rate_hz: float = 100.0, link_path: str | None = None,
                 seed: int = 0, loop: bool = False, truth_capacity: int = 10_000,
                 replay: bool = False):
        """
        Prepare a board for a Scene (or a bundled scene name or YAML path); start() runs it.

        replay (looped boards only): render one pass of the scene at start() and replay it.
        """
        self.scene = _as_scene(scene)
        self.rate_hz = check_number(rate_hz, 'rate_hz', positive=True, high=20_000)
        check_int(truth_capacity, 'truth_capacity', low=1)
        self.link_path = os.path.abspath(link_path) if link_path else None
        self.loop = bool(loop)
        if replay and not self.loop:
            raise ValueError('replay needs loop: only a looped scene repeats its scans')
        self._replay = bool(replay)
        self._replayed = None  # the scans of one pass, with replay
        self._rng = np.random.default_rng(seed)
        self._truth: dict = {}
        self._truth_order: deque = deque()
        self._truth_capacity = truth_capacity
        one_frame = frame_size(self.scene.model.rows, self.scene.model.cols)
        self._max_pending = max(65536, 4 * one_frame)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._master: int | None = None
        self._slave: int | None = None
        self._port: str | None = None
        self._pending = bytearray()
        self._garbage: list = []
        self._frame_ends: deque = deque()  # stream offsets at which queued frames end
        self._queued_bytes = 0
        self._written_bytes = 0
        self._next_index = 0
        self._t0 = 0.0
        self._seq_offset = 0
        self._time_offset_us = 0
        self._hold_until = 0.0
        self._noise = 0.0
        self._noise_rng = np.random.default_rng(seed + 1)
        self._wire_shape: tuple | None = None
        self._sent_ends: deque = deque(maxlen=SENT_HISTORY)  # (end offset, intact) of sent frames
        self.frames_sent = 0          # frames whose last byte went into the pty
        self.frames_dropped = 0       # frames scanned but never sent (unplugged, queue full, lag)
        self.frames_damaged = 0       # sent frames whose bytes the line noise changed
        self.frames_wrong_shape = 0   # sent frames of a grid other than the scene's
        self.frames_unread = 0        # sent intact frames the reader had not read at an unplug
        self.seq_skipped = 0          # sequence numbers skipped by skip_sequence()
        self.first_seq_since_plug = None  # seq of the first frame queued on the current pty

    # ---- public control -------------------------------------------------------------------

    @property
    def epoch_monotonic(self) -> float:
        """Return the host's monotonic time at device time 0."""
        return self._t0

    @property
    def port(self) -> str | None:
        """Return the pty slave path while plugged in, else None."""
        return self._port

    @property
    def next_seq(self) -> int:
        """Return the sequence number the next scanned frame will carry."""
        return (self._next_index + self._seq_offset) & MAX_SEQ

    @property
    def ground_truth(self) -> dict:
        """Return a snapshot {seq: FrameTruth} of the most recent truth_capacity frames."""
        with self._lock:
            return dict(self._truth)

    def truth(self, seq: int) -> FrameTruth | None:
        """Return the truth of one frame, or None if unknown or already forgotten."""
        with self._lock:
            return self._truth.get(seq)

    def start(self) -> str:
        """Open the pty, start streaming and return the port path (the link if one was asked)."""
        if self._thread is not None:
            raise RuntimeError('SimulatedSkin already started')
        if self._replay and self._replayed is None:
            passes = max(1, round(self.scene.duration_s * self.rate_hz))
            self._replayed = [self._render(i / self.rate_hz) for i in range(passes)]
        self._plug()
        self._stop.clear()
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._run, name='skin-sim', daemon=True)
        self._thread.start()
        return self.link_path or self._port

    def stop(self) -> None:
        """Stop streaming, close the pty and remove the link."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        with self._lock:
            self._unplug_locked()

    def unplug(self) -> None:
        """Close the pty as if the cable were pulled; the device clock keeps running."""
        with self._lock:
            self._unplug_locked()

    def replug(self) -> str:
        """Open a fresh pty, re-point the link and resume streaming; return the port path."""
        with self._lock:
            self._unplug_locked()
        self._plug()
        return self.link_path or self._port

    def inject_garbage(self, data: bytes) -> None:
        """Write raw bytes into the stream between two frames (fault injection)."""
        with self._lock:
            self._garbage.append(bytes(data))

    def stall(self, seconds: float) -> None:
        """Stop scanning and sending for seconds, as a hung firmware would, then carry on."""
        _check_duration(seconds)
        # Moving the start of the clock leaves no frame due until the stall is over; the
        # sequence and the device time carry on where they stopped.
        self._t0 += seconds
        # The board's hardware clock runs on while its firmware hangs.
        self._time_offset_us += int(round(seconds * 1e6))

    def burst(self, seconds: float) -> None:
        """Hold the frames back for seconds, then send them all in one clump."""
        _check_duration(seconds)
        with self._lock:
            self._hold_until = time.monotonic() + seconds

    def set_line_noise(self, probability: float) -> None:
        """
        Damage each frame on the line with this probability (0 turns the noise off).

        A damaged frame has a bit flipped, a byte dropped or duplicated, bytes inserted or its
        tail cut off; as often again, random bytes fall between two frames.
        """
        self._noise = check_number(probability, 'probability', low=0.0, high=1.0)

    def skip_sequence(self, count: int) -> None:
        """Make the next sequence number jump forward by count, as a firmware losing scans."""
        check_int(count, 'count', low=1, high=1_000_000)
        with self._lock:
            self._seq_offset += count
            self.seq_skipped += count

    def set_wire_shape(self, shape) -> None:
        """Send frames of another grid (rows, cols), cropped or zero-padded; None restores."""
        if shape is not None:
            rows, cols = shape
            if not all(isinstance(v, int) and 1 <= v <= 255 for v in (rows, cols)):
                raise ValueError(f'shape must be (rows, cols) within 1..255, got {shape!r}')
            shape = (rows, cols)
        self._wire_shape = shape

    def __enter__(self) -> SimulatedSkin:
        """Start the board."""
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        """Stop the board."""
        self.stop()

    # ---- pty handling ---------------------------------------------------------------------

    def _plug(self) -> None:
        master, slave = os.openpty()
        try:
            # Raw mode: no line editing, echo, CR/LF mapping or XON/XOFF on binary frames.
            tty.setraw(slave)
            flags = fcntl.fcntl(master, fcntl.F_GETFL)
            fcntl.fcntl(master, fcntl.F_SETFL, flags | os.O_NONBLOCK)
            port = os.ttyname(slave)
            if self.link_path:
                point_link(self.link_path, port)
        except BaseException:
            os.close(master)
            os.close(slave)
            raise
        with self._lock:
            self._pending.clear()
            self._frame_ends.clear()
            self._sent_ends.clear()
            self._queued_bytes = self._written_bytes = 0
            # The slave stays open here so that a reader may close and reopen the port.
            self._master, self._slave, self._port = master, slave, port
            self.first_seq_since_plug = None

    def _unplug_locked(self) -> None:
        if self._master is None:
            return
        self.frames_unread += self._count_unread_locked()
        # Frames still queued here never leave the board.
        self.frames_dropped += len(self._frame_ends)
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.link_path:
            remove_link(self.link_path, self._port)
        self._master = self._slave = self._port = None
        self._pending.clear()
        self._frame_ends.clear()
        self._garbage.clear()

    def _count_unread_locked(self) -> int:
        """Return how many sent intact frames have bytes the reader has not read yet."""
        # Written bytes reach the slave's read queue (what FIONREAD counts) a moment later.
        time.sleep(UNPLUG_SETTLE_S)
        try:
            raw = fcntl.ioctl(self._slave, termios.FIONREAD, b'\0\0\0\0')
            unread = struct.unpack('i', raw)[0]
        except OSError:
            return 0
        read_up_to = self._written_bytes - unread
        return sum(1 for end, intact in self._sent_ends if intact and end > read_up_to)

    # ---- streaming ------------------------------------------------------------------------

    def _run(self) -> None:
        period = 1.0 / self.rate_hz
        while not self._stop.is_set():
            now = time.monotonic()
            due = math.floor((now - self._t0) * self.rate_hz) + 1
            if due - self._next_index > MAX_LAG_S * self.rate_hz:
                skipped = due - self._next_index - 1
                self.frames_dropped += skipped
                self._next_index += skipped
            while self._next_index < due and not self._stop.is_set():
                self._emit(self._next_index)
                self._next_index += 1
            self._flush()
            wake = self._t0 + self._next_index * period
            if period < BATCH_S:
                wake += BATCH_S - period
            delay = max(0.0, wake - time.monotonic())
            if self._pending:
                # Bytes the pty could not take yet (or held for a burst) go out meanwhile.
                delay = min(delay, BATCH_S)
            self._stop.wait(delay)

    def _scene_time(self, seconds: float) -> float:
        duration = self.scene.duration_s
        if self.loop and duration > 0:
            return math.fmod(seconds, duration)
        return seconds

    def _emit(self, index: int) -> None:
        seq = (index + self._seq_offset) & MAX_SEQ
        device_time_us, seconds = _frame_times(index, self.rate_hz)
        device_time_us += self._time_offset_us
        with self._lock:
            plugged = self._master is not None
            room = len(self._pending) < self._max_pending
        if not (plugged and room):
            self.frames_dropped += 1
            return
        if self._replayed:
            scan = self._replayed[index % len(self._replayed)]
        else:
            scan = self._render(self._scene_time(seconds))
        top, bottom = scan.top, scan.bottom
        wire_shape = self._wire_shape
        wrong_shape = wire_shape is not None and wire_shape != top.shape
        if wrong_shape:
            top, bottom = _reshape(top, wire_shape), _reshape(bottom, wire_shape)
            top.flags.writeable = False
            bottom.flags.writeable = False
            raw = encode_frame(seq, device_time_us, top, bottom)
        else:
            raw = frame_with_counts(seq, device_time_us, *scan.counts)
        truth = FrameTruth(seq, device_time_us, top, bottom, scan.presses, scan.scene_time_s,
                           scan.press_indices)
        junk, wire, damaged = b'', raw, False
        if self._noise and self._noise_rng.random() < self._noise:
            wire = damage(raw, self._noise_rng)
            # Damage at the very end may leave the frame intact with junk behind it.
            damaged = wire[:len(raw)] != raw
        if self._noise and self._noise_rng.random() < self._noise:
            junk = self._noise_rng.integers(0, 256, int(self._noise_rng.integers(1, 64)),
                                            dtype=np.uint8).tobytes()
        with self._lock:
            self._remember(truth)
            if self._master is None:
                self.frames_dropped += 1
                return
            self._garbage.append(junk)
            for extra in self._garbage:
                self._pending += extra
                self._queued_bytes += len(extra)
            self._garbage.clear()
            self._pending += wire
            self._queued_bytes += len(wire)
            if self.first_seq_since_plug is None:
                self.first_seq_since_plug = seq
            self._frame_ends.append((self._queued_bytes, damaged, wrong_shape))

    def _render(self, t: float) -> _Scan:
        """Render the scan of scene time t."""
        active = self.scene.active_at(t)
        presses = tuple(p for _, p in active)
        top, bottom = physics.render(self.scene.model, presses, self._rng)
        top.flags.writeable = False
        bottom.flags.writeable = False
        return _Scan(t, presses, tuple(i for i, _ in active), top, bottom,
                     encode_counts(top, bottom))

    def _remember(self, truth: FrameTruth) -> None:
        if truth.seq in self._truth:
            self._truth_order.remove(truth.seq)
        self._truth[truth.seq] = truth
        self._truth_order.append(truth.seq)
        while len(self._truth_order) > self._truth_capacity:
            del self._truth[self._truth_order.popleft()]

    def _flush(self) -> None:
        with self._lock:
            if self._master is None or not self._pending:
                return
            if time.monotonic() < self._hold_until:
                return
            try:
                n = os.write(self._master, self._pending)
            except BlockingIOError:
                return
            except OSError as err:
                if err.errno in (errno.EIO, errno.EBADF):
                    return
                raise
            del self._pending[:n]
            self._written_bytes += n
            while self._frame_ends and self._frame_ends[0][0] <= self._written_bytes:
                end, damaged, wrong_shape = self._frame_ends.popleft()
                self.frames_sent += 1
                self.frames_damaged += damaged
                self.frames_wrong_shape += wrong_shape
                self._sent_ends.append((end, not (damaged or wrong_shape)))


def _check_duration(seconds: float) -> None:
    check_number(seconds, 'seconds', low=0.0, high=3600.0)


def _reshape(layer: np.ndarray, shape: tuple) -> np.ndarray:
    """Return layer cropped or zero-padded to shape."""
    out = np.zeros(shape, dtype=layer.dtype)
    rows, cols = min(shape[0], layer.shape[0]), min(shape[1], layer.shape[1])
    out[:rows, :cols] = layer[:rows, :cols]
    return out
