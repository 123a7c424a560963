"""
Bad requests and parameters get a clear refusal; the calibration file is never half-written.

Every ranged parameter of both nodes is tried out of range at start-up and at run time, the
services are called with nonsense, and a process writing calibrations is killed mid-write.
"""

import math
import os
import random
import signal
import subprocess
import sys
import textwrap
import time

from builtin_interfaces.msg import Time
import numpy as np
from pipeline import call, overrides, pipeline, scene, send_goal
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rosutil import ros_context, spin_until
from skin_driver.core.estimation.calibration import calibration as calib
from skin_driver.ros import conversions
from skin_driver.ros.conversions import status_values
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.ros.params import ParameterError
from skin_msgs.action import Calibrate
from skin_msgs.msg import SkinFrame
from std_srvs.srv import Trigger

NODES = {'driver': SkinDriverNode, 'direction': DirectionNode}
NORMAL_PRESSES = [{'time_s': 0.3 + 1.2 * i} for i in range(4)]


def ranged_parameters(node_class):
    """Return {name: (low, high, is_int)} of every parameter with a declared range."""
    with ros_context() as (context, _):
        node = node_class(context=context)
        found = {}
        names = node.list_parameters([], 0).names
        for name, descriptor in zip(names, node.describe_parameters(names)):
            for rng in descriptor.integer_range:
                found[name] = (rng.from_value, rng.to_value, True)
            for rng in descriptor.floating_point_range:
                found[name] = (rng.from_value, rng.to_value, False)
        node.destroy_node()
    return found


RANGED = [(kind, name, spec) for kind, cls in NODES.items()
          for name, spec in sorted(ranged_parameters(cls).items())]


def out_of_range(spec):
    """Return one value above and one below the range, of the parameter's type."""
    low, high, is_int = spec
    if is_int:
        return [int(high) + 1, int(low) - 1]
    return [high * 2.0 + 1.0, low - 1.0]


@pytest.mark.ros
def test_every_ranged_parameter_is_covered():
    names = {name for _, name, _ in RANGED}
    assert {'rows', 'cols', 'baud', 'stall_timeout', 'reconnect_max', 'threshold',
            'calibration.presses', 'calibration.timeout', 'tare.frames', 'viz_rate'} <= names
    assert len(RANGED) >= 20


@pytest.mark.ros
@pytest.mark.parametrize('kind, name, spec', RANGED, ids=[f'{k}:{n}' for k, n, _ in RANGED])
def test_out_of_range_at_start_up_stops_the_node_naming_the_parameter(kind, name, spec):
    with ros_context() as (context, _):
        probe = Node('probe', context=context)
        for value in out_of_range(spec):
            with pytest.raises(ParameterError, match=f"'{name}' = .* is out of range"):
                NODES[kind](context=context, parameter_overrides=overrides({name: value}))
            # Destroyed before the error left the constructor, not left to the garbage
            # collector (this context's own graph is updated at once, with no discovery).
            assert probe.get_node_names() == ['probe']
        probe.destroy_node()


@pytest.mark.ros
@pytest.mark.parametrize('kind', sorted(NODES))
def test_out_of_range_at_run_time_is_rejected_with_the_reason(kind):
    with ros_context() as (context, _):
        node = NODES[kind](context=context)
        for _, name, spec in (r for r in RANGED if r[0] == kind):
            before = node.get_parameter(name).value
            for value in out_of_range(spec):
                (result,) = node.set_parameters([Parameter(name, value=value)])
                assert not result.successful, (name, value)
                assert name in result.reason and 'range' in result.reason, result.reason
            assert node.get_parameter(name).value == before
            # The right type is required too: a string is refused.
            (result,) = node.set_parameters([Parameter(name, value='many')])
            assert not result.successful and node.get_parameter(name).value == before
        node.destroy_node()


@pytest.mark.ros
def test_driver_refuses_empty_strings_and_an_inverted_back_off_at_run_time():
    with ros_context() as (context, _):
        node = SkinDriverNode(context=context)
        # An empty port and frame_id are the defaults: this user's port and the frame of the
        # namespace.
        for name in ('port', 'frame_id'):
            (result,) = node.set_parameters([Parameter(name, value='')])
            assert result.successful
        (result,) = node.set_parameters([Parameter('reconnect_min', value=5.0)])
        assert not result.successful and 'must not exceed' in result.reason
        result = node.set_parameters_atomically([Parameter('reconnect_min', value=0.2),
                                                 Parameter('reconnect_max', value=0.1)])
        assert not result.successful and 'must not exceed' in result.reason
        (result,) = node.set_parameters([Parameter('reconnect_max', value=1.0)])
        assert result.successful
        node.destroy_node()


@pytest.mark.ros
def test_direction_refuses_an_unknown_method_at_run_time_and_applies_a_known_one():
    with ros_context() as (context, _):
        node = DirectionNode(context=context)
        try:
            (result,) = node.set_parameters([Parameter('method', value='bogus')])
            assert not result.successful and "'method' is 'bogus'" in result.reason
            (result,) = node.set_parameters([Parameter('method', value='centroid')])
            assert result.successful
            # The estimator is rebuilt off the executor thread; it is in force once that is done.
            deadline = time.monotonic() + 10.0
            while node.host.rebuilding and time.monotonic() < deadline:
                time.sleep(0.01)
            assert node.host.estimator.config.method == 'centroid'
        finally:
            node.destroy_node()


@pytest.mark.ros
def test_calibrate_refuses_a_huge_timeout_and_tare_refuses_without_frames(tmp_path, capfd):
    with ros_context() as (context, executor):
        node = DirectionNode(context=context, parameter_overrides=overrides(
            {'calibration_file': str(tmp_path / 'cal.yaml')}))
        executor.add_node(node)
        for timeout in (1e9, math.inf):
            result = send_goal(executor, node, Calibrate, '/skin_direction/calibrate',
                               Calibrate.Goal(presses=2, timeout=timeout))[1]
            assert not result.success and 'is not in (0, 3600]' in result.message
        result = call(executor, node, Trigger, '/skin_direction/tare', Trigger.Request())
        assert not result.success and 'no scan is arriving' in result.message
        # The refusal is in the node's log too (issue #37: it was not).
        assert 'tare refused: no scan is arriving' in capfd.readouterr().err
        node.destroy_node()
    assert not (tmp_path / 'cal.yaml').exists()


@pytest.mark.ros
@pytest.mark.parametrize('timeout', [math.nan, -1.0])
def test_calibrate_refuses_a_nan_or_negative_timeout(tmp_path, timeout):
    with ros_context() as (context, executor):
        node = DirectionNode(context=context, parameter_overrides=overrides(
            {'calibration_file': str(tmp_path / 'cal.yaml'), 'calibration.timeout': 0.3}))
        executor.add_node(node)
        try:
            result = send_goal(executor, node, Calibrate, '/skin_direction/calibrate',
                               Calibrate.Goal(presses=2, timeout=timeout))[1]
            assert not result.success and 'timeout' in result.message
            assert 'timed out' not in result.message  # refused, not waited for
        finally:
            node.destroy_node()


@pytest.mark.ros
def test_calibrate_refuses_absurdly_many_presses(tmp_path):
    with ros_context() as (context, executor):
        node = DirectionNode(context=context, parameter_overrides=overrides(
            {'calibration_file': str(tmp_path / 'cal.yaml')}))
        executor.add_node(node)
        try:
            result = send_goal(executor, node, Calibrate, '/skin_direction/calibrate',
                               Calibrate.Goal(presses=2 ** 32 - 1, timeout=0.3))[1]
            assert not result.success and 'presses' in result.message
            assert 'timed out' not in result.message
        finally:
            node.destroy_node()


@pytest.mark.ros
def test_calibrate_with_absurdly_many_presses_fails_clearly_and_keeps_the_file(tmp_path):
    previous = calib.Calibration(x_p_m=0.0003, y_p_m=-0.0001, presses=5)
    previous.save_yaml(str(tmp_path / 'calibration.yaml'))
    with pipeline(tmp_path, scene([])) as (sim, _, direction, probe, executor):
        result = send_goal(executor, direction, Calibrate, '/skin_direction/calibrate',
                           Calibrate.Goal(presses=2 ** 32 - 1, timeout=0.3))[1]
        assert not result.success
        assert 'presses 4294967295 is more than 1000' in result.message
        assert 'previous calibration stays in force' in result.message
        # A refused request answers the calibration in force, not zeros.
        assert (result.x_p, result.y_p) == (0.0003, -0.0001)
        assert direction.host.estimator.calibration == previous
    assert calib.Calibration.load_yaml(str(tmp_path / 'calibration.yaml')) == previous


@pytest.mark.ros
def test_failed_write_of_a_new_calibration_keeps_the_previous_one(tmp_path):
    blocker = tmp_path / 'not_a_dir'
    blocker.write_text('a file where the calibration directory should be')
    path = blocker / 'calibration.yaml'
    the_scene = scene(NORMAL_PRESSES, misalignment_m=[0.001, 0.0])
    with pipeline(tmp_path, the_scene, direction={'calibration_file': str(path)}) as (
            sim, _, direction, __, executor):
        before = direction.host.estimator.calibration
        result = send_goal(executor, direction, Calibrate, '/skin_direction/calibrate',
                           Calibrate.Goal(presses=2, timeout=8.0))[1]
        assert not result.success, result.message
        assert 'previous calibration stays in force' in result.message
        assert direction.host.estimator.calibration == before
        assert (result.x_p, result.y_p) == (before.x_p_m, before.y_p_m)


WRITER = textwrap.dedent("""
    import sys
    from skin_driver.core.estimation.calibration.calibration import Calibration
    path = sys.argv[1]
    i = 0
    while True:
        i += 1
        Calibration(x_p_m=i * 1e-6, y_p_m=-i * 1e-6, std_x_m=1e-6, std_y_m=2e-6,
                    presses=i).save_yaml(path)
        if i == 1:
            print('ready', flush=True)
""")


def test_calibration_file_survives_sigkill_at_random_moments(tmp_path):
    path = tmp_path / 'calibration.yaml'
    rng = random.Random(11)
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE='1')
    last = 0
    for _ in range(12):
        proc = subprocess.Popen([sys.executable, '-c', WRITER, str(path)],
                                stdout=subprocess.PIPE, env=env)
        assert proc.stdout.readline().strip() == b'ready'
        time.sleep(rng.uniform(0.0, 0.15))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
        cal = calib.Calibration.load_yaml(str(path))
        # Whole and one of the values written: the i-th write is x_p = i um, presses = i.
        assert cal.presses >= 1
        assert cal == calib.Calibration(x_p_m=cal.presses * 1e-6, y_p_m=-cal.presses * 1e-6,
                                        std_x_m=1e-6, std_y_m=2e-6, presses=cal.presses)
        last = max(last, cal.presses)
    assert last > 1  # the kills landed while writes were going on
    # A kill between creating and renaming the temporary file can leave it behind; never the
    # target itself.
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith('.')) == [
        'calibration.yaml']


def test_a_frame_whose_layers_do_not_match_its_grid_is_counted_and_the_stream_goes_on(
        tmp_path):
    with pipeline(tmp_path, scene([])) as (_, _, direction, probe, executor):
        assert spin_until(executor, lambda: len(probe.record.received_s) >= 5)
        bad = conversions.skin_frame_to_msg(conversions.make_header(Time(), 'skin_link'), 1, 2,
                                            0.005, np.zeros((4, 4), np.uint16),
                                            np.zeros((4, 4), np.uint16))
        bad.rows = 5
        publisher = probe.node.create_publisher(SkinFrame, 'frame', qos_profile_sensor_data)
        assert spin_until(executor, lambda: publisher.get_subscription_count() > 0)

        def bad_frames():
            status = probe.latest('contact estimation')
            return status is not None and int(status_values(status)['bad frames']) >= 1
        publisher.publish(bad)
        assert spin_until(executor, bad_frames)
        count = len(probe.record.received_s)
        assert spin_until(executor, lambda: len(probe.record.received_s) >= count + 5)
