"""
What the link costs the CPU, counted on the rehosted chip: instructions per scan, by part.

``python -m skin_driver.tools.rehost.cost --usb`` runs the USB image with the port open (the
scripted host reading bulk IN at once) and counts, while it measures only, the instructions the
CPU runs, attributed through the ELF's function symbols:

- ``interrupt``: the OTG FS handler and all it calls (from its entry to its return);
- ``link``: the link's calls from the main loop and all they call (board_link_send,
  board_link_idle, board_link_abort, nucleo_link_poll: over USB tud_task and the CDC write path);
- ``wait``: the loops of board_wait_scan_tick and board_delay_us themselves;
- ``scan``: the rest of the main loop (the rows, the frame, its CRC, the information frame).

The count is of instructions, not cycles, and of the rehost's run: it skips most of each busy
wait (a poll jumps device time to the change it waits for, docs/firmware.md), so ``wait`` and the
link's polls from the waits are far fewer than on silicon, where that time is idle, not cost.
Without ``--usb`` the same for the USART image. A block hook counts (one Python call per basic
block, not per instruction); a stop inside a block (a peripheral access that ends a run) counts
that block's tail twice, a few instructions a stop.
"""

from __future__ import annotations

import argparse
import bisect
from collections import Counter
import sys

import numpy as np
from unicorn import UC_HOOK_BLOCK
from unicorn.arm_const import UC_ARM_REG_LR

from .board import build_nucleo_image, PINS
from .chip import Chip
from .elf import ElfImage
from .usb_host import ScriptedHost
from .wiring import load_wiring

PARTS = ('interrupt', 'link', 'scan', 'wait')
LINK_CALLS = ('board_link_send', 'board_link_idle', 'board_link_abort', 'nucleo_link_poll')
WAITS = ('board_wait_scan_tick', 'board_delay_us')
SCAN_START = 'board_wait_scan_tick'     # entered once a scan
HCLK_HZ = 180e6
CPI = (1.0, 1.5)
EP_IN, ADDRESS = 2, 5


def thumb_instructions(code: bytes) -> int:
    """Return how many Thumb-2 instructions code holds (a 32-bit one starts 0b11101..0b11111)."""
    n = k = 0
    while k + 1 < len(code):
        k += 4 if code[k + 1] >> 3 in (0b11101, 0b11110, 0b11111) else 2
        n += 1
    return n


class InstructionCount:
    """Instructions the chip's CPU runs, by part (PARTS), while installed (a context manager)."""

    def __init__(self, chip: Chip):
        """Attribute chip's instructions by its image's function symbols."""
        self.chip = chip
        functions = chip.image.functions
        self._starts = [f.start for f in functions]
        self._functions = functions
        self._link_entries = {chip.image.address(n) & ~1 for n in LINK_CALLS}
        self._scan_start = chip.image.address(SCAN_START) & ~1
        self._sizes = {}
        self._places = {}           # address: (function, its part in the main loop)
        self._link_return = None    # where the outermost link call returns to
        self._started = False       # counting from the first scan's start, not mid-call
        self._running = Counter()
        self._running_by_function = Counter()
        # Whole scans only, from the first scan's start to the last one's:
        self.counts = Counter()     # part: instructions
        self.by_function = Counter()    # (part, function or None): instructions
        self.scans = 0
        self._hook = None

    def __enter__(self) -> InstructionCount:
        """Start counting."""
        self._hook = self.chip.uc.hook_add(UC_HOOK_BLOCK, self._block)
        self.chip.uc.ctl_flush_tb()     # blocks translated before have no call to the hook
        return self

    def __exit__(self, *exc) -> None:
        """Stop counting (unicorn runs at full speed again)."""
        self.chip.uc.hook_del(self._hook)
        self.chip.uc.ctl_flush_tb()

    def function(self, address: int) -> str | None:
        """Return the name of the function address is in, None outside every one."""
        i = bisect.bisect_right(self._starts, address) - 1
        if i >= 0 and address < self._functions[i].end:
            return self._functions[i].name
        return None

    def _where(self, address: int) -> tuple:
        where = self._places.get(address)
        if where is None:
            name = self.function(address)
            where = self._places[address] = (name, 'wait' if name in WAITS else 'scan')
        return where

    def _add(self, part: str, address: int, n: int) -> None:
        self._running[part] += n
        self._running_by_function[part, self._where(address)[0]] += n

    def _scan_starts(self) -> None:
        if self._started:
            self.scans += 1
            self.counts = Counter(self._running)
            self.by_function = Counter(self._running_by_function)
        self._started = True

    def _block(self, uc, address, size, _user) -> None:
        if address == self._scan_start:
            self._scan_starts()
        if not self._started:
            return
        n = self._sizes.get((address, size))
        if n is None:
            n = self._sizes[address, size] = thumb_instructions(bytes(uc.mem_read(address, size)))
        if self.chip.in_handler:
            self._add('interrupt', address, n)
            return
        if self._link_return is not None:
            if address != self._link_return:
                self._add('link', address, n)
                return
            self._link_return = None
        elif address in self._link_entries:
            self._link_return = uc.reg_read(UC_ARM_REG_LR) & ~1
            self._add('link', address, n)
            return
        self._add(self._where(address)[1], address, n)


def _skin(wiring, scans: int = 8):
    """Return (top, bottom) of an unloaded skin with one taxel pressed, moving scan by scan."""
    top = np.full((scans, wiring.rows, wiring.cols), 100, np.uint16)
    for k in range(scans):
        top[k, k % wiring.rows, (2 * k) % wiring.cols] = 3000
    return top, np.full_like(top, 100)


def measure(usb: bool, scans: int = 100, warmup: int = 20, image: ElfImage | None = None):
    """
    Run the image (the USB one, port open, if usb) for warmup scans, then count scans more.

    Return (InstructionCount, scan rate of the image in Hz).
    """
    image = image or ElfImage.load(build_nucleo_image(usb=usb))
    wiring = load_wiring(PINS, usb=usb)
    chip = Chip(image, wiring, *_skin(wiring), wiring.scan_rate_hz)
    period_s = 1.0 / wiring.scan_rate_hz
    if usb:
        host = ScriptedHost(chip)
        host.open_port(ADDRESS)

        def run(n):
            end = chip.now / 1e9 + n * period_s
            host.bulk_in(EP_IN, lambda packet: None, lambda: chip.now / 1e9 >= end)
    else:
        chip.sink = lambda data: None

        def run(n):
            chip.run(until_s=chip.now / 1e9 + n * period_s, wall_s=120)
    run(warmup)
    count = InstructionCount(chip)
    with count:
        run(scans)
    if chip.errors:
        raise RuntimeError(f'the chip reported: {chip.errors}')
    return count, wiring.scan_rate_hz


def report(count: InstructionCount, rate_hz: int, functions: int = 0) -> str:
    """
    Return the table: instructions per scan by part, and the CPU share at two rates.

    With functions, that many of the costliest (part, function) pairs follow it.
    """
    rates = sorted({rate_hz, 1000})
    head = ['part', 'instructions/scan'] + [f'CPU % at {r}/s (CPI {c:g})' for r in rates
                                            for c in CPI]
    lines = [' | '.join(head)]
    for part in PARTS:
        per = count.counts[part] / max(count.scans, 1)
        shares = [f'{100 * per * c * r / HCLK_HZ:.2f}' for r in rates for c in CPI]
        lines.append(' | '.join([part, f'{per:.0f}'] + shares))
    lines.append(f'({count.scans} scans counted; {HCLK_HZ / 1e6:g} MHz)')
    for (part, name), n in count.by_function.most_common(functions):
        lines.append(f'{part} {name}: {n / max(count.scans, 1):.0f}')
    return '\n'.join(lines)


def main(argv=None) -> int:
    """Command line: print the table for the USB image (--usb) or the USART one."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--usb', action='store_true', help='the USB image, port open')
    parser.add_argument('--scans', type=int, default=100, help='scans counted (100)')
    parser.add_argument('--functions', type=int, default=0, metavar='N',
                        help='also the N costliest functions, per scan, by part')
    args = parser.parse_args(argv)
    count, rate = measure(args.usb, args.scans)
    print(report(count, rate, args.functions))
    return 0


if __name__ == '__main__':
    sys.exit(main())
