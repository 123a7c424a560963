"""
The emulated firmware board: the firmware (firmware/) on QEMU's netduinoplus2, on a pty.

It streams on a pseudo-terminal like the real board, its "ADC" fed with scans of a simulator
scene.

``python -m skin_driver.tools.firmware_board --scene demo --rate 100 --link /tmp/skin0`` builds
the image if needed, renders the scene into the scan file the board reads over semihosting,
starts QEMU and prints ``SKIN_PORT <path>`` on stdout and ``SKIN_EPOCH <wall-clock time of
device time 0>`` on stderr, as the simulator does (skin_driver.tools.sim). ROS-free.

The board sends the scan of its present device time: scan i of the file covers i / rate to
(i + 1) / rate seconds after start-up (the file looped), so the scene's time is the device time
even when the emulation cannot keep up with the rate (it then skips scans of the file, as a slow
board samples less often, while its sequence numbers still count every frame). QEMU drops what it
writes while no reader has the port open, as a USB board's host would.

The scan file (format 1, little-endian): ``SKNS``, u8 1, u8 rows, u8 cols, u8 0, u32 scan rate in
Hz, u32 scans, then per scan the top then the bottom counts as u16, row-major.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import fcntl
import os
from pathlib import Path
import re
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

from skin_driver.core.sim import physics
from skin_driver.core.sim.scene import load_scene, Scene
from skin_driver.tools.sim import stop_on_signal

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE_DIR = Path(os.environ.get('SKIN_FW_DIR') or ROOT / 'firmware')
BUILD_DIR = Path(os.environ.get('SKIN_FW_BUILD_DIR') or ROOT / 'build')
HOST_BUILD = BUILD_DIR / 'fw-host'
ARM_BUILD = BUILD_DIR / 'fw-arm'
QEMU = 'qemu-system-arm'
ARM_GCC = 'arm-none-eabi-gcc'
SCAN_FILE = 'scans.bin'
SCAN_HEADER = struct.Struct('<4sBBBBII')
# The grid the emulated board is built for (firmware/boards/qemu_netduinoplus2/skin_fw_config.h).
QEMU_GRID = (16, 16)
_PTY = re.compile(r'char device redirected to (\S+) \(label serial0\)')
PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    # QEMU runs in a session of its own (a Ctrl-C is for its owner, who stops it); should the
    # owner be killed outright, QEMU goes with it instead of streaming on forever.
    if sys.platform.startswith('linux'):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def missing_tools(qemu: bool = True) -> list:
    """Return the programs the firmware build (and with qemu, its emulation) needs but lacks."""
    tools = ['cmake', 'cc'] + ([ARM_GCC, QEMU] if qemu else [])
    return [t for t in tools if shutil.which(t) is None]


@contextlib.contextmanager
def _build_lock():
    """Serialise builds: parallel test workers share one build tree."""
    BUILD_DIR.mkdir(parents=True, exist_ok=True)
    with open(BUILD_DIR / '.fw-build.lock', 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


def _cmake(build: Path, *configure: str, target: str | None = None) -> None:
    if not (FIRMWARE_DIR / 'CMakeLists.txt').exists():
        raise RuntimeError(f'no firmware sources at {FIRMWARE_DIR} (set SKIN_FW_DIR)')
    with _build_lock():
        if not (build / 'CMakeCache.txt').exists():
            _run(['cmake', '-S', str(FIRMWARE_DIR), '-B', str(build), *configure])
        _run(['cmake', '--build', str(build)] + (['--target', target] if target else []))


def _run(argv: list) -> None:
    done = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if done.returncode:
        raise RuntimeError(f'{" ".join(argv)} failed:\n{done.stdout[-4000:]}')


def build_frame_dump() -> Path:
    """Build the host program that makes frames with the firmware core; return its path."""
    _cmake(HOST_BUILD, target='frame_dump')
    return HOST_BUILD / 'tests' / 'frame_dump'


def build_board_dump() -> Path:
    """Build the host program that runs the firmware's loop at given times; return its path."""
    _cmake(HOST_BUILD, target='board_dump')
    return HOST_BUILD / 'tests' / 'board_dump'


def build_image(protocol: int = 2) -> Path:
    """
    Cross-build the emulated board's image; return the ELF's path.

    It sends protocol version ``protocol``: 2, or 1 (built in a build tree of its own).
    """
    if protocol not in (1, 2):
        raise ValueError(f'protocol must be 1 or 2, got {protocol!r}')
    build = ARM_BUILD if protocol == 2 else BUILD_DIR / 'fw-arm-v1'
    _cmake(build, f'-DCMAKE_TOOLCHAIN_FILE={FIRMWARE_DIR / "cmake" / "arm-none-eabi.cmake"}',
           '-DCMAKE_BUILD_TYPE=MinSizeRel', f'-DSKIN_FW_PROTOCOL={protocol}', target='skin_qemu')
    return build / 'boards' / 'qemu_netduinoplus2' / 'skin_qemu.elf'


def render_scans(scene: Scene, count: int, rate_hz: float, noise_seed: int = 0) -> tuple:
    """
    Return (top, bottom), each (count, rows, cols) uint16: the scene scanned at rate_hz.

    As the simulator renders a scan (SimulatedSkin): scan i at scene time i / rate_hz (past the
    scene's end, the unloaded skin), one noise generator for the run.
    """
    rng = np.random.default_rng(noise_seed)
    rows, cols = scene.model.rows, scene.model.cols
    top = np.empty((count, rows, cols), np.uint16)
    bottom = np.empty_like(top)
    for i in range(count):
        presses = tuple(p for _, p in scene.active_at(i / rate_hz))
        top[i], bottom[i] = physics.render(scene.model, presses, rng)
    return top, bottom


def write_scans(path, top: np.ndarray, bottom: np.ndarray, rate_hz: float) -> None:
    """Write scans (count, rows, cols each) in the emulated board's scan-file format."""
    count, rows, cols = top.shape
    if bottom.shape != top.shape or count < 1:
        raise ValueError(f'top and bottom must be the same non-empty stacks, got {top.shape} '
                         f'and {bottom.shape}')
    if (rows, cols) != QEMU_GRID:
        raise ValueError(f'the emulated board is built for {QEMU_GRID[0]}x{QEMU_GRID[1]}, '
                         f'not {rows}x{cols}')
    counts = np.stack([top, bottom], axis=1).astype('<u2')
    with open(path, 'wb') as f:
        f.write(SCAN_HEADER.pack(b'SKNS', 1, rows, cols, 0, int(round(rate_hz)), count))
        f.write(counts.tobytes())


class QemuBoard:
    """The firmware image on qemu-system-arm, reading workdir/scans.bin, its USART1 on a pty."""

    def __init__(self, image, workdir, link_path: str | None = None):
        """Prepare a board; the scan file must be at workdir/scans.bin before start()."""
        self.image = Path(image)
        self.workdir = Path(workdir)
        self.link_path = os.path.abspath(link_path) if link_path else None
        self.process: subprocess.Popen | None = None
        self.port: str | None = None
        self.epoch = 0.0
        self.lines: list = []
        self._reader: threading.Thread | None = None

    def start(self, timeout_s: float = 10.0) -> str:
        """Start QEMU; return the port path (the link if one was asked)."""
        argv = [QEMU, '-M', 'netduinoplus2', '-display', 'none', '-monitor', 'none',
                '-serial', 'pty', '-semihosting-config', 'enable=on,target=native',
                '-kernel', str(self.image)]
        # The board's clock starts with the machine: close enough to device time 0.
        self.epoch = time.time()
        self.process = subprocess.Popen(argv, cwd=self.workdir, stdin=subprocess.DEVNULL,
                                        stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True,
                                        start_new_session=True,
                                        preexec_fn=_die_with_parent)
        found = threading.Event()

        def read():
            for line in self.process.stdout:
                self.lines.append(line)
                match = _PTY.search(line)
                if match:
                    self.port = match.group(1)
                    found.set()
            found.set()

        self._reader = threading.Thread(target=read, name='qemu-output', daemon=True)
        self._reader.start()
        found.wait(timeout_s)
        if self.port is None:
            self.stop()
            raise RuntimeError(f'{QEMU} did not open its serial port: {"".join(self.lines)}')
        if self.link_path:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.link_path)
            os.symlink(self.port, self.link_path)
        return self.link_path or self.port

    def running(self) -> bool:
        """Return whether QEMU still runs (the firmware stops it on a bad scan file)."""
        return self.process is not None and self.process.poll() is None

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop QEMU and remove the link."""
        if self.process is not None and self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            try:
                self.process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        if self._reader is not None:
            self._reader.join(2.0)
        if self.link_path and os.path.islink(self.link_path):
            os.unlink(self.link_path)

    def __enter__(self) -> QemuBoard:
        """Start the board."""
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        """Stop the board."""
        self.stop()


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='firmware_board',
        description='The skin firmware on an emulated STM32 (QEMU) fed with a simulator scene.')
    parser.add_argument('--scene', default='seed', help='bundled scene or scene YAML (seed)')
    parser.add_argument('--rate', type=float, default=100.0, help='scans per second (100)')
    parser.add_argument('--scans', type=int, default=None,
                        help='scans in the file the board loops (default: one pass of the scene)')
    parser.add_argument('--link', default=None, help='make this path a symlink to the port')
    parser.add_argument('--noise-seed', type=int, default=0, help='noise seed (0)')
    parser.add_argument('--protocol', type=int, choices=(1, 2), default=2,
                        help='wire protocol version the image sends (2; 1 is built apart)')
    return parser


def main(argv=None) -> int:
    """Run the emulated board until SIGINT or SIGTERM; return the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if '--ros-args' in argv:
        argv = argv[:argv.index('--ros-args')]
    args = _parser().parse_args(argv)
    missing = missing_tools()
    if missing:
        print(f'firmware_board: missing {", ".join(missing)} (tools/setup-firmware.sh installs '
              'them)', file=sys.stderr)
        return 2
    # From here a stop request ends the run quietly, also while the image builds.
    done = stop_on_signal()
    try:
        scene = load_scene(args.scene)
        if not 1.0 <= args.rate <= 100_000.0:
            raise ValueError(f'--rate must be 1 to 100000, got {args.rate}')
        if args.scans is not None and args.scans < 1:
            raise ValueError(f'--scans must be 1 or more, got {args.scans}')
        if args.noise_seed < 0:
            raise ValueError(f'--noise-seed must be 0 or more, got {args.noise_seed}')
        if (scene.model.rows, scene.model.cols) != QEMU_GRID:
            raise ValueError(f'the emulated board is built for {QEMU_GRID[0]}x{QEMU_GRID[1]}, '
                             f'the scene has {scene.model.rows}x{scene.model.cols}')
        count = args.scans or max(1, round(scene.duration_s * args.rate))
        image = build_image(args.protocol)
        top, bottom = render_scans(scene, count, args.rate, args.noise_seed)
    except (ValueError, OSError, RuntimeError) as err:
        print(f'firmware_board: error: {err}', file=sys.stderr)
        return 2
    if done.is_set():
        return 0
    with tempfile.TemporaryDirectory(prefix='skin_qemu_') as workdir:
        write_scans(os.path.join(workdir, SCAN_FILE), top, bottom, args.rate)
        board = QemuBoard(image, workdir, args.link)
        try:
            port = board.start()
        except RuntimeError as err:
            print(f'firmware_board: error: {err}', file=sys.stderr)
            return 2
        print(f'SKIN_PORT {port}', flush=True)
        print(f'SKIN_EPOCH {board.epoch:.6f}', file=sys.stderr, flush=True)
        print(f'firmware_board: scene {scene.name!r}, {count} scans at {args.rate:g} Hz on '
              f'{board.port}; Ctrl-C stops', file=sys.stderr, flush=True)
        try:
            while not done.wait(0.2) and board.running():
                pass
        finally:
            board.stop()
        if not done.is_set():
            print(f'firmware_board: QEMU stopped: {"".join(board.lines[-5:])}', file=sys.stderr)
            return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
