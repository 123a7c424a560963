"""
Where the skin is on a robot: its frame's name and the static transform that mounts it.

The skin's frame is named after the namespace of its nodes, so two skins on one robot never
share a frame: ``left_skin_link`` for ``/left``, ``robot_left_skin_link`` for ``/robot/left``,
and ``skin_link`` for the launch file's namespace ``skin`` or none.
"""

import math

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from skin_driver.ros import conversions
from skin_driver.ros.lifetime import destroyed_if_refused
from skin_driver.ros.params import accept_whole_numbers, declare
from skin_driver.ros.spin import create_or_exit, spin_nodes


def default_frame_id(namespace: str) -> str:
    """Return the skin's frame for nodes in ``namespace``."""
    prefix = namespace.strip('/').replace('/', '_')
    return 'skin_link' if prefix in ('', 'skin') else f'{prefix}_skin_link'


class MountTransform(Node):
    """
    Publish the skin's mount pose on its parent link once, on /tf_static (latched).

    tf2_ros's static_transform_publisher does the same; this one needs only tf2_msgs, so the
    launch file places the skin where tf2_ros is not installed.
    """

    @destroyed_if_refused
    def __init__(self, **kwargs):
        super().__init__('skin_mount_tf', **kwargs)
        # tf2_msgs comes with every ROS 2 install but has no wheel: imported where it is used.
        from tf2_msgs.msg import TFMessage
        parent = declare(self, 'parent_frame', 'base_link',
                         'Link the skin is mounted on.', non_empty=True)
        child = declare(self, 'frame_id', '',
                        "The skin's frame (empty: from the namespace, as the driver names it).")
        pose = [declare(self, name, 0.0, f'Mount pose on the parent link: {what}.',
                        low=low, high=high)
                for name, what, low, high in (
                    ('x', 'x in metres', -100.0, 100.0), ('y', 'y in metres', -100.0, 100.0),
                    ('z', 'z in metres', -100.0, 100.0),
                    ('roll', 'roll about x in radians', -2 * math.pi, 2 * math.pi),
                    ('pitch', 'pitch about y in radians', -2 * math.pi, 2 * math.pi),
                    ('yaw', 'yaw about z in radians', -2 * math.pi, 2 * math.pi))]
        accept_whole_numbers(self)
        self.transform = conversions.mount_transform(
            self.get_clock().now().to_msg(), parent, child or default_frame_id(
                self.get_namespace()), pose[:3], pose[3:])
        # /tf_static is latched: a listener that starts later still gets the mount.
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self._pub = self.create_publisher(TFMessage, '/tf_static', latched)
        self._pub.publish(TFMessage(transforms=[self.transform]))
        self.get_logger().info(f'{self.transform.child_frame_id} mounted on {parent}')


MISSING_TF2_MSGS = ('tf2_msgs is not installed, so the mount cannot go on /tf_static: install '
                    'ros-jazzy-tf2-msgs (every ROS 2 desktop install has it) or publish the mount '
                    'with tf2_ros static_transform_publisher')


def main(args=None):
    """Publish the mount transform and keep it latched until shut down."""
    rclpy.init(args=args)
    try:
        import tf2_msgs.msg  # noqa: F401 - only whether it is there
    except ImportError:
        # One line that says what to install, not an ImportError's traceback.
        rclpy.logging.get_logger('skin_mount_tf').fatal(MISSING_TF2_MSGS)
        rclpy.try_shutdown()
        raise SystemExit(1) from None
    spin_nodes([create_or_exit(MountTransform, 'skin_mount_tf')])
