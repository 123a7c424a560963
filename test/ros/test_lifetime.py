"""
A node's end: destroy_node (or a refused start) destroys what the node made at once.

Nothing is left for the garbage collector to destroy later, on whatever thread, after the
context may be gone (skin_driver.ros.lifetime). A context's own graph lists its nodes without
discovery, so the probe sees a node go the moment its rcl handle is destroyed.
"""

import contextlib
import gc

from pipeline import overrides
import pytest
from rclpy.node import Node
from rosutil import ros_context
from skin_driver.ros.direction_node import DirectionNode
from skin_driver.ros.driver_node import SkinDriverNode
from skin_driver.ros.params import ParameterError

pytestmark = pytest.mark.ros

NODES = {'skin_driver': SkinDriverNode, 'skin_direction': DirectionNode}


@contextlib.contextmanager
def collector_off():
    """Keep the garbage collector from destroying anything while the block runs."""
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


@pytest.mark.parametrize('name', sorted(NODES))
def test_destroy_node_leaves_nothing_to_the_garbage_collector(name):
    with ros_context() as (context, _), collector_off():
        probe = Node('probe', context=context)
        node = NODES[name](context=context)
        assert sorted(probe.get_node_names()) == sorted(['probe', name])
        node.destroy_node()
        # The node's action servers (direction) and state machine (driver) went with it.
        assert probe.get_node_names() == ['probe']
        probe.destroy_node()


@pytest.mark.parametrize('name', sorted(NODES))
def test_a_refused_start_leaves_nothing_to_the_garbage_collector(name):
    with ros_context() as (context, _), collector_off():
        probe = Node('probe', context=context)
        with pytest.raises(ParameterError, match="'tare.frames' = 0 is out of range"
                           if name == 'skin_direction' else "'rows' = 300 is out of range"):
            NODES[name](context=context, parameter_overrides=overrides(
                {'tare.frames': 0} if name == 'skin_direction' else {'rows': 300}))
        assert probe.get_node_names() == ['probe']
        probe.destroy_node()
