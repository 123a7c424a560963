"""The core must run where no ROS is installed: it may not import rclpy or any message package."""

import ast
import pathlib
import subprocess
import sys

import pytest

CORE = pathlib.Path(__file__).resolve().parents[1] / 'skin_driver' / 'core'
# The ROS-free tools beside the core: the evaluator and the simulator run without ROS too.
ROS_FREE_TOOLS = ['skin_driver.evaluate', 'skin_driver.sim']
FORBIDDEN = ('rclpy', 'rosidl', 'builtin_interfaces', 'std_msgs', 'geometry_msgs', 'sensor_msgs',
             'skin_msgs', 'visualization_msgs', 'diagnostic_msgs', 'std_srvs', 'launch')


def _core_modules():
    return sorted(CORE.glob('*.py'))


def _imported_names(path):
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module


def test_core_has_modules():
    assert len(_core_modules()) >= 2


@pytest.mark.parametrize('path', _core_modules(), ids=lambda p: p.name)
def test_core_module_names_no_ros_import(path):
    bad = [name for name in _imported_names(path) if name.split('.')[0] in FORBIDDEN]
    assert bad == [], f'{path.name} imports {bad}'


def test_importing_the_core_loads_no_ros_module():
    modules = ['skin_driver.core.' + p.stem for p in _core_modules() if p.stem != '__init__']
    code = (
        'import importlib, sys\n'
        f'for m in {modules + ROS_FREE_TOOLS!r}:\n'
        '    importlib.import_module(m)\n'
        f'bad = sorted(m for m in sys.modules if m.split(".")[0] in {FORBIDDEN!r})\n'
        'print(",".join(bad))\n'
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ''
