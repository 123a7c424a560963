"""
Simulated skin: a virtual board that streams protocol frames on a pseudo-terminal.

Run ``python -m skin_driver.sim --scene seed --rate 100 --link /tmp/skin`` and open the printed
port (or the link) like the real board.  The first stdout line is ``SKIN_PORT <path>``; human
messages go to stderr.  ``--export OUT.npz`` renders the scene offline into an evaluator dataset.

Like a USB CDC board whose host stops reading, the simulator never blocks: frames that do not fit
into the pty and a small output queue are dropped whole, so the clock and the sequence numbers run
on and the reader sees a sequence gap.
"""

from __future__ import annotations

import argparse
from collections import deque
from dataclasses import dataclass
import errno
import fcntl
import math
import os
import signal
import sys
import threading
import time
import tty

import numpy as np

from skin_driver.core import physics
from skin_driver.core.dataset import Dataset, save_dataset
from skin_driver.core.protocol import encode_frame, frame_size, MAX_SEQ
from skin_driver.core.scene import load_scene, Scene

# Below this period frames are written in batches: one wake-up per BATCH_S instead of per frame.
BATCH_S = 0.002
# Further behind than this (a stalled process) the clock skips frames instead of bursting them.
MAX_LAG_S = 0.5


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


def _as_scene(scene) -> Scene:
    return scene if isinstance(scene, Scene) else load_scene(scene)


def _frame_times(index: int, rate_hz: float) -> tuple:
    """Return (device time in us, seconds since start) of the frame with this index."""
    seconds = index / rate_hz
    return int(round(index * 1e6 / rate_hz)), seconds


class SimulatedSkin:
    """A virtual skin board on a pseudo-terminal, streaming frames rendered from a scene."""

    def __init__(self, scene, rate_hz: float = 100.0, link_path: str | None = None,
                 seed: int = 0, loop: bool = False, truth_capacity: int = 10_000):
        """Prepare a board for a Scene (or a bundled scene name or YAML path); start() runs it."""
        self.scene = _as_scene(scene)
        if isinstance(rate_hz, bool) or not isinstance(rate_hz, (int, float)) or not (
                math.isfinite(rate_hz) and 0 < rate_hz <= 20_000):
            raise ValueError(f'rate_hz must be in (0, 20000], got {rate_hz!r}')
        if isinstance(truth_capacity, bool) or not isinstance(truth_capacity, int) \
                or truth_capacity < 1:
            raise ValueError(f'truth_capacity must be a positive integer, got {truth_capacity!r}')
        self.rate_hz = float(rate_hz)
        self.link_path = os.path.abspath(link_path) if link_path else None
        self.loop = bool(loop)
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
        self.frames_sent = 0
        self.frames_dropped = 0

    # ---- public control -------------------------------------------------------------------

    @property
    def port(self) -> str | None:
        """Return the pty slave path while plugged in, else None."""
        return self._port

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
                _point_link(self.link_path, port)
        except BaseException:
            os.close(master)
            os.close(slave)
            raise
        with self._lock:
            self._pending.clear()
            self._frame_ends.clear()
            self._queued_bytes = self._written_bytes = 0
            # The slave stays open here so that a reader may close and reopen the port.
            self._master, self._slave, self._port = master, slave, port

    def _unplug_locked(self) -> None:
        if self._master is None:
            return
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.link_path:
            _remove_link(self.link_path, self._port)
        self._master = self._slave = self._port = None
        self._pending.clear()
        self._frame_ends.clear()
        self._garbage.clear()

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
            self._stop.wait(max(0.0, wake - time.monotonic()))

    def _scene_time(self, seconds: float) -> float:
        duration = self.scene.duration_s
        if self.loop and duration > 0:
            return math.fmod(seconds, duration)
        return seconds

    def _emit(self, index: int) -> None:
        seq = index & MAX_SEQ
        device_time_us, seconds = _frame_times(index, self.rate_hz)
        with self._lock:
            plugged = self._master is not None
            room = len(self._pending) < self._max_pending
        if not (plugged and room):
            self.frames_dropped += 1
            return
        t = self._scene_time(seconds)
        active = self.scene.active_at(t)
        presses = tuple(p for _, p in active)
        top, bottom = physics.render(self.scene.model, presses, self._rng)
        top.flags.writeable = False
        bottom.flags.writeable = False
        raw = encode_frame(seq, device_time_us, top, bottom)
        truth = FrameTruth(seq, device_time_us, top, bottom, presses, t,
                           tuple(i for i, _ in active))
        with self._lock:
            self._remember(truth)
            if self._master is None:
                self.frames_dropped += 1
                return
            for junk in self._garbage:
                self._pending += junk
                self._queued_bytes += len(junk)
            self._garbage.clear()
            self._pending += raw
            self._queued_bytes += len(raw)
            self._frame_ends.append(self._queued_bytes)

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
            while self._frame_ends and self._frame_ends[0] <= self._written_bytes:
                self._frame_ends.popleft()
                self.frames_sent += 1


def _point_link(link: str, target: str) -> None:
    """Atomically make link a symlink to target; never replace anything but a symlink."""
    if os.path.lexists(link) and not os.path.islink(link):
        raise ValueError(f'link path {link!r} exists and is not a symlink; refusing to replace it')
    tmp = f'{link}.tmp{os.getpid()}'
    if os.path.lexists(tmp):
        os.unlink(tmp)
    os.symlink(target, tmp)
    os.replace(tmp, link)


def _remove_link(link: str, target: str | None) -> None:
    """Remove link if it still points at target (as udev removes a by-id link on unplug)."""
    try:
        if os.path.islink(link) and os.readlink(link) == target:
            os.unlink(link)
    except OSError:
        pass


# ---- dataset export -------------------------------------------------------------------------

def render_dataset(scene, seed: int = 0, samples_per_press: int = 1,
                   tare_frames: int = 20) -> Dataset:
    """
    Render a scene offline into an evaluator dataset, one or more samples per press.

    Samples are taken during the hold phase of every press (every repetition), at full force,
    with all presses active at that moment rendered together.  Labels are those of the sampled
    press: azimuth_deg is NaN for a normal press (alpha = 0), where no direction is defined.
    The tare frames are rendered with no press.
    """
    scene = _as_scene(scene)
    for name, value, low in (('samples_per_press', samples_per_press, 1),
                             ('tare_frames', tare_frames, 0)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ValueError(f'{name} must be an integer >= {low}, got {value!r}')
    rng = np.random.default_rng(seed)
    model = scene.model
    maps, labels = [], []
    for k in range(scene.repeat):
        for p in scene.presses:
            hold_start = p.time_s + p.ramp_s
            hold = max(p.duration_s - 2 * p.ramp_s, 0.0)
            for j in range(samples_per_press):
                t = k * scene.period_s + hold_start + hold * (j + 0.5) / samples_per_press
                maps.append(physics.render(model, scene.presses_at(t), rng))
                labels.append(p)
    tare = [physics.render(model, [], rng) for _ in range(tare_frames)]
    # A validated scene has at least one press, so there is at least one sample.
    return Dataset(
        top=np.stack([t for t, _ in maps]), bottom=np.stack([b for _, b in maps]),
        pitch_m=model.pitch_m,
        azimuth_deg=np.array([math.nan if p.alpha_deg == 0 else p.beta_deg % 360.0
                              for p in labels]),
        alpha_deg=np.array([p.alpha_deg for p in labels]),
        force_n=np.array([p.force_n for p in labels]),
        x_m=np.array([p.x_m for p in labels]), y_m=np.array([p.y_m for p in labels]),
        tare_top=np.stack([t for t, _ in tare]) if tare else None,
        tare_bottom=np.stack([b for _, b in tare]) if tare else None)


def export_dataset(scene, path: str, seed: int = 0, samples_per_press: int = 1) -> int:
    """Render a scene offline and save it as an evaluator .npz; return the number of samples."""
    data = render_dataset(scene, seed=seed, samples_per_press=samples_per_press)
    save_dataset(path, data)
    return data.frames


# ---- command line ---------------------------------------------------------------------------

def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='sim', description='Simulated two-layer tactile skin on a pseudo-terminal.')
    parser.add_argument('--scene', default='seed',
                        help='bundled scene name or YAML path (default: seed)')
    parser.add_argument('--rate', type=float, default=100.0, help='frames per second (100)')
    parser.add_argument('--link', default=None, help='make this path a symlink to the port')
    parser.add_argument('--duration', type=float, default=None,
                        help='stop after this many seconds (default: run until Ctrl-C)')
    parser.add_argument('--loop', action='store_true', help='replay the scene when it ends')
    parser.add_argument('--seed', type=int, default=0, help='noise seed (0)')
    parser.add_argument('--export', metavar='OUT.npz', default=None,
                        help='render the scene into a dataset file and exit, without a pty')
    parser.add_argument('--samples-per-press', type=int, default=1,
                        help='dataset samples per press with --export (1)')
    return parser


def main(argv=None) -> int:
    """Run the simulator from the command line; return the process exit status."""
    args = _parser().parse_args(argv)
    try:
        scene = load_scene(args.scene)
        if args.duration is not None and not (math.isfinite(args.duration)
                                              and args.duration >= 0):
            raise ValueError(f'--duration must be a non-negative number, got {args.duration}')
        if args.export:
            n = export_dataset(scene, args.export, seed=args.seed,
                               samples_per_press=args.samples_per_press)
            print(f'sim: wrote {n} samples of scene {scene.name!r} to {args.export}',
                  file=sys.stderr)
            return 0
        skin = SimulatedSkin(scene, rate_hz=args.rate, link_path=args.link, seed=args.seed,
                             loop=args.loop)
        port = skin.start()
    except (ValueError, OSError) as err:
        print(f'sim: error: {err}', file=sys.stderr)
        return 2
    done = threading.Event()

    def _on_signal(signum, frame):
        done.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _on_signal)
    print(f'SKIN_PORT {port}', flush=True)
    model = scene.model
    print(f'sim: scene {scene.name!r} ({scene.duration_s:.1f} s{", looped" if args.loop else ""}'
          f'), {model.rows}x{model.cols} taxels at {args.rate:g} Hz on {skin.port}'
          + (f' (link {port})' if args.link else '') + '; Ctrl-C stops', file=sys.stderr)
    try:
        done.wait(args.duration)
    finally:
        skin.stop()
    print(f'sim: stopped after {skin.frames_sent} frames sent, {skin.frames_dropped} dropped',
          file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
