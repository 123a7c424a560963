"""
The simulated board frames through the firmware core built for the host (skin_fw_host).

Its frames and information frames are held against the host's independent reading of
docs/protocol.md (core.protocol.wire's encoder) on hard cases, and what it sends on the pty is
the firmware's frame of the scan it reports as its truth.
"""

import os
import subprocess
import sys

import numpy as np
from port_reader import read_from
import pytest

from skin_driver.core.protocol.wire import (BoardInfo, encode_frame, encode_info, FrameDecoder,
                                            MAX_DEVICE_TIME_US, MAX_SEQ)
from skin_driver.core.sim import firmware
from skin_driver.core.sim.board import sim_board_info, SimulatedSkin
from skin_driver.core.sim.firmware import Framer, info_frame, InfoSchedule, row_map
from skin_driver.core.sim.scene import scene_from_dict

ROW_FAILED = 0x0001  # firmware/core/include/skin_fw/frame.h: SKIN_FAULT_ROW_FAILED


def layers(rows, cols, seed=0):
    rng = np.random.default_rng(seed)
    return rng.integers(0, 4096, (2, rows, cols)).astype(np.uint16)


# (version, rows, cols, seq, device time): the wraps of both counters, odd grids whose row map
# has spare bits and whose packed counts need padding, the smallest and a wide grid.
CASES = [(version, *case) for version in (1, 2) for case in [
    (16, 16, 1, 1000),
    (9, 5, MAX_SEQ, 2**32 - 1),          # the sequence's last number, the 32-bit clock's
    (1, 1, 0, 2**32),                    # past the board's 32-bit clock
    (3, 255, 7, MAX_DEVICE_TIME_US),     # the last device time
    (128, 2, 123_456, 71 * 60 * 10**6)]]


@pytest.mark.parametrize('version, rows, cols, seq, time_us', CASES)
def test_a_clean_frame_is_the_protocols(version, rows, cols, seq, time_us):
    counts = layers(rows, cols, seq)
    raw = Framer(rows, cols, version).frame(seq, time_us, counts)
    assert raw == encode_frame(seq, time_us, counts[0], counts[1], version)


def test_failed_rows_and_fault_bits_are_the_protocols_with_the_firmwares_summary():
    rows, cols = 11, 4
    counts = layers(rows, cols)
    valid = np.ones((2, rows), bool)
    valid[0, 0] = valid[1, 10] = valid[1, 3] = False
    framer = Framer(rows, cols, 2)
    # The firmware adds the row-failed bit to the fault bits of a frame with a failed row.
    raw = framer.frame(5, 6, counts, 0b100, row_map(valid))
    assert raw == encode_frame(5, 6, counts[0], counts[1], 2, 0b100 | ROW_FAILED, valid)
    frames = FrameDecoder().feed(raw)
    assert frames[0].faults == 0b101 and np.array_equal(frames[0].row_valid, valid)
    # Fault bits alone: no row map flag.
    assert framer.frame(5, 6, counts, 0x10) == encode_frame(5, 6, counts[0], counts[1], 2, 0x10)


def test_counts_of_another_shape_or_type_are_refused():
    framer = Framer(4, 4, 2)
    with pytest.raises(ValueError, match='uint16 of shape'):
        framer.frame(0, 0, layers(4, 5))
    with pytest.raises(ValueError, match='uint16 of shape'):
        framer.frame(0, 0, layers(4, 4).astype(np.int32))


@pytest.mark.parametrize('info', [
    sim_board_info(16, 16, 0.005, 100.0),
    sim_board_info(255, 1, 0.0125, 20_000.0, 'left palm'),
    # A board with health, as a test may have the simulated board claim.
    BoardInfo.parse('board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=16x16;'
                    'pitch_um=5000;rate_hz=100;reset=iwdg;clock=hse;drop=3;adc_ovr=3')])
def test_the_information_frame_is_the_protocols(info):
    assert info_frame(info) == encode_info(info)


def test_the_schedule_is_the_firmwares_on_hard_cases():
    # Expected sends: the first scan; the first at or after each whole period since the last
    # was due (a late scan delays one); after a stall of over a period one, a period later the
    # next; past the 32-bit wrap of the board's clock.
    schedule = InfoSchedule(1_000_000)
    times = [0, 400_000, 1_300_000, 2_000_000, 7_300_000, 8_000_000, 8_300_000,
             2**32 + 8_299_999, 2**32 + 8_300_000, 2**32 + 9_300_000]
    sent = []
    for t in times:
        if schedule.due(t):
            schedule.sent(t)
            sent.append(t)
    assert sent == [0, 1_300_000, 2_000_000, 7_300_000, 8_300_000, 2**32 + 8_299_999,
                    2**32 + 9_300_000]


def test_what_the_board_sends_is_the_firmwares_frame_of_its_truth():
    # The reader's decoder expects the default 16 x 16 grid.
    scene = scene_from_dict({'presses': [{
        'time_s': 0.0, 'x_m': 0.01, 'y_m': 0.01, 'force_n': 5.0, 'alpha_deg': 0.0,
        'beta_deg': 0.0, 'radius_m': 0.004, 'duration_s': 1000.0}]})
    sim = SimulatedSkin(scene, rate_hz=200.0, noise_seed=4)
    valid = np.ones((2, 16), bool)
    valid[1, 2] = False
    sim.set_row_faults(valid, faults=0x8)
    sim.skip_sequence(3)
    reader = read_from(sim, 3)
    framer = Framer(16, 16, 2)
    for frame in reader.frames:
        truth = sim.truth(frame.seq)
        sent = np.stack((truth.top, truth.bottom)).astype(np.uint16)
        sent[1, 2] = 4095  # what a failed row carries
        expected = framer.frame(frame.seq, frame.device_time_us, sent, 0x8, row_map(valid))
        assert encode_frame(frame.seq, frame.device_time_us, frame.top, frame.bottom, 2,
                            frame.faults, frame.row_valid) == expected
        assert frame.faults == 0x8 | ROW_FAILED and frame.seq >= 3


def _load_with(library: str) -> str:
    """Return what loading the library named in the environment printed, in a fresh process."""
    code = ('from skin_driver.core.sim import firmware\n'
            'try:\n'
            '    firmware.library()\n'
            'except firmware.FirmwareMissing as err:\n'
            '    print(err)\n')
    env = {**os.environ, firmware.LIBRARY_VARIABLE: library}
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_a_missing_or_foreign_library_is_refused_with_where_it_looked():
    assert 'no /nowhere/libskin_fw_host.so.1' in _load_with('/nowhere/libskin_fw_host.so.1')
    # Another library of the workspace (the kernel): not taken for the firmware's.
    from skin_driver.core.estimation.scan import kernel
    other = kernel.load_library()._name
    said = _load_with(other)
    assert f'{other} is not skin_fw_host' in said and 'make setup' in said
