"""
Start the pipeline for the demo, the soak, the benchmark and the tests, and stop all of it again.

Two ways, with the same parameters and the same wiring as a deployment:

* as processes (:func:`write_params`, :func:`start_nodes`, :func:`start_sim`), as a robot runs
  them: the demo, the soak and the benchmark. Each child gets a session of its own, so Ctrl-C in
  the terminal reaches only the parent, which then stops the children in order; on Linux a child
  also dies with its parent if the parent is killed outright, so nothing lingers.
* in one process (:func:`in_process`): the simulated board on a pty, the driver, the direction
  node (or the fused pair, wired by the driver's own :func:`~skin_driver.ros.driver_node.fuse`)
  and a probe on one private context: the tests.

The wait loops spin an executor until a condition holds (:func:`spin_until`) and say what they
gave up waiting for (:func:`wait_for`).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Callable, Iterable, List, Optional

import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
import yaml

PR_SET_PDEATHSIG = 1
DRIVER = 'skin_driver.ros.driver_node'
DIRECTION = 'skin_driver.ros.direction_node'
SIM = 'skin_driver.tools.sim'


# ---- child processes --------------------------------------------------------------------------

def _child_setup() -> None:
    # A parent started in the background (nohup, cron, `make bench &`) ignores Ctrl-C, and so
    # would its children, which then could only be killed: give them the default back, so that
    # stop() interrupts them as it says.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    if sys.platform.startswith('linux'):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def spawn(argv: List[str], log, profile_to: Optional[str] = None, prefix: Iterable[str] = (),
          **popen) -> subprocess.Popen:
    """Run `[prefix...] python argv...` (optionally under cProfile), output to log."""
    head = list(prefix) + [sys.executable]
    if profile_to:
        head += ['-m', 'cProfile', '-o', profile_to]
    popen.setdefault('stdout', log)
    popen.setdefault('stderr', subprocess.STDOUT)
    return subprocess.Popen(head + argv, start_new_session=True, preexec_fn=_child_setup,
                            **popen)


def stop(procs: Iterable[subprocess.Popen], timeout_s: float = 5.0) -> None:
    """Interrupt the processes (as Ctrl-C would), then kill what is left after timeout_s."""
    procs = list(procs)
    for proc in procs:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
    deadline = time.monotonic() + timeout_s
    for proc in procs:
        try:
            proc.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def grid_params(scene) -> dict:
    """
    Return the driver's rows, cols and pitch of a scene's skin, set rather than the board's word.

    The simulated board says them too, but a driver that connects after the board started may
    hold a second of scans until its next information frame; the tools count every scan.
    """
    model = scene.model
    return {'rows': model.rows, 'cols': model.cols, 'pitch': model.pitch_m}


def write_params(workdir: str, driver: dict = None, direction: dict = None,
                 name: str = 'params.yaml') -> str:
    """
    Write the parameter file of the driver and the direction node; return its path.

    The driver reads the board at ``workdir/skin0``, the direction node keeps its calibration in
    ``workdir/calibration.yaml``; ``driver`` and ``direction`` add to or replace those. The
    entries match the nodes in any namespace, and in either layout.
    """
    path = os.path.join(workdir, name)
    with open(path, 'w') as f:
        yaml.safe_dump({
            '/**/skin_driver': {'ros__parameters': {
                'port': os.path.join(workdir, 'skin0'), **(driver or {})}},
            '/**/skin_direction': {'ros__parameters': {
                'calibration_file': os.path.join(workdir, 'calibration.yaml'),
                **(direction or {})}}}, f)
    return path


def ros_args(namespace: str, params: str, log_level: str = 'warn') -> list:
    """Return the ROS arguments that put a node in namespace with the parameter file."""
    return ['--ros-args', '-r', f'__ns:={namespace}', '--log-level', log_level,
            '--params-file', params]


def start_nodes(fused: bool, args: list, log, profile_to: Optional[str] = None,
                prefix: Iterable[str] = ()) -> dict:
    """
    Start the nodes of one layout with the ROS arguments args; return {name: Popen}.

    Split: the driver and the direction node; fused: the driver alone, estimating on its reader
    thread. ``profile_to`` runs the direction node under cProfile, ``prefix`` every node under
    a command (chrt, for instance).
    """
    if fused:
        return {'driver': spawn(['-m', DRIVER] + args + ['-p', 'fused:=true'], log,
                                prefix=prefix)}
    return {'driver': spawn(['-m', DRIVER] + args, log, prefix=prefix),
            'direction': spawn(['-m', DIRECTION] + args, log, profile_to, prefix=prefix)}


class BoardProcess:
    """The simulated board as a child process, with what it says on stderr."""

    def __init__(self, process: subprocess.Popen):
        self.process = process
        self.lines = []
        self._reader = threading.Thread(target=lambda: self.lines.extend(process.stderr),
                                        daemon=True)
        self._reader.start()

    @property
    def epoch(self) -> Optional[float]:
        """Return the wall-clock instant of device time 0 (None until the board plays)."""
        found = [s for s in self.lines if s.startswith('SKIN_EPOCH')]
        return float(found[0].split()[1]) if found else None

    def stop(self, timeout_s: float = 10.0) -> tuple:
        """Stop the board; return (frames sent, frames dropped), or (None, None) if unsaid."""
        stop([self.process], timeout_s)
        self._reader.join(2.0)
        for s in self.lines:
            if 'stopped after' in s:
                words = s.split()
                return int(words[words.index('sent,') - 2]), int(words[-2])
        return None, None


def start_sim(executor, scene: str, port: str, rate_hz: float, log, loop: bool = False,
              prefix: Iterable[str] = (), timeout_s: float = 20.0,
              replay: bool = False, protocol: int = 2) -> BoardProcess:
    """
    Start the simulated board playing scene on a pty linked at port; spin executor until it plays.

    With loop and replay the board renders one pass of the scene first and replays it.
    protocol: the wire protocol version of its frames (2, or 1).

    Its epoch, the wall-clock instant of device time 0, turns a scan's device time into a host
    time.
    """
    board = BoardProcess(spawn(['-m', SIM, '--scene', scene, '--link', port, '--rate',
                                str(rate_hz)] + (['--loop'] if loop else [])
                               + (['--replay'] if replay else [])
                               + ['--protocol', str(protocol)], log,
                               prefix=prefix, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True))

    def started() -> bool:
        return board.epoch is not None or board.process.poll() is not None

    if not spin_until(executor, started, timeout_s, period_s=0.01) or board.epoch is None:
        board.stop()
        raise RuntimeError(f'the simulator did not start: {"".join(board.lines)}')
    return board


def write_scene(workdir: str, scene: dict, name: str = 'scene.yaml') -> str:
    """Write a scene mapping for the simulator; return its path."""
    path = os.path.join(workdir, name)
    with open(path, 'w') as f:
        yaml.safe_dump(scene, f)
    return path


# The environment variable rcl reads at init for how far a context discovers others.
DISCOVERY_RANGE = 'ROS_AUTOMATIC_DISCOVERY_RANGE'


# ---- spinning and waiting ----------------------------------------------------------------------

@contextlib.contextmanager
def ros_session(context=None, alone: bool = False):
    """
    Yield a SingleThreadedExecutor on an initialised rclpy context; shut both down after.

    alone: the context discovers no other (ROS_AUTOMATIC_DISCOVERY_RANGE=OFF, read at init);
    its own nodes still talk to each other.
    """
    if alone:
        before = os.environ.get(DISCOVERY_RANGE)
        os.environ[DISCOVERY_RANGE] = 'OFF'
        try:
            rclpy.init(context=context)
        finally:
            if before is None:
                del os.environ[DISCOVERY_RANGE]
            else:
                os.environ[DISCOVERY_RANGE] = before
    else:
        rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    try:
        yield executor
    finally:
        executor.shutdown()
        # The context may be down already, as Ctrl-C leaves it.
        rclpy.try_shutdown(context=context)


def spin_until(executor, condition: Callable[[], bool], timeout_s: float = 10.0,
               period_s: float = 0.05) -> bool:
    """Spin the executor until condition() is true or the timeout passes; return condition()."""
    deadline = time.monotonic() + timeout_s
    while not condition() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=period_s)
    return condition()


def spin_for(executor, seconds: float, period_s: float = 0.005) -> None:
    """Spin the executor for seconds."""
    spin_until(executor, lambda: False, seconds, period_s)


def wait_for(executor, condition: Callable[[], bool], timeout_s: float, what: str,
             procs: Iterable[subprocess.Popen] = ()) -> None:
    """Spin until condition() holds; raise RuntimeError naming what when a process dies first."""
    procs = list(procs)

    def done() -> bool:
        return condition() or any(p.poll() is not None for p in procs)

    if not spin_until(executor, done, timeout_s) or not condition():
        raise RuntimeError(f'gave up waiting for {what} after {timeout_s:.0f} s')


# How long a service or action server may take to be discovered: only a bound on a hung test,
# as waiting longer costs nothing when it is up.
READY_S = 60.0


def wait_for_server(executor, client, ready_s: float = READY_S) -> None:
    """
    Spin until a service or action client sees its server; raise RuntimeError naming it if not.

    The executor spins meanwhile, so that the nodes on it (an in-process server among them) go
    on working; rclpy's own wait_for_service and wait_for_server spin nothing.
    """
    if isinstance(client, ActionClient):
        name, ready, nodes = client._action_name, client.server_is_ready, [client._node]
    else:
        name, ready, nodes = client.srv_name, client.service_is_ready, executor.get_nodes()
    if spin_until(executor, ready, ready_s, period_s=0.01):
        return
    seen = 'no node to ask'
    if nodes:
        # The servers the graph knows under that name tell an absent server from one half
        # discovered (or half gone): an action's three services should have one each.
        node, prefix = nodes[0], nodes[0].resolve_service_name(name)
        seen = {n: node.count_services(n) for n, _ in sorted(node.get_service_names_and_types())
                if n == prefix or n.startswith(prefix + '/')} or 'none'
    raise RuntimeError(f'{name} did not come up in {ready_s:.0f} s; servers per service in the '
                       f'graph: {seen}')


def call_service(executor, client, request, timeout_s: float, ready_s: float = READY_S):
    """Call a service and spin until it answers; raise RuntimeError when it does not."""
    wait_for_server(executor, client, ready_s)
    future = client.call_async(request)
    if not spin_until(executor, future.done, timeout_s):
        raise RuntimeError(f'service {client.srv_name} did not answer in {timeout_s:.0f} s')
    return future.result()


def send_goal(executor, client, goal, timeout_s: float, feedback=None,
              ready_s: float = READY_S, on_accepted: Optional[Callable[[], None]] = None):
    """
    Send an action goal and spin until it ends: (status, result), or (None, None) if rejected.

    ``feedback`` receives each feedback message; ``on_accepted`` is called once the goal is
    accepted (a test starts its board there, so that the presses come while the goal waits).
    Raises RuntimeError when the server does not come up, answer or end in time.
    """
    what = type(goal).__name__.split('_')[0]
    wait_for_server(executor, client, ready_s)
    sent = client.send_goal_async(
        goal, feedback_callback=(lambda msg: feedback(msg.feedback)) if feedback else None)
    if not spin_until(executor, sent.done, ready_s):
        raise RuntimeError(f'action {what} did not answer the goal in {ready_s:.0f} s')
    if not sent.result().accepted:
        return None, None
    if on_accepted is not None:
        on_accepted()
    done = sent.result().get_result_async()
    if not spin_until(executor, done.done, timeout_s):
        raise RuntimeError(f'action {what} did not end in {timeout_s:.0f} s')
    return done.result().status, done.result().result


# ---- the whole pipeline in this process -------------------------------------------------------

def overrides(values: dict) -> list:
    """Turn a dict into parameter overrides."""
    return [Parameter(name, value=value) for name, value in values.items()]


@contextlib.contextmanager
def in_process(workdir: str, scene, rate_hz: float = 200.0, driver: dict = None,
               direction: dict = None, loop: bool = False, fused: bool = False,
               noise_seed: int = 1, identity='sim', play: bool = True, protocol: int = 2):
    """
    Yield (sim, driver node, direction node, probe, executor) on a fresh private context.

    The simulated board plays scene (a :class:`~skin_driver.core.sim.scene.Scene`) on a pty at
    ``workdir/skin0``; the driver is configured and activated. fused: the direction node takes
    its scans from the driver's reader thread, wired as the driver's own main wires it, instead
    of from the frame topic. identity: what the board says it is (SimulatedSkin's); protocol: the
    version of its frames. play=False leaves starting the board (``sim.start()``) to the caller,
    for a scene that must play only once something else is under way; the driver finds the port
    when it appears. Everything is stopped and destroyed afterwards.
    """
    from skin_driver.core.sim.board import SimulatedSkin
    from skin_driver.ros.direction_node import DirectionNode
    from skin_driver.ros.driver_node import fuse, SkinDriverNode
    from skin_driver.tools.probe import Probe

    link = os.path.join(workdir, 'skin0')
    sim = SimulatedSkin(scene, rate_hz=rate_hz, link_path=link, noise_seed=noise_seed, loop=loop,
                        identity=identity, protocol=protocol)
    driver_params = {'port': link, **grid_params(scene), **(driver or {})}
    direction_params = {'calibration_file': os.path.join(workdir, 'calibration.yaml'),
                        **(direction or {})}
    context = rclpy.Context()
    # Every node of the pipeline is on this context: it needs no discovery, and sees no
    # same-named server of another run that shares the domain on this machine.
    with ros_session(context, alone=True) as executor:
        driver_node = SkinDriverNode(context=context, parameter_overrides=overrides(driver_params))
        direction_kwargs = {'context': context,
                            'parameter_overrides': overrides(direction_params)}
        direction_node = (fuse(driver_node, **direction_kwargs) if fused
                          else DirectionNode(**direction_kwargs))
        probe_node = rclpy.create_node('probe', context=context)
        probe = Probe(probe_node, keep_messages=True, frames=True)
        nodes = (direction_node, driver_node, probe_node)
        for node in nodes:
            executor.add_node(node)
        if play:
            sim.start()
        try:
            driver_node.trigger_configure()
            driver_node.trigger_activate()
            yield sim, driver_node, direction_node, probe, executor
        finally:
            driver_node.close()
            sim.stop()
            for node in nodes:
                node.destroy_node()
