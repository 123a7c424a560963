"""The live sim drifts: creep calibration and baseline tracking tried on it, as a user does."""

from dataclasses import replace
import math

from action_msgs.msg import GoalStatus
import numpy as np
from pipeline import call, pipeline, send_goal
import pytest
from rosutil import spin_until
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.estimation.calibration.session import CalibrationSession
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.sim.physics import render
from skin_driver.core.sim.scene import load_scene, scene_from_dict
from skin_msgs.action import CalibrateCreep
from std_srvs.srv import Trigger

pytestmark = pytest.mark.ros

ACTION = '/skin_direction/calibrate_creep'
# Only bounds a hung test on a loaded machine: the tests wait on the board's clock.
WAIT_S = 120.0
# The idle skin's offsets rise this many counts a second: its tracked baselines lag by
# RISE * track_s at most (30 counts), below the touch threshold (40), so no phantom touch.
RISE = 0.5


def force_calibrated(scene, path) -> None:
    """Save the force curves the scene's force presses give (the recipe's step before creep)."""
    rng = np.random.default_rng(2)
    est = ContactEstimator(EstimatorConfig()).with_tare(
        *(np.stack(layer) for layer in zip(*[render(scene.model, [], rng) for _ in range(20)])))
    presses = scene.labelled('force')
    session = CalibrationSession(est, 'force', forces_n=[p.force_n for p in presses])
    for t in np.arange(presses[0].time_s - 1.0, presses[-1].end_s + 1.0, 0.02):
        top, bottom = render(scene.model, scene.presses_at(float(t)), rng)
        session.add_scan(top, bottom, est.process(top, bottom))
    session.finish().calibration.save_yaml(path)


def test_creep_calibration_on_the_calibrate_scenes_held_load_finds_its_films_creep(tmp_path):
    calibrate = load_scene('calibrate')
    held = calibrate.labelled('creep')[0]
    path = tmp_path / 'calibration.yaml'
    force_calibrated(calibrate, path)
    # The scene's skin and held load, the load arriving 2 s after the board starts.
    only_held = replace(calibrate, presses=(replace(held, time_s=2.0),), repeat=1,
                        period_s=held.duration_s + 2.0)
    with pipeline(tmp_path, only_held, rate_hz=100.0,
                  direction={'calibration_file': str(path)}) as (_, _, direction, _, executor):
        status, result = send_goal(
            executor, direction, CalibrateCreep, ACTION,
            CalibrateCreep.Goal(load=held.force_n, hold=30.0, timeout=90.0), timeout_s=WAIT_S)
    assert status == GoalStatus.STATUS_SUCCEEDED and result.success, result.message
    stored = Calibration.load_yaml(path)
    assert stored.force_curves is not None  # the file's force curves are kept beside it
    assert stored.creep.per_decade == pytest.approx(result.per_decade)
    assert abs(result.load_read / held.force_n - 1.0) < 0.1
    # Not the default the estimator assumes (2.5 %), but the film's own (6 %).
    truth = calibrate.model.drift.creep_per_decade
    assert EstimatorConfig().creep_per_decade < 0.5 * truth
    assert stored.creep.per_decade == pytest.approx(truth, rel=0.15)


def test_baseline_tracking_follows_an_idle_skin_whose_offsets_drift(tmp_path):
    idle = scene_from_dict({
        'name': 'drifting', 'drift': {'offset_counts_per_hour': RISE * 3600.0},
        'presses': [{'time_s': 1000.0, 'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 10.0,
                     'alpha_deg': 0.0, 'beta_deg': 0.0, 'radius_m': 0.004,
                     'duration_s': 1.0}]})
    track_s = EstimatorConfig().track_s
    with pipeline(tmp_path, idle, rate_hz=100.0) as (_, _, direction, probe, executor):

        def newest_s():
            return probe.contacts[-1].device_time_us / 1e6 if probe.contacts else -1.0
        assert spin_until(executor, lambda: newest_s() > 1.0, WAIT_S)
        answer = call(executor, direction, Trigger, '/skin_direction/tare', Trigger.Request())
        assert answer.success, answer.message
        tared = newest_s()
        assert spin_until(executor, lambda: newest_s() > tared + 30.0, WAIT_S)
        (top, bottom), _ = direction.host.estimator.drift()
        since = newest_s() - tared
        reported = sum(len(m.contacts) for m in probe.contacts)
    # The offsets rose RISE * since (15 counts); the baselines followed them with the time
    # constant track_s: by RISE * (t - track_s (1 - exp(-t / track_s))), about 3 counts.
    followed = RISE * (since - track_s * (1.0 - math.exp(-since / track_s)))
    assert followed > 2.5
    for layer in (top, bottom):
        assert layer == pytest.approx(followed, rel=0.2, abs=0.3)
    assert reported == 0
