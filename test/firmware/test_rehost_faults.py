"""
Faults injected into the rehosted Nucleo-F446RE (skin_driver/tools/rehost): none hangs the board.

Each fault is switched on after the board runs cleanly, and off again where it would last for
ever. In each: every frame the host accepts is valid (the stream decoded afresh has no corrupt
or malformed frame, every count is 12 bits and every row the board marks as sampled is the
skin's), the board sends valid frames again within 1 s of device time, and the host names the
fault from the board's information frame (docs/firmware.md, "Faults and their bounds"). The
image sends protocol version 2 (its default): a row it failed to sample is marked, not sent as
counts.
"""

import numpy as np
import pytest

from skin_driver.core.common.boardhealth import BoardHealth
from skin_driver.core.protocol.wire import FrameDecoder
from skin_driver.tools.rehost.board import PINS
from skin_driver.tools.rehost.chip import Chip, Faults
from skin_driver.tools.rehost.elf import ElfImage
from skin_driver.tools.rehost.wiring import load_wiring

GRID = (16, 16)
WIRING = load_wiring(PINS)
RATE = WIRING.scan_rate_hz
PRESSED = (5, 3)


class Host:
    """What the host reads from the chip: every byte, and the frames with their device time."""

    def __init__(self, chip):
        self.chip = chip
        self.raw = bytearray()
        self.decoder = FrameDecoder(expected_shape=GRID)
        self.frames = []  # (device time in s when the frame was whole, frame)
        self.infos = []
        chip.sink = self._take

    def _take(self, data):
        self.raw += data
        for frame in self.decoder.feed(data):
            self.frames.append((self.chip.now / 1e9, frame))
        info = self.decoder.board_info
        if info is not None and (not self.infos or self.infos[-1] is not info):
            self.infos.append(info)

    def run(self, seconds):
        self.chip.run(until_s=self.chip.now / 1e9 + seconds, wall_s=150)

    def frames_after(self, t_s):
        return [frame for at, frame in self.frames if at > t_s]

    def health(self):
        return BoardHealth.of(self.infos[-1])

    def assert_nothing_invalid(self):
        """No frame or information frame the host would reject, and every count 12 bits."""
        again = FrameDecoder(expected_shape=GRID)
        again.feed(bytes(self.raw))
        stats = again.stats
        assert (stats.crc_errors, stats.size_errors, stats.version_errors,
                stats.info_errors) == (0, 0, 0, 0), stats
        skin = np.full(GRID, 100)
        skin[PRESSED] = 3000
        for _, frame in self.frames:
            assert frame.top.max() <= 4095 and frame.bottom.max() <= 4095
            # The skin shows one press: a row the board says it sampled with another pattern
            # would be a row misplaced, or a failed one sent as counts.
            valid = np.ones((2, GRID[0]), bool) if frame.row_valid is None else frame.row_valid
            assert np.array_equal(frame.top[valid[0]], skin[valid[0]]), frame.seq
            assert (frame.bottom[valid[1]] == 100).all(), frame.seq


def _chip(nucleo_image, **faults):
    top = np.full((4,) + GRID, 100, np.uint16)
    top[(slice(None),) + PRESSED] = 3000
    return Chip(ElfImage.load(nucleo_image), WIRING, top, np.full_like(top, 100), RATE,
                faults=Faults(**faults))


def _valid_again_within_one_second(host, since_s):
    after = host.frames_after(since_s)
    assert after, f'no frame after {since_s:.3f} s; board says {host.infos[-1].text}'
    first = next(at for at, _ in host.frames if at > since_s)
    assert first - since_s < 1.0


FAULT_AT_S = 0.3


def test_a_tx_dma_that_never_completes_again(nucleo_image):
    # From 0.3 s on the DMA never serves the USART: the link times out, the board resets the
    # USART and sends by the CPU; frames resume at once, with one lost (a sequence gap).
    host = Host(_chip(nucleo_image, tx_dma_stuck=True, from_s=FAULT_AT_S))
    host.run(1.6)
    host.assert_nothing_invalid()
    _valid_again_within_one_second(host, FAULT_AT_S + 0.05)
    assert host.chip.errors == []
    health = host.health()
    assert health.count('link_to') >= 1
    assert any('link timeouts' in p for p in health.problems(None))
    assert host.decoder.stats.frames_missed <= 1 + host.chip.now / 1e9  # one a DMA retry


def test_an_adc_overrun_on_one_row(nucleo_image):
    # Row 5 of the top layer overruns on every scan from 0.3 s: every frame is still sent, with
    # that row marked not sampled and the row-failed fault bit (never its counts), and counted
    # as flagged; the information frame names it; once the ADC is sound the row is valid again.
    host = Host(_chip(nucleo_image, adc_overrun_row=(0, 5), from_s=FAULT_AT_S))
    host.run(1.4)
    marked = host.frames_after(FAULT_AT_S + 0.02)
    assert len(marked) > 100  # 1.1 s at 100 scans/s: the scan rate kept
    for frame in marked:
        assert frame.faults & 1 and not frame.row_valid[0, 5], frame.seq
        assert frame.row_valid.sum() == 2 * GRID[0] - 1 and (frame.top[5] == 0).all()
    health = host.health()
    assert health.count('flagged') >= 1 and health.count('adc_ovr') == 2 * health.count('flagged')
    assert health.count('drop') is None  # a version-2 board counts what it flagged instead
    problems = health.problems(None)
    assert any('frames sent with a row the board failed to sample marked' in p for p in problems)
    assert any('ADC overruns' in p for p in problems)
    healed_at = host.chip.now / 1e9
    host.chip.faults = Faults()
    host.run(1.2)
    _valid_again_within_one_second(host, healed_at)
    assert all(f.row_valid is None for f in host.frames_after(healed_at + 0.02))
    host.assert_nothing_invalid()
    # Every scan was sent under its number: no gap for the host to blame on the line.
    assert host.decoder.stats.seq_gaps == 0


def test_hse_absent_at_boot_falls_back_to_the_hsi(nucleo_image):
    host = Host(_chip(nucleo_image, hse_absent=True))
    host.run(1.0)
    host.assert_nothing_invalid()
    _valid_again_within_one_second(host, 0.0)
    assert host.chip.clock_report()['sysclk_mhz'] == pytest.approx(180.0)
    health = host.health()
    assert health.clock == 'hsi'
    assert any('internal 16 MHz' in p for p in health.problems(None))


def test_the_host_not_reading(nucleo_image):
    # The board never learns that nobody reads (no flow control): it goes on, and the host that
    # reads again gets valid frames at once.
    host = Host(_chip(nucleo_image, host_not_reading=True, from_s=FAULT_AT_S))
    host.run(1.0)
    back_at = host.chip.now / 1e9
    host.chip.faults = Faults()
    host.run(0.5)
    host.assert_nothing_invalid()
    _valid_again_within_one_second(host, back_at)
    assert host.health().count('link_to') == 0


def _rows_alike_while_pressed(frame):
    """Tell whether a layer has every row equal while a count is well above idle (100)."""
    return any((layer == layer[0]).all() and layer.max() > 1000
               for layer in (frame.top, frame.bottom))


def test_a_mux_stuck_on_one_row_while_pressed(nucleo_image):
    # Both muxes select input 5 from 0.3 s while the skin is pressed at row 5: every top row
    # would read 3000 at column 3. The board sends none of those scans (every row of the top
    # layer alike while pressed: counted as mux only, not as a flagged row) and names it; the mux
    # freed, valid frames come back within 1 s.
    host = Host(_chip(nucleo_image, mux_stuck_channel=5, from_s=FAULT_AT_S))
    host.run(1.4)  # past the information frame of 1 s
    assert host.chip.stats['mux_stuck_samples'] > 0
    assert host.frames_after(FAULT_AT_S + 0.02) == []
    assert not any(_rows_alike_while_pressed(f) for _, f in host.frames)
    health = host.health()
    assert health.count('mux') >= 2 and health.count('flagged') == 0
    assert any('(row mux stuck?)' in p for p in health.problems(None))
    healed_at = host.chip.now / 1e9
    host.chip.faults = Faults()
    host.run(1.2)
    _valid_again_within_one_second(host, healed_at)
    host.assert_nothing_invalid()
    assert not any(_rows_alike_while_pressed(f) for _, f in host.frames)
    assert host.decoder.stats.seq_gaps == 0


def test_a_hang_ends_in_a_watchdog_reset_and_frames_within_one_second(nucleo_image):
    # TIM2, the device clock, stopped by a debugger's write: the settle delay never ends. The
    # IWDG resets the board, which says why and sends frames again.
    host = Host(_chip(nucleo_image))
    host.run(0.3)
    hung_at = host.chip.now / 1e9
    host.chip.debug_write(0x4000_0000, 0)  # TIM2_CR1: CEN off
    host.run(1.0)
    assert host.chip.stats['resets'] == 1
    # Past the frame that was on the line when the clock stopped (11.4 ms).
    _valid_again_within_one_second(host, hung_at + 0.02)
    host.assert_nothing_invalid()
    # The board starts over: its frames count from 0 again after the reset.
    seqs = [frame.seq for _, frame in host.frames]
    assert 0 in seqs[1:]
    assert host.health().reset == 'iwdg'
    assert any('independent watchdog' in p for p in host.health().problems(None))
    # Every version-2 frame since says so too (fault bit 4, docs/protocol.md "Fault bits"); none
    # before the hang did.
    restarted = seqs.index(0, 1)
    frames = [frame for _, frame in host.frames]
    assert all(frame.faults & 1 << 4 for frame in frames[restarted:])
    assert not any(frame.faults for frame in frames[:restarted])
