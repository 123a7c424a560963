"""
The simulated board: streams protocol frames of a scene on a pseudo-terminal, like the real one.

Like a USB CDC board whose host stops reading, the simulator never blocks: frames that do not fit
into the pty and a small output queue are dropped whole (``pty_line``), so the clock and the
sequence numbers run on and the reader sees a sequence gap.

Faults for reliability tests: unplug/replug, stall (the board stops for a while), burst (frames
held back and sent in one clump), line noise (damaged frames and junk between frames), sequence
gaps and frames of another grid size.  A looped board may replay (``replay``): it renders one pass
of the scene before it starts and sends those scans again with new sequence numbers and device
times, so that it costs next to nothing per scan (the benchmark's board shares the cores it
measures).  Every frame that leaves the board has exactly one fate the
board can name: intact, damaged by the line, of the wrong size, or still unread in the pty when
the cable was pulled (see the frames_* counters).

A scene that drifts (``drift``, :mod:`.scene`) is rendered with its creep and offset drift
(:func:`physics.render_held`): each press by its equivalent age under load at the scene's time,
the offsets by the board's clock, which runs on across the passes of a looped scene.

Like the firmware, the board says who it is (docs/protocol.md, board information frame): once
before its first frame and then once a second of device time, between two frames, on the
firmware's schedule. By default it is a fixed fake board
(:func:`sim_board_info`: board ``sim``, the scene's grid and pitch); ``identity`` names another,
or None for a version-1 board that sends no identity.

It sends protocol version 2 (packed counts, fault bits, row map) unless ``protocol=1`` asks for
version 1. A version-2 board can report rows it failed to sample and fault bits
(``set_row_faults``), as the firmware does.

Every frame it sends, data or information, is built by the firmware core's own code, and the
information frames keep the firmware's own schedule: the core built for the host
(:mod:`.firmware`, package skin_fw_host), so that the real and the simulated board frame alike.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
import hashlib
import math
import os
import threading
import time

import numpy as np

from . import physics
from .drift import held_age
from .firmware import Framer, info_frame, InfoSchedule, row_map
from .line import damage
from .pty_line import PtyLine
from .scene import load_scene, Scene
from ..common.validate import check_int, check_number
from ..protocol.wire import BoardInfo, frame_size, LATEST_VERSION, MAX_SEQ, PROTOCOL_VERSIONS

# Below this period frames are written in batches: one wake-up per BATCH_S instead of per frame.
# A USB full-speed board's bytes reach the host in the 1 ms bus frame they were sent in, so a
# scan never waits there for the next one to be written: at 1 kHz each scan goes alone.
BATCH_S = 0.001
# Further behind than this (a stalled process) the clock skips frames instead of bursting them.
MAX_LAG_S = 0.5
# The simulated board's unique ID: 'SIM' in ASCII, then zeros (a real STM32's is never so).
SIM_UID = '53494d000000000000000000'
SIM_FIRMWARE = '0.1.0'
# Microseconds of device time between two board information frames.
INFO_PERIOD_US = 1_000_000
# Default of SimulatedSkin's identity: the simulated board's own.
SIM = 'sim'
# What an invalid row carries: meaningless counts, here the ADC's full scale.
INVALID_ROW_COUNT = 4095


def sim_uid(name: str = '') -> str:
    """
    Return the unique ID of the simulated board called ``name`` ('': SIM_UID).

    'SIM' in ASCII, then 18 hex digits of the name's SHA-256: the same board gets the same uid
    at every run (its calibration file stays bound to it), two boards of several patches never
    share one.
    """
    if not name:
        return SIM_UID
    return SIM_UID[:6] + hashlib.sha256(name.encode('utf-8')).hexdigest()[:18]


def sim_board_info(rows: int, cols: int, pitch_m: float, rate_hz: float,
                   name: str = '') -> BoardInfo:
    """Return the identity the simulated board ``name`` gives for this grid, pitch and rate."""
    return BoardInfo('sim', sim_uid(name), SIM_FIRMWARE, rows, cols, pitch_m,
                     max(1, int(round(rate_hz))))


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
    counts: np.ndarray  # (2, rows, cols) uint16, top then bottom, as the firmware samples them


def _as_scene(scene) -> Scene:
    return scene if isinstance(scene, Scene) else load_scene(scene)


def _frame_times(index: int, rate_hz: float) -> tuple:
    """Return (device time in us, seconds since start) of the frame with this index."""
    seconds = index / rate_hz
    return int(round(index * 1e6 / rate_hz)), seconds


class SimulatedSkin:
    """A virtual skin board on a pseudo-terminal, streaming frames rendered from a scene."""

    def __init__(self, scene, rate_hz: float = 100.0, link_path: str | None = None,
                 noise_seed: int = 0, loop: bool = False, truth_capacity: int = 10_000,
                 replay: bool = False, identity=SIM, protocol: int = LATEST_VERSION):
        """
        Prepare a board for a Scene (or a bundled scene name or YAML path); start() runs it.

        replay (looped boards only): render one pass of the scene at start() and replay it.
        identity: the BoardInfo the board sends, ``SIM`` (default) the simulated board's, None
        none (a version-1 board).
        protocol: the wire protocol version of its frames, 2 (default) or 1.
        """
        if protocol not in PROTOCOL_VERSIONS:
            raise ValueError(f'protocol must be one of {PROTOCOL_VERSIONS}, got {protocol!r}')
        self.protocol = protocol
        self._row_valid = None  # (2, rows) booleans of the rows it samples; None: all
        self._row_map = None  # the firmware's row map of _row_valid
        self._faults = 0
        self.scene = _as_scene(scene)
        self.rate_hz = check_number(rate_hz, 'rate_hz', positive=True, high=20_000)
        check_int(truth_capacity, 'truth_capacity', low=1)
        self.link_path = os.path.abspath(link_path) if link_path else None
        self.loop = bool(loop)
        if replay and not self.loop:
            raise ValueError('replay needs loop: only a looped scene repeats its scans')
        self._replay = bool(replay)
        if replay and self.scene.drifts:
            raise ValueError('replay sends one pass again and again: a scene that drifts '
                             'cannot be replayed')
        # Per press, the loads its film remembers (Scene.loads), found once.
        self._loads = ([list(self.scene.loads(i)) for i in range(len(self.scene.presses))]
                       if self.scene.drifts else None)
        self._replayed = None  # the scans of one pass, with replay
        self._rng = np.random.default_rng(noise_seed)
        self._truth: dict = {}
        self._truth_order: deque = deque()
        self._truth_capacity = truth_capacity
        one_frame = frame_size(self.scene.model.rows, self.scene.model.cols, protocol)
        self._line = PtyLine(self.link_path, max_pending=max(65536, 4 * one_frame))
        self._lock = threading.Lock()  # guards the truth
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._next_index = 0
        self._t0 = 0.0
        self._seq_offset = 0
        self._time_offset_us = 0
        self._noise = 0.0
        self._noise_rng = np.random.default_rng(noise_seed + 1)
        self._wire_shape: tuple | None = None
        model = self.scene.model
        if isinstance(identity, str) and identity == SIM:
            identity = sim_board_info(model.rows, model.cols, model.pitch_m, self.rate_hz)
        if identity is not None and not isinstance(identity, BoardInfo):
            raise ValueError(f'identity must be a BoardInfo, {SIM!r} or None, got {identity!r}')
        self.identity = identity
        self._info = info_frame(identity) if identity is not None else b''
        self._info_schedule = InfoSchedule(INFO_PERIOD_US)
        self._framers = {}  # (rows, cols): the Framer of the frames of that grid
        self.info_frames_sent = 0  # info frames queued on the line
        self._not_queued = 0          # frames scanned while unplugged, the queue full, or lagging
        self.seq_skipped = 0          # sequence numbers skipped by skip_sequence()

    # ---- public control -------------------------------------------------------------------

    @property
    def epoch_monotonic(self) -> float:
        """Return the host's monotonic time at device time 0."""
        return self._t0

    @property
    def port(self) -> str | None:
        """Return the pty slave path while plugged in, else None."""
        return self._line.port

    @property
    def frames_sent(self) -> int:
        """Return how many frames had their last byte written into the pty."""
        return self._line.frames_sent

    @property
    def frames_dropped(self) -> int:
        """Return how many scanned frames were never sent (unplugged, queue full, lag)."""
        return self._not_queued + self._line.frames_dropped

    @property
    def frames_damaged(self) -> int:
        """Return how many sent frames the line noise changed."""
        return self._line.frames_damaged

    @property
    def frames_wrong_shape(self) -> int:
        """Return how many sent frames were of a grid other than the scene's."""
        return self._line.frames_wrong_shape

    @property
    def frames_unread(self) -> int:
        """Return how many sent intact frames the reader had not read at an unplug."""
        return self._line.frames_unread

    @property
    def first_seq_since_plug(self) -> int | None:
        """Return the sequence number of the first frame queued on the current pty."""
        return self._line.first_tag_since_plug

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
        port = self._line.plug()
        self._stop.clear()
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._run, name='skin-sim', daemon=True)
        self._thread.start()
        return self.link_path or port

    def stop(self) -> None:
        """Stop streaming, close the pty and remove the link."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        self._line.unplug()

    def unplug(self) -> None:
        """Close the pty as if the cable were pulled; the device clock keeps running."""
        self._line.unplug()

    def replug(self) -> str:
        """Open a fresh pty, re-point the link and resume streaming; return the port path."""
        port = self._line.plug()
        return self.link_path or port

    def inject_garbage(self, data: bytes) -> None:
        """Write raw bytes into the stream between two frames (fault injection)."""
        self._line.inject(data)

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
        self._line.hold(seconds)

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

    def set_row_faults(self, row_valid=None, faults: int = 0) -> None:
        """
        From the next scan on, fail to sample the rows false in ``row_valid`` and report faults.

        row_valid: (2, rows) booleans (top, bottom), None: every row sampled. An invalid row
        carries meaningless counts (full scale) and is marked so in the frame; faults: the fault
        bits (0..0xFFFF). Version 2 only: a version-1 frame cannot say so (ValueError).
        """
        if self.protocol == 1 and (row_valid is not None or faults):
            raise ValueError('a version-1 board cannot report invalid rows or faults')
        model = self.scene.model
        if row_valid is not None:
            row_valid = np.array(row_valid, dtype=bool)
            if row_valid.shape != (2, model.rows):
                raise ValueError(f'row_valid must have shape (2, {model.rows}), got '
                                 f'{row_valid.shape}')
            if row_valid.all():
                row_valid = None
        self._faults = check_int(faults, 'faults', low=0, high=0xFFFF)
        self._row_map = None if row_valid is None else row_map(row_valid)
        self._row_valid = row_valid

    def __enter__(self) -> SimulatedSkin:
        """Start the board."""
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        """Stop the board."""
        self.stop()

    # ---- streaming ------------------------------------------------------------------------

    def _run(self) -> None:
        period = 1.0 / self.rate_hz
        while not self._stop.is_set():
            now = time.monotonic()
            due = math.floor((now - self._t0) * self.rate_hz) + 1
            if due - self._next_index > MAX_LAG_S * self.rate_hz:
                skipped = due - self._next_index - 1
                self._not_queued += skipped
                self._next_index += skipped
            while self._next_index < due and not self._stop.is_set():
                self._emit(self._next_index)
                self._next_index += 1
            self._line.flush()
            wake = self._t0 + self._next_index * period
            if period < BATCH_S:
                wake += BATCH_S - period
            delay = max(0.0, wake - time.monotonic())
            if self._line.has_pending():
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
        if not self._line.has_room():
            self._not_queued += 1
            return
        if self._replayed:
            scan = self._replayed[index % len(self._replayed)]
        else:
            scan = self._render(self._scene_time(seconds), device_time_us / 1e6)
        top, bottom = scan.top, scan.bottom
        wire_shape = self._wire_shape
        wrong_shape = wire_shape is not None and wire_shape != top.shape
        row_valid, faults = self._row_valid, self._faults
        if wrong_shape:
            top, bottom = _reshape(top, wire_shape), _reshape(bottom, wire_shape)
            top.flags.writeable = False
            bottom.flags.writeable = False
            raw = self._framer(wire_shape).frame(seq, device_time_us, _counts(top, bottom),
                                                 faults)
        elif row_valid is not None:
            sent = np.where(row_valid[:, :, None], scan.counts, INVALID_ROW_COUNT)
            raw = self._framer(top.shape).frame(seq, device_time_us, sent.astype(np.uint16),
                                                faults, self._row_map)
        else:
            raw = self._framer(top.shape).frame(seq, device_time_us, scan.counts, faults)
        truth = FrameTruth(seq, device_time_us, top, bottom, scan.presses, scan.scene_time_s,
                           scan.press_indices)
        info = b''
        if self._info and self._info_schedule.due(device_time_us):
            info = self._info
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
        # The info frame goes ahead of the frame, before any junk: it is the board's, the junk
        # the line's.
        if not self._line.queue(wire, seq, damaged, wrong_shape, info + junk):
            self._not_queued += 1
        elif info:
            self.info_frames_sent += 1
            self._info_schedule.sent(device_time_us)

    def _render(self, t: float, clock_s: float = 0.0) -> _Scan:
        """Render the scan of scene time t; a drifting scene's offsets at the clock's time."""
        active = self.scene.active_at(t)
        presses = tuple(p for _, p in active)
        if self._loads is None:
            top, bottom = physics.render(self.scene.model, presses, self._rng)
        else:
            drift = self.scene.model.drift
            ages = [held_age(drift, self._loads[i], t) for i, _ in active]
            top, bottom = physics.render_held(self.scene.model, presses, ages, clock_s,
                                              self._rng)
        top.flags.writeable = False
        bottom.flags.writeable = False
        return _Scan(t, presses, tuple(i for i, _ in active), top, bottom, _counts(top, bottom))

    def _framer(self, shape: tuple) -> Framer:
        framer = self._framers.get(shape)
        if framer is None:
            framer = self._framers[shape] = Framer(*shape, self.protocol)
        return framer

    def _remember(self, truth: FrameTruth) -> None:
        if truth.seq in self._truth:
            self._truth_order.remove(truth.seq)
        self._truth[truth.seq] = truth
        self._truth_order.append(truth.seq)
        while len(self._truth_order) > self._truth_capacity:
            del self._truth[self._truth_order.popleft()]


def _counts(top: np.ndarray, bottom: np.ndarray) -> np.ndarray:
    """Return both layers as the firmware's samples: (2, rows, cols) uint16."""
    return np.ascontiguousarray(np.stack((top, bottom)), dtype=np.uint16)


def _check_duration(seconds: float) -> None:
    check_number(seconds, 'seconds', low=0.0, high=3600.0)


def _reshape(layer: np.ndarray, shape: tuple) -> np.ndarray:
    """Return layer cropped or zero-padded to shape."""
    out = np.zeros(shape, dtype=layer.dtype)
    rows, cols = min(shape[0], layer.shape[0]), min(shape[1], layer.shape[1])
    out[:rows, :cols] = layer[:rows, :cols]
    return out
