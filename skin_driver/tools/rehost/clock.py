"""
RCC, PWR and FLASH: ready flags, and the clock tree computed from the firmware's own writes.

RM0390 Rev 4: section 6.3 (RCC registers: RCC_CR 6.3.1, RCC_PLLCFGR 6.3.2, RCC_CFGR 6.3.3,
RCC_CSR 6.3.21), section 5.1.4 and 5.4 (over-drive, PWR_CR and PWR_CSR), section 3.4.1
(Table 5, flash wait states against HCLK) and 3.8.1 (FLASH_ACR). The limits are the
STM32F446xx datasheet's (DS10693, "General operating conditions"): HCLK 180 MHz with over-drive
(168 MHz without), APB1 45 MHz, APB2 90 MHz, ADC clock 36 MHz (VDDA 2.4..3.6 V), VCO input
1..2 MHz, VCO output 100..432 MHz.
"""

from __future__ import annotations

from dataclasses import dataclass, field

HSI_HZ = 16_000_000
HSE_HZ = 8_000_000        # the ST-LINK's MCO on a Nucleo-64 (UM1724, "OSC clock")
LSI_HZ = 32_000

# Start-up times (datasheet orders of magnitude): the exact values only move device time.
HSE_BYPASS_NS = 2_000
PLL_LOCK_NS = 100_000
OVERDRIVE_NS = 50_000
OVERDRIVE_SWITCH_NS = 10_000

MAX_HCLK_OD, MAX_HCLK = 180e6, 168e6
MAX_APB1_OD, MAX_APB1 = 45e6, 42e6
MAX_APB2_OD, MAX_APB2 = 90e6, 84e6
MAX_ADC = 36e6

AHB_DIV = {8: 2, 9: 4, 10: 8, 11: 16, 12: 64, 13: 128, 14: 256, 15: 512}
APB_DIV = {4: 2, 5: 4, 6: 8, 7: 16}

# RCC_CR bits (6.3.1)
HSION, HSIRDY, HSEON, HSERDY, HSEBYP = 1 << 0, 1 << 1, 1 << 16, 1 << 17, 1 << 18
PLLON, PLLRDY = 1 << 24, 1 << 25
PLLSAION, PLLSAIRDY = 1 << 28, 1 << 29
CK48MSEL = 1 << 27      # RCC_DCKCFGR2 (RM0390 6.3): the 48 MHz clock from PLLSAI_P, not PLL_Q
# PWR bits (5.4.1, 5.4.2)
ODEN, ODSWEN, ODRDY, ODSWRDY, VOSRDY = 1 << 16, 1 << 17, 1 << 16, 1 << 17, 1 << 14
# RCC_CSR reset flags (6.3.21): power-on, pin, brown-out after power-up; IWDG
CSR_POWER_ON = (1 << 27) | (1 << 26) | (1 << 25)
CSR_IWDG = 1 << 29
CSR_PIN = 1 << 26
CSR_RMVF = 1 << 24


@dataclass
class ClockTree:
    """The frequencies the firmware's register writes set, and every datasheet limit broken."""

    source: str = 'hsi'            # the PLL's input: 'hse' or 'hsi'
    sysclk_hz: float = HSI_HZ
    hclk_hz: float = HSI_HZ
    pclk1_hz: float = HSI_HZ
    pclk2_hz: float = HSI_HZ
    vco_in_hz: float = 0.0
    vco_hz: float = 0.0
    pll_q_hz: float = 0.0
    overdrive: bool = False
    flash_wait_states: int = 0
    adc_hz: float = 0.0
    violations: list = field(default_factory=list)

    def timer_hz(self, apb: int) -> float:
        """Return the timers' clock on APB1 or APB2 (twice the bus clock when it is divided)."""
        pclk = self.pclk1_hz if apb == 1 else self.pclk2_hz
        return pclk if pclk == self.hclk_hz else 2 * pclk


def _vco_limits(name: str, f_in: float, m: int, cfg: int) -> list:
    """Return the limits a PLL's M, N (bits 14:6) and Q (27:24) break: input, VCO, Q range."""
    n, q = (cfg >> 6) & 0x1FF, (cfg >> 24) & 0xF
    vco = 'VCO' if name == 'PLL' else f'{name} VCO'
    bad = []
    if not 2 <= m <= 63:
        bad.append(f'{name}M {m} outside 2..63')
    elif not 1e6 <= f_in / m <= 2e6:
        bad.append(f'{vco} input {f_in / m / 1e6:g} MHz outside 1..2 MHz')
    if not 50 <= n <= 432:
        bad.append(f'{name}N {n} outside 50..432')
    elif m and not 100e6 <= f_in / max(m, 1) * n <= 432e6:
        bad.append(f'{vco} {f_in / m * n / 1e6:g} MHz outside 100..432 MHz')
    if not 2 <= q <= 15:
        bad.append(f'{name}Q {q} outside 2..15')
    return bad


class Rcc:
    """Reset and clock control (RM0390 6.3), with PWR (5.4) and FLASH (3.8) as its partners."""

    polled = frozenset({0x00, 0x08})
    counters = frozenset()

    def __init__(self, chip):
        """Reset state (RM0390 6.3: RCC_CR 0x83, RCC_PLLCFGR and RCC_PLLSAICFGR 0x2400_3010)."""
        self.chip = chip
        self.regs = {0x00: HSION | HSIRDY | (16 << 3), 0x04: 0x2400_3010, 0x08: 0,
                     0x30: 0x0010_0000, 0x34: 0, 0x40: 0, 0x44: 0, 0x74: 0, 0x88: 0x2400_3010}
        self.ready_at = {}          # RCC_CR ready bit -> device time it sets
        self.tree = ClockTree()

    def reset(self, csr_flags: int) -> None:
        """Reset the registers to their reset values, keeping the reset cause flags."""
        csr = self.regs[0x74] | csr_flags
        self.__init__(self.chip)
        self.regs[0x74] = csr

    def read(self, off: int) -> int:
        """Return the register at off, ready bits as of now."""
        if off == 0x00:
            now = self.chip.now
            for bit, at in list(self.ready_at.items()):
                if at <= now:
                    self.regs[0] |= bit
                    del self.ready_at[bit]
        elif off == 0x08:
            self._switch()
        return self.regs.get(off, 0)

    def next_change(self, off: int):
        """Return the device time a polled register changes next (None: nothing pending)."""
        return min(self.ready_at.values()) if off == 0 and self.ready_at else None

    def _switch(self) -> None:
        # SWS follows SW once the selected source is ready (a few cycles: at once here).
        self.read(0x00)
        sws = self._sws(self.regs[8] & 3)
        if sws != (self.regs[8] >> 2) & 3:
            self.regs[8] = (self.regs[8] & ~0xC) | (sws << 2)
            self.update()

    def _sws(self, sw: int) -> int:
        ready = {0: HSIRDY, 1: HSERDY, 2: PLLRDY}.get(sw, 0)
        if self.regs[0] & ready:
            return sw
        return (self.regs[8] >> 2) & 3

    def _switch_pll(self, value: int, old: int, on: int, ready: int, settings_ok) -> None:
        """Start a PLL's lock when RCC_CR turns it on (if its settings hold), or drop its lock."""
        if value & on and not old & on and settings_ok():
            self.ready_at[ready] = self.chip.now + PLL_LOCK_NS
        if not value & on:
            self.regs[0] &= ~ready
            self.ready_at.pop(ready, None)

    def write(self, off: int, value: int) -> None:
        """Write a register: start oscillators and the PLL, switch the system clock."""
        chip = self.chip
        if off == 0x00:
            old = self.regs[0]
            keep = old & (HSIRDY | HSERDY | PLLRDY | PLLSAIRDY)
            self.regs[0] = (value & ~(HSIRDY | HSERDY | PLLRDY | 0x2A00_0000)) | keep
            if value & HSEON and not old & HSEON:
                if chip.faults.hse_absent:
                    chip.stats['hse_refused'] += 1
                else:
                    self.ready_at[HSERDY] = chip.now + HSE_BYPASS_NS
            if not value & HSEON:
                self.regs[0] &= ~HSERDY
                self.ready_at.pop(HSERDY, None)
            self._switch_pll(value, old, PLLON, PLLRDY, self._pll_ok)
            self._switch_pll(value, old, PLLSAION, PLLSAIRDY, self._pllsai_ok)
        elif off == 0x04:
            if self.regs[0] & PLLON:
                chip.error('RCC_PLLCFGR written while the PLL is on (RM0390 6.3.2 forbids it)')
            self.regs[4] = value
        elif off == 0x88:
            if self.regs[0] & PLLSAION:
                chip.error('RCC_PLLSAICFGR written while PLLSAI is on (RM0390 6.3)')
            self.regs[0x88] = value
        elif off == 0x08:
            self.regs[8] = (self.regs[8] & 0xC) | (value & ~0xC)
            self._switch()
            self.update()
        elif off == 0x74:
            self.regs[0x74] = (value & 0xFF) if value & CSR_RMVF else \
                (self.regs[0x74] & 0xFF00_0000) | (value & 0xFF)
            if value & 1:
                self.regs[0x74] |= 2            # LSIRDY: the LSI starts within microseconds
        else:
            self.regs[off] = value

    def _pll_in(self) -> tuple:
        cfg = self.regs[4]
        src = 'hse' if cfg & (1 << 22) else 'hsi'
        return src, (HSE_HZ if src == 'hse' else HSI_HZ), cfg & 0x3F

    def _pll_ok(self) -> bool:
        """Check the PLL's dividers (RM0390 6.3.2); a PLL out of range is not let lock."""
        src, f_in, m = self._pll_in()
        if src == 'hse' and not self.regs[0] & HSERDY:
            self.chip.error('PLL started from the HSE before HSERDY')
            return False
        cfg = self.regs[4]
        bad = _vco_limits('PLL', f_in, m, cfg)
        r = (cfg >> 28) & 7
        if not 2 <= r <= 7:
            bad.append(f'PLLR {r} outside 2..7')
        for text in bad:
            self.chip.error(f'clock: {text} (RM0390 6.3.2)')
        return not bad

    def _pllsai_ok(self) -> bool:
        """Check PLLSAI's dividers (RM0390 6.3, RCC_PLLSAICFGR); its input is the main PLL's."""
        _, f_in, _ = self._pll_in()
        cfg = self.regs[0x88]
        bad = _vco_limits('PLLSAI', f_in, cfg & 0x3F, cfg)
        for text in bad:
            self.chip.error(f'clock: {text} (RM0390 6.3, RCC_PLLSAICFGR)')
        return not bad

    def clk48_hz(self) -> float:
        """Return the 48 MHz clock: PLLSAI_P or PLL_Q by CK48MSEL (RCC_DCKCFGR2), 0 if off."""
        if self.regs.get(0x94, 0) & CK48MSEL:
            if not self.read(0x00) & PLLSAIRDY:
                return 0.0
            _, f_in, _ = self._pll_in()
            cfg = self.regs[0x88]
            m, n, p = cfg & 0x3F, (cfg >> 6) & 0x1FF, 2 * (((cfg >> 16) & 3) + 1)
            return f_in / m * n / p if m else 0.0
        return self.tree.pll_q_hz if self.read(0x00) & PLLRDY else 0.0

    def update(self) -> None:
        """Recompute the clock tree from the registers and check it against the limits."""
        chip, tree = self.chip, self.tree
        cfg = self.regs[4]
        src, f_in, m = self._pll_in()
        n, p = (cfg >> 6) & 0x1FF, 2 * (((cfg >> 16) & 3) + 1)
        tree.source = src
        tree.vco_in_hz = f_in / m if m else 0.0
        tree.vco_hz = tree.vco_in_hz * n
        tree.pll_q_hz = tree.vco_hz / max((cfg >> 24) & 0xF, 1)
        sws = (self.regs[8] >> 2) & 3
        tree.sysclk_hz = {0: HSI_HZ, 1: HSE_HZ, 2: tree.vco_hz / p}.get(sws, HSI_HZ)
        c = self.regs[8]
        tree.hclk_hz = tree.sysclk_hz / AHB_DIV.get((c >> 4) & 0xF, 1)
        tree.pclk1_hz = tree.hclk_hz / APB_DIV.get((c >> 10) & 7, 1)
        tree.pclk2_hz = tree.hclk_hz / APB_DIV.get((c >> 13) & 7, 1)
        tree.overdrive = bool(chip.pwr.csr & ODSWRDY)
        tree.flash_wait_states = chip.flash.acr & 0xF
        chip.set_cpu_clock(tree.hclk_hz)
        od = tree.overdrive
        limits = ((tree.hclk_hz, MAX_HCLK_OD if od else MAX_HCLK, 'HCLK'),
                  (tree.pclk1_hz, MAX_APB1_OD if od else MAX_APB1, 'APB1'),
                  (tree.pclk2_hz, MAX_APB2_OD if od else MAX_APB2, 'APB2'))
        for f, top, name in limits:
            if f > top:
                self._violate(f'{name} {f / 1e6:g} MHz over {top / 1e6:g} MHz '
                              f'({"with" if od else "without"} over-drive)')
        # Table 5 (2.7..3.6 V): one more wait state per 30 MHz of HCLK.
        needed = max(0, -(-int(tree.hclk_hz) // 30_000_000) - 1)
        if tree.flash_wait_states < needed:
            self._violate(f'{tree.flash_wait_states} flash wait states for HCLK '
                          f'{tree.hclk_hz / 1e6:g} MHz, which needs {needed} (RM0390 Table 5)')

    def _violate(self, text: str) -> None:
        if text not in self.tree.violations:
            self.tree.violations.append(text)
        self.chip.error(f'clock: {text}')


class Pwr:
    """Power controller: voltage scale and over-drive (RM0390 5.1.4, 5.4)."""

    polled = frozenset({0x04})
    counters = frozenset()

    def __init__(self, chip):
        """Reset state: PWR_CR VOS = scale 1 (0x0000_C000), PWR_CSR VOSRDY once powered."""
        self.chip = chip
        self.cr = 0xC000
        self.csr = VOSRDY
        self.ready_at = {}

    def read(self, off: int) -> int:
        """Return PWR_CR or PWR_CSR (ready bits as of now)."""
        if off == 0:
            return self.cr
        if off == 4:
            for bit, at in list(self.ready_at.items()):
                if at <= self.chip.now:
                    self.csr |= bit
                    del self.ready_at[bit]
            return self.csr
        self.chip.unmodelled('PWR', off)
        return 0

    def next_change(self, off: int):
        """Return when PWR_CSR changes next."""
        return min(self.ready_at.values()) if self.ready_at else None

    def write(self, off: int, value: int) -> None:
        """Write PWR_CR: over-drive enable and switch (5.1.4's sequence is checked)."""
        if off != 0:
            self.chip.unmodelled('PWR', off)
            return
        rcc = self.chip.rcc
        if (value ^ self.cr) & 0xC000 and rcc.regs[0] & PLLON:
            self.chip.error('PWR_CR VOS changed while the PLL is on (RM0390 5.4.1)')
        if value & ODEN and not self.cr & ODEN:
            if not rcc.regs[0] & PLLON:
                self.chip.error('over-drive enabled before the PLL (RM0390 5.1.4, step 3)')
            self.ready_at[ODRDY] = self.chip.now + OVERDRIVE_NS
        if value & ODSWEN and not self.cr & ODSWEN:
            if not self.csr & ODRDY:
                self.chip.error('over-drive switch before ODRDY (RM0390 5.1.4, step 4)')
            else:
                self.ready_at[ODSWRDY] = self.chip.now + OVERDRIVE_SWITCH_NS
        self.cr = value
        rcc.update()


class Flash:
    """Flash interface: FLASH_ACR's latency, read back at once (RM0390 3.4.1, 3.8.1)."""

    polled = frozenset({0x00})
    counters = frozenset()

    def __init__(self, chip):
        """Reset state: no wait states, caches off."""
        self.chip = chip
        self.acr = 0

    def read(self, off: int) -> int:
        """Return FLASH_ACR (other registers: flash programming, not modelled)."""
        if off != 0:
            self.chip.unmodelled('FLASH', off)
            return 0
        return self.acr

    def next_change(self, off: int):
        """Return None: the latency is in effect at once."""
        return None

    def write(self, off: int, value: int) -> None:
        """Write FLASH_ACR; the clock tree is checked against the new latency."""
        if off != 0:
            self.chip.unmodelled('FLASH', off)
            return
        self.acr = value & 0x1F0F
        self.chip.rcc.update()
