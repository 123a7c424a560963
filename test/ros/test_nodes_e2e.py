"""End to end: simulated skin on a pty -> driver -> direction node -> subscriber."""

import math
import os

from diagnostic_msgs.msg import DiagnosticStatus
import numpy as np
from pipeline import call, overrides, pipeline, scene, send_goal
import pytest
import rclpy
from rclpy.lifecycle import TransitionCallbackReturn
from rosutil import ros_context, spin_until
from skin_driver.core.estimation.calibration import calibration as calib
from skin_driver.core.sim.board import SimulatedSkin
from skin_driver.ros import qos
from skin_driver.ros.conversions import status_values
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.ros.params import ParameterError
from skin_driver.tools.harness import spawn, stop
from skin_driver.tools.probe import Probe
from skin_msgs.action import Calibrate
from skin_msgs.msg import SkinInfo
from std_srvs.srv import Trigger
import yaml

pytestmark = pytest.mark.ros

OK, ERROR = DiagnosticStatus.OK, DiagnosticStatus.ERROR
NORMAL_PRESSES = [{'time_s': 0.3 + 1.2 * i} for i in range(5)]
# Both layouts: scans through the frame topic, or estimated on the driver's reader thread.
LAYOUTS = pytest.mark.parametrize('fused', [False, True], ids=['split', 'fused'])


def test_every_published_frame_equals_the_simulators_ground_truth(tmp_path):
    with pipeline(tmp_path, scene([{'time_s': 0.1, 'alpha_deg': 45.0, 'beta_deg': 30.0}]),
                  rate_hz=250.0) as (sim, driver, _, probe, executor):
        assert spin_until(executor, lambda: len(probe.frames) >= 150)
        checked = 0
        for msg in probe.frames:
            truth = sim.truth(msg.sequence)
            assert truth is not None
            assert msg.device_time_us == truth.device_time_us
            assert msg.header.frame_id == 'skin_link'
            assert np.array_equal(np.asarray(msg.top).reshape(16, 16), truth.top)
            assert np.array_equal(np.asarray(msg.bottom).reshape(16, 16), truth.bottom)
            checked += 1
        assert checked >= 150
        # Some frames carry the press: the comparison is not only of empty maps.
        assert any(max(msg.top) > 1000 for msg in probe.frames)


def test_garbage_between_frames_costs_at_most_the_damaged_frame(tmp_path):
    junk = [b'\x00' * 7, b'\xa5\x5a\x01', b'\xa5' * 40, bytes(range(256)), b'\x5a\xa5\x5a']
    with pipeline(tmp_path, scene([]), rate_hz=250.0) as (sim, driver, _, probe, executor):
        assert spin_until(executor, lambda: len(probe.frames) >= 20)
        for data in junk:
            sim.inject_garbage(data)
            start = len(probe.frames)
            assert spin_until(executor, lambda: len(probe.frames) >= start + 10)
        stats = driver.link.decoder.stats
        # Frames the simulator itself dropped (a loaded machine) are not the garbage's doing.
        assert stats.frames_missed - sim.frames_dropped <= len(junk)
        assert stats.bytes_discarded > 0


def test_unplug_and_replug_is_survived_and_reported(tmp_path):
    with pipeline(tmp_path, scene([]), rate_hz=200.0) as (sim, driver, _, probe, executor):
        assert spin_until(executor, lambda: len(probe.frames) >= 20)
        sim.unplug()
        assert spin_until(executor, lambda: (probe.link_status() is not None
                                             and probe.link_status().level == ERROR))
        lost = probe.link_status()
        assert 'disconnected' in lost.message or 'lost' in lost.message
        before = len(probe.frames)
        sim.replug()
        assert spin_until(executor, lambda: len(probe.frames) >= before + 20)
        assert spin_until(executor, lambda: probe.link_status().level == OK)
        values = status_values(probe.link_status())
        assert int(values['disconnects']) >= 1 and int(values['connects']) >= 2


@LAYOUTS
def test_contacts_match_the_simulated_presses(tmp_path, fused):
    # Held for the whole test: on a busy machine the nodes may come up after a short press.
    presses = [{'time_s': 0.1, 'alpha_deg': 45.0, 'beta_deg': 90.0, 'duration_s': 1000.0,
                'x_m': 0.03, 'y_m': 0.045}]
    with pipeline(tmp_path, scene(presses), fused=fused) as (sim, _, __, probe, executor):
        def held():
            return sum(1 for m in probe.contacts if m.contacts
                       and m.contacts[0].magnitude > 4.0) >= 40
        assert spin_until(executor, held)
    strong = [m.contacts[0] for m in probe.contacts
              if m.contacts and m.contacts[0].magnitude > 4.0]
    assert all(m.header.frame_id == 'skin_link' for m in probe.contacts)
    xs = np.array([c.location.x for c in strong])
    ys = np.array([c.location.y for c in strong])
    assert abs(np.median(xs) - 0.03) < 0.0025 and abs(np.median(ys) - 0.045) < 0.0025
    valid = [c for c in strong if c.direction_valid]
    assert len(valid) >= 0.9 * len(strong)
    errors = [abs(math.remainder(c.azimuth - math.pi / 2, 2 * math.pi)) for c in valid]
    assert np.degrees(np.mean(errors)) < 5.0
    for c in strong:
        assert c.wrench.force.z < 0 and all(math.isfinite(v) for v in (c.azimuth, c.polar))
    # Each contacts message names its scan: the same sequence, device time and stamp as the frame.
    frames = {f.sequence: f for f in probe.frames}
    named = [m for m in probe.contacts if m.sequence in frames]
    assert len(named) >= 0.5 * len(probe.contacts)
    for m in named:
        frame = frames[m.sequence]
        assert m.device_time_us == frame.device_time_us and m.header.stamp == frame.header.stamp
        assert sim.truth(m.sequence).device_time_us == m.device_time_us


@LAYOUTS
def test_calibrate_records_normal_presses_and_the_file_is_loaded_at_start_up(tmp_path, fused):
    offset = (0.001, -0.0005)
    the_scene = scene(NORMAL_PRESSES, misalignment_m=list(offset))
    # The presses play once the goal waits for them, however long the start took.
    with pipeline(tmp_path, the_scene, fused=fused, play=False) as (
            sim, _, direction, probe, executor):
        result = send_goal(executor, direction, Calibrate, '/skin_direction/calibrate',
                           Calibrate.Goal(presses=3, timeout=8.0), on_accepted=sim.start)[1]
        assert result.success, result.message
        assert result.presses_used == 3
        assert result.x_p == pytest.approx(offset[0], abs=0.0004)
        assert result.y_p == pytest.approx(offset[1], abs=0.0004)
    path = tmp_path / 'calibration.yaml'
    assert path.exists()
    saved = calib.Calibration.load_yaml(str(path))
    assert (saved.x_p_m, saved.y_p_m) == (result.x_p, result.y_p)
    with ros_context() as (context, _):
        node = DirectionNode(context=context, parameter_overrides=overrides(
            {'calibration_file': str(path)}))
        assert node.host.estimator.calibration.x_p_m == result.x_p
        node.destroy_node()


def test_calibrate_times_out_without_presses_and_keeps_the_previous_calibration(tmp_path):
    previous = calib.Calibration(x_p_m=0.0002, y_p_m=0.0001, std_x_m=1e-5, std_y_m=1e-5,
                                 presses=4)
    previous.save_yaml(str(tmp_path / 'calibration.yaml'))
    with pipeline(tmp_path, scene([])) as (sim, _, direction, probe, executor):
        result = send_goal(executor, direction, Calibrate, '/skin_direction/calibrate',
                           Calibrate.Goal(presses=2, timeout=0.5))[1]
        assert not result.success
        assert 'timed out' in result.message and 'previous calibration' in result.message
        assert (result.x_p, result.y_p) == (0.0002, 0.0001)
        assert direction.host.estimator.calibration == previous
    assert calib.Calibration.load_yaml(str(tmp_path / 'calibration.yaml')) == previous


def test_calibrate_ignores_tilted_presses(tmp_path):
    tilted = [{'time_s': 0.2 + 1.2 * i, 'alpha_deg': 45.0, 'beta_deg': 0.0} for i in range(3)]
    with pipeline(tmp_path, scene(tilted), play=False) as (sim, _, direction, probe, executor):
        result = send_goal(executor, direction, Calibrate, '/skin_direction/calibrate',
                           Calibrate.Goal(presses=2, timeout=3.5), on_accepted=sim.start)[1]
    assert not result.success
    assert 'did not look normal' in result.message
    assert not (tmp_path / 'calibration.yaml').exists()


def test_calibrate_refuses_too_much_spread(tmp_path):
    # Normal presses at five spots a fraction of a taxel apart: their shifts differ by the
    # sampling of the imprints (tens of micrometres), far more than the 1 um accepted here.
    spots = [dict(p, x_m=0.03 + 0.0011 * i) for i, p in enumerate(NORMAL_PRESSES)]
    with pipeline(tmp_path, scene(spots), direction={'calibration.max_std': 1e-6},
                  play=False) as (sim, _, direction, __, executor):
        result = send_goal(executor, direction, Calibrate, '/skin_direction/calibrate',
                           Calibrate.Goal(presses=3, timeout=8.0), on_accepted=sim.start)[1]
    assert not result.success
    assert 'spread' in result.message and 'previous calibration' in result.message
    assert not (tmp_path / 'calibration.yaml').exists()


@LAYOUTS
def test_tare_refuses_while_loaded_and_records_an_unloaded_baseline(tmp_path, fused):
    presses = [{'time_s': 0.0, 'duration_s': 2.0, 'ramp_s': 0.05}]
    with pipeline(tmp_path, scene(presses), fused=fused, play=False) as (
            sim, _, direction, probe, executor):
        # The press starts once everything is up: the refusal must come while it is held.
        sim.start()
        assert spin_until(executor, lambda: sum(1 for m in probe.contacts if m.contacts) >= 25)
        loaded = call(executor, direction, Trigger, '/skin_direction/tare', Trigger.Request())
        assert not loaded.success and 'loaded' in loaded.message
        assert spin_until(executor, lambda: len(probe.contacts) > 30 and not any(
            m.contacts for m in probe.contacts[-25:]), 20.0)
        unloaded = call(executor, direction, Trigger, '/skin_direction/tare', Trigger.Request())
        assert unloaded.success, unloaded.message


def test_bad_parameters_stop_start_up_with_a_clear_message():
    with ros_context() as (context, _):
        with pytest.raises(ParameterError, match="'rows' = 300 is out of range"):
            SkinDriverNode(context=context, parameter_overrides=overrides({'rows': 300}))
        with pytest.raises(ParameterError, match="'method' is 'bogus'"):
            DirectionNode(context=context, parameter_overrides=overrides({'method': 'bogus'}))
        node = SkinDriverNode(context=context, parameter_overrides=overrides(
            {'reconnect_min': 5.0, 'reconnect_max': 1.0}))
        assert node.trigger_configure() == TransitionCallbackReturn.FAILURE
        node.destroy_node()


def test_driver_waits_for_a_missing_device_without_crashing(tmp_path):
    with ros_context() as (context, executor):
        node = SkinDriverNode(context=context, parameter_overrides=overrides(
            {'port': str(tmp_path / 'nothing'), 'reconnect_min': 0.05, 'reconnect_max': 0.1}))
        executor.add_node(node)
        node.trigger_configure()
        node.trigger_activate()
        assert spin_until(executor, lambda: node.link.stats.open_failures >= 3)
        assert node.link.state == 'connecting'
        node.close()
        node.destroy_node()
    assert not os.path.exists(tmp_path / 'nothing')


def test_fused_driver_process_offers_the_direction_nodes_topics_services_and_diagnostics(
        tmp_path):
    link = str(tmp_path / 'skin0')
    ns = f'/fused_{os.getpid()}'
    log = open(tmp_path / 'driver.log', 'w')
    given = tmp_path / 'mount.yaml'
    given.write_text(yaml.safe_dump({'/**/skin_driver': {'ros__parameters': {
        'parent_frame': 'left_forearm_link', 'mount_z': 0.05}}}))
    # Named as launch_ros names it: a rule for every node of the process.
    driver = spawn(['-m', 'skin_driver.ros.driver_node', '--ros-args', '-r', f'__ns:={ns}',
                    '-r', '__node:=skin_driver',
                    '-p', 'fused:=true', '-p', f'port:={link}', '-p', 'reconnect_max:=0.1',
                    '-p', 'skin_direction:diagnostics_period:=0.2',
                    '-p', f'skin_direction:calibration_file:={tmp_path / "cal.yaml"}',
                    # The mount the launch gives the driver alone: its skin_direction publishes it.
                    '--params-file', str(given)], log)
    # Looped: a driver process that starts slowly on a loaded machine still sees the press.
    sim = SimulatedSkin(scene([{'time_s': 0.5, 'duration_s': 0.6, 'ramp_s': 0.1}]), rate_hz=200.0,
                        link_path=link, noise_seed=1, loop=True)
    try:
        with ros_context() as (context, executor):
            node = rclpy.create_node('probe', namespace=ns, context=context)
            executor.add_node(node)
            probe = Probe(node, keep_messages=True)
            described = []
            node.create_subscription(SkinInfo, 'skin_info', described.append, qos.latched())
            sim.start()
            assert spin_until(executor, lambda: sum(1 for m in probe.contacts if m.contacts) >= 20,
                              20.0), log_text(tmp_path)
            assert spin_until(executor, lambda: probe.latest('contact estimation') is not None,
                              20.0)
            status = probe.latest('contact estimation')
            assert status.name == f'{ns}/skin_direction: contact estimation'
            assert float(status_values(status)['frames']) > 0
            result = call(executor, node, Trigger, f'{ns}/skin_direction/tare', Trigger.Request())
            # Presses are on or just over: either answer proves the service runs in the driver.
            assert ('baseline recorded' in result.message or 'loaded' in result.message), \
                result.message
            sequences = [m.sequence for m in probe.contacts]
            assert sequences == sorted(sequences) and all(sim.truth(s) for s in sequences[-5:])
            assert spin_until(executor, lambda: described, 10.0)
            assert (described[-1].parent_frame, described[-1].mount_source) == (
                'left_forearm_link', 'parameters')
            assert described[-1].mount_pose.position.z == 0.05
            node.destroy_node()
    finally:
        sim.stop()
        # A loaded machine can take a while to wind the process down; it must still exit 0.
        stop([driver], 20.0)
        log.close()
    assert driver.returncode == 0, log_text(tmp_path)


def log_text(tmp_path):
    """Return the driver process's output, for a failure message."""
    return (tmp_path / 'driver.log').read_text()[-3000:]
