"""
The mount action: the skin's pose on its parent link from touches, the ROS side of core mount.py.

``MountCalibration(node, frame_id, put_mount)`` declares the ``mount.*`` parameters and offers
``~/calibrate_mount`` (skin_msgs/action/CalibrateMount). A robot or a probe touches the skin at
points known in ``mount.parent_frame``, given in the goal or read per touch from the tool tip
topic ``mount.tool_topic`` (geometry_msgs/PointStamped or PoseStamped, in the parent frame:
tf2_ros has no wheel, so no transform is looked up). The node calls :meth:`feed` with every
scan's contacts. On success the pose is handed to ``put_mount`` (which stores it with the
calibration and puts it in force) and returned with its residuals and a xacro line. A refused,
failed or cancelled calibration changes nothing; each is logged, as is a rejected goal.

The mount in force goes on /tf_static (latched) whenever it changes, and at every start
(:meth:`show`): the calibration file's, or, when the file has none, the one the parameters
``parent_frame`` and ``mount_x`` .. ``mount_yaw`` give (the launch arguments of the same names;
a change at run time is shown at once). Which wins when both are there is core robot/mount.py's
rule, warned once.
"""

import math
import threading
import time

from geometry_msgs.msg import Point, PointStamped, Pose, PoseStamped, Quaternion
from rclpy.action import CancelResponse, GoalResponse
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from skin_driver.core.estimation.calibration.mount import (MAX_RESIDUAL_M, MountRefused,
                                                           MountSession, urdf_snippet)
from skin_driver.core.robot.mount import mount_in_force
from skin_driver.ros import conversions, qos
from skin_driver.ros.calibration_services import goal_outcome
from skin_driver.ros.lifetime import ActionOwner
from skin_driver.ros.params import declare
from skin_msgs.action import CalibrateMount

DEFAULT_TOUCHES = 6
MAX_TOUCHES = 100
NOTHING = '; nothing changed'
# A tool tip position older than this when a scan arrives is not that scan's.
MAX_TIP_AGE_S = 0.5
GIVEN_POSE = (('x', 'x in metres', 100.0), ('y', 'y in metres', 100.0),
              ('z', 'z in metres', 100.0), ('roll', 'roll about x in radians', 2 * math.pi),
              ('pitch', 'pitch about y in radians', 2 * math.pi),
              ('yaw', 'yaw about z in radians', 2 * math.pi))


def declare_given_mount(node) -> tuple:
    """Declare the mount given by parameters on ``node``; return (parent, xyz, rpy)."""
    parent = declare(node, 'parent_frame', '',
                     "Link the skin is mounted on, with the pose mount_x .. mount_yaw; '': none. "
                     'A mount from ~/calibrate_mount in the calibration file wins (warned).')
    pose = [declare(node, f'mount_{name}', 0.0, f'Mount pose on parent_frame: {what}.',
                    low=-limit, high=limit) for name, what, limit in GIVEN_POSE]
    return parent, tuple(pose[:3]), tuple(pose[3:])


def given_mount(node) -> tuple:
    """Return (parent, xyz, rpy) of the mount the parameters give now."""
    pose = tuple(node.get_parameter(f'mount_{name}').value for name, _, _ in GIVEN_POSE)
    return node.get_parameter('parent_frame').value, pose[:3], pose[3:]


class _Running:
    """One running calibration: read whole by the scan thread, set whole by the executor."""

    def __init__(self, session: MountSession, goal, tip_wanted: bool):
        self.session = session
        self.goal = goal
        self.tip_wanted = tip_wanted


class MountCalibration(ActionOwner):
    """Offer ~/calibrate_mount on ``node`` for the skin whose frame is ``frame_id()``."""

    def __init__(self, node, frame_id, skin_shape, put_mount, file_problem=lambda: ''):
        """
        Declare the parameters, create the action; skin_shape() is (rows, cols, pitch).

        file_problem() says why nothing may be written (a refused file): the goal then ends at
        once, before any touch is awaited.
        """
        self._node = node
        self._file_problem = file_problem
        self._frame_id = frame_id
        self._skin_shape = skin_shape
        self._put_mount = put_mount
        self._running = None
        self._busy = threading.Lock()
        self._tip = None
        self._tip_sub = None
        self._tf_pub = None
        self._given = declare_given_mount(node)
        self._showing = threading.Lock()
        self._shown = None  # (mount, child frame) last put on /tf_static
        self._warned = ''
        self._last = None  # (calibration, where) last shown: shown again when the given changes
        self.in_force = None  # the core robot.mount.Mount in force, None: none
        node.add_post_set_parameters_callback(self._on_parameters)
        declare(node, 'mount.parent_frame', 'base_link',
                'Link the skin is mounted on: ~/calibrate_mount gives its pose there.',
                non_empty=True)
        declare(node, 'mount.tool_topic', '',
                'geometry_msgs/PointStamped or PoseStamped topic of the tool tip in the parent '
                'frame, read per touch by ~/calibrate_mount when its goal gives no points.')
        declare(node, 'mount.max_residual', MAX_RESIDUAL_M,
                'Largest miss of a touch (metres) that ~/calibrate_mount accepts.',
                low=1.0e-5, high=0.1)
        self.serve(node, CalibrateMount, '~/calibrate_mount', self._execute, self._on_goal,
                   self._on_cancel)

    # ---- per scan ----------------------------------------------------------------------------
    def feed(self, contacts) -> None:
        """Give the running calibration, if any, one scan's contacts (strongest first)."""
        running = self._running
        if running is None:
            return
        tip = None
        if running.tip_wanted and self._tip is not None:
            point, stamp = self._tip
            tip = point if time.monotonic() - stamp <= MAX_TIP_AGE_S else None
        note = running.session.add_scan(contacts, tip)
        if note:
            self._node.get_logger().info(f'mount calibration: {note}')
            running.goal.publish_feedback(CalibrateMount.Feedback(
                touches_done=len(running.session.skin_xy_m),
                touches_wanted=running.session.wanted, note=note))

    def _on_tip(self, msg) -> None:
        position = msg.pose.position if isinstance(msg, PoseStamped) else msg.point
        if msg.header.frame_id and msg.header.frame_id != self._param('mount.parent_frame'):
            self._tip = None
            return
        self._tip = ((position.x, position.y, position.z), time.monotonic())

    # ---- action ------------------------------------------------------------------------------
    def _param(self, name: str):
        return self._node.get_parameter(name).value

    def _on_goal(self, request) -> GoalResponse:
        if not self._busy.acquire(blocking=False):
            self._node.get_logger().warning(
                'mount calibration goal rejected: one is already running; wait for it to end or '
                'cancel it')
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle) -> CancelResponse:
        self._node.get_logger().info('mount calibration: cancel requested')
        return CancelResponse.ACCEPT

    def _problem(self, goal) -> str:
        """Return why the goal cannot be served, or ''."""
        points = [(p.x, p.y, p.z) for p in goal.points]
        if not all(math.isfinite(v) for p in points for v in p):
            return 'a point holds a value that is not finite'
        if len(points) > MAX_TOUCHES or goal.touches > MAX_TOUCHES:
            return f'more than {MAX_TOUCHES} touches asked for'
        if not (math.isfinite(goal.timeout) and goal.timeout >= 0.0):
            return f'timeout {goal.timeout} s is not a number of seconds >= 0'
        if not points and not self._param('mount.tool_topic'):
            return ('no points in the goal and no mount.tool_topic to read the tool tip from; '
                    'give the touch points, or name the tool tip topic')
        return self._file_problem()

    async def _execute(self, goal_handle):
        try:
            return await self._run(goal_handle)
        finally:
            self._running = None
            self._busy.release()

    async def _run(self, goal_handle):
        goal, result = goal_handle.request, CalibrateMount.Result()
        result.parent_frame = self._param('mount.parent_frame')
        result.pose = Pose(orientation=Quaternion(w=1.0))
        logger = self._node.get_logger()
        points = [(p.x, p.y, p.z) for p in goal.points]
        try:
            problem = self._problem(goal)
            if problem:
                raise MountRefused(problem)
            touches = len(points) or goal.touches or DEFAULT_TOUCHES
            session = MountSession(touches, points, self._param('mount.max_residual'))
        except MountRefused as err:
            return self._end(goal_handle, result, f'refused: {err}{NOTHING}', goal_handle.abort)
        if not points:
            self._follow_tip()
        timeout = goal.timeout or self._param('calibration.timeout')
        self._running = _Running(session, goal_handle, not points)
        logger.info(f'mount calibration: make {touches} touches within {timeout:.0f} s')
        try:
            outcome = await goal_outcome(self._node, goal_handle, lambda: session.done, timeout)
        finally:
            self._running = None
        made = f'{len(session.skin_xy_m)} of {touches} touches'
        if outcome == 'cancel':
            return self._end(goal_handle, result, f'cancelled with {made}{NOTHING}',
                             goal_handle.canceled)
        if outcome == 'timeout':
            return self._end(goal_handle, result,
                             f'timed out after {timeout:.0f} s with {made}{NOTHING}',
                             goal_handle.abort)
        try:
            fit = session.finish()
            rows, cols, pitch = self._skin_shape()
            urdf = urdf_snippet(fit, result.parent_frame, self._frame_id(), rows, cols, pitch)
            # Stored and put in force: :meth:`show` puts it on /tf_static.
            written = self._put_mount(result.parent_frame, fit)
        except (MountRefused, OSError, ValueError) as err:
            return self._end(goal_handle, result, f'refused: {err}{NOTHING}', goal_handle.abort)
        x, y, z = fit.translation_m
        qx, qy, qz, qw = fit.quaternion_xyzw
        result.pose = Pose(position=Point(x=x, y=y, z=z),
                           orientation=Quaternion(x=qx, y=qy, z=qz, w=qw))
        result.residuals = list(fit.residuals_m)
        result.position_sigma = fit.position_sigma_m
        result.orientation_sigma = fit.orientation_sigma_rad
        result.touches_used = len(fit.residuals_m)
        result.urdf = urdf
        result.success = True
        result.message = f'{self._frame_id()} on {result.parent_frame}: {fit.describe()}{written}'
        return self._end(goal_handle, result, result.message, goal_handle.succeed)

    def _end(self, goal_handle, result, message: str, finish):
        result.message = message
        log = self._node.get_logger()
        (log.info if result.success else log.warning)(f'mount calibration: {message}')
        finish()
        return result

    def _follow_tip(self) -> None:
        """Subscribe to the tool tip topic with the type its publishers use."""
        topic = self._node.resolve_topic_name(self._param('mount.tool_topic'))
        if self._tip_sub is not None:
            if self._tip_sub.topic_name == topic:
                return
            self._node.destroy_subscription(self._tip_sub)
        types = dict(self._node.get_topic_names_and_types()).get(topic, [])
        kind = PointStamped if 'geometry_msgs/msg/PointStamped' in types else PoseStamped
        self._tip = None
        self._tip_sub = self._node.create_subscription(kind, topic, self._on_tip, qos.stream(),
                                                       **qos.overridable())

    def show(self, calibration, where: str) -> None:
        """
        Put the mount in force on /tf_static when it or the skin's frame changed.

        ``calibration`` is the one in force, read from the file ``where``. Any thread: the
        host calls it when a calibration is put in force and when the skin's frame is known.
        """
        with self._showing:
            self._last = (calibration, where)
            mount, warning = mount_in_force(calibration.mount, *self._given, where=where)
            self.in_force = mount
            if warning and warning != self._warned:
                self._node.get_logger().warning(f'mount: {warning}')
            self._warned = warning
            shown = (mount, self._frame_id())
            if mount is None or shown == self._shown:
                return
            self._shown = shown
            if self._publish_tf(mount):
                self._node.get_logger().info(f'{shown[1]} mounted on {mount.describe()} '
                                             f'(from the {mount.source}), on /tf_static')

    def _on_parameters(self, params) -> None:
        names = {'parent_frame'} | {f'mount_{name}' for name, _, _ in GIVEN_POSE}
        if names & {p.name for p in params}:
            self._given = given_mount(self._node)
            if self._last is not None:
                self.show(*self._last)

    def _publish_tf(self, mount) -> bool:
        """Put the mount on /tf_static (latched) where tf2_msgs loads; return whether it did."""
        try:
            from tf2_msgs.msg import TFMessage
            if self._tf_pub is None:
                latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                     reliability=ReliabilityPolicy.RELIABLE)
                self._tf_pub = self._node.create_publisher(TFMessage, '/tf_static', latched)
        except Exception as err:  # noqa: B902 - ImportError, or its type support not loading
            # The mount is found and stored all the same: the result and the file carry it.
            self._node.get_logger().warning(
                f'mount: not on /tf_static (tf2_msgs: {err}); a calibrated mount is in the '
                'calibration file and skin_info')
            return False
        transform = conversions.mount_transform(self._node.get_clock().now().to_msg(),
                                                mount.parent_frame, self._frame_id(),
                                                mount.xyz_m, mount.rpy_rad)
        self._tf_pub.publish(TFMessage(transforms=[transform]))
        return True
