"""
Build diagnostic_msgs messages without diagnostic_updater (not available as a wheel).

A node keeps one DiagnosticPublisher and hands it status dictionaries at a fixed period; the
result is what diagnostic_aggregator and rqt_robot_monitor expect on /diagnostics.
"""

from typing import Dict, Iterable, Tuple

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
    """Count events between two reads and report their rate."""

    def __init__(self, now_s: float):
        self._count = 0
        self._since = now_s

    def add(self, n: int = 1) -> None:
        """Count n events."""
        self._count += n

    def take(self, now_s: float) -> Tuple[float, int]:
        """Return (events per second, events) since the last take and start again."""
        elapsed = max(now_s - self._since, 1e-9)
        count, self._count, self._since = self._count, 0, now_s
        return count / elapsed, count
