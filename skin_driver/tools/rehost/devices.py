"""
The STM32F446's peripherals the Nucleo firmware touches, each from RM0390 (Rev 4).

A device is a 1 kB register block: read(off) and write(off, value) on word offsets, the set of
offsets a firmware polls (``polled``) and, for each, the device time its value changes next
(``next_change``), which lets the chip skip a busy-wait at once (chip.py).
"""

from __future__ import annotations

import struct

from .clock import LSI_HZ

NS = 1_000_000_000


def _ceil_div(a: int, b: int) -> int:
    return -(-a // b)


class Gpio:
    """A GPIO port (RM0390 7.4): mode, output data, set/reset; pins read back as driven."""

    polled = counters = frozenset()
    RESET = {0: (0xA800_0000, 0x0C00_0000, 0x6400_0000), 1: (0x0000_0280, 0x0000_00C0,
                                                             0x0000_0100)}

    def __init__(self, chip, port: int):
        """Reset state of port A..D (RM0390 7.4.1, 7.4.3, 7.4.4: A and B hold the debug pins)."""
        self.chip, self.port = chip, port
        moder, ospeedr, pupdr = self.RESET.get(port, (0, 0, 0))
        self.regs = {0x00: moder, 0x04: 0, 0x08: ospeedr, 0x0C: pupdr, 0x14: 0, 0x1C: 0,
                     0x20: 0, 0x24: 0}

    def level(self, pin: int):
        """Return the level pin drives (0 or 1), or None unless it is a general-purpose output."""
        if (self.regs[0] >> (2 * pin)) & 3 != 1:
            return None
        return (self.regs[0x14] >> pin) & 1

    def read(self, off: int) -> int:
        """Read a register; IDR reads the outputs back (no external driver is modelled)."""
        if off == 0x10:
            return self.regs[0x14]
        if off == 0x18:
            return 0        # BSRR is write-only
        if off not in self.regs:
            self.chip.unmodelled(f'GPIO{"ABCD"[self.port]}', off)
        return self.regs.get(off, 0)

    def next_change(self, off: int):
        """No register of a port changes by itself."""
        return None

    def write(self, off: int, value: int) -> None:
        """Write a register; BSRR sets and resets ODR bits, a set winning (RM0390 7.4.7)."""
        if off == 0x18:
            odr = self.regs[0x14] & ~(value >> 16)
            self.regs[0x14] = (odr | value) & 0xFFFF
            self.chip.mux_changed()
        elif off == 0x14:
            self.regs[0x14] = value & 0xFFFF
            self.chip.mux_changed()
        elif off in self.regs:
            self.regs[off] = value
            if off == 0:
                self.chip.mux_changed()
        else:
            self.chip.unmodelled(f'GPIO{"ABCD"[self.port]}', off)


class Timer:
    """
    TIM2..TIM5, 32-bit up-counting time base (RM0390 17.3.1, 17.4).

    The counter is computed from device time: (time since the last rebase) x the timer clock /
    (PSC + 1), wrapping at ARR + 1 with UIF set. PSC is preloaded and takes effect at an update
    event (UG or overflow, 17.3.1). Interrupts and DMA requests are not modelled (an enable is
    reported as an error).
    """

    polled = frozenset({0x10, 0x24})
    counters = frozenset({0x24})

    def __init__(self, chip, name: str):
        """Reset state: stopped, PSC 0, ARR 0xFFFF_FFFF."""
        self.chip, self.name = chip, name
        self.cr1 = self.sr = self.psc = self.psc_active = 0
        self.arr = 0xFFFF_FFFF
        self.base_t = 0
        self.base_cnt = 0
        self.wraps = 0
        self.hz = 0
        self.div = NS
        self.other = {}

    def _total(self) -> int:
        if not self.cr1 & 1 or not self.hz:
            return self.base_cnt
        return self.base_cnt + (self.chip.now - self.base_t) * self.hz // self.div

    def _sync(self) -> int:
        total = self._total()
        period = self.arr + 1
        if total >= (self.wraps + 1) * period:
            self.wraps = total // period
            self.sr |= 1
            if self.psc != self.psc_active:
                # The preload takes effect at the update event (from now, a tick's error).
                self.psc_active = self.psc
                self._rebase(total % period)
        return total % period

    def _rebase(self, cnt: int) -> None:
        self.base_cnt, self.base_t, self.wraps = cnt, self.chip.now, 0
        self.hz = int(self.chip.rcc.tree.timer_hz(1))
        self.div = (self.psc_active + 1) * NS

    def read(self, off: int) -> int:
        """Read CR1, SR, CNT, PSC, ARR (others as written)."""
        if off == 0x24:
            return self._sync()
        if off == 0x10:
            self._sync()
            return self.sr
        if off == 0x00:
            return self.cr1
        if off == 0x28:
            return self.psc
        if off == 0x2C:
            return self.arr
        return self.other.get(off, 0)

    def next_change(self, off: int):
        """Return when CNT ticks next, or when the next overflow sets UIF."""
        if not self.cr1 & 1 or not self.hz:
            return None
        if off == 0x24:
            target = (self.chip.now - self.base_t) * self.hz // self.div + 1
        else:
            if self.sr & 1:
                return None
            target = (self.wraps + 1) * (self.arr + 1) - self.base_cnt
        return self.base_t + _ceil_div(target * self.div, self.hz)

    def write(self, off: int, value: int) -> None:
        """Write a register: start/stop, UG, rc_w0 SR, CNT, PSC, ARR."""
        if off == 0x00:
            cnt = self._sync()
            was = self.cr1 & 1
            self.cr1 = value & 0x3FF
            if self.cr1 & 1 and not was:
                self.chip.timer_started(self)
            self._rebase(cnt)
        elif off == 0x10:
            self._sync()
            self.sr &= value
        elif off == 0x14:
            if value & 1:
                self.psc_active = self.psc
                self._rebase(0)
                if not self.cr1 & 4:     # URS = 0: UG sets UIF too
                    self.sr |= 1
        elif off == 0x24:
            self._rebase(value)
        elif off == 0x28:
            self.psc = value & 0xFFFF
        elif off == 0x2C:
            cnt = self._sync()
            self.arr = value
            self._rebase(cnt % (self.arr + 1))
        else:
            if off == 0x0C and value:
                self.chip.error(f'{self.name}_DIER {value:#x}: timer interrupts and DMA are not '
                                'modelled')
            self.other[off] = value


class Adc:
    """
    ADC1, ADC2, ADC3 and their common registers (RM0390 13.9, 13.13).

    Only what the firmware uses is converted: triple regular simultaneous mode (ADC_CCR MULTI =
    10110, 13.9.2) started by ADC1's SWSTART, each ADC converting its sequence (SQR1..3, L) one
    rank at the same instant, a rank taking (sampling + 12) ADC clock cycles (13.5), and DMA
    mode 1 (13.9, "DMA requests in dual or triple ADC modes"): one half-word per request, in
    the order ADC1, ADC2, ADC3, ADC1, ... The results go to DMA2 Stream 0 in one transfer. An
    overrun (13.8.1 and 13.9) sets OVR and stops the multi-ADC DMA requests until the flags
    are cleared.
    """

    polled = frozenset({0x000, 0x100, 0x200})
    counters = frozenset()
    CDR = 0x4001_2308
    CYCLES = (3, 15, 28, 56, 84, 112, 144, 480)   # SMPx codes (13.13.4, 13.13.5)

    def __init__(self, chip):
        """Reset state of the three ADCs and the common registers."""
        self.chip = chip
        self.regs = [dict.fromkeys(range(0, 0x50, 4), 0) for _ in range(3)]
        self.ccr = 0
        self.on_at = [None, None, None]
        self.cdr = 0
        self.plan = None            # the checked conversion set-up, until a register changes

    def clock_hz(self) -> float:
        """Return ADCCLK: PCLK2 / (2, 4, 6, 8) by ADC_CCR ADCPRE (13.13.16)."""
        return self.chip.rcc.tree.pclk2_hz / (2 * (((self.ccr >> 16) & 3) + 1))

    def read(self, off: int) -> int:
        """Read an ADC's register or a common one."""
        adc, reg = off >> 8, off & 0xFF
        if adc == 3:
            return {0x00: self._csr(), 0x04: self.ccr, 0x08: self.cdr}.get(reg, 0)
        return self.regs[adc].get(reg, 0)

    def _csr(self) -> int:
        # ADC_CSR (13.13.15) mirrors each ADC's SR flags, 8 bits apart.
        return sum((self.regs[i][0] & 0x3F) << (8 * i) for i in range(3))

    def next_change(self, off: int):
        """Return None: the flags change only when the firmware starts a conversion."""
        return None

    def write(self, off: int, value: int) -> None:
        """Write a register; ADC1's SWSTART starts the triple conversion."""
        adc, reg = off >> 8, off & 0xFF
        chip = self.chip
        if reg != 0x00 and (reg != 0x08 or adc == 3 or
                            (value & ~(1 << 30)) != self.regs[adc][8]):
            self.plan = None            # a start alone keeps the checked set-up
        if adc == 3:
            if reg == 0x04:
                self.ccr = value
                adc_hz = self.clock_hz()
                chip.rcc.tree.adc_hz = adc_hz
                if adc_hz > 36e6:
                    chip.error(f'ADC clock {adc_hz / 1e6:g} MHz over 36 MHz (datasheet)')
                if not value & 0xC000:
                    for r in self.regs:
                        r[0] &= ~0x20
            else:
                chip.unmodelled('ADC common', reg)
            return
        regs = self.regs[adc]
        if reg == 0x00:
            regs[0] &= value            # rc_w0 flags
        elif reg == 0x08:
            if value & 1 and not regs[8] & 1:
                self.on_at[adc] = chip.now
            regs[8] = value & ~(1 << 30)
            if value & (1 << 30):
                if adc == 0:
                    self._start()
                else:
                    chip.error(f'SWSTART on ADC{adc + 1}: the slaves start from ADC1 in '
                               'multi-ADC mode (RM0390 13.9)')
        elif reg in regs:
            regs[reg] = value
        else:
            chip.unmodelled(f'ADC{adc + 1}', reg)

    def _sequence(self, adc: int) -> list:
        r = self.regs[adc]
        length = ((r[0x2C] >> 20) & 0xF) + 1
        sq = [r[0x34], r[0x30], r[0x2C]]
        return [(sq[k // 6] >> (5 * (k % 6))) & 0x1F for k in range(length)]

    def _sample_cycles(self, adc: int, ch: int) -> int:
        r = self.regs[adc]
        smpr = r[0x10] if ch < 10 else r[0x0C]
        return self.CYCLES[(smpr >> (3 * (ch % 10))) & 7]

    def _plan(self):
        """Check the set-up against the manual; return (sequences, rank time) or None."""
        chip = self.chip
        if self.ccr & 0x1F != 0b10110:
            chip.error(f'ADC_CCR MULTI {self.ccr & 0x1F:#07b}: only triple regular simultaneous '
                       'mode (10110) is modelled')
            return None
        if self.ccr & 0xC000 != 0x4000:
            chip.error('ADC_CCR DMA is not mode 1: only DMA mode 1 is modelled')
            return None
        for i in range(3):
            if not self.regs[i][8] & 1:
                chip.error(f'ADC{i + 1} started with ADON clear')
                return None
        seqs = [self._sequence(i) for i in range(3)]
        if len({len(s) for s in seqs}) != 1:
            chip.error(f'sequences of unequal length {[len(s) for s in seqs]} in simultaneous '
                       'mode (RM0390 13.9)')
            return None
        cycles = set()
        for rank, chans in enumerate(zip(*seqs)):
            if len(set(chans)) != 3:
                chip.error(f'rank {rank + 1} converts one channel on two ADCs at once '
                           '(RM0390 13.9 forbids it)')
            cycles.update(self._sample_cycles(i, ch) for i, ch in enumerate(chans))
        if len(cycles) != 1:
            chip.error(f'unequal sampling times {sorted(cycles)} break the lock step')
        rank_ns = (max(cycles) + 12) * NS / self.clock_hz()
        order = [ch for chans in zip(*seqs) for ch in chans]     # ADC1, ADC2, ADC3 per rank
        return order, rank_ns

    def _start(self) -> None:
        chip = self.chip
        if self.plan is None:
            self.plan = self._plan() or ()
        if not self.plan:
            return
        order, rank_ns = self.plan
        for i in range(3):
            if chip.now - self.on_at[i] < 3_000:
                chip.error(f'ADC{i + 1} started before tSTAB (3 us) after ADON')
        counts = chip.sample(order)
        now = chip.now
        times = [now + int((k // 3 + 1) * rank_ns) for k in range(len(counts))]
        for i in range(3):
            self.regs[i][0] |= 0x12                   # STRT, EOC
            self.regs[i][0x4C] = counts[len(counts) - 3 + i]
        if self.regs[0][0] & 0x20 or self.regs[1][0] & 0x20 or self.regs[2][0] & 0x20:
            return                                    # OVR stops the requests until cleared
        done = chip.dma2.peripheral_request(0, 0, counts, times, self.CDR, 2)
        if chip.faults.adc_overrun_row is not None and chip.faults_active() and \
                chip.selected_row() == tuple(chip.faults.adc_overrun_row):
            done = min(done, 3)
            chip.stats['adc_overruns'] += 1
        if done < len(counts):
            self.regs[0][0] |= 0x20                   # ADC1 OVR: the data was not read in time
            chip.stats['adc_ovr_set'] += 1
            chip.dma2.cancel(0, done)


class Dma:
    """
    A DMA controller's interrupt status/clear registers and eight streams (RM0390 9.3, 9.5).

    A transfer is done in bulk when its peripheral asks (the ADC's results, the USART's bytes);
    its flags (TCIF, HTIF) and the stream's EN clear at the device time of the last item.
    Direct mode only (FIFO and double buffer report an error).
    """

    polled = frozenset({0x00, 0x04})
    counters = frozenset()
    SHIFT = (0, 6, 16, 22)
    TCIF, HTIF, TEIF = 0x20, 0x10, 0x08

    def __init__(self, chip, name: str):
        """Reset state: every stream off."""
        self.chip, self.name = chip, name
        self.isr = [0, 0]
        self.streams = [dict.fromkeys((0, 4, 8, 0xC, 0x10, 0x14), 0) for _ in range(8)]
        for s in self.streams:
            s[0x14] = 0x21
        self.pending = {}          # stream -> (device time, flags)
        self.pointer = [0] * 8

    def _settle(self) -> None:
        now = self.chip.now
        for s, (at, flags) in list(self.pending.items()):
            if at <= now:
                self.isr[s // 4] |= flags << self.SHIFT[s % 4]
                self.streams[s][0] &= ~1
                del self.pending[s]
                if s == 7 and self is self.chip.dma2:
                    self.chip.stats['tx_dma_completed'] += 1

    def read(self, off: int) -> int:
        """Read LISR/HISR or a stream register, completions as of now."""
        self._settle()
        if off < 8:
            return self.isr[off // 4]
        if off < 0x10:
            return 0
        s, reg = divmod(off - 0x10, 0x18)
        return self.streams[s].get(reg, 0)

    def next_change(self, off: int):
        """Return when the next flag of LISR (streams 0..3) or HISR (4..7) sets."""
        times = [at for s, (at, _) in self.pending.items() if s // 4 == off // 4]
        return min(times) if times else None

    def write(self, off: int, value: int) -> None:
        """Clear flags, configure a stream, enable or disable it."""
        self._settle()
        if off in (0x08, 0x0C):
            self.isr[(off - 8) // 4] &= ~value
            return
        if off < 0x10 or off >= 0x10 + 8 * 0x18:
            self.chip.unmodelled(self.name, off)
            return
        s, reg = divmod(off - 0x10, 0x18)
        stream = self.streams[s]
        if reg == 0:
            was = stream[0] & 1
            stream[0] = value
            if value & 1 and not was:
                if value & (1 << 18) or value & (1 << 8):
                    self.chip.error(f'{self.name} stream {s}: double buffer or circular mode '
                                    'is not modelled')
                self.pointer[s] = stream[0xC]
                self.chip.dma_enabled(self, s)
            elif was and not value & 1:
                self.pending.pop(s, None)
        elif stream[0] & 1:
            self.chip.error(f'{self.name} stream {s} register {reg:#x} written while enabled '
                            '(RM0390 9.5.5: ignored)')
        else:
            if reg == 0x14 and value & 4:
                self.chip.error(f'{self.name} stream {s}: FIFO mode is not modelled')
            stream[reg] = value

    def peripheral_request(self, s: int, channel: int, items, times, par: int,
                           size: int) -> int:
        """
        Serve a peripheral's requests with items (one each, at times); return how many it took.

        The stream must be enabled, on channel, from par, peripheral to memory, with size-byte
        items on both sides; it takes at most NDTR items and completes at the last one.
        """
        stream = self.streams[s]
        cr = stream[0]
        if not cr & 1:
            return 0
        want = (channel << 25) | ((size >> 1) << 11) | ((size >> 1) << 13) | (1 << 10)
        got = cr & ((7 << 25) | (3 << 11) | (3 << 13) | (1 << 10) | (3 << 6))
        if got != want or stream[8] != par:
            self.chip.error(f'{self.name} stream {s} set up as CR {cr:#x} PAR {stream[8]:#x}; '
                            f'this request needs channel {channel}, {size}-byte items, memory '
                            f'increment, peripheral to memory from {par:#x}')
            return 0
        n = min(stream[4], len(items))
        fmt = '<%d%s' % (n, 'H' if size == 2 else 'B')
        self.chip.uc.mem_write(self.pointer[s], struct.pack(fmt, *items[:n]))
        self.pointer[s] += n * size
        stream[4] -= n
        if stream[4] == 0 and n:
            self.pending[s] = (times[n - 1], self.TCIF | self.HTIF)
        return n

    def cancel(self, s: int, done: int) -> None:
        """Stop serving a peripheral that stopped asking: the stream waits, no flag sets."""
        self.pending.pop(s, None)

    def memory_to_peripheral(self, s: int, channel: int, par: int):
        """Return the bytes an enabled stream would send to par, or None (wrong set-up)."""
        stream = self.streams[s]
        cr = stream[0]
        want = (channel << 25) | (1 << 10) | (1 << 6)
        got = cr & ((7 << 25) | (3 << 11) | (3 << 13) | (1 << 10) | (3 << 6))
        if got != want or stream[8] != par:
            self.chip.error(f'{self.name} stream {s} set up as CR {cr:#x} PAR {stream[8]:#x}; '
                            f'the USART needs channel {channel}, bytes, memory increment, '
                            f'memory to peripheral to {par:#x}')
            return None
        return bytes(self.chip.uc.mem_read(self.pointer[s], stream[4]))

    def complete_at(self, s: int, at: int) -> None:
        """Finish stream s's transfer at device time at (NDTR to 0, TCIF and HTIF set)."""
        self.streams[s][4] = 0
        self.pending[s] = (at, self.TCIF | self.HTIF)


class Usart:
    """
    USART1 transmitting (RM0390 25.3.2, 25.3.4, 25.6).

    The baud rate from BRR and PCLK2,
    a byte's time on the line (start, 8 or 9 data bits, stop bits), TXE and TC, and the
    transmit DMA (DMA2 Stream 7 channel 4, 25.3.13: TCIF when the DMA has written the last
    byte). Reception is not modelled.
    """

    polled = frozenset({0x00})
    counters = frozenset()
    DR = 0x4001_1004

    def __init__(self, chip):
        """Reset state: SR 0x00C0 (TXE, TC)."""
        self.chip = chip
        self.regs = {0x00: 0xC0, 0x04: 0, 0x08: 0, 0x0C: 0, 0x10: 0, 0x14: 0, 0x18: 0}
        self.txe_at = self.tc_at = 0

    def baud(self) -> float:
        """Return the rate BRR gives at the present PCLK2 (25.3.4), 0 when BRR is 0."""
        brr = self.regs[8]
        if self.regs[0x0C] & (1 << 15):
            div = ((brr >> 4) << 3) | (brr & 7)    # OVER8: the fraction's bit 3 is unused
        else:
            div = brr
        return self.chip.rcc.tree.pclk2_hz / div if div else 0.0

    def byte_ns(self) -> int:
        """Return a character's time on the line."""
        bits = 1 + (9 if self.regs[0x0C] & (1 << 12) else 8) + \
            {0: 1, 1: 0.5, 2: 2, 3: 1.5}[(self.regs[0x10] >> 12) & 3]
        baud = self.baud()
        return int(bits * NS / baud) if baud else NS

    def read(self, off: int) -> int:
        """Read SR (TXE and TC as of now) or another register."""
        if off == 0:
            now = self.chip.now
            sr = self.regs[0] & ~0xC0
            sr |= (0x80 if now >= self.txe_at else 0) | (0x40 if now >= self.tc_at else 0)
            return sr
        return self.regs.get(off, 0)

    def next_change(self, off: int):
        """Return when TXE or TC sets next."""
        now = self.chip.now
        later = [t for t in (self.txe_at, self.tc_at) if t > now]
        return min(later) if later else None

    def _ready(self) -> bool:
        cr1 = self.regs[0x0C]
        return bool(cr1 & (1 << 13) and cr1 & (1 << 3))

    def _check_baud(self) -> None:
        want, got = self.chip.host_baud, self.baud()
        if got and abs(got - want) > 0.02 * want:
            self.chip.error(f'USART1 at {got:.0f} baud, the host reads {want}: the bytes would be '
                            'garbled')

    def write(self, off: int, value: int) -> None:
        """Write a register; a DR write sends one byte."""
        if off == 0x04:
            if self._ready():
                self._check_baud()
                now = self.chip.now
                start = max(now, self.txe_at)
                self.txe_at = start + 1
                self.tc_at = max(start, self.tc_at) + self.byte_ns()
                self.chip.send(bytes([value & 0xFF]))
            return
        if off == 0:
            self.regs[0] &= value | ~0x360
            return
        if off == 0x14 and value & ~0x80:
            self.chip.error(f'USART1_CR3 {value:#x}: only DMAT is modelled')
        if off == 0x0C and value & 0x1F0:
            self.chip.error(f'USART1_CR1 {value:#x}: USART interrupts are not modelled')
        self.regs[off] = value

    def dma_transmit(self, dma: Dma, s: int) -> None:
        """Send what an enabled DMA stream holds: the bytes at once, its TCIF in line time."""
        chip = self.chip
        if not self.regs[0x14] & 0x80 or not self._ready():
            chip.error('DMA2 stream 7 enabled while USART1 does not request it (UE, TE, DMAT)')
            return
        data = dma.memory_to_peripheral(s, 4, self.DR)
        if data is None:
            return
        chip.stats['tx_dma_started'] += 1
        if chip.faults_active() and chip.faults.tx_dma_stuck:
            return                                # no request is ever served: no byte, no flag
        self._check_baud()
        now, byte = chip.now, self.byte_ns()
        # The DMA's last write to DR comes once the byte before it moved to the shift register.
        dma.complete_at(s, now + max(len(data) - 1, 0) * byte + 1)
        self.txe_at = now + max(len(data) - 1, 0) * byte + 1
        self.tc_at = now + len(data) * byte
        chip.send(data)


def _crc_table() -> list:
    table = []
    for i in range(256):
        c = i << 24
        for _ in range(8):
            c = ((c << 1) ^ 0x04C1_1DB7) if c & 0x8000_0000 else c << 1
        table.append(c & 0xFFFF_FFFF)
    return table


class Crc:
    """The CRC calculation unit (RM0390 4.3, 4.4): CRC-32 0x04C11DB7, MSB first, 32-bit words."""

    polled = counters = frozenset()
    TABLE = _crc_table()

    def __init__(self, chip):
        """Reset state: DR 0xFFFF_FFFF."""
        self.chip = chip
        self.crc = 0xFFFF_FFFF
        self.idr = 0

    def read(self, off: int) -> int:
        """Read DR (the CRC so far), IDR or CR."""
        return {0x00: self.crc, 0x04: self.idr}.get(off, 0)

    def next_change(self, off: int):
        """Return None: the unit holds the bus until a word is done."""
        return None

    def write(self, off: int, value: int) -> None:
        """Feed a word (DR), keep a byte (IDR) or reset (CR)."""
        if off == 0x00:
            crc, table = self.crc ^ value, self.TABLE
            for _ in range(4):
                crc = ((crc << 8) & 0xFFFF_FFFF) ^ table[crc >> 24]
            self.crc = crc
        elif off == 0x04:
            self.idr = value & 0xFF
        elif off == 0x08 and value & 1:
            self.crc = 0xFFFF_FFFF


class Iwdg:
    """
    The independent watchdog (RM0390 20.3, 20.4).

    Started by 0xCCCC, reloaded by 0xAAAA, PR and
    RLR written after 0x5555; counting down from RLR at LSI (32 kHz) / (4 << PR); at zero it
    resets the chip (RCC_CSR IWDGRSTF).
    """

    polled = frozenset({0x0C})
    counters = frozenset()

    def __init__(self, chip):
        """Reset state: stopped, PR 0, RLR 0xFFF, locked."""
        self.chip = chip
        self.pr, self.rlr = 0, 0xFFF
        self.unlocked = False
        self.expires_at = None

    def timeout_ns(self) -> int:
        """Return the time from a reload to the reset."""
        return (self.rlr + 1) * (4 << min(self.pr, 6)) * NS // LSI_HZ

    def read(self, off: int) -> int:
        """Read PR, RLR; SR reads 0 (updates are done at once)."""
        return {0x04: self.pr, 0x08: self.rlr}.get(off, 0)

    def next_change(self, off: int):
        """SR never changes here."""
        return None

    def write(self, off: int, value: int) -> None:
        """Write a key (KR) or, unlocked, PR or RLR."""
        if off == 0x00:
            key = value & 0xFFFF
            if key == 0xCCCC or (key == 0xAAAA and self.expires_at is not None):
                self.expires_at = self.chip.now + self.timeout_ns()
                self.chip.watchdog_set(self.expires_at)
            self.unlocked = key == 0x5555
        elif self.unlocked and off == 0x04:
            self.pr = value & 7
        elif self.unlocked and off == 0x08:
            self.rlr = value & 0xFFF


class SystemControl:
    """
    The Cortex-M4's system control space at 0xE000E000 (ARM v7-M ARM B3.2, B3.4).

    CPACR, VTOR, AIRCR (a SYSRESETREQ resets the chip), CPUID, and the NVIC's set-enable and
    clear-enable registers for the interrupts a model raises (``DELIVERED``: the chip takes
    them, chip.py); enabling any other interrupt, or SysTick's, is reported: nothing raises it.
    """

    polled = frozenset({0x010})
    counters = frozenset()
    CPUID = 0x410F_C241
    DELIVERED = 1 << 67     # OTG_FS (otg.py)

    def __init__(self, chip):
        """Reset state: every interrupt disabled."""
        self.chip = chip
        self.regs = {}
        self.enabled = 0    # bit n: interrupt n enabled

    def read(self, off: int) -> int:
        """Read a register (CPUID fixed; ISER and ICER read the enabled set)."""
        if off == 0xD00:
            return self.CPUID
        if 0x100 <= off < 0x120 or 0x180 <= off < 0x1A0:
            return self.enabled >> (8 * (off & 0x1F)) & 0xFFFF_FFFF
        return self.regs.get(off, 0)

    def next_change(self, off: int):
        """Return None: SysTick is not counted."""
        return None

    def write(self, off: int, value: int) -> None:
        """Write a register; AIRCR with its key and SYSRESETREQ resets the chip."""
        if off == 0xD0C and value >> 16 == 0x05FA and value & 4:
            self.chip.request_reset(0x1000_0000)     # RCC_CSR SFTRSTF
            return
        if 0x100 <= off < 0x120 or 0x180 <= off < 0x1A0:
            irqs = value << (8 * (off & 0x1F))
            if off < 0x180:
                for n in range(irqs.bit_length()):
                    if irqs >> n & 1 and not self.DELIVERED >> n & 1:
                        self.chip.error(f'interrupt {n} enabled: no model raises it')
                self.enabled |= irqs
            else:
                self.enabled &= ~irqs
            # An enable is no register a poll reads (TinyUSB masks its interrupt around each
            # look at its queue, in the loop that waits for the scan tick): it does not end a
            # poll. Whether an interrupt is now taken is the chip's (irq_changed).
            self.chip.writes -= 1
            self.chip.irq_changed()
            return
        if off == 0x010 and value & 2:
            self.chip.error(f'{0xE000E000 + off:#x} <- {value:#x}: SysTick is not counted, '
                            'its interrupt never comes')
        self.regs[off] = value
