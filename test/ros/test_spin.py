"""An executable that cannot start says why in one fatal line and exits with status 1."""

import os
import subprocess
import sys


def _without_kernel() -> dict:
    """Return this environment with skin_kernel taken out of the ament index."""
    kept = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
            if p and 'skin_kernel' not in p]
    return {**os.environ, 'AMENT_PREFIX_PATH': os.pathsep.join(kept) or os.devnull}


def test_a_node_without_its_compiled_kernel_stops_in_one_fatal_line():
    out = subprocess.run([sys.executable, '-m', 'skin_driver.ros.direction_node'],
                         capture_output=True, text=True, env=_without_kernel(), timeout=60)
    assert out.returncode == 1
    assert 'Traceback' not in out.stderr
    (line,) = [s for s in out.stderr.splitlines() if '[FATAL]' in s]
    assert 'skin_kernel' in line and 'make setup' in line
