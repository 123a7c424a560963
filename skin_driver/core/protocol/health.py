"""
The link's health rules: how a serial link and its decoder's counters read as a status.

OK while frames arrive; WARN when the link is stalled or, since the last assessment, frames
were dropped (sequence gaps, frames lost while the device was away) or corrupt frames were
rejected (line noise); ERROR while the device is missing, or when the board sends nothing but
frames of another grid size (the received shape is in the message). ROS-free: the driver node
turns an assessment into a diagnostic status.

The board's identity (its board information frame, docs/protocol.md) is in the values: name,
uid, firmware, grid, pitch and scan rate, or "no board identity (version-1 stream)" while it
has sent none. A board that says it has another grid than its frames, or another pitch than
the driver is configured with, is a WARN for as long as it says so (the frames are still
decoded: the board's word may be the wrong one); so are malformed info frames since the last
assessment.

The board's health, where its information frame carries it (core.common.boardhealth), is in
the values by name: why it last reset, the fault before that reset, its clock, its fault
counters. A reset by a watchdog or after a fault, and a board on its internal oscillator, are a
WARN while the board says so; a counter that grew since the last assessment is a WARN that
names it, so frames the board dropped or flagged (a row failed to sample) are told from line
noise.

The protocol version of the newest frame is in the values. A version-2 board's own word on a
scan is too: rows it did not sample (held at their last valid counts, or the frame dropped as
board-flagged when a row has none yet; core.protocol.hold) and its fault bits are a WARN for the
assessment in which they arrived.
"""

from __future__ import annotations

from dataclasses import dataclass

from skin_driver.core.common.boardhealth import BoardHealth, HEALTH_KEYS
from skin_driver.core.protocol.link import CONNECTED, STALLED
from skin_driver.core.protocol.packed import fault_names

__all__ = ['OK', 'WARN', 'ERROR', 'Health', 'LinkHealth', 'NO_BOARD_IDENTITY', 'board_values']

# The levels of diagnostic_msgs/DiagnosticStatus, so that a node passes them on unchanged.
OK, WARN, ERROR = 0, 1, 2


@dataclass(frozen=True)
class Health:
    """One assessment: a level (OK, WARN, ERROR), a message for a person, and the counters."""

    level: int
    message: str
    values: dict


class LinkHealth:
    """Assess a link against its counters at the previous assessment."""

    def __init__(self, expected_shape: tuple = None, pitch_m: float = 0.0):
        """
        Assess a link that must deliver frames of ``expected_shape`` (rows, cols; None: any).

        ``pitch_m`` (> 0) is the pitch the driver is configured with, compared with the one the
        board states; 0 compares none.
        """
        self._expected = expected_shape
        self._pitch_m = pitch_m
        self._reported = {}
        self._health = None  # the board's health at the previous assessment

    def assess(self, link, detail: str) -> Health:
        """Return the health of ``link`` (a SerialLink) now; ``detail`` is its last news."""
        stats, dec = link.stats, link.decoder.stats
        state = link.state
        dropped = dec.frames_missed + stats.frames_lost_reconnecting
        hold = link.hold
        totals = {'frames': dec.frames, 'dropped': dropped, 'size': dec.size_errors,
                  'corrupt': dec.crc_errors + dec.version_errors, 'info': dec.info_errors,
                  'flagged': dec.rows_flagged, 'faults': dec.fault_frames}
        new = {k: v - self._reported.get(k, 0) for k, v in totals.items()}
        self._reported = totals
        level = {CONNECTED: OK, STALLED: WARN}.get(state, ERROR)
        problems = []
        rejected = link.decoder.last_rejected_shape
        shape = f'{rejected[0]}x{rejected[1]}' if rejected else ''
        if new['size']:
            # A board that sends nothing but another grid is misconfigured, not noisy.
            level = max(level, WARN if new['frames'] else ERROR)
            rows, cols = self._expected
            problems.append(f"{new['size']} frames of the wrong grid size {shape} rejected "
                            f'(expected {rows}x{cols})')
        if new['corrupt']:
            level = max(level, WARN)
            problems.append(f"{new['corrupt']} corrupt frames rejected (line noise?)")
        if new['dropped']:
            level = max(level, WARN)
            problems.append(f"{new['dropped']} frames dropped (sequence gaps)")
        if new['info']:
            level = max(level, WARN)
            problems.append(f"{new['info']} malformed board information frames rejected")
        if new['flagged']:
            level = max(level, WARN)
            problems.append(f"{new['flagged']} frames with rows the board did not sample (held "
                            'at their last valid counts)')
        if new['faults']:
            level = max(level, WARN)
            names = ', '.join(fault_names(link.decoder.last_faults)) or 'none in the newest'
            problems.append(f"{new['faults']} frames with board faults ({names})")
        board_problems = self._board_problems(link.decoder)
        health = BoardHealth.of(link.decoder.board_info)
        if health is not None:
            board_problems += health.problems(self._health)
        self._health = health
        if board_problems:
            level = max(level, WARN)
            problems += board_problems
        values = {
            'link state': state, 'frames': dec.frames, 'crc errors': dec.crc_errors,
            'size errors': dec.size_errors, 'last rejected shape': shape,
            'version errors': dec.version_errors, 'bytes discarded': dec.bytes_discarded,
            'sequence gaps': dec.seq_gaps, 'implausible sequence jumps': dec.seq_implausible,
            'frames dropped': dropped,
            'frames lost while disconnected': stats.frames_lost_reconnecting,
            'connects': stats.connects, 'disconnects': stats.disconnects,
            'open failures': stats.open_failures, 'publish errors': stats.callback_errors,
            'last error': stats.last_error,
            **board_values(link.decoder.board_info),
            'board info frames': dec.info_frames, 'board info errors': dec.info_errors,
            'protocol version': link.decoder.last_version or 'no frame yet',
            'frames with board faults': dec.fault_frames,
            'board fault bits (newest frame)': ', '.join(fault_names(link.decoder.last_faults))
            or 'none',
            'frames with rows not sampled': dec.rows_flagged,
            'rows held at their last valid counts': hold.rows_held,
            'frames dropped, board-flagged (a row never sampled yet)': hold.frames_flagged,
        }
        return Health(level, '; '.join([f'{state}: {detail}'] + problems), values)

    def _board_problems(self, decoder) -> list:
        """Return where the board's word disagrees with its frames or the configuration."""
        info = decoder.board_info
        if info is None:
            return []
        problems = []
        rows, cols = decoder.last_shape or self._expected or (info.rows, info.cols)
        if (info.rows, info.cols) != (rows, cols):
            problems.append(f'board {info.board} says its grid is {info.rows}x{info.cols}, its '
                            f'frames are {rows}x{cols}' if decoder.last_shape else
                            f'board {info.board} says its grid is {info.rows}x{info.cols}, the '
                            f'driver expects {rows}x{cols}')
        # The board states whole micrometres.
        if self._pitch_m > 0 and abs(info.pitch_m - self._pitch_m) > 0.5e-6:
            problems.append(f'board {info.board} says its pitch is {1000 * info.pitch_m:.3f} mm, '
                            f'the driver is configured with {1000 * self._pitch_m:.3f} mm')
        return problems


NO_BOARD_IDENTITY = 'no board identity (version-1 stream)'


def board_values(info) -> dict:
    """Return the board's identity and health (a BoardInfo or None) as diagnostic values."""
    if info is None:
        return {'board': NO_BOARD_IDENTITY}
    health = BoardHealth.of(info)
    return {'board': info.board, 'board uid': info.uid, 'board firmware': info.fw,
            'board grid': f'{info.rows}x{info.cols}',
            'board pitch [mm]': round(1000 * info.pitch_m, 3),
            'board scan rate [Hz]': info.rate_hz,
            **(health.values() if health is not None else {}),
            **{f'board {key}': value for key, value in info.extra if key not in HEALTH_KEYS}}
