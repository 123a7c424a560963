"""The harness that starts the pipeline for the demo, the soak, the benchmark and the tests."""

import os
import signal
import subprocess

import pytest
import rclpy
from rclpy.action import ActionClient
from skin_driver.tools import harness
from skin_msgs.action import CalibrateForce
from std_srvs.srv import Trigger
import yaml

pytestmark = pytest.mark.ros


@pytest.fixture
def executor():
    with harness.ros_session(rclpy.Context()) as ex:
        yield ex


def test_parameter_file_points_both_nodes_at_the_workdir_and_takes_overrides(tmp_path):
    path = harness.write_params(str(tmp_path), driver={'publish_images': False},
                                direction={'method': 'centroid'})
    params = yaml.safe_load(open(path))
    driver = params['/**/skin_driver']['ros__parameters']
    direction = params['/**/skin_direction']['ros__parameters']
    assert driver == {'port': str(tmp_path / 'skin0'), 'publish_images': False}
    assert direction == {'calibration_file': str(tmp_path / 'calibration.yaml'),
                         'method': 'centroid'}
    args = harness.ros_args('/ns', path)
    assert args[args.index('--params-file') + 1] == path and '__ns:=/ns' in args


def test_the_simulated_board_plays_a_bundled_scene_and_counts_what_it_sent(tmp_path, executor):
    with open(tmp_path / 'sim.log', 'w') as log:
        board = harness.start_sim(executor, 'random', str(tmp_path / 'skin0'), 200.0, log,
                                  loop=True)
        assert board.epoch is not None and os.path.exists(tmp_path / 'skin0')
        harness.spin_for(executor, 0.3)
        sent, dropped = board.stop()
    assert board.process.returncode == 0
    # Nobody reads the pty: what the board could not write is counted, not lost silently.
    assert sent > 0 and dropped >= 0


def test_a_board_that_cannot_start_is_an_error_naming_the_cause(tmp_path, executor):
    with open(tmp_path / 'sim.log', 'w') as log, pytest.raises(RuntimeError) as err:
        harness.start_sim(executor, 'no_such_scene', str(tmp_path / 'skin0'), 100.0, log)
    assert 'did not start' in str(err.value) and 'no_such_scene' in str(err.value)


def test_waiting_stops_with_the_reason_when_a_process_dies(tmp_path, executor):
    with open(tmp_path / 'child.log', 'w') as log:
        child = harness.spawn(['-c', 'raise SystemExit(3)'], log)
        with pytest.raises(RuntimeError, match='the driver to come up'):
            harness.wait_for(executor, lambda: False, 60.0, 'the driver to come up', [child])
    assert child.wait() == 3


def test_waiting_returns_once_the_condition_holds(executor):
    looks = []
    # Raises when it gives up: returning is the success.
    harness.wait_for(executor, lambda: looks.append(1) or len(looks) >= 3, 60.0, 'three looks')
    assert len(looks) >= 3


def test_a_server_that_never_comes_up_is_an_error_naming_it_and_what_the_graph_shows(
        executor):
    node = rclpy.create_node('asker', context=executor.context)
    executor.add_node(node)
    client = ActionClient(node, CalibrateForce, '/nobody/calibrate_force')
    try:
        with pytest.raises(RuntimeError) as raised:
            harness.wait_for_server(executor, client, ready_s=1.0)
        # The client's own three services are in the graph, with no server.
        action = '/nobody/calibrate_force/_action/'
        servers = {f'{action}{name}': 0 for name in ('cancel_goal', 'get_result', 'send_goal')}
        assert str(raised.value) == ('/nobody/calibrate_force did not come up in 1 s; servers '
                                     f'per service in the graph: {servers}')
    finally:
        client.destroy()
        node.destroy_node()


def test_a_server_on_the_same_executor_is_waited_for_while_it_spins(executor):
    server_node = rclpy.create_node('server', context=executor.context)
    node = rclpy.create_node('asker', context=executor.context)
    server = server_node.create_service(Trigger, 'poke', lambda _, answer: answer)
    for n in (server_node, node):
        executor.add_node(n)
    client = node.create_client(Trigger, '/poke')
    try:
        assert harness.call_service(executor, client, Trigger.Request(), 30.0) is not None
    finally:
        server_node.destroy_service(server)
        for n in (server_node, node):
            n.destroy_node()


def test_stop_interrupts_then_kills_what_ignores_the_interrupt(tmp_path):
    ignore = ('import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); '
              'print("ready", flush=True); time.sleep(60)')
    with open(tmp_path / 'child.log', 'w') as log:
        polite = harness.spawn(['-c', 'import time; time.sleep(60)'], log)
        stubborn = harness.spawn(['-c', ignore], log, stdout=subprocess.PIPE, text=True)
        assert stubborn.stdout.readline() == 'ready\n'
        harness.stop([polite, stubborn], timeout_s=1.0)
    # The interrupt ends the one (KeyboardInterrupt), the kill the other.
    assert polite.returncode not in (0, -9)
    assert stubborn.returncode == -9


def test_a_background_parent_still_interrupts_its_children(tmp_path):
    # Started in the background (nohup, cron), a parent ignores SIGINT and its children would
    # inherit that: stop() could then only kill them (-9).
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with open(tmp_path / 'child.log', 'w') as log:
            child = harness.spawn(['-c', 'print("ready", flush=True); import time; '
                                   'time.sleep(60)'], log, stdout=subprocess.PIPE, text=True)
            assert child.stdout.readline() == 'ready\n'
            harness.stop([child], timeout_s=10.0)
    finally:
        signal.signal(signal.SIGINT, old)
    # An uncaught KeyboardInterrupt ends Python by SIGINT (not by the kill).
    assert child.returncode == -signal.SIGINT


def test_a_child_runs_in_a_session_of_its_own(tmp_path):
    with open(tmp_path / 'child.log', 'w') as log:
        child = harness.spawn(['-c', 'import os; print(os.getsid(0))'], log,
                              stdout=subprocess.PIPE, text=True)
        out, _ = child.communicate(timeout=30)
    # Ctrl-C in the terminal reaches the parent alone, which stops its children in order.
    assert int(out) == child.pid != os.getsid(0)
