"""The creep action on the direction node: a held load in, its creep out, in the file; refusals."""

import re

from action_msgs.msg import GoalStatus
from pipeline import pipeline, scene, send_goal
import pytest
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from rosutil import spin_until
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.ros.conversions import status_values
from skin_msgs.action import CalibrateCreep

pytestmark = pytest.mark.ros

ACTION = '/skin_direction/calibrate_creep'


def test_a_load_held_still_gives_the_creep_in_the_result_the_file_and_the_estimator(tmp_path):
    feedback = []
    held = scene([{'time_s': 1.0, 'force_n': 10.0, 'duration_s': 30.0}])
    with pipeline(tmp_path, held, rate_hz=100.0) as (_, _, direction, _, executor):
        status, result = send_goal(
            executor, direction, CalibrateCreep, ACTION,
            CalibrateCreep.Goal(load=10.0, hold=6.0, timeout=20.0), timeout_s=30.0,
            feedback=feedback.append)
        in_force = direction.host.estimator.calibration.creep
    assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
    # The simulated board's film does not creep: none is found, and the fit says so.
    assert 0.0 <= result.per_decade < 0.01 and result.held >= 6.0
    assert result.load_read > 5.0 and 'the load weighs 10.00 N' in result.message
    assert 'written to' in result.message
    # no force calibration was in force: the result says which comes first
    assert 'calibrate force first, then creep' in result.message
    assert len(feedback) >= 8 and feedback[-1].hold == 6.0
    assert all(b.held > a.held for a, b in zip(feedback, feedback[1:]))
    stored = Calibration.load_yaml(tmp_path / 'calibration.yaml').creep
    assert stored is not None and stored.per_decade == pytest.approx(result.per_decade)
    assert stored.made_utc and in_force == stored


def test_with_a_rest_the_feedback_says_when_to_take_the_load_off_and_put_it_back(tmp_path):
    feedback = []
    off_and_on = scene([{'time_s': 1.0, 'force_n': 10.0, 'duration_s': 9.0},
                        {'time_s': 12.0, 'force_n': 10.0, 'duration_s': 5.0}])
    with pipeline(tmp_path, off_and_on, rate_hz=100.0) as (_, _, direction, _, executor):
        status, result = send_goal(
            executor, direction, CalibrateCreep, ACTION,
            CalibrateCreep.Goal(hold=6.0, rest=2.0, timeout=25.0), timeout_s=35.0,
            feedback=feedback.append)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
    notes = [f.note for f in feedback if not re.match(r'held [\d.]+ of', f.note)]
    assert notes == ['held long enough: take the load off now',
                     'load off: put it back in a moment, where it was',
                     'load back: hold it two seconds']
    # A film that does not creep does not say how it recovers: the estimator's stays.
    assert result.recovery == 60.0 and 'recovers in 60 s' in result.message


def test_a_load_that_moves_ends_the_goal_with_the_reason_and_changes_nothing(tmp_path):
    # One load slid a millimetre every half second: 4 mm away after two seconds.
    sliding = scene([{'time_s': 1.0 + 0.5 * i, 'duration_s': 0.6, 'ramp_s': 0.05,
                      'x_m': 0.030 + 0.001 * i} for i in range(16)])
    with pipeline(tmp_path, sliding, rate_hz=100.0) as (_, _, direction, _, executor):
        status, result = send_goal(
            executor, direction, CalibrateCreep, ACTION,
            CalibrateCreep.Goal(hold=6.0, timeout=20.0), timeout_s=30.0)
        assert direction.host.estimator.calibration.creep is None
    assert status == GoalStatus.STATUS_ABORTED and not result.success
    assert 'the load moved by' in result.message and 'previous calibration stays' in result.message
    assert not (tmp_path / 'calibration.yaml').exists()


def test_no_load_a_bad_goal_and_a_cancel_each_end_with_a_message_and_change_nothing(
        tmp_path, capfd):
    with pipeline(tmp_path, scene([]), rate_hz=100.0) as (_, _, direction, probe, executor):
        # the diagnostics show the drift followed since the start: no tare was made (issue #36;
        # #47: it said "since the tare")
        assert spin_until(executor, lambda: any(
            'drift since the start (no tare yet), top [counts]' in status_values(s)
            for _, s in probe.statuses if s.name.endswith('contact estimation')), 10.0)
        status, result = send_goal(executor, direction, CalibrateCreep, ACTION,
                                   CalibrateCreep.Goal(hold=1.0))
        assert status == GoalStatus.STATUS_ABORTED
        assert result.message.startswith('refused: hold 1 s is not in [5, 3600] s')
        status, result = send_goal(executor, direction, CalibrateCreep, ACTION,
                                   CalibrateCreep.Goal(hold=5.0, timeout=6.0), timeout_s=15.0)
        assert status == GoalStatus.STATUS_ABORTED
        assert 'timed out after 6 s: no load arrived' in result.message
        client = ActionClient(direction, CalibrateCreep, ACTION)
        sent = client.send_goal_async(CalibrateCreep.Goal(hold=60.0))
        assert spin_until(executor, sent.done, 5.0) and sent.result().accepted
        # one at a time: a second goal meanwhile is turned away
        assert send_goal(executor, direction, CalibrateCreep, ACTION,
                         CalibrateCreep.Goal()) == (None, None)
        done = sent.result().get_result_async()
        sent.result().cancel_goal_async()
        assert spin_until(executor, done.done, 5.0)
        assert done.result().status == GoalStatus.STATUS_CANCELED
        assert done.result().result.message.startswith('cancelled after 0 s held')
        assert direction.host.estimator.calibration.creep is None
        client.destroy()
    assert not (tmp_path / 'calibration.yaml').exists()
    logged = capfd.readouterr().err
    assert 'creep calibration goal rejected' in logged
    assert 'creep calibration: cancelled after' in logged


def test_a_change_of_parameters_keeps_how_long_a_press_has_been_held(tmp_path):
    held = scene([{'time_s': 1.0, 'force_n': 10.0, 'duration_s': 30.0}])
    with pipeline(tmp_path, held, rate_hz=100.0) as (_, _, direction, probe, executor):

        def longest():
            return max((c.held for m in probe.contacts for c in m.contacts), default=0.0)
        assert spin_until(executor, lambda: longest() > 3.0, 15.0)
        generation = direction.host.live.generation
        direction.set_parameters([Parameter('min_confidence', value=0.2)])
        assert spin_until(executor, lambda: direction.host.live.generation > generation, 5.0)
        before = len(probe.contacts)
        assert spin_until(executor, lambda: len(probe.contacts) > before + 20, 5.0)
        # the new estimator's first contacts: the time under load carried over, not restarted
        after = [c.held for m in probe.contacts[before + 10:] for c in m.contacts]
        assert after and min(after) > 3.0
