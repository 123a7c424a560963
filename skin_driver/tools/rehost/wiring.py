"""The expander's wiring as skin_board_pins.h gives it: the physical side of the rehosted board."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import re

PORTS = 'ABCD'


@dataclass(frozen=True)
class Wiring:
    """Which column is on which ADC channel and which row on which mux input, and the pins."""

    rows: int
    cols: int
    channel_column: dict      # ADC channel -> column
    channel_row: tuple        # per layer: mux input -> row
    addr_pins: tuple          # S0..S3, pin ids (port * 16 + pin)
    enable_pins: tuple        # top, bottom
    enable_active_low: bool
    baud: int
    scan_rate_hz: int


def _define(text: str, name: str) -> str:
    match = re.search(rf'#define\s+{name}(?![A-Za-z0-9_])((?:[^\n]*\\\n)*[^\n]*)', text)
    if match is None:
        raise ValueError(f'skin_board_pins.h has no {name}')
    body = re.sub(r'/\*.*?\*/', ' ', match.group(1).replace('\\\n', ' '), flags=re.S)
    return body.strip()


def _pin(text: str, name: str) -> int:
    port, pin = re.fullmatch(r'SKIN_PIN\(([A-D]),\s*(\d+)\)', _define(text, name)).groups()
    return PORTS.index(port) * 16 + int(pin)


def _pairs(body: str) -> list:
    return [(int(a), int(b)) for a, b in re.findall(r'X\((\d+),\s*(\d+)\)', body)]


def _scan_rate(text: str, protocol: int) -> int:
    """Return the USART image's scan rate for protocol (the table sets one for each version)."""
    match = re.search(r'#if defined\(SKIN_FW_PROTOCOL\) && SKIN_FW_PROTOCOL == 1\s*'
                      r'#define\s+SKIN_BOARD_SCAN_RATE_HZ\s+(\d+)\s*#else\s*'
                      r'#define\s+SKIN_BOARD_SCAN_RATE_HZ\s+(\d+)', text)
    if match is None:
        return int(_define(text, 'SKIN_BOARD_SCAN_RATE_HZ'))
    return int(match.group(1) if protocol == 1 else match.group(2))


def load_wiring(path, protocol: int = 2, usb: bool = False) -> Wiring:
    """
    Parse the pin table at path (firmware/boards/nucleo_f446re/skin_board_pins.h).

    ``protocol``: the wire protocol version the image was built for (its scan rate depends on it);
    ``usb``: the table as the USB image reads it (SKIN_BOARD_USB_SCAN_RATE_HZ its scan rate).
    """
    text = Path(path).read_text()
    rate = int(_define(text, 'SKIN_BOARD_USB_SCAN_RATE_HZ')) if usb else _scan_rate(text, protocol)
    rows = int(_define(text, 'SKIN_BOARD_ROWS'))
    cols = int(_define(text, 'SKIN_BOARD_COLS'))
    columns = _pairs(_define(text, r'SKIN_BOARD_COLUMNS\(X\)'))
    layers = tuple(
        {ch: row for row, ch in _pairs(_define(text, rf'SKIN_BOARD_ROW_CHANNELS_{n}\(X\)'))}
        for n in ('TOP', 'BOTTOM'))
    return Wiring(
        rows=rows, cols=cols, channel_column={ch: col for col, ch in columns},
        channel_row=layers,
        addr_pins=tuple(_pin(text, f'SKIN_BOARD_ROW_ADDR{i}') for i in range(4)),
        enable_pins=(_pin(text, 'SKIN_BOARD_ROW_EN_TOP'), _pin(text, 'SKIN_BOARD_ROW_EN_BOTTOM')),
        enable_active_low=_define(text, 'SKIN_BOARD_ROW_EN_ACTIVE_LOW') == '1',
        baud=int(_define(text, 'SKIN_BOARD_BAUD')),
        scan_rate_hz=rate)
