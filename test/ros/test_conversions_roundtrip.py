"""Every skin_msgs message survives a publish/subscribe round trip; Calibrate answers a goal."""

import math

from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Point, Vector3, Wrench
import numpy as np
from pipeline import send_goal
import pytest
import rclpy
from rclpy.action import ActionServer
from rclpy.qos import qos_profile_sensor_data
from rosutil import ros_context, spin_until
from skin_driver.ros.conversions import make_header, skin_frame_layers, skin_frame_to_msg
from skin_msgs.action import Calibrate
from skin_msgs.msg import SkinFrame, TactileContact, TactileContactArray

pytestmark = pytest.mark.ros


def _contact(header):
    return TactileContact(
        header=header, location=Point(x=0.035, y=0.04, z=0.0), magnitude=9.5 * math.sqrt(2.0),
        normal_force=9.5,
        azimuth=math.radians(135.0), polar=math.radians(45.0), shift=Vector3(x=-0.003, y=0.003),
        wrench=Wrench(force=Vector3(x=-4.7, y=4.7, z=-9.5)), area=4.0e-5, confidence=0.875,
        direction_valid=True)


def _frame(header):
    rng = np.random.default_rng(3)
    top = rng.integers(0, 4096, size=(16, 16), dtype=np.uint16)
    # A pitch that float32 holds exactly, so the round trip can be compared with ==.
    return skin_frame_to_msg(header, 4_000_000_001, 2**40 + 7, 0.00390625, top, top[::-1, ::-1])


@pytest.mark.parametrize('msg_type,make', [
    (SkinFrame, _frame),
    (TactileContact, _contact),
    (TactileContactArray,
     lambda h: TactileContactArray(header=h, contacts=[_contact(h), _contact(h)])),
], ids=['SkinFrame', 'TactileContact', 'TactileContactArray'])
def test_message_round_trip(msg_type, make):
    with ros_context() as (context, executor):
        node = rclpy.create_node('roundtrip', context=context)
        executor.add_node(node)
        received = []
        node.create_subscription(msg_type, 'probe', received.append, qos_profile_sensor_data)
        pub = node.create_publisher(msg_type, 'probe', qos_profile_sensor_data)
        sent = make(make_header(node.get_clock().now().to_msg(), 'skin_link'))

        def delivered():
            if not received:
                pub.publish(sent)
            return bool(received)

        assert spin_until(executor, delivered)
        assert received[0] == sent
        if msg_type is SkinFrame:
            top, bottom = skin_frame_layers(received[0])
            assert top.shape == (16, 16) and np.array_equal(bottom, top[::-1, ::-1])


def test_calibrate_action_round_trip():
    with ros_context() as (context, executor):
        node = rclpy.create_node('calibrate_probe', context=context)
        executor.add_node(node)

        def execute(goal_handle):
            goal = goal_handle.request
            goal_handle.publish_feedback(Calibrate.Feedback(
                presses_done=1, presses_wanted=goal.presses, last_force=9.5,
                last_shift_x=1e-4, last_shift_y=-2e-4, note='press 1/3 recorded'))
            goal_handle.succeed()
            return Calibrate.Result(
                success=goal.presses == 3, presses_used=goal.presses,
                message=f'recorded {goal.presses} presses in {goal.timeout:.1f} s',
                x_p=1e-4, y_p=-2e-4, std_x=1e-5, std_y=2e-5)

        server = ActionServer(node, Calibrate, 'calibrate', execute)
        feedback = []
        status, result = send_goal(executor, node, Calibrate, 'calibrate',
                                   Calibrate.Goal(presses=3, timeout=7.5),
                                   feedback=feedback.append)
        assert status == GoalStatus.STATUS_SUCCEEDED
        assert result.success and result.presses_used == 3
        assert result.message == 'recorded 3 presses in 7.5 s'
        assert (result.x_p, result.y_p) == (1e-4, -2e-4)
        assert [(f.presses_done, f.presses_wanted, f.note) for f in feedback] == [
            (1, 3, 'press 1/3 recorded')]
        server.destroy()
        node.destroy_node()
