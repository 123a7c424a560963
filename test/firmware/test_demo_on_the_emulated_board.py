"""`make demo ARGS=--board qemu`: the demo's contacts come through the firmware's ARM code."""

import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.ros


def test_the_demo_on_the_emulated_board_prints_table_1(qemu_image):
    # qemu_image builds the image first (or skips, naming what is missing), so the demo's own
    # build is a no-op and its time goes to the scene.
    result = subprocess.run(
        [sys.executable, '-m', 'skin_lab.demo', '--board', 'qemu', '--plain',
         '--repeats', '1', '--pace', '0.6'],
        capture_output=True, text=True, timeout=300, env=dict(os.environ))
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    out = result.stdout
    assert 'calibrated (x_p' in out
    table = out[out.index('Table 1'):]
    for beta in ('0.0', '90.0', '180.0', '270.0'):
        assert f'\n{beta:>10}' in table
