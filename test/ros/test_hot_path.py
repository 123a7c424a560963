"""Subscriber counts asked at a low rate, and work for viewers kept off the reader's thread."""

import threading

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
