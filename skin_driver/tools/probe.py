"""
One probe for the benchmark, the soak, the demo and the tests: what a subscriber sees.

A Probe adds subscriptions to a node someone else owns and spins. It records every contacts
message with its receive time (host clock), its header stamp (when the driver read the scan's last
byte), the scan's sequence number and device time; counts the scans lost by sequence; and reports
latency percentiles. On request it also keeps the messages themselves, the raw frames and the
diagnostics statuses of the pipeline's nodes.

The benchmark's probe takes contacts on a thread of its own (own_thread), as cheaply as rclpy
can, so that measuring costs the shared cores little; and, beside the subscription a controller
would have (sensor-data QoS, depth 5), it can keep an audit subscription with a deep queue
(audit_depth): a scan the audit has and the controller-like one lacks was dropped at the
subscriber's queue, not by the driver.
"""

from __future__ import annotations

import collections
import math
import time
from typing import Callable, Optional

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from skin_driver.ros.conversions import read_contacts_head, status_values
from skin_driver.ros.hot_path import TakenOnThread
from skin_msgs.msg import SkinFrame, TactileContactArray

SEQ_MODULUS = 2 ** 32


class Record:
    """Columns of what arrived, one row per contacts message (plain lists: appends are cheap)."""

    def __init__(self):
        self.received_s = []    # host wall-clock time at which the message arrived
        self.stamp_s = []       # header stamp: host time of the scan's last byte at the driver
        self.sequence = []      # the scan's sequence number
        self.device_us = []     # the scan's device time
        self.contacts = []      # number of contacts in the message
        # the publisher's wall-clock time of the publish (the middleware's source timestamp),
        # NaN where the subscription did not say (an executor's callback gets no message info)
        self.published_s = []


def unwrap(sequence) -> np.ndarray:
    """Return sequence numbers (in arrival order) with their 32-bit wraps undone."""
    seq = np.asarray(sequence, dtype=np.int64)
    if seq.size == 0:
        return seq
    step = np.diff(seq) % SEQ_MODULUS
    step = np.where(step >= SEQ_MODULUS // 2, step - SEQ_MODULUS, step)
    return np.concatenate(([seq[0]], seq[0] + np.cumsum(step)))


def percentiles_ms(seconds, qs=(50, 99, 100)) -> dict:
    """Return {'p50': ms, ...} of latencies in seconds ('max' for 100); None when empty."""
    names = {q: 'max' if q == 100 else f'p{q:g}' for q in qs}
    if len(seconds) == 0:
        return {names[q]: None for q in qs}
    values = np.percentile(np.asarray(seconds, dtype=np.float64) * 1e3, qs)
    return {names[q]: float(v) for q, v in zip(qs, values)}


def _published(info: Optional[dict]) -> float:
    """Return the publish time (s) in a message info of the middleware, NaN without one."""
    return math.nan if info is None else info['source_timestamp'] * 1e-9


class Probe:
    """Subscriptions that record what the skin pipeline publishes."""

    def __init__(self, node, *, keep_messages: bool = False, frames: bool = False,
                 depth: Optional[int] = None, diagnostics: int = 200,
                 on_contacts: Optional[Callable] = None, on_frame: Optional[Callable] = None,
                 on_status: Optional[Callable] = None, own_thread: bool = False,
                 audit_depth: int = 0):
        """
        Subscribe on node: contacts always, frame if asked (or given on_frame), /diagnostics.

        keep_messages keeps every message (tests); depth deepens the best-effort queue (the
        default is the sensor-data QoS a controller would use); on_contacts, on_frame and
        on_status are called with each message (status) after it is recorded. A counting probe
        (none of keep_messages, on_contacts) with own_thread takes contacts on threads of its
        own (close() stops them); audit_depth > 0 adds the audit subscription, recorded in
        ``audit``.
        """
        self.node = node
        self.keep = keep_messages
        self.record = Record()
        self.contacts = []
        self.frames = []
        self.frame_count = 0
        self.statuses = collections.deque(maxlen=diagnostics)
        self.audit = Record()
        self._taker = None
        self._on_contacts_hook = on_contacts
        self._on_frame_hook = on_frame
        self._on_status_hook = on_status
        qos = QoSProfile(depth=depth or 5, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.BEST_EFFORT)
        if keep_messages or on_contacts is not None:
            node.create_subscription(TactileContactArray, 'contacts', self._on_contacts, qos)
        else:
            # Counting alone needs the head of each message: its bytes, not a message object
            # (the probe shares the benchmark's cores with the pipeline it measures).
            # On its own thread, the audit shares it: one thread, no GIL to hand over.
            taker = TakenOnThread(node, 'skin-probe') if own_thread else None
            self._count(taker, self._on_contacts_raw, qos)
            if audit_depth:
                deep = QoSProfile(depth=audit_depth, history=HistoryPolicy.KEEP_LAST,
                                  reliability=ReliabilityPolicy.BEST_EFFORT)
                self._count(taker, self._on_audit_raw, deep)
            if taker is not None:
                taker.start()
                self._taker = taker
        if frames or on_frame is not None:
            node.create_subscription(SkinFrame, 'frame', self._on_frame, qos)
        node.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 50)

    def _on_contacts(self, msg: TactileContactArray) -> None:
        stamp = msg.header.stamp
        self._add(time.time(), stamp.sec, stamp.nanosec, msg.sequence, msg.device_time_us,
                  len(msg.contacts))
        if self.keep:
            self.contacts.append(msg)
        if self._on_contacts_hook is not None:
            self._on_contacts_hook(msg)

    def _count(self, taker, callback, qos) -> None:
        """Count contacts from their bytes, on the taker's thread or else the node's executor."""
        if taker is None:
            self.node.create_subscription(TactileContactArray, 'contacts', callback, qos,
                                          raw=True)
        else:
            taker.subscribe(TactileContactArray, 'contacts', callback, qos, raw=True, info=True)

    def close(self) -> None:
        """Stop the probe's own thread (before its node is destroyed)."""
        if self._taker is not None:
            self._taker.stop()

    def _on_contacts_raw(self, data: bytes, info: Optional[dict] = None) -> None:
        now = time.time()
        self._add(now, *read_contacts_head(data), published_s=_published(info))

    def _on_audit_raw(self, data: bytes, info: Optional[dict] = None) -> None:
        now = time.time()
        self._add(now, *read_contacts_head(data), record=self.audit,
                  published_s=_published(info))

    def _add(self, received_s, sec, nanosec, sequence, device_us, contacts,
             record: Optional[Record] = None, published_s: float = math.nan) -> None:
        r = self.record if record is None else record
        r.received_s.append(received_s)
        r.published_s.append(published_s)
        r.stamp_s.append(sec + nanosec * 1e-9)
        r.sequence.append(sequence)
        r.device_us.append(device_us)
        r.contacts.append(contacts)

    def _on_frame(self, msg: SkinFrame) -> None:
        self.frame_count += 1
        if self.keep:
            self.frames.append(msg)
        if self._on_frame_hook is not None:
            self._on_frame_hook(msg)

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        now = time.monotonic()
        for status in msg.status:
            self.statuses.append((now, status))
            if self._on_status_hook is not None:
                self._on_status_hook(status)

    def reset(self) -> None:
        """Forget everything recorded so far."""
        self.record, self.audit = Record(), Record()
        self.contacts, self.frames, self.frame_count = [], [], 0
        self.statuses.clear()

    # ---- diagnostics ------------------------------------------------------------------------
    def statuses_of(self, suffix: str) -> list:
        """Return the kept statuses whose name ends with suffix, oldest first."""
        return [status for _, status in self.statuses if status.name.endswith(suffix)]

    def latest(self, suffix: str):
        """Return the newest kept status whose name ends with suffix, or None."""
        found = self.statuses_of(suffix)
        return found[-1] if found else None

    def link_status(self):
        """Return the newest skin-link status of the driver, or None."""
        return self.latest('skin link')

    def saw_link_status(self, predicate) -> bool:
        """Return whether a kept skin-link status satisfies predicate(status, values)."""
        return any(predicate(status, status_values(status))
                   for status in self.statuses_of('skin link'))

    def counters(self, suffix: str, start: float, end: float) -> dict:
        """Return how the numeric values of a status moved between two monotonic instants."""
        reports = [(t, status_values(s)) for t, s in self.statuses if s.name.endswith(suffix)]
        first = [r for r in reports if r[0] <= start]
        last = [r for r in reports if r[0] <= end]
        if not first or not last or last[-1][0] <= first[-1][0]:
            return {}
        (t0, a), (t1, b) = first[-1], last[-1]
        out = {'span_s': t1 - t0, 'latest': b}
        for key, value in b.items():
            try:
                out[key] = float(value) - float(a[key])
            except (KeyError, ValueError):
                pass
        return out

    # ---- summary ----------------------------------------------------------------------------
    def summary(self, device_window_s=None, expected: Optional[int] = None,
                epoch_s: Optional[float] = None, record: Optional[Record] = None) -> dict:
        """
        Return scans received and lost, and latency percentiles (ms).

        device_window_s (start, end) keeps the scans whose device time lies in it. Lost scans
        are the gaps in the received sequence numbers, or expected less received when the
        number of scans sent in the window is known. Latency 'from last byte' runs from the
        header stamp (the driver's host time for the scan's last byte) to arrival here, and
        'published after last byte' to the publish (the messages taken on the probe's own
        thread, which have the middleware's source timestamp); with
        epoch_s (host time of device time 0) also 'from device time', which adds the board's
        own wait before it sent the scan. 'published first of read' keeps the scans that came
        first in the driver's read (the others wait behind them: 'behind in read' is their
        share). ``record`` summarises another record (the audit).
        """
        r = self.record if record is None else record
        received = np.asarray(r.received_s, dtype=np.float64)
        stamp = np.asarray(r.stamp_s, dtype=np.float64)
        device = np.asarray(r.device_us, dtype=np.float64) * 1e-6
        seq = unwrap(r.sequence)
        keep = np.ones(len(received), dtype=bool)
        if device_window_s is not None:
            keep = (device >= device_window_s[0]) & (device < device_window_s[1])
        seq_kept = np.unique(seq[keep])
        span = int(seq_kept[-1] - seq_kept[0] + 1) if seq_kept.size else 0
        out = {
            'received': int(keep.sum()),
            'duplicates': int(keep.sum() - seq_kept.size),
            'sequence_gaps': span - int(seq_kept.size),
            'with_contact': int(np.count_nonzero(np.asarray(r.contacts)[keep])) if keep.size
            else 0,
        }
        out['lost'] = (max(expected - int(seq_kept.size), 0) if expected is not None
                       else out['sequence_gaps'])
        out['latency_from_last_byte_ms'] = percentiles_ms(received[keep] - stamp[keep])
        published = np.full(received.shape, np.nan)  # rows added without it: not told
        published[:len(r.published_s)] = r.published_s
        told = keep & np.isfinite(published)
        out['published_after_last_byte_ms'] = percentiles_ms(published[told] - stamp[told])
        # A read that returns several scans stamps them alike: all but the first wait for the
        # scans before them to be handled. The first of each read is the driver's own latency.
        order = np.argsort(seq, kind='stable')
        first = np.ones(len(stamp), dtype=bool)
        first[order[1:]] = np.diff(stamp[order]) != 0
        alone = told & first
        out['published_first_of_read_ms'] = percentiles_ms(published[alone] - stamp[alone])
        out['behind_in_read'] = (float(np.count_nonzero(keep & ~first)) / keep.sum()
                                 if keep.any() else 0.0)
        if epoch_s is not None:
            out['latency_from_device_time_ms'] = percentiles_ms(
                received[keep] - (epoch_s + device[keep]))
            out['last_byte_after_device_time_ms'] = percentiles_ms(
                stamp[keep] - (epoch_s + device[keep]))
        return out
