"""What a controller relies on: the net wrench, QoS it can connect to, parameters, ~/tare."""

import math

from geometry_msgs.msg import WrenchStamped
from pipeline import call, pipeline, scene
import pytest
from rcl_interfaces.srv import SetParameters
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from rosutil import ros_context, spin_until, wait_for_server
from skin_driver.ros import qos
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.tools.harness import spawn, stop
from skin_msgs.msg import TactileContactArray
from std_srvs.srv import Trigger

pytestmark = pytest.mark.ros

# Held for the whole test: the board plays from its start, and on a busy machine the nodes and
# the subscriptions may come up seconds later (a 3 s pinch was over by then).
PINCH = [{'time_s': 0.2, 'x_m': 0.025, 'y_m': 0.0375, 'force_n': 10.0, 'alpha_deg': 40.0,
          'beta_deg': 0.0, 'duration_s': 1000.0},
         {'time_s': 0.2, 'x_m': 0.050, 'y_m': 0.0375, 'force_n': 10.0, 'alpha_deg': 40.0,
          'beta_deg': 180.0, 'duration_s': 1000.0}]


# Every scan's contacts and wrench, none lost: the driver stamps the frames of one read alike,
# so within a stamp only the order pairs a wrench with its contacts, and a best-effort drop on
# a busy machine shifted that order (a wrench checked against the next scan's contacts).
EVERY_ONE = {f'qos_overrides./{topic}.publisher.{policy}': value
             for topic in ('contacts', 'wrench')
             for policy, value in (('reliability', 'reliable'), ('depth', 1000))}


def test_a_pinch_gives_the_net_wrench_about_zero_tangential_force_not_one_finger(tmp_path):
    by_stamp = {}
    with pipeline(tmp_path, scene(PINCH), direction=EVERY_ONE) as (
            _, _, direction, probe, executor):
        node = probe.node

        def keep(kind):
            def on_message(msg):
                stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
                by_stamp.setdefault(stamp, {'contacts': [], 'wrench': []})[kind].append(msg)
            return on_message
        every = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(TactileContactArray, 'contacts', keep('contacts'), every)
        node.create_subscription(WrenchStamped, 'wrench', keep('wrench'), every)

        def pinched():
            # At full load (7.7 N normal each), not on the ramps. A stamp whose messages are
            # not all here yet (or came before a subscription did) is left out.
            pairs = [(c.contacts, w.wrench) for s in list(by_stamp.values())
                     if len(s['contacts']) == len(s['wrench'])
                     for c, w in zip(s['contacts'], s['wrench'])]
            return [(contacts, wrench) for contacts, wrench in pairs if len(contacts) == 2
                    and all(c.direction_valid and -c.wrench.force.z > 6.0 for c in contacts)]
        assert spin_until(executor, lambda: len(pinched()) >= 20, 60.0)
    for contacts, wrench in pinched():
        strongest = math.hypot(contacts[0].wrench.force.x, contacts[0].wrench.force.y)
        # Each finger pushes sideways with ~6 N; the skin carries about none of it net.
        assert strongest > 3.0
        assert abs(wrench.force.x) < 0.3 * strongest
        # The normal forces add: the wrench is the sum of both contacts, torque included.
        for axis in ('x', 'y', 'z'):
            assert getattr(wrench.force, axis) == pytest.approx(
                sum(getattr(c.wrench.force, axis) for c in contacts), abs=1e-9)
            assert getattr(wrench.torque, axis) == pytest.approx(
                sum(getattr(c.wrench.torque, axis) for c in contacts), abs=1e-9)


def test_the_wrench_is_zero_when_nothing_touches(tmp_path):
    wrenches = []
    with pipeline(tmp_path, scene([])) as (_, _, _, probe, executor):
        probe.node.create_subscription(WrenchStamped, 'wrench', wrenches.append,
                                       qos_profile_sensor_data)
        assert spin_until(executor, lambda: len(wrenches) >= 10)
    assert all((w.wrench.force.x, w.wrench.force.y, w.wrench.force.z, w.wrench.torque.x,
                w.wrench.torque.y, w.wrench.torque.z) == (0.0,) * 6 for w in wrenches)


def test_a_reliable_subscriber_gets_the_wrench_once_the_publisher_is_overridden(tmp_path):
    # As a controller subscribes by default: reliable, keep last 10.
    override = {'qos_overrides./wrench.publisher.reliability': 'reliable'}
    wrenches = []
    with pipeline(tmp_path, scene([]), direction=override) as (
            _, _, direction, probe, executor):
        probe.node.create_subscription(WrenchStamped, '/wrench', wrenches.append, 10)
        assert spin_until(executor, lambda: len(wrenches) >= 5)
        # The other streams keep the sensor-data profile, those made after the wrench too.
        best_effort = [ReliabilityPolicy.BEST_EFFORT]
        for topic in ('/contacts', '/frame'):
            info = direction.get_publishers_info_by_topic(topic)
            assert [i.qos_profile.reliability for i in info] == best_effort, topic
        info = [i for i in direction.get_subscriptions_info_by_topic('/frame')
                if i.node_name == 'skin_direction']
        assert [i.qos_profile.reliability for i in info] == best_effort


def _set_through_the_service(executor, node, target, name, value):
    """Set one parameter as `ros2 param set` does: through the node's service."""
    client = node.create_client(SetParameters, f'{target}/set_parameters')
    wait_for_server(executor, client)
    future = client.call_async(SetParameters.Request(
        parameters=[Parameter(name, value=value).to_parameter_msg()]))
    assert spin_until(executor, future.done)
    return future.result().results[0]


def test_double_parameters_take_whole_numbers_at_start_up_in_yaml_and_when_set(tmp_path):
    params = tmp_path / 'params.yaml'
    params.write_text('/**/skin_direction:\n  ros__parameters:\n    compliance: 1\n'
                      '    viz_full_scale: 20\n')
    context = rclpy.Context()
    rclpy.init(context=context, args=['--ros-args', '--params-file', str(params)])
    executor = SingleThreadedExecutor(context=context)
    try:
        direction = DirectionNode(context=context, parameter_overrides=[
            Parameter('threshold', value=40), Parameter('calibration.timeout', value=30),
            Parameter('calibration_file', value=str(tmp_path / 'cal.yaml'))])
        helper = rclpy.create_node('helper', context=context)
        for node in (direction, helper):
            executor.add_node(node)
        assert direction.get_parameter('threshold').value == 40.0
        assert direction.get_parameter('calibration.timeout').value == 30.0
        assert direction.get_parameter('compliance').value == 1.0
        assert direction.get_parameter('viz_full_scale').value == 20.0
        result = _set_through_the_service(executor, helper, '/skin_direction', 'threshold', 60)
        assert result.successful, result.reason
        assert direction.get_parameter('threshold').type_ == Parameter.Type.DOUBLE
        assert direction.get_parameter('threshold').value == 60.0
        # Ranges still hold for the number given as an integer.
        result = _set_through_the_service(executor, helper, '/skin_direction', 'threshold', 5000)
        assert not result.successful
        # An integer parameter stays an integer; a string is still refused.
        assert _set_through_the_service(executor, helper, '/skin_direction', 'tare.frames',
                                        30).successful
        assert direction.get_parameter('tare.frames').value == 30
        assert not _set_through_the_service(executor, helper, '/skin_direction', 'threshold',
                                            'sixty').successful
        direction.destroy_node()
        helper.destroy_node()
    finally:
        executor.shutdown()
        rclpy.try_shutdown(context=context)


def test_the_driver_takes_a_whole_number_of_seconds_and_metres(tmp_path):
    with ros_context() as (context, _):
        driver = SkinDriverNode(context=context, parameter_overrides=[
            Parameter('stall_timeout', value=2), Parameter('reconnect_max', value=1)])
        assert driver.get_parameter('stall_timeout').value == 2.0
        assert driver.set_parameters([Parameter('diagnostics_period', value=3)])[0].successful
        assert driver.get_parameter('diagnostics_period').value == 3.0
        driver.close()
        driver.destroy_node()


@pytest.mark.parametrize('fused', [False, True], ids=['split', 'fused'])
def test_tare_refuses_while_no_scans_arrive_and_never_uses_stale_ones(tmp_path, fused):
    with pipeline(tmp_path, scene([]), fused=fused) as (_, driver, direction, probe, executor):
        assert spin_until(executor, lambda: len(probe.frames) >= 30)
        driver.trigger_deactivate()
        # Wait until the scans of before the deactivation are old (a second, STALE_AFTER_S).
        spin_until(executor, lambda: False, 1.5)
        stale = call(executor, direction, Trigger, '/skin_direction/tare', Trigger.Request())
        assert not stale.success
        assert 'no scan is arriving' in stale.message and 'driver active' in stale.message
        driver.trigger_activate()
        count = len(probe.frames)
        assert spin_until(executor, lambda: len(probe.frames) >= count + 30)
        fresh = call(executor, direction, Trigger, '/skin_direction/tare', Trigger.Request())
        assert fresh.success, fresh.message


@pytest.mark.parametrize('module, node', [('skin_driver.ros.direction_node', 'skin_direction'),
                                          ('skin_driver.ros.driver_node', 'skin_driver')])
def test_a_fatal_start_up_error_is_logged_by_the_node_in_its_namespace(tmp_path, module, node):
    bad = 'method:=bogus' if node == 'skin_direction' else 'rows:=300'
    with open(tmp_path / 'out.log', 'w') as log:
        proc = spawn(['-m', module, '--ros-args', '-r', '__ns:=/left', '-p', bad], log)
        try:
            proc.wait(60)
        finally:
            stop([proc])
    out = (tmp_path / 'out.log').read_text()
    assert proc.returncode == 1, out
    line = next(line for line in out.splitlines() if 'FATAL' in line)
    assert f'[left.{node}]' in line and ('bogus' in line or '300' in line)


def test_each_stream_gets_its_own_copy_of_the_sensor_data_profile():
    # rclpy writes a topic's overrides into the profile it is given: never the shared one.
    assert qos.stream() == qos_profile_sensor_data and qos.stream() is not qos.stream()
