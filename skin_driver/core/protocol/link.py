"""
Read skin frames from a serial port (or any pyserial URL) in a background thread.

One decoder, many transports: a device path such as /dev/ttyACM0 or a pseudo-terminal, or a
pyserial URL such as socket://host:port or loop://. The link reconnects with exponential back-off
when the device goes away and reports every change of state; it never raises into its caller.
A device path that was missing is watched while the link waits, so a replugged board is opened
as soon as its path reappears rather than when the back-off ends.
It is ROS-free, so the driver node only wires it to topics and diagnostics.

Frames lost while the device was away are counted when the board comes back with its sequence
moved on (frames_lost_reconnecting): the same board's clock has advanced about as much as the
host's since the last frame, whereas a board that restarted counts its clock from zero again, so
a jump is only counted when the device clock advanced by at least the host's time less
SAME_BOARD_TOLERANCE_S.
"""

from dataclasses import dataclass
import os
import select
import threading
import time
from typing import Callable, List, Optional

import serial

from skin_driver.core.protocol.hold import RowHold
from skin_driver.core.protocol.realtime import (name_this_thread, NORMAL, schedule_this_thread,
                                                Scheduling, StageCpu)
from skin_driver.core.protocol.wire import BoardInfo, Frame, FrameDecoder, MAX_SEQ

CONNECTING = 'connecting'
CONNECTED = 'connected'
STALLED = 'stalled'
DISCONNECTED = 'disconnected'
STOPPED = 'stopped'

# How often a missing device path is looked for while the link waits to reopen it.
PATH_POLL_S = 0.05
# Most bytes one read takes: what a pty or a USB CDC buffer holds.
READ_MAX = 65536
# Slack between the device clock and the host clock across a reconnect (latency, backlog).
SAME_BOARD_TOLERANCE_S = 1.0


def default_port(namespace: str = '') -> str:
    """
    Return where the skin of ``namespace`` is found by default: a path of this user's own.

    Under $XDG_RUNTIME_DIR (else $ROS_HOME, else ~/.ros), one folder per namespace as the frames
    are named (``skin`` for the namespace skin or none): two users or two skins on one machine
    never meet on a shared /tmp path. The simulator links its pseudo-terminal there.
    """
    base = (os.environ.get('XDG_RUNTIME_DIR') or os.environ.get('ROS_HOME')
            or os.path.join(os.path.expanduser('~'), '.ros'))
    name = namespace.strip('/').replace('/', '_') or 'skin'
    return os.path.join(base, 'skin_driver', name, 'skin0')


def port_problem(port: str) -> str:
    """
    Return why ``port`` cannot be a serial port ('' when it may be one).

    pyserial opens a regular file and then fails to configure it with 'Inappropriate ioctl for
    device', which names neither the file nor what is wrong with it.
    """
    if '://' not in port and os.path.isfile(port):
        return (f"{port} is a regular file, not a serial port or pty; name the board's device "
                '(e.g. /dev/ttyACM0) or the link the simulated skin makes')
    return ''


@dataclass
class LinkStats:
    """What the link has seen since it was created."""

    connects: int = 0
    disconnects: int = 0
    open_failures: int = 0
    bytes_read: int = 0
    callback_errors: int = 0
    frames: int = 0
    frames_lost_reconnecting: int = 0
    last_connect_s: float = 0.0   # time.monotonic() of the latest successful open
    last_error: str = ''


class SerialLink:
    """
    Own the serial port, feed its bytes to a FrameDecoder and hand complete frames over.

    on_frames(frames, monotonic_receive_time) is called from the link's thread for every read
    that completed at least one frame; on_state(state, detail) whenever the link changes state;
    on_board_info(info) when the board says who it is (a BoardInfo, docs/protocol.md) for the
    first time or differently, before the frames of the same read.
    With a priority (1..99) the thread asks for SCHED_FIFO at it (core.protocol.realtime);
    ``scheduling`` says what it got once start() has returned. ``cpu`` (a StageCpu with at
    least the stages read, decode and deliver) measures the thread's CPU per stage; on_frames
    may mark stages of its own in it.
    Rows a version-2 board says it did not sample are held at their last valid counts before
    on_frames sees them (``hold``, core.protocol.hold).
    """

    def __init__(self, port: str, baud: int, decoder: FrameDecoder,
                 on_frames: Callable[[List[Frame], float], None],
                 on_state: Callable[[str, str], None] = lambda state, detail: None,
                 read_timeout_s: float = 0.05, stall_timeout_s: float = 1.0,
                 backoff_min_s: float = 0.1, backoff_max_s: float = 2.0,
                 open_port: Optional[Callable[..., serial.SerialBase]] = None,
                 priority: int = 0, cpu: Optional[StageCpu] = None,
                 on_board_info: Callable[[BoardInfo], None] = lambda info: None):
        self.port = port
        self.cpu = cpu or StageCpu(('read', 'decode', 'deliver'))
        self.priority = priority
        self.scheduling = Scheduling(NORMAL)
        self._scheduled = threading.Event()
        self.baud = baud
        self.decoder = decoder
        self.hold = RowHold()
        self.stats = LinkStats()
        self.state = STOPPED
        self._on_frames = on_frames
        self._on_state = on_state
        self._on_board_info = on_board_info
        self._board_info: Optional[BoardInfo] = None  # the newest one handed to on_board_info
        self._read_timeout = read_timeout_s
        self._stall_timeout = stall_timeout_s
        self._backoff = (backoff_min_s, backoff_max_s)
        self._open_port = open_port or self._default_open
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self._serial: Optional[serial.SerialBase] = None
        self._read: Callable[[], bytes] = bytes
        self._last_frame: Optional[tuple] = None  # (seq, device time in us, host time in s)
        self._resumed = False

    def _default_open(self) -> serial.SerialBase:
        problem = port_problem(self.port)
        if problem:
            raise ValueError(problem)
        return serial.serial_for_url(self.port, baudrate=self.baud, timeout=self._read_timeout)

    @property
    def running(self) -> bool:
        """Return whether the reader thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> None:
        """Start reading in a daemon thread (idempotent); return once it has its scheduling."""
        if self._thread is not None and self._thread.is_alive():
            return
        self._stop.clear()
        self._scheduled.clear()
        self._thread = threading.Thread(target=self._run, name=f'skin-link {self.port}',
                                        daemon=True)
        self._thread.start()
        self._scheduled.wait()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop the thread and close the port."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
            self._thread = None
        self._close()
        self._set_state(STOPPED, '')

    def _set_state(self, state: str, detail: str) -> None:
        if state != self.state:
            self.state = state
            self._notify(self._on_state, state, detail)

    def _notify(self, callback, *args) -> None:
        # A failing consumer must not kill the reader: the link would die silently.
        try:
            callback(*args)
        except Exception as err:  # noqa: B902 - any consumer error, reported and survived
            self.stats.callback_errors += 1
            self.stats.last_error = f'{type(err).__name__} in {callback.__name__}: {err}'

    def _close(self) -> None:
        ser, self._serial = self._serial, None
        if ser is not None:
            try:
                ser.close()
            except (OSError, serial.SerialException):
                pass

    def _connect(self) -> bool:
        try:
            self._serial = self._open_port()
        except (OSError, serial.SerialException, ValueError) as err:
            self.stats.open_failures += 1
            self.stats.last_error = str(err)
            self._set_state(DISCONNECTED if self.stats.connects else CONNECTING,
                            f'cannot open {self.port}: {err}')
            return False
        self._read = reader(self._serial, self._read_timeout)
        self.stats.connects += 1
        self.stats.last_connect_s = time.monotonic()
        # Bytes buffered from the previous connection belong to a frame that will never finish.
        self.decoder.reset()
        self.hold.reset()
        self._resumed = self._last_frame is not None
        self._set_state(CONNECTED, f'reading {self.port}')
        return True

    def _run(self) -> None:
        name_this_thread('skin-reader')
        self.scheduling = schedule_this_thread(self.priority)
        self._scheduled.set()
        backoff = self._backoff[0]
        last_frame = time.monotonic()
        size_errors = self.decoder.stats.size_errors  # at the latest good frame
        while not self._stop.is_set():
            if self._serial is None:
                if not self._connect():
                    self._wait_to_retry(backoff)
                    backoff = min(backoff * 2.0, self._backoff[1])
                    continue
                backoff = self._backoff[0]
                last_frame = time.monotonic()
            cpu = self.cpu
            cpu.begin()
            try:
                data = self._read()
            except (OSError, serial.SerialException, TypeError, AttributeError) as err:
                # pyserial raises TypeError/AttributeError when the fd vanishes under a read.
                self.stats.disconnects += 1
                self.stats.last_error = str(err) or type(err).__name__
                self._close()
                self._set_state(DISCONNECTED, f'lost {self.port}: {self.stats.last_error}')
                continue
            now = time.monotonic()
            cpu.mark('read')
            if data:
                self.stats.bytes_read += len(data)
                frames = self.hold.apply(self.decoder.feed(data))
                cpu.mark('decode')
                if self.decoder.board_info is not self._board_info:
                    # The decoder keeps the same object while the board repeats itself.
                    self._board_info = self.decoder.board_info
                    self._notify(self._on_board_info, self._board_info)
                if frames:
                    cpu.frames(len(frames))
                    self._follow_sequence(frames, now)
                    self.stats.frames += len(frames)
                    last_frame = now
                    size_errors = self.decoder.stats.size_errors
                    self._set_state(CONNECTED, f'reading {self.port}')
                    self._notify(self._on_frames, frames, now)
                    cpu.mark('deliver')
            if now - last_frame > self._stall_timeout:
                self._set_state(STALLED, self._stall_detail(now - last_frame, size_errors))

    def _stall_detail(self, quiet_s: float, size_errors_before: int) -> str:
        shape = self.decoder.last_rejected_shape
        if self.decoder.stats.size_errors > size_errors_before and shape:
            # Frames do arrive: saying "no frame" would send a maintainer to the cable.
            return (f'only frames of the wrong grid size {shape[0]}x{shape[1]} from {self.port} '
                    f'for {quiet_s:.1f} s')
        return f'no frame from {self.port} for {quiet_s:.1f} s'

    def _wait_to_retry(self, backoff_s: float) -> None:
        """Wait backoff_s, or less if the device path was missing and has just appeared."""
        deadline = time.monotonic() + backoff_s
        watch = self.port.startswith('/') and not os.path.exists(self.port)
        while not self._stop.is_set():
            left = deadline - time.monotonic()
            if left <= 0:
                return
            self._stop.wait(min(left, PATH_POLL_S) if watch else left)
            if watch and os.path.exists(self.port):
                return

    def _follow_sequence(self, frames: List[Frame], now: float) -> None:
        if self._resumed:
            self._resumed = False
            seq, device_us, host_s = self._last_frame
            first = frames[0]
            step = (first.seq - seq) & MAX_SEQ
            device_s = (first.device_time_us - device_us) * 1e-6
            if 1 < step <= MAX_SEQ // 2 and device_s >= now - host_s - SAME_BOARD_TOLERANCE_S:
                self.stats.frames_lost_reconnecting += step - 1
        last = frames[-1]
        self._last_frame = (last.seq, last.device_time_us, now)


def reader(port: serial.SerialBase, timeout_s: float) -> Callable[[], bytes]:
    """
    Return a function that reads every byte the open port holds, waiting up to timeout_s.

    A port with a file descriptor (a device, a pty) is read with one poll and one os.read of
    all that is there: pyserial's read(in_waiting) takes two calls per frame when the first
    byte of a frame is alone in the buffer. Pyserial URLs (socket://, loop://) keep its read.
    A port that says it is ready but gives no byte is gone (pyserial says the same).
    """
    try:
        fd = port.fileno()
    except (AttributeError, OSError, ValueError):  # a URL handler has no descriptor
        return lambda: port.read(max(1, port.in_waiting))
    poller = select.poll()
    poller.register(fd, select.POLLIN)
    timeout_ms = max(1, round(1000 * timeout_s))

    def read() -> bytes:
        if not poller.poll(timeout_ms):
            return b''
        try:
            data = os.read(fd, READ_MAX)
        except BlockingIOError:  # pyserial opens ports non-blocking; someone else was quicker
            return b''
        if not data:
            raise serial.SerialException(f'{port.port} reports readiness to read but returned '
                                         'no data (device disconnected?)')
        return data
    return read
