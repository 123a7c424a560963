"""A whole pipeline in one test process: simulated skin on a pty, driver, direction node, probe."""

import contextlib

import rclpy
from rclpy.parameter import Parameter
from rosutil import ros_context, spin_until
from skin_driver.core.sim.board import SimulatedSkin
from skin_driver.core.sim.scene import scene_from_dict
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.tools.probe import Probe


def scene(presses, rows=16, cols=16, **model):
    """Return a one-shot scene of the given presses on the seed's 16 x 16, 5 mm skin."""
    # A scene needs a press; one far in the future leaves the skin idle for the whole test.
    presses = presses or [{'time_s': 1000.0}]
    return scene_from_dict({
        'name': 'test', 'model': dict(rows=rows, cols=cols, pitch_m=0.005, **model),
        'defaults': {'x_m': 0.0375, 'y_m': 0.0375, 'force_n': 10.0, 'radius_m': 0.004,
                     'ramp_s': 0.3, 'duration_s': 1.0, 'alpha_deg': 0.0, 'beta_deg': 0.0},
        'presses': presses}, name='test')


def overrides(values):
    """Turn a dict into parameter overrides."""
    return [Parameter(name, value=value) for name, value in values.items()]


@contextlib.contextmanager
def pipeline(tmp_path, the_scene, rate_hz=200.0, driver=None, direction=None, loop=False,
             fused=False):
    """
    Yield (sim, driver node, direction node, probe, executor) wired on a fresh context.

    fused: the direction node takes its scans from the driver's reader thread, as in the
    driver's fused mode, instead of from the frame topic.
    """
    link = str(tmp_path / 'skin0')
    sim = SimulatedSkin(the_scene, rate_hz=rate_hz, link_path=link, seed=1, loop=loop)
    driver_params = {'port': link, 'rows': the_scene.model.rows, 'cols': the_scene.model.cols,
                     'reconnect_min': 0.05, 'reconnect_max': 0.2, 'stall_timeout': 0.3,
                     'diagnostics_period': 0.2, **(driver or {})}
    direction_params = {'calibration_file': str(tmp_path / 'calibration.yaml'),
                        'diagnostics_period': 0.2, **(direction or {})}
    with ros_context() as (context, executor):
        direction_node = DirectionNode(subscribe=not fused, context=context,
                                       parameter_overrides=overrides(direction_params))
        driver_node = SkinDriverNode(context=context, parameter_overrides=overrides(driver_params))
        if fused:
            driver_node.estimation = direction_node.host
        probe_node = rclpy.create_node('probe', context=context)
        probe = Probe(probe_node, keep_messages=True, frames=True)
        for node in (direction_node, driver_node, probe_node):
            executor.add_node(node)
        sim.start()
        try:
            driver_node.trigger_configure()
            driver_node.trigger_activate()
            yield sim, driver_node, direction_node, probe, executor
        finally:
            driver_node.close()
            sim.stop()
            for node in (direction_node, driver_node, probe_node):
                node.destroy_node()


def call(executor, node, srv_type, name, request, timeout_s=20.0):
    """Call a service from a helper client and spin until it answers."""
    client = node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=5.0), f'{name} is not offered'
    future = client.call_async(request)
    assert spin_until(executor, future.done, timeout_s), f'{name} did not answer'
    node.destroy_client(client)
    return future.result()
