"""
Record a live skin's ``frame`` messages into an offline dataset (docs/dataset.md).

Usage::

    ros2 run skin_driver record OUT.npz [--topic /skin/frame] [--scans N] [--duration S]
                                [--tare-frames N] [--azimuth-deg DEG --alpha-deg DEG --force-n N]
                                [--board-info-topic /skin/board_info]

Records until it has ``--scans`` scans, ``--duration`` seconds have passed or Ctrl-C, then writes
OUT.npz atomically; ``python -m skin_lab.evaluate OUT.npz`` scores it. The subscription has
the sensor-data QoS of the stream and takes ROS 2's QoS overrides
(``--ros-args -p qos_overrides./skin/frame.subscription.depth:=100``). The driver builds frames
only while someone subscribes: the recorder is such a subscriber. The board's identity,
latched on board_info beside the frame topic, stamps the dataset (``board_info``) when the board
said who it is.
"""

import argparse
import posixpath
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
from std_msgs.msg import String


class FrameRecorder:
    """Subscribe to SkinFrame messages on ``node`` and keep them in a Recording."""

    def __init__(self, node, topic: str, tare_frames: int = 0, board_info_topic: str = ''):
        self.node = node
        self.recording = Recording(tare_frames)
        self.rejected = 0
        node.create_subscription(
            SkinFrame, topic, self._on_frame, qos.stream(), **qos.overridable())
        node.create_subscription(String, board_info_topic or board_info_beside(topic),
                                 self._on_board_info, qos.latched())

    def _on_board_info(self, msg: String) -> None:
        try:
            self.recording.set_board(msg.data)
        except ValueError as err:
            self.node.get_logger().warning(f'board info not recorded: {err}')

    def _on_frame(self, msg: SkinFrame) -> None:
        try:
            top, bottom = conversions.skin_frame_layers(msg)
            self.recording.add(msg.pitch, top, bottom)
        except ValueError as err:
            self.rejected += 1
            self.node.get_logger().warning(f'frame {msg.sequence} not recorded: {err}',
                                           throttle_duration_sec=5.0)


def board_info_beside(topic: str) -> str:
    """Return the board_info topic of the driver that publishes the frame topic ``topic``."""
    return posixpath.join(posixpath.dirname(topic) or '/', 'board_info')


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog='ros2 run skin_driver record',
                                     description=__doc__.strip().split('\n')[0])
    parser.add_argument('out', help='dataset .npz to write')
    parser.add_argument('--topic', default='/skin/frame', help='SkinFrame topic to record')
    parser.add_argument('--scans', type=int, default=0,
                        help='stop after this many scans, tare included (0: no limit)')
    parser.add_argument('--duration', type=float, default=0.0,
                        help='stop after this many seconds (0: no limit)')
    parser.add_argument('--board-info-topic', default='',
                        help='std_msgs/String topic of the board identity (default: board_info '
                             'beside --topic)')
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
    recorder = FrameRecorder(node, args.topic, args.tare_frames, args.board_info_topic)
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
    board = recorder.recording.board
    print(f'wrote {data.frames} frames ({args.tare_frames} tare scans, {recorder.rejected} '
          f'refused) from {args.topic} to {args.out}; '
          + (f'board {board.board} uid {board.uid}' if board else 'no board identity'))
    return 0


if __name__ == '__main__':
    sys.exit(main())
