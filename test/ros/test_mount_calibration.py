"""The mount action on the direction node: touches in, the pose out, in the file; refusals."""

import math

from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Point, PointStamped
import numpy as np
from pipeline import pipeline, scene, send_goal
import pytest
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_msgs.action import CalibrateMount
from std_msgs.msg import Header

pytestmark = pytest.mark.ros

ACTION = '/skin_direction/calibrate_mount'
TOUCHES_M = [(0.0075, 0.0075), (0.0675, 0.0080), (0.0070, 0.0675), (0.0680, 0.0670),
             (0.0375, 0.0210), (0.0360, 0.0550)]
# The skin on its link: turned 30 degrees about z, tilted 20 about x, 0.2 m out.
RPY = (math.radians(20.0), 0.0, math.radians(30.0))
XYZ = (0.2, -0.1, 0.05)


def rotation(roll, pitch, yaw):
    """Return Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
            @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
            @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))


def points(touches):
    r = rotation(*RPY)
    return [Point(x=float(q[0]), y=float(q[1]), z=float(q[2]))
            for q in (r @ np.array([x, y, 0.0]) + np.array(XYZ) for x, y in touches)]


def touches_scene(touches):
    return scene([{'time_s': 1.5 + 1.5 * i, 'x_m': x, 'y_m': y, 'force_n': 12.0}
                  for i, (x, y) in enumerate(touches)])


def test_six_touches_give_the_mount_in_the_result_and_the_calibration_file(tmp_path):
    feedback = []
    with pipeline(tmp_path, touches_scene(TOUCHES_M), rate_hz=100.0) as (
            _, _, direction, _, executor):
        status, result = send_goal(
            executor, direction, CalibrateMount, ACTION,
            CalibrateMount.Goal(points=points(TOUCHES_M), timeout=30.0), timeout_s=40.0,
            feedback=feedback.append)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
    assert result.touches_used == 6 and len(result.residuals) == 6
    assert max(result.residuals) < 0.002
    p = result.pose.position
    assert np.linalg.norm(np.subtract((p.x, p.y, p.z), XYZ)) < 0.001
    q = result.pose.orientation
    expected = rotation(*RPY)
    # The rotation's x axis, from the quaternion, against the truth's.
    x_axis = (1 - 2 * (q.y * q.y + q.z * q.z), 2 * (q.x * q.y + q.z * q.w),
              2 * (q.x * q.z - q.y * q.w))
    assert math.degrees(math.acos(min(1.0, float(np.dot(x_axis, expected[:, 0]))))) < 1.0
    assert result.parent_frame == 'base_link' and 'xacro:skin_patch' in result.urdf
    assert [f.touches_done for f in feedback] == [1, 2, 3, 4, 5, 6]
    stored = Calibration.load_yaml(tmp_path / 'calibration.yaml')
    assert stored.mount.parent_frame == 'base_link' and stored.mount.touches == 6
    # Stamped like every part (issue #47: the file's made map had no mount).
    assert stored.made('mount') == stored.mount.made_utc != ''
    assert np.allclose(stored.mount.xyz_m, (p.x, p.y, p.z))


def test_collinear_touches_are_refused_and_change_nothing(tmp_path):
    line = [(0.01 + 0.01 * i, 0.02 + 0.005 * i) for i in range(4)]
    with pipeline(tmp_path, touches_scene(line), rate_hz=100.0) as (
            _, _, direction, _, executor):
        status, result = send_goal(
            executor, direction, CalibrateMount, ACTION,
            CalibrateMount.Goal(points=points(line), timeout=30.0), timeout_s=40.0)
    assert status == GoalStatus.STATUS_ABORTED and not result.success
    assert 'lie on a line' in result.message and 'nothing changed' in result.message
    assert not (tmp_path / 'calibration.yaml').exists() or \
        Calibration.load_yaml(tmp_path / 'calibration.yaml').mount is None


def test_a_goal_without_points_or_tool_topic_is_refused_at_once(tmp_path):
    with pipeline(tmp_path, scene([]), rate_hz=100.0) as (_, _, direction, _, executor):
        status, result = send_goal(executor, direction, CalibrateMount, ACTION,
                                   CalibrateMount.Goal(touches=6), timeout_s=10.0)
    assert status == GoalStatus.STATUS_ABORTED
    assert 'mount.tool_topic' in result.message


def test_the_tool_tip_topic_gives_each_touch_its_point(tmp_path):
    """A robot that publishes where its tool tip is, instead of points in the goal."""
    parent = points(TOUCHES_M)
    with pipeline(tmp_path, touches_scene(TOUCHES_M), rate_hz=100.0,
                  direction={'mount.tool_topic': '/tool_tip'}) as (
            _, _, direction, probe, executor):
        tip = probe.node.create_publisher(PointStamped, '/tool_tip', 10)

        def publish_tip():
            # The robot knows which point it is touching: the touch under the newest contact.
            if not probe.contacts or not probe.contacts[-1].contacts:
                return
            where = probe.contacts[-1].contacts[0].location
            k = min(range(len(TOUCHES_M)), key=lambda i: math.hypot(
                TOUCHES_M[i][0] - where.x, TOUCHES_M[i][1] - where.y))
            tip.publish(PointStamped(header=Header(frame_id='base_link'), point=parent[k]))
        probe.node.create_timer(0.01, publish_tip)
        status, result = send_goal(
            executor, direction, CalibrateMount, ACTION,
            CalibrateMount.Goal(touches=6, timeout=30.0), timeout_s=40.0)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
    p = result.pose.position
    assert np.linalg.norm(np.subtract((p.x, p.y, p.z), XYZ)) < 0.001
