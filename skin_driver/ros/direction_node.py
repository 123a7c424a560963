"""
Direction node: turns SkinFrame scans into contacts with location, force and direction.

Subscribes to frame (skin_msgs/SkinFrame) and board_info (std_msgs/String, latched: who the
board says it is, which the calibration file is bound to). Publishes contacts
(TactileContactArray, every scan, empty when nothing touches), contact (the strongest
TactileContact, when there is one) and wrench (geometry_msgs/WrenchStamped: the net wrench of all
contacts about the frame origin, as a force/torque sensor reports it; zero when nothing touches,
so a controller sees the release).
For rviz, at most viz_rate times a second: top/heatmap and bottom/heatmap (rgb8) and markers
(visualization_msgs/MarkerArray). Actions: ~/calibrate, ~/calibrate_force,
~/calibrate_compliance, ~/calibrate_gains (skin_msgs/action). Services: ~/tare and
~/reset_calibration (std_srvs/srv/Trigger). Diagnostics on /diagnostics.

Threads: the frames are taken and estimated on a thread of their own (skin-frames), every frame
waiting at each wake-up, not by the executor, which serves parameters, services, actions and
timers (skin_driver.ros.hot_path.TakenOnThread; rclpy's executor rebuilds its wait set from
every entity of the node at each wake-up, a cost the scans should not pay).

The same node runs inside the driver's process when the driver is fused (parameter fused): it
then has no subscription, and the driver's serial reader thread hands it every scan directly.
Either way the estimation itself is skin_driver.ros.estimation_host.
"""

import rclpy
from rclpy.node import Node
from skin_driver.core.protocol.wire import BoardInfo
from skin_driver.ros import conversions, qos
from skin_driver.ros.estimation_host import EstimationHost
from skin_driver.ros.hot_path import TakenOnThread
from skin_driver.ros.lifetime import destroyed_if_refused
from skin_driver.ros.spin import create_or_exit, spin_nodes
from skin_msgs.msg import SkinFrame
from std_msgs.msg import String


class DirectionNode(Node):
    """Estimate contacts from raw scans; calibrate and tare on request."""

    @destroyed_if_refused
    def __init__(self, subscribe: bool = True, **kwargs):
        """Create the node; with subscribe false, scans come only through host.process()."""
        super().__init__('skin_direction', **kwargs)
        self.host = EstimationHost(self)
        self._frames = None
        # Fused as well: the driver's reader hands over scans, not who the board is.
        self.create_subscription(String, 'board_info', self._on_board_info, qos.latched())
        if subscribe:
            # The scan's bytes as they arrive, read straight into the layers, where rclpy's
            # own bytes read back right: no message object per scan.
            raw = conversions.skin_frames_read_back()
            self._frames = TakenOnThread(self, 'skin-frames', self._frame_failed)
            self._frames.subscribe(SkinFrame, 'frame',
                                   self._on_frame_bytes if raw else self._on_frame,
                                   qos.stream(qos.EVERY_SCAN_DEPTH), raw=raw, **qos.overridable())
            self._frames.start()

    def destroy_node(self):
        """Stop taking frames and estimating, then destroy the node."""
        if self._frames is not None:
            self._frames.stop()
        self.host.close()
        return super().destroy_node()

    def _on_board_info(self, msg: String) -> None:
        try:
            info = BoardInfo.parse(msg.data)
        except ValueError as err:
            self.get_logger().warning(f'board_info not understood, ignored: {err}')
            return
        self.host.calibration.set_board(info)

    def _frame_failed(self, err: Exception) -> None:
        self.get_logger().error(f'frame not estimated: {err!r}', throttle_duration_sec=5.0)

    def _on_frame_bytes(self, data: bytes) -> None:
        try:
            header, sequence, device_time_us, pitch, top, bottom = conversions.read_skin_frame(
                data)
        except ValueError as err:
            self.host.reject(None, err)  # its sequence number is not known for sure
            return
        self.host.process(header, sequence, device_time_us, pitch, top, bottom)

    def _on_frame(self, msg: SkinFrame) -> None:
        try:
            top, bottom = conversions.skin_frame_layers(msg)
        except ValueError as err:
            self.host.reject(msg.sequence, err)
            return
        self.host.process(msg.header, msg.sequence, msg.device_time_us, float(msg.pitch),
                          top, bottom)


def main(args=None):
    """Run the direction node until shut down."""
    rclpy.init(args=args)
    spin_nodes([create_or_exit(DirectionNode, 'skin_direction')])


if __name__ == '__main__':
    main()
