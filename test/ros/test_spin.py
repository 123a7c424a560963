"""How every executable runs: one fatal line when it cannot start; a frozen heap once up."""

import os
import subprocess
import sys


def test_a_node_without_its_compiled_kernel_stops_in_one_fatal_line():
    out = subprocess.run([sys.executable, '-m', 'skin_driver.ros.direction_node'],
                         capture_output=True, text=True, timeout=60,
                         env={**os.environ, 'SKIN_KERNEL_LIBRARY': '/nonexistent/lib.so'})
    assert out.returncode == 1
    assert 'Traceback' not in out.stderr
    (line,) = [s for s in out.stderr.splitlines() if '[FATAL]' in s]
    assert 'skin_kernel' in line and 'make setup' in line


# A node whose timer reports what the garbage collector holds frozen once spinning, then stops.
_FROZEN_WHILE_SPINNING = """
import gc, rclpy
from skin_driver.ros.spin import spin_nodes
rclpy.init()
node = rclpy.create_node('frozen_probe')
def report():
    print('frozen', gc.get_freeze_count(), flush=True)
    raise KeyboardInterrupt
node.create_timer(0.01, report)
spin_nodes([node])
"""


def test_what_is_alive_when_nodes_spin_is_out_of_the_collectors_reach():
    # A full collection over it would hold the GIL while no scan is read or published.
    out = subprocess.run([sys.executable, '-c', _FROZEN_WHILE_SPINNING], capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    (line,) = [s for s in out.stdout.splitlines() if s.startswith('frozen')]
    assert int(line.split()[1]) > 1000  # rclpy, numpy and the node at least
