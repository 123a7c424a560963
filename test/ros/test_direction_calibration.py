"""~/calibrate_direction: presses of known azimuth learn the direction (issue #38)."""

import math

from action_msgs.msg import GoalStatus
from pipeline import pipeline, scene, send_goal
import pytest
from rclpy.action import ActionClient
from rosutil import spin_until, wait_for_server
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_msgs.action import CalibrateDirection

pytestmark = pytest.mark.ros

DIRECTION = '/skin_direction/calibrate_direction'
# Twelve tilted presses spread over the skin: (x, y) in metres, alpha and beta in degrees.
PRESSES = [(0.02 + 0.012 * (k % 4), 0.025 + 0.012 * (k // 4), 30.0 + 5.0 * (k % 3),
            (37.0 * k) % 360.0) for k in range(12)]
BAD = 5  # the goal gives this press an azimuth half a turn off: a press to leave out


# After the last press the calibration learns the skin's model and renders presses through it:
# tens of seconds of CPU, a minute and more on a busy machine. Only bounds on a hung test.
@pytest.mark.timeout(400)
def test_presses_of_known_azimuth_learn_the_direction_one_bad_press_left_out(tmp_path):
    presses = [{'time_s': 2.0 + 1.6 * k, 'x_m': x, 'y_m': y, 'force_n': 10.0, 'alpha_deg': a,
                'beta_deg': b} for k, (x, y, a, b) in enumerate(PRESSES)]
    azimuths = [math.radians(b + (180.0 if k == BAD else 0.0))
                for k, (_, _, _, b) in enumerate(PRESSES)]
    feedback = []
    with pipeline(tmp_path, scene(presses), rate_hz=100.0, play=False) as (
            sim, _, direction, probe, executor):
        status, result = send_goal(executor, direction, CalibrateDirection, DIRECTION,
                                   CalibrateDirection.Goal(azimuths=azimuths, timeout=40.0),
                                   timeout_s=300.0, feedback=feedback.append,
                                   on_accepted=sim.start)
        assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
        in_force = direction.host.estimator.calibration
    # Every press made is fed back; the one given the wrong azimuth is left out of the fit.
    assert [f.presses_done for f in feedback] == list(range(1, len(PRESSES) + 1))
    assert result.presses_used == len(PRESSES) - 1
    assert '1 press left out' in result.message and 'written to' in result.message
    assert result.error_before > 0 and result.error_after > 0
    assert result.applied == in_force.direction.kept
    assert in_force.direction.presses == len(PRESSES) - 1
    assert Calibration.load_yaml(str(tmp_path / 'calibration.yaml')) == in_force


def test_bad_goals_end_at_once_and_a_cancel_changes_nothing(tmp_path, capfd):
    with pipeline(tmp_path, scene([])) as (_, _, node, _, executor):
        previous = node.host.estimator.calibration
        _bad_goals_and_a_cancel(node, executor)
        assert node.host.estimator.calibration == previous
    assert not (tmp_path / 'calibration.yaml').exists()
    logged = capfd.readouterr().err
    assert 'direction calibration goal aborted' in logged
    assert 'calibration (direction): cancelled with 0 of 12 presses' in logged


def _bad_goals_and_a_cancel(node, executor):
    for goal, message in ((CalibrateDirection.Goal(timeout=60.0), 'calibration.wrench_topic'),
                          (CalibrateDirection.Goal(azimuths=[0.0] * 5, timeout=60.0),
                           'at least 10'),
                          (CalibrateDirection.Goal(azimuths=[0.0] * 11 + [math.nan]),
                           'finite number of radians')):
        status, result = send_goal(executor, node, CalibrateDirection, DIRECTION, goal,
                                   timeout_s=10.0)
        assert status == GoalStatus.STATUS_ABORTED and message in result.message
        assert 'previous calibration stays in force' in result.message
        assert not result.applied
    client = ActionClient(node, CalibrateDirection, DIRECTION)
    wait_for_server(executor, client)
    sent = client.send_goal_async(CalibrateDirection.Goal(azimuths=[0.5] * 12, timeout=60.0))
    assert spin_until(executor, sent.done, 30.0) and sent.result().accepted
    done = sent.result().get_result_async()
    sent.result().cancel_goal_async()
    assert spin_until(executor, done.done, 30.0)
    assert done.result().status == GoalStatus.STATUS_CANCELED
    client.destroy()
