"""
The STM32F446RE: unicorn's Cortex-M4 running the image, the peripherals on its bus, device time.

Device time advances by a fixed cost per peripheral access (ACCESS_CYCLES of the CPU clock: the
code between two accesses) and by the waits the firmware polls for. A read of a status or
counter register that returns what the last read of it returned, with no peripheral write in
between, is a poll: device time jumps at once to when that register changes next (a DMA's
completion, a timer's overflow, a ready flag), or for a counter to its next tick, growing by an
eighth of the time the poll has lasted (so a long wait on a counter takes few reads). Only the
peripheral pages are hooked (unicorn's MMIO regions), so code and RAM run at JIT speed.

The CPU is stopped only from inside a peripheral access (device time reached, a reset, the
wall-time bound, a stop request), and unicorn then restarts the instruction that made the
access when it runs on: the chip answers that replay as before, without a second effect (a
second ADC start, a CRC word fed twice). Bytes leave through ``sink`` from inside the access.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
import struct
import time

import numpy as np
from unicorn import arm_const as arm
from unicorn import Uc, UC_ARCH_ARM, UC_MODE_MCLASS, UC_MODE_THUMB, UC_PROT_EXEC, UC_PROT_READ
from unicorn import UcError
from unicorn.arm_const import UC_ARM_REG_MSP, UC_ARM_REG_PC, UC_ARM_REG_SP, UC_CPU_ARM_CORTEX_M4
from unicorn.unicorn_py3 import unicorn as binding

from . import clock, devices, otg
from .elf import ElfImage
from .wiring import Wiring

FLASH = (0x0800_0000, 512 * 1024)      # RM0390 2.2.2, memory map
SRAM = (0x2000_0000, 128 * 1024)       # SRAM1 112 kB + SRAM2 16 kB, contiguous
SYSTEM = (0x1FFF_0000, 0x8000)         # system memory and the OTP/signature area
UID_ADDR = 0x1FFF_7A10                 # RM0390 34.1
FLASH_SIZE_ADDR = 0x1FFF_7A22          # RM0390 34.2
# Where an interrupt handler returns to: a page no firmware address reaches (F446 has nothing at
# 0x1000_0000), fetch only; reaching it ends the handler (see _enter_irq).
RETURN_PAGE = 0x1000_0000
DEFAULT_UID = bytes.fromhex('3900_1e00_0b51_3834_3939_3134'.replace('_', ''))

ACCESS_CYCLES = 12      # CPU cycles counted per peripheral access (the code around it)
IDLE_POLL_CYCLES = 10   # a poll of a flag nothing will change: one loop iteration
CHECK_MASK = 1023       # every 1024 accesses, a look at the wall clock and the stop request
MAX_ERRORS = 50


class ChipError(RuntimeError):
    """The emulated CPU stopped: an access to no memory or an instruction it cannot run."""


@dataclass
class Faults:
    """
    Fault switches of the models, all off by default.

    Each takes effect from device time ``from_s`` on, except ``hse_absent``, which is the
    board's state from power-on.
    """

    tx_dma_stuck: bool = False        # DMA2 Stream 7 never serves USART1: no byte, no TCIF7
    adc_overrun_row: tuple | None = None   # (layer, row): the ADCs overrun on that row
    hse_absent: bool = False          # no MCO from the ST-LINK: HSERDY never sets
    host_not_reading: bool = False    # the host drains nothing: the bytes are dropped
    mux_stuck_channel: int | None = None   # both muxes select this input, whatever S0..S3 say
    from_s: float = 0.0


class Chip:
    """The microcontroller with the image in its flash, wired to a skin that plays scans."""

    def __init__(self, image: ElfImage, wiring: Wiring, top: np.ndarray, bottom: np.ndarray,
                 scan_rate_hz: float, faults: Faults | None = None, uid: bytes = DEFAULT_UID,
                 host_baud: int | None = None):
        """
        Load image and reset; top and bottom are (scans, rows, cols) counts of the skin.

        The skin shows scan floor(t * scan_rate_hz) (looped) at device time t since the
        firmware started TIM2, the clock it stamps frames with.
        """
        if top.shape != bottom.shape or top.shape[1:] != (wiring.rows, wiring.cols):
            raise ValueError(f'scans of shape {top.shape} and {bottom.shape} do not fit the '
                             f'{wiring.rows}x{wiring.cols} wiring')
        self.image, self.wiring = image, wiring
        self.scans = (np.ascontiguousarray(top, np.uint16), np.ascontiguousarray(bottom,
                                                                                 np.uint16))
        self.scan_rate_hz = scan_rate_hz
        self.faults = faults or Faults()
        self.host_baud = host_baud or wiring.baud
        self.now = 0
        self.writes = 0
        self.errors: list = []
        self.stats = Counter()
        self.tx = bytearray()
        self.sink = None            # called with the bytes USART1 sends; else they gather in tx
        self.time_origin = None
        self.stop_at = float('inf')
        self._halting = False
        self._replay = None
        self._accesses = 0
        self._deadline = None
        self._stop = None
        self.failure = None         # an exception in an access callback, raised by run()
        self.reset_pending = 0
        self.watchdog_at = None
        self._replay = None
        self._polls = {}
        self._mux = None
        self._column_cache = {}
        self._fault_ns = int(self.faults.from_s * 1e9)
        self.irq_lines = 0          # bit n: interrupt line n high (the models drive them)
        self._irq_wanted = False    # a line is high, enabled, and no handler runs
        self._handler = None        # the interrupted context while a handler runs
        self.uc = Uc(UC_ARCH_ARM, UC_MODE_THUMB | UC_MODE_MCLASS)
        self.uc.ctl_set_cpu_model(UC_CPU_ARM_CORTEX_M4)
        self.uc.mem_map(*FLASH)
        self.uc.mem_map(*SRAM)
        self.uc.mem_map(*SYSTEM, UC_PROT_READ)
        self.uc.mem_map(RETURN_PAGE, 0x1000, UC_PROT_EXEC | UC_PROT_READ)
        self.uc.mem_write(RETURN_PAGE, b'\xfe\xe7' * 0x800)     # b . (never run: the stop)
        for seg in image.segments:
            if not FLASH[0] <= seg.paddr < FLASH[0] + FLASH[1] - len(seg.data) + 1:
                raise ValueError(f'segment at {seg.paddr:#x} is not in the flash: not an image '
                                 'for this chip')
            self.uc.mem_write(seg.paddr, seg.data)
        self.uc.mem_write(UID_ADDR, bytes(uid))
        self.uc.mem_write(FLASH_SIZE_ADDR, struct.pack('<H', FLASH[1] // 1024))
        self._blocks = {}
        self._make_devices()
        self._map_peripherals()
        self.rcc.regs[0x74] = clock.CSR_POWER_ON
        self.set_cpu_clock(clock.HSI_HZ)
        self._reset_cpu()

    # ---- set-up ---------------------------------------------------------------------------

    def _make_devices(self) -> None:
        self.rcc, self.pwr, self.flash = clock.Rcc(self), clock.Pwr(self), clock.Flash(self)
        self.gpio = [devices.Gpio(self, p) for p in range(4)]
        self.tim2, self.tim5 = devices.Timer(self, 'TIM2'), devices.Timer(self, 'TIM5')
        self.adc = devices.Adc(self)
        self.dma1, self.dma2 = devices.Dma(self, 'DMA1'), devices.Dma(self, 'DMA2')
        self.usart1 = devices.Usart(self)
        self.crc = devices.Crc(self)
        self.iwdg = devices.Iwdg(self)
        self.scb = devices.SystemControl(self)
        self.otg = otg.OtgFs(self)
        self.irq_lines = 0
        self._irq_wanted = False
        # RM0390 2.2.2 (register boundary addresses) and the enable bits of 6.3.10..6.3.14
        ahb1, ahb2, apb1, apb2 = 0x30, 0x34, 0x40, 0x44
        table = [(0x4000_0000, self.tim2, (apb1, 0)), (0x4000_0C00, self.tim5, (apb1, 3)),
                 (0x4000_3000, self.iwdg, None), (0x4000_7000, self.pwr, (apb1, 28)),
                 (0x4001_1000, self.usart1, (apb2, 4)), (0x4001_2000, self.adc, (apb2, 8)),
                 (0x4002_3000, self.crc, (ahb1, 12)), (0x4002_3800, self.rcc, None),
                 (0x4002_3C00, self.flash, None), (0x4002_6000, self.dma1, (ahb1, 21)),
                 (0x4002_6400, self.dma2, (ahb1, 22))]
        table += [(0x4002_0000 + 0x400 * p, g, (ahb1, p)) for p, g in enumerate(self.gpio)]
        self._blocks.clear()
        for base, dev, gate in table:
            self._blocks[base >> 10] = (dev, base, gate)
        for k in range(4):
            self._blocks[(0xE000_E000 >> 10) + k] = (self.scb, 0xE000_E000, None)
        # OTG_FS (31.15): core and device registers, power and clock gating, the endpoint
        # FIFOs; the host registers (0x400..0x7FF) are left out: device mode only.
        for k in (0, 2, 3) + tuple(range(4, 4 * (otg.ENDPOINTS + 1))):
            self._blocks[(0x5000_0000 >> 10) + k] = (self.otg, 0x5000_0000, (ahb2, 7))

    def _map_peripherals(self) -> None:
        """Map the peripheral pages to the models, straight through ctypes where possible."""
        pages = sorted({key << 10 & ~0xFFF for key in self._blocks})
        lib, handle = getattr(binding, 'uclib', None), getattr(self.uc, '_uch', None)
        read_type = getattr(binding, 'MMIO_READ_CFUNC', None)
        write_type = getattr(binding, 'MMIO_WRITE_CFUNC', None)
        if None in (lib, handle, read_type, write_type):
            for page in pages:
                self.uc.mmio_map(page, 0x1000, self._read, page, self._write, page)
            return
        # The binding's own callbacks add two Python frames to each of ~1 200 accesses a
        # scan; these call the chip directly and stop the CPU on an exception as it does.

        def read(_handle, offset, size, page):
            try:
                return self._read(self.uc, offset, size, page)
            except BaseException as err:  # noqa: B902 - re-raised by run()
                self.failure = self.failure or err
                self.uc.emu_stop()
                return 0

        def write(_handle, offset, size, value, page):
            try:
                self._write(self.uc, offset, size, value, page)
            except BaseException as err:  # noqa: B902 - re-raised by run()
                self.failure = self.failure or err
                self.uc.emu_stop()

        self._callbacks = (read_type(read), write_type(write))
        for page in pages:
            status = lib.uc_mmio_map(handle, page, 0x1000, self._callbacks[0], page,
                                     self._callbacks[1], page)
            if status:
                raise UcError(status)

    def _reset_cpu(self) -> None:
        sp, pc = struct.unpack('<II', self.uc.mem_read(FLASH[0], 8))
        self.uc.reg_write(UC_ARM_REG_MSP, sp)
        self.uc.reg_write(UC_ARM_REG_SP, sp)
        self.pc = pc

    def set_cpu_clock(self, hz: float) -> None:
        """Take the CPU's clock for the cost of an access and of an idle poll."""
        self.cycle_ns = 1e9 / hz
        self.access_ns = max(1, round(ACCESS_CYCLES * self.cycle_ns))
        self.idle_ns = max(1, round(IDLE_POLL_CYCLES * self.cycle_ns))

    # ---- the bus ----------------------------------------------------------------------------

    def _refused(self, addr: int, entry) -> None:
        """Report an access to no peripheral, or to one whose clock is off."""
        if entry is None:
            self.error(f'access to {addr:#010x}: no peripheral is modelled there')
            return
        dev, base, gate = entry
        self.error(f'{type(dev).__name__} at {base:#x} accessed with its clock off '
                   f'(RCC register {gate[0]:#x} bit {gate[1]}): reads 0, writes ignored')

    # The two callbacks below are the hot path (about 1 200 calls a scan): kept flat.

    def _read(self, uc, offset, size, page):
        addr = page + offset
        if self._replay is not None:
            replay, self._replay = self._replay, None
            if replay[0] == addr:
                return replay[1]
        self.now += self.access_ns
        entry = self._blocks.get(addr >> 10)
        gate = entry and entry[2]
        if entry is None or (gate and not self.rcc.regs[gate[0]] >> gate[1] & 1):
            self._refused(addr, entry)
            value = 0
        else:
            dev = entry[0]
            off = addr - entry[1]
            word = off & ~3
            value = dev.read(word)
            if word in dev.polled:
                prev = self._polls.get(addr)
                if prev is not None and prev[0] == self.writes and prev[1] == value:
                    self._skip(dev, word, prev[2])
                    value = dev.read(word)
                    self._polls[addr] = (self.writes, value,
                                         prev[2] if value == prev[1] else self.now)
                else:
                    self._polls[addr] = (self.writes, value, self.now)
            if size < 4:
                value = (value >> (8 * (off & 3))) & ((1 << (8 * size)) - 1)
            value &= 0xFFFF_FFFF
        self._accesses += 1
        if self._halting or self._irq_wanted or self.now >= self.stop_at or \
                not self._accesses & CHECK_MASK:
            self._end(uc, addr, value)
        return value

    def _write(self, uc, offset, size, value, page):
        addr = page + offset
        if self._replay is not None:
            replay, self._replay = self._replay, None
            if replay[0] == addr:
                return
        self.now += self.access_ns
        self.writes += 1
        entry = self._blocks.get(addr >> 10)
        gate = entry and entry[2]
        if entry is None or (gate and not self.rcc.regs[gate[0]] >> gate[1] & 1):
            self._refused(addr, entry)
        else:
            dev = entry[0]
            off = addr - entry[1]
            if size < 4:
                if getattr(dev, 'word_only', False):
                    self.error(f'{size}-byte write to {addr:#010x}: this block takes words only')
                    return
                shift = 8 * (off & 3)
                mask = ((1 << (8 * size)) - 1) << shift
                off &= ~3
                value = (dev.read(off) & ~mask) | ((value << shift) & mask)
            dev.write(off, value & 0xFFFF_FFFF)
        self._accesses += 1
        if self._halting or self._irq_wanted or self.now >= self.stop_at or \
                not self._accesses & CHECK_MASK:
            self._end(uc, addr, None)

    def _end(self, uc, addr: int, value) -> None:
        """Stop the CPU after this access if asked, remembering the access for its replay."""
        if self.now >= self.stop_at or (self._irq_wanted and self._irq_unmasked()):
            self._halting = True
        if not self._accesses & CHECK_MASK and (
                (self._stop is not None and self._stop()) or
                (self._deadline is not None and time.monotonic() >= self._deadline)):
            self._halting = True
        if self._halting:
            self._halting = False
            self._replay = (addr, value)
            uc.emu_stop()

    def _skip(self, dev, word: int, since: int) -> None:
        """Move device time past a poll: to when the register changes, or by an idle step."""
        at = dev.next_change(word)
        if at is None:
            at = self.now + self.idle_ns
        if word in dev.counters:
            at = max(at, self.now + (self.now - since) // 8)
        self.advance_to(at)

    def advance_to(self, at: int) -> None:
        """Let device time reach at (a watchdog due by then resets the chip)."""
        if at > self.now:
            self.now = at
        if self.watchdog_at is not None and self.now >= self.watchdog_at:
            self.watchdog_at = None
            self.request_reset(clock.CSR_IWDG)
        if self.now >= self.stop_at:
            self._halting = True

    # ---- what the devices ask of the chip -----------------------------------------------

    def error(self, text: str) -> None:
        """Record a mistake of the firmware against the manual (or a model's limit), once."""
        if text not in self.errors and len(self.errors) < MAX_ERRORS:
            self.errors.append(text)

    def unmodelled(self, device: str, off: int) -> None:
        """Record an access to a register no model has."""
        self.error(f'{device} register at offset {off:#x} is not modelled')

    def faults_active(self) -> bool:
        """Return whether the fault switches are in effect (device time past from_s)."""
        return self.now >= self._fault_ns

    def timer_started(self, timer) -> None:
        """Note TIM2's first start: the origin of the skin's scans."""
        if timer is self.tim2 and self.time_origin is None:
            self.time_origin = self.now

    def mux_changed(self) -> None:
        """Forget the selected row (a GPIO changed)."""
        self._mux = None

    def selected_row(self):
        """Return (layer, row) the two muxes connect to the columns, or None (none or both)."""
        if self._mux is None:
            self._mux = (self._select(),)
        return self._mux[0]

    def _level(self, pin: int):
        return self.gpio[pin // 16].level(pin % 16)

    def _select(self):
        w = self.wiring
        active = 0 if w.enable_active_low else 1
        levels = [self._level(p) for p in w.enable_pins]
        on = [layer for layer in (0, 1) if levels[layer] == active]
        if len(on) != 1:
            if len(on) == 2:
                self.error("both layers' muxes enabled at once: two rows on the columns")
            return None
        bits = [self._level(p) for p in w.addr_pins]
        if None in bits:
            self.error('a mux address line is not an output while a mux is enabled')
            return None
        channel = sum(b << i for i, b in enumerate(bits))
        if self.faults.mux_stuck_channel is not None and self.faults_active():
            channel = self.faults.mux_stuck_channel
            self.stats['mux_stuck_samples'] += 1
        row = w.channel_row[on[0]].get(channel)
        return None if row is None else (on[0], row)

    def scan_index(self) -> int:
        """Return which of the skin's scans the columns show now."""
        t = self.now - (self.time_origin or 0)
        return int(t * self.scan_rate_hz // 1_000_000_000) % len(self.scans[0])

    def sample(self, channels) -> list:
        """Return the counts of the channels (ADC1, ADC2, ADC3 per rank) of the selected row."""
        where = self.selected_row()
        if where is None:
            return [0] * len(channels)
        layer, row = where
        values = self.scans[layer][self.scan_index()][row]
        self.stats['rows_sampled'] += 1
        # An input no column is wired to reads 0 (the last entry of the padded row).
        return np.append(values, 0)[self._columns(tuple(channels))].tolist()

    def _columns(self, channels: tuple):
        cols = self._column_cache.get(channels)
        if cols is None:
            column = self.wiring.channel_column
            cols = np.array([column.get(ch, self.wiring.cols) for ch in channels])
            self._column_cache[channels] = cols
        return cols

    def dma_enabled(self, dma, s: int) -> None:
        """Start what an enabled stream serves: the USART's stream sends at once."""
        if dma is self.dma2 and s == 7:
            self.usart1.dma_transmit(dma, s)

    def send(self, data: bytes) -> None:
        """Bytes leave on USART1's TX: to the host, or dropped while it reads nothing."""
        if self.faults.host_not_reading and self.faults_active():
            self.stats['bytes_dropped'] += len(data)
            return
        self.stats['bytes_sent'] += len(data)
        if self.sink is not None:
            self.sink(data)
        else:
            self.tx += data

    def set_irq(self, n: int, level: bool) -> None:
        """Drive interrupt line n (level-sensitive: it stays pending while high)."""
        self.irq_lines = self.irq_lines | 1 << n if level else self.irq_lines & ~(1 << n)
        self.irq_changed()

    def irq_changed(self) -> None:
        """Recompute whether an interrupt waits to be taken (a line or an enable changed)."""
        self._irq_wanted = self._handler is None and bool(self.irq_lines & self.scb.enabled)

    def _irq_unmasked(self) -> bool:
        return not self.uc.reg_read(arm.UC_ARM_REG_PRIMASK) & 1

    def request_stop(self) -> None:
        """Stop the CPU after the access in progress (run() then asks its stop())."""
        self._halting = True

    def watchdog_set(self, at: int) -> None:
        """Note that the IWDG resets the chip at device time at unless reloaded before."""
        self.watchdog_at = at

    def request_reset(self, csr_flag: int) -> None:
        """Reset the chip once the CPU stops (a watchdog or a software reset)."""
        self.reset_pending |= csr_flag
        self._halting = True

    def _system_reset(self) -> None:
        # RM0390 6.1.2: a system reset sets the registers to their reset values except the
        # reset flags in RCC_CSR; SRAM keeps its content.
        csr = self.rcc.regs[0x74] | self.reset_pending
        self.reset_pending = 0
        self.watchdog_at = None
        self._replay = None
        self._handler = None
        self._polls.clear()
        self._mux = None
        self._make_devices()
        self.rcc.regs[0x74] = csr | clock.CSR_PIN
        self.set_cpu_clock(clock.HSI_HZ)
        self.stats['resets'] += 1
        self._reset_cpu()

    # ---- running --------------------------------------------------------------------------

    def run(self, until_s: float | None = None, wall_s: float | None = None,
            stop=None) -> None:
        """Run until device time until_s, wall time wall_s has passed, or stop() is true."""
        self._deadline = None if wall_s is None else time.monotonic() + wall_s
        self._stop = stop
        self.stop_at = float('inf') if until_s is None else int(until_s * 1e9)
        while True:
            if self._irq_wanted and self._irq_unmasked():
                self._enter_irq()
            try:
                self.uc.emu_start(self.pc | 1, RETURN_PAGE)
            except UcError as err:
                pc = self.uc.reg_read(UC_ARM_REG_PC)
                raise ChipError(f'the CPU stopped at pc {pc:#x}: {err}') from err
            self.pc = self.uc.reg_read(UC_ARM_REG_PC)
            if self.pc & ~1 == RETURN_PAGE and self._handler is not None:
                self._return_from_irq()
            if self.failure is not None:
                failure, self.failure = self.failure, None
                raise failure
            if self.reset_pending:
                self._system_reset()
                continue
            if self.now >= self.stop_at or (stop is not None and stop()):
                return
            if self._deadline is not None and time.monotonic() >= self._deadline:
                return

    # ---- interrupts -------------------------------------------------------------------------
    # unicorn has no NVIC: the chip takes an interrupt itself between two runs of the CPU, as
    # the v7-M exception entry does (ARM v7-M ARM B1.5.6): the eight-word frame pushed on the
    # stack (aligned to 8 bytes), the handler from the vector table at VTOR, LR a return
    # address. The handler's return branches there, where unicorn stops, and the frame is
    # popped (B1.5.8). The CPU stops for an interrupt only at a peripheral access, like every
    # stop, so an interrupt raised meanwhile waits for the next access: where the firmware
    # spins on RAM alone (none of its waits do) it would wait. The floating-point context
    # (S0..S15, FPSCR) is kept aside as lazy stacking would keep it; priorities and nesting
    # are not modelled (one handler at a time), nor are IPSR and the handler mode.

    FRAME = ('R0', 'R1', 'R2', 'R3', 'R12', 'LR', 'PC', 'XPSR')

    def _enter_irq(self) -> None:
        pending = self.irq_lines & self.scb.enabled
        n = (pending & -pending).bit_length() - 1       # the lowest number first
        uc = self.uc
        regs = [uc.reg_read(getattr(arm, f'UC_ARM_REG_{r}')) for r in self.FRAME]
        regs[6] = self.pc
        sp = uc.reg_read(UC_ARM_REG_SP)
        align = sp & 4
        sp = (sp - 32) & ~7
        regs[7] = regs[7] & ~(1 << 9) | (align << 7)       # xPSR bit 9: the alignment pad
        uc.mem_write(sp, struct.pack('<8I', *regs))
        uc.reg_write(UC_ARM_REG_SP, sp)
        fp = [uc.reg_read(getattr(arm, f'UC_ARM_REG_S{k}')) for k in range(16)]
        fp.append(uc.reg_read(arm.UC_ARM_REG_FPSCR))
        self._handler = (n, self._replay, fp)
        self._replay = None
        self._irq_wanted = False
        uc.reg_write(arm.UC_ARM_REG_LR, RETURN_PAGE | 1)
        vtor = self.scb.regs.get(0xD08, 0)
        if vtor < FLASH[1]:
            vtor += FLASH[0]        # booted from flash: it is aliased at 0 (RM0390 2.4)
        self.pc = struct.unpack('<I', uc.mem_read(vtor + 4 * (16 + n), 4))[0] & ~1
        self.stats[f'irq{n}'] += 1

    def _return_from_irq(self) -> None:
        uc = self.uc
        n, replay, fp = self._handler
        sp = uc.reg_read(UC_ARM_REG_SP)
        regs = struct.unpack('<8I', uc.mem_read(sp, 32))
        for name, value in zip(self.FRAME, regs):
            if name != 'PC':
                uc.reg_write(getattr(arm, f'UC_ARM_REG_{name}'), value)
        for k, value in enumerate(fp[:16]):
            uc.reg_write(getattr(arm, f'UC_ARM_REG_S{k}'), value)
        uc.reg_write(arm.UC_ARM_REG_FPSCR, fp[16])
        uc.reg_write(UC_ARM_REG_SP, sp + 32 + (4 if regs[7] & (1 << 9) else 0))
        self.pc = regs[6]
        self._replay = replay
        self._handler = None
        self.irq_changed()

    @property
    def in_handler(self) -> bool:
        """Whether the CPU runs an interrupt handler (between its entry and its return)."""
        return self._handler is not None

    def halt(self) -> None:
        """Stop the CPU for good from another thread (a replayed access is not guarded)."""
        self.uc.emu_stop()

    def debug_write(self, addr: int, value: int) -> None:
        """Write a peripheral register as a debugger would (SWD), between two runs."""
        self._write(self.uc, addr & 0xFFF, 4, value, addr & ~0xFFF)
        self._replay = None

    def debug_read(self, addr: int) -> int:
        """Read a peripheral register as a debugger would (SWD), between two runs."""
        value = self._read(self.uc, addr & 0xFFF, 4, addr & ~0xFFF)
        self._replay = None
        return value

    def take_tx(self) -> bytes:
        """Return and forget the bytes sent since the last call."""
        data = bytes(self.tx)
        self.tx.clear()
        return data

    def symbol_u32(self, name: str) -> int:
        """Return the 32-bit word at the image's symbol name (a counter, a fault code)."""
        return struct.unpack('<I', self.uc.mem_read(self.image.address(name), 4))[0]

    def clock_report(self) -> dict:
        """Return the clock tree the firmware set up, in MHz, with the limits it breaks."""
        t = self.rcc.tree
        return {'source': t.source, 'sysclk_mhz': t.sysclk_hz / 1e6, 'hclk_mhz': t.hclk_hz / 1e6,
                'apb1_mhz': t.pclk1_hz / 1e6, 'apb2_mhz': t.pclk2_hz / 1e6,
                'vco_in_mhz': t.vco_in_hz / 1e6, 'vco_mhz': t.vco_hz / 1e6,
                'overdrive': t.overdrive, 'flash_wait_states': t.flash_wait_states,
                'adc_mhz': t.adc_hz / 1e6, 'baud': self.usart1.baud(),
                'violations': list(t.violations)}
