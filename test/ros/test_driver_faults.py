"""
Device faults against the simulated skin: each is reported on /diagnostics and survived.

Whatever the board does, the driver keeps running, publishes only frames equal to the
simulator's ground truth, and says what happened at the level a maintainer expects.
"""

import time

from diagnostic_msgs.msg import DiagnosticStatus
import numpy as np
from pipeline import pipeline, scene
import pytest
from rosutil import spin_until
from skin_driver.ros.conversions import status_values

pytestmark = pytest.mark.ros

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR
# Generous: only bounds a hung test on a loaded machine.
WAIT_S = 15.0


def assert_published_frames_are_true(sim, probe):
    """Every published frame equals the frame the simulator rendered for its seq."""
    assert probe.frames
    for msg in probe.frames:
        truth = sim.truth(msg.sequence)
        assert truth is not None, f'frame {msg.sequence} was never sent'
        assert msg.device_time_us == truth.device_time_us
        assert (msg.rows, msg.cols) == truth.top.shape
        assert np.array_equal(np.asarray(msg.top).reshape(truth.top.shape), truth.top)
        assert np.array_equal(np.asarray(msg.bottom).reshape(truth.top.shape), truth.bottom)


def assert_in_order(probe):
    seqs = [m.sequence for m in probe.frames]
    assert seqs == sorted(set(seqs))


def more_frames(executor, probe, count):
    target = len(probe.frames) + count
    assert spin_until(executor, lambda: len(probe.frames) >= target, WAIT_S)


def link_is(probe, predicate):
    """Return whether the newest skin-link status exists and satisfies predicate(status)."""
    status = probe.link_status()
    return status is not None and predicate(status)


def warned_of_drops_since(probe, since):
    """Return whether a skin-link status received after since (monotonic) warned of drops."""
    return any(t > since and s.name.endswith('skin link') and s.level == WARN
               and 'dropped' in s.message for t, s in probe.statuses)


def test_unplug_is_an_error_and_replug_reconnects_at_the_first_open_after_it(tmp_path):
    # The driver's own defaults for the back-off: a retry at least every 0.5 s, and at once when
    # the port's path comes back (how soon, on a given machine, is the bench's to say).
    defaults = {'reconnect_min': 0.1, 'reconnect_max': 0.5}
    with pipeline(tmp_path, scene([]), driver=defaults) as (sim, driver, _, probe, executor):
        more_frames(executor, probe, 20)
        stats = driver.link.stats
        for _ in range(2):
            failed = stats.open_failures
            sim.unplug()
            assert spin_until(executor, lambda: link_is(probe, lambda s: s.level == ERROR), WAIT_S)
            assert 'disconnected' in probe.link_status().message
            # The back-off at its longest delay: 0.1, 0.2, 0.4, then 0.5 s between failed opens.
            assert spin_until(executor, lambda: stats.open_failures >= failed + 4, WAIT_S)
            connects, failed = stats.connects, stats.open_failures
            replugged = time.monotonic()
            sim.replug()
            more_frames(executor, probe, 20)
            # One more connect, and at most the one open that may have failed just before the
            # path came back: the wait for the path ends with it, not with the back-off.
            assert stats.connects == connects + 1
            assert stats.open_failures <= failed + 1
            # Reported before the next unplug: a report while unplugged would be the ERROR's.
            assert spin_until(executor, lambda: warned_of_drops_since(probe, replugged), WAIT_S)
        assert spin_until(executor, lambda: link_is(probe, lambda s: s.level == OK), WAIT_S)
        values = status_values(probe.link_status())
        assert int(values['disconnects']) == 2 and int(values['connects']) == 3, \
            driver.link.stats
        # The frames the board scanned while unplugged are counted as dropped.
        assert int(values['frames lost while disconnected']) > 0
        assert int(values['frames dropped']) >= int(values['frames lost while disconnected'])
        assert_published_frames_are_true(sim, probe)


def test_stall_is_reported_as_a_warning_and_the_stream_resumes(tmp_path):
    with pipeline(tmp_path, scene([])) as (sim, driver, _, probe, executor):
        more_frames(executor, probe, 20)
        sim.stall(1.5)
        assert spin_until(executor, lambda: link_is(probe, lambda s: 'stalled' in s.message),
                          WAIT_S)
        assert probe.link_status().level == WARN
        more_frames(executor, probe, 20)
        assert spin_until(executor, lambda: link_is(probe, lambda s: s.level == OK), WAIT_S)
        values = status_values(probe.link_status())
        # A stall loses nothing: the board carries on with the next sequence number.
        assert values['frames dropped'] == '0' and values['disconnects'] == '0'
        assert driver.link.decoder.stats.frames_missed == 0
        assert_in_order(probe)
        assert_published_frames_are_true(sim, probe)


def test_burst_is_published_whole_and_in_order(tmp_path):
    with pipeline(tmp_path, scene([]), rate_hz=200.0) as (sim, driver, _, probe, executor):
        more_frames(executor, probe, 20)
        sim.burst(0.25)
        more_frames(executor, probe, 40)
        # The probe's sensor-data queue (depth 5) may miss part of a clump; the driver's own
        # counts show that it published every frame.
        assert_in_order(probe)
        stats = driver.link.decoder.stats
        assert (stats.frames_missed, stats.crc_errors, stats.bytes_discarded) == (0, 0, 0)
        assert spin_until(executor, lambda: probe.saw_link_status(
            lambda s, v: int(v['largest burst [frames]']) >= 2), WAIT_S)
        assert driver.link.decoder.stats.frames_missed == 0
        assert_published_frames_are_true(sim, probe)


def test_line_noise_is_a_warning_and_costs_only_the_damaged_frames(tmp_path):
    # The press is held for the whole test, however late the nodes come up.
    with pipeline(tmp_path, scene([{'time_s': 0.1, 'duration_s': 1000.0}]),
                  rate_hz=200.0) as (sim, driver, _, probe, executor):
        more_frames(executor, probe, 20)
        sim.set_line_noise(0.3)
        more_frames(executor, probe, 100)
        sim.set_line_noise(0.0)
        more_frames(executor, probe, 30)
        assert spin_until(executor, lambda: probe.saw_link_status(
            lambda s, v: s.level == WARN and 'corrupt frames rejected' in s.message), WAIT_S)
        stats = driver.link.decoder.stats
        assert sim.frames_damaged > 10 and stats.crc_errors > 0
        # Junk between frames costs nothing; each damaged frame costs itself and no other. On a
        # loaded machine the simulator may itself fall half a second behind and skip frames it
        # never sends (frames_dropped): those are gaps too, but not the driver's.
        assert stats.frames_missed == sim.frames_damaged + sim.frames_dropped
        assert_published_frames_are_true(sim, probe)
        assert any(max(m.top) > 1000 for m in probe.frames)


def test_sequence_gap_is_counted_as_dropped_frames(tmp_path):
    with pipeline(tmp_path, scene([])) as (sim, driver, _, probe, executor):
        more_frames(executor, probe, 20)
        sim.skip_sequence(7)
        more_frames(executor, probe, 20)
        sim.skip_sequence(1000)
        more_frames(executor, probe, 20)
        # On a loaded machine the simulator may itself fall behind and skip frames it never
        # sends (frames_dropped): those are dropped frames too, each run of them one more gap.
        assert spin_until(executor, lambda: probe.saw_link_status(
            lambda s, v: int(v['frames dropped']) == 1007 + sim.frames_dropped
            and 2 <= int(v['sequence gaps']) <= 2 + sim.frames_dropped), WAIT_S)
        assert probe.saw_link_status(
            lambda s, v: s.level == WARN and 'frames dropped' in s.message)
        assert_published_frames_are_true(sim, probe)


def test_wrong_grid_size_is_an_error_naming_the_received_shape(tmp_path):
    with pipeline(tmp_path, scene([])) as (sim, driver, _, probe, executor):
        more_frames(executor, probe, 20)
        sim.set_wire_shape((8, 12))
        assert spin_until(executor, lambda: link_is(probe, lambda s: s.level == ERROR), WAIT_S)
        status = probe.link_status()
        assert 'wrong grid size 8x12' in status.message and 'expected 16x16' in status.message
        assert status_values(status)['last rejected shape'] == '8x12'
        before = len(probe.frames)
        spin_until(executor, lambda: False, 0.5)
        assert all((m.rows, m.cols) == (16, 16) for m in probe.frames)
        sim.set_wire_shape(None)
        more_frames(executor, probe, 20)
        assert len(probe.frames) > before
        assert spin_until(executor, lambda: link_is(probe, lambda s: s.level == OK), WAIT_S)
        assert_published_frames_are_true(sim, probe)


def test_all_faults_in_a_row_never_stop_the_driver(tmp_path):
    with pipeline(tmp_path, scene([{'time_s': 0.2, 'alpha_deg': 30.0}]),
                  rate_hz=300.0) as (sim, driver, _, probe, executor):
        more_frames(executor, probe, 20)
        for fault in (lambda: sim.set_line_noise(0.5), sim.unplug, sim.replug,
                      lambda: sim.set_line_noise(0.0), lambda: sim.stall(0.5),
                      lambda: sim.burst(0.1), lambda: sim.skip_sequence(3),
                      lambda: sim.set_wire_shape((4, 4)), lambda: sim.set_wire_shape(None)):
            fault()
            spin_until(executor, lambda: False, 0.3)
            assert driver.link.running
        more_frames(executor, probe, 30)
        assert driver.link.stats.callback_errors == 0
        assert_published_frames_are_true(sim, probe)
