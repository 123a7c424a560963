"""Diagnostic counts written by one thread and reported by another: nothing lost, none reset."""

import threading

from skin_driver.ros.diagnostics import PeriodMax, RateMeter, TakenByOwner


def test_a_rate_meter_loses_no_event_counted_while_it_is_read():
    meter = RateMeter(0.0)
    total = 200_000
    counted = threading.Thread(target=lambda: [meter.add() for _ in range(total)])
    counted.start()
    taken = 0
    now = 0.0
    while counted.is_alive():
        now += 1.0
        taken += meter.take(now)[1]
    counted.join()
    taken += meter.take(now + 1.0)[1]
    assert taken == total
    assert meter.take(now + 3.0) == (0.0, 0)


def test_the_largest_value_is_the_periods_own():
    worst = PeriodMax()
    assert worst.take() == 0.0
    for value in (3.0, 7.0, 5.0):
        worst.see(value)
    assert worst.take() == 7.0
    worst.see(2.0)  # a new period: the old largest does not carry over
    assert worst.take() == 2.0
    assert worst.take() == 0.0


def test_a_resetting_reading_is_taken_by_its_owner_when_asked():
    taken = []

    def take():
        taken.append(len(taken) + 1)
        return {'stage': float(taken[-1])}
    reading = TakenByOwner(take, {'stage': 0.0})
    reading.serve()  # nobody asked: nothing is taken
    assert taken == []
    assert reading.ask() == {'stage': 0.0}
    reading.serve()
    reading.serve()  # taken once per ask
    assert taken == [1]
    assert reading.ask() == {'stage': 1.0}
    # The owner did not run since: its idle values, not the old reading.
    assert reading.ask() == {'stage': 0.0}
