"""
The unmodified USB image (skin_fw_nucleo_f446re_usb) on the rehosted chip, against a scripted host.

The chip's OTG FS core is a model written from RM0390 (skin_driver/tools/rehost/otg.py), the
host is usb_host.py: what is shown is that TinyUSB and the board's glue enumerate, configure and
stream on that model, not on silicon (docs/firmware.md, "The USB link"). The descriptors are
checked against the firmware's own: the bytes of usb_desc.c's tables in the image, and what they
must say from usb_desc.h and tusb_config.h. The frames read by bulk IN go through the driver's
decoder, and each holds the scan the skin showed at its device time. SKIN_REHOST_USB_FRAMES sets
how many (30; from 600 on, over a second of device time, the information frame's repeat is
checked too).
"""

import os
from pathlib import Path
import re
import struct

import numpy as np
import pytest

from skin_driver.core.protocol.wire import FrameDecoder
from skin_driver.tools import firmware_board
from skin_driver.tools.rehost import cost
from skin_driver.tools.rehost.board import PINS
from skin_driver.tools.rehost.chip import Chip, DEFAULT_UID
from skin_driver.tools.rehost.elf import ElfImage
from skin_driver.tools.rehost.otg import Stalled
from skin_driver.tools.rehost.usb_host import parse_descriptors, ScriptedHost
from skin_driver.tools.rehost.usb_host import UsbTimeout
from skin_driver.tools.rehost.wiring import load_wiring

USB_DIR = firmware_board.FIRMWARE_DIR / 'boards' / 'nucleo_f446re' / 'usb'
WIRING = load_wiring(PINS, usb=True)
GRID = (16, 16)
SCANS = 8
FRAMES = int(os.environ.get('SKIN_REHOST_USB_FRAMES', '30'))
ADDRESS = 5
CDC_CLASS, CDC_DATA_CLASS, ACM_SUBCLASS = 0x02, 0x0A, 0x02


def _defines(path: Path) -> dict:
    """Return the integer #defines and enum members of a C header."""
    text = Path(path).read_text()
    found = {name: int(value, 0) for name, value in
             re.findall(r'#define\s+(\w+)\s+(0x[0-9A-Fa-f]+|\d+)u?\b', text)}
    found.update({name: int(value) for name, value in re.findall(r'(USB_STR_\w+) = (\d+)', text)})
    return found


DESC = _defines(USB_DIR / 'usb_desc.h')
EP0_SIZE = _defines(USB_DIR / 'tusb_config.h')['CFG_TUD_ENDPOINT0_SIZE']
STRINGS = {DESC[f'USB_STR_{name}']: text for name, text in
           re.findall(r'\[USB_STR_(\w+)\] = "([^"]*)"', (USB_DIR / 'usb_desc.c').read_text())}


def _skin():
    """Return scans of an unloaded skin (100 counts), top taxel (k, 2k) pressed in scan k."""
    top = np.full((SCANS,) + GRID, 100, np.uint16)
    for k in range(SCANS):
        top[k, k, 2 * k] = 3000
    return top, np.full_like(top, 100)


def _table(chip, image, name):
    """Return the bytes of the image's static table name as the chip's flash holds them."""
    address = image.address(name)
    return bytes(chip.uc.mem_read(address, image.symbols[name][1]))


def _configured(image, dtr=True):
    """Return (chip, host) with the device enumerated at ADDRESS and configured (port open)."""
    chip = Chip(image, WIRING, *_skin(), WIRING.scan_rate_hz)
    host = ScriptedHost(chip)
    host.attach()
    host.reset()
    host.set_address(ADDRESS)
    host.set_configuration(1)
    host.set_line_coding()
    if dtr:
        host.set_lines(True)
    return chip, host


@pytest.fixture(scope='module')
def usb_image(nucleo_usb_image):
    """Return the USB image, loaded."""
    return ElfImage.load(nucleo_usb_image)


@pytest.fixture(scope='module')
def session(usb_image):
    """Enumerate as a PC does, configure, open the port and read FRAMES frames; record it all."""
    chip = Chip(usb_image, WIRING, *_skin(), WIRING.scan_rate_hz)
    host = ScriptedHost(chip)
    got = {}
    host.attach()
    host.reset()
    # Linux's first look: 64 bytes of the device descriptor at address 0, then a second reset.
    got['first'] = host.get_descriptor('device', length=64)
    host.reset()
    host.set_address(ADDRESS)
    got['address'] = chip.debug_read(0x5000_0800) >> 4 & 0x7F     # OTG_DCFG DAD
    got['device'] = host.get_descriptor('device', length=18)
    head = host.get_descriptor('configuration', length=9)
    got['configuration'] = host.get_descriptor('configuration', length=head[2] | head[3] << 8)
    got['langids'] = host.get_descriptor('string', 0, langid=0)
    got['strings'] = {i: host.get_string(i) for i in range(1, DESC['USB_STR_COUNT'])}
    host.set_configuration(1)
    host.set_line_coding()
    host.set_lines(True)
    decoder = FrameDecoder(expected_shape=GRID)
    frames, raw, sizes = [], bytearray(), []

    def sink(packet):
        sizes.append(len(packet))
        raw.extend(packet)
        frames.extend(decoder.feed(packet))

    host.bulk_in(DESC['USB_EP_IN'] & 0xF, sink, lambda: len(frames) >= FRAMES)
    got['sizes'] = sizes
    tables = {name: _table(chip, usb_image, name) for name in ('device', 'configuration')}
    got.update(chip=chip, host=host, frames=frames, decoder=decoder, raw=bytes(raw),
               tables=tables)
    return got


def test_the_device_descriptor_is_the_firmwares(session):
    device = session['device']
    # Byte for byte usb_desc.c's table, and what usb_desc.h and tusb_config.h say it must hold.
    assert device == session['tables']['device']
    assert session['first'] == device       # asked 64, given its 18
    (length, kind, bcd_usb, cls, subclass, protocol, ep0, vid, pid, bcd_device, i_manufacturer,
     i_product, i_serial, configurations) = struct.unpack('<BBHBBBBHHHBBBB', device)
    assert (length, kind, bcd_usb) == (18, 1, 0x0200)
    assert (cls, subclass, protocol) == (0xEF, 0x02, 0x01)     # IAD: a composite function
    assert ep0 == EP0_SIZE == 64
    assert (vid, pid, bcd_device) == (DESC['USB_DESC_VID'], DESC['USB_DESC_PID'],
                                      DESC['USB_DESC_BCD_DEVICE'])
    assert (i_manufacturer, i_product, i_serial) == (
        DESC['USB_STR_MANUFACTURER'], DESC['USB_STR_PRODUCT'], DESC['USB_STR_SERIAL'])
    assert configurations == 1


def test_set_address_reaches_the_core(session):
    assert session['address'] == ADDRESS


def test_the_configuration_is_one_cdc_acm_function_with_64_byte_bulk_endpoints(session):
    data = session['configuration']
    assert data == session['tables']['configuration']
    parts = parse_descriptors(data)
    kind, config = parts[0]
    total, interfaces, value = struct.unpack('<HBB', config[2:6])
    assert (kind, total, interfaces, value) == (2, len(data), 2, 1)
    assoc = [d for k, d in parts if k == 11]
    assert [(d[2], d[3], d[4], d[5]) for d in assoc] == [(0, 2, CDC_CLASS, ACM_SUBCLASS)]
    found = [(d[2], d[5], d[6]) for k, d in parts if k == 4]
    assert found == [(0, CDC_CLASS, ACM_SUBCLASS), (1, CDC_DATA_CLASS, 0)]
    # The class-specific descriptors: header, call management, ACM, union (master 0, slave 1).
    functional = [d for k, d in parts if k == 0x24]
    assert [d[2] for d in functional] == [0x00, 0x01, 0x02, 0x06]
    assert functional[3][3:5] == bytes([0, 1])
    endpoints = {d[2]: (d[3] & 3, d[4] | d[5] << 8) for k, d in parts if k == 5}
    assert endpoints == {DESC['USB_EP_NOTIFY']: (3, DESC['USB_EP_NOTIFY_SIZE']),
                         DESC['USB_EP_OUT']: (2, DESC['USB_EP_BULK_SIZE']),
                         DESC['USB_EP_IN']: (2, DESC['USB_EP_BULK_SIZE'])}
    assert DESC['USB_EP_BULK_SIZE'] == 64


def test_the_strings_are_usb_desc_cs_and_the_serial_is_the_uid(session):
    assert session['langids'] == bytes([4, 3, 0x09, 0x04])      # English (US) only
    expected = dict(STRINGS)
    expected[DESC['USB_STR_SERIAL']] = DEFAULT_UID.hex()        # the board's unique ID, in hex
    assert session['strings'] == expected


def test_bulk_in_carries_intact_frames_of_the_scans_the_skin_showed(session):
    frames, decoder = session['frames'], session['decoder']
    top, bottom = _skin()
    stats = decoder.stats
    assert (stats.crc_errors, stats.size_errors, stats.version_errors) == (0, 0, 0)
    assert (stats.seq_gaps, stats.frames_missed, stats.bytes_discarded) == (0, 0, 0)
    # The port opened on a frame boundary, the information frame's (checked below).
    assert session['raw'][:2] == bytes([0xA5, 0x69])
    assert {f.version for f in frames} == {2}
    first = frames[0].seq
    assert [f.seq for f in frames] == list(range(first, first + len(frames)))
    for frame in frames:
        index = frame.device_time_us * WIRING.scan_rate_hz // 1_000_000 % SCANS
        assert np.array_equal(frame.top, top[index]), f'seq {frame.seq}'
        assert np.array_equal(frame.bottom, bottom[index]), f'seq {frame.seq}'
    assert len({f.device_time_us * WIRING.scan_rate_hz // 1_000_000 % SCANS
                for f in frames}) == SCANS                   # every scan of the loop seen
    # Packets of the endpoint's 64 bytes, a transfer's last one shorter.
    assert max(session['sizes']) == DESC['USB_EP_BULK_SIZE']
    chip = session['chip']
    assert chip.errors == []
    assert chip.stats['irq67'] > 0                          # the stack ran from its interrupt
    # The board named itself when the port opened, and again every second of device time.
    info = decoder.board_info
    assert (info.board, info.uid, info.rows, info.cols, info.rate_hz) == (
        'nucleo-f446re', DEFAULT_UID.hex(), 16, 16, WIRING.scan_rate_hz)
    seconds = (frames[-1].device_time_us - frames[0].device_time_us) // 1_000_000
    assert stats.info_frames == 1 + seconds


def test_a_port_not_opened_gets_no_byte_and_the_first_after_dtr_names_the_board(usb_image):
    # Configured but DTR never raised (no program has the port open): the board discards its
    # frames and the bulk endpoint NAKs; expected: a timeout, frames counted as discarded.
    chip, host = _configured(usb_image, dtr=False)
    with pytest.raises(UsbTimeout, match='bulk IN on endpoint 2'):
        host.bulk_in(2, lambda packet: pytest.fail(f'{len(packet)} bytes before DTR'),
                     lambda: False)
    assert chip.symbol_u32('usb_link_discarded') > 0
    assert chip.errors == []
    # Then the port opens: the first packet starts the information frame (marker, info version
    # 1), whole, and a data frame follows it, not one of the next second.
    host.set_lines(True, rts=False)
    packets, decoder = [], FrameDecoder(expected_shape=GRID)
    frames = []

    def sink(packet):
        packets.append(packet)
        frames.extend(decoder.feed(packet))

    host.bulk_in(2, sink, lambda: frames)
    assert packets[0][:3] == bytes([0xA5, 0x69, 1])
    assert decoder.board_info.board == 'nucleo-f446re'
    assert (decoder.stats.info_frames, decoder.stats.bytes_discarded) == (1, 0)


def test_a_string_the_firmware_has_not_is_stalled_and_the_next_request_answered(usb_image):
    # Expected: STALL on the data stage (tud_descriptor_string_cb returns NULL), then a SETUP
    # clears it and the device answers the next request.
    chip, host = _configured(usb_image)
    missing = DESC['USB_STR_COUNT'] + 3
    with pytest.raises(Stalled):
        host.get_string(missing)
    assert host.get_string(DESC['USB_STR_PRODUCT']) == STRINGS[DESC['USB_STR_PRODUCT']]
    assert chip.errors == []


def test_an_interrupt_no_model_raises_is_reported_when_enabled(usb_image):
    chip = Chip(usb_image, WIRING, *_skin(), WIRING.scan_rate_hz)
    chip.debug_write(0xE000_E104, 1 << (37 - 32))       # NVIC_ISER1: USART1 (IRQ 37)
    assert chip.errors == ['interrupt 37 enabled: no model raises it']


def test_what_usb_costs_the_cpu_is_counted_by_part(usb_image):
    # Instructions per scan on the rehost (skin_driver/tools/rehost/cost.py), not a time: every
    # part counted, each function where its caller puts it (the write path under the link, the
    # handler under the interrupt, the frame under the scan), and one scan counted a period.
    count, rate = cost.measure(usb=True, scans=10, warmup=3, image=usb_image)
    assert rate == WIRING.scan_rate_hz
    assert 9 <= count.scans <= 11
    assert all(count.counts[part] > 0 for part in cost.PARTS), count.counts
    parts = {}
    for part, name in count.by_function:
        parts.setdefault(name, set()).add(part)
    assert parts['OTG_FS_IRQHandler'] == {'interrupt'}
    assert parts['tud_task_ext'] == parts['tud_cdc_n_write_flush'] == {'link'}
    assert parts['skin_frame_finish'] == parts['skin_scan_fill'] == {'scan'}
    assert parts['board_delay_us'] == {'wait'}
    unattributed = sum(n for (_, name), n in count.by_function.items() if name is None)
    assert unattributed < 0.01 * sum(count.counts.values())
