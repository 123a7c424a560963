"""
The simulated board's end of the cable: a pseudo-terminal that never blocks the board.

Like a USB CDC device whose host stops reading, frames that do not fit into the pty and a small
output queue are dropped whole.  Every queued frame has exactly one fate the line can name: sent
intact, sent damaged, sent of the wrong size, still queued when the cable was pulled (dropped),
or sent but unread by the host at the pull (unread).
"""

from __future__ import annotations

from collections import deque
import errno
import fcntl
import os
import threading
import time
import tty

from .line import point_link, remove_link

# Sent frames remembered to tell, at an unplug, which of them the reader had not read yet.
SENT_HISTORY = 8192


class PtyLine:
    """A non-blocking pty with an output queue of whole frames and a count of their fates."""

    def __init__(self, link_path: str | None, max_pending: int):
        """Prepare an unplugged line; link_path, if given, is a symlink kept pointing at it."""
        self.link_path = link_path
        self._max_pending = max_pending
        self._lock = threading.Lock()
        self._master: int | None = None
        self._slave: int | None = None
        self._port: str | None = None
        self._pending = bytearray()
        self._garbage: list = []
        self._frame_ends: deque = deque()  # stream offsets at which queued frames end
        self._sent_ends: deque = deque(maxlen=SENT_HISTORY)  # (end offset, intact) of sent frames
        self._queued_bytes = 0
        self._written_bytes = 0
        self._hold_until = 0.0
        self.frames_sent = 0          # frames whose last byte went into the pty
        self.frames_dropped = 0       # frames queued but never sent (the cable was pulled)
        self.frames_damaged = 0       # sent frames whose bytes the line noise changed
        self.frames_wrong_shape = 0   # sent frames of a grid other than the scene's
        self.frames_unread = 0        # sent intact frames the reader had not read at an unplug
        self.first_tag_since_plug = None  # tag of the first frame queued on the current pty

    @property
    def port(self) -> str | None:
        """Return the pty slave path while plugged in, else None."""
        return self._port

    def has_room(self) -> bool:
        """Return whether a plugged line's queue takes another frame."""
        with self._lock:
            return self._master is not None and len(self._pending) < self._max_pending

    def has_pending(self) -> bool:
        """Return whether bytes wait for the pty (it was full, or a burst holds them)."""
        return bool(self._pending)

    def plug(self) -> str:
        """Open a fresh pty (closing any other), point the link at it and return its path."""
        self.unplug()
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
            self.first_tag_since_plug = None
        return port

    def unplug(self) -> None:
        """Close the pty as if the cable were pulled, counting what it held."""
        with self._lock:
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

    def inject(self, data: bytes) -> None:
        """Put raw bytes into the stream ahead of the next frame."""
        with self._lock:
            self._garbage.append(bytes(data))

    def hold(self, seconds: float) -> None:
        """Keep queued bytes back for seconds, then let them go in one clump."""
        with self._lock:
            self._hold_until = time.monotonic() + seconds

    def queue(self, wire: bytes, tag, damaged: bool, wrong_shape: bool, junk=b'') -> bool:
        """
        Queue one frame's bytes after any injected ones and junk; False if unplugged.

        tag names the frame (the board's sequence number) for first_tag_since_plug.
        """
        with self._lock:
            if self._master is None:
                return False
            self._garbage.append(junk)
            for extra in self._garbage:
                self._pending += extra
                self._queued_bytes += len(extra)
            self._garbage.clear()
            self._pending += wire
            self._queued_bytes += len(wire)
            if self.first_tag_since_plug is None:
                self.first_tag_since_plug = tag
            self._frame_ends.append((self._queued_bytes, damaged, wrong_shape))
            return True

    def flush(self) -> None:
        """Write what the pty takes now, and count the frames whose last byte went out."""
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

    def _count_unread_locked(self) -> int:
        """Return how many sent intact frames have bytes the reader has not read yet."""
        # What the reader has not read is read out here, so each byte is either the reader's
        # or counted: the pty's input count (FIONREAD) would miss bytes still on their way to
        # the slave (the kernel passes them on later, on a busy machine much later, and its
        # count stops at 4 KB while nobody reads) and bytes the reader takes after the count but
        # before the close.
        unread = self._drain_locked()
        read_up_to = self._written_bytes - unread
        return sum(1 for end, intact in self._sent_ends if intact and end > read_up_to)

    def _drain_locked(self) -> int:
        """Read what is left for the reader on the slave; return how many bytes that was."""
        try:
            flags = fcntl.fcntl(self._slave, fcntl.F_GETFL)
            # Only this end's own open file turns non-blocking, not the reader's.
            fcntl.fcntl(self._slave, fcntl.F_SETFL, flags | os.O_NONBLOCK)
        except OSError:
            return 0
        drained = 0
        while True:
            try:
                # With nothing waiting, the kernel first passes on what is on its way, so the
                # first refusal (EAGAIN) means nothing is left at all.
                data = os.read(self._slave, 65536)
            except OSError:
                return drained
            if not data:
                return drained
            drained += len(data)
