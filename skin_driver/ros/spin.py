"""Run nodes until shutdown, the one way every executable of this package does."""

import gc

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from skin_driver.core.estimation.scan.kernel import KernelMissing
from skin_driver.ros.params import ParameterError


def create_or_exit(create, name: str):
    """
    Return ``create()`` (the nodes of an executable, after rclpy.init).

    A parameter it refuses stops the process with status 1 and one fatal line, logged by the
    node that refused it with its namespace ([left.skin_direction]), else by ``name``; so does
    a compiled kernel that is not built (one line naming the fix).
    """
    try:
        return create()
    except ParameterError as err:
        err.log_fatal(name)
    except KernelMissing as err:
        rclpy.logging.get_logger(name).fatal(str(err))
    rclpy.try_shutdown()
    raise SystemExit(1)


def freeze_heap() -> None:
    """
    Put every object alive now out of the garbage collector's reach (gc.freeze).

    What a process holds once its nodes are up (modules, nodes, estimator, reused messages)
    lives as long as the process. A full collection walks all of it while holding the GIL, a
    pause in which no thread reads, estimates or publishes a scan, and a subscriber at the
    sensor-data depth loses what arrives meanwhile. Frozen, a collection walks only what came
    later.
    """
    gc.collect()
    gc.freeze()


def spin_nodes(nodes, before_spin=None) -> None:
    """
    Spin ``nodes`` on one executor until Ctrl-C or shutdown, then destroy them and shut down.

    ``before_spin()`` runs once the nodes are on the executor (a lifecycle node's autostart);
    then what is alive is frozen (:func:`freeze_heap`).
    A node with a ``close()`` method has it called before it is destroyed.
    """
    executor = SingleThreadedExecutor()
    for node in nodes:
        executor.add_node(node)
    try:
        if before_spin is not None:
            before_spin()
        freeze_heap()
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:  # noqa: B902 - judged by the context, re-raised unless shutting down
        # Ctrl-C shuts the context down under a callback already running: its publish fails,
        # and that is the shutdown, not a crash.
        if nodes[0].context.ok():
            raise
    finally:
        for node in nodes:
            if hasattr(node, 'close'):
                node.close()
            node.destroy_node()
        rclpy.try_shutdown()
