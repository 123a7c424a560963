"""
Serial driver node: reads the skin's frames and publishes them as ROS messages.

A lifecycle node: configure reads and checks the parameters, activate opens the port and starts
reading, deactivate stops reading, cleanup forgets the configuration. With autostart (default) it
walks to active on its own, as a plain node would.

Publishes (sensor-data QoS): frame (skin_msgs/SkinFrame), top/image_raw and bottom/image_raw
(sensor_msgs/Image, mono16, raw counts). Diagnostics on /diagnostics once a second.

Each message is stamped with the host time at which its last byte was read. The board's own clock
travels in SkinFrame.device_time_us: it is not synchronised with the host, but its differences are
exact, so consumers use it for the interval between scans and for latency measurements.
"""

import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.lifecycle import Node, State, TransitionCallbackReturn
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import Image
from skin_msgs.msg import SkinFrame

from skin_driver import conversions, diagnostics
from skin_driver.core.protocol import FrameDecoder
from skin_driver.params import declare, ParameterError
from skin_driver.serial_link import CONNECTED, SerialLink, STALLED, STOPPED


class SkinDriverNode(Node):
    """Lifecycle node that owns the serial link to the skin."""

    def __init__(self, **kwargs):
        super().__init__('skin_driver', **kwargs)
        self._declare_parameters()
        self._link = None
        self._pubs = {}
        self._diag = None
        self._diag_timer = None
        self._rate = None
        self._state_detail = 'not configured'

    def _declare_parameters(self) -> None:
        self.autostart = declare(
            self, 'autostart', True,
            'Walk through configure and activate at start-up, as a plain node would.')
        declare(self, 'port', '/tmp/skin0',
                'Serial device or pyserial URL of the skin board, e.g. /dev/ttyACM0, '
                'socket://localhost:5000, loop://', non_empty=True)
        declare(self, 'baud', 921600, 'Serial baud rate (USB CDC and ptys ignore it).',
                low=1200, high=12000000)
        declare(self, 'rows', 16, 'Taxel rows the board must send (along y).', low=1, high=128)
        declare(self, 'cols', 16, 'Taxel columns the board must send (along x).', low=1, high=128)
        declare(self, 'pitch', 0.005, 'Distance between taxel centres, metres.',
                low=0.0001, high=0.1)
        declare(self, 'frame_id', 'skin_link', 'TF frame of the skin patch in every header.',
                non_empty=True)
        declare(self, 'publish_images', True,
                'Also publish each layer as a mono16 image (costs time at kHz rates).')
        declare(self, 'read_timeout', 0.05,
                'Seconds one read may block; bounds how fast the reader notices a stop.',
                low=0.001, high=1.0)
        declare(self, 'stall_timeout', 1.0,
                'Seconds without a frame before the link is reported stalled.',
                low=0.05, high=60.0)
        declare(self, 'reconnect_min', 0.1, 'First delay before reopening a lost port, seconds.',
                low=0.01, high=10.0)
        declare(self, 'reconnect_max', 2.0, 'Longest delay between reopening attempts, seconds.',
                low=0.01, high=60.0)
        declare(self, 'diagnostics_period', 1.0, 'Seconds between two /diagnostics reports.',
                low=0.1, high=60.0)

    def _p(self, name):
        return self.get_parameter(name).value

    # ---- lifecycle --------------------------------------------------------------------------
    def on_configure(self, state: State) -> TransitionCallbackReturn:
        """Check the parameters and create publishers."""
        if self._p('reconnect_min') > self._p('reconnect_max'):
            self.get_logger().error(
                f"parameter 'reconnect_min' ({self._p('reconnect_min')}) must not exceed "
                f"'reconnect_max' ({self._p('reconnect_max')})")
            return TransitionCallbackReturn.FAILURE
        self._frame_id = self._p('frame_id')
        self._pitch = float(self._p('pitch'))
        self._pubs['frame'] = self.create_lifecycle_publisher(SkinFrame, 'frame',
                                                              qos_profile_sensor_data)
        if self._p('publish_images'):
            for layer in ('top', 'bottom'):
                self._pubs[layer] = self.create_lifecycle_publisher(
                    Image, f'{layer}/image_raw', qos_profile_sensor_data)
        decoder = FrameDecoder(expected_shape=(self._p('rows'), self._p('cols')))
        self._link = SerialLink(
            self._p('port'), self._p('baud'), decoder, self._publish_frames, self._on_link_state,
            read_timeout_s=self._p('read_timeout'), stall_timeout_s=self._p('stall_timeout'),
            backoff_min_s=self._p('reconnect_min'), backoff_max_s=self._p('reconnect_max'))
        self._diag = diagnostics.DiagnosticPublisher(self)
        self._rate = diagnostics.RateMeter(time.monotonic())
        self._diag_timer = self.create_timer(self._p('diagnostics_period'), self._report)
        self._state_detail = 'configured'
        self.get_logger().info(f"configured for {self._p('port')} "
                               f"({self._p('rows')}x{self._p('cols')} taxels)")
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        """Open the port (retrying in the background until the device is there)."""
        result = super().on_activate(state)
        self._link.start()
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        """Stop reading and close the port."""
        self._link.stop()
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        """Release everything configure created."""
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        """Stop reading and release everything."""
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def close(self) -> None:
        """Stop reading and release the port; safe to call in any state."""
        self._release()

    def _release(self) -> None:
        if self._link is not None:
            self._link.stop()
            self._link = None
        for pub in self._pubs.values():
            self.destroy_lifecycle_publisher(pub)
        self._pubs = {}
        if self._diag_timer is not None:
            self.destroy_timer(self._diag_timer)
            self._diag_timer = None
        if self._diag is not None:
            self._diag.destroy()
            self._diag = None

    # ---- data path (runs on the link's thread) ---------------------------------------------
    def _publish_frames(self, frames, receive_monotonic: float) -> None:
        stamp = self.get_clock().now().to_msg()
        header = conversions.make_header(stamp, self._frame_id)
        for frame in frames:
            self._pubs['frame'].publish(conversions.skin_frame_to_msg(
                header, frame.seq, frame.device_time_us, self._pitch, frame.top, frame.bottom))
            if 'top' in self._pubs:
                self._pubs['top'].publish(conversions.counts_to_image(header, frame.top))
                self._pubs['bottom'].publish(conversions.counts_to_image(header, frame.bottom))
        self._rate.add(len(frames))

    def _on_link_state(self, state: str, detail: str) -> None:
        self._state_detail = detail
        if state == STOPPED:
            return
        # rclpy fixes a call site's severity at its first call: one call site per severity.
        if state == CONNECTED:
            self.get_logger().info(f'skin link {state}: {detail}')
        else:
            self.get_logger().warning(f'skin link {state}: {detail}')

    # ---- diagnostics ------------------------------------------------------------------------
    def _report(self) -> None:
        if self._link is None:
            return
        rate, _ = self._rate.take(time.monotonic())
        link, dec = self._link.stats, self._link.decoder.stats
        state = self._link.state
        if state == CONNECTED:
            level = diagnostics.OK if not dec.size_errors else diagnostics.WARN
        elif state == STALLED:
            level = diagnostics.WARN
        else:
            level = diagnostics.ERROR
        message = f'{state}: {self._state_detail}'
        if dec.size_errors and state == CONNECTED:
            message += (f"; {dec.size_errors} frames of the wrong grid size rejected "
                        f"(expected {self._p('rows')}x{self._p('cols')})")
        values = {
            'port': self._p('port'), 'link state': state, 'frame rate [Hz]': rate,
            'frames': dec.frames, 'crc errors': dec.crc_errors, 'size errors': dec.size_errors,
            'version errors': dec.version_errors, 'bytes discarded': dec.bytes_discarded,
            'sequence gaps': dec.seq_gaps, 'frames dropped': dec.frames_missed,
            'connects': link.connects, 'disconnects': link.disconnects,
            'open failures': link.open_failures, 'publish errors': link.callback_errors,
            'last error': link.last_error,
        }
        self._diag.publish([diagnostics.make_status(
            f'{self.get_fully_qualified_name()}: skin link', self._p('port'), level, message,
            values)])


def main(args=None):
    """Run the driver node until shut down."""
    rclpy.init(args=args)
    try:
        node = SkinDriverNode()
    except ParameterError as err:
        rclpy.logging.get_logger('skin_driver').fatal(str(err))
        rclpy.try_shutdown()
        raise SystemExit(1)
    try:
        if node.autostart:
            if node.trigger_configure() != TransitionCallbackReturn.SUCCESS:
                raise SystemExit(1)
            node.trigger_activate()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.close()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
