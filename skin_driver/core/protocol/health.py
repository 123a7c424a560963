"""
The link's health rules: how a serial link and its decoder's counters read as a status.

OK while frames arrive; WARN when the link is stalled or, since the last assessment, frames
were dropped (sequence gaps, frames lost while the device was away) or corrupt frames were
rejected (line noise); ERROR while the device is missing, or when the board sends nothing but
frames of another grid size (the received shape is in the message). ROS-free: the driver node
turns an assessment into a diagnostic status.
"""

from __future__ import annotations

from dataclasses import dataclass

from skin_driver.core.protocol.link import CONNECTED, STALLED

__all__ = ['OK', 'WARN', 'ERROR', 'Health', 'LinkHealth']

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

    def __init__(self, expected_shape: tuple):
        """Assess a link that must deliver frames of ``expected_shape`` (rows, cols)."""
        self._expected = expected_shape
        self._reported = {}

    def assess(self, link, detail: str) -> Health:
        """Return the health of ``link`` (a SerialLink) now; ``detail`` is its last news."""
        stats, dec = link.stats, link.decoder.stats
        state = link.state
        dropped = dec.frames_missed + stats.frames_lost_reconnecting
        totals = {'frames': dec.frames, 'dropped': dropped, 'size': dec.size_errors,
                  'corrupt': dec.crc_errors + dec.version_errors}
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
        }
        return Health(level, '; '.join([f'{state}: {detail}'] + problems), values)
