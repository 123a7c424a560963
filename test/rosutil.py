"""Helpers for tests that need a ROS graph: a private context, spinning until a condition holds."""

import contextlib

import rclpy
from skin_driver.tools.harness import (  # noqa: F401 - shared with tests
    ros_session, spin_until, wait_for_server)


@contextlib.contextmanager
def ros_context():
    """Yield (context, executor) on a fresh rclpy context, shut down afterwards."""
    context = rclpy.Context()
    with ros_session(context) as executor:
        yield context, executor
