"""
The simulated board sends its information frames when the firmware's own loop does.

``board_dump`` runs firmware/core/src/run.c on the host at given scan times and prints what it
sends (I: information frame, F: data frame). The simulated board keeps the schedule through the
same C code (skin_info_schedule_t, in the host build skin_fw_host); this holds the way it uses
it, as the simulated board does, against the way run.c does (started at the first scan).
"""

import subprocess

import numpy as np
import pytest
from skin_driver.core.sim.board import INFO_PERIOD_US
from skin_driver.core.sim.firmware import InfoSchedule

SECOND = 1_000_000


def _firmware(board_dump, times) -> str:
    done = subprocess.run([str(board_dump)], input=''.join(f'{t}\n' for t in times),
                          capture_output=True, text=True, check=True, timeout=60)
    return done.stdout.strip()


def _simulated(times) -> str:
    schedule, out = InfoSchedule(INFO_PERIOD_US), []
    for t in times:
        if schedule.due(int(t)):
            schedule.sent(int(t))
            out.append('I')
        out.append('F')
    return ''.join(out)


def _stalled(before, stall_us, after, step_us=100_000, start=0):
    """Return scan times: ``before`` scans, a stall of ``stall_us``, then ``after`` scans."""
    first = start + step_us * np.arange(before)
    return list(first) + list(first[-1] + stall_us + step_us * np.arange(after))


CASES = {
    'scans_at_1kHz': list(range(0, 3_500_000, 1000)),
    # Off the second: at the first scan at or after each whole second since the last was due.
    'scans_300ms_apart': list(range(0, 12_100_000, 300_000)),
    # A stall past several periods: one frame, then the next a period after it (not on the
    # whole seconds the board started on).
    'stall_of_5_3_s': _stalled(5, 5_300_000, 30),
    'first_scan_late': list(range(123_456, 4_000_000, 50_000)),
    # The firmware's 32-bit microsecond clock wraps at 4295 s; the device time does not.
    'clock_wrap': list(range(2**32 - 1_500_000, 2**32 + 2_500_000, 250_000)),
}


@pytest.mark.parametrize('name', sorted(CASES))
def test_the_simulated_board_keeps_the_firmwares_information_schedule(board_dump, name):
    times = CASES[name]
    firmware = _firmware(board_dump, times)
    assert firmware.count('F') == len(times)
    assert _simulated(times) == firmware
