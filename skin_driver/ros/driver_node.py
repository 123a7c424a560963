"""
Serial driver node: reads the skin's frames and publishes them as ROS messages.

A lifecycle node: configure reads and checks the parameters, activate opens the port and starts
reading, deactivate stops reading, cleanup forgets the configuration. With autostart (default) it
walks to active on its own, as a plain node would.

Publishes (sensor-data QoS): frame (skin_msgs/SkinFrame), top/image_raw and bottom/image_raw
(sensor_msgs/Image, mono16, raw counts). Diagnostics on /diagnostics once a second. board_info
(std_msgs/String, latched): the board's information text (docs/protocol.md) each time the
board says who it is, or its health (fault counters), for the first time or differently;
nothing from a version-1 board.

The reader thread does only what each scan needs: read, decode, (fused) estimate and publish
contacts, publish frame while someone subscribes to it. Raw images are built only while someone
subscribes, on a thread of their own from the newest scan (a viewer may miss scans; the reader
never waits for it). With realtime_priority the reader thread runs SCHED_FIFO at it when the
process may, else at normal priority with a warning (README, "Real-time priority").

Diagnostics: OK while frames arrive; WARN when the link is stalled or, within the last period,
frames were dropped (sequence gaps, frames lost while the device was away) or corrupt frames
were rejected (line noise); ERROR while the device is missing or when it only sends frames of
another grid size (the received shape is in the message). A change of link state is reported at
once, not at the next period. An inactive or unconfigured driver (stopped on request) is OK and
keeps reporting its state. Parameters set at run time are checked as at start-up; those that
configure reads are refused with the reason while the driver is configured (deactivate, cleanup,
set, configure, activate), never accepted and silently ignored. A link lost while the node shuts
down (Ctrl-C stops the simulated board too) is not reported as a fault.

The grid and pitch are the board's word (core.protocol.grid): the grid from its frames, the
pitch from its board information frame; scans that arrive before the board has said its pitch
are counted, not published. The rows, cols and pitch parameters (0: the board's) override it; a
board that contradicts one that is set stops the scans' use: the error, naming both, is logged,
on /diagnostics (ERROR) and the driver deactivates itself and refuses to activate until it is
configured afresh (cleanup, set the parameter, configure, activate).

Fused (parameter fused, read at start-up): the process also runs the skin_direction node (same
parameters, services, topics and diagnostics as the separate direction node) and estimates every
scan on the serial reader thread right after decoding it, before the frame is published: no
executor and no SkinFrame round trip between the last byte and the contacts. With grid and
pitch set, configure checks the estimator (calibration, pitch) for them, so the reader's first
scan is estimated; from the board's word, the first scans ask the executor to check it.

Each message is stamped with the host time at which its last byte was read. The board's own clock
travels in SkinFrame.device_time_us: it is not synchronised with the host, but its differences are
exact, so consumers use it for the interval between scans and for latency measurements.
"""

import threading
import time

from builtin_interfaces.msg import Time
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.lifecycle import Node, State, TransitionCallbackReturn
from rclpy.parameter import Parameter
from sensor_msgs.msg import Image
from skin_driver.core.protocol.grid import SkinGrid
from skin_driver.core.protocol.health import ERROR, LinkHealth, WARN
from skin_driver.core.protocol.link import (CONNECTED, default_port, DISCONNECTED, SerialLink,
                                            STOPPED)
from skin_driver.core.protocol.realtime import StageCpu
from skin_driver.core.protocol.wire import FrameDecoder
from skin_driver.ros import conversions, diagnostics, qos
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.frames import default_frame_id
from skin_driver.ros.hot_path import LatestOnly, Listened
from skin_driver.ros.lifetime import destroy_state_machine, destroyed_if_refused
from skin_driver.ros.mount_calibration import declare_given_mount, GIVEN_POSE
from skin_driver.ros.params import accept_whole_numbers, declare
from skin_driver.ros.spin import create_or_exit, spin_nodes
from skin_msgs.msg import SkinFrame
from std_msgs.msg import String

# Every other parameter is read by configure: a change while configured would be accepted and
# change nothing, so it is refused.
START_UP_PARAMETERS = ('autostart', 'fused', 'use_sim_time')
# Ctrl-C reaches a simulated board as well as the driver: a port lost within this long before the
# context shuts down belongs to the shutdown, not to a fault.
SHUTDOWN_GRACE_S = 0.25
# The smallest pitch the driver takes (a set pitch below it is a slip of the unit).
MIN_PITCH_M = 0.0001
# The reader thread's stages whose CPU per scan /diagnostics reports (deliver: the rest).
READER_STAGES = ('read', 'decode', 'estimation', 'frame', 'images', 'deliver')


class SkinDriverNode(Node):
    """Lifecycle node that owns the serial link to the skin."""

    @destroyed_if_refused
    def __init__(self, **kwargs):
        super().__init__('skin_driver', **kwargs)
        self._declare_parameters()
        accept_whole_numbers(self)
        self._link = None
        self._pubs = {}
        self._rate = None
        self._lifecycle = 'unconfigured'
        self._state_detail = ''
        self._burst = self._cpu_reading = None  # the reader's, made at configure
        self._health = None
        self._grid = None  # the SkinGrid of the configuration
        self._ready = False  # the grid and pitch are known and nothing contradicts them
        self._held = 0  # scans not used while the board's word was awaited
        # The reader thread's way to have the executor deactivate a driver whose board
        # contradicts its parameters.
        self._refused = self.create_guard_condition(self._deactivate_refused)
        self._report_lock = threading.Lock()
        self._shutting_down = threading.Event()
        self.context.on_shutdown(self._shutting_down.set)
        # Diagnostics live as long as the node: a stopped driver still says what it is doing.
        self._diag = diagnostics.DiagnosticPublisher(self)
        self._diag_timer = self.create_timer(self._p('diagnostics_period'), self._report)
        self.estimation = None  # an EstimationHost fed on the reader thread when fused
        self._listened = self._images = None
        self._board_pub = None
        self._system_time = not self.get_clock().ros_time_is_active
        self.add_on_set_parameters_callback(self._check_new_parameters)
        self.add_post_set_parameters_callback(self._follow_sim_time)

    @property
    def link(self):
        """
        Return the SerialLink of core.protocol while configured, else None.

        For monitoring: its ``state``, ``stats`` and ``decoder.stats`` are what the diagnostics
        report.
        """
        return self._link

    def _declare_parameters(self) -> None:
        self.autostart = declare(
            self, 'autostart', True,
            'Walk through configure and activate at start-up, as a plain node would.')
        declare(self, 'port', '',
                'Serial device or pyserial URL of the skin board, e.g. /dev/ttyACM0, '
                'socket://localhost:5000, loop://; empty: the path of this user for the namespace '
                '($XDG_RUNTIME_DIR/skin_driver/<namespace>/skin0), where the simulator links')
        declare(self, 'baud', 921600, 'Serial baud rate (USB CDC and ptys ignore it).',
                low=1200, high=12000000)
        declare(self, 'rows', 0, 'Taxel rows the board must send (along y); 0: what the board '
                'sends.', low=0, high=128)
        declare(self, 'cols', 0, 'Taxel columns the board must send (along x); 0: what the '
                'board sends.', low=0, high=128)
        declare(self, 'pitch', 0.0, 'Distance between taxel centres, metres (at least '
                f'{MIN_PITCH_M}); 0: what the board says in its information frame (a version-1 '
                'board says none: set it).', low=0.0, high=0.1)
        declare(self, 'frame_id', '',
                'TF frame of the skin patch in every header; empty: from the namespace '
                '(<namespace>_skin_link, skin_link in the namespace skin or none).')
        declare(self, 'publish_images', True,
                'Offer each layer as a mono16 image, built only while someone subscribes, on a '
                'thread of its own from the newest scan.')
        declare(self, 'realtime_priority', 0,
                'SCHED_FIFO priority of the serial reader thread (1..99), 0: normal priority. '
                'Needs CAP_SYS_NICE or an rtprio limit at least as high; without either the '
                'driver warns and reads at normal priority.', low=0, high=99)
        declare(self, 'read_timeout', 0.05,
                'Seconds one read may block; bounds how fast the reader notices a stop.',
                low=0.001, high=1.0)
        declare(self, 'stall_timeout', 1.0,
                'Seconds without a frame before the link is reported stalled.',
                low=0.05, high=60.0)
        declare(self, 'reconnect_min', 0.1, 'First delay before reopening a lost port, seconds.',
                low=0.01, high=10.0)
        declare(self, 'reconnect_max', 0.5,
                'Longest delay between reopening attempts, seconds (a device path that '
                'reappears is reopened at once).', low=0.01, high=60.0)
        declare(self, 'diagnostics_period', 1.0, 'Seconds between two /diagnostics reports.',
                low=0.1, high=60.0)
        self.fused = declare(
            self, 'fused', False,
            'Estimate contacts on the serial reader thread of this process (a skin_direction '
            'node inside the driver) instead of in a separate direction node.', read_only=True)

    def _p(self, name):
        return self.get_parameter(name).value

    def _follow_sim_time(self, params) -> None:
        # rclpy's time source has taken the change already (an on-set callback).
        self._system_time = not self.get_clock().ros_time_is_active

    def _port(self) -> str:
        return self._p('port').strip() or default_port(self.get_namespace())

    def _check_new_parameters(self, params) -> SetParametersResult:
        """Refuse at run time what start-up refuses; rclpy itself checks the ranges."""
        new = {p.name: p.value for p in params}
        fixed = [name for name in new if name not in START_UP_PARAMETERS]
        if fixed and self._link is not None:
            problem = (f"{', '.join(map(repr, fixed))} cannot change while the driver is "
                       f'{self._lifecycle}: it is read at configure; deactivate, cleanup, set it, '
                       'then configure and activate')
        else:
            problem = _backoff_problem(new.get('reconnect_min', self._p('reconnect_min')),
                                       new.get('reconnect_max', self._p('reconnect_max')))
        if problem:
            self.get_logger().warning(f'parameter refused: {problem}')
        return SetParametersResult(successful=not problem, reason=problem)

    # ---- lifecycle --------------------------------------------------------------------------
    def on_configure(self, state: State) -> TransitionCallbackReturn:
        """Check the parameters and create publishers."""
        problem = _backoff_problem(self._p('reconnect_min'), self._p('reconnect_max'))
        if 0 < self._p('pitch') < MIN_PITCH_M:
            problem = f"'pitch' ({self._p('pitch')} m) must be 0 or at least {MIN_PITCH_M} m"
        if problem:
            self.get_logger().error(f'parameter {problem}')
            return TransitionCallbackReturn.FAILURE
        self._frame_id = self._p('frame_id').strip() or default_frame_id(self.get_namespace())
        self._grid = SkinGrid(self._p('rows'), self._p('cols'), self._p('pitch'))
        self._pitch = self._grid.pitch_m or 0.0
        self._ready = self._grid.ready
        self._held = 0
        self._serialized = conversions.SerializedMessages(self._frame_id)
        self._pubs['frame'] = self.create_lifecycle_publisher(SkinFrame, 'frame', qos.stream(),
                                                              **qos.overridable())
        if self._p('publish_images'):
            for layer in ('top', 'bottom'):
                self._pubs[layer] = self.create_lifecycle_publisher(
                    Image, f'{layer}/image_raw', qos.stream(), **qos.overridable())
            self._images = LatestOnly(self._publish_images, 'skin-images', self._images_failed)
        self._listened = Listened(self._pubs)
        self._board_pub = self.create_publisher(String, 'board_info', qos.latched())
        self._board_said = None  # the BoardInfo last published
        decoder = FrameDecoder(expected_shape=self._grid.shape)
        self._link = SerialLink(
            self._port(), self._p('baud'), decoder, self._publish_frames, self._on_link_state,
            read_timeout_s=self._p('read_timeout'), stall_timeout_s=self._p('stall_timeout'),
            backoff_min_s=self._p('reconnect_min'), backoff_max_s=self._p('reconnect_max'),
            priority=self._p('realtime_priority'), cpu=StageCpu(READER_STAGES),
            on_board_info=self._on_board_info)
        # The reader raises its counts, the report reads them: neither resets the other's.
        self._rate = diagnostics.RateMeter(time.monotonic())
        self._burst = diagnostics.PeriodMax()
        self._cpu_reading = diagnostics.TakenByOwner(self._link.cpu.take,
                                                     dict.fromkeys(READER_STAGES, 0.0))
        if self.estimation is not None and self._ready:
            # Fused: the estimator is checked for this skin before the reader hands it a scan.
            self.estimation.prepare(self._grid.rows, self._grid.cols, self._pitch)
        # A set pitch the board contradicts is the grid's refusal, not the link's warning.
        self._health = LinkHealth(self._grid.shape)
        self.destroy_timer(self._diag_timer)
        self._diag_timer = self.create_timer(self._p('diagnostics_period'), self._report)
        self._lifecycle = 'inactive'
        self.get_logger().info(f'configured for {self._port()} ({self._grid_text()})')
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        """Open the port (retrying in the background until the device is there)."""
        if self._grid.refusal:
            self.get_logger().error(f'not activated: {self._grid.refusal}; cleanup, set the '
                                    'parameter, configure')
            return TransitionCallbackReturn.FAILURE
        result = super().on_activate(state)
        self._lifecycle = 'active'
        self._link.start()
        scheduling = self._link.scheduling
        if scheduling.warning:
            self.get_logger().warning(f'serial reader: {scheduling.warning}')
        else:
            self.get_logger().info(f'serial reader at {scheduling.policy}')
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        """Stop reading and close the port."""
        self._lifecycle = 'inactive'
        self._link.stop()
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        """Release everything configure created."""
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        """Stop reading, release everything, and end the process once the transition is done."""
        self.close()
        # A finalized driver can do nothing more: its process ends, so that a launch file (or a
        # supervisor) sees it go, as after Ctrl-C. The context shuts down only after this
        # callback's answer to the change_state request has gone out.
        self.get_logger().info('shut down on request: the process ends')
        self._end = self.create_timer(SHUTDOWN_GRACE_S, self._end_process)
        return TransitionCallbackReturn.SUCCESS

    def _end_process(self) -> None:
        self.destroy_timer(self._end)
        rclpy.try_shutdown(context=self.context)

    def destroy_node(self):
        """Stop reading, release everything, then destroy the node and its state machine."""
        self.close()
        result = super().destroy_node()
        destroy_state_machine(self)
        return result

    def close(self) -> None:
        """Stop reading and release the port and diagnostics; safe to call in any state."""
        self._release()
        if self._diag_timer is not None:
            self.destroy_timer(self._diag_timer)
            self._diag_timer = None
        if self._diag is not None:
            self._diag.destroy()
            self._diag = None

    def _release(self) -> None:
        self._lifecycle = 'unconfigured'
        self._grid = None
        self._ready = False
        if self._link is not None:
            self._link.stop()
            self._link = None
        if self._images is not None:
            self._images.stop()
            self._images = None
        for pub in self._pubs.values():
            self.destroy_lifecycle_publisher(pub)
        self._pubs = {}
        if self._board_pub is not None:
            self.destroy_publisher(self._board_pub)
            self._board_pub = None

    # ---- data path (runs on the link's thread) ---------------------------------------------
    def _publish_frames(self, frames, receive_monotonic: float) -> None:
        header = conversions.make_header(self._now(), self._frame_id)
        listened = self._listened(receive_monotonic)
        cpu = self._link.cpu
        for frame in frames if self._ready else self._usable(frames):
            if self.estimation is not None:
                # What skin_info says of the link; a plain attribute, read by the report timer.
                self.estimation.protocol_version = frame.version
                # Contacts first: they are what a controller waits for.
                self.estimation.process(header, frame.seq, frame.device_time_us, self._pitch,
                                        frame.top, frame.bottom)
                cpu.mark('estimation')
            # Nobody listening (fused, nothing recording): no message to build and serialise.
            if listened['frame']:
                self._pubs['frame'].publish(self._frame_message(header, frame))
                cpu.mark('frame')
        if self._images is not None and self._ready and (listened['top'] or listened['bottom']):
            self._images.offer((header, frames[-1], listened))
            cpu.mark('images')
        self._rate.add(len(frames))
        self._burst.see(len(frames))
        self._cpu_reading.serve()

    def _usable(self, frames) -> list:
        """Return the frames to use while the grid is not ready (reader thread): none, or all."""
        grid = self._grid
        if not grid.refusal and grid.see_frame(*frames[0].top.shape):
            self._refuse()
        if grid.ready:
            self._adopt()
            return frames
        self._held += len(frames)
        return []

    def _adopt(self) -> None:
        """Read scans from now on at the grid and pitch now known (reader thread)."""
        self._pitch = self._grid.pitch_m
        self._ready = True
        self.get_logger().info(f'scans read as {self._grid_text()}')

    def _refuse(self) -> None:
        """Stop using scans: the board contradicts a parameter (reader thread)."""
        self._ready = False
        self.get_logger().error(f'scans not used: {self._grid.refusal}; the driver deactivates')
        self._refused.trigger()
        self._report()

    def _deactivate_refused(self) -> None:
        if self._lifecycle == 'active' and self._grid is not None and self._grid.refusal:
            self.trigger_deactivate()

    def _grid_text(self) -> str:
        grid = self._grid
        rows, cols = grid.rows or '?', grid.cols or '?'
        pitch = f'{1000 * grid.pitch_m:.3f} mm' if grid.pitch_m else "the board's"
        source = ', '.join(name for name in ('rows', 'cols', 'pitch') if grid.set[name])
        said = f'set: {source}' if source else "all the board's word"
        return f'{rows}x{cols} taxels at {pitch} pitch; {said}'

    def _frame_message(self, header, frame):
        """Return a scan's SkinFrame as CDR bytes, or as a message where those are not rmw's."""
        serialized = self._serialized
        if serialized.usable:
            return serialized.frame(header.stamp.sec, header.stamp.nanosec, frame.seq,
                                    frame.device_time_us, self._pitch, frame.top, frame.bottom)
        return conversions.skin_frame_to_msg(header, frame.seq, frame.device_time_us,
                                             self._pitch, frame.top, frame.bottom)

    def _now(self) -> Time:
        """Return the node's time now: the system clock's, read directly, unless sim time."""
        if self._system_time:
            sec, nanosec = divmod(time.time_ns(), 1_000_000_000)
            return Time(sec=sec, nanosec=nanosec)
        return self.get_clock().now().to_msg()

    def _publish_images(self, item) -> None:
        header, frame, listened = item
        for layer, counts in (('top', frame.top), ('bottom', frame.bottom)):
            if listened[layer]:
                self._pubs[layer].publish(conversions.counts_to_image(header, counts))

    def _images_failed(self, err: Exception) -> None:
        self.get_logger().warning(f'raw image not published: {err}', throttle_duration_sec=5.0)

    def _on_board_info(self, info) -> None:
        """Pass on who the board is, its health and its grid (link thread, once per new text)."""
        if self._board_said is None or info.identity != self._board_said.identity:
            self.get_logger().info(f'the board says it is {info.describe()}')
        self._board_said = info
        self._board_pub.publish(String(data=info.text))
        grid = self._grid
        refused = grid.refusal
        if grid.hear_board(info) and not refused:
            self._refuse()
        elif not self._ready and grid.ready:
            self._adopt()

    def _on_link_state(self, state: str, detail: str) -> None:
        self._state_detail = detail
        if state == STOPPED:
            return
        if state == DISCONNECTED and self._shutting_down.wait(SHUTDOWN_GRACE_S):
            return
        self._report()
        # rclpy fixes a call site's severity at its first call: one call site per severity.
        if state == CONNECTED:
            self.get_logger().info(f'skin link {state}: {detail}')
        else:
            self.get_logger().warning(f'skin link {state}: {detail}')

    # ---- diagnostics ------------------------------------------------------------------------
    def _report(self) -> None:
        # The timer and the link's thread (on a change of state) both report.
        with self._report_lock:
            if self._diag is None or self._shutting_down.is_set():
                return
            if self._lifecycle == 'active':
                self._report_link()
            elif self._grid is not None and self._grid.refusal:
                self._diag.publish([diagnostics.make_status(
                    f'{self.get_fully_qualified_name()}: skin link', self._port(),
                    diagnostics.ERROR, f'{self._lifecycle}: {self._grid.refusal}',
                    {'port': self._port(), 'lifecycle state': self._lifecycle,
                     **self._grid_values()})])
            else:
                self._diag.publish([diagnostics.make_status(
                    f'{self.get_fully_qualified_name()}: skin link', self._port(),
                    diagnostics.OK, f'{self._lifecycle}: not reading, as requested',
                    {'port': self._port(), 'lifecycle state': self._lifecycle})])

    def _report_link(self) -> None:
        rate, _ = self._rate.take(time.monotonic())
        burst = int(self._burst.take())
        health = self._health.assess(self._link, self._state_detail)
        cpu = {f'reader CPU per scan, {stage} [us]': round(us, 1)
               for stage, us in self._cpu_reading.ask().items()}
        values = {'port': self._port(), 'frame rate [Hz]': rate,
                  'largest burst [frames]': burst,
                  'reader scheduling': self._link.scheduling.policy,
                  **cpu, **health.values, **self._grid_values()}
        level, message = health.level, health.message
        problem = self._grid.refusal or self._grid.waiting_for()
        if problem:
            level = max(level, ERROR if self._grid.refusal else WARN)
            message = f'{message}; {problem}'
        self._diag.publish([diagnostics.make_status(
            f'{self.get_fully_qualified_name()}: skin link', self._port(), level,
            message, values)])

    def _grid_values(self) -> dict:
        return {'grid': self._grid_text(), "scans held for the board's word": self._held}


def _backoff_problem(low, high) -> str:
    """Return why a reconnect back-off range is unusable, or '' if it is fine."""
    if isinstance(low, (int, float)) and isinstance(high, (int, float)) and low > high:
        return f"'reconnect_min' ({low}) must not exceed 'reconnect_max' ({high})"
    return ''


def fuse(driver: SkinDriverNode, **direction_kwargs) -> DirectionNode:
    """Create the skin_direction node that estimates on the driver's reader thread; return it."""
    direction = DirectionNode(subscribe=False, **direction_kwargs)
    driver.estimation = direction.host
    return direction


def main(args=None):
    """Run the driver node until shut down."""
    rclpy.init(args=args)

    def create():
        node = SkinDriverNode()
        if not node.fused:
            return node, None
        # The mount the launch gives the driver is the fused skin_direction's to publish.
        parent, xyz, rpy = declare_given_mount(node)
        given = [Parameter('parent_frame', value=parent)] + [
            Parameter(f'mount_{name}', value=v)
            for (name, _, _), v in zip(GIVEN_POSE, xyz + rpy)]
        # launch_ros names a node with a process-wide rule (-r __node:=skin_driver); a rule of
        # the node's own takes precedence and keeps this one skin_direction.
        return node, fuse(node, cli_args=['--ros-args', '-r', '__node:=skin_direction'],
                          parameter_overrides=given)
    node, direction = create_or_exit(create, 'skin_driver')

    def autostart():
        if node.autostart:
            if node.trigger_configure() != TransitionCallbackReturn.SUCCESS:
                raise SystemExit(1)
            node.trigger_activate()

    spin_nodes([node] + ([direction] if direction is not None else []), autostart)


if __name__ == '__main__':
    main()
