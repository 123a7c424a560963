"""
The uses of rclpy's private API in skin_driver, in this module alone.

The wait set of rclpy's C extension, whether a node's rcl handle was made (:func:`node_made`),
and the end of a lifecycle node's state machine (:func:`destroy_state_machine`).

Jazzy's rclpy has no public wait set; its executors and ``rclpy.wait_for_message`` wait on this
one. :class:`skin_driver.ros.hot_path.TakenOnThread` waits on its subscriptions and a guard
condition alone: the public way to serve subscriptions on a thread of their own, an executor
spinning a node that holds only them, costs several times the CPU per message (docs/rclpy.md
gives the measurement, tools/take_cost.py makes it). On an rclpy without it, importing this
module raises ImportError saying what is missing.
"""

try:
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    WaitSet = _rclpy.WaitSet
    RCLError = _rclpy.RCLError
except (ImportError, AttributeError) as err:
    raise ImportError(
        "skin_driver needs the wait set of rclpy's C extension "
        '(rclpy.impl.implementation_singleton.rclpy_implementation.WaitSet and RCLError, as '
        f"in ROS 2 Jazzy's rclpy), which this rclpy does not have: {err}") from err

__all__ = ['WaitSet', 'RCLError', 'destroy_state_machine', 'node_made']


def destroy_state_machine(node) -> None:
    """
    Destroy a lifecycle node's state machine now (after Node.destroy_node).

    Jazzy's LifecycleNode.destroy_node leaves it, and with it the node's rcl handle, to the
    garbage collector (skin_driver.ros.lifetime says why that matters). A node without one, or
    an rclpy that names it otherwise, is left as it is.
    """
    machine = getattr(node, '_state_machine', None)
    if machine is not None:
        machine.destroy_when_not_in_use()


def node_made(node) -> bool:
    """
    Return whether rclpy's Node constructor made the node's rcl handle.

    A node whose own constructor raised may have stopped before or after rclpy's; only one made
    has anything to destroy (skin_driver.ros.lifetime).
    """
    return getattr(node, '_Node__node', None) is not None
