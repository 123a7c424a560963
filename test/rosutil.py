"""Helpers for tests that need a ROS graph: a private context, spinning until a condition holds."""

import contextlib
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor


@contextlib.contextmanager
def ros_context():
    """Yield (context, executor) on a fresh rclpy context, shut down afterwards."""
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    try:
        yield context, executor
    finally:
        executor.shutdown()
        # A test may have shut the context down itself, as Ctrl-C does.
        rclpy.try_shutdown(context=context)


def spin_until(executor, condition, timeout_s=10.0):
    """Spin the executor until condition() is true or the timeout passes; return condition()."""
    deadline = time.monotonic() + timeout_s
    while not condition() and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.05)
    return condition()
