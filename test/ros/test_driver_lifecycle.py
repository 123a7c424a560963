"""The driver across its lifecycle: refusals with reasons, diagnostics in every state, shutdown."""

import time

from diagnostic_msgs.msg import DiagnosticStatus
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState
from pipeline import pipeline, scene
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rosutil import spin_until
from skin_driver.core.protocol.link import DISCONNECTED
from skin_driver.ros import direction_node
from skin_driver.tools.harness import (call_service, ros_args, ros_session, spawn, stop,
                                       write_params)
from skin_msgs.msg import TactileContactArray

pytestmark = pytest.mark.ros

OK, WARN = DiagnosticStatus.OK, DiagnosticStatus.WARN
# Generous: only bounds a hung test on a loaded machine.
WAIT_S = 15.0


def _newest_link_status_after(executor, probe, predicate):
    probe.statuses.clear()
    return spin_until(executor, lambda: probe.link_status() is not None
                      and predicate(probe.link_status()), WAIT_S)


@pytest.mark.parametrize('name,value', [('port', '/dev/ttyACM7'), ('frame_id', 'left_palm'),
                                        ('publish_images', False), ('rows', 8)])
def test_configure_time_parameter_on_an_active_driver_is_refused_with_the_reason(
        tmp_path, name, value):
    with pipeline(tmp_path, scene([])) as (_, driver, _, _, _):
        before = driver.get_parameter(name).value
        (result,) = driver.set_parameters([Parameter(name, value=value)])
        assert not result.successful
        assert name in result.reason and 'active' in result.reason
        assert 'deactivate, cleanup' in result.reason
        assert driver.get_parameter(name).value == before
        # Once cleaned up, the same change is taken, and configure uses it.
        driver.trigger_deactivate()
        driver.trigger_cleanup()
        (result,) = driver.set_parameters([Parameter(name, value=value)])
        assert result.successful, result.reason


def test_a_driver_stopped_on_request_is_ok_and_keeps_reporting_its_state(tmp_path):
    with pipeline(tmp_path, scene([])) as (_, driver, _, probe, executor):
        assert _newest_link_status_after(executor, probe, lambda s: s.level == OK
                                         and s.message.startswith('connected'))
        driver.trigger_deactivate()
        assert _newest_link_status_after(executor, probe,
                                         lambda s: s.message.startswith('inactive'))
        assert probe.link_status().level == OK
        driver.trigger_cleanup()
        assert _newest_link_status_after(executor, probe,
                                         lambda s: s.message.startswith('unconfigured'))
        assert probe.link_status().level == OK
        # And back: configure and activate read again.
        driver.trigger_configure()
        driver.trigger_activate()
        assert _newest_link_status_after(executor, probe, lambda s: s.level == OK
                                         and s.message.startswith('connected'))


def test_a_stall_reaches_diagnostics_without_waiting_for_the_period(tmp_path):
    # A period longer than the test: only the change of state itself can report the stall.
    with pipeline(tmp_path, scene([]), driver={'diagnostics_period': 60.0,
                                               'stall_timeout': 0.3}) as (sim, _, _, probe,
                                                                          executor):
        assert spin_until(executor, lambda: len(probe.frames) >= 20, WAIT_S)
        sim.stall(3.0)
        assert spin_until(executor, lambda: probe.saw_link_status(
            lambda s, v: s.level == WARN and 'stalled' in s.message), WAIT_S)


def test_a_port_lost_while_shutting_down_is_not_reported_as_a_fault(tmp_path, capfd):
    with pipeline(tmp_path, scene([])) as (sim, driver, _, probe, executor):
        assert spin_until(executor, lambda: len(probe.frames) >= 20, WAIT_S)
        capfd.readouterr()
        # What Ctrl-C does: the context shuts down, and the simulated board goes away with it.
        rclpy.shutdown(context=driver.context)
        sim.unplug()
        # Nothing spins a shut-down context: wait on the link's own thread.
        deadline = time.monotonic() + WAIT_S
        while driver.link.state != DISCONNECTED and time.monotonic() < deadline:
            time.sleep(0.02)
        assert driver.link.state == DISCONNECTED
        driver.close()
        err = capfd.readouterr().err
        assert 'disconnected' not in err and 'Failed to publish' not in err, err


def _spin_into(shutdown_first):
    def spin(executor):
        node = executor.get_nodes()[0]
        publisher = node.create_publisher(TactileContactArray, 'contacts', 5)
        if shutdown_first:
            rclpy.shutdown(context=node.context)  # what Ctrl-C does under a running callback
            publisher.publish(TactileContactArray())
        raise RuntimeError('a callback failed while the node was running')
    return spin


def test_direction_node_ends_quietly_when_ctrl_c_lands_inside_a_callback(tmp_path, monkeypatch):
    monkeypatch.setattr(SingleThreadedExecutor, 'spin', _spin_into(shutdown_first=True))
    direction_node.main(args=['--ros-args', '-p', f'calibration_file:={tmp_path / "cal.yaml"}'])


def test_direction_node_still_fails_on_a_callback_error_while_running(tmp_path, monkeypatch):
    monkeypatch.setattr(SingleThreadedExecutor, 'spin', _spin_into(shutdown_first=False))
    with pytest.raises(RuntimeError, match='a callback failed'):
        direction_node.main(args=['--ros-args', '-p',
                                  f'calibration_file:={tmp_path / "cal.yaml"}'])


def test_the_shutdown_transition_ends_the_driver_process(tmp_path):
    """Issue #37: after the lifecycle shutdown the process stayed alive, unseen by launch."""
    params = write_params(str(tmp_path))
    log = open(tmp_path / 'driver.log', 'w')
    driver = spawn(['-m', 'skin_driver.ros.driver_node'] + ros_args('/life', params), log)
    try:
        with ros_session(rclpy.Context()) as executor:
            node = rclpy.create_node('lifecycle_client', context=executor.context)
            executor.add_node(node)
            client = node.create_client(ChangeState, '/life/skin_driver/change_state')
            answer = call_service(executor, client, ChangeState.Request(transition=Transition(
                id=Transition.TRANSITION_ACTIVE_SHUTDOWN)), timeout_s=20.0)
            assert answer.success
        assert driver.wait(timeout=20.0) == 0
    finally:
        stop([driver])
        log.close()
