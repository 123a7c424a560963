"""
What keeps work a lower rate would do off the per-scan path of the driver and the estimation.

* :class:`Listened`: which publishers have subscribers, asked a few times a second instead of
  on every scan (a count is a call into the middleware per topic and scan, for an answer that
  changes when someone starts or stops listening). A new subscriber is served within REFRESH_S.
* :class:`LatestOnly`: a thread of its own that runs a job on the newest item offered, dropping
  items it had no time for: raw images for a viewer never delay the next scan's read.
* :class:`TakenOnThread`: subscriptions whose messages a thread of its own takes as they arrive,
  every waiting one per wake-up, instead of the node's executor: the split direction node's
  frames, the benchmark's subscriber (its two subscriptions on one thread: no GIL hand-over).
  rclpy's executor rebuilds its wait set from every entity of its nodes on each wake-up, a cost
  paid per scan that grows with the node's services, actions and timers; this thread waits on
  its subscriptions and a stop signal alone (through :mod:`skin_driver.ros.wait_set`, rclpy's
  private wait set: why, there), and the executor keeps parameters, services and timers.
"""

import contextlib
import threading
from typing import Callable, Dict

from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.exceptions import InvalidHandle
from rclpy.guard_condition import GuardCondition
from skin_driver.core.protocol.realtime import name_this_thread
from skin_driver.ros.wait_set import RCLError, WaitSet

REFRESH_S = 0.1
# How often a waiting TakenOnThread looks whether its context is still up (a shutdown wakes it
# as well; this only bounds a wake-up that a shutdown under way could miss).
WAIT_NS = 100_000_000


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
        # Items replaced before their job started (read by any thread: an int, set under _ready).
        self.dropped = 0
        # True from an offer until the job of the last item offered has returned (set under
        # _ready): while False, this thread runs nothing and will not until the next offer.
        self.busy = False
        self._stopped = False
        self._ready = threading.Condition()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def offer(self, item) -> None:
        """Hand over ``item``; one not yet started is replaced (and counted in ``dropped``)."""
        with self._ready:
            self.dropped += self._item is not None
            self._item = item
            self.busy = True
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
            with self._ready:
                self.busy = self._item is not None


class NoExecutor(CallbackGroup):
    """A callback group that no executor runs: its entities are served by a thread of their own."""

    def can_execute(self, entity) -> bool:
        """Return False: executors leave the entity out of their wait sets."""
        return False

    def beginning_execution(self, entity) -> bool:
        """Return False: never run by an executor."""
        return False

    def ending_execution(self, entity) -> None:
        """Do nothing (never run by an executor)."""


class TakenOnThread:
    """Subscriptions of a node whose messages a thread of its own takes and hands on."""

    def __init__(self, node, name: str, on_error: Callable = lambda err: None):
        """
        Prepare the thread (OS name ``name``) for subscriptions of node; start() starts it.

        ``on_error(err)`` hears of a callback that raised (the next message is still served).
        """
        self._node = node
        self._name = name
        self._on_error = on_error
        self._context = node.context
        # (rclpy Subscription, callback, with info), served in this order
        self._subscriptions = []
        self._wake = GuardCondition(None, None, context=self._context)
        self._stopped = False
        self._thread = None

    def subscribe(self, msg_type, topic: str, callback: Callable, qos_profile, raw: bool = False,
                  info: bool = False, **kwargs):
        """
        Subscribe the node to topic (before start()); return the rclpy Subscription.

        The subscription is the node's own (graph, QoS overrides in kwargs), but in a callback
        group no executor runs. ``callback(msg)`` runs on the thread for every message taken;
        with ``raw`` the messages are their CDR bytes; with ``info`` it is ``callback(msg,
        info)``, info the middleware's dict (``source_timestamp``: the publisher's wall-clock
        time of the publish, ns).
        """
        kwargs.setdefault('event_callbacks',
                          SubscriptionEventCallbacks(use_default_callbacks=False))
        sub = self._node.create_subscription(msg_type, topic, callback, qos_profile,
                                             callback_group=NoExecutor(), raw=raw, **kwargs)
        self._subscriptions.append((sub, callback, info))
        return sub

    def start(self) -> None:
        """Start taking messages."""
        self._context.on_shutdown(self._on_shutdown)
        self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop the thread after the message in hand; the node destroys the subscriptions."""
        self._stopped = True
        self._on_shutdown()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout_s)

    def _on_shutdown(self) -> None:
        try:
            self._wake.trigger()
        except (InvalidHandle, RuntimeError):  # the context is down already: the thread sees it
            pass

    def _run(self) -> None:
        name_this_thread(self._name)
        wake, context = self._wake, self._context
        try:
            with context.handle:
                wait_set = WaitSet(len(self._subscriptions), 1, 0, 0, 0, 0, context.handle)
            while not self._stopped and context.ok():
                with contextlib.ExitStack() as handles:
                    for sub, _, _ in self._subscriptions:
                        handles.enter_context(sub.handle)
                    handles.enter_context(wake.handle)
                    wait_set.clear_entities()
                    for sub, _, _ in self._subscriptions:
                        wait_set.add_subscription(sub.handle)
                    wait_set.add_guard_condition(wake.handle)
                    wait_set.wait(WAIT_NS)
                    for sub, callback, info in self._subscriptions:
                        self._take_all(sub, callback, info)
        except InvalidHandle:  # the node was destroyed under the thread: nothing left to take
            pass
        except RCLError:
            if context.ok():
                raise
            # The context was shut down under the thread (Ctrl-C before or during a wait).
        finally:
            wake.destroy()

    def _take_all(self, sub, callback, info: bool) -> None:
        """Hand every waiting message to the callback (one wake-up for all that arrived)."""
        take, msg_type, raw = sub.handle.take_message, sub.msg_type, sub.raw
        while not self._stopped:
            taken = take(msg_type, raw)
            if taken is None:
                return
            try:
                if info:
                    callback(*taken)
                else:
                    callback(taken[0])
            except Exception as err:  # noqa: B902 - reported; the next message is still served
                if not self._context.ok():
                    # Ctrl-C under the callback: its publish failed on the dead context, which
                    # is the end of the process, not a fault.
                    return
                self._on_error(err)
