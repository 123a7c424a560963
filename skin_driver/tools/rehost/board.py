"""
The rehosted board on a pty, as the driver sees a real one.

``python -m skin_driver.tools.rehost --scene demo --link /tmp/skin0`` builds the Nucleo image if
needed, renders the scene at the firmware's scan rate, runs the image and prints
``SKIN_PORT <path>`` on stdout and ``SKIN_EPOCH <wall-clock time of device time 0>`` on stderr,
as the simulator and the QEMU board do. ROS-free.

By default the board keeps to wall time (a board at 80 scans/s sends 80 frames a second) and
drops what the pty cannot take, as a USB host that stops reading would. ``realtime=False``
(``--fast``) runs as fast as the emulation goes and waits for the reader instead: what tests use.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
from pathlib import Path
import select
import sys
import threading
import time
import tty

from skin_driver.core.sim.scene import load_scene
from skin_driver.tools import firmware_board
from skin_driver.tools.sim import stop_on_signal

from .chip import Chip, DEFAULT_UID, Faults
from .elf import ElfImage
from .wiring import load_wiring

IMAGE = firmware_board.ARM_BUILD / 'boards' / 'nucleo_f446re' / 'skin_fw_nucleo_f446re.elf'
USB_IMAGE = IMAGE.with_name('skin_fw_nucleo_f446re_usb.elf')
PINS = firmware_board.FIRMWARE_DIR / 'boards' / 'nucleo_f446re' / 'skin_board_pins.h'
# How far device time may run ahead of wall time before a real-time board sleeps.
AHEAD_S = 0.005


def build_nucleo_image(usb: bool = False) -> Path:
    """Cross-build the Nucleo-F446RE image (as ``make firmware`` does); return the ELF's path."""
    image = USB_IMAGE if usb else IMAGE
    firmware_board._cmake(
        firmware_board.ARM_BUILD,
        f'-DCMAKE_TOOLCHAIN_FILE={firmware_board.FIRMWARE_DIR / "cmake" / "arm-none-eabi.cmake"}',
        '-DCMAKE_BUILD_TYPE=MinSizeRel', target=image.stem)
    return image


class RehostBoard:
    """The Nucleo image on the emulated chip in a thread, its USART1 on a pty."""

    def __init__(self, image, top, bottom, link_path: str | None = None,
                 faults: Faults | None = None, realtime: bool = True, pins=PINS,
                 uid: bytes = DEFAULT_UID):
        """
        Prepare a board; image is an ELF path or an ElfImage.

        top and bottom, (scans, rows, cols) counts, are what the skin shows, one scan per
        period of the firmware's scan rate (looped).
        """
        self.image = image if isinstance(image, ElfImage) else ElfImage.load(image)
        self.wiring = load_wiring(pins)
        self.chip = Chip(self.image, self.wiring, top, bottom, self.wiring.scan_rate_hz,
                         faults=faults, uid=uid)
        self.link_path = os.path.abspath(link_path) if link_path else None
        self.realtime = realtime
        self.port: str | None = None
        self.failure: BaseException | None = None
        self.dropped = 0
        self._master = self._slave = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._start_mono = 0.0
        self._start_wall = 0.0

    @property
    def epoch(self) -> float | None:
        """Return the wall-clock time of the frames' device time 0, once TIM2 has started."""
        if self.chip.time_origin is None:
            return None
        return self._start_wall + self.chip.time_origin / 1e9

    def start(self) -> str:
        """Open the pty and start the chip; return the port (the link if one was asked)."""
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.port = os.ttyname(self._slave)
        if self.link_path:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.link_path)
            os.symlink(self.port, self.link_path)
        self._start_mono, self._start_wall = time.monotonic(), time.time()
        self._thread = threading.Thread(target=self._run, name='rehost-chip', daemon=True)
        self._thread.start()
        return self.link_path or self.port

    def _run(self) -> None:
        try:
            self.chip.sink = self._send
            self.chip.run(stop=self._stop.is_set)
        except BaseException as err:  # noqa: B902 - reported by running() and stop()
            self.failure = err

    def _send(self, data: bytes) -> None:
        self._write(data)
        with contextlib.suppress(OSError):
            os.read(self._master, 65536)       # what the host sends: no receiver is modelled
        if self.realtime:
            ahead = self.chip.now / 1e9 - (time.monotonic() - self._start_mono)
            if ahead > AHEAD_S:
                self._stop.wait(min(ahead, 0.2))

    def _write(self, data: bytes) -> None:
        while data and not self._stop.is_set():
            try:
                data = data[os.write(self._master, data):]
            except BlockingIOError:
                if self.realtime:
                    self.dropped += len(data)   # a host that does not read loses them
                    return
                select.select([], [self._master], [], 0.1)
            except OSError as err:
                if err.errno != errno.EIO:
                    raise
                return

    def running(self) -> bool:
        """Return whether the chip still runs (it stops on a fault of the emulation)."""
        return self._thread is not None and self._thread.is_alive()

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop the chip, close the pty and remove the link."""
        self._stop.set()
        if self._thread is not None:
            self.chip.halt()
            self._thread.join(timeout_s)
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None
        if self.link_path and os.path.islink(self.link_path):
            os.unlink(self.link_path)

    def __enter__(self) -> RehostBoard:
        """Start the board."""
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        """Stop the board."""
        self.stop()


def _layer_row(text: str) -> tuple:
    layer, row = (int(v) for v in text.split(','))
    return layer, row


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='rehost',
        description='The unmodified Nucleo-F446RE image on an emulated STM32F446 (unicorn) '
                    'with a simulator scene on its ADCs, its USART on a pty.')
    parser.add_argument('--scene', default='seed', help='bundled scene or scene YAML (seed)')
    parser.add_argument('--scans', type=int, default=None,
                        help='scans the skin plays, looped (default: one pass of the scene at '
                             "the firmware's scan rate)")
    parser.add_argument('--link', default=None, help='make this path a symlink to the port')
    parser.add_argument('--noise-seed', type=int, default=0, help='noise seed (0)')
    parser.add_argument('--image', default=None,
                        help='ELF to run (default: build the Nucleo image)')
    parser.add_argument('--fast', action='store_true',
                        help='run as fast as the emulation goes, waiting for the reader')
    faults = parser.add_argument_group('fault injection (docs/firmware.md)')
    faults.add_argument('--fault-tx-dma-stuck', action='store_true',
                        help='DMA2 Stream 7 never serves USART1 (no byte, no TCIF7)')
    faults.add_argument('--fault-adc-overrun', type=_layer_row, metavar='LAYER,ROW',
                        help='the ADCs overrun while that row is sampled')
    faults.add_argument('--fault-hse-absent', action='store_true',
                        help='no 8 MHz clock from the ST-LINK: HSERDY never sets')
    faults.add_argument('--fault-host-not-reading', action='store_true',
                        help='the host drains nothing: the bytes sent are dropped')
    faults.add_argument('--fault-mux-stuck', type=int, metavar='INPUT',
                        help='both muxes select this input (0..15) whatever S0..S3 say')
    faults.add_argument('--fault-from', type=float, default=0.0, metavar='S',
                        help='device time the faults start at (0)')
    return parser


def faults_from_args(args) -> Faults:
    """Return the fault switches the command line asks for."""
    return Faults(tx_dma_stuck=args.fault_tx_dma_stuck, adc_overrun_row=args.fault_adc_overrun,
                  hse_absent=args.fault_hse_absent, host_not_reading=args.fault_host_not_reading,
                  mux_stuck_channel=args.fault_mux_stuck, from_s=args.fault_from)


def main(argv=None) -> int:
    """Run the rehosted board until SIGINT or SIGTERM; return the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if '--ros-args' in argv:
        argv = argv[:argv.index('--ros-args')]
    args = _parser().parse_args(argv)
    done = stop_on_signal()
    try:
        if args.scans is not None and args.scans < 1:
            raise ValueError(f'--scans must be 1 or more, got {args.scans}')
        if args.fault_mux_stuck is not None and not 0 <= args.fault_mux_stuck <= 15:
            raise ValueError(f'--fault-mux-stuck must be 0..15, got {args.fault_mux_stuck}')
        scene = load_scene(args.scene)
        rate = load_wiring(PINS).scan_rate_hz
        count = args.scans or max(1, round(scene.duration_s * rate))
        if args.image is None:
            missing = firmware_board.missing_tools(qemu=False)
            if missing:
                raise RuntimeError(f'missing {", ".join(missing)} to build the image '
                                   '(tools/setup-firmware.sh installs them)')
        image = args.image or build_nucleo_image()
        top, bottom = firmware_board.render_scans(scene, count, rate, args.noise_seed)
        board = RehostBoard(image, top, bottom, args.link, faults_from_args(args),
                            realtime=not args.fast)
    except (ValueError, OSError, RuntimeError) as err:
        print(f'rehost: error: {err}', file=sys.stderr)
        return 2
    port = board.start()
    try:
        print(f'SKIN_PORT {port}', flush=True)
        while board.epoch is None and board.running() and not done.wait(0.01):
            pass
        if board.epoch is not None:
            print(f'SKIN_EPOCH {board.epoch:.6f}', file=sys.stderr, flush=True)
            print(f'rehost: clock {board.chip.clock_report()}', file=sys.stderr, flush=True)
        print(f'rehost: scene {scene.name!r}, {count} scans at {rate} Hz on {board.port}; '
              'Ctrl-C stops', file=sys.stderr, flush=True)
        while not done.wait(0.2) and board.running():
            pass
    finally:
        board.stop()
    for text in board.chip.errors:
        print(f'rehost: model: {text}', file=sys.stderr)
    if board.failure is not None:
        print(f'rehost: the chip stopped: {board.failure}', file=sys.stderr)
        return 1
    return 0
