"""The calibration actions on the direction node: progress, cancel, one at a time, files."""

import math

from action_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Point, WrenchStamped
import numpy as np
from pipeline import call, overrides, pipeline, scene, send_goal
import pytest
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rosutil import ros_context, spin_until, wait_for_server
from skin_driver.core.estimation.calibration.calibration import Calibration, SkinIdentity
from skin_driver.core.estimation.model.forcecurve import ForceCurve
from skin_driver.core.sim.board import SIM_UID
from skin_driver.ros.calibration_services import default_calibration_file
from skin_driver.ros.conversions import status_values
from skin_driver.ros.direction_node import DirectionNode
from skin_msgs.action import (CalibrateCompliance, CalibrateCreep, CalibrateForce,
                              CalibrateGains, CalibrateMount)
from std_srvs.srv import Trigger

pytestmark = pytest.mark.ros

# Another FSR curve and twice the default compliance: the assumed values are far off here.
MODEL = {'fsr': {'r_series_ohm': 2000.0, 'r_min_ohm': 150.0, 'r_max_ohm': 6000.0,
                 'force_at_r_min_n': 40.0}, 'compliance_m_per_n': 1.4e-3}
FORCES = [5.0, 30.0, 10.0, 40.0, 15.0, 25.0, 8.0, 20.0]
TILTED = [(6.0, 30.0, 0.0), (8.0, 20.0, 90.0), (5.0, 40.0, 200.0), (7.0, 25.0, 300.0)]
CURVE = ForceCurve((0.0, 1000.0, 3000.0), (0.0, 1.0, 9.0))
FORCE = '/skin_direction/calibrate_force'
COMPLIANCE = '/skin_direction/calibrate_compliance'
RESET = '/skin_direction/reset_calibration'


def latest_status(probe):
    """Return the key/values, level and message of the newest contact estimation status."""
    for _, s in reversed(probe.statuses):
        if s.name.endswith('contact estimation'):
            return status_values(s), s.level, s.message
    return {}, None, ''


def test_force_then_compliance_through_the_actions_with_feedback_per_press(tmp_path):
    # Two sessions on one calibration file, each scene played once its goal is accepted: however
    # slowly the machine sends a goal, no press goes by before it (presses 1.6 s apart: a loaded
    # machine that skips a few frames still sees each release).
    forces = [{'time_s': 0.5 + 1.6 * i, 'force_n': f} for i, f in enumerate(FORCES)]
    tilted = [{'time_s': 0.5 + 1.6 * i, 'force_n': f, 'alpha_deg': a, 'beta_deg': b}
              for i, (f, a, b) in enumerate(TILTED)]
    feedback = []
    # At 100 scans/s (the paper's board sends ~30) a loaded CI machine keeps up with the scans; at
    # 200 under a parallel suite one press of eight was once read 20 % off.
    with pipeline(tmp_path, scene(forces, **MODEL), rate_hz=100.0, play=False) as (
            sim, _, direction, probe, executor):
        status, force = send_goal(executor, direction, CalibrateForce, FORCE,
                                  CalibrateForce.Goal(forces=FORCES, timeout=40.0),
                                  timeout_s=50.0, feedback=feedback.append,
                                  on_accepted=sim.start)
        assert status == GoalStatus.STATUS_SUCCEEDED and force.success, force.message
        assert force.presses_used == len(FORCES) and len(force.residuals) == len(FORCES)
        assert max(abs(r) / f for r, f in zip(force.residuals, FORCES)) < 0.15
        assert len(force.curve_counts) == len(force.curve_forces) >= 2
        assert 'written to' in force.message
        # One feedback per press: how many are in and what the last one read.
        assert [f.presses_done for f in feedback] == list(range(1, len(FORCES) + 1))
        assert all(f.presses_wanted == len(FORCES) and f.last_force > 0 for f in feedback)
    # The second session starts from the file the first one wrote.
    with pipeline(tmp_path, scene(tilted, **MODEL), rate_hz=100.0, play=False) as (
            sim, _, direction, probe, executor):
        status, compliance = send_goal(
            executor, direction, CalibrateCompliance, COMPLIANCE,
            CalibrateCompliance.Goal(forces=[t[0] for t in TILTED],
                                     alphas=[math.radians(t[1]) for t in TILTED], timeout=40.0),
            timeout_s=50.0, on_accepted=sim.start)
        assert status == GoalStatus.STATUS_SUCCEEDED, compliance.message
        assert compliance.compliance == pytest.approx(1.4e-3, rel=0.2)
        assert len(compliance.fitted) == len(TILTED)
        in_force = direction.host.estimator.calibration
        assert in_force.force_curves is not None and in_force.compliance_presses == 4
        # Stamped for the board that said who it is (the simulated board's fake identity).
        assert in_force.skin == SkinIdentity(16, 16, 0.005, '', SIM_UID, 'sim')
        # What the diagnostics say is what was made, and when.
        assert spin_until(executor, lambda: latest_status(probe)[0].get(
            'calibration made') == in_force.made_utc)
        assert latest_status(probe)[0]['force made'] == in_force.made('force')
    saved = Calibration.load_yaml(str(tmp_path / 'calibration.yaml'))
    assert saved == in_force


@pytest.fixture
def node_with_calibration(tmp_path):
    """Yield (node, executor, path, calibration in force) for a node without frames."""
    path = tmp_path / 'calibration.yaml'
    previous = Calibration(x_p_m=2e-4, compliance_m_per_n=1e-3, force_curves=(CURVE, CURVE),
                           force_presses=7, made_utc='2026-01-01T00:00:00Z')
    previous.save_yaml(path)
    with ros_context() as (context, executor):
        node = DirectionNode(context=context, parameter_overrides=overrides(
            {'calibration_file': str(path)}))
        executor.add_node(node)
        try:
            yield node, executor, path, previous
        finally:
            node.destroy_node()


def test_bad_goals_end_before_any_press_and_change_nothing(node_with_calibration):
    node, executor, path, previous = node_with_calibration
    text = path.read_text()
    for goal, message in ((CalibrateForce.Goal(forces=[5.0, -1.0], timeout=60.0),
                           'positive number of newtons'),
                          (CalibrateForce.Goal(forces=[5.0, 10.0], timeout=60.0),
                           '2 presses of known force; the force curve needs at least 6')):
        # A timeout of a minute: the goal ends at once all the same, waiting for no press.
        status, force = send_goal(executor, node, CalibrateForce, FORCE, goal, timeout_s=10.0)
        assert status == GoalStatus.STATUS_ABORTED and message in force.message
        assert 'previous calibration stays in force' in force.message
        assert list(force.curve_counts) == list(CURVE.counts)
    for goal, message in ((CalibrateCompliance.Goal(forces=[], timeout=60.0),
                           'calibration.wrench_topic'),
                          (CalibrateCompliance.Goal(forces=[5.0], alphas=[2.0]),
                           'pi/2) radians')):
        status, compliance = send_goal(executor, node, CalibrateCompliance, COMPLIANCE, goal,
                                       timeout_s=10.0)
        assert status == GoalStatus.STATUS_ABORTED and message in compliance.message
        assert compliance.compliance == 1e-3
    status, force = send_goal(executor, node, CalibrateForce, FORCE,
                              CalibrateForce.Goal(forces=[5.0] * 5 + [20.0], timeout=0.3))
    assert status == GoalStatus.STATUS_ABORTED and 'timed out' in force.message
    status, gains = send_goal(executor, node, CalibrateGains, '/skin_direction/calibrate_gains',
                              CalibrateGains.Goal(presses=1, timeout=0.3))
    assert status == GoalStatus.STATUS_ABORTED and 'timed out' in gains.message
    assert (gains.gain_min, gains.gain_max) == (1.0, 1.0)  # no gains in force
    assert node.host.estimator.calibration == previous
    assert path.read_text() == text


def test_a_second_goal_is_rejected_and_a_cancel_changes_nothing(node_with_calibration, capfd):
    """The rejection and the cancel are logged too (issue #37: neither was)."""
    node, executor, path, previous = node_with_calibration
    text = path.read_text()
    first = ActionClient(node, CalibrateForce, FORCE)
    wait_for_server(executor, first)
    sent = first.send_goal_async(CalibrateForce.Goal(forces=FORCES, timeout=60.0))
    assert spin_until(executor, sent.done, 30.0) and sent.result().accepted
    # While the first waits for presses, another goal of any kind is turned away at once.
    status, result = send_goal(executor, node, CalibrateCompliance, COMPLIANCE,
                               CalibrateCompliance.Goal(forces=[5.0] * 3, alphas=[0.3] * 3))
    assert (status, result) == (None, None)
    done = sent.result().get_result_async()
    sent.result().cancel_goal_async()
    assert spin_until(executor, done.done, 30.0)
    assert done.result().status == GoalStatus.STATUS_CANCELED
    assert done.result().result.message.startswith('cancelled with 0 of 8 presses')
    assert node.host.estimator.calibration == previous
    assert path.read_text() == text
    logged = capfd.readouterr().err
    assert 'compliance calibration goal rejected: a force calibration is already running' \
        in logged
    assert 'calibration (force): cancelled with 0 of 8 presses' in logged
    first.destroy()
    # The session is over: the next goal is taken.
    status, _ = send_goal(executor, node, CalibrateForce, FORCE,
                          CalibrateForce.Goal(forces=FORCES, timeout=0.3))
    assert status == GoalStatus.STATUS_ABORTED


def test_reset_puts_the_defaults_in_force_and_in_the_file(node_with_calibration):
    node, executor, path, previous = node_with_calibration
    assert node.host.estimator.calibration == previous
    before = path.read_bytes()
    answer = call(executor, node, Trigger, RESET, Trigger.Request())
    # It says which file it wrote, and where the previous one is kept.
    assert answer.success and answer.message == (
        f'calibration reset to the defaults in {path} (the previous one is kept as {path}.bak)')
    assert node.host.estimator.calibration == Calibration()
    assert Calibration.load_yaml(path) == Calibration()
    assert (path.parent / 'calibration.yaml.bak').read_bytes() == before


def test_a_corrupt_calibration_file_is_refused_when_set(node_with_calibration):
    node, _, path, previous = node_with_calibration
    corrupt = path.parent / 'corrupt.yaml'
    corrupt.write_text('format: skin_driver/calibration\nx_p_m: [unclosed\n')
    result = node.set_parameters([Parameter('calibration_file', value=str(corrupt))])[0]
    assert not result.successful
    assert result.reason.startswith(f'calibration file refused: {corrupt}: not valid YAML')
    assert result.reason.endswith('; the calibration in force stays')
    assert node.get_parameter('calibration_file').value == str(path)
    assert node.host.estimator.calibration == previous


def test_a_corrupt_file_given_at_start_up_is_never_written(tmp_path):
    path = tmp_path / 'calibration.yaml'
    path.write_text('format: skin_driver/calibration\nx_p_m: [unclosed\n')
    before = path.read_bytes()
    with ros_context() as (context, executor):
        node = DirectionNode(context=context, parameter_overrides=overrides(
            {'calibration_file': str(path)}))
        executor.add_node(node)
        try:
            assert node.host.estimator.calibration == Calibration()
            answer = call(executor, node, Trigger, RESET, Trigger.Request())
            assert not answer.success
            assert answer.message.startswith(f'reset refused: {path} is not written: it was '
                                             'refused (')
            assert 'calibration_file (a new path is made by the first calibration)' in \
                answer.message
            # A calibration is refused before any press is awaited (a minute's timeout).
            status, force = send_goal(executor, node, CalibrateForce, FORCE,
                                      CalibrateForce.Goal(forces=FORCES, timeout=60.0),
                                      timeout_s=10.0)
            assert status == GoalStatus.STATUS_ABORTED
            assert f'{path} is not written' in force.message
            # So are the mount and the creep, whose results the same file would keep.
            for action, name, goal in (
                    (CalibrateMount, 'calibrate_mount', CalibrateMount.Goal(
                        points=[Point(x=0.01 * i, y=0.02 * (i % 2)) for i in range(6)],
                        timeout=60.0)),
                    (CalibrateCreep, 'calibrate_creep', CalibrateCreep.Goal(hold=5.0,
                                                                            timeout=60.0))):
                status, result = send_goal(executor, node, action, f'/skin_direction/{name}',
                                           goal, timeout_s=10.0)
                assert status == GoalStatus.STATUS_ABORTED
                assert f'refused: {path} is not written' in result.message, name
        finally:
            node.destroy_node()
    assert path.read_bytes() == before
    assert not (tmp_path / 'calibration.yaml.bak').exists()


def test_a_calibration_file_that_does_not_exist_is_refused_when_set(node_with_calibration):
    node, _, path, previous = node_with_calibration
    result = node.set_parameters([Parameter('calibration_file', value='/no/such/cal.yaml')])[0]
    assert not result.successful and 'no calibration file at /no/such/cal.yaml' in result.reason
    assert node.get_parameter('calibration_file').value == str(path)
    assert node.host.estimator.calibration == previous


def test_a_calibration_made_for_another_skin_is_refused_never_written_and_the_diagnostics_warn(
        tmp_path):
    path = tmp_path / 'calibration.yaml'
    other_grid = SkinIdentity(64, 64, 0.00125)
    Calibration(x_p_m=4e-4, presses=8, skin=other_grid).save_yaml(path)
    before = path.read_bytes()
    another = tmp_path / 'another.yaml'
    Calibration(x_p_m=3e-4, presses=8, skin=other_grid).save_yaml(another)
    with pipeline(tmp_path, scene([])) as (sim, _, direction, probe, executor):
        assert spin_until(executor, lambda: 'made for 64 x 64' in latest_status(probe)[2])
        values, level, message = latest_status(probe)
        assert level == DiagnosticStatus.WARN
        assert 'this skin is 16 x 16 taxels at 5.000 mm pitch' in message
        assert direction.host.estimator.calibration == Calibration()
        # Reset does not write the other skin's file: it says why and how to go on.
        answer = call(executor, direction, Trigger, RESET, Trigger.Request())
        assert not answer.success and f'{path} is not written' in answer.message
        # Another grid's file set at run time is refused by the set itself, with the reason.
        result = direction.set_parameters([Parameter('calibration_file', value=str(another))])[0]
        assert not result.successful
        assert result.reason.startswith(f'calibration file refused: {another}: made for 64 x 64')
        assert direction.get_parameter('calibration_file').value == str(path)
    # The file is left as it was, byte for byte: it may be the right one for the other skin.
    assert path.read_bytes() == before
    assert not (tmp_path / 'calibration.yaml.bak').exists()


def test_the_wrench_topic_takes_a_best_effort_publisher(node_with_calibration):
    node, executor, _, _ = node_with_calibration
    assert node.set_parameters([Parameter('calibration.wrench_topic',
                                          value='/ft_sensor/wrench')])[0].successful
    sensor = node.create_publisher(WrenchStamped, '/ft_sensor/wrench', qos_profile_sensor_data)
    # A reliable subscription would not match a best-effort publisher.
    assert spin_until(executor, lambda: sensor.get_subscription_count() == 1, 30.0)
    node.destroy_publisher(sensor)


def test_two_skins_in_two_namespaces_never_share_a_calibration_file(tmp_path, monkeypatch):
    monkeypatch.setenv('ROS_HOME', str(tmp_path))
    left = default_calibration_file('/left/skin_direction')
    assert left == str(tmp_path / 'skin_driver' / 'calibration' / 'left' / 'skin_direction.yaml')
    Calibration(x_p_m=5e-4, presses=3).save_yaml(left, make_parents=True)
    with ros_context() as (context, _):
        nodes = {ns: DirectionNode(context=context, namespace=ns) for ns in ('/left', '/skin')}
        try:
            assert nodes['/left'].host.estimator.calibration.x_p_m == 5e-4
            assert nodes['/skin'].host.estimator.calibration == Calibration()
            assert 'skin/skin_direction.yaml' in nodes['/skin'].host.calibration.note
        finally:
            for node in nodes.values():
                node.destroy_node()
    assert np.isclose(Calibration.load_yaml(left).x_p_m, 5e-4)
