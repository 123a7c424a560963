"""
When a tare may be taken: the recent scans, and the rule that refuses a loaded or silent skin.

A tare averages unloaded scans into the baseline. Scans that carried a contact would bake a press
into it, so a tare is refused while any of the scans it would use has one; with fewer scans than
it needs (the driver is not streaming), it is refused too. The reason is meant for a person.
"""

from __future__ import annotations

import collections

import numpy as np

__all__ = ['TareRefused', 'RecentScans']


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

    def clear(self) -> None:
        """Forget every scan (the stream stopped: old scans say nothing of the skin now)."""
        self._scans.clear()

    def add(self, top: np.ndarray, bottom: np.ndarray, contacts: int) -> None:
        """Remember one scan and its number of contacts."""
        self._scans.append((top, bottom, contacts))

    def unloaded(self, wanted: int) -> tuple:
        """Return (tops, bottoms) of the last ``wanted`` scans; raise TareRefused if unfit."""
        scans = list(self._scans)[-wanted:]
        if len(scans) < wanted:
            raise TareRefused(f'only {len(scans)} of {wanted} scans received so far; '
                              'is the driver running?')
        loaded = sum(1 for _, _, n in scans if n)
        if loaded:
            raise TareRefused(f'the skin is loaded ({loaded} of the last {wanted} scans have a '
                              'contact); lift everything off it and call again')
        return np.stack([s[0] for s in scans]), np.stack([s[1] for s in scans])
