"""Let tests import their shared helpers (rosutil, pipeline) and keep parallel workers apart."""

import os
import pathlib
import sys

from hypothesis import settings
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

# The same examples on every run and machine: a red CI run can be reproduced, never a fluke.
settings.register_profile('skin', derandomize=True, database=None, deadline=None)
settings.load_profile('skin')

# Under pytest-xdist every worker runs its own ROS graph: a DDS domain of its own keeps one
# worker's nodes from receiving another's frames. rclpy reads the variable at init, later.
_worker = os.environ.get('PYTEST_XDIST_WORKER', '')
if _worker.startswith('gw'):
    _base = int(os.environ.get('ROS_DOMAIN_ID', '0') or 0)
    _index = int(_worker[2:]) + 1
    _domain = _base + _index if _base + _index <= 101 else _base - _index
    os.environ['ROS_DOMAIN_ID'] = str(_domain)


@pytest.fixture
def owner_checked(monkeypatch):
    """Kernels made in the test refuse every thread but their owner; a refusal fails the test."""
    from skin_driver.core.estimation.scan import kernel
    monkeypatch.setenv(kernel.CHECK_VARIABLE, '1')
    before = len(kernel.breaches())
    yield
    assert kernel.breaches()[before:] == []
