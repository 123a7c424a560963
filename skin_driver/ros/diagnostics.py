"""
Build diagnostic_msgs messages without diagnostic_updater (not available as a wheel).

A node keeps one DiagnosticPublisher and hands it status dictionaries at a fixed period; the
result is what diagnostic_aggregator and rqt_robot_monitor expect on /diagnostics.
"""

from typing import Callable, Dict, Iterable, Tuple

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from skin_driver.ros import qos

OK = DiagnosticStatus.OK
WARN = DiagnosticStatus.WARN
ERROR = DiagnosticStatus.ERROR


def make_status(name: str, hardware_id: str, level: int, message: str,
                values: Dict[str, object]) -> DiagnosticStatus:
    """Return one DiagnosticStatus with its key/value pairs as strings (level: byte or int)."""
    return DiagnosticStatus(
        level=bytes([level]) if isinstance(level, int) else level, name=name, message=message,
        hardware_id=hardware_id,
        values=[KeyValue(key=str(k), value=_fmt(v)) for k, v in values.items()])


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return f'{value:.6g}'
    return str(value)


class DiagnosticPublisher:
    """Publish DiagnosticArray messages on /diagnostics for one node."""

    def __init__(self, node):
        self._node = node
        self._pub = node.create_publisher(DiagnosticArray, '/diagnostics', qos.DIAGNOSTICS_DEPTH,
                                          **qos.overridable())

    def publish(self, statuses: Iterable[DiagnosticStatus]) -> None:
        """Send the statuses, stamped now."""
        msg = DiagnosticArray(status=list(statuses))
        msg.header.stamp = self._node.get_clock().now().to_msg()
        self._pub.publish(msg)

    def destroy(self) -> None:
        """Release the publisher."""
        self._node.destroy_publisher(self._pub)


class RateMeter:
    """
    Count events on one thread and report their rate on another.

    ``add`` (the counting thread) only ever raises a running total; ``take`` (the reporting
    thread) reports the difference from the total it saw last. Neither resets what the other
    writes, so no count is lost between the two.
    """

    def __init__(self, now_s: float):
        self._total = 0  # written by add() alone
        self._seen = 0  # written by take() alone
        self._since = now_s

    def add(self, n: int = 1) -> None:
        """Count n events."""
        self._total += n

    def take(self, now_s: float) -> Tuple[float, int]:
        """Return (events per second, events) since the last take."""
        elapsed = max(now_s - self._since, 1e-9)
        total = self._total
        count, self._seen, self._since = total - self._seen, total, now_s
        return count / elapsed, count


class PeriodMax:
    """
    The largest value one thread saw in each of another thread's reporting periods.

    The observing thread writes one (period, largest) pair and the reporting thread only
    advances the period: a value is never reset by a thread other than the one that raises it.
    """

    def __init__(self):
        self._period = 0  # written by take() alone
        self._largest = (0, 0.0)  # written by see() alone

    def see(self, value: float) -> None:
        """Take ``value`` into the current period's largest."""
        period, largest = self._largest
        if period != self._period:
            self._largest = (self._period, value)
        elif value > largest:
            self._largest = (period, value)

    def take(self) -> float:
        """Return the largest value of the period now ending (0 if none), and start another."""
        period, largest = self._largest
        value = largest if period == self._period else 0.0
        self._period += 1
        return value


class TakenByOwner:
    """
    A reading that resets what it reads (StageCpu.take), taken on the thread that writes it.

    The reporting thread asks (:meth:`ask`) and reads the last reading; the owning thread
    calls :meth:`serve` after each pass, which takes the reading when one was asked for. A
    reading is at most one period old; none since the last ask means the owner did not run.
    """

    def __init__(self, take: Callable[[], dict], idle: dict):
        self._take = take
        self._idle = dict(idle)
        self._asked = 0  # written by ask() alone
        self._reading = (0, self._idle)  # (ask served, reading), written by serve() alone

    def serve(self) -> None:
        """Take the reading if it was asked for (on the owning thread)."""
        asked = self._asked
        if self._reading[0] != asked:
            self._reading = (asked, self._take())

    def ask(self) -> dict:
        """Return the last period's reading (idle values if the owner did not run); ask anew."""
        served, reading = self._reading
        fresh = served == self._asked
        self._asked += 1
        return reading if fresh else self._idle
