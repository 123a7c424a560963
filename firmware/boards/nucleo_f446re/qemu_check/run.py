#!/usr/bin/env python3
"""
Check the Nucleo-F446RE board's code on QEMU's netduinoplus2, as far as the emulation reaches.

    python3 firmware/boards/nucleo_f446re/qemu_check/run.py

Builds two images with arm-none-eabi-gcc into a temporary directory and runs them under
qemu-system-arm (7.2 or later):

1. the firmware as flashed: QEMU has no RCC, so the HSE never starts and the PLL never locks;
   the firmware must fall back to the HSI, then record the PLL fault in its .noinit record and
   reset (bounded waits; QEMU keeps the RAM over the reset);
2. qemu_check.c with the board's GPIO, row, timer, ADC and link code: the ADC sequences, sampling
   times, timer and USART registers QEMU stores, the DMA and GPIO writes QEMU logs (-d unimp),
   a row's timeout path (QEMU has no DMA) and the bounded waits.

The expected values are computed here from skin_board_pins.h, independently of the C code.
What QEMU cannot show (the clock tree, multi-ADC conversions, DMA transfers, pins, the line) is
listed in docs/firmware.md. Exit status 0 when every check holds.
"""

from __future__ import annotations

from pathlib import Path
import re
import subprocess
import sys
import tempfile
import time

BOARD = Path(__file__).resolve().parents[1]
FW = BOARD.parents[1]
CFLAGS = ['-mcpu=cortex-m4', '-mthumb', '-mfloat-abi=hard', '-mfpu=fpv4-sp-d16', '-Os', '-g',
          '-std=c11', '-Wall', '-Wextra', '-Wpedantic', '-Werror', '-DSTM32F446xx', f'-I{BOARD}',
          f'-I{FW / "core/include"}', '-isystem', str(FW / 'vendor/cmsis_core/Include'),
          '-isystem', str(FW / 'vendor/cmsis_device_f4/Include')]
LDFLAGS = [f'-T{BOARD / "nucleo_f446re.ld"}', '-nostartfiles', '--specs=nano.specs',
           '--specs=nosys.specs', '-Wl,--gc-sections']
QEMU = ['qemu-system-arm', '-M', 'netduinoplus2', '-nographic', '-serial', 'null']
PORTS = {'A': 0, 'B': 1, 'C': 2, 'D': 3}


def wiring() -> dict:
    """Read the settings of skin_board_pins.h this check needs."""
    text = (BOARD / 'skin_board_pins.h').read_text()
    text = re.sub(r'/\*.*?\*/', '', text, flags=re.S)

    def define(name):
        return re.search(rf'#define {name}\s+(.+)', text).group(1).strip()

    def pin(name):
        port, num = re.fullmatch(r'SKIN_PIN\((\w), (\d+)\)', define(name)).groups()
        return PORTS[port], int(num)

    def table(name):
        body = re.search(rf'#define {name}\(X\)(.*?)(?:\n\s*\n|#define)', text,
                         flags=re.S).group(1)
        return {int(a): int(b) for a, b in re.findall(r'X\(\s*(\d+),\s*(\d+)\)', body)}

    return {
        'cols': int(define('SKIN_BOARD_COLS')),
        'columns': table('SKIN_BOARD_COLUMNS'),
        'rows_top': table('SKIN_BOARD_ROW_CHANNELS_TOP'),
        'rows_bottom': table('SKIN_BOARD_ROW_CHANNELS_BOTTOM'),
        'sample': int(define('SKIN_BOARD_ADC_SAMPLE_CYCLES')),
        'usart': int(define('SKIN_BOARD_LINK_USART')),
        'baud': int(define('SKIN_BOARD_BAUD')),
        'rate': int(define('SKIN_BOARD_SCAN_RATE_HZ')),
        'addr': [pin(f'SKIN_BOARD_ROW_ADDR{i}') for i in range(4)],
        'en': [pin('SKIN_BOARD_ROW_EN_TOP'), pin('SKIN_BOARD_ROW_EN_BOTTOM')],
        'active_low': int(define('SKIN_BOARD_ROW_EN_ACTIVE_LOW')),
    }


def expected(w: dict) -> dict:
    """Compute the register values and results the board's code must produce for wiring w."""
    cols = w['cols']
    ranks = (cols + 2) // 3
    exp = {}
    for adc in range(3):
        slots = [s if s < cols else s % 3 for s in range(adc, 3 * ranks, 3)]
        sqr3 = 0
        for rank, slot in enumerate(slots[:6]):
            sqr3 |= w['columns'][slot] << (5 * rank)
        exp[f'adc{adc + 1}_sqr3'] = sqr3
        exp[f'adc{adc + 1}_sqr1'] = (ranks - 1) << 20
    code = [3, 15, 28, 56, 84, 112, 144, 480].index(w['sample'])
    exp['adc1_smpr2'] = sum(code << (3 * ch) for ch in range(10))
    exp['adc1_smpr1'] = sum(code << (3 * ch) for ch in range(9))
    exp['adc1_cr1'] = 1 << 8  # SCAN
    exp['tim2_psc'] = exp['tim5_psc'] = 90 - 1
    exp['tim5_arr'] = 1_000_000 // w['rate'] - 1
    clock = 90_000_000 if w['usart'] == 1 else 45_000_000
    over8 = w['baud'] > clock // 16
    div = (clock + w['baud'] // 2) // w['baud']
    exp['link_brr'] = ((div >> 3) << 4 | (div & 7)) if over8 else div
    exp['link_cr1'] = (1 << 13) | (1 << 3) | ((1 << 15) if over8 else 0)  # UE, TE, OVER8
    exp['link_cr3'] = 1 << 7  # DMAT
    exp['row_sampled'] = 0  # the row failed: nothing of it is taken as counts
    exp['row_after_slack'] = 0
    exp['adc_timeouts'] = 2  # the row is tried twice
    exp['adc_overruns'] = 0
    exp['scan_tick_returned'] = 1
    exp['done'] = 1
    return exp


def bsrr_drive(w: dict, layer: int, row: int) -> list:
    """List the (port, BSRR) writes of board_drive_row(layer, row), board_release_rows()."""
    on = 0 if w['active_low'] else 1

    def write(pin, high):
        port, num = pin
        return port, (1 << num) if high else (1 << (num + 16))

    off = [write(p, 1 - on) for p in w['en']]
    ch = w['rows_bottom' if layer else 'rows_top'][row]
    return (off + [write(w['addr'][i], (ch >> i) & 1) for i in range(4)] +
            [write(w['en'][layer], on)] + off)


def build(out: Path, sources: list, extra: list = ()) -> Path:
    """Compile and link sources into the ELF out with the board's flags."""
    subprocess.run(['arm-none-eabi-gcc', *CFLAGS, *extra, *map(str, sources), *LDFLAGS, '-o',
                    str(out)], check=True)
    return out


def symbol(elf: Path, name: str) -> int:
    """Return the address of the symbol name in elf."""
    nm = subprocess.run(['arm-none-eabi-nm', str(elf)], check=True, capture_output=True,
                        text=True).stdout
    return int(re.search(rf'^([0-9a-f]+) \w {name}$', nm, flags=re.M).group(1), 16)


def read_words(elf: Path, addrs: dict, settle_s: float = 3.0) -> dict:
    """Run elf under QEMU for settle_s, then read one word at each address by the monitor."""
    qemu = subprocess.Popen([*QEMU, '-kernel', str(elf), '-monitor', 'stdio'],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    time.sleep(settle_s)
    cmds = ''.join(f'xp /1wx {a:#x}\n' for a in addrs.values()) + 'quit\n'
    out, _ = qemu.communicate(cmds, timeout=20)
    lines = re.findall(r'^([0-9a-f]{16}): (0x[0-9a-f]+)', out, flags=re.M)
    found = {int(a, 16): int(v, 16) for a, v in lines}
    return {name: found.get(a) for name, a in addrs.items()}


def main() -> int:
    """Run both images, print each check, return the exit status."""
    w = wiring()
    failures = []

    def check(name, got, want):
        """Record got against want (a value, or a predicate)."""
        ok = got == want if not callable(want) else want(got)
        print(f'{"ok  " if ok else "FAIL"} {name}: {got!r}' + ('' if ok else f' (want {want!r})'))
        if not ok:
            failures.append(name)

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        board_sources = [BOARD / f for f in ('startup.c', 'gpio.c', 'rows.c', 'timers.c', 'adc.c',
                                             'link.c', 'fault.c', 'reset.c')]
        core = [FW / 'core/src' / f for f in ('fault.c', 'wait.c')]

        full = build(tmp / 'full.elf', board_sources +
                     [BOARD / f for f in ('main.c', 'board.c', 'clock.c', 'crc_hw.c',
                                          'watchdog.c', 'pins_check.c')] +
                     sorted((FW / 'core/src').glob('*.c')), ['-DSKIN_FW_CRC32_HW'])
        # Each start reads the record (and clears its magic) into nucleo_fault_code.
        words = read_words(full, {'recorded': symbol(full, 'fault_record') + 4,
                                  'read at start': symbol(full, 'nucleo_fault_code')})
        for what, got in words.items():
            check(f'firmware without RCC: fault {what} is the PLL (1), after the HSI fallback',
                  got, 1)

        probe = build(tmp / 'probe.elf', board_sources + core +
                      [BOARD / 'qemu_check/qemu_check.c'])
        log = tmp / 'unimp.log'
        run = subprocess.run([*QEMU, '-monitor', 'none', '-kernel', str(probe),
                              '-semihosting-config', 'enable=on,target=native', '-d', 'unimp',
                              '-D', str(log)], capture_output=True, text=True, timeout=60)
        # QEMU writes the guest's semihosting console to its stderr.
        got = dict(re.findall(r'^(\w+)=([0-9a-f]{8})$', run.stdout + run.stderr, flags=re.M))
        got = {k: int(v, 16) for k, v in got.items()}
        for name, want in expected(w).items():
            check(name, got.get(name), want)
        check('delay_us(100) waited at least 100 us', got.get('delay_100_took'),
              lambda v: v is not None and v >= 100)
        # adc.c's bound: 4 x the row's conversions + 10 us (39 us for 16 columns at 15 cycles).
        row_ranks = (w['cols'] + 2) // 3
        bound = 4 * -(-row_ranks * (w['sample'] + 12) * 1_000_000 // 22_500_000) + 10
        # QEMU runs its timers in real time, slower guest code makes the recovery look long.
        check(f'a row that never converts ends, past twice its bound ({bound} us)',
              got.get('row_took'), lambda v: v is not None and 2 * bound < v < 100_000)

        writes = re.findall(r'^(\w+): unimplemented device write \(size 4, offset (0x[0-9a-f]+), '
                            r'value (0x[0-9a-f]+)\)', log.read_text(), flags=re.M)
        writes = [(dev, int(off, 16), int(val, 16)) for dev, off, val in writes]
        bsrr = [('ABCD'.index(dev[-1]), val) for dev, off, val in writes
                if dev.startswith('GPIO') and off == 0x18]
        want = bsrr_drive(w, 1, 5)
        check('drive_row(1, 5) + release: BSRR writes, break before make',
              any(bsrr[i:i + len(want)] == want for i in range(len(bsrr))), True)
        dma2 = [(off, val) for dev, off, val in writes if dev == 'DMA2']
        ranks = (w['cols'] + 2) // 3
        for what, write in [('ADC stream 0: PAR = ADC_CDR', (0x18, 0x40012308)),
                            ('ADC stream 0: CR (ch 0, very high, 16/16 bit, MINC)',
                             (0x10, 0x00032C00)),
                            ('ADC stream 0: NDTR = 3 x ranks', (0x14, 3 * ranks))]:
            check(what, write in dma2, True)
        if w['usart'] == 1:
            check('link stream: DMA2 Stream7 PAR = USART1_DR', (0xC0, 0x40011004) in dma2, True)
            check('link stream: DMA2 Stream7 CR (ch 4, mem->periph, MINC)',
                  (0xB8, 0x08020440) in dma2, True)

    print('all checks hold' if not failures else f'{len(failures)} checks failed')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
