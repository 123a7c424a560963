"""An executable that cannot start says why in one fatal line and exits with status 1."""

import os
import subprocess
import sys


def test_a_node_without_its_compiled_kernel_stops_in_one_fatal_line():
    out = subprocess.run([sys.executable, '-m', 'skin_driver.ros.direction_node'],
                         capture_output=True, text=True, timeout=60,
                         env={**os.environ, 'AMENT_PREFIX_PATH': os.devnull})
    assert out.returncode == 1
    assert 'Traceback' not in out.stderr
    (line,) = [s for s in out.stderr.splitlines() if '[FATAL]' in s]
    assert 'skin_kernel' in line and 'make setup' in line
