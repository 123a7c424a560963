"""A whole pipeline in one test process, started by the tools' harness with fast timings."""

import contextlib

from rclpy.action import ActionClient
from skin_driver.core.sim.scene import scene_from_dict
from skin_driver.tools import harness
from skin_driver.tools.harness import overrides  # noqa: F401 - the tests' one import place

# Short timings, so that faults show within a test's patience.
FAST_DRIVER = {'reconnect_min': 0.05, 'reconnect_max': 0.2, 'stall_timeout': 0.3,
               'diagnostics_period': 0.2}
FAST_DIRECTION = {'diagnostics_period': 0.2}


def scene(presses, rows=16, cols=16, pitch_m=0.005, **model):
    """Return a one-shot scene of the given presses on the seed's 16 x 16, 5 mm skin."""
    # A scene needs a press; one far in the future leaves the skin idle for the whole test.
    presses = presses or [{'time_s': 1000.0}]
    return scene_from_dict({
        'name': 'test', 'model': dict(rows=rows, cols=cols, pitch_m=pitch_m, **model),
        'defaults': {'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 10.0, 'radius_m': 0.004,
                     'ramp_s': 0.3, 'duration_s': 1.0, 'alpha_deg': 0.0, 'beta_deg': 0.0},
        'presses': presses}, name='test')


@contextlib.contextmanager
def pipeline(tmp_path, the_scene, rate_hz=200.0, driver=None, direction=None, loop=False,
             fused=False, identity='sim', play=True, protocol=2):
    """Yield (sim, driver node, direction node, probe, executor): harness.in_process."""
    with harness.in_process(str(tmp_path), the_scene, rate_hz,
                            {**FAST_DRIVER, **(driver or {})},
                            {**FAST_DIRECTION, **(direction or {})}, loop, fused,
                            identity=identity, play=play, protocol=protocol) as started:
        yield started


def call(executor, node, srv_type, name, request, timeout_s=20.0):
    """Call a service from a helper client and spin until it answers."""
    client = node.create_client(srv_type, name)
    try:
        return harness.call_service(executor, client, request, timeout_s)
    finally:
        node.destroy_client(client)


def send_goal(executor, node, action_type, name, goal, timeout_s=20.0, feedback=None,
              on_accepted=None):
    """
    Send an action goal from a helper client: (status, result), (None, None) if rejected.

    on_accepted: called once the goal is accepted; ``sim.start`` with ``pipeline(play=False)``
    plays the scene's presses while the goal waits for them, however long the start took.
    """
    client = ActionClient(node, action_type, name)
    try:
        return harness.send_goal(executor, client, goal, timeout_s, feedback,
                                 on_accepted=on_accepted)
    finally:
        client.destroy()
