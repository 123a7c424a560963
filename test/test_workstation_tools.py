"""The workspace scripts work where a ROS 2 workstation user runs them, not only after setup."""

import importlib.util
import os
import pathlib
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _clone_without_setup(tmp_path):
    """Return a copy of the repository's tools as a colcon workspace clone has them: no .venv."""
    clone = tmp_path / 'skin_driver'
    shutil.copytree(ROOT / 'tools', clone / 'tools')
    return clone


def test_with_env_runs_in_a_sourced_colcon_workspace_clone(tmp_path):
    # This test's own environment plays the sourced workspace: rclpy and skin_msgs import.
    clone = _clone_without_setup(tmp_path)
    done = subprocess.run(
        ['bash', str(clone / 'tools' / 'with-env.sh'), sys.executable, '-c',
         'import skin_msgs.msg; print("ran")'], capture_output=True, text=True, timeout=60)
    assert (done.returncode, done.stdout.strip()) == (0, 'ran'), done.stderr


def test_with_env_without_any_ros_environment_says_what_to_do(tmp_path):
    clone = _clone_without_setup(tmp_path)
    bare = {'PATH': '/usr/bin:/bin', 'HOME': str(tmp_path)}
    done = subprocess.run(['bash', str(clone / 'tools' / 'with-env.sh'), 'true'],
                          capture_output=True, text=True, env=bare, timeout=60)
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and 'make setup' in lines[0] and 'install/setup.bash' in lines[0]


@pytest.mark.skipif(importlib.util.find_spec('launch_testing') is None,
                    reason='launch_testing is not installed (no wheel exists); a ROS 2 Jazzy '
                           'install registers its pytest plugin, and there this test runs')
def test_pytest_collects_with_jazzys_launch_testing_plugin_installed():
    done = subprocess.run([sys.executable, '-m', 'pytest', '--collect-only', '-q', '-p',
                           'no:xdist', 'test/core/estimation/test_atomic.py'], cwd=ROOT,
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, 'PYTEST_ADDOPTS': ''})
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
