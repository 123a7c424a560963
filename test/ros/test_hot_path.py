"""Subscriber counts asked at a low rate, and work for viewers kept off the reader's thread."""

import contextlib
import importlib
import sys
import threading
import time

import pytest
from rclpy.impl import implementation_singleton
from skin_driver.ros.hot_path import LatestOnly, Listened, REFRESH_S


class CountingPublisher:
    """A publisher stand-in whose subscriber count the test sets, counting the questions."""

    def __init__(self, count=0):
        self.count = count
        self.asked = 0

    def get_subscription_count(self):
        self.asked += 1
        return self.count


def test_subscriber_counts_are_asked_once_per_refresh_period():
    frame, image = CountingPublisher(1), CountingPublisher(0)
    listened = Listened({'frame': frame, 'image': image})
    assert listened(100.0) == {'frame': True, 'image': False}
    image.count = 2
    # Within the period the old answer stands and nobody is asked.
    assert listened(100.0 + REFRESH_S / 2) == {'frame': True, 'image': False}
    assert (frame.asked, image.asked) == (1, 1)
    assert listened(100.0 + REFRESH_S) == {'frame': True, 'image': True}
    assert (frame.asked, image.asked) == (2, 2)


def test_latest_only_serves_the_newest_item_and_survives_a_failing_job():
    started, release, failed, done = (threading.Event() for _ in range(4))
    seen, errors = [], []

    def job(item):
        if item == 'block':
            started.set()
            release.wait(5.0)
        elif item == 'fail':
            raise RuntimeError('viewer gone')
        seen.append(item)
        if item == 'last':
            done.set()

    def on_error(err):
        errors.append(str(err))
        failed.set()

    worker = LatestOnly(job, 'skin-test', on_error)
    try:
        worker.offer('block')
        assert started.wait(5.0)
        for item in ('old', 'older', 'fail'):
            worker.offer(item)  # never blocks, though the job is busy
        release.set()
        assert failed.wait(5.0)  # only the newest, 'fail', was served after 'block'
        worker.offer('last')
        assert done.wait(5.0)
    finally:
        worker.stop()
    assert seen == ['block', 'last']
    assert errors == ['viewer gone']
    assert worker.dropped == 2  # 'old' and 'older', replaced before they started


def test_latest_only_is_busy_from_an_offer_until_its_job_has_returned():
    started, release = threading.Event(), threading.Event()

    def job(item):
        started.set()
        release.wait(5.0)
    worker = LatestOnly(job, 'skin-test-busy')
    try:
        assert not worker.busy
        worker.offer(1)
        assert worker.busy and started.wait(5.0)
        worker.offer(2)  # waits behind the running job
        release.set()
        deadline = time.monotonic() + 5.0
        while worker.busy and time.monotonic() < deadline:
            time.sleep(0.001)
        assert not worker.busy  # both served: nothing runs until the next offer
    finally:
        worker.stop()


@contextlib.contextmanager
def numbers_taken_on_thread(thread_name, on_message, on_error, depth, info=False):
    """Yield (context, executor, publisher): a node's `numbers` taken by a TakenOnThread."""
    import rclpy
    from rosutil import ros_context, spin_until
    from skin_driver.ros.hot_path import TakenOnThread
    from std_msgs.msg import UInt32

    with ros_context() as (context, executor):
        node = rclpy.create_node('taken_on_thread', context=context)
        executor.add_node(node)
        sub = TakenOnThread(node, thread_name, on_error)
        sub.subscribe(UInt32, 'numbers', on_message, depth, info=info)
        sub.start()
        pub = node.create_publisher(UInt32, 'numbers', depth)
        try:
            assert spin_until(executor, lambda: pub.get_subscription_count() == 1, 10.0)
            yield context, executor, pub
        finally:
            sub.stop()
            if context.ok():
                node.destroy_node()


def test_a_subscription_taken_on_its_own_thread_gets_every_message_and_no_executor_runs_it():
    from rosutil import spin_until
    from std_msgs.msg import UInt32

    threads, taken, errors = set(), [], []

    def on_message(msg):
        threads.add(threading.current_thread().name)
        if msg.data == 3:
            raise ValueError('a bad message')
        taken.append(msg.data)

    with numbers_taken_on_thread('skin-test-take', on_message, errors.append, 100) as (
            _, executor, pub):
        for i in range(50):
            pub.publish(UInt32(data=i))
        # The executor spins meanwhile and must not take a single one of them.
        assert spin_until(executor, lambda: len(taken) == 49, 10.0)
    assert taken == [i for i in range(50) if i != 3]  # in order; the bad one is reported
    assert [str(e) for e in errors] == ['a bad message']
    assert threads == {'skin-test-take'}


def test_a_subscription_asked_for_message_info_gets_the_publish_time_with_each_message():
    import time

    from rosutil import spin_until
    from std_msgs.msg import UInt32

    taken = []
    with numbers_taken_on_thread('skin-test-info', lambda msg, info: taken.append(
            (msg.data, info['source_timestamp'] * 1e-9)), taken.append, 10, info=True) as (
            _, executor, pub):
        before = time.time()
        pub.publish(UInt32(data=5))
        after = time.time()
        assert spin_until(executor, lambda: len(taken) == 1, 10.0)
    (data, published), = taken
    # The publisher's wall clock during its publish call (a float of time.time() is as fine
    # as 0.3 us: a millisecond either side only absorbs that).
    assert data == 5 and before - 1e-3 <= published <= after + 1e-3


def test_a_callback_failing_because_ctrl_c_shut_the_context_is_not_reported():
    import rclpy
    from std_msgs.msg import UInt32

    errors, calls, running = [], [], {}

    def on_message(msg):
        calls.append(msg.data)
        # What Ctrl-C does under the callback: the publish it makes then fails.
        rclpy.shutdown(context=running['context'])
        raise RuntimeError('Failed to publish: context is invalid')

    with numbers_taken_on_thread('skin-test-shutdown', on_message, errors.append, 10) as (
            context, _, pub):
        running['context'] = context
        pub.publish(UInt32(data=1))
        deadline = time.monotonic() + 10.0
        while not calls and time.monotonic() < deadline:
            time.sleep(0.01)
    assert calls == [1]
    assert errors == []


def test_an_rclpy_without_its_private_wait_set_is_named_on_import(monkeypatch):
    # The one private use of rclpy (skin_driver.ros.wait_set) fails on import, saying what the
    # rclpy in use lacks, rather than deep inside a thread at the first wait.
    monkeypatch.delattr(implementation_singleton.rclpy_implementation, 'WaitSet')
    monkeypatch.delitem(sys.modules, 'skin_driver.ros.wait_set', raising=False)
    with pytest.raises(ImportError, match=r"needs the wait set of rclpy's C extension .*"
                                          r'rclpy_implementation\.WaitSet'):
        importlib.import_module('skin_driver.ros.wait_set')
