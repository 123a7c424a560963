"""The probe counts lost scans by sequence and reports latency percentiles."""

from builtin_interfaces.msg import Time
import pytest
from rclpy.serialization import serialize_message
from skin_driver.tools.probe import percentiles_ms, Probe, Record, unwrap
from skin_msgs.msg import TactileContact, TactileContactArray
from std_msgs.msg import Header


class _Node:
    """Just enough of a node for a Probe: it records what it would subscribe to."""

    def __init__(self):
        self.topics = []
        self.raw = {}
        self.callbacks = {}

    def create_subscription(self, kind, topic, callback, qos, raw=False):
        self.topics.append(topic)
        self.raw[topic] = raw
        self.callbacks[topic] = callback


def _probe_with(rows):
    """Return a probe whose record holds rows of (received s, stamp s, sequence, device us)."""
    probe = Probe(_Node())
    probe.record = Record()
    for received, stamp, seq, device in rows:
        probe.record.received_s.append(received)
        probe.record.stamp_s.append(stamp)
        probe.record.sequence.append(seq)
        probe.record.device_us.append(device)
        probe.record.contacts.append(1)
    return probe


def test_sequence_numbers_are_unwrapped_across_two_to_the_32():
    assert list(unwrap([2 ** 32 - 2, 2 ** 32 - 1, 0, 1, 3])) == [
        2 ** 32 - 2, 2 ** 32 - 1, 2 ** 32, 2 ** 32 + 1, 2 ** 32 + 3]
    assert list(unwrap([])) == []


def test_gaps_in_the_sequence_are_the_lost_scans():
    rows = [(10.001 + i * 0.001, 10.0 + i * 0.001, seq, seq * 1000)
            for i, seq in enumerate([5, 6, 8, 9, 12])]
    summary = _probe_with(rows).summary()
    assert (summary['received'], summary['lost'], summary['sequence_gaps']) == (5, 3, 3)


def test_with_the_number_sent_lost_counts_the_missing_ends_too():
    rows = [(1.0, 1.0, seq, seq * 1000) for seq in (3, 4, 5)]
    # Scans 0..9 were sent (device times 0-9 ms); the window keeps device times below 8 ms.
    summary = _probe_with(rows).summary(device_window_s=(0.0, 0.008), expected=8)
    assert (summary['received'], summary['lost'], summary['sequence_gaps']) == (3, 5, 0)


def test_a_repeated_scan_is_a_duplicate_not_a_new_one():
    rows = [(1.0, 1.0, 7, 0), (1.1, 1.0, 7, 0), (1.2, 1.0, 8, 1000)]
    summary = _probe_with(rows).summary()
    assert (summary['received'], summary['duplicates'], summary['lost']) == (3, 1, 0)


def test_latency_runs_from_the_stamp_and_from_device_time():
    # Stamped 0.5 ms after the device time (host epoch 100 s), received 1, 2 and 4 ms later.
    rows = [(100.0015, 100.0005, 0, 0), (101.0025, 101.0005, 1, 1_000_000),
            (102.0045, 102.0005, 2, 2_000_000)]
    summary = _probe_with(rows).summary(epoch_s=100.0)
    assert summary['latency_from_last_byte_ms'] == pytest.approx(
        {'p50': 2.0, 'p99': 3.96, 'max': 4.0}, abs=1e-6)
    assert summary['last_byte_after_device_time_ms']['max'] == pytest.approx(0.5, abs=1e-6)
    assert summary['latency_from_device_time_ms']['p50'] == pytest.approx(2.5, abs=1e-6)


def test_no_message_gives_no_percentile():
    assert percentiles_ms([]) == {'p50': None, 'p99': None, 'max': None}
    assert _probe_with([]).summary()['lost'] == 0


def test_the_probe_listens_to_frames_only_when_asked():
    assert _Node().topics == []
    node = _Node()
    Probe(node)
    assert node.topics == ['contacts', '/diagnostics']
    node = _Node()
    Probe(node, frames=True)
    assert 'frame' in node.topics


def test_a_counting_probe_reads_the_contacts_bytes_and_a_keeping_one_the_messages():
    node = _Node()
    probe = Probe(node)
    assert node.raw['contacts']
    msg = TactileContactArray(header=Header(stamp=Time(sec=5, nanosec=250000000)),
                              sequence=7, device_time_us=9000, contacts=[TactileContact()] * 2)
    node.callbacks['contacts'](serialize_message(msg))
    r = probe.record
    assert (r.stamp_s, r.sequence, r.device_us, r.contacts) == ([5.25], [7], [9000], [2])
    node = _Node()
    Probe(node, keep_messages=True)
    assert not node.raw['contacts']


def test_the_publish_time_comes_from_the_message_info_of_a_taken_message():
    # Stamped at 5.25 s (the last byte), published 0.4 ms later by the middleware's word.
    node = _Node()
    probe = Probe(node)
    msg = TactileContactArray(header=Header(stamp=Time(sec=5, nanosec=250000000)), sequence=7)
    node.callbacks['contacts'](serialize_message(msg), {'source_timestamp': 5_250_400_000})
    assert probe.summary()['published_after_last_byte_ms'] == pytest.approx(
        {'p50': 0.4, 'p99': 0.4, 'max': 0.4}, abs=1e-3)
    # An executor's callback has no message info: no publish time, no percentile.
    node = _Node()
    probe = Probe(node)
    node.callbacks['contacts'](serialize_message(msg))
    assert probe.summary()['published_after_last_byte_ms']['p99'] is None


def test_scans_one_read_returned_together_are_told_apart_from_the_first_of_each_read():
    # Scans 0 and 1 came in one read (one stamp), 2 alone; published 0.2, 0.5 and 0.3 ms later.
    node = _Node()
    probe = Probe(node)
    for seq, stamp_ns, published_us in ((0, 5_250_000_000, 200), (1, 5_250_000_000, 500),
                                        (2, 5_251_000_000, 300)):
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        msg = TactileContactArray(header=Header(stamp=Time(sec=sec, nanosec=nanosec)),
                                  sequence=seq)
        node.callbacks['contacts'](serialize_message(msg),
                                   {'source_timestamp': stamp_ns + published_us * 1000})
    summary = probe.summary()
    assert summary['published_after_last_byte_ms']['max'] == pytest.approx(0.5, abs=1e-3)
    assert summary['published_first_of_read_ms']['max'] == pytest.approx(0.3, abs=1e-3)
    assert summary['behind_in_read'] == pytest.approx(1 / 3)
