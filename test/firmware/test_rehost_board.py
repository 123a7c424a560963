"""
The unmodified Nucleo-F446RE image on the rehosted chip (skin_driver/tools/rehost).

Through the driver's link and decoder: every frame intact and in order from the first whole one
on, each carrying the scan the skin showed at its device time, so the contacts are the
simulator's. Without the driver: the clock tree the firmware sets up, a wiring mistake seen as a
moved taxel, and each fault switch taking effect in its model. SKIN_REHOST_SCANS sets the
scans of the long run (1 000; ``make soak-rehost`` runs 10 000).
"""

import os
import signal
import struct
import subprocess
import sys
import time

import numpy as np
from port_reader import Collector, TapDecoder
import pytest
import serial

from skin_driver.core.estimation.scan.pipeline import ContactEstimator
from skin_driver.core.protocol.link import CONNECTED, SerialLink
from skin_driver.core.protocol.wire import frame_size, FrameDecoder
from skin_driver.core.sim.scene import load_scene
from skin_driver.tools import firmware_board
from skin_driver.tools.rehost import clock
from skin_driver.tools.rehost.board import PINS, RehostBoard
from skin_driver.tools.rehost.chip import Chip, Faults
from skin_driver.tools.rehost.elf import ElfImage
from skin_driver.tools.rehost.wiring import load_wiring

SCANS = int(os.environ.get('SKIN_REHOST_SCANS', '1000'))
GRID = (16, 16)
WIRING = load_wiring(PINS)
RATE = WIRING.scan_rate_hz
FRAME = frame_size(*GRID, 2)  # the image sends protocol version 2 (its default)


def _frames(chip, seconds):
    """Run chip for seconds of device time; return the frames and the decoder."""
    decoder = FrameDecoder(expected_shape=GRID)
    frames = []
    chip.sink = lambda data: frames.extend(decoder.feed(data))
    chip.run(until_s=chip.now / 1e9 + seconds, wall_s=120)
    return frames, decoder


def _press(row, col, count=3000, scans=4):
    """Return scans of an unloaded skin (100 counts) but one pressed taxel of the top layer."""
    top = np.full((scans,) + GRID, 100, np.uint16)
    top[:, row, col] = count
    return top, np.full_like(top, 100)


@pytest.mark.timeout(1800 if SCANS > 1000 else 170)
def test_a_thousand_scans_through_the_driver(nucleo_image, tmp_path):
    scene = load_scene('random')
    top, bottom = firmware_board.render_scans(scene, SCANS, SCANS / scene.duration_s)
    decoder = TapDecoder(expected_shape=GRID)
    collector = Collector(SCANS)
    received, enough = collector.frames, collector.enough

    board = RehostBoard(nucleo_image, top, bottom, str(tmp_path / 'skin0'), realtime=False)
    port = board.start()
    states = []
    link = SerialLink(port, WIRING.baud, decoder, collector,
                      on_state=lambda state, detail: states.append(state), stall_timeout_s=60.0)
    started = time.monotonic()
    try:
        link.start()
        assert enough.wait(160 if SCANS <= 1000 else 1700), \
            f'{len(received)} frames; chip: {board.failure} {board.chip.errors}'
    finally:
        link.stop()
        board.stop()
    took = time.monotonic() - started
    frames = received[:SCANS]
    chip = board.chip

    assert chip.errors == [] and board.failure is None
    assert states.count(CONNECTED) == 1, f'the link reopened the port: {states}'
    stats = decoder.stats
    gaps = [(a.seq, a.device_time_us, b.seq) for a, b in zip(received, received[1:])
            if b.seq != a.seq + 1]
    assert (stats.seq_gaps, stats.frames_missed, stats.seq_implausible) == (0, 0, 0), \
        (stats, gaps, chip.stats)
    first = frames[0].seq
    assert [f.seq for f in frames] == list(range(first, first + SCANS))
    # From the first whole frame on, not one check fails, the stream decoded afresh.
    raw = bytes(decoder.raw)
    # The image sends protocol version 2 (its default): a clean frame's flags are 0.
    assert {f.version for f in frames} == {2}
    start = raw.find(struct.pack('<BBBBI', 0xA5, 0x5A, 2, 0, first))
    assert start >= 0
    again = FrameDecoder(expected_shape=GRID)
    again.feed(raw[start:])
    checked = again.stats
    assert (checked.crc_errors, checked.size_errors, checked.version_errors) == (0, 0, 0)
    assert checked.frames >= SCANS and checked.bytes_discarded == 0 and checked.info_errors == 0
    info = decoder.board_info
    assert (info.board, info.uid, info.rows, info.cols, info.rate_hz) == (
        'nucleo-f446re', '39001e000b51383439393134', 16, 16, RATE)

    # Each frame holds the scan the skin showed at the frame's device time (the scan period
    # after the TIM5 tick that started it), so its contacts are the simulator's for that scan.
    estimator = ContactEstimator()
    with_contacts = 0
    for frame in frames:
        index = frame.device_time_us * RATE // 1_000_000 % SCANS
        assert np.array_equal(frame.top, top[index]), f'seq {frame.seq}'
        assert np.array_equal(frame.bottom, bottom[index]), f'seq {frame.seq}'
        got = estimator.process(frame.top, frame.bottom)
        assert got == estimator.process(top[index], bottom[index]), f'seq {frame.seq}'
        with_contacts += bool(got)
    assert with_contacts > SCANS // 10
    device_s = (frames[-1].device_time_us - frames[0].device_time_us) / 1e6
    print(f'\n{SCANS} scans through the driver in {took:.1f} s wall ({SCANS / took:.0f} '
          f'scans/s), {device_s:.1f} s of device time ({SCANS / device_s:.0f} scans/s), '
          f'{with_contacts} with contacts')


def test_the_clock_tree_is_the_one_the_firmware_means(nucleo_image):
    top, bottom = _press(0, 0)
    chip = Chip(ElfImage.load(nucleo_image), WIRING, top, bottom, RATE)
    _frames(chip, 0.02)
    report = chip.clock_report()
    assert report['source'] == 'hse'
    assert report['sysclk_mhz'] == pytest.approx(180.0)
    assert report['vco_mhz'] == pytest.approx(360.0)
    assert report['vco_in_mhz'] == pytest.approx(2.0)
    assert report['overdrive'] is True
    assert report['flash_wait_states'] == 5
    assert (report['apb1_mhz'], report['apb2_mhz']) == pytest.approx((45.0, 90.0))
    assert report['adc_mhz'] == pytest.approx(22.5)
    assert report['baud'] == pytest.approx(921600, rel=0.01)
    assert report['violations'] == [] and chip.errors == []


def test_a_pll_multiplier_of_200_breaks_the_datasheets_limits(nucleo_image):
    # nucleo_clock_init's `orr.w r3, r3, #0x2d00` (PLLN 180 << 6) patched to #0x3200 (PLLN
    # 200, the same Thumb-2 rotation): VCO 400 MHz, SYSCLK 200 MHz with 5 wait states.
    image = ElfImage.load(nucleo_image)
    text = image.segments[0].data
    orr = bytes.fromhex('43f43453')
    assert text.count(orr) == 1
    data = bytearray(image.data)
    at = image.file_offset(image.segments[0].paddr + text.index(orr)) + 2
    data[at] = 0x48
    top, bottom = _press(0, 0)
    chip = Chip(ElfImage(bytes(data)), WIRING, top, bottom, RATE)
    chip.run(until_s=0.002, wall_s=60)
    report = chip.clock_report()
    assert (report['vco_mhz'], report['sysclk_mhz']) == pytest.approx((400.0, 200.0))
    assert sorted(v.split()[0] for v in report['violations']) == ['5', 'APB1', 'APB2', 'HCLK']


def test_two_columns_swapped_in_the_pin_table_move_a_taxel(nucleo_image):
    image = ElfImage.load(nucleo_image)
    # The image's own copy of SKIN_BOARD_COLUMNS (column -> ADC channel), columns 0 and 3
    # swapped: both on ADC1, so the image stays valid for the ADCs, only wrong for the expander.
    table = image.data[image.file_offset(image.address('column_channel')):][:16]
    assert list(table) == [ch for ch, _ in sorted(WIRING.channel_column.items(),
                                                  key=lambda kv: kv[1])]
    swapped = bytes([table[3], table[1], table[2], table[0]])
    variant = image.patched('column_channel', 0, swapped)
    top, bottom = _press(5, 3)
    right, _ = _frames(Chip(image, WIRING, top, bottom, RATE), 0.05)
    wrong, _ = _frames(Chip(variant, WIRING, top, bottom, RATE), 0.05)
    assert right and wrong
    assert {np.unravel_index(np.argmax(f.top), GRID) for f in right} == {(5, 3)}
    assert {np.unravel_index(np.argmax(f.top), GRID) for f in wrong} == {(5, 0)}


# ---- fault switches: each takes effect in its model (what the firmware then does is not
# asserted here: that is the fault-tolerance work's to define) -------------------------------

def _chip(nucleo_image, **faults):
    top, bottom = _press(5, 3)
    return Chip(ElfImage.load(nucleo_image), WIRING, top, bottom, RATE, faults=Faults(**faults))


def test_a_stuck_tx_dma_never_sets_its_transfer_complete_flag(nucleo_image):
    chip = _chip(nucleo_image, tx_dma_stuck=True)
    chip.run(until_s=0.003, wall_s=60)
    assert chip.stats['tx_dma_started'] >= 1
    assert chip.stats['tx_dma_completed'] == 0 and chip.stats['bytes_sent'] == 0
    assert not chip.dma2.read(0x04) & (1 << 27)          # DMA_HISR TCIF7
    assert chip.dma2.streams[7][0] & 1, 'the stream stays enabled'


def test_an_adc_overrun_on_a_row_stops_its_dma_requests(nucleo_image):
    chip = _chip(nucleo_image, adc_overrun_row=(0, 5))
    chip.run(until_s=0.05, wall_s=60)
    # Once a scan, row 5 of the top layer: ADC1's OVR set after the first rank's 3 transfers.
    assert chip.stats['adc_overruns'] >= 3
    assert chip.stats['adc_ovr_set'] == chip.stats['adc_overruns']


def test_an_absent_hse_never_becomes_ready(nucleo_image):
    chip = _chip(nucleo_image, hse_absent=True)
    chip.run(until_s=0.5, wall_s=120)
    assert chip.stats['hse_refused'] >= 1
    assert not chip.rcc.regs[0] & clock.HSERDY


def test_a_host_not_reading_gets_no_byte(nucleo_image):
    chip = _chip(nucleo_image, host_not_reading=True)
    frames, _ = _frames(chip, 0.05)
    assert frames == [] and chip.stats['bytes_sent'] == 0
    assert chip.stats['bytes_dropped'] >= 2 * FRAME


def test_a_stuck_mux_below_the_press_level_shows_one_row_everywhere(nucleo_image):
    # 1000 counts at (5, 3), not above the board's press level (1024, skin_fw/mux_check.h): the
    # board cannot tell rows alike from a stuck mux and sends them, input 5's row in every row.
    # Pressed (3000), it sends none of them: test_rehost_faults.
    top, bottom = _press(5, 3, count=1000)
    chip = Chip(ElfImage.load(nucleo_image), WIRING, top, bottom, RATE,
                faults=Faults(mux_stuck_channel=5))
    frames, _ = _frames(chip, 0.05)
    assert frames and chip.stats['mux_stuck_samples'] > 0
    for frame in frames:
        assert (frame.top[:, 3] == 1000).all() and (frame.top[:, :3] == 100).all()


def test_stopping_and_running_on_anywhere_changes_no_byte(nucleo_image):
    # unicorn restarts the instruction whose access stopped the CPU: stopped every 370 us of
    # device time (inside rows, CRC feeds and waits), the chip must send what a run in one go
    # sends, each access having one effect.
    sent = []
    for step in (None, 0.00037):
        top, bottom = _press(5, 3)
        chip = Chip(ElfImage.load(nucleo_image), WIRING, top, bottom, RATE)
        chip.sink = (out := bytearray()).extend
        until = 0.0
        while until < 0.06:
            until = 0.06 if step is None else until + step
            chip.run(until_s=until, wall_s=60)
        assert chip.errors == []
        sent.append(bytes(out))
    assert len(sent[0]) > 4 * FRAME
    assert sent[1] == sent[0]


def test_the_firmware_runs_the_independent_watchdog_and_feeds_it(nucleo_image):
    # The firmware starts the IWDG at boot (watchdog.c: LSI / 32, reload 250, 250 ms at 32 kHz;
    # RM0390 20.3) and feeds it once per healthy scan: no reset while it runs. A hang ended by
    # it: test_rehost_faults.py.
    chip = _chip(nucleo_image)
    frames, _ = _frames(chip, 0.6)
    assert (chip.debug_read(0x4000_3004), chip.debug_read(0x4000_3008)) == (3, 249)
    assert frames and chip.stats['resets'] == 0
    assert chip.debug_read(0x4002_3874) & clock.CSR_IWDG == 0


def test_command_line_board_streams_on_its_link_and_stops_on_sigint(nucleo_image, tmp_path):
    link = tmp_path / 'skin0'
    proc = subprocess.Popen(
        [sys.executable, '-m', 'skin_driver.tools.rehost', '--scene', 'seed', '--scans', '50',
         '--link', str(link), '--image', str(nucleo_image)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().split() == ['SKIN_PORT', str(link)]
        decoder = FrameDecoder(expected_shape=GRID)
        port = serial.serial_for_url(str(link), timeout=0.2)
        frames = []
        try:
            while len(frames) < 20 and proc.poll() is None:
                frames += decoder.feed(port.read(4096))
        finally:
            port.close()
        assert len(frames) >= 20
        proc.send_signal(signal.SIGINT)
        assert proc.wait(20) == 0
        assert 'SKIN_EPOCH' in proc.stderr.read()
        assert not link.exists()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
