"""
A node's end at a known moment: what it made is destroyed by destroy_node, not by the collector.

Jazzy's Node.destroy_node leaves action servers alone, and LifecycleNode's leaves its state
machine; each keeps the node's rcl handle alive. Left to the garbage collector, they are destroyed
at any later moment, on whatever thread allocates, maybe after their context is shut down, and
rclpy's native destruction may then block holding the GIL (a test worker once hung 600 s in the
next node's constructor). The same holds for a node whose constructor refused a parameter.
"""

import functools

from rclpy.action import ActionServer
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from skin_driver.ros.wait_set import destroy_state_machine, node_made

__all__ = ['ActionOwner', 'destroy_actions', 'destroyed_if_refused', 'destroy_state_machine']


def destroy_actions(node) -> None:
    """
    Destroy every action server of the node (before Node.destroy_node).

    For a node whose constructor raised, where no owner exists to close them; a node built
    whole has each server closed by what made it.
    """
    for waitable in list(node.waitables):
        if isinstance(waitable, ActionServer):
            waitable.destroy()


def destroyed_if_refused(init):
    """Decorate a node's __init__: if it raises once rclpy's Node exists, destroy that first."""
    @functools.wraps(init)
    def wrapper(self, *args, **kwargs):
        try:
            init(self, *args, **kwargs)
        except BaseException:
            if node_made(self):
                destroy_actions(self)
                Node.destroy_node(self)
                destroy_state_machine(self)
            raise
    return wrapper


class ActionOwner:
    """What offers actions: it makes their servers (serve) and destroys them (close)."""

    _servers = ()

    def serve(self, node, action, name, execute, on_goal, on_cancel) -> None:
        """Offer an action whose goals run in a callback group of their own."""
        # A goal may wait for scans: in a group of its own it cannot hold up what it waits for,
        # which runs in the node's default group.
        server = ActionServer(node, action, name, execute_callback=execute,
                              goal_callback=on_goal, cancel_callback=on_cancel,
                              callback_group=MutuallyExclusiveCallbackGroup())
        self._servers = (*self._servers, server)

    def close(self) -> None:
        """Destroy the servers (with the node: its destroy_node leaves them)."""
        for server in self._servers:
            server.destroy()
        self._servers = ()
