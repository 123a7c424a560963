"""
Tares, calibrations and parameter changes while the fused reader estimates 2000 scans a second.

Every contacts message must be what one estimator in force made of its scan (no scan meets half
of a change), every scan the reader handed over is either published or counted, and only the
thread that estimates enters a live kernel (the owner check on).
"""

import math

from action_msgs.msg import GoalStatus
from pipeline import call, pipeline, send_goal
import pytest
from rclpy.parameter import Parameter
from rosutil import spin_until
from skin_driver.core.estimation.calibration.calibration import Calibration
from skin_driver.core.sim.scene import scene_from_dict
from skin_driver.ros import conversions
from skin_msgs.action import Calibrate
from std_srvs.srv import Trigger

pytestmark = pytest.mark.ros

WAIT_S = 20.0
RATE_HZ = 2000.0
# Each period: a normal press (a calibration's), a tilted one (a direction to get right), then
# 0.4 s untouched (a tare's).
SCENE = scene_from_dict({
    'name': 'changes', 'period_s': 0.8,
    'model': {'rows': 16, 'cols': 16, 'pitch_m': 0.005},
    'defaults': {'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 8.0, 'radius_m': 0.004,
                 'ramp_s': 0.04, 'duration_s': 0.15, 'alpha_deg': 0.0, 'beta_deg': 0.0},
    'presses': [{'time_s': 0.02}, {'time_s': 0.2, 'alpha_deg': 35.0, 'beta_deg': 120.0}]},
    name='changes')
# Two calibrations a change of file switches between (another zero, another compliance).
CALIBRATIONS = (Calibration(x_p_m=2e-4, y_p_m=-1e-4, presses=8, std_x_m=5e-5, std_y_m=5e-5),
                Calibration(x_p_m=-3e-4, y_p_m=2e-4, presses=8, std_x_m=8e-5, std_y_m=4e-5,
                            compliance_m_per_n=1.1e-3, compliance_presses=4))
PARAMETERS = ({'threshold': 60.0, 'min_force': 0.5}, {'threshold': 40.0, 'min_force': 0.2},
              {'method': 'centroid'}, {'method': 'taxel_fit'}, {'min_confidence': 0.6},
              {'min_confidence': 0.3, 'compliance': 9e-4})
ROUNDS = 3
# A contact lighter than this is a press coming or going: what estimator made it can't be told.
FAINT_N = 1.0


def _untouched(probe, scans=40):
    """Return whether the last ``scans`` contacts messages received had no contact."""
    counts = probe.record.contacts[-scans:]
    return len(counts) == scans and not any(counts)


def test_changes_under_a_2_khz_fused_reader_never_tear_a_scan_nor_lose_one(tmp_path,
                                                                           owner_checked):
    files = [str(tmp_path / f'calibration_{i}.yaml') for i in range(len(CALIBRATIONS))]
    for cal, path in zip(CALIBRATIONS, files):
        cal.save_yaml(path)
    with pipeline(tmp_path, SCENE, rate_hz=RATE_HZ, fused=True, loop=True,
                  direction={'calibration_file': files[0]}) as (
            _, driver, direction, probe, executor):
        host = direction.host
        tare, reset = (f'/{direction.get_name()}/{name}' for name in ('tare',
                                                                      'reset_calibration'))
        assert spin_until(executor, lambda: len(probe.contacts) > 50, WAIT_S)
        # Nothing has changed since the reader started: every estimator in force from here on
        # is one this test sees put in force.
        seen = {host.live.generation: host.estimator}
        tared = calibrated = 0

        def record():
            assert spin_until(executor, lambda: not host.rebuilding, WAIT_S)
            live = host.live
            seen.setdefault(live.generation, live.estimator)

        for round_ in range(ROUNDS):
            for k, values in enumerate(PARAMETERS):
                direction.set_parameters_atomically(
                    [Parameter(n, value=v) for n, v in values.items()])
                record()
                if k % 2 == 0:
                    # A tare wants untouched scans: taken between presses (asked again if a
                    # press began meanwhile; a refusal changes nothing).
                    for _ in range(5):
                        assert spin_until(executor, lambda: _untouched(probe), WAIT_S)
                        answer = call(executor, probe.node, Trigger, tare, Trigger.Request())
                        record()
                        if answer.success:
                            tared += 1
                            break
                else:
                    path = files[(round_ + k) % len(files)]
                    CALIBRATIONS[(round_ + k) % len(files)].save_yaml(path)
                    direction.set_parameters([Parameter('calibration_file', value=path)])
                    record()
            # A calibration session fed by the reader, and a reset of what it made.
            status, result = send_goal(executor, probe.node, Calibrate,
                                       f'/{direction.get_name()}/calibrate',
                                       Calibrate.Goal(presses=1, timeout=3.0), timeout_s=WAIT_S)
            record()
            calibrated += status == GoalStatus.STATUS_SUCCEEDED
            assert call(executor, probe.node, Trigger, reset, Trigger.Request()).success
            record()
        # Over a second of 2 kHz scans met the changes: waited for, not assumed from how long
        # the changes took (a quiet machine makes them quicker).
        assert spin_until(executor, lambda: len(probe.contacts) > 200
                          and host.tally().estimated > 2000, WAIT_S)
        driver.trigger_deactivate()  # the reader stops: every count below is final
        handed = driver.link.stats.frames
        tally = host.tally()
        frames = {msg.sequence: msg for msg in probe.frames}
        contacts = [msg for msg in probe.contacts if msg.sequence in frames]

    # Each change put exactly one new estimator in force, and the test saw them all.
    generations = sorted(seen)
    assert generations == list(range(generations[0], generations[-1] + 1))
    assert len(generations) > 3 * len(PARAMETERS) * ROUNDS // 2
    assert tared >= ROUNDS and calibrated >= 1

    # No torn state: each message is its scan as one estimator in force made it. The scans run
    # again in order and timed through the estimators in force one after another, each taking
    # the tracked baselines and creep ages of the one before as the host's swap does; the
    # estimators in force follow one another, so a scan's is at or after the last one's.
    assert len(contacts) > 200
    published = {msg.sequence: msg for msg in contacts}
    at, used = generations[0], set()
    live = _timed_copy(seen[at])
    for sequence in sorted(frames):
        top, bottom = conversions.skin_frame_layers(frames[sequence])
        time_s = frames[sequence].device_time_us * 1e-6
        made, g, candidate = live.process(top, bottom, time_s=time_s), at, live
        msg = published.get(sequence)
        if msg is None:
            continue
        while not _same_contacts([conversions.contact_fields(c) for c in made], msg.contacts):
            g += 1
            if g > generations[-1]:
                pytest.fail(f"scan {sequence}: its contacts are no estimator's from "
                            f'generation {at} on ({len(msg.contacts)} contacts)')
            candidate = _timed_copy(seen[g], live)
            made = candidate.process(top, bottom, time_s=time_s)
        live, at = candidate, g
        used.add(g)
    # The changes met scans that tell estimators apart, more than once a round: an untouched
    # scan, or a press coming or going, is every one's, and most changes meet only those.
    touched = sum(1 for msg in contacts if msg.contacts)
    assert touched > 100 and len(used) > ROUNDS, (touched, sorted(used), generations)

    # Nothing lost: every scan the reader handed over was published or counted as not.
    assert handed == (tally.estimated + tally.refused + tally.left_for_newer
                      + tally.before_skin_checked)
    assert (tally.refused, tally.left_for_newer, tally.before_skin_checked) == (0, 0, 0)
    assert tally.estimated > 2000


def _timed_copy(estimator, before=None):
    """Return a new copy of estimator, with before's tracked baselines and creep ages if given."""
    copy = estimator.with_config(estimator.config)
    return copy.carry_from(before) if before is not None else copy


def _same_contacts(made, published) -> bool:
    """
    Return whether the published contacts are those made again of the same scan.

    The scans run again timed, each estimator taking its predecessor's tracked state, yet not
    from the very scan the host's swap did, so a taxel at the touch threshold may count in one
    and not the other: a press coming or going (a contact under FAINT_N on either side) tells
    no estimator apart, and forces may differ by such a taxel. ``held`` is the live one's
    alone. What tells estimators apart stays: where, how hard, and for a direction both trust,
    whether it is valid, its tangential part and which way it points.
    """
    if (any(fields[4] < FAINT_N for fields in made)
            or any(msg.normal_force < FAINT_N for msg in published)):
        return True
    if len(made) != len(published):
        return False
    for fields, msg in zip(made, published):
        x, y, _, magnitude, normal, azimuth = fields[:6]
        confidence, valid = fields[18], fields[19]
        if (abs(x - msg.location.x) > 1e-4 or abs(y - msg.location.y) > 1e-4
                or abs(normal - msg.normal_force) > 0.03 * msg.normal_force + 0.03):
            return False
        if min(confidence, msg.confidence) > 0.7 and (
                valid != msg.direction_valid
                or abs(magnitude - msg.magnitude) > 0.03 * msg.magnitude + 0.03
                or (valid and abs(math.remainder(azimuth - msg.azimuth, 2 * math.pi)) > 0.05)):
            return False
    return True


def test_a_direction_node_checks_the_skin_its_frames_show_before_estimating_them(tmp_path):
    # Another grid and pitch than the estimator starts with: the first scans wait (counted)
    # while the executor checks the calibration and builds the estimator for 4 mm taxels.
    other = scene_from_dict({
        'name': 'small', 'model': {'rows': 10, 'cols': 12, 'pitch_m': 0.004},
        'defaults': {'force_n': 8.0, 'radius_m': 0.003, 'alpha_deg': 0.0, 'beta_deg': 0.0,
                     'ramp_s': 0.1, 'duration_s': 1000.0},
        'presses': [{'time_s': 0.0, 'x_m': 0.026, 'y_m': 0.018}]}, name='small')
    with pipeline(tmp_path, other, rate_hz=200.0, driver={'pitch': 0.004}) as (
            _, _, direction, probe, executor):
        assert spin_until(executor, lambda: any(m.contacts for m in probe.contacts), WAIT_S)
        host = direction.host
        assert host.live.skin == (10, 12, 0.004)
        assert host.estimator.config.pitch_m == 0.004
        tally = host.tally()
        assert tally.before_skin_checked >= 1 and tally.refused == 0
        contact = next(m for m in reversed(probe.contacts) if m.contacts).contacts[0]
        assert (contact.location.x, contact.location.y) == pytest.approx((0.026, 0.018),
                                                                         abs=0.001)


def test_the_drift_state_sees_every_scan_across_changes_under_a_2_khz_fused_reader(
        tmp_path, owner_checked):
    # Each change is put in force by the reader between two scans, the drift state carried
    # then: the estimator in force at the end has tracked every scan estimated (no tare here,
    # which would start it afresh).
    with pipeline(tmp_path, SCENE, rate_hz=RATE_HZ, fused=True, loop=True) as (
            _, driver, direction, probe, executor):
        host = direction.host
        assert spin_until(executor, lambda: len(probe.contacts) > 50, WAIT_S)
        first = host.live.generation
        for values in PARAMETERS:
            direction.set_parameters_atomically(
                [Parameter(n, value=v) for n, v in values.items()])
            assert spin_until(executor, lambda: not host.rebuilding, WAIT_S)
            seen = len(probe.contacts)
            assert spin_until(executor, lambda: len(probe.contacts) > seen + 20, WAIT_S)
        driver.trigger_deactivate()  # the reader stops: what is in force is final
        tally = host.tally()
        in_force = host.in_force
    assert in_force.generation == first + len(PARAMETERS)
    assert tally.estimated > 200 and tally.refused == 0
    assert in_force.estimator.timed_scans == tally.estimated
