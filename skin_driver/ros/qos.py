"""
The QoS of the skin's topics, and ROS 2's standard way for a user to change it.

Streams (frame, images, contacts, contact, wrench) keep the sensor-data profile: best effort,
keep last 5, so a late or slow reader costs the publisher nothing and never sees stale scans.
The direction node, which must estimate every scan, reads frame best effort too but keeps the
last EVERY_SCAN_DEPTH: five scans are 2.5 ms at 2 kHz, shorter than a thread may wait for a core
on a busy machine, so a depth of five would lose scans there.
The rviz topics and /diagnostics are reliable, keep last 5 and 10. board_info (what the board
says it is, sent when it changes) is latched: reliable, transient local, keep last 1, so a node
that starts later still hears it. Every publisher and
subscription takes ROS 2's QoS overrides, parameters read once at start-up, e.g.

    --ros-args -p qos_overrides./skin/wrench.publisher.reliability:=reliable

(history, depth and reliability; a YAML parameter file takes them as well).
"""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.qos_overriding_options import QoSOverridingOptions

VIZ_DEPTH = 5
STREAM_DEPTH = 5
EVERY_SCAN_DEPTH = 50  # 25 ms of scans at 2 kHz
DIAGNOSTICS_DEPTH = 10


def stream(depth: int = STREAM_DEPTH) -> QoSProfile:
    """Return a fresh sensor-data profile (rclpy's qos_profile_sensor_data) for one stream."""
    # A fresh one each time: rclpy applies a topic's overrides to the profile object it is given,
    # and on the shared qos_profile_sensor_data they would leak to every later stream.
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.VOLATILE)


def latched() -> QoSProfile:
    """Return the profile of a topic whose last message a late subscriber still gets."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


def overridable() -> dict:
    """Return the keyword that lets a publisher or subscription take QoS overrides."""
    return {'qos_overriding_options': QoSOverridingOptions.with_default_policies()}
