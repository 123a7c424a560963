"""
What keeps work a lower rate would do off the per-scan path of the driver and the estimation.

* :class:`Listened`: which publishers have subscribers, asked a few times a second instead of
  on every scan (a count is a call into the middleware per topic and scan, for an answer that
  changes when someone starts or stops listening). A new subscriber is served within REFRESH_S.
* :class:`LatestOnly`: a thread of its own that runs a job on the newest item offered, dropping
  items it had no time for: raw images for a viewer never delay the next scan's read.
"""

import threading
from typing import Callable, Dict

from skin_driver.core.protocol.realtime import name_this_thread

REFRESH_S = 0.1


class Listened:
    """Whether each of some publishers has a subscriber, refreshed every REFRESH_S."""

    def __init__(self, publishers: Dict[str, object]):
        """Watch ``publishers`` ({name: publisher}); a name maps to False until first asked."""
        self._publishers = dict(publishers)
        self._due = 0.0
        self.now = dict.fromkeys(self._publishers, False)

    def __call__(self, monotonic_s: float) -> Dict[str, bool]:
        """Return {name: has a subscriber} as of at most REFRESH_S before ``monotonic_s``."""
        if monotonic_s >= self._due:
            self._due = monotonic_s + REFRESH_S
            self.now = {name: pub.get_subscription_count() > 0
                        for name, pub in self._publishers.items()}
        return self.now


class LatestOnly:
    """Run ``job(item)`` on a daemon thread for the newest item offered; never block offer()."""

    def __init__(self, job: Callable, name: str, on_error: Callable = lambda err: None):
        """Start the thread (OS name ``name``); ``on_error(err)`` hears of a failed job."""
        self._job = job
        self._on_error = on_error
        self._name = name
        self._item = None
        self._stopped = False
        self._ready = threading.Condition()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def offer(self, item) -> None:
        """Hand over ``item``; one not yet started is replaced."""
        with self._ready:
            self._item = item
            self._ready.notify()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop the thread after the job in progress."""
        with self._ready:
            self._stopped = True
            self._ready.notify()
        self._thread.join(timeout_s)

    def _run(self) -> None:
        name_this_thread(self._name)
        while True:
            with self._ready:
                while self._item is None and not self._stopped:
                    self._ready.wait()
                if self._stopped:
                    return
                item, self._item = self._item, None
            try:
                self._job(item)
            except Exception as err:  # noqa: B902 - reported; the next item is still served
                self._on_error(err)
