"""
Record a live skin's ``frame`` messages into an offline dataset (docs/dataset.md).

Usage::

    ros2 run skin_driver record OUT.npz [--topic /skin/frame] [--scans N] [--duration S]
                                [--tare-frames N] [--azimuth-deg DEG --alpha-deg DEG --force-n N]

Records until it has ``--scans`` scans, ``--duration`` seconds have passed or Ctrl-C, then writes
OUT.npz atomically; ``python -m skin_driver.evaluate OUT.npz`` scores it. The subscription has
the sensor-data QoS of the stream and takes ROS 2's QoS overrides
(``--ros-args -p qos_overrides./skin/frame.subscription.depth:=100``). The driver builds frames
only while someone subscribes: the recorder is such a subscriber.
"""

import argparse
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from skin_driver.core.common.atomic import check_writable
from skin_driver.core.estimation.data.dataset import save_dataset
from skin_driver.core.estimation.data.recording import Recording
from skin_driver.ros import conversions, qos
from skin_driver.tools.recording_args import add_recording_arguments, labels_of
from skin_msgs.msg import SkinFrame


class FrameRecorder:
    """Subscribe to SkinFrame messages on ``node`` and keep them in a Recording."""

    def __init__(self, node, topic: str, tare_frames: int = 0):
        self.node = node
        self.recording = Recording(tare_frames)
        self.rejected = 0
        node.create_subscription(
            SkinFrame, topic, self._on_frame, qos.stream(), **qos.overridable())

    def _on_frame(self, msg: SkinFrame) -> None:
        try:
            top, bottom = conversions.skin_frame_layers(msg)
            self.recording.add(msg.pitch, top, bottom)
        except ValueError as err:
            self.rejected += 1
            self.node.get_logger().warning(f'frame {msg.sequence} not recorded: {err}',
                                           throttle_duration_sec=5.0)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='ros2 run skin_driver record',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('out', help='dataset .npz to write')
    parser.add_argument('--topic', default='/skin/frame', help='SkinFrame topic to record')
    parser.add_argument('--scans', type=int, default=0,
                        help='stop after this many scans, tare included (0: no limit)')
    parser.add_argument('--duration', type=float, default=0.0,
                        help='stop after this many seconds (0: no limit)')
    add_recording_arguments(parser)
    return parser


def main(argv=None) -> int:
    """Record until done or interrupted, then write the dataset; return the exit status."""
    args_in = sys.argv[1:] if argv is None else list(argv)
    ros_args = rclpy.utilities.remove_ros_args(['record'] + args_in)[1:]
    parser = _parser()
    args = parser.parse_args(ros_args)
    try:
        check_writable(args.out)
    except ValueError as err:
        parser.error(str(err))
    rclpy.init(args=['record'] + args_in)
    node = rclpy.create_node('skin_recorder')
    recorder = FrameRecorder(node, args.topic, args.tare_frames)
    deadline = time.monotonic() + args.duration if args.duration > 0 else None
    try:
        while rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.1)
            if args.scans and recorder.recording.scans >= args.scans:
                break
            if deadline is not None and time.monotonic() >= deadline:
                break
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    try:
        data = recorder.recording.dataset(labels_of(args))
        save_dataset(args.out, data)
    except (OSError, ValueError) as err:
        print(f'error: nothing written: {err}', file=sys.stderr)
        return 2
    print(f'wrote {data.frames} frames ({args.tare_frames} tare scans, {recorder.rejected} '
          f'refused) from {args.topic} to {args.out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
