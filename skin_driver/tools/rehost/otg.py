"""
The STM32F446's OTG FS core in device mode, as far as TinyUSB's DWC2 driver uses it.

RM0390 Rev 4, chapter 31, "USB on-the-go full-speed/high-speed (OTG_FS/OTG_HS)"; and the
cable's other end: the tokens a host sends (``host_*``), for the scripted host (usb_host.py).

Modelled: core soft reset and AHB idle, the FIFO flushes, device mode with the internal FS PHY
(OTG_GCCFG PWRDWN, VBUS sensing off and the B-session override), the soft disconnect, the bus
reset and the end of enumeration at full speed, the receive FIFO as a queue of OTG_GRXSTSP
entries with their data (SETUP packets, OUT data, SETUP stage done, OUT transfer completed),
the IN endpoints' transmit FIFOs (the data written to them, packets cut at MPSIZ or at the
transfer's end, XFRSIZ counted down as packets are written, PKTCNT as the host takes them,
XFRC at the last; INEPTFSAV and TXFE from the FIFO's fill), NAK, STALL and disable of an
endpoint, and the interrupt tree: OTG_DIEPINTx / OTG_DOEPINTx under their masks into OTG_DAINT,
DAINT under DAINTMSK into IEPINT / OEPINT of OTG_GINTSTS, GINTSTS under GINTMSK and GAHBCFG
GINTMSK to the NVIC's line 67 (OTG_FS).

Not modelled: the host and OTG roles (HNP, SRP, ADP), SOF, suspend and resume, isochronous
endpoints, DMA, battery charging detection, LPM, and the bus's timing: a token the host sends
is answered at once, in the device time it is sent, so no rate or latency over USB means
anything here. OTG_GSNPSID and OTG_GHWCFG1..4 are not in RM0390: they read the values TinyUSB's
dwc2_info.py lists for the STM32F412's OTG FS core, whose OTG_CID (0x2000), endpoint count (6)
and FIFO RAM (1.25 kB) are the F446's.
"""

from __future__ import annotations

from collections import deque

IRQ = 67                       # OTG_FS global interrupt (RM0390 10.2, the vector table)
NS = 1_000_000_000
ENDPOINTS = 6                  # IN and OUT endpoints of OTG_FS (31.3, OTG_FS in device mode)
FIFO_WORDS = 320               # 1.25 kB of FIFO RAM

# Identification: OTG_CID (31.15, reset value), then what RM0390 does not list (see above).
CID = 0x0000_2000
SNPSID = 0x4F54_320A
HWCFG = {0x44: 0x0000_0000, 0x48: 0x229E_D520, 0x4C: 0x0200_D1E8, 0x50: 0x17F0_8030}

# OTG_GINTSTS bits (31.15)
CMOD, OTGINT, SOF, RXFLVL, NPTXFE = 1 << 0, 1 << 2, 1 << 3, 1 << 4, 1 << 5
GINAKEFF, BOUTNAKEFF = 1 << 6, 1 << 7
USBSUSP, USBRST, ENUMDNE = 1 << 11, 1 << 12, 1 << 13
IEPINT, OEPINT, PTXFE = 1 << 18, 1 << 19, 1 << 26
GINTSTS_W1C = 0xF8F0_FC0A      # the rc_w1 flags (MMIS, SOF, ESUSP..EOPF, IISOIXFR, ..., WKUINT)
# OTG_GRSTCTL
CSRST, RXFFLSH, TXFFLSH, AHBIDL = 1 << 0, 1 << 4, 1 << 5, 1 << 31
# OTG_DCTL
SDIS, SGINAK, CGINAK, SGONAK, CGONAK = 1 << 1, 1 << 7, 1 << 8, 1 << 9, 1 << 10
# OTG_DIEPCTLx / OTG_DOEPCTLx
USBAEP, NAKSTS, STALL = 1 << 15, 1 << 17, 1 << 21
CNAK, SNAK, EPDIS, EPENA = 1 << 26, 1 << 27, 1 << 30, 1 << 31
CTL_WRITE_ONLY = 0x3C00_0000   # CNAK, SNAK, SD0PID, SODDFRM
# OTG_DIEPINTx / OTG_DOEPINTx
XFRC, EPDISD, STUP, INEPNE, TXFE = 1 << 0, 1 << 1, 1 << 3, 1 << 6, 1 << 7
# OTG_GRXSTSP packet status (PKTSTS, device mode)
OUT_DATA, OUT_DONE, SETUP_DONE, SETUP_DATA = 2, 3, 4, 6
# Registers kept as written and read back (their effect is none the model needs).
PLAIN = {0x004, 0x018, 0x024, 0x028, 0x03C, 0x054, 0x810, 0x814, 0x81C, 0x828, 0x82C, 0x834}
PLAIN |= {0x104 + 4 * k for k in range(ENDPOINTS - 1)}
# OTG_GDFIFOCFG: not an F446 register (RM0390 has none at 0x05C); TinyUSB writes it for DWC2
# cores of its own configuration, so it is kept, with no effect, rather than reported.
IGNORED = {0x05C}


class Stalled(Exception):
    """The endpoint answered a token with STALL."""


class Endpoint:
    """One direction of one endpoint: its control, interrupt and size registers."""

    def __init__(self):
        """Reset state: not active, not enabled, NAK."""
        self.ctl = self.intr = self.tsiz = 0
        self.nak = True
        self.packets: deque = deque()  # IN: whole packets in the transmit FIFO
        self.partial = bytearray()     # IN: the packet being written
        self.length = 0                # IN: the length of the packet being written

    @property
    def enabled(self) -> bool:
        """Return whether EPENA is set."""
        return bool(self.ctl & EPENA)

    def flush(self) -> None:
        """Empty the transmit FIFO."""
        self.packets.clear()
        self.partial.clear()
        self.length = 0

    def words(self) -> int:
        """Return the 32-bit words the transmit FIFO holds."""
        return sum(-(-len(p) // 4) for p in self.packets) + len(self.partial) // 4


class OtgFs:
    """OTG_FS at 0x5000_0000: global registers, device registers, power and clock, FIFOs."""

    polled = frozenset({0x010, 0x014} | {0x908 + 0x20 * n for n in range(ENDPOINTS)} |
                       {0xB08 + 0x20 * n for n in range(ENDPOINTS)})
    counters = frozenset()
    word_only = True            # a byte access to a FIFO would pop or push a whole word

    def __init__(self, chip):
        """Reset state (31.15: the reset values of the registers the model has)."""
        self.chip = chip
        self.regs = dict.fromkeys(PLAIN | IGNORED, 0)
        self.regs[0x03C] = CID
        self.regs[0x028] = 0x0200_0200
        self.gotgctl = 0x0001_0000         # CIDSTS: B-device (no A plug)
        self.gahbcfg = 0
        self.gusbcfg = 0x0000_1440         # TRDT 5, PHYSEL (the FS transceiver, fixed)
        self.gintsts = 0x0400_0020 & GINTSTS_W1C
        self.gccfg = 0
        self.dcfg = 0x0220_0000
        self.dctl = SDIS
        self.pcgcctl = 0
        self.enum_speed = 0
        self.reset_at = 0
        self.inep = [Endpoint() for _ in range(ENDPOINTS)]
        self.outep = [Endpoint() for _ in range(ENDPOINTS)]
        self.rx: deque = deque()           # (status word, data) entries not yet popped
        self.rx_words: deque = deque()     # the popped entry's data, word by word
        self.on_change = None              # called when what a host waits for may be there
        self._line = False

    # ---- the bus side ---------------------------------------------------------------------

    def read(self, off: int) -> int:
        """Read a register, or pop a word of the receive FIFO (any FIFO address)."""
        if off >= 0x1000:
            return self.rx_words.popleft() if self.rx_words else 0
        if off in self.regs:
            return self.regs[off]
        if 0x900 <= off < 0x900 + 0x20 * ENDPOINTS:
            return self._ep_read(self.inep[(off - 0x900) >> 5], off & 0x1F, (off - 0x900) >> 5)
        if 0xB00 <= off < 0xB00 + 0x20 * ENDPOINTS:
            return self._ep_read(self.outep[(off - 0xB00) >> 5], off & 0x1F, None)
        value = self._global_read(off)
        if value is None:
            self.chip.unmodelled('OTG_FS', off)
            return 0
        return value

    def _global_read(self, off: int):
        if off == 0x000:
            return self.gotgctl | (1 << 19 if self._b_valid() else 0)
        if off == 0x008:
            return self.gahbcfg
        if off == 0x00C:
            return self.gusbcfg | (1 << 6)
        if off == 0x010:
            return AHBIDL
        if off == 0x014:
            return self.gintsts_now()
        if off in (0x01C, 0x020):
            if not self.rx:
                return 0
            status, data = self.rx.popleft() if off == 0x020 else self.rx[0]
            if off == 0x020:
                self._popped(status, data)
                self.update()
            return status
        if off == 0x038:
            return self.gccfg
        if off == 0x040:
            return SNPSID
        if off in HWCFG:
            return HWCFG[off]
        if off == 0x800:
            return self.dcfg
        if off == 0x804:
            return self.dctl & ~0xC | (4 if self.dctl & SGINAK else 0) | \
                (8 if self.dctl & SGONAK else 0)
        if off == 0x808:
            frame = (self.chip.now - self.reset_at) // 1_000_000 & 0x3FFF
            return (self.enum_speed << 1) | (frame << 8)
        if off == 0x818:
            return self.daint()
        if off == 0xE00:
            return self.pcgcctl
        return None

    def _ep_read(self, ep: Endpoint, reg: int, tx) -> int:
        if reg == 0x00:
            ep0 = ep is self.inep[0] or ep is self.outep[0]
            return ep.ctl | (NAKSTS if ep.nak else 0) | (USBAEP if ep0 else 0)
        if reg == 0x08:
            return ep.intr | (TXFE if tx is not None and self._tx_empty(tx) else 0)
        if reg == 0x10:
            return ep.tsiz
        if reg == 0x18 and tx is not None:
            return max(0, self.fifo_depth(tx) - ep.words())
        self.chip.unmodelled('OTG_FS', 0x900 + 0x20 * (tx or 0) + reg)
        return 0

    def next_change(self, off: int):
        """Return None: a flag polled here changes only by a write or the host's tokens."""
        return None

    def write(self, off: int, value: int) -> None:
        """Write a register, or push a word into an IN endpoint's transmit FIFO."""
        if off >= 0x1000:
            n = (off >> 12) - 1
            if n < ENDPOINTS:
                self._push(n, value)
            else:
                self.chip.unmodelled('OTG_FS', off)
        elif off in self.regs:
            self.regs[off] = value
            if off == 0x004:
                self.regs[off] = 0             # GOTGINT: rc_w1, nothing sets it here
        elif 0x900 <= off < 0x900 + 0x20 * ENDPOINTS:
            self._ep_write(self.inep[(off - 0x900) >> 5], (off - 0x900) >> 5, off & 0x1F,
                           value, True)
        elif 0xB00 <= off < 0xB00 + 0x20 * ENDPOINTS:
            self._ep_write(self.outep[(off - 0xB00) >> 5], (off - 0xB00) >> 5, off & 0x1F,
                           value, False)
        elif not self._global_write(off, value):
            self.chip.unmodelled('OTG_FS', off)
        self.update()

    def _global_write(self, off: int, value: int) -> bool:
        chip = self.chip
        if off == 0x000:
            self.gotgctl = value & 0x0000_0FFF | 0x0001_0000
        elif off == 0x008:
            self.gahbcfg = value
            if value & 0x20:
                chip.error('OTG_FS: DMAEN set, the FS core has no DMA (RM0390 31.15, OTG_GAHBCFG)')
        elif off == 0x00C:
            if value & (1 << 29):
                chip.error('OTG_FS: host mode forced (FHMOD): only device mode is modelled')
            self.gusbcfg = value & ~(1 << 31)
        elif off == 0x010:
            self._reset_control(value)
        elif off == 0x014:
            self.gintsts &= ~(value & GINTSTS_W1C)
        elif off == 0x038:
            self.gccfg = value
        elif off == 0x800:
            if value & 3 != 3:
                chip.error(f'OTG_DCFG DSPD {value & 3}: the internal PHY runs at full speed '
                           'only (11)')
            self.dcfg = value
        elif off == 0x804:
            self._dctl(value)
        elif off == 0xE00:
            self.pcgcctl = value
        else:
            return False
        return True

    def _reset_control(self, value: int) -> None:
        if value & CSRST:
            # 31.15 (OTG_GRSTCTL CSRST): a core soft reset flushes the FIFOs, clears the
            # interrupts and stops every transfer; the configuration registers keep their values.
            self.gintsts = 0
            self.rx.clear()
            self.rx_words.clear()
            for ep in self.inep + self.outep:
                ep.flush()
                ep.ctl &= ~(EPENA | EPDIS)
                ep.intr = 0
            self.chip.stats['otg_soft_resets'] += 1
        if value & RXFFLSH:
            self.rx.clear()
            self.rx_words.clear()
        if value & TXFFLSH:
            n = (value >> 6) & 0x1F
            for k, ep in enumerate(self.inep):
                if n == 0x10 or n == k:
                    ep.flush()

    def _dctl(self, value: int) -> None:
        was = self.dctl
        self.dctl = value & ~(CGINAK | CGONAK)
        if value & CGINAK:
            self.dctl &= ~SGINAK
        if value & CGONAK:
            self.dctl &= ~SGONAK
        if (was ^ self.dctl) & SDIS:
            self._changed()

    def _ep_write(self, ep: Endpoint, n: int, reg: int, value: int, is_in: bool) -> None:
        if reg == 0x00:
            self._ctl(ep, n, value, is_in)
        elif reg == 0x08:
            ep.intr &= ~value
        elif reg == 0x10:
            ep.tsiz = value
        else:
            self.chip.unmodelled('OTG_FS', (0x900 if is_in else 0xB00) + 0x20 * n + reg)

    def _ctl(self, ep: Endpoint, n: int, value: int, is_in: bool) -> None:
        was = ep.ctl
        ep.ctl = value & ~CTL_WRITE_ONLY & ~(EPDIS | EPENA) | (was & EPENA)
        if value & SNAK:
            ep.nak = True
            if is_in:
                ep.intr |= INEPNE
        if value & CNAK:
            ep.nak = False
        if value & EPDIS and was & EPENA:
            # 31.16 ("Disabling an endpoint"): the core stops it and says so with EPDISD.
            ep.ctl &= ~EPENA
            ep.intr |= EPDISD
        elif value & EPENA:
            ep.ctl |= EPENA
            if not was & EPENA:
                ep.length = 0
                if is_in and self._in_type(ep, n) == 1:
                    self.chip.error(f'OTG_FS IN endpoint {n}: isochronous is not modelled')
                self._changed()

    def _changed(self) -> None:
        if self.on_change is not None:
            self.on_change()

    # ---- the FIFOs ------------------------------------------------------------------------

    def fifo_depth(self, n: int) -> int:
        """Return the words of IN endpoint n's transmit FIFO (OTG_DIEPTXF0 / OTG_DIEPTXFx)."""
        reg = self.regs[0x028] if n == 0 else self.regs[0x104 + 4 * (n - 1)]
        return reg >> 16

    def mps(self, n: int, ep: Endpoint) -> int:
        """Return an endpoint's maximum packet size (endpoint 0: the MPSIZ code of 31.15)."""
        if n == 0:
            return (64, 32, 16, 8)[ep.ctl & 3]
        return ep.ctl & 0x7FF

    @staticmethod
    def _in_type(ep: Endpoint, n: int) -> int:
        return 0 if n == 0 else (ep.ctl >> 18) & 3

    def _tx_empty(self, n: int) -> bool:
        # TXFE: half empty, or completely empty with GAHBCFG TXFELVL (31.15).
        used, depth = self.inep[n].words(), self.fifo_depth(n)
        return used == 0 if self.gahbcfg & 0x80 else used * 2 <= depth

    def _push(self, n: int, word: int) -> None:
        ep = self.inep[n]
        if not ep.enabled:
            self.chip.error(f'OTG_FS: FIFO {n} written while IN endpoint {n} is disabled')
            return
        if ep.words() >= self.fifo_depth(n):
            self.chip.error(f'OTG_FS: FIFO {n} written past its {self.fifo_depth(n)} words '
                            '(INEPTFSAV not checked)')
            return
        size_mask = 0x7F if n == 0 else 0x7FFFF
        left = ep.tsiz & size_mask
        if not ep.partial:
            ep.length = min(left, self.mps(n, ep))
            if ep.length == 0:
                self.chip.error(f'OTG_FS: FIFO {n} written with XFRSIZ 0')
                return
        ep.partial += word.to_bytes(4, 'little')
        if len(ep.partial) >= ep.length:
            # XFRSIZ counts down as whole packets are written to the FIFO (OTG_DIEPTSIZx).
            ep.packets.append(bytes(ep.partial[:ep.length]))
            ep.partial.clear()
            ep.tsiz = ep.tsiz & ~size_mask | (left - ep.length)
            self._changed()

    def _popped(self, status: int, data: bytes) -> None:
        """Put a popped entry's data behind the FIFO address; the done patterns flag the EP."""
        self.rx_words.clear()
        for k in range(0, len(data), 4):
            self.rx_words.append(int.from_bytes(data[k:k + 4].ljust(4, b'\0'), 'little'))
        kind, ep = (status >> 17) & 0xF, self.outep[status & 0xF]
        if kind == SETUP_DONE:
            ep.intr |= STUP
        elif kind == OUT_DONE:
            ep.intr |= XFRC

    # ---- interrupts -----------------------------------------------------------------------

    def daint(self) -> int:
        """Return OTG_DAINT: each endpoint's interrupt flags under their masks."""
        in_mask, out_mask = self.regs[0x810], self.regs[0x814]
        empty_mask = self.regs[0x834]
        value = 0
        for n in range(ENDPOINTS):
            pending = self.inep[n].intr & in_mask
            if empty_mask >> n & 1 and self._tx_empty(n):
                pending |= TXFE
            if pending:
                value |= 1 << n
            if self.outep[n].intr & out_mask:
                value |= 1 << (16 + n)
        return value

    def gintsts_now(self) -> int:
        """Return OTG_GINTSTS: the latched flags and those computed from the FIFOs and EPs."""
        value = self.gintsts | NPTXFE | PTXFE
        if self.rx:
            value |= RXFLVL
        if self.dctl & SGINAK:
            value |= GINAKEFF
        if self.dctl & SGONAK:
            value |= BOUTNAKEFF
        daint = self.daint() & self.regs[0x81C]
        if daint & 0xFFFF:
            value |= IEPINT
        if daint >> 16:
            value |= OEPINT
        return value

    def update(self) -> None:
        """Drive the interrupt line: GINTSTS under GINTMSK, gated by GAHBCFG GINTMSK."""
        line = bool(self.gahbcfg & 1 and self.gintsts_now() & self.regs[0x018] & ~CMOD)
        if self.regs[0x018] & SOF:
            self.chip.error('OTG_FS: SOF interrupt enabled: start-of-frame is not modelled')
        if line != self._line:
            self._line = line
            self.chip.set_irq(IRQ, line)

    # ---- what the host's tokens do (the cable's other end) ------------------------------

    def _b_valid(self) -> bool:
        # VBUS is not wired (PA9 is USART1's TX): the session is valid by the override only.
        return bool(self.gotgctl & 0xC0 == 0xC0)

    def attached(self) -> str | None:
        """Return why a host would not see the device on the bus, or None if it would."""
        if not self.chip.rcc.regs[0x34] & 0x80:
            return 'the OTG FS clock is off (RCC_AHB2ENR OTGFSEN)'
        if self.dctl & SDIS:
            return 'soft disconnect (OTG_DCTL SDIS): no pull-up on D+'
        if not self.gccfg & (1 << 16):
            return 'the transceiver is powered down (OTG_GCCFG PWRDWN clear)'
        if self.gccfg & (1 << 21):
            return 'VBUS sensing on (OTG_GCCFG VBDEN) with no VBUS wired: no session'
        if not self._b_valid():
            return 'no B-session valid (OTG_GOTGCTL BVALOEN/BVALOVAL)'
        if self.pcgcctl & 1:
            return 'PHY clock stopped (OTG_PCGCCTL STPPCLK)'
        hz = self.chip.rcc.clk48_hz()
        if abs(hz - 48e6) > 0.0025 * 48e6:
            return f'the 48 MHz clock is {hz / 1e6:g} MHz (USB needs 48 MHz within 0.25 %)'
        return None

    def host_reset(self) -> None:
        """Signal a bus reset, then its end at full speed (USBRST, then ENUMDNE)."""
        self.gintsts |= USBRST | ENUMDNE
        self.enum_speed = 3                 # full speed, 48 MHz PHY clock
        self.reset_at = self.chip.now
        # The core leaves the address and the endpoints to the application's reset handler
        # (31.16, "Initialization on USB reset"): the firmware's own work is what is tested.
        self.update()

    def host_setup(self, data: bytes) -> None:
        """Send a SETUP packet to endpoint 0 (always accepted: a device may not NAK it)."""
        ep = self.outep[0]
        for either in (ep, self.inep[0]):
            either.ctl &= ~STALL            # a SETUP clears EP0's STALL (31.15, OTG_DIEPCTL0)
        # USB 2.0 8.5.3: a SETUP is taken whatever the endpoint's state; STUPCNT counts the
        # back-to-back ones (TinyUSB rewrites OTG_DOEPTSIZ0 without it for the status stage).
        stupcnt = (ep.tsiz >> 29) & 3
        ep.tsiz = ep.tsiz & ~(3 << 29) | (max(stupcnt - 1, 0) << 29)
        self.rx.append((SETUP_DATA << 17 | len(data) << 4, bytes(data)))
        self.rx.append((SETUP_DONE << 17, b''))
        self.update()

    def host_in(self, n: int):
        """Send an IN token to endpoint n; return the packet, None for a NAK; raise Stalled."""
        ep = self.inep[n]
        if ep.ctl & STALL:
            raise Stalled(f'IN endpoint {n} stalled')
        if not ep.enabled or ep.nak:
            return None
        size_mask = 0x7F if n == 0 else 0x7FFFF
        if ep.packets:
            data = ep.packets.popleft()
        elif ep.tsiz & size_mask == 0 and not ep.partial and ep.tsiz >> 19 & 0x3FF:
            data = b''                      # a zero-length packet: nothing to write
        else:
            return None
        count = (ep.tsiz >> 19) & 0x3FF
        ep.tsiz = ep.tsiz & ~(0x3FF << 19) | (max(count - 1, 0) << 19)
        if count <= 1:
            ep.ctl &= ~EPENA
            ep.intr |= XFRC
            ep.nak = True
        self.update()
        return data

    def host_out(self, n: int, data: bytes) -> bool:
        """Send an OUT packet to endpoint n; return whether the device took it (else NAK)."""
        ep = self.outep[n]
        if ep.ctl & STALL:
            raise Stalled(f'OUT endpoint {n} stalled')
        if not ep.enabled or ep.nak or self.dctl & SGONAK:
            return False
        size_mask = 0x7F if n == 0 else 0x7FFFF
        self.rx.append((OUT_DATA << 17 | len(data) << 4 | n, bytes(data)))
        left = max((ep.tsiz & size_mask) - len(data), 0)
        count = max(((ep.tsiz >> 19) & 0x3FF) - 1, 0)
        ep.tsiz = ep.tsiz & ~(size_mask | 0x3FF << 19) | left | count << 19
        if count == 0 or len(data) < self.mps(n, ep):
            # 31.16: the transfer is done; the core NAKs the endpoint until it is enabled again.
            self.rx.append((OUT_DONE << 17 | n, b''))
            ep.ctl &= ~EPENA
            ep.nak = True
        self.update()
        return True
