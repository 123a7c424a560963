"""
Changes of the live estimator handed to the thread that runs the scans, applied between two.

The thread that runs the scans owns the estimator in force and its kernels (:mod:`kernel`).
Any other thread that changes it (a tare, a calibration, a parameter) builds the new estimator
itself, off the hot path, on the newest one, and hands it over with :meth:`Handover.put`; the
owner puts the newest handed over in force when it calls :meth:`Handover.take` before its next
scan, and carries the per-scan state (drift state, dead marks) into it then (``carry``): every
scan is seen by the drift state of the estimator it met, none is lost between a copy and the
swap, and a dead mark revived after the new estimator was built stays revived. Each change is
built on the one before it, so the newest holds them all: while no scan comes, changes replace
each other in one slot and are not queued (an unplugged board and a script changing parameters
hold one estimator, not one per change). The owner takes no lock: the slot is one reference,
read and written whole.
"""

import threading
from typing import Callable

__all__ = ['Handover']


class Handover:
    """The live state in force (the owner's) and the changes handed over to it, in order."""

    def __init__(self, first, carry: Callable = lambda new, old: None):
        """
        Start with ``first`` in force.

        ``carry(new, old)`` is called by the owner as it puts ``new`` in force after ``old``:
        where the per-scan state moves on (it may enter both; it is the owner's call).
        """
        self.in_force = first  # the owner's: read by other threads as a snapshot only
        self._newest = first  # handed over: in force from the owner's next take()
        self._carry = carry
        # Serialises the changers (each builds on the newest), never the owner.
        self._changing = threading.Lock()

    @property
    def newest(self):
        """Return the newest state: in force, or handed over and in force by the next scan."""
        return self._newest

    @property
    def pending(self) -> bool:
        """Return whether a change waits for the owner's next scan."""
        return self._newest is not self.in_force

    def put(self, change: Callable):
        """
        Hand over ``change(newest)`` (built here, on the caller's thread); return it.

        Changes are serialised: each is built on the one handed over before it, and replaces
        it if the owner has not taken it yet. Nothing is handed over if ``change`` raises.
        """
        with self._changing:
            made = change(self._newest)
            self._newest = made
        return made

    def take(self):
        """Return the state in force after applying what was handed over (the owner's call)."""
        made = self._newest  # read once: a change handed over meanwhile waits for the next scan
        if made is not self.in_force:
            try:
                self._carry(made, self.in_force)
            finally:  # in force whatever the carry raised: a change is never lost
                self.in_force = made
        return self.in_force
