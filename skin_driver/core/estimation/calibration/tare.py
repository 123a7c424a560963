"""
When a tare may be taken: the recent scans, and the rule that refuses a loaded or silent skin.

A tare averages unloaded scans into the baseline. Scans that carried a contact would bake a press
into it, so a tare is refused while any of the scans it would use has one; with fewer scans than
it needs, it is refused too. Scans older than ``STALE_AFTER_S`` are not the skin as it is now
(the driver was deactivated, the link stalled): a tare is refused while no scan is arriving, and a
stream that resumes after such a gap starts the window afresh. The reason is meant for a person.
"""

from __future__ import annotations

import collections

import numpy as np

__all__ = ['TareRefused', 'RecentScans', 'STALE_AFTER_S']

# Seconds after which a scan is stale: the driver's default stall timeout, when it reports the
# link stalled.
STALE_AFTER_S = 1.0


class TareRefused(ValueError):
    """A tare cannot be taken now; the message says why and what to do."""


class RecentScans:
    """The last scans seen (raw counts and how many contacts each had), for a tare."""

    def __init__(self, keep: int):
        """Keep the last ``keep`` scans."""
        self._scans = collections.deque(maxlen=int(keep))

    def resize(self, keep: int) -> None:
        """Keep the last ``keep`` scans from now on (those already kept stay, up to that)."""
        self._scans = collections.deque(self._scans, maxlen=int(keep))

    def add(self, top: np.ndarray, bottom: np.ndarray, contacts: int, now_s: float) -> None:
        """Remember one scan, its number of contacts and when it arrived (monotonic seconds)."""
        scans = self._scans
        if scans and now_s - scans[-1][3] > STALE_AFTER_S:
            scans.clear()
        scans.append((top, bottom, contacts, now_s))

    def unloaded(self, wanted: int, now_s: float) -> tuple:
        """Return (tops, bottoms) of the last ``wanted`` scans; raise TareRefused if unfit."""
        scans = list(self._scans)[-wanted:]
        age = now_s - scans[-1][3] if scans else None
        if age is None or age > STALE_AFTER_S:
            raise TareRefused('no scan is arriving' + (
                f' (the last came {age:.1f} s ago)' if age is not None else '') +
                '; is the driver active?')
        if len(scans) < wanted:
            raise TareRefused(f'only {len(scans)} of {wanted} scans received since the scans '
                              'started; call again in a moment')
        loaded = sum(1 for _, _, n, _ in scans if n)
        if loaded:
            raise TareRefused(f'the skin is loaded ({loaded} of the last {wanted} scans have a '
                              'contact); lift everything off it and call again')
        return np.stack([s[0] for s in scans]), np.stack([s[1] for s in scans])
